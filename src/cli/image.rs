//! `trussmesh image`: mesh the bright (or, with --invert, dark) region of a PNG picture.

use super::budget::{self, Budget};
use super::{output, Failure};
use clap::Args;
use std::path::PathBuf;
use trussmesh::io::MeshData;
use trussmesh::mesher::image::{decode_png_grey, mesh_image_checked, read_png_header, ImageOptions};

/// Arguments of `trussmesh image`.
#[derive(Args, Debug)]
pub struct ImageArgs {
    /// The PNG picture.
    pub file: PathBuf,
    /// Grey level in [0, 1] separating inside (brighter) from outside.
    #[arg(long, value_name = "T", default_value_t = 0.5)]
    pub threshold: f64,
    /// Inside is darker than the threshold.
    #[arg(long)]
    pub invert: bool,
    /// Smallest edge length in pixels.
    #[arg(long, value_name = "H", default_value_t = 4.0)]
    pub h0: f64,
    /// Largest edge length in pixels (the automatic size function grows to it; --h0 gives
    /// uniform elements) [default: 4 h0].
    #[arg(long, value_name = "H")]
    pub hmax: Option<f64>,
    /// The old spelling: the largest edge length over the smallest.
    #[arg(long, hide = true, conflicts_with = "hmax")]
    pub max_ratio: Option<f64>,
    /// Output units per pixel (coordinates: origin at the top-left corner, x right, y down).
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    pub scale: f64,
    /// Output files; the extension picks the format (.vtu .msh .mesh .json .obj .stl .ply .svg .png).
    #[arg(short = 'o', long = "output", value_name = "FILE", required = true)]
    pub outputs: Vec<PathBuf>,
    /// Memory budget (such as 2G or 500M; default a quarter of the machine's memory): a
    /// picture or a mesh whose estimate passes it is refused before the work.
    #[arg(long, value_name = "BYTES")]
    pub max_memory: Option<String>,
    /// No report on stdout.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `trussmesh image`.
pub fn run(a: ImageArgs) -> Result<(), Failure> {
    output::check_all(&a.outputs)?;
    let budget = Budget::new(a.max_memory.as_deref())?;
    let name = a.file.display().to_string();
    // The header's size is checked before the picture is read or decoded.
    let head = read_png_header(&a.file)?;
    let pixels = head.pixels() as f64;
    let pixel_bytes = budget::BASE_BYTES + pixels * budget::BYTES_PER_PIXEL;
    budget.check(
        &format!("the picture {name}, {} x {} pixels,", head.width, head.height),
        pixel_bytes,
        &format!("{} pixels at about {} bytes each", budget::count(pixels), budget::BYTES_PER_PIXEL),
        "use a smaller picture",
    )?;
    let bytes = std::fs::read(&a.file).map_err(|e| Failure::bad(format!("cannot read the picture {name}: {e}")))?;
    let (grey, w, h) = decode_png_grey(&bytes, &name)?;
    drop(bytes);
    let max_ratio = match (a.hmax, a.max_ratio) {
        (Some(h), _) => h / a.h0,
        (None, Some(r)) => r,
        (None, None) => 4.0,
    };
    if let Some(h) = a.hmax.filter(|&h| a.h0 > 0.0 && !(h >= a.h0 && h.is_finite())) {
        return Err(Failure::bad(format!(
            "--hmax {h} must be finite and at least --h0 {} (the largest edge cannot be smaller than the smallest)",
            a.h0
        )));
    }
    let opts = ImageOptions { threshold: a.threshold, invert: a.invert, h0: a.h0, max_ratio, scale: a.scale };
    let check = |triangles: f64| {
        budget
            .check(
                &format!("the mesh of {name}"),
                pixel_bytes + triangles * budget::BYTES_PER_TRIANGLE_2D,
                &format!(
                    "{} triangles at about {} bytes each, and the picture's {}",
                    budget::count(triangles),
                    budget::BYTES_PER_TRIANGLE_2D,
                    budget::human(pixel_bytes)
                ),
                "use a larger --h0",
            )
            .map_err(|f| trussmesh::Error::OverBudget(f.message))
    };
    let out = mesh_image_checked(&grey, w, h, &opts, &check)?;
    let data = MeshData::from_trimesh2(&out.mesh);
    output::write_all(&a.outputs, &data, &name)?;
    if !a.quiet {
        println!("{}", out.report);
        for p in &a.outputs {
            println!("wrote {}", output::describe(p));
        }
    }
    Ok(())
}
