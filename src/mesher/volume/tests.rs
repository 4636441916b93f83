//! Unit tests of the 3-D mesher: the star radius-ratio sum, the snapshot's refresh against a
//! rebuild, and the removal of specks.

use super::carve::{count_pieces, drop_specks};
use super::options::Options3;
use super::smoothing::{star_rr_sum, StarRr};
use super::snapshot::Snapshot;
use super::Ctx;
use crate::geometry::project::Projection;
use crate::mesher::truss::NodeKind;
use crate::mesher::Report;
use crate::topology::{Level, TVertexId, TetId, TetMesh, EDGE_VERTICES};
use glam::DVec3;

#[test]
fn star_rr_sums_the_radius_ratios() {
    let mut rng = crate::testing::Rng::new(crate::testing::SEED);
    for _ in 0..200 {
        let star: Vec<([DVec3; 4], usize)> =
            (0..5).map(|k| ([0; 4].map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64())), k % 4)).collect();
        let x = DVec3::new(rng.f64(), rng.f64(), rng.f64());
        let (fast, slow) = (StarRr::new(&star).sum(x), star_rr_sum(&star, x));
        assert!((fast - slow).abs() < 1e-9, "{fast} against {slow}");
    }
}

/// A snapshot in vertex keys: (vertex, kind, sorted neighbours) and (tet, corners).
type Keyed = (Vec<(TVertexId, NodeKind, Vec<TVertexId>)>, Vec<(TetId, [TVertexId; 4])>);

/// The snapshot in vertex keys, for comparing snapshots whose indices differ.
fn by_key(s: &Snapshot) -> Keyed {
    let mut verts: Vec<(TVertexId, NodeKind, Vec<TVertexId>)> = (0..s.ids.len())
        .filter(|&i| s.kind[i] != NodeKind::Dead)
        .map(|i| {
            let mut nb: Vec<TVertexId> =
                s.row(i).iter().filter(|&&j| j as usize != i).map(|&j| s.ids[j as usize]).collect();
            nb.sort_unstable();
            (s.ids[i], s.kind[i], nb)
        })
        .collect();
    verts.sort_unstable_by_key(|x| x.0);
    let tets = s.tet_ids.iter().zip(&s.tets).map(|(&t, v)| (t, v.map(|i| s.ids[i as usize]))).collect();
    (verts, tets)
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(crate::testing::SEED),
        ..proptest::test_runner::Config::default()
    })]

    /// Random operation sequences (flips, edge removals, splits, collapses, insertions,
    /// moves), the snapshot refreshed after every few: it always says what a rebuild says.
    #[test]
    fn refreshes_after_random_operations_equal_rebuilds(
        n in 8usize..40,
        seed in proptest::prelude::any::<u64>(),
        bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..400),
        every in 1usize..6,
    ) {
        let (mut m, _) = TetMesh::delaunay(&crate::testing::random_points_3d(n, seed)).expect("delaunay");
        m.tag_boundary_vertices();
        let mut snap = Snapshot::build(&m);
        m.open_journal();
        let mut u = arbitrary::Unstructured::new(&bytes);
        let mut k = 0;
        // (An exhausted input still yields default operations: stop on it.)
        while !u.is_empty() && k < 64 {
            let Ok(op) = u.arbitrary::<crate::testing::TetOp>() else { break };
            let _ = crate::testing::apply_tet_op(&mut m, op);
            k += 1;
            if k % every == 0 {
                let journal = m.take_journal().expect("open journal");
                if !snap.refresh(&m, &journal) {
                    snap = Snapshot::build(&m);
                }
                proptest::prop_assert_eq!(by_key(&snap), by_key(&Snapshot::build(&m)));
                m.open_journal();
            }
        }
    }
}

