//! The half-edge engine: exact topology after each operation on named fixtures, property tests
//! over random operation sequences, the fuzz corpus, and the spade Delaunay oracle.

use glam::DVec2;
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use trussmesh::testing::{
    self, apply_op, check_ops, grid, random_points, single_triangle, two_triangles, vertex_onering, Op,
};
use trussmesh::topology::{Level, Refusal, TriMesh, VertexTag};

fn edge(m: &TriMesh<DVec2>, a: usize, b: usize) -> trussmesh::topology::HalfEdgeId {
    let ids: Vec<_> = m.vertex_ids().collect();
    m.find_half_edge(ids[a], ids[b]).expect("edge exists")
}

#[test]
fn flip_two_triangles() {
    let mut m = two_triangles();
    let h = edge(&m, 0, 1);
    m.flip(h).unwrap();
    m.validate(Level::Geometry).unwrap();
    let ids: Vec<_> = m.vertex_ids().collect();
    assert!(m.find_half_edge(ids[0], ids[1]).is_none());
    assert!(m.find_half_edge(ids[2], ids[3]).is_some());
    assert_eq!((m.num_vertices(), m.num_edges(), m.num_faces()), (4, 5, 2));
    // Flipping back restores the diagonal.
    m.flip(h).unwrap();
    assert!(m.find_half_edge(ids[0], ids[1]).is_some());
}

#[test]
fn flip_refusals() {
    let mut m = single_triangle();
    let h = edge(&m, 0, 1);
    assert_eq!(m.flip(h), Err(Refusal::BoundaryEdge));
    // A non-convex quad: flipping would invert.
    let p = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(-0.5, 0.3), DVec2::new(-0.5, -0.3)];
    let (mut m, _) = TriMesh::from_arrays(&p, &[[0, 1, 2], [1, 0, 3]]).unwrap();
    let before = m.clone();
    let h = edge(&m, 0, 1);
    assert_eq!(m.flip(h), Err(Refusal::WouldInvert));
    assert!(m == before);
    // Collinear: a, c, d on a line makes a zero-area triangle.
    let p = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0), DVec2::new(0.0, -1.0)];
    let (mut m, _) = TriMesh::from_arrays(&p, &[[0, 1, 2], [1, 0, 3]]).unwrap();
    let h = edge(&m, 0, 1);
    assert_eq!(m.flip(h), Err(Refusal::WouldDegenerate));
    // Different labels: an internal boundary.
    let mut m = two_triangles();
    let f = m.face_ids().next().unwrap();
    m.set_label(f, 7);
    let h = edge(&m, 0, 1);
    assert_eq!(m.flip(h), Err(Refusal::Constrained));
}

#[test]
fn split_interior_and_boundary() {
    let mut m = two_triangles();
    let h = edge(&m, 0, 1);
    let v = m.split_edge(h, DVec2::new(0.5, 0.0)).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!((m.num_vertices(), m.num_faces()), (5, 4));
    assert_eq!(m.valence(v), 4);
    assert_eq!(m.tag(v), VertexTag::Interior);
    assert!(!m.is_boundary_vertex(v));

    let mut m = single_triangle();
    let h = edge(&m, 1, 2);
    let v = m.split_edge(h, DVec2::new(0.65, 0.4)).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!((m.num_vertices(), m.num_faces(), m.num_edges()), (4, 2, 5));
    assert_eq!(m.tag(v), VertexTag::Boundary);
    assert!(m.is_boundary_vertex(v));
    assert_eq!(m.boundary_loops()[0].len(), 4);
    // The boundary twin direction too.
    let mut m = single_triangle();
    let h = m.twin(edge(&m, 1, 2));
    m.split_edge(h, DVec2::new(0.65, 0.4)).unwrap();
    m.validate(Level::Geometry).unwrap();
    // A split point off the edge that would invert is refused.
    let mut m = single_triangle();
    let before = m.clone();
    let h = edge(&m, 0, 1);
    assert_eq!(m.split_edge(h, DVec2::new(0.5, 2.0)), Err(Refusal::WouldInvert));
    assert!(m == before);
}

