//! The tetrahedral engine: exact topology after each operation on named fixtures, property
//! tests over random operation sequences, the fuzz corpus, and the Delaunay oracle.

use glam::DVec3;
use proptest::prelude::*;
use trussmesh::predicates::{orient3d, Sign};
use trussmesh::testing::{self, check_tet_ops, edge_shell, random_points_3d, single_tet, tet_pair, TetOp};
use trussmesh::topology::{Level, Refusal, TVertexId, TetId, TetMesh, VertexTag, EDGE_VERTICES};

fn vids(m: &TetMesh) -> Vec<TVertexId> {
    m.vertex_ids().collect()
}

/// The (tet, local edge index) of edge a-b.
fn edge_of(m: &TetMesh, a: TVertexId, b: TVertexId) -> (TetId, usize) {
    let t = m.find_edge(a, b).expect("edge exists");
    let (i, j) = (m.local_index(t, a).unwrap(), m.local_index(t, b).unwrap());
    let e = EDGE_VERTICES.iter().position(|&[x, y]| (x == i && y == j) || (x == j && y == i)).unwrap();
    (t, e)
}

fn first_interior_face(m: &TetMesh) -> (TetId, usize) {
    m.tet_ids().find_map(|t| (0..4).find(|&i| m.neighbour(t, i).is_some()).map(|i| (t, i))).unwrap()
}

#[test]
fn flip23_and_back() {
    let mut m = tet_pair();
    let v = vids(&m);
    let (t, i) = first_interior_face(&m);
    let made = m.flip23(t, i).unwrap();
    assert_eq!(made.len(), 3);
    m.validate(Level::Geometry).unwrap();
    assert_eq!((m.num_vertices(), m.num_tets(), m.boundary_faces().len()), (5, 3, 6));
    assert!(m.find_edge(v[3], v[4]).is_some());
    // Every new tet holds the new edge 3-4; the old face 0-1-2 is gone.
    assert!(made.iter().all(|&t| m.tet(t).v.contains(&v[3]) && m.tet(t).v.contains(&v[4])));
    assert!(!m.has_face(v[0], v[1], v[2]));
    let (t, e) = edge_of(&m, v[3], v[4]);
    let made = m.flip32(t, e).unwrap();
    assert_eq!(made.len(), 2);
    m.validate(Level::Geometry).unwrap();
    assert!(m.find_edge(v[3], v[4]).is_none());
    assert!(m.has_face(v[0], v[1], v[2]));
    assert!((m.volume() - tet_pair().volume()).abs() < 1e-12);
}

#[test]
fn flip23_refusals() {
    let mut m = single_tet();
    let t = m.tet_ids().next().unwrap();
    assert_eq!(m.flip23(t, 0).err(), Some(Refusal::BoundaryFace));
    // A non-convex pair: the apexes lie far to one side, so the segment misses the face.
    let p = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(2.0, 2.0, 0.5),
        DVec3::new(2.0, 2.0, -0.5),
    ];
    let (mut m, _) = TetMesh::from_arrays(&p, &[[0, 1, 2, 3], [0, 2, 1, 4]]).unwrap();
    let before = m.clone();
    let (t, i) = first_interior_face(&m);
    assert_eq!(m.flip23(t, i).err(), Some(Refusal::WouldInvert));
    assert!(m == before);
    // Different labels: an internal boundary.
    let mut m = tet_pair();
    let t = m.tet_ids().next().unwrap();
    m.set_label(t, 3);
    let (t, i) = first_interior_face(&m);
    assert_eq!(m.flip23(t, i).err(), Some(Refusal::Constrained));
}

#[test]
fn flip32_needs_degree_three() {
    let mut m = edge_shell(3);
    let v = vids(&m);
    let (t, e) = edge_of(&m, v[0], v[1]);
    m.flip32(t, e).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!(m.num_tets(), 2);
    assert!(m.has_face(v[2], v[3], v[4]));
    let mut m = edge_shell(4);
    let v = vids(&m);
    let (t, e) = edge_of(&m, v[0], v[1]);
    assert_eq!(m.flip32(t, e).err(), Some(Refusal::NotConvex));
    // A boundary edge.
    let (t, e) = edge_of(&m, v[0], v[2]);
    assert_eq!(m.flip32(t, e).err(), Some(Refusal::BoundaryEdge));
}

