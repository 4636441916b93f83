//! Triangulated geometry on the command line: `trussmesh mesh --dim 3 --domain FILE` meshes
//! the inside of a closed surface file, `trussmesh surface --input FILE` remeshes it (see
//! docs/trisurf.md).

use super::auto_size::is_auto;
use super::budget::{self, Budget};
use super::mesh::{constant, parse_expr, split_top, MeshArgs};
use super::surface::{size_rule, SizeRule, SurfaceArgs};
use super::{output, Failure};
use glam::DVec3;
use std::path::Path;
use trussmesh::expr::Expr;
use trussmesh::geometry::trisurf::DEFAULT_FEATURE_ANGLE;
use trussmesh::geometry::TriSurface;
use trussmesh::io::{CellType, MeshData};
use trussmesh::{mesh_3d, mesh_surface};

/// The extensions a surface file may have.
const EXTENSIONS: [&str; 6] = ["stl", "obj", "ply", "mesh", "msh", "vtu"];

/// Whether `--domain` names a surface file rather than an expression.
pub fn is_surface_file(domain: &str) -> bool {
    let ext = output::extension(Path::new(domain.trim()));
    EXTENSIONS.contains(&ext.as_str()) && !domain.contains(['(', ')', '+', '*', ' '])
}

fn read(path: &str) -> Result<TriSurface, Failure> {
    let p = Path::new(path.trim());
    if !p.exists() {
        return Err(Failure::bad(format!("the surface file {} does not exist", p.display())));
    }
    let s = TriSurface::read(p).map_err(|e| match e {
        trussmesh::Error::Surface(_) => Failure::bad(format!("{}: {e}", p.display())),
        e => e.into(),
    })?;
    if s.dropped_triangles() > 0 {
        eprintln!(
            "note: {}: {} triangles with two coincident corners dropped (their zero-length edges collapsed)",
            p.display(),
            s.dropped_triangles()
        );
    }
    Ok(s)
}

/// The feature angle of the flags: None when features are off (`--no-sharp`).
fn feature_angle(angle: Option<f64>, sharp: bool) -> Result<Option<f64>, Failure> {
    let a = angle.unwrap_or(DEFAULT_FEATURE_ANGLE);
    if !(a > 0.0 && a <= 180.0) {
        return Err(Failure::bad(format!("--feature-angle {a} must be in (0, 180] degrees")));
    }
    Ok(sharp.then_some(a))
}

/// A relative size expression (parsed), checked positive at the surface's vertices.
fn checked_size(e: Expr, src: &str, surf: &TriSurface) -> Result<Expr, Failure> {
    for p in surf.points() {
        let v = e.eval(p.x, p.y, p.z);
        if !(v > 0.0 && v.is_finite()) {
            return Err(Failure::bad(format!(
                "--size {src:?} is {v} at the surface point ({}, {}, {}); sizes must be positive",
                p.x, p.y, p.z
            )));
        }
    }
    Ok(e)
}

/// `--bbox` (six numbers) or the file's box.
fn bbox(src: Option<&str>) -> Result<Option<[DVec3; 2]>, Failure> {
    let Some(src) = src else { return Ok(None) };
    let c: Vec<f64> = split_top(src, ',').iter().map(|c| constant("a --bbox value", c)).collect::<Result<_, _>>()?;
    if c.len() != 6 {
        return Err(Failure::bad(format!("--bbox needs 6 numbers X0,Y0,Z0,X1,Y1,Z1, not {}", c.len())));
    }
    let (lo, hi) = (DVec3::new(c[0], c[1], c[2]), DVec3::new(c[3], c[4], c[5]));
    if !(lo.cmplt(hi).all() && (hi - lo).is_finite()) {
        return Err(Failure::bad(format!("--bbox {src:?} is empty or not finite")));
    }
    Ok(Some([lo, hi]))
}

/// Bytes a checked input surface takes (points, triangles, neighbours, hierarchy, normals).
const BYTES_PER_INPUT_TRIANGLE: f64 = 400.0;

/// Refuses a run whose memory estimate passes `--max-memory` (elements at uniform size h0).
fn check_budget(
    max_memory: Option<&str>,
    surf: &TriSurface,
    what: &str,
    elements: f64,
    per: f64,
) -> Result<(), Failure> {
    let input = surf.triangles().len() as f64 * BYTES_PER_INPUT_TRIANGLE;
    Budget::new(max_memory)?.check(
        what,
        budget::BASE_BYTES + input + elements * per,
        &format!("about {} elements at about {per} bytes each, and the input's triangles", budget::count(elements)),
        "use a larger --h0",
    )
}

fn positive_h0(src: &str) -> Result<f64, Failure> {
    let h0 = constant("h0", src)?;
    if !(h0 > 0.0 && h0.is_finite()) {
        return Err(Failure::bad(format!("h0 = {h0} must be positive (--h0 {})", src.trim())));
    }
    Ok(h0)
}

