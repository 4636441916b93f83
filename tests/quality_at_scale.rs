//! Quality that holds at every size: the unit disk from 3x10^3 to 1.2x10^6 triangles keeps
//! q min >= 0.7 (the large meshes get the worst-triangle polish too, bounded by a queue of the
//! worst triangles), and the meshes from 10^5 up keep q mean >= 0.999.

use trussmesh::geometry::Circle;
use trussmesh::mesher::{mesh_2d, Options2};

#[test]
fn unit_disk_quality_holds_at_every_size() {
    let disk = Circle::new([0.0, 0.0], 1.0);
    println!("| h0 | triangles | q min | q mean | seconds |");
    println!("|---|---|---|---|---|");
    for h0 in [0.04, 0.008, 0.004, 0.0025] {
        let out = mesh_2d(&disk, &Options2::uniform(h0, [-1.0, -1.0], [1.0, 1.0])).expect("meshing");
        let q = out.report.quality;
        println!("| {h0} | {} | {:.4} | {:.5} | {:.2} |", q.triangles, q.q_min, q.q_mean, out.report.seconds);
        assert!(q.q_min >= 0.7, "h0 {h0}: q min {:.4} below 0.7 at {} triangles", q.q_min, q.triangles);
        if q.triangles >= 100_000 {
            assert!(q.q_mean >= 0.999, "h0 {h0}: q mean {:.5} below 0.999", q.q_mean);
        }
    }
}