/// A context for the passes run alone on a hand-made mesh: uniform size, exact projection.
fn test_ctx<'a>(domain: &'a dyn crate::geometry::Implicit3, opts: &'a Options3) -> Ctx<'a> {
    Ctx {
        domain,
        opts,
        projection: Projection::Exact,
        h_floor: 1.0,
        report: Report::default(),
        rng: 1,
        trace: false,
        polish_worst: 0.0,
        fixed: Vec::new(),
        strict_folds: false,
        start_shift: 0.0,
    }
}

#[test]
fn a_cut_off_speck_is_dropped_and_the_rest_kept() {
    let mut rng = crate::testing::Rng::new(crate::testing::SEED);
    let mut pts: Vec<DVec3> = (0..200).map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64())).collect();
    let (del, _) = TetMesh::delaunay(&pts).expect("delaunay");
    let crate::topology::MeshArrays { points, cells: mut tets, .. } = del.to_arrays();
    pts = points;
    // A flat tet away from the rest, cut off from it.
    let n = pts.len();
    pts.extend([[3.0, 0.0, 0.0], [4.0, 0.0, 0.0], [3.0, 1.0, 0.0], [3.2, 0.2, 1e-3]].map(DVec3::from));
    tets.push([n, n + 1, n + 2, n + 3]);
    let (mut m, _) = TetMesh::from_arrays(&pts, &tets).expect("valid");
    m.tag_boundary_vertices();
    let domain = crate::geometry::Ball::new([0.0, 0.0, 0.0], 10.0);
    let opts = Options3::uniform(0.1, [-1.0; 3], [5.0; 3]);
    let ctx = test_ctx(&domain, &opts);
    let before = m.num_tets();
    assert_eq!(count_pieces(&m), 2);
    assert!(drop_specks(&ctx, &mut m).expect("no error"));
    assert_eq!((count_pieces(&m), m.num_tets(), m.num_vertices()), (1, before - 1, n));
    m.validate(Level::Geometry).expect("valid");
    // Nothing left to drop.
    assert!(!drop_specks(&ctx, &mut m).expect("no error"));
}

#[test]
fn a_refreshed_snapshot_equals_a_rebuilt_one() {
    let mut rng = crate::testing::Rng::new(crate::testing::SEED);
    let pts: Vec<DVec3> = (0..400).map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64())).collect();
    let (mut m, _) = TetMesh::delaunay(&pts).expect("delaunay");
    m.tag_boundary_vertices();
    let mut snap = Snapshot::build(&m);
    m.open_journal();
    // Tets taken off the boundary (which retag vertices) and 2-3 flips (each adds an edge).
    let (mut flips, mut removed) = (0, 0);
    let ids: Vec<TetId> = m.tet_ids().collect();
    for &t in &ids {
        if removed < 5 && m.check_remove_boundary_tet(t).is_ok_and(|f| f <= 2) {
            removed += usize::from(m.remove_boundary_tet(t).is_ok());
        }
    }
    for &t in &ids {
        if m.contains_tet(t) && (0..4).any(|i| m.flip23(t, i).is_ok()) {
            flips += 1;
        }
        if flips >= 40 {
            break;
        }
    }
    assert!(flips >= 40 && removed > 0, "{flips} flips, {removed} removals");
    let journal = m.take_journal().expect("open journal");
    assert!(!journal.vertices_changed);
    assert!(snap.refresh(&m, &journal));
    let fresh = Snapshot::build(&m);
    // Without a vertex added or removed, the indices are the rebuild's too.
    assert_eq!(snap.ids, fresh.ids);
    assert_eq!(snap.tets, fresh.tets);
    assert_eq!(by_key(&snap), by_key(&fresh));
    // Splits add vertices and collapses remove them: the journal says so, the refresh
    // appends and buries entries, and the snapshot still says what a rebuild says.
    m.open_journal();
    let (mut splits, mut collapses) = (0, 0);
    let ids: Vec<TetId> = m.tet_ids().collect();
    for (k, &t) in ids.iter().enumerate() {
        if !m.contains_tet(t) {
            continue;
        }
        let [a, b] = EDGE_VERTICES[k % 6].map(|i| m.pos(m.tet(t).v[i]));
        if k % 3 == 0 && splits < 10 {
            splits += usize::from(m.split_edge(t, k % 6, (a + b) * 0.5).is_ok());
        } else if k % 3 == 1 && collapses < 10 {
            collapses += usize::from(m.collapse(t, k % 6, false, b).is_ok());
        }
    }
    assert!(splits == 10 && collapses > 0, "{splits} splits, {collapses} collapses");
    let journal = m.take_journal().expect("open journal");
    assert!(journal.vertices_changed);
    assert!(snap.refresh(&m, &journal));
    m.validate(Level::Geometry).expect("valid");
    assert_eq!(by_key(&snap), by_key(&Snapshot::build(&m)));
}

