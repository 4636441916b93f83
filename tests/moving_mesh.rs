//! Moving meshes (seed section 5.1, figure 5-2): a circular hole travels through a rectangle;
//! every step starts from the previous mesh.

use std::collections::HashSet;
use trussmesh::geometry::{difference, Circle, Rectangle};
use trussmesh::mesher::{mesh_2d, move_mesh_2d, remesh_2d, Options2};
use trussmesh::topology::Level;
use trussmesh::Error;

const STEP_ITER: usize = 200;

fn opts(max_iter: usize) -> Options2 {
    Options2::uniform(0.08, [-1.0, -0.5], [1.0, 0.5])
        .with_fixed([[-1.0, -0.5], [1.0, -0.5], [1.0, 0.5], [-1.0, 0.5]])
        .with_max_iter(max_iter)
}

fn domain(xc: f64) -> impl trussmesh::geometry::Implicit2 {
    difference(Rectangle::new([-1.0, -0.5], [1.0, 0.5]), Circle::new([xc, 0.0], 0.25))
}

/// Runs the 100 steps, without freezing or with freezing past `rings` rings; prints the table
/// and returns the most nodes moved in a step and the first step (if any) below q min 0.5 or
/// q mean 0.95.
fn hundred_steps(rings: Option<usize>) -> (f64, Option<(usize, f64, f64)>) {
    let mut mesh = mesh_2d(&domain(-0.5), &opts(1000)).unwrap().mesh;
    let (mut worst_min, mut worst_mean, mut total_s, mut max_moved) = (1.0f64, 1.0f64, 0.0, 0.0f64);
    let mut failure = None;
    for step in 1..=100 {
        let (x0, x1) = (-0.5 + (step - 1) as f64 * 0.01, -0.5 + step as f64 * 0.01);
        let before: HashSet<(u64, u64)> =
            mesh.vertices().map(|(_, v)| (v.pos.x.to_bits(), v.pos.y.to_bits())).collect();
        let out = match rings {
            None => remesh_2d(&mesh, &domain(x1), &opts(STEP_ITER)),
            Some(r) => move_mesh_2d(&mesh, &domain(x0), &domain(x1), &opts(STEP_ITER), r),
        }
        .unwrap();
        out.mesh.validate(Level::Geometry).unwrap_or_else(|e| panic!("step {step}: {e}"));
        let q = out.report.quality;
        let moved =
            out.mesh.vertices().filter(|(_, v)| !before.contains(&(v.pos.x.to_bits(), v.pos.y.to_bits()))).count()
                as f64
                / out.mesh.num_vertices() as f64;
        worst_min = worst_min.min(q.q_min);
        worst_mean = worst_mean.min(q.q_mean);
        max_moved = max_moved.max(moved);
        total_s += out.report.seconds;
        if step % 20 == 0 {
            println!(
                "step {step}: {} nodes, q min {:.3}, q mean {:.4}, {:.0}% of nodes moved, {:.3} s",
                q.vertices,
                q.q_min,
                q.q_mean,
                100.0 * moved,
                out.report.seconds
            );
        }
        if failure.is_none() && (q.q_min < 0.5 || q.q_mean < 0.95) {
            failure = Some((step, q.q_min, q.q_mean));
        }
        mesh = out.mesh;
    }
    println!("| steps | freezing | worst q min | worst q mean | most nodes moved in a step | mean time per step (s) |");
    println!(
        "| 100 | {} | {worst_min:.3} | {worst_mean:.4} | {:.0}% | {:.4} |",
        rings.map_or("none".to_string(), |r| format!("{r} ring(s)")),
        100.0 * max_moved,
        total_s / 100.0
    );
    (max_moved, failure)
}

#[test]
fn hole_moves_through_a_rectangle_in_100_steps() {
    let (_, failure) = hundred_steps(None);
    if let Some((step, qmin, qmean)) = failure {
        panic!("step {step}: q min {qmin:.3}, q mean {qmean:.4}");
    }
}

/// Issue 10's target: with freezing past one ring of the motion, fewer than 30% of the nodes
/// move in any step, and every step keeps q min >= 0.5 and q mean >= 0.95. Measured:
///
/// | steps | freezing | worst q min | worst q mean | most nodes moved in a step | mean time per step (s) |
/// |---|---|---|---|---|---|
/// | 100 | 1 ring(s) | 0.673 | 0.9739 | 26% | 0.0026 |
///
/// (The node count stays between 328 and 337; without freezing it grows from 340 to 400.)
#[test]
fn hole_moves_with_freezing() {
    let (max_moved, failure) = hundred_steps(Some(1));
    assert!(max_moved < 0.3, "{:.0}% of nodes moved in one step", 100.0 * max_moved);
    if let Some((step, qmin, qmean)) = failure {
        panic!("step {step}: q min {qmin:.3}, q mean {qmean:.4}");
    }
}

#[test]
fn remeshing_an_invalid_mesh_is_an_error() {
    use glam::DVec2;
    use trussmesh::topology::TriMesh;
    // Two triangles, one of them clockwise (inverted).
    let p = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0), DVec2::new(1.0, 1.0)];
    let (m, _) = TriMesh::from_arrays(&p, &[[0, 1, 2], [1, 3, 2]]).unwrap();
    let (mut bad, ids) = (m.clone(), m.vertex_ids().collect::<Vec<_>>());
    bad.set_pos_unchecked(ids[3], DVec2::new(-1.0, -1.0));
    let e = remesh_2d(&bad, &domain(0.0), &opts(10)).unwrap_err();
    assert!(matches!(e, Error::InvalidMesh(_)), "{e}");
    assert!(e.to_string().contains("inverted"), "{e}");
}
