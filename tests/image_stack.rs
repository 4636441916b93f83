//! Meshing a 3-D image (seed section 5.3): a synthetic stack of slices (two overlapping
//! balls, drawn voxel by voxel) to a signed distance by smoothing and fast marching, then
//! meshed as a surface and as a volume.

use glam::DVec3;
use trussmesh::mesher::image::stack_distance;
use trussmesh::mesher::{mesh_3d, Options3};
use trussmesh::surface::{mesh_surface, SurfaceOptions};
use trussmesh::topology::{Level, VertexTag};

const N: [usize; 3] = [48, 40, 36];
const C1: [f64; 3] = [19.0, 20.0, 18.0];
const R1: f64 = 10.0;
const C2: [f64; 3] = [31.0, 21.0, 18.0];
const R2: f64 = 7.0;

/// The true signed distance of the union of the two balls (exact outside).
fn truth(p: DVec3) -> f64 {
    (p.distance(DVec3::from(C1)) - R1).min(p.distance(DVec3::from(C2)) - R2)
}

/// The stack: 1 where the voxel centre lies in a ball, 0 elsewhere.
fn stack() -> Vec<f64> {
    let mut v = Vec::with_capacity(N[0] * N[1] * N[2]);
    for k in 0..N[2] {
        for j in 0..N[1] {
            for i in 0..N[0] {
                let p = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5);
                v.push(if truth(p) < 0.0 { 1.0 } else { 0.0 });
            }
        }
    }
    v
}

/// Volume of the union: both balls minus their lens.
fn exact_volume() -> f64 {
    let d = DVec3::from(C1).distance(DVec3::from(C2));
    let ball = |r: f64| 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    let lens = std::f64::consts::PI
        * (R1 + R2 - d).powi(2)
        * (d * d + 2.0 * d * R2 - 3.0 * R2 * R2 + 2.0 * d * R1 + 6.0 * R1 * R2 - 3.0 * R1 * R1)
        / (12.0 * d);
    ball(R1) + ball(R2) - lens
}

#[test]
fn a_stack_meshed_as_a_surface() {
    let phi = stack_distance(&stack(), N[0], N[1], N[2], 0.5).expect("distance");
    let bbox = [DVec3::splat(-2.0), DVec3::new(N[0] as f64 + 2.0, N[1] as f64 + 2.0, N[2] as f64 + 2.0)];
    let out = mesh_surface(&phi, &SurfaceOptions::uniform(2.0, bbox[0], bbox[1])).expect("surface meshes");
    let q = &out.report.quality;
    let worst = out.mesh.vertices().map(|(_, v)| truth(v.pos).abs()).fold(0.0, f64::max);
    println!(
        "stack surface: {} vertices, Euler {}, min angle {:.1}, mean q {:.4}, worst distance to the true boundary {worst:.3} voxels",
        q.vertices, q.euler, q.min_angle, q.mean_q
    );
    assert!(q.closed_manifold && q.inward_faces == 0);
    assert_eq!(q.euler, 2, "one closed surface of genus 0");
    assert!(worst <= 1.0, "every vertex within one voxel of the true boundary, worst {worst}");
    assert!(q.mean_q >= 0.95, "mean q {}", q.mean_q);
}

#[test]
fn a_stack_meshed_as_a_volume() {
    let phi = stack_distance(&stack(), N[0], N[1], N[2], 0.5).expect("distance");
    let opts = Options3::uniform(2.0, [-2.0, -2.0, -2.0], [N[0] as f64 + 2.0, N[1] as f64 + 2.0, N[2] as f64 + 2.0]);
    let out = mesh_3d(&phi, &opts).expect("volume meshes");
    out.mesh.validate(Level::Geometry).expect("valid, every tetrahedron positive");
    let trussmesh::topology::MeshArrays { points: pts, cells: tets, .. } = out.mesh.to_arrays();
    let vol: f64 = tets
        .iter()
        .map(|t| {
            let [a, b, c, d] = t.map(|i| pts[i]);
            (b - a).dot((c - a).cross(d - a)) / 6.0
        })
        .sum();
    let exact = exact_volume();
    let mut worst: f64 = 0.0;
    for v in out.mesh.vertex_ids() {
        if out.mesh.tag(v) == VertexTag::Boundary {
            worst = worst.max(truth(out.mesh.pos(v)).abs());
        }
    }
    let q = out.report.quality;
    println!(
        "stack volume: {} nodes, {} tets, dihedral {:.1} to {:.1}, radius ratio mean {:.3}, volume {vol:.0} (exact {exact:.0}, {:+.2}%), boundary nodes within {worst:.3} voxels of the true boundary",
        q.vertices, q.tets, q.dihedral_min, q.dihedral_max, q.rr_mean, 100.0 * (vol - exact) / exact
    );
    assert!(vol > 0.0 && ((vol - exact) / exact).abs() < 0.05, "volume {vol} against {exact}");
    assert!(worst <= 1.0, "boundary nodes within one voxel of the true boundary, worst {worst}");
    assert!(q.dihedral_min > 10.0, "min dihedral {}", q.dihedral_min);
}