#[test]
fn edge_removal_on_shells() {
    for n in 3..=10 {
        let mut m = edge_shell(n);
        let v = vids(&m);
        let vol = m.volume();
        let (t, e) = edge_of(&m, v[0], v[1]);
        let plan = m.check_remove_edge(t, e).unwrap();
        assert!(plan.min_quality > 0.0);
        let made = m.remove_edge(t, e).unwrap();
        assert_eq!(made.len(), 2 * n - 4, "n = {n}");
        m.validate(Level::Geometry).unwrap();
        assert!(m.find_edge(v[0], v[1]).is_none());
        assert_eq!(m.num_tets(), 2 * n - 4);
        assert!((m.volume() - vol).abs() < 1e-12);
    }
    // The ring polygon seen from the edge folds over itself: no valid triangulation.
    let mut p = vec![DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, 1.0)];
    for k in 0..5 {
        let a = std::f64::consts::TAU * k as f64 / 5.0;
        p.push(DVec3::new(a.cos(), a.sin(), 0.0));
    }
    let t: Vec<[usize; 4]> = (0..5).map(|k| [0, 1, 2 + k, 2 + (k + 1) % 5]).collect();
    let (mut m, ids) = TetMesh::from_arrays(&p, &t).unwrap();
    // Pull ring vertex 0 toward the axis and up past b's level: every triangulation inverts.
    let _ = m.relocate(ids[2], DVec3::new(0.05, 0.0, 0.0));
    let (t, e) = edge_of(&m, ids[0], ids[1]);
    let r = m.check_remove_edge(t, e);
    if let Err(r) = r {
        assert_eq!(r, Refusal::NotConvex);
    }
}

#[test]
fn split_interior_and_boundary_edges() {
    let mut m = edge_shell(5);
    let v = vids(&m);
    let (t, e) = edge_of(&m, v[0], v[1]);
    let w = m.split_edge(t, e, DVec3::ZERO).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!((m.num_vertices(), m.num_tets()), (8, 10));
    assert_eq!(m.tag(w), VertexTag::Interior);
    assert!(!m.is_boundary_vertex(w));
    assert_eq!(m.vertex_tets(w).len(), 10);

    let mut m = single_tet();
    let v = vids(&m);
    let (t, e) = edge_of(&m, v[0], v[1]);
    let mid = (m.pos(v[0]) + m.pos(v[1])) * 0.5;
    let w = m.split_edge(t, e, mid).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!((m.num_vertices(), m.num_tets(), m.boundary_faces().len()), (5, 2, 6));
    assert_eq!(m.tag(w), VertexTag::Boundary);
    assert!(m.is_boundary_vertex(w));

    // A point off the edge that would invert a tet is refused.
    let mut m = single_tet();
    let before = m.clone();
    let (t, e) = edge_of(&m, v[0], v[1]);
    // Past b on the line of the edge: the tet (m, b, x, y) would be inverted.
    let bad = m.pos(v[1]) + (m.pos(v[1]) - m.pos(v[0])) * 0.5;
    assert_eq!(m.split_edge(t, e, bad).err(), Some(Refusal::WouldInvert));
    assert!(m == before);
}

#[test]
fn insertion_in_a_tet() {
    let mut m = single_tet();
    let t = m.tet_ids().next().unwrap();
    let c = m.tet_points(t).iter().sum::<DVec3>() / 4.0;
    let w = m.insert_in_tet(t, c).unwrap();
    m.validate(Level::Geometry).unwrap();
    assert_eq!((m.num_vertices(), m.num_tets()), (5, 4));
    assert_eq!(m.vertex_tets(w).len(), 4);
    assert_eq!(m.vertex_neighbours(w).len(), 4);
    let before = m.clone();
    let t = m.tet_ids().next().unwrap();
    assert_eq!(m.insert_in_tet(t, DVec3::splat(5.0)).err(), Some(Refusal::WouldInvert));
    assert!(m == before);
}