#[test]
fn collapse_interior_vertex_of_onering() {
    let mut m = vertex_onering(6);
    let ids: Vec<_> = m.vertex_ids().collect();
    let h = m.find_half_edge(ids[0], ids[1]).unwrap();
    let b = m.collapse(h, m.pos(ids[1])).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!(b, ids[1]);
    assert_eq!((m.num_vertices(), m.num_faces()), (6, 4));
    assert_eq!(m.euler_characteristic(), 1);
}

#[test]
fn collapse_refusals() {
    // Boundary vertex into interior vertex: protected.
    let mut m = vertex_onering(6);
    let ids: Vec<_> = m.vertex_ids().collect();
    for &v in &ids[1..] {
        m.set_tag(v, VertexTag::Boundary);
    }
    let h = m.find_half_edge(ids[1], ids[0]).unwrap();
    assert_eq!(m.collapse(h, m.pos(ids[0])), Err(Refusal::Protected(VertexTag::Boundary)));
    // Fixed vertex never goes.
    m.set_tag(ids[0], VertexTag::Fixed);
    let h = m.find_half_edge(ids[0], ids[1]).unwrap();
    assert_eq!(m.collapse(h, m.pos(ids[1])), Err(Refusal::Protected(VertexTag::Fixed)));
    // Valence-3 ring: collapsing the centre along one spoke fails the link condition? No: it
    // leaves one triangle; collapsing a boundary edge of a lone triangle is too small.
    let mut m = single_triangle();
    let h = edge(&m, 0, 1);
    let before = m.clone();
    assert_eq!(m.collapse(h, m.pos(m.dest(h))), Err(Refusal::TooSmall));
    assert!(m == before);
    // Interior edge joining two boundary vertices pinches.
    let m = grid(2, 1, 0.0, 1);
    let before = m.clone();
    let mut refused = 0;
    for h in m.half_edge_ids().collect::<Vec<_>>() {
        if !m.is_boundary_edge(h) {
            assert_eq!(m.check_collapse(h, m.pos(m.dest(h))).err(), Some(Refusal::LinkCondition));
            refused += 1;
        }
    }
    assert!(refused > 0);
    assert!(m == before);
}

#[test]
fn collapse_along_boundary() {
    let mut m = grid(3, 3, 0.0, 1);
    for v in m.vertex_ids().collect::<Vec<_>>() {
        if m.is_boundary_vertex(v) {
            m.set_tag(v, VertexTag::Boundary);
        }
    }
    // Collapse a boundary edge between two non-corner boundary vertices on the bottom side.
    let ids: Vec<_> = m.vertex_ids().collect();
    let h = m.find_half_edge(ids[1], ids[2]).unwrap();
    let target = m.pos(ids[2]);
    m.collapse(h, target).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!(m.num_vertices(), 15);
    assert_eq!(m.boundary_loops().len(), 1);
    assert_eq!(m.boundary_loops()[0].len(), 11);
}

#[test]
fn insert_and_relocate() {
    let mut m = single_triangle();
    let f = m.face_ids().next().unwrap();
    let v = m.insert_in_face(f, DVec2::new(0.4, 0.3)).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!((m.num_vertices(), m.num_faces(), m.valence(v)), (4, 3, 3));
    assert_eq!(m.relocate(v, DVec2::new(0.45, 0.25)), Ok(()));
    let before = m.clone();
    assert_eq!(m.relocate(v, DVec2::new(5.0, 5.0)), Err(Refusal::WouldInvert));
    assert_eq!(m.relocate(v, DVec2::new(f64::NAN, 0.0)), Err(Refusal::NonFinite));
    assert!(m == before);
    let f = m.face_ids().next().unwrap();
    assert!(matches!(m.insert_in_face(f, DVec2::new(50.0, 1.0)), Err(Refusal::WouldInvert | Refusal::WouldDegenerate)));
    assert!(m == before);
}

