//! Times `validate` on large meshes: the combinatorial checks (`Topology`) against the full
//! check with the embedding (`Geometry`), for a 10^6-triangle planar grid, the Delaunay tet mesh
//! of random points and its boundary surface. `cargo run --release --example validate_timing`
use std::time::Instant;
use trussmesh::testing::{grid, random_points_3d, SEED};
use trussmesh::topology::{Level, TetMesh};

fn time<F: FnMut()>(mut f: F) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        f();
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(708);
    let m = grid(n, n, 0.2, SEED);
    let topo = time(|| m.validate(Level::Topology).unwrap());
    let geo = time(|| m.validate(Level::Geometry).unwrap());
    println!("planar: {} triangles, Topology {topo:.3} s, Geometry (with embedding) {geo:.3} s", m.num_faces());
    let (t, _) = TetMesh::delaunay(&random_points_3d(200_000, SEED)).expect("random points");
    let topo = time(|| t.validate(Level::Topology).unwrap());
    let geo = time(|| t.validate(Level::Geometry).unwrap());
    println!("tets: {} tets, Topology {topo:.3} s, Geometry (with embedding) {geo:.3} s", t.num_tets());
    // A graph surface over the planar grid.
    let a = m.to_arrays();
    let pts: Vec<_> = a.points.iter().map(|p| p.extend((0.05 * p.x).sin() * (0.07 * p.y).cos() * 3.0)).collect();
    let (s, _) = trussmesh::topology::TriMesh::from_arrays(&pts, &a.cells).unwrap();
    let topo = time(|| s.validate(Level::Topology).unwrap());
    let geo = time(|| s.validate(Level::Geometry).unwrap());
    println!(
        "surface: {} triangles, Topology {topo:.3} s, Geometry (with self-intersection) {geo:.3} s",
        s.num_faces()
    );
}
