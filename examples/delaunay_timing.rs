//! Times the 3-D Delaunay tetrahedralization of uniform random points (one run, one thread).
//! `cargo run --release --example delaunay_timing -- 1000000`
use std::time::Instant;
use trussmesh::testing::{random_points_3d, SEED};
use trussmesh::topology::TetMesh;

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(1_000_000);
    let pts = random_points_3d(n, SEED);
    let t = Instant::now();
    let (m, _) = TetMesh::delaunay(&pts).expect("random points");
    let dt = t.elapsed().as_secs_f64();
    println!("{n} points: {dt:.3} s, {:.0} points/s, {} tets", n as f64 / dt, m.num_tets());
}
