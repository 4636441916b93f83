//! `trussmesh image`: mesh the bright (or, with --invert, dark) region of a PNG picture.

use super::mesh::write_output;
use super::Failure;
use clap::Args;
use std::path::PathBuf;
use trussmesh::io::MeshData;
use trussmesh::mesher::image::{mesh_image, read_png_grey, ImageOptions};

/// Arguments of `trussmesh image`.
#[derive(Args, Debug)]
pub struct ImageArgs {
    /// The PNG picture.
    pub file: PathBuf,
    /// Grey level in [0, 1] separating inside (brighter) from outside.
    #[arg(long, default_value_t = 0.5)]
    pub threshold: f64,
    /// Inside is darker than the threshold.
    #[arg(long)]
    pub invert: bool,
    /// Smallest edge length in pixels.
    #[arg(long, default_value_t = 4.0)]
    pub h0: f64,
    /// Largest edge length over the smallest (the automatic size function grows to it).
    #[arg(long, default_value_t = 4.0)]
    pub max_ratio: f64,
    /// Output units per pixel (coordinates: origin at the top-left corner, x right, y down).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// Output files; the extension picks the format (.vtu .msh .mesh .json .obj .stl .ply .svg .png).
    #[arg(short = 'o', long = "output", required = true)]
    pub outputs: Vec<PathBuf>,
    /// No report on stdout.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `trussmesh image`.
pub fn run(a: ImageArgs) -> Result<(), Failure> {
    for p in &a.outputs {
        trussmesh::io::Format::from_path(p).map(|_| ()).or_else(|e| match p.extension().and_then(|x| x.to_str()) {
            Some("svg") | Some("png") => Ok(()),
            _ => Err(e),
        })?;
    }
    let (grey, w, h) = read_png_grey(&a.file).map_err(|e| Failure::bad(e.to_string()))?;
    let opts =
        ImageOptions { threshold: a.threshold, invert: a.invert, h0: a.h0, max_ratio: a.max_ratio, scale: a.scale };
    let out = mesh_image(&grey, w, h, &opts)?;
    let data = MeshData::from_trimesh2(&out.mesh);
    let title = a.file.display().to_string();
    for p in &a.outputs {
        write_output(p, &data, &title)?;
    }
    if !a.quiet {
        println!("{}", out.report);
        for p in &a.outputs {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}