/// `trussmesh mesh --dim 3 --domain FILE`: tetrahedra inside the closed surface.
pub fn run_mesh(args: &MeshArgs, file: &str) -> Result<(), Failure> {
    if args.dim.unwrap_or(3) != 3 {
        return Err(Failure::bad("a surface file as --domain needs --dim 3"));
    }
    for (on, flag) in
        [(args.implicit, "--implicit"), (args.internal.is_some(), "--internal"), (args.metric.is_some(), "--metric")]
    {
        if on {
            return Err(Failure::bad(format!("{flag} does not apply to a surface file as --domain")));
        }
    }
    output::check_all(&args.output)?;
    let h0 = positive_h0(args.h0.as_deref().ok_or_else(|| Failure::bad("missing --h0"))?)?;
    let angle = feature_angle(args.feature_angle, !args.no_sharp)?;
    let surf = read(file)?.with_feature_angle(angle);
    // A regular tet of edge h0 has volume h0^3 / (6 sqrt 2).
    let tets = surf.volume() * 6.0 * 2f64.sqrt() / (h0 * h0 * h0);
    check_budget(args.max_memory.as_deref(), &surf, "the tet mesh", tets, budget::BYTES_PER_TET)?;
    let given_box = bbox(args.bbox.as_deref())?;
    let [lo, hi] = given_box.unwrap_or_else(|| surf.padded_box(h0));
    let size_fn: Option<trussmesh::mesher::SizeFn3> = match args.size.as_deref() {
        None => None,
        Some(s) if is_auto(Some(s)) => {
            let Some(auto) = args.auto.resolve(true, h0)? else {
                return Err(Failure::internal("--size auto gave no automatic sizes"));
            };
            let grid = auto.grid3(&surf, lo.to_array(), hi.to_array())?;
            Some(std::sync::Arc::new(move |p: DVec3| trussmesh::Implicit3::value(&*grid, p)))
        }
        Some(s) => {
            let e = checked_size(parse_expr("--size", s)?, s, &surf)?;
            Some(std::sync::Arc::new(move |p: DVec3| e.eval(p.x, p.y, p.z)))
        }
    };
    if args.size.is_none() {
        args.auto.resolve(false, h0)?;
    }
    let mut opts = surf.volume_options(h0, size_fn, angle);
    if given_box.is_some() {
        opts.bbox = [lo, hi];
        opts.fixed.retain(|p| p.cmpge(lo).all() && p.cmple(hi).all());
    }
    if let Some(f) = &args.fix {
        for q in split_top(f, ';').iter().filter(|q| !q.trim().is_empty()) {
            let c: Vec<f64> =
                split_top(q, ',').iter().map(|c| constant("a --fix value", c)).collect::<Result<_, _>>()?;
            if c.len() != 3 {
                return Err(Failure::bad(format!("a --fix point needs 3 coordinates, not {}", c.len())));
            }
            opts.fixed.push(DVec3::new(c[0], c[1], c[2]));
        }
    }
    if let Some(n) = args.max_iter {
        opts = opts.with_max_iter(n);
    }
    if let Some(s) = args.seed {
        opts = opts.with_seed(s);
    }
    if let Some(p) = args.projection {
        opts = opts.with_projection(p.into());
    }
    let out = super::mesh::with_progress_bar(args.quiet, "iterations", |pb| {
        if let Some(pb) = pb {
            opts = opts.clone().with_progress(super::mesh::progress_callback(pb));
        }
        mesh_3d(&surf, &opts)
    })?;
    let arrays = out.mesh.to_arrays();
    let data = MeshData {
        dim: 3,
        cell_type: CellType::Tetra,
        points: arrays.points.iter().map(|p| p.to_array()).collect(),
        cells: arrays.cells.iter().flatten().copied().collect(),
        subdomain: None,
    };
    output::write_all(&args.output, &data, file)?;
    if !args.quiet {
        println!("{}", out.report);
        for p in &args.output {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}

/// `trussmesh surface --input FILE`: the closed surface remeshed.
pub fn run_surface(args: &SurfaceArgs, file: &Path, h0: f64) -> Result<(), Failure> {
    output::check_all(&args.output)?;
    let name = file.display().to_string();
    let angle = feature_angle(args.feature_angle, !args.no_sharp)?;
    // Input faces too narrow to hold at the smallest size are merged into a neighbour.
    let surf = read(&name)?.with_feature_angle(angle).with_feature_size(Some(h0));
    let triangles = surf.area() / (3f64.sqrt() / 4.0 * h0 * h0);
    check_budget(args.max_memory.as_deref(), &surf, "the surface mesh", triangles, budget::BYTES_PER_SURFACE_TRIANGLE)?;
    let mut opts = surf.surface_options(h0);
    if let Some([lo, hi]) = bbox(args.bbox.as_deref())? {
        opts.bbox = [lo, hi];
    }
    if args.size.is_some() && args.curvature.is_some() {
        return Err(Failure::bad("--size and --curvature cannot be combined"));
    }
    match size_rule(args)? {
        SizeRule::Uniform => {}
        SizeRule::Curvature(k) => {
            opts = opts.with_curvature(k, args.gradient.unwrap_or(0.3), args.hmax.unwrap_or(8.0 * h0));
        }
        SizeRule::Relative(e) => {
            let e = checked_size(e, args.size.as_deref().unwrap_or_default(), &surf)?;
            opts = opts.with_size(move |p| e.eval(p.x, p.y, p.z));
        }
    }
    if let Some(n) = args.max_iter {
        opts = opts.with_max_iter(n);
    }
    let out = super::mesh::with_progress_bar(args.quiet, "stages", |pb| {
        if let Some(pb) = pb {
            opts = opts.clone().with_progress(super::mesh::progress_callback(pb));
        }
        mesh_surface(&surf, &opts)
    })?;
    let data = MeshData::from_trimesh3(&out.mesh);
    // A remeshed surface that is no valid input in turn (the mesher's own check should have
    // caught it) is refused, not written.
    if let Err(e) = TriSurface::from_mesh_data(&data) {
        return Err(Failure::internal(format!("the remeshed surface is no valid closed surface ({e})")));
    }
    output::write_all(&args.output, &data, &name)?;
    if !args.quiet {
        println!("{}", out.report);
        for p in &args.output {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}