#[test]
fn collapse_undoes_split() {
    let mut m = edge_shell(5);
    let v = vids(&m);
    let (t, e) = edge_of(&m, v[0], v[1]);
    let w = m.split_edge(t, e, DVec3::new(0.0, 0.0, 0.1)).unwrap();
    // Collapse the new interior vertex into a.
    let (t, e) = edge_of(&m, w, v[0]);
    let rev = m.tet(t).v[EDGE_VERTICES[e][0]] != w;
    let b = m.collapse(t, e, rev, m.pos(v[0])).unwrap();
    assert_eq!(b, v[0]);
    m.validate(Level::Geometry).unwrap();
    assert_eq!((m.num_vertices(), m.num_tets()), (7, 5));
    assert!(!m.contains_vertex(w));
    assert!(m.find_edge(v[0], v[1]).is_some());
}

#[test]
fn collapse_refusals() {
    // Tags.
    let mut m = edge_shell(5);
    let v = vids(&m);
    let w = {
        let (t, e) = edge_of(&m, v[0], v[1]);
        m.split_edge(t, e, DVec3::ZERO).unwrap()
    };
    m.set_tag(w, VertexTag::Fixed);
    let before = m.clone();
    let (t, e) = edge_of(&m, w, v[0]);
    let rev = m.tet(t).v[EDGE_VERTICES[e][0]] != w;
    assert_eq!(m.collapse(t, e, rev, m.pos(v[0])).err(), Some(Refusal::Protected(VertexTag::Fixed)));
    assert!(m == before);
    // A boundary vertex may not leave the boundary along an interior edge.
    let mut m = edge_shell(5);
    let v = vids(&m);
    m.set_tag(v[0], VertexTag::Boundary);
    let (t, e) = edge_of(&m, v[0], v[1]);
    let rev = m.tet(t).v[EDGE_VERTICES[e][0]] != v[0];
    assert_eq!(m.collapse(t, e, rev, m.pos(v[1])).err(), Some(Refusal::Protected(VertexTag::Boundary)));
    // Interior edge between two boundary vertices: the link condition (boundary at infinity).
    let mut m = edge_shell(5);
    let v = vids(&m);
    let (t, e) = edge_of(&m, v[0], v[1]);
    assert_eq!(m.collapse(t, e, false, m.pos(v[1])).err(), Some(Refusal::LinkCondition));
    // A single tet cannot lose an edge.
    let mut m = single_tet();
    let t = m.tet_ids().next().unwrap();
    assert!(m.collapse(t, 0, false, m.tet_points(t)[1]).is_err());
}

#[test]
fn relocation() {
    let mut m = single_tet();
    let v = vids(&m);
    m.relocate(v[3], m.pos(v[3]) + DVec3::splat(0.01)).unwrap();
    assert_eq!(m.relocate(v[3], DVec3::new(0.3, 0.3, -1.0)).err(), Some(Refusal::WouldInvert));
    m.set_tag(v[3], VertexTag::Fixed);
    assert_eq!(m.relocate(v[3], m.pos(v[3])).err(), Some(Refusal::Protected(VertexTag::Fixed)));
    m.validate(Level::Geometry).unwrap();
}

/// Each bad input of `from_arrays` gets its own message, naming the first bad tet in input
/// order (the face matching runs in parallel, the report must not depend on it).
#[test]
fn from_arrays_names_the_problem() {
    let p = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(0.0, 0.0, -1.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(0.2, 0.2, 2.0),
    ];
    let err = |pts: &[DVec3], t: &[[usize; 4]]| TetMesh::from_arrays(pts, t).unwrap_err().to_string();
    assert!(err(&p, &[[0, 1, 2, 3], [0, 1, 2, 9]]).contains("tet 1 refers past the 7 points"));
    assert!(err(&p, &[[0, 1, 2, 3], [0, 1, 1, 4]]).contains("tet 1 repeats a vertex"));
    assert!(err(&p, &[[0, 1, 2, 3], [0, 1, 2, 5]]).contains("tet 1 is flat"));
    // Three tets on face 0-1-2: the third in input order is named, also before a later bad tet.
    let third = err(&p[..5], &[[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 3], [0, 1, 2, 9]]);
    assert!(third.contains("tet 2: a face is shared by more than two tets"), "{third}");
    // A bad tet before the third sharer is named first.
    let first = err(&p[..5], &[[0, 1, 2, 3], [0, 1, 1, 4], [0, 2, 1, 4], [0, 1, 2, 3]]);
    assert!(first.contains("tet 1 repeats a vertex"), "{first}");
    assert!(err(&p, &[[0, 1, 2, 3], [0, 2, 1, 4]]).contains("point 5 is used by no tet"));
    // Apexes 3 and 6 on the same side of the shared face 0-1-2.
    assert!(err(&[&p[..4], &p[6..]].concat(), &[[0, 1, 2, 3], [0, 1, 2, 4]]).contains("overlap"));
    let mut nan = p;
    nan[2].y = f64::NAN;
    assert!(err(&nan, &[[0, 1, 2, 3]]).contains("point 2 is not finite"));
}

