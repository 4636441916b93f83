//! Times writing a 10^6-triangle planar mesh as binary VTU, stage by stage: the input check,
//! the node kinds from the boundary edges, the quality field, the bytes, and the file.
//! `cargo run --release --example io_timing [K]` (a K x K grid cut into 2 K^2 triangles,
//! K = 708 by default).
use std::time::Instant;
use trussmesh::io::{measure::triangle_q_values, write_mesh_bytes_with, write_mesh_with, Encoding, Format};

fn best<T, F: FnMut() -> T>(mut f: F) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        std::hint::black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

fn main() {
    let k: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(708);
    let m = trussmesh::testing::grid_mesh_data(k);
    println!("{} triangles, {} points", m.num_cells(), m.points.len());
    println!("check        {:.4} s", best(|| m.validate().unwrap()));
    println!("node kinds   {:.4} s", best(|| m.boundary_nodes()));
    println!("quality      {:.4} s", best(|| triangle_q_values(&m)));
    println!("bytes        {:.4} s", best(|| write_mesh_bytes_with(&m, Format::Vtu, Encoding::Binary).unwrap()));
    println!("json bytes   {:.4} s", best(|| write_mesh_bytes_with(&m, Format::Json, Encoding::Ascii).unwrap()));
    let dir = std::env::temp_dir().join(format!("trussmesh-io-timing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("m.vtu");
    println!("file         {:.4} s", best(|| write_mesh_with(&path, &m, Encoding::Binary).unwrap()));
    let bytes = std::fs::read(&path).unwrap();
    println!("{:.1} MB", bytes.len() as f64 / 1e6);
    std::fs::remove_dir_all(&dir).ok();
}