/// Small meshes with open fans: a 320-degree fan, a thin notch, grids, a Delaunay mesh, a ring.
fn small_meshes() -> Vec<(&'static str, TriMesh<DVec2>)> {
    // An open fan turning by 320 degrees (five ring points at 80-degree steps).
    let mut p = vec![DVec2::ZERO];
    let mut t = Vec::new();
    for k in 0..5 {
        let a = (80.0 * k as f64).to_radians();
        let r = 1.0 + 0.1 * k as f64;
        p.push(DVec2::new(r * a.cos(), r * a.sin()));
        if k > 0 {
            t.push([0, k, k + 1]);
        }
    }
    let fan = TriMesh::from_arrays(&p, &t).unwrap().0;
    // A U whose notch is a gap 0.1 wide and 1 deep: its sides are far apart along the boundary.
    let xs = [0.0, 1.0, 1.1, 2.1];
    let p: Vec<DVec2> = (0..3).flat_map(|r| xs.iter().map(move |&x| DVec2::new(x, r as f64))).collect();
    let mut t = Vec::new();
    for r in 0..2 {
        for c in 0..3 {
            if (c, r) != (1, 1) {
                let (a, b, d, e) = (r * 4 + c, r * 4 + c + 1, r * 4 + c + 5, r * 4 + c + 4);
                t.extend([[a, b, d], [a, d, e]]);
            }
        }
    }
    let notch = TriMesh::from_arrays(&p, &t).unwrap().0;
    vec![
        ("notch", notch),
        ("fan 320", fan),
        ("grid 2x2", grid(2, 2, 0.2, 5)),
        ("grid 3x1", grid(3, 1, 0.2, 9)),
        ("delaunay 10", TriMesh::delaunay(&random_points(10, 3)).unwrap().0),
        ("onering 5", vertex_onering(5)),
    ]
}

/// A collapse the engine accepts leaves a valid embedding: every half-edge of the small meshes
/// collapsed to every point of a lattice. Without the fan checks, a collapse at the boundary
/// could fold the merged vertex's open fan or a boundary neighbour's.
#[test]
fn accepted_collapses_keep_the_embedding() {
    println!("{:>12} {:>9} {:>9} {:>9}", "mesh", "tries", "accepted", "invalid");
    for (name, m) in small_meshes() {
        let (lo, hi) =
            m.vertex_ids().map(|v| m.pos(v)).fold((DVec2::MAX, DVec2::MIN), |(a, b), q| (a.min(q), b.max(q)));
        let (lo, hi) = (lo - (hi - lo) * 0.5, hi + (hi - lo) * 0.5);
        let n = 24;
        let (mut tries, mut accepted, mut invalid) = (0, 0, 0);
        for h in m.half_edge_ids().collect::<Vec<_>>() {
            for i in 0..=n {
                for j in 0..=n {
                    let q = lo + (hi - lo) * DVec2::new(i as f64, j as f64) / n as f64;
                    let mut c = m.clone();
                    tries += 1;
                    if c.collapse(h, q).is_ok() {
                        accepted += 1;
                        invalid += c.validate(Level::Geometry).is_err() as usize;
                    }
                }
            }
        }
        println!("{name:>12} {tries:>9} {accepted:>9} {invalid:>9}");
        assert_eq!(invalid, 0, "{name}: {invalid} accepted collapses left an invalid mesh");
        assert!(accepted > 0);
    }
}