#[test]
fn arrays_round_trip_and_boundary_surface() {
    let (m, _) = TetMesh::delaunay(&random_points_3d(300, testing::SEED)).unwrap();
    let trussmesh::topology::MeshArrays { points: p, cells: t, labels, .. } = m.to_arrays();
    assert_eq!(labels.len(), t.len());
    let (m2, _) = TetMesh::from_arrays(&p, &t).unwrap();
    m2.validate(Level::Delaunay).unwrap();
    assert_eq!(
        (m2.num_vertices(), m2.num_tets(), m2.num_edges(), m2.num_faces()),
        (m.num_vertices(), m.num_tets(), m.num_edges(), m.num_faces())
    );
    // Euler characteristic of a ball: V - E + F - T = 1.
    let chi = m.num_vertices() as i64 - m.num_edges() as i64 + m.num_faces() as i64 - m.num_tets() as i64;
    assert_eq!(chi, 1);
    for mesh in [m, edge_shell(7), single_tet(), tet_pair()] {
        let s = mesh.to_boundary_trimesh().unwrap();
        s.validate(Level::Topology).unwrap();
        assert_eq!(s.euler_characteristic(), 2);
        assert!(s.boundary_loops().is_empty());
    }
}

#[test]
fn replay_fuzz_corpus() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/tetmesh_ops");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let data = std::fs::read(e.unwrap().path()).unwrap();
        testing::run_tet_ops(&data);
        n += 1;
    }
    assert!(n >= 10, "corpus has {n} files");
}

#[test]
fn deterministic_random_sequences() {
    let mut r = testing::Rng::new(testing::SEED ^ 3);
    let mut applied = 0;
    for round in 0..1000 {
        let len = 10 + (r.next_u64() % 200) as usize;
        let data: Vec<u8> = (0..len).map(|_| r.next_u64() as u8).collect();
        let result = std::panic::catch_unwind(|| testing::run_tet_ops(&data));
        assert!(result.is_ok(), "round {round} failed; bytes {data:?}");
        applied += 1;
    }
    assert_eq!(applied, 1000);
}

#[test]
fn every_op_kind_succeeds_somewhere() {
    // The random sequences are only meaningful if each op kind is sometimes accepted.
    let mut r = testing::Rng::new(testing::SEED);
    let mut ok = [0usize; 7];
    for _ in 0..40 {
        let (mut m, _) = TetMesh::delaunay(&random_points_3d(60, r.next_u64())).unwrap();
        for _ in 0..100 {
            let k = r.next_u64() as u16;
            let (a, b, c) = (r.next_u64() as u8, r.next_u64() as u8, r.next_u64() as u8);
            let ops = [
                TetOp::Flip23(k, a),
                TetOp::Flip32(k, a),
                TetOp::RemoveEdge(k, a),
                TetOp::Split(k, a, b),
                TetOp::Collapse(k, a, b % 2 == 0, c),
                TetOp::Insert(k, a, b, c),
                TetOp::Relocate(k, a as i8, b as i8, c as i8),
            ];
            let which = (r.next_u64() % 7) as usize;
            let before = m.clone();
            if testing::apply_tet_op(&mut m, ops[which]).is_ok() {
                ok[which] += 1;
                m.validate(Level::Geometry).unwrap();
            } else {
                assert!(m == before);
            }
        }
    }
    assert!(ok.iter().all(|&n| n > 0), "accepted per kind: {ok:?}");
}

