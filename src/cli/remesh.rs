//! `trussmesh remesh`: remesh a 2-D mesh file for a new size field (seed section 5.2).

use super::mesh::write_output;
use super::Failure;
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
    #[arg(long)]
    pub size: String,
    /// Gradient limit g applied to the size on the old mesh.
    #[arg(long, default_value_t = 0.3)]
    pub g: f64,
    /// Iteration cap of the force iterations.
    #[arg(long, default_value_t = 1000)]
    pub max_iter: usize,
    /// Output files; the extension picks the format.
    #[arg(short = 'o', long = "output", required = true)]
    pub outputs: Vec<PathBuf>,
    /// No report on stdout.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `trussmesh remesh`.
pub fn run(a: RemeshArgs) -> Result<(), Failure> {
    let size =
        Expr::parse(&a.size).map_err(|e| Failure::bad(format!("bad --size expression, {e}\n{}", e.render(&a.size))))?;
    let data = trussmesh::io::read_mesh(&a.mesh)?;
    if data.cell_type != CellType::Triangle || data.dim != 2 {
        return Err(Failure::bad(format!("{}: remeshing needs a planar triangle mesh", a.mesh.display())));
    }
    let points: Vec<DVec2> = data.points.iter().map(|p| DVec2::new(p[0], p[1])).collect();
    let tris: Vec<[usize; 3]> = data.cells.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    let (old, _) = TriMesh::from_arrays(&points, &tris)?;
    let h: Vec<f64> = old.vertex_ids().map(|v| size.eval(old.pos(v).x, old.pos(v).y, 0.0)).collect();
    let out = remesh_adapt_2d(&old, h, a.g, a.max_iter)?;
    let md = MeshData::from_trimesh2(&out.mesh);
    for p in &a.outputs {
        write_output(p, &md, &a.mesh.display().to_string())?;
    }
    if !a.quiet {
        println!("{}", out.report);
        for p in &a.outputs {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}
