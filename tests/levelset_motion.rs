//! Level sets on a grid moving a boundary (seed section 5.1.1): phi is advanced by a normal
//! speed (eq. 5.2-5.5) and by a velocity field (eq. 5.1), reinitialised by fast marching, and
//! every step is meshed with the moving-mesh API from the previous mesh.

use glam::DVec2;
use trussmesh::geometry::{levelset, Circle, Grid2};
use trussmesh::mesher::{boundary_deviation, mesh_2d, move_mesh_2d, Options2};
use trussmesh::topology::Level;

const H0: f64 = 0.05;

fn opts(max_iter: usize) -> Options2 {
    Options2::uniform(H0, [-1.0, -1.0], [1.0, 1.0]).with_max_iter(max_iter)
}

#[test]
fn a_level_set_front_meshed_at_every_step() {
    // A disk of radius 0.3 grows faster on the right (normal speed 0.5 + 0.5 x), then drifts.
    let mut phi = Grid2::sample(&Circle::new([-0.3, 0.0], 0.3), [-1.0, -1.0], [1.0, 1.0], 0.02).unwrap();
    let mut mesh = mesh_2d(&phi, &opts(1000)).expect("first mesh").mesh;
    let area0: f64 = trussmesh::mesher::area(&mesh);
    println!("| step | nodes | q min | q mean | max |phi|/h0 on the boundary | area |");
    let (mut worst_min, mut worst_mean) = (1.0f64, 1.0f64);
    for step in 1..=12 {
        let next = if step <= 6 {
            levelset::move_normal_2d(&phi, |p: DVec2| 0.5 + 0.5 * p.x, 0.05).unwrap()
        } else {
            levelset::advect_2d(&phi, |_| DVec2::new(0.4, 0.2), 0.05).unwrap()
        };
        let out = move_mesh_2d(&mesh, &phi, &next, &opts(200), 3).expect("step meshes");
        out.mesh.validate(Level::Geometry).unwrap_or_else(|e| panic!("step {step}: {e}"));
        let q = out.report.quality;
        let bdev = boundary_deviation(&out.mesh, &next) / H0;
        let a = trussmesh::mesher::area(&out.mesh);
        println!("| {step} | {} | {:.3} | {:.4} | {bdev:.1e} | {a:.4} |", q.vertices, q.q_min, q.q_mean);
        assert!(bdev <= 1e-3, "step {step}: boundary nodes {bdev} h0 off phi = 0");
        worst_min = worst_min.min(q.q_min);
        worst_mean = worst_mean.min(q.q_mean);
        mesh = out.mesh;
        phi = next;
    }
    // The region grew: the mesh's area follows the level set's.
    let inside = phi.values().iter().filter(|&&v| v < 0.0).count() as f64 * 0.02 * 0.02;
    let a = trussmesh::mesher::area(&mesh);
    println!("area {area0:.4} -> {a:.4} (grid cells inside: {inside:.4}); worst q min {worst_min:.3}, q mean {worst_mean:.4}");
    let lens: Vec<f64> = mesh.edge_ids().map(|h| mesh.edge_length(h) / H0).collect();
    let mean_len = lens.iter().sum::<f64>() / lens.len() as f64;
    println!("mean edge length {mean_len:.3} h0");
    assert!(a > area0 * 1.3, "the region grew");
    assert!((a - inside).abs() < 0.03 * inside, "mesh area {a} against the level set's {inside}");
    assert!(worst_min >= 0.5, "q min {worst_min}");
    assert!(worst_mean >= 0.95, "q mean {worst_mean}");
}