fn op_strategy() -> impl Strategy<Value = TetOp> {
    prop_oneof![
        (any::<u16>(), any::<u8>()).prop_map(|(k, f)| TetOp::Flip23(k, f)),
        (any::<u16>(), any::<u8>()).prop_map(|(k, e)| TetOp::Flip32(k, e)),
        (any::<u16>(), any::<u8>()).prop_map(|(k, e)| TetOp::RemoveEdge(k, e)),
        (any::<u16>(), any::<u8>(), any::<u8>()).prop_map(|(k, e, t)| TetOp::Split(k, e, t)),
        (any::<u16>(), any::<u8>(), any::<bool>(), any::<u8>()).prop_map(|(k, e, r, t)| TetOp::Collapse(k, e, r, t)),
        (any::<u16>(), any::<u8>(), any::<u8>(), any::<u8>()).prop_map(|(k, u, v, w)| TetOp::Insert(k, u, v, w)),
        (any::<u16>(), any::<i8>(), any::<i8>(), any::<i8>()).prop_map(|(k, x, y, z)| TetOp::Relocate(k, x, y, z)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, rng_seed: proptest::test_runner::RngSeed::Fixed(trussmesh::testing::SEED), ..ProptestConfig::default() })]

    #[test]
    fn random_ops_keep_mesh_valid(n in 5usize..50, seed in any::<u64>(), ops in proptest::collection::vec(op_strategy(), 1..80)) {
        let (mut m, _) = TetMesh::delaunay(&random_points_3d(n, seed)).unwrap();
        m.validate(Level::Delaunay).unwrap();
        check_tet_ops(&mut m, &ops);
    }

    #[test]
    fn random_ops_on_shells(n in 3usize..10, ops in proptest::collection::vec(op_strategy(), 1..60)) {
        let mut m = edge_shell(n);
        check_tet_ops(&mut m, &ops);
    }
}

/// The oracle: exact insphere on every interior face; every boundary face has every point on
/// its inner side (so the boundary is the convex hull); the boundary is a sphere; the summed
/// volume equals the volume the boundary encloses (divergence theorem); every point is a vertex.
fn delaunay_oracle(n: usize) {
    let pts = random_points_3d(n, testing::SEED ^ n as u64);
    let t0 = std::time::Instant::now();
    let (m, ids) = TetMesh::delaunay(&pts).unwrap();
    let dt = t0.elapsed();
    m.validate(Level::Delaunay).unwrap();
    assert!(ids.iter().all(|&v| m.contains_vertex(v)));
    assert_eq!(m.num_vertices(), n);
    let mut enclosed = 0.0;
    for (t, i) in m.boundary_faces() {
        let f = m.face_vertices(t, i);
        let (a, b, c) = (m.pos(f[0]), m.pos(f[1]), m.pos(f[2]));
        enclosed += a.dot(b.cross(c)) / 6.0;
        for p in &pts {
            assert_ne!(orient3d(a, b, c, *p), Sign::Positive, "a point lies outside a boundary face");
        }
    }
    let vol = m.volume();
    assert!((vol - enclosed).abs() < 1e-9 * vol.max(1.0), "volume {vol} vs enclosed {enclosed}");
    assert!(vol > 0.5 && vol < 1.0);
    let s = m.to_boundary_trimesh().unwrap();
    s.validate(Level::Topology).unwrap();
    assert_eq!(s.euler_characteristic(), 2);
    eprintln!("Delaunay of {n} points: {} tets in {:?}", m.num_tets(), dt);
}

#[test]
fn delaunay_oracle_1e2() {
    delaunay_oracle(100);
}

#[test]
fn delaunay_oracle_1e3() {
    delaunay_oracle(1000);
}

#[test]
fn delaunay_oracle_1e4() {
    delaunay_oracle(10_000);
}

#[test]
fn delaunay_oracle_1e5() {
    delaunay_oracle(100_000);
}

#[test]
fn delaunay_is_invariant_under_translation_and_scaling() {
    let pts = random_points_3d(500, testing::SEED);
    let (m, _) = TetMesh::delaunay(&pts).unwrap();
    let moved: Vec<DVec3> = pts.iter().map(|p| *p * 4.0 + DVec3::new(-3.0, 10.0, 0.5)).collect();
    let (m2, _) = TetMesh::delaunay(&moved).unwrap();
    m2.validate(Level::Delaunay).unwrap();
    assert_eq!((m.num_tets(), m.num_edges()), (m2.num_tets(), m2.num_edges()));
}

