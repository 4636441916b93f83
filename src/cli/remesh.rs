//! `trussmesh remesh`: remesh a 2-D mesh file for a new size field (seed section 5.2).

use super::budget::{self, Budget};
use super::mesh::whole_number;
use super::{output, Failure};
use clap::Args;
use glam::DVec2;
use std::path::PathBuf;
use trussmesh::expr::Expr;
use trussmesh::io::{CellType, MeshData};
use trussmesh::mesher::remesh_adapt_2d;
use trussmesh::topology::TriMesh;

/// Arguments of `trussmesh remesh`.
#[derive(Args, Debug)]
pub struct RemeshArgs {
    /// The mesh to start from (a 2-D triangle mesh in any readable format).
    pub mesh: PathBuf,
    /// The new absolute size h(x, y), evaluated at the old mesh's nodes.
    #[arg(long, value_name = "EXPR", allow_hyphen_values = true)]
    pub size: String,
    /// Gradient limit g applied to the size on the old mesh (`--g` is the old spelling).
    #[arg(long = "gradient", alias = "g", value_name = "G", default_value_t = 0.3)]
    pub g: f64,
    /// Iteration cap of the force iterations.
    #[arg(long, default_value_t = 1000, allow_hyphen_values = true, value_parser = whole_number::<usize>)]
    pub max_iter: usize,
    /// Output files; the extension picks the format.
    #[arg(short = 'o', long = "output", value_name = "FILE", required = true)]
    pub outputs: Vec<PathBuf>,
    /// Memory budget (such as 2G or 500M; default a quarter of the machine's memory): a run
    /// whose estimate passes it is refused before remeshing.
    #[arg(long, value_name = "BYTES")]
    pub max_memory: Option<String>,
    /// No report on stdout.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `trussmesh remesh`.
pub fn run(a: RemeshArgs) -> Result<(), Failure> {
    output::check_all(&a.outputs)?;
    let budget = Budget::new(a.max_memory.as_deref())?;
    let size =
        Expr::parse(&a.size).map_err(|e| Failure::bad(format!("bad --size expression, {e}\n{}", e.render(&a.size))))?;
    let data = trussmesh::io::read_mesh(&a.mesh)?;
    if data.cell_type != CellType::Triangle || data.dim != 2 {
        return Err(Failure::bad(format!("{}: remeshing needs a planar triangle mesh", a.mesh.display())));
    }
    let check = trussmesh::io::check_mesh(&data);
    if !check.is_valid() {
        let list: Vec<&str> = check.problems.iter().map(|p| p.message.as_str()).collect();
        return Err(Failure::bad(format!(
            "the mesh to remesh, {}, is invalid: {} (trussmesh stats {} lists the problems)",
            a.mesh.display(),
            list.join("; "),
            a.mesh.display()
        )));
    }
    let points: Vec<DVec2> = data.points.iter().map(|p| DVec2::new(p[0], p[1])).collect();
    let tris: Vec<[usize; 3]> = data.cells.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    // The new size at every node, and from it the triangle count: each old triangle holds
    // its area over that of an equilateral triangle of the mean size of its nodes.
    let h_at: Vec<f64> = points.iter().map(|p| size.eval(p.x, p.y, 0.0)).collect();
    if let Some((i, v)) = h_at.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v > 0.0)) {
        return Err(Failure::bad(format!(
            "--size {:?} is {v} at node {i} ({}, {}); the new size must be positive and finite at every node",
            a.size, points[i].x, points[i].y
        )));
    }
    let estimate: f64 = tris
        .iter()
        .map(|t| {
            let area = trussmesh::quality::triangle_area([points[t[0]], points[t[1]], points[t[2]]]).abs();
            let h = (h_at[t[0]] + h_at[t[1]] + h_at[t[2]]) / 3.0;
            area / (3f64.sqrt() / 4.0 * h * h)
        })
        .sum();
    budget.check(
        "the new mesh",
        budget::BASE_BYTES + (estimate + tris.len() as f64) * budget::BYTES_PER_TRIANGLE_2D,
        &format!(
            "about {} new triangles and {} old ones at about {} bytes each",
            budget::count(estimate),
            tris.len(),
            budget::BYTES_PER_TRIANGLE_2D
        ),
        "use a larger --size",
    )?;
    let (old, _) = TriMesh::from_arrays(&points, &tris)?;
    let h: Vec<f64> = old.vertex_ids().map(|v| size.eval(old.pos(v).x, old.pos(v).y, 0.0)).collect();
    let out = remesh_adapt_2d(&old, h, a.g, a.max_iter)?;
    let md = MeshData::from_trimesh2(&out.mesh);
    output::write_all(&a.outputs, &md, &a.mesh.display().to_string())?;
    if !a.quiet {
        println!("{}", out.report);
        for p in &a.outputs {
            println!("wrote {}", output::describe(p));
        }
    }
    Ok(())
}
