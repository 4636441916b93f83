//! A planar domain from a polyline file on the command line: `trussmesh mesh --domain FILE`
//! with an OBJ of `l` records, a text file of x y lines, or a planar triangle mesh (whose
//! boundary is taken) meshes the inside of the closed polylines, their corners held (see
//! docs/polygons.md).

use super::budget::{self, Budget};
use super::mesh::{constant, parse_expr, show_point, split_top, MeshArgs};
use super::{auto_size, kinds, output, Failure};
use glam::DVec2;
use std::path::Path;
use std::sync::Arc;
use trussmesh::geometry::polygons::{read, DEFAULT_FEATURE_ANGLE};
use trussmesh::geometry::{Implicit2, Polygons2};
use trussmesh::io::MeshData;
use trussmesh::mesh_2d;

/// Whether `--domain` names a polyline file for the 2-D mesher: a text file (.txt .xy .dat
/// .csv) always; an .obj, .msh, .vtu or .mesh file with `--dim 2`, or without `--dim` when its
/// content is planar (`l` records, or triangles whose z is 0 everywhere).
pub fn is_polyline_file(domain: &str, dim: Option<usize>) -> bool {
    let path = Path::new(domain.trim());
    let ext = output::extension(path);
    if domain.contains(['(', ')', '+', '*', ' ']) || !read::EXTENSIONS.contains(&ext.as_str()) {
        return false;
    }
    if read::TEXT_EXTENSIONS.contains(&ext.as_str()) {
        return true;
    }
    match dim {
        Some(2) => true,
        Some(_) => false,
        None => path.exists() && read::is_planar(path).unwrap_or(false),
    }
}

fn load(path: &str) -> Result<Polygons2, Failure> {
    let p = Path::new(path.trim());
    if !p.exists() {
        return Err(Failure::bad(format!("the polyline file {} does not exist", p.display())));
    }
    Polygons2::read(p).map_err(|e| match e {
        trussmesh::Error::Polygon(_) => Failure::bad(format!("{}: {e}", p.display())),
        e => e.into(),
    })
}

/// `--bbox` (four numbers) or None.
fn bbox(src: Option<&str>) -> Result<Option<[DVec2; 2]>, Failure> {
    let Some(src) = src else { return Ok(None) };
    let c: Vec<f64> = split_top(src, ',').iter().map(|c| constant("a --bbox value", c)).collect::<Result<_, _>>()?;
    if c.len() != 4 {
        return Err(Failure::bad(format!("--bbox needs 4 numbers X0,Y0,X1,Y1 for a polyline file, not {}", c.len())));
    }
    let (lo, hi) = (DVec2::new(c[0], c[1]), DVec2::new(c[2], c[3]));
    if !(lo.cmplt(hi).all() && (hi - lo).is_finite()) {
        return Err(Failure::bad(format!("--bbox {src:?} is empty or not finite")));
    }
    Ok(Some([lo, hi]))
}

/// `trussmesh mesh --domain FILE` for a polyline file: triangles inside the closed polylines.
pub fn run_mesh(args: &MeshArgs, file: &str) -> Result<(), Failure> {
    if args.dim.unwrap_or(2) != 2 {
        return Err(Failure::bad("a polyline file as --domain needs --dim 2"));
    }
    for (on, flag) in [
        (args.implicit, "--implicit"),
        (args.internal.is_some(), "--internal"),
        (args.metric.is_some(), "--metric"),
        (args.origin.is_some(), "--origin"),
        (args.spacing.is_some(), "--spacing"),
    ] {
        if on {
            return Err(Failure::bad(format!("{flag} does not apply to a polyline file as --domain")));
        }
    }
    output::check_all(&args.output)?;
    let h0_src = args.h0.as_deref().ok_or_else(|| Failure::bad("missing --h0"))?;
    let h0 = constant("h0", h0_src)?;
    if !(h0 > 0.0 && h0.is_finite()) {
        return Err(Failure::bad(format!("h0 = {h0} must be positive (--h0 {})", h0_src.trim())));
    }
    let angle = args.feature_angle.unwrap_or(DEFAULT_FEATURE_ANGLE);
    if !(angle > 0.0 && angle <= 180.0) {
        return Err(Failure::bad(format!("--feature-angle {angle} must be in (0, 180] degrees")));
    }
    let geom = load(file)?;
    // An equilateral triangle of edge h0 has area sqrt(3)/4 h0^2.
    let tris = geom.area() / (3f64.sqrt() / 4.0 * h0 * h0);
    Budget::new(args.max_memory.as_deref())?.check(
        "the 2-D mesh",
        budget::BASE_BYTES + geom.num_segments() as f64 * 200.0 + tris * budget::BYTES_PER_TRIANGLE_2D,
        &format!("about {} triangles at about {} bytes each", budget::count(tris), budget::BYTES_PER_TRIANGLE_2D),
        "use a larger --h0",
    )?;
    let mut opts = geom.options(h0, None, (!args.no_sharp).then_some(angle));
    if let Some([lo, hi]) = bbox(args.bbox.as_deref())? {
        opts.bbox = [lo, hi];
        opts.fixed.retain(|p| p.cmpge(lo).all() && p.cmple(hi).all());
    }
    let auto = args.auto.resolve(auto_size::is_auto(args.size.as_deref()), h0)?;
    if let Some(a) = &auto {
        let [lo, hi] = opts.bbox;
        let g = a.grid2(&geom, lo.to_array(), hi.to_array())?;
        opts.size = Some(Arc::new(move |p| Implicit2::value(&*g, p)));
    } else if let Some(src) = &args.size {
        let e = parse_expr("--size", src)?;
        for p in geom.loops().iter().flatten() {
            let v = e.eval(p.x, p.y, 0.0);
            if !(v > 0.0 && v.is_finite()) {
                return Err(Failure::bad(format!(
                    "--size {src:?} is {v} at the boundary point ({}, {}); sizes must be positive",
                    p.x, p.y
                )));
            }
        }
        opts.size = Some(Arc::new(move |p| e.eval(p.x, p.y, 0.0)));
    }
    let mut fix: Vec<Vec<f64>> = Vec::new();
    if let Some(f) = &args.fix {
        for q in split_top(f, ';').iter().filter(|q| !q.trim().is_empty()) {
            let c: Vec<f64> =
                split_top(q, ',').iter().map(|c| constant("a --fix value", c)).collect::<Result<_, _>>()?;
            if c.len() != 2 {
                return Err(Failure::bad(format!("a --fix point needs 2 coordinates, not {}", c.len())));
            }
            let d = geom.value(DVec2::new(c[0], c[1]));
            if d > 1e-2 * h0 {
                return Err(Failure::bad(format!(
                    "the fixed point {} lies outside the polylines' domain (d = {d:.4} there); fixed points must be \
                     inside it or on its boundary",
                    show_point(&c)
                )));
            }
            opts.fixed.push(DVec2::new(c[0], c[1]));
            fix.push(c);
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
        mesh_2d(&geom, &opts)
    })?;
    let data = MeshData::from_trimesh2(&out.mesh);
    let node_kind = kinds::planar(&out.mesh, &fix, h0);
    let extras = output::Extras { measure: None, node_kind: Some(&node_kind) };
    output::write_all_by(&args.output, &data, file, extras)?;
    if !args.quiet {
        println!("{}", out.report);
        for p in &args.output {
            println!("wrote {}", output::describe(p));
        }
    }
    Ok(())
}