#[test]
fn flip44_on_a_four_shell() {
    let mut m = edge_shell(4);
    let v = vids(&m);
    let (t, e) = edge_of(&m, v[0], v[1]);
    let made = m.flip44(t, e).unwrap();
    assert_eq!(made.len(), 4);
    m.validate(Level::Geometry).unwrap();
    assert!(m.find_edge(v[0], v[1]).is_none());
    assert!(m.find_edge(v[2], v[4]).is_some() || m.find_edge(v[3], v[5]).is_some());
    let mut m = edge_shell(5);
    let v = vids(&m);
    let (t, e) = edge_of(&m, v[0], v[1]);
    assert_eq!(m.flip44(t, e).err(), Some(Refusal::NotConvex));
}

#[test]
fn revision_counts_writes_only() {
    let mut m = tet_pair();
    let r0 = m.revision();
    let t = m.tet_ids().next().unwrap();
    let i = (0..4).find(|&i| m.neighbour(t, i).is_none()).unwrap();
    assert!(m.flip23(t, i).is_err());
    assert_eq!(m.revision(), r0);
    let (t, i) = first_interior_face(&m);
    m.flip23(t, i).unwrap();
    assert_ne!(m.revision(), r0);
}

/// Degenerate inputs: cubic grids (cospherical and coplanar everywhere, 4-4 flips needed),
/// points on a sphere, and lattice points with duplicates.
#[test]
fn delaunay_of_degenerate_points() {
    for n in 2..8usize {
        let mut pts = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    pts.push(DVec3::new(i as f64, j as f64, k as f64));
                }
            }
        }
        let (m, ids) = TetMesh::delaunay(&pts).unwrap();
        m.validate(Level::Delaunay).unwrap();
        assert!((m.volume() - ((n - 1) * (n - 1) * (n - 1)) as f64).abs() < 1e-9, "grid {n}: volume {}", m.volume());
        assert_eq!(m.to_boundary_trimesh().unwrap().euler_characteristic(), 2);
        assert!(ids.iter().zip(&pts).all(|(&v, &p)| m.pos(v) == p));
    }
    let mut r = testing::Rng::new(testing::SEED);
    let pts: Vec<DVec3> =
        (0..2000).map(|_| DVec3::new(r.f64() - 0.5, r.f64() - 0.5, r.f64() - 0.5).normalize()).collect();
    let (m, ids) = TetMesh::delaunay(&pts).unwrap();
    m.validate(Level::Delaunay).unwrap();
    assert!(ids.iter().all(|&v| m.contains_vertex(v)));
    let pts: Vec<DVec3> = (0..3000)
        .map(|_| DVec3::new((r.next_u64() % 8) as f64, (r.next_u64() % 8) as f64, (r.next_u64() % 8) as f64))
        .collect();
    let (m, ids) = TetMesh::delaunay(&pts).unwrap();
    m.validate(Level::Delaunay).unwrap();
    assert!(ids.iter().zip(&pts).all(|(&v, &p)| m.contains_vertex(v) && m.pos(v) == p));
    assert!((m.volume() - 343.0).abs() < 1e-9);
}

#[test]
fn boundary_tags_protect_the_hull() {
    let (mut m, _) = TetMesh::delaunay(&random_points_3d(80, testing::SEED)).unwrap();
    let n = m.tag_boundary_vertices();
    assert!(n > 0 && n < m.num_vertices());
    assert_eq!(m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Boundary).count(), n);
    assert!(m.vertex_ids().all(|v| (m.tag(v) == VertexTag::Boundary) == m.is_boundary_vertex(v)));
    // With tags set, no collapse may move a hull vertex off the hull: every accepted collapse
    // keeps the hull volume.
    let vol = m.volume();
    let tets: Vec<TetId> = m.tet_ids().collect();
    let mut accepted = 0;
    for t in tets {
        for (e, &[i, j]) in EDGE_VERTICES.iter().enumerate() {
            if !m.contains_tet(t) {
                break;
            }
            let (a, b) = (m.tet(t).v[i], m.tet(t).v[j]);
            if m.tag(a) == VertexTag::Interior && m.collapse(t, e, false, m.pos(b)).is_ok() {
                accepted += 1;
                m.validate(Level::Geometry).unwrap();
            }
        }
    }
    assert!(accepted > 0);
    assert!((m.volume() - vol).abs() < 1e-9);
}

#[test]
fn dihedral_range_of_a_delaunay_mesh_is_open() {
    let (m, _) = TetMesh::delaunay(&random_points_3d(200, testing::SEED)).unwrap();
    let (lo, hi) = m.dihedral_range();
    assert!(lo > 0.0 && hi < 180.0 && lo < hi);
}