/// A fixed point held by one flat cap alone, with a free boundary node just beside it (as a
/// crease point is left after removals at the boundary): the cap goes and the node takes the
/// point's place, fixed; a node too far away leaves the mesh as it was.
#[test]
fn a_lonely_fixed_point_is_reseated_on_the_node_beside_it() {
    use super::improve::reseat_lonely_fixed_points;
    use crate::quality::tet_dihedral_quality;
    use crate::topology::VertexTag;
    // The body B C D E, the cap A B C D (A just above B C D, beyond the edge B C) and W B C E
    // (W just below A).
    let build = |w: DVec3| {
        let pts = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.5, 1.0, 0.0),
            DVec3::new(0.5, 0.45, -0.6),
            DVec3::new(0.5, -0.08, 0.02),
            w,
        ];
        let orient = |t: [usize; 4]| {
            let p = t.map(|i| pts[i]);
            if (p[1] - p[0]).cross(p[2] - p[0]).dot(p[3] - p[0]) > 0.0 {
                t
            } else {
                [t[1], t[0], t[2], t[3]]
            }
        };
        let tets = [orient([0, 1, 2, 3]), orient([4, 0, 1, 2]), orient([5, 0, 1, 3])];
        let (mut m, ids) = TetMesh::from_arrays(&pts, &tets).expect("valid");
        m.tag_boundary_vertices();
        m.set_tag(ids[4], VertexTag::Fixed);
        (m, ids)
    };
    let domain = crate::geometry::Ball::new([0.0, 0.0, 0.0], 10.0);
    let opts = Options3::uniform(1.0, [-1.0; 3], [2.0; 3]);
    let ctx = || test_ctx(&domain, &opts);
    let (mut m, ids) = build(DVec3::new(0.5, -0.1, -0.01));
    let cap = m.vertex_tets(ids[4])[0];
    let cap_q = tet_dihedral_quality(m.tet_points(cap));
    assert!(cap_q < 0.2, "the cap is flat: tq {cap_q}");
    let a = m.pos(ids[4]);
    assert_eq!(reseat_lonely_fixed_points(&mut ctx(), &mut m).expect("no error"), 1);
    m.validate(Level::Geometry).expect("valid");
    assert!(!m.contains_vertex(ids[4]), "the lonely point's cap went with it");
    assert_eq!((m.pos(ids[5]), m.tag(ids[5])), (a, VertexTag::Fixed), "the node beside it holds the point");
    let worst = m.tet_ids().map(|t| tet_dihedral_quality(m.tet_points(t))).fold(f64::INFINITY, f64::min);
    assert!(worst > cap_q, "worst tq {worst} against the cap's {cap_q}");
    // Beyond the reach (0.3 h0): nothing changes.
    let (mut far, fids) = build(DVec3::new(0.5, -0.6, -0.2));
    let before = far.to_arrays();
    assert_eq!(reseat_lonely_fixed_points(&mut ctx(), &mut far).expect("no error"), 0);
    assert_eq!(far.to_arrays(), before);
    assert_eq!(far.tag(fids[4]), VertexTag::Fixed);
}