/// `relocate` accepts exactly the moves after which the mesh is still a valid embedding:
/// every vertex of a few small meshes is tried at every point of a lattice over (and past) the
/// mesh, and the answer is compared with `validate` on the moved mesh. Among the lattice moves
/// are some that keep every triangle positive and still fold an open fan at the boundary (the
/// moved vertex's own or a boundary neighbour's), or lay the moved star over the far side of
/// a thin notch: the count of those is printed and must be positive, so the test exercises
/// the fold checks.
#[test]
fn relocate_accepts_exactly_the_embedding_moves() {
    let meshes = small_meshes();
    println!("{:>12} {:>9} {:>9} {:>13} {:>9}", "mesh", "moves", "accepted", "positive bad", "mismatch");
    let mut folds = 0;
    for (name, m) in meshes {
        m.validate(Level::Geometry).unwrap();
        let (lo, hi) =
            m.vertex_ids().map(|v| m.pos(v)).fold((DVec2::MAX, DVec2::MIN), |(a, b), q| (a.min(q), b.max(q)));
        let (lo, hi) = (lo - (hi - lo) * 0.5, hi + (hi - lo) * 0.5);
        let n = 60;
        let (mut moves, mut accepted, mut positive_fold, mut mismatch) = (0, 0, 0, 0);
        for v in m.vertex_ids().collect::<Vec<_>>() {
            for i in 0..=n {
                for j in 0..=n {
                    let q = lo + (hi - lo) * DVec2::new(i as f64, j as f64) / n as f64;
                    let mut moved = m.clone();
                    moved.set_pos_unchecked(v, q);
                    let positive =
                        moved.face_ids().all(|f| moved.face_orientation(f) == trussmesh::predicates::Sign::Positive);
                    let valid = moved.validate(Level::Geometry).is_ok();
                    let ok = m.check_relocate(v, q).is_ok();
                    moves += 1;
                    accepted += ok as usize;
                    positive_fold += (positive && !valid) as usize;
                    mismatch += (ok != valid) as usize;
                }
            }
        }
        println!("{name:>12} {moves:>9} {accepted:>9} {positive_fold:>13} {mismatch:>9}");
        assert_eq!(mismatch, 0, "{name}: relocate's answer differs from validate's on {mismatch} moves");
        folds += positive_fold;
    }
    assert!(folds > 0, "no lattice move kept the triangles positive and folded a fan");
}

#[test]
fn arrays_round_trip() {
    let m = grid(4, 3, 0.2, 3);
    let trussmesh::topology::MeshArrays { points: p, cells: t, labels, .. } = m.to_arrays();
    assert_eq!(labels.len(), t.len());
    let (m2, _) = TriMesh::from_arrays(&p, &t).unwrap();
    assert_eq!(m2.to_arrays().cells, t);
    assert_eq!(m2.euler_characteristic(), 1);
    // Bad arrays are typed errors.
    assert!(TriMesh::from_arrays(&p, &[[0, 1, 99]]).is_err());
    assert!(TriMesh::<DVec2>::from_arrays(&p[..3], &[[0, 1, 1]]).is_err());
    assert!(TriMesh::from_arrays(&p[..4], &[[0, 1, 2]]).is_err()); // unused point 3
    let bowtie = [
        DVec2::new(0.0, 0.0),
        DVec2::new(1.0, 0.0),
        DVec2::new(0.0, 1.0),
        DVec2::new(-1.0, 0.0),
        DVec2::new(0.0, -1.0),
    ];
    assert!(TriMesh::from_arrays(&bowtie, &[[0, 1, 2], [0, 3, 4]]).is_err());
    // A side used twice in the same direction names the later triangle.
    let square = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0)];
    let err = TriMesh::from_arrays(&square, &[[0, 1, 2], [0, 2, 3], [0, 1, 3]]).unwrap_err().to_string();
    assert!(err.contains("edge 0-1 is used twice") && err.contains("triangle 2"), "{err}");
}

