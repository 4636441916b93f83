//! Surface remeshing of a wide family of turned boxes (random rotations and sides, four sizes):
//! every run ends in a valid closed surface, and a run either holds the box's 12 edges and 8
//! corners or says plainly in its report that it rounded them. Prints the table
//! (`cargo test --release --test trisurf_boxes -- --nocapture`).

use trussmesh::geometry::TriSurface;
use trussmesh::io::MeshData;
use trussmesh::mesh_surface;
use trussmesh::testing::Rng;

mod trisurf_inputs;
use trisurf_inputs::{feature_gap, random_turned_box, BOX_SEED};

const SIZES: [f64; 4] = [0.08, 0.1, 0.12, 0.15];

/// One row: (held, min angle), after checking what every run must give.
fn row(k: usize, surf: &TriSurface, h0: f64) -> (bool, f64) {
    let out = mesh_surface(surf, &surf.surface_options(h0)).unwrap_or_else(|e| panic!("turned box {k}, h0 {h0}: {e}"));
    let q = &out.report.quality;
    assert!(q.closed_manifold && q.inward_faces == 0 && q.euler == 2, "turned box {k}, h0 {h0}: {q:?}");
    let remeshed = TriSurface::from_mesh_data(&MeshData::from_trimesh3(&out.mesh)).expect("a valid closed surface");
    let (gap, corners) = feature_gap(surf, &remeshed, h0);
    let rounded = out.report.notes.iter().any(|n| n.contains("rounds them"));
    println!(
        "| {k} | {h0} | {} | {:.1} | {:.4} | {:.1}% | {gap:.3} | {corners} | {} |",
        q.triangles,
        q.min_angle,
        q.mean_q,
        100.0 * q.size_deviation,
        if rounded { "rounded (said so)" } else { "held" }
    );
    // Held means held: every input edge within 0.06 h of an output feature edge, 8 corners.
    assert!(rounded || (gap <= 0.06 && corners == 8), "turned box {k}, h0 {h0}: features lost silently");
    (!rounded, q.min_angle)
}

const HEADER: &str = "| box | h0 | triangles | min angle | mean q | size dev | feature gap / h0 | corners | features |\n|---|---|---|---|---|---|---|---|---|";

/// Eight boxes at four sizes: no failure, no silent loss of features, and the angle
/// target on the whole wide family: features held and min angle 30 degrees or more in every
/// run. Reached since held runs flip after their last projection (box 0 at h0 0.08 had 28.0
/// degrees: a triangle with its three corners on a rim, flattened when they were put onto it;
/// 30.4 now).
#[test]
fn turned_boxes_reach_30_degrees_with_features_held() {
    println!("{HEADER}");
    let mut rng = Rng::new(BOX_SEED);
    let boxes: Vec<TriSurface> = (0..8).map(|_| random_turned_box(&mut rng)).collect();
    let mut failed = Vec::new();
    for &h0 in &SIZES {
        for (k, surf) in boxes.iter().enumerate() {
            let (held, min_angle) = row(k, surf, h0);
            if !held || min_angle < 30.0 {
                failed.push(format!("box {k} at h0 {h0}"));
            }
        }
    }
    assert!(failed.is_empty(), "{failed:?}");
}
