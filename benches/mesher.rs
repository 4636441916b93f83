//! The 2-D mesher's cost: the local strategy against the classic global-Delaunay one on the
//! unit disk at about 2x10^5 triangles (same run), and the cost curve of the local strategy
//! from 10^3 to 10^6 triangles. A timed binary (one run per size; criterion's repetitions
//! would take many minutes at these sizes): `cargo bench --bench mesher [-- --max N]`.

use std::time::Instant;
use trussmesh::geometry::Circle;
use trussmesh::mesher::{mesh_2d, size_deviation, Options2, Strategy};

fn main() {
    let max: f64 = std::env::args().skip_while(|a| a != "--max").nth(1).and_then(|s| s.parse().ok()).unwrap_or(1.1e6);
    let disk = Circle::new([0.0, 0.0], 1.0);
    println!("machine: {} threads (rayon)", rayon::current_num_threads());
    println!();
    println!("| strategy | h0 | triangles | iterations | seconds | q min | q mean | size dev |");
    println!("|---|---|---|---|---|---|---|---|");
    let h_for = |tris: f64| (std::f64::consts::PI / (3f64.sqrt() / 4.0 * tris)).sqrt();
    let h0 = h_for(2e5);
    for strategy in [Strategy::Local, Strategy::GlobalDelaunay] {
        let opts = Options2::uniform(h0, [-1.0, -1.0], [1.0, 1.0]).with_strategy(strategy);
        let t = Instant::now();
        let out = mesh_2d(&disk, &opts).expect("meshing");
        let secs = t.elapsed().as_secs_f64();
        let q = out.report.quality;
        println!(
            "| {:?} | {:.5} | {} | {} | {:.2} | {:.4} | {:.4} | {:.4} |",
            strategy,
            h0,
            q.triangles,
            out.report.iterations,
            secs,
            q.q_min,
            q.q_mean,
            size_deviation(&out.mesh, &|_| 1.0)
        );
    }
    println!();
    println!("| target triangles | triangles | iterations | seconds | microseconds per triangle | peak RSS bytes per triangle |");
    println!("|---|---|---|---|---|---|");
    let mut target = 1e3;
    while target <= max {
        let opts = Options2::uniform(h_for(target), [-1.0, -1.0], [1.0, 1.0]);
        let t = Instant::now();
        let out = mesh_2d(&disk, &opts).expect("meshing");
        let secs = t.elapsed().as_secs_f64();
        let n = out.report.quality.triangles;
        println!(
            "| {:.0e} | {} | {} | {:.3} | {:.2} | {} |",
            target,
            n,
            out.report.iterations,
            secs,
            1e6 * secs / n as f64,
            peak_rss().map_or("-".into(), |b| format!("{:.0}", b as f64 / n as f64))
        );
        target *= 10.0;
    }
}

/// Peak resident set size of this process so far (Linux), in bytes.
fn peak_rss() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
