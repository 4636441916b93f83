//! Cost curve of the 3-D mesher: the uniform unit ball from about 10^3 to 10^6 tetrahedra.
//! Not a criterion bench (one run per size is minutes at the top): prints a markdown table.
//!
//! `cargo bench --bench mesh3d_scale` (all sizes) or `cargo bench --bench mesh3d_scale -- 0.1 0.05`
//! (the given h0 values only).

use trussmesh::geometry::Ball;
use trussmesh::mesher::{mesh_3d, Options3};

fn main() {
    let args: Vec<f64> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let sizes = if args.is_empty() { vec![0.4, 0.2, 0.1, 0.05, 0.025] } else { args };
    println!("threads: {}", rayon::current_num_threads());
    println!("| h0 | nodes | tets | iterations | seconds | tets/s | min dihedral | max dihedral | rr mean |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for h0 in sizes {
        let o = Options3::uniform(h0, [-1.1; 3], [1.1; 3]);
        let out = mesh_3d(&Ball::new([0.0, 0.0, 0.0], 1.0), &o).expect("meshes");
        let q = &out.report.quality;
        println!(
            "| {h0} | {} | {} | {} | {:.2} | {:.0} | {:.1} | {:.1} | {:.4} |",
            q.vertices,
            q.tets,
            out.report.iterations,
            out.report.seconds,
            q.tets as f64 / out.report.seconds,
            q.dihedral_min,
            q.dihedral_max,
            q.rr_mean
        );
    }
}
