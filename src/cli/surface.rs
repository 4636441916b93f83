//! `trussmesh surface`: the closed surface phi(x, y, z) = 0, meshed in space (seed section 3.6.1).

use super::mesh::{check_output, constant, parse_expr, split_top, write_output};
use super::Failure;
use clap::Args;
use glam::DVec3;
use std::path::PathBuf;
use trussmesh::expr::ExprImplicit3;
use trussmesh::io::MeshData;
use trussmesh::surface::{mesh_implicit_surface, SurfaceOptions};

/// Mesh the closed surface phi(x, y, z) = 0 (phi < 0 inside).
#[derive(Args, Debug)]
pub struct SurfaceArgs {
    /// The surface phi(x, y, z) = 0, any smooth level-set function, negative inside.
    #[arg(long, value_name = "EXPR", allow_hyphen_values = true)]
    pub phi: String,
    /// A box containing the whole surface: the minimum corner, then the maximum corner.
    #[arg(long, value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true)]
    pub bbox: String,
    /// Target edge length (the smallest one with --curvature).
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub h0: String,
    /// Sizes from curvature: K elements per radian, h = 1/(K |kappa|) clamped to [h0, hmax].
    #[arg(long, value_name = "K")]
    pub curvature: Option<f64>,
    /// Gradient limit of the curvature sizes.
    #[arg(long, value_name = "G", default_value_t = 0.3)]
    pub gradient: f64,
    /// Largest size with --curvature (default 8 h0).
    #[arg(long, value_name = "H")]
    pub hmax: Option<f64>,
    /// Iteration cap of the force loop.
    #[arg(long, value_name = "N")]
    pub max_iter: Option<usize>,
    /// Output file; the extension picks the format (.json .vtu .msh .mesh .obj .stl .ply, or a
    /// shaded picture .svg .png).
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: Vec<PathBuf>,
    /// No report.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `trussmesh surface`.
pub fn run(args: SurfaceArgs) -> Result<(), Failure> {
    for p in &args.output {
        check_output(p)?;
    }
    let phi = ExprImplicit3::new(parse_expr("phi", &args.phi)?);
    let h0 = constant("h0", &args.h0)?;
    let corners: Vec<f64> = split_top(&args.bbox, ',').iter().map(|c| constant("bbox", c)).collect::<Result<_, _>>()?;
    if corners.len() != 6 {
        return Err(Failure::bad(format!("--bbox needs 6 numbers X0,Y0,Z0,X1,Y1,Z1, not {}", corners.len())));
    }
    let bbox = [DVec3::new(corners[0], corners[1], corners[2]), DVec3::new(corners[3], corners[4], corners[5])];
    let mut opts = SurfaceOptions::uniform(h0, bbox);
    if let Some(k) = args.curvature {
        opts = opts.with_curvature(k, args.gradient, args.hmax.unwrap_or(8.0 * h0));
    }
    if let Some(n) = args.max_iter {
        opts = opts.with_max_iterations(n);
    }
    let out = mesh_implicit_surface(&phi, &opts)?;
    let data = MeshData::from_trimesh3(&out.mesh);
    for p in &args.output {
        write_output(p, &data, &args.phi)?;
    }
    if !args.quiet {
        println!("{}", out.report);
        for p in &args.output {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}
