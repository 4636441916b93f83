//! Meshes the unit disk and prints the report: `cargo run --release --example disk -- 0.05`.
use trussmesh::geometry::Circle;
use trussmesh::mesher::{area, boundary_deviation, mesh_2d, size_deviation, Options2};

fn main() {
    let h0: f64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(0.05);
    let disk = Circle::new([0.0, 0.0], 1.0);
    let mut opts = Options2::uniform(h0, [-1.0, -1.0], [1.0, 1.0]);
    if std::env::var_os("CLASSIC").is_some() {
        opts = opts.with_strategy(trussmesh::mesher::Strategy::GlobalDelaunay);
    }
    let out = mesh_2d(&disk, &opts).expect("meshing failed");
    println!("{}", out.report);
    println!(
        "size deviation {:.4}, boundary deviation {:.2e}, area {:.6} (pi = {:.6})",
        size_deviation(&out.mesh, &|_| 1.0),
        boundary_deviation(&out.mesh, &disk),
        area(&out.mesh),
        std::f64::consts::PI
    );
    if let Some(path) = std::env::args().nth(2) {
        let data = trussmesh::io::MeshData::from_trimesh2(&out.mesh);
        trussmesh::io::write_png(std::path::Path::new(&path), &data, "disk", 1000).expect("picture");
    }
}
