//! `trussmesh surface`: the closed surface phi(x, y, z) = 0 (seed section 3.6.1), or rational
//! Bézier patches from a JSON file (section 3.6.2), meshed in space.

use super::mesh::{check_output, constant, parse_expr, split_top, write_output};
use super::Failure;
use clap::Args;
use glam::DVec3;
use std::path::PathBuf;
use std::sync::Arc;
use trussmesh::expr::{Expr, ExprImplicit3};
use trussmesh::io::{CellType, MeshData};
use trussmesh::surface::bezier::{mesh_patches, BezierOptions, BezierQuality, RationalBezierPatch};
use trussmesh::surface::{mesh_surface, SurfaceOptions};

/// Mesh the closed surface phi(x, y, z) = 0 (phi < 0 inside).
#[derive(Args, Debug)]
pub struct SurfaceArgs {
    /// The surface phi(x, y, z) = 0, any smooth level-set function, negative inside.
    #[arg(
        long,
        value_name = "EXPR",
        allow_hyphen_values = true,
        required_unless_present = "bezier",
        conflicts_with = "bezier"
    )]
    pub phi: Option<String>,
    /// Rational Bézier patches instead of phi: a JSON file {"patches": [{"degree": [m, n],
    /// "control": [[x, y, z], ...], "weights": [...], "trim": "EXPR in u, v"}]} (control points
    /// u fastest; the patch keeps trim <= 0).
    #[arg(long, value_name = "PATCHES.json")]
    pub bezier: Option<PathBuf>,
    /// A box containing the whole surface: the minimum corner, then the maximum corner.
    #[arg(long, value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true, required_unless_present = "bezier")]
    pub bbox: Option<String>,
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
    /// Iteration cap of each force loop (one per level of the coarse-to-fine start).
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
    let h0 = constant("h0", &args.h0)?;
    if let Some(path) = &args.bezier {
        return run_bezier(path, h0, &args);
    }
    let (Some(phi_src), Some(bbox_src)) = (&args.phi, &args.bbox) else {
        return Err(Failure::bad("--phi and --bbox are needed without --bezier"));
    };
    let phi = ExprImplicit3::new(parse_expr("phi", phi_src)?);
    let corners: Vec<f64> = split_top(bbox_src, ',').iter().map(|c| constant("bbox", c)).collect::<Result<_, _>>()?;
    if corners.len() != 6 {
        return Err(Failure::bad(format!("--bbox needs 6 numbers X0,Y0,Z0,X1,Y1,Z1, not {}", corners.len())));
    }
    let (lo, hi) = (DVec3::new(corners[0], corners[1], corners[2]), DVec3::new(corners[3], corners[4], corners[5]));
    let mut opts = SurfaceOptions::uniform(h0, lo, hi);
    if let Some(k) = args.curvature {
        opts = opts.with_curvature(k, args.gradient, args.hmax.unwrap_or(8.0 * h0));
    }
    if let Some(n) = args.max_iter {
        opts = opts.with_max_iter(n);
    }
    let out = super::mesh::with_progress_bar(args.quiet, "stages", |pb| {
        if let Some(pb) = pb {
            opts = opts.with_progress(super::mesh::progress_callback(pb));
        }
        mesh_surface(&phi, &opts)
    })?;
    let data = MeshData::from_trimesh3(&out.mesh);
    for p in &args.output {
        write_output(p, &data, phi_src)?;
    }
    if !args.quiet {
        println!("{}", out.report);
        for p in &args.output {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}

/// One patch as the JSON file gives it.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PatchJson {
    degree: [usize; 2],
    control: Vec<[f64; 3]>,
    weights: Vec<f64>,
    #[serde(default)]
    trim: Option<String>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PatchesJson {
    patches: Vec<PatchJson>,
}

/// The trim expression is written in u and v; the expression language knows x and y, so the
/// identifiers u and v are renamed (and x, y refused, to keep one meaning).
fn trim_expr(src: &str) -> Result<Expr, Failure> {
    let mut out = String::with_capacity(src.len());
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| -> Result<(), Failure> {
        match word.as_str() {
            "u" => out.push('x'),
            "v" => out.push('y'),
            "x" | "y" | "z" => return Err(Failure::bad(format!("the trim expression uses u and v, not {word}"))),
            w => out.push_str(w),
        }
        word.clear();
        Ok(())
    };
    for c in src.chars() {
        if c.is_ascii_alphanumeric()
            || c == '_'
            || (c == '.' && word.chars().all(|d| d.is_ascii_digit())) && !word.is_empty()
        {
            word.push(c);
        } else {
            flush(&mut word, &mut out)?;
            out.push(c);
        }
    }
    flush(&mut word, &mut out)?;
    parse_expr("trim", &out).map_err(|f| Failure::bad(format!("{} (in the trim expression {src:?})", f.message)))
}

/// `trussmesh surface --bezier PATCHES.json`.
fn run_bezier(path: &std::path::Path, h0: f64, args: &SurfaceArgs) -> Result<(), Failure> {
    let text =
        std::fs::read_to_string(path).map_err(|e| Failure::bad(format!("cannot read {}: {e}", path.display())))?;
    let json: PatchesJson = serde_json::from_str(&text)
        .map_err(|e| Failure::bad(format!("bad Bézier patch file {}: {e}", path.display())))?;
    let mut patches = Vec::with_capacity(json.patches.len());
    for (k, p) in json.patches.into_iter().enumerate() {
        let control = p.control.iter().map(|c| DVec3::from_array(*c)).collect();
        let mut patch = RationalBezierPatch::new((p.degree[0], p.degree[1]), control, p.weights)
            .map_err(|e| Failure::bad(format!("patch {k}: {e}")))?;
        if let Some(t) = &p.trim {
            let e = trim_expr(t)?;
            patch = patch.with_trim(Arc::new(move |u, v| e.eval(u, v, 0.0)));
        }
        patches.push(patch);
    }
    let mut opts = BezierOptions::new(h0);
    if let Some(n) = args.max_iter {
        opts.max_iter = n;
    }
    let start = std::time::Instant::now();
    let out = mesh_patches(&patches, &opts)?;
    let q = BezierQuality::measure(&out.points, &out.triangles, h0);
    let data = MeshData {
        dim: 3,
        cell_type: CellType::Triangle,
        points: out.points.iter().map(|p| p.to_array()).collect(),
        cells: out.triangles.iter().flatten().copied().collect(),
        subdomain: None,
    };
    for p in &args.output {
        write_output(p, &data, "Bézier patches")?;
    }
    if !args.quiet {
        println!(
            "bezier: {} patches, {} vertices, {} triangles; min angle {:.1}, min q {:.3}, mean q {:.4}, size deviation {:.1}% (mean length/h {:.3}); {:.2} s",
            patches.len(),
            q.vertices,
            q.triangles,
            q.min_angle,
            q.min_q,
            q.mean_q,
            100.0 * q.size_deviation,
            q.mean_size_ratio,
            start.elapsed().as_secs_f64()
        );
        for p in &args.output {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}