#[test]
fn a_wide_fan_builds() {
    // 100 000 triangles around one centre vertex: twins are found by binary search in the
    // centre's sorted half-edge list, not by a scan per side.
    let k = 100_000;
    let mut p = vec![DVec2::ZERO];
    p.extend((0..k).map(|i| {
        let a = std::f64::consts::TAU * i as f64 / k as f64;
        DVec2::new(a.cos(), a.sin())
    }));
    let t: Vec<[usize; 3]> = (0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect();
    let (m, _) = TriMesh::from_arrays(&p, &t).unwrap();
    assert_eq!(m.num_faces(), k);
    assert_eq!(m.euler_characteristic(), 1);
    m.validate(Level::Topology).unwrap();
}

#[test]
fn lawson_flips_reach_delaunay() {
    let mut m = grid(8, 8, 0.35, 11);
    assert!(m.validate_delaunay().is_err(), "the jittered grid starts non-Delaunay");
    let flips = m.make_delaunay();
    assert!(flips > 0);
    m.validate_delaunay().unwrap();
}

#[test]
fn replay_fuzz_corpus() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/trimesh_ops");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let data = std::fs::read(e.unwrap().path()).unwrap();
        testing::run_ops(&data);
        n += 1;
    }
    assert!(n >= 10, "corpus has {n} files");
}

#[test]
fn deterministic_random_sequences() {
    // Thousands of random sequences, deterministic so failures reproduce.
    let mut r = testing::Rng::new(testing::SEED);
    for round in 0..1500 {
        let len = 10 + (r.next_u64() % 300) as usize;
        let data: Vec<u8> = (0..len).map(|_| r.next_u64() as u8).collect();
        let result = std::panic::catch_unwind(|| testing::run_ops(&data));
        assert!(result.is_ok(), "round {round} failed; bytes {data:?}");
    }
}

fn op_strategy() -> impl Strategy<Value = Op> {
    prop_oneof![
        any::<u16>().prop_map(Op::Flip),
        (any::<u16>(), any::<u8>()).prop_map(|(k, t)| Op::Split(k, t)),
        (any::<u16>(), any::<u8>()).prop_map(|(k, t)| Op::Collapse(k, t)),
        (any::<u16>(), any::<u8>(), any::<u8>()).prop_map(|(k, u, v)| Op::Insert(k, u, v)),
        (any::<u16>(), any::<i8>(), any::<i8>()).prop_map(|(k, x, y)| Op::Relocate(k, x, y)),
        Just(Op::Delaunay),
        any::<u16>().prop_map(Op::RemoveBoundaryTriangle),
        any::<u16>().prop_map(Op::FillEar),
        any::<u16>().prop_map(Op::RemoveEar),
    ]
}

proptest! {
    // A fixed seed: CI runs the same cases every time (failures are kept in the regressions file).
    #![proptest_config(ProptestConfig { cases: 512, rng_seed: RngSeed::Fixed(testing::SEED), ..ProptestConfig::default() })]

    #[test]
    fn random_ops_keep_mesh_valid(n in 3usize..60, seed in any::<u64>(), ops in proptest::collection::vec(op_strategy(), 1..120)) {
        let (mut m, _) = TriMesh::delaunay(&random_points(n, seed)).unwrap();
        m.validate(Level::Geometry).unwrap();
        check_ops(&mut m, &ops);
    }

    #[test]
    fn random_ops_on_grids(nx in 1usize..6, ny in 1usize..6, seed in any::<u64>(), ops in proptest::collection::vec(op_strategy(), 1..120)) {
        // Jitter 0.2 of a cell keeps every starting triangle positive (0.3 can invert one).
        let mut m = grid(nx, ny, 0.2, seed);
        m.validate(Level::Geometry).unwrap();
        check_ops(&mut m, &ops);
        // Split-only growth then Delaunay keeps the Delaunay invariant.
        let _ = apply_op(&mut m, Op::Delaunay);
        m.validate_delaunay().unwrap();
    }
}

fn spade_edges(points: &[DVec2]) -> std::collections::BTreeSet<(u64, u64, u64, u64)> {
    use spade::{DelaunayTriangulation, Point2, Triangulation};
    let pts: Vec<Point2<f64>> = points.iter().map(|p| Point2::new(p.x, p.y)).collect();
    let t = DelaunayTriangulation::<Point2<f64>>::bulk_load(pts).unwrap();
    t.undirected_edges()
        .map(|e| {
            let [a, b] = e.positions();
            key(DVec2::new(a.x, a.y), DVec2::new(b.x, b.y))
        })
        .collect()
}

fn key(a: DVec2, b: DVec2) -> (u64, u64, u64, u64) {
    let (a, b) = if (a.x, a.y) < (b.x, b.y) { (a, b) } else { (b, a) };
    (a.x.to_bits(), a.y.to_bits(), b.x.to_bits(), b.y.to_bits())
}

#[test]
fn delaunay_matches_spade() {
    for (i, &n) in [100usize, 1000, 10_000, 100_000].iter().enumerate() {
        let pts = random_points(n, testing::SEED + i as u64);
        let (m, _) = TriMesh::delaunay(&pts).unwrap();
        if n <= 10_000 {
            m.validate_delaunay().unwrap();
        } else {
            m.validate(Level::Topology).unwrap();
        }
        let ours: std::collections::BTreeSet<_> =
            m.edge_ids().map(|h| key(m.pos(m.origin(h)), m.pos(m.dest(h)))).collect();
        let theirs = spade_edges(&pts);
        println!("n = {n}: {} edges, spade {}", ours.len(), theirs.len());
        assert_eq!(ours.len(), theirs.len(), "edge count differs for n = {n}");
        assert!(ours == theirs, "edge sets differ for n = {n}");
        assert_eq!(m.num_vertices(), n);
    }
}

#[test]
fn delaunay_on_grid_points_and_duplicates() {
    // Cocircular grid points and duplicates: still a valid Delaunay triangulation of the hull.
    let mut pts = Vec::new();
    for j in 0..20 {
        for i in 0..20 {
            pts.push(DVec2::new(i as f64, j as f64));
        }
    }
    pts.push(DVec2::new(3.0, 3.0));
    let (m, ids) = TriMesh::delaunay(&pts).unwrap();
    m.validate_delaunay().unwrap();
    assert_eq!(m.num_vertices(), 400);
    assert_eq!(ids[400], ids[3 * 20 + 3]);
    assert_eq!(m.num_faces(), 2 * 19 * 19);
    assert!(TriMesh::delaunay(&[DVec2::ZERO, DVec2::X]).is_err());
    assert!(TriMesh::delaunay(&[DVec2::ZERO, DVec2::X, DVec2::new(f64::NAN, 0.0)]).is_err());
}

#[test]
fn remove_boundary_ear_peels_a_flat_ear() {
    // a, v, c nearly on a line below the chord a-c, w above it: the ear (a, v, c) goes.
    let p = [DVec2::new(0.0, 0.0), DVec2::new(1.0, -1e-3), DVec2::new(2.0, 0.0), DVec2::new(1.0, 1.0)];
    let (mut m, ids) = TriMesh::from_arrays(&p, &[[0, 1, 2], [0, 2, 3]]).unwrap();
    assert_eq!(m.remove_boundary_ear(ids[1]), Err(Refusal::Protected(VertexTag::Interior)));
    for &v in &ids {
        m.set_tag(v, VertexTag::Boundary);
    }
    // A vertex with two triangles is no ear.
    let before = m.clone();
    assert_eq!(m.remove_boundary_ear(ids[0]), Err(Refusal::LinkCondition));
    assert!(m == before);
    m.set_tag(ids[1], VertexTag::Fixed);
    assert_eq!(m.remove_boundary_ear(ids[1]), Err(Refusal::Protected(VertexTag::Fixed)));
    m.set_tag(ids[1], VertexTag::Boundary);
    m.remove_boundary_ear(ids[1]).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!((m.num_vertices(), m.num_faces()), (3, 1));
    assert!(m.is_boundary_edge(m.find_half_edge(ids[0], ids[2]).unwrap()));
    // The last triangle stays.
    assert_eq!(m.remove_boundary_ear(ids[3]), Err(Refusal::TooSmall));
    m.validate(Level::Geometry).unwrap();
}
