//! Fixtures, random operation sequences and fuzz bodies, shared by tests, benches and fuzz
//! targets. Not part of the stable API.

use crate::topology::{Level, Refusal, TriMesh};
use arbitrary::{Arbitrary, Unstructured};
use glam::DVec2;

/// The one seed for every randomised test.
pub const SEED: u64 = 0x7275_7373_6d65_7368;

/// A small deterministic generator (SplitMix64): tests need reproducible numbers, not a crate.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }
}

/// `n` uniform random points in the unit square.
pub fn random_points(n: usize, seed: u64) -> Vec<DVec2> {
    let mut r = Rng::new(seed);
    (0..n).map(|_| DVec2::new(r.f64(), r.f64())).collect()
}

/// One counter-clockwise triangle.
pub fn single_triangle() -> TriMesh<DVec2> {
    let p = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(0.3, 0.8)];
    TriMesh::from_arrays(&p, &[[0, 1, 2]]).expect("valid").0
}

/// Two triangles sharing the edge 0-1 (a convex quad).
pub fn two_triangles() -> TriMesh<DVec2> {
    let p = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(0.4, 0.9), DVec2::new(0.6, -0.8)];
    TriMesh::from_arrays(&p, &[[0, 1, 2], [1, 0, 3]]).expect("valid").0
}

/// A vertex at the origin with `n` neighbours on the unit circle.
pub fn vertex_onering(n: usize) -> TriMesh<DVec2> {
    let mut p = vec![DVec2::ZERO];
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        p.push(DVec2::new(a.cos(), a.sin()));
    }
    let t: Vec<[usize; 3]> = (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
    TriMesh::from_arrays(&p, &t).expect("valid").0
}

/// A structured nx-by-ny grid of squares split into triangles, jittered by `jitter` cells.
pub fn grid(nx: usize, ny: usize, jitter: f64, seed: u64) -> TriMesh<DVec2> {
    let mut r = Rng::new(seed);
    let mut p = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let inner = i > 0 && j > 0 && i < nx && j < ny;
            let (dx, dy) = if inner { (r.range(-jitter, jitter), r.range(-jitter, jitter)) } else { (0.0, 0.0) };
            p.push(DVec2::new(i as f64 + dx, j as f64 + dy));
        }
    }
    let id = |i: usize, j: usize| j * (nx + 1) + i;
    let mut t = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            if (i + j) % 2 == 0 {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                t.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                t.push([id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    TriMesh::from_arrays(&p, &t).expect("valid").0
}

/// One local operation, with element choices as indices taken modulo the live counts.
#[derive(Clone, Copy, Debug, Arbitrary, PartialEq)]
pub enum Op {
    /// Flip the k-th half-edge.
    Flip(u16),
    /// Split the k-th half-edge at parameter t/255 along it.
    Split(u16, u8),
    /// Collapse the k-th half-edge; the survivor ends at parameter t/255 along it.
    Collapse(u16, u8),
    /// Insert in the k-th face at barycentric weights from (u, v).
    Insert(u16, u8, u8),
    /// Move the k-th vertex by (dx, dy)/64 of its shortest edge.
    Relocate(u16, i8, i8),
    /// Lawson flips to Delaunay.
    Delaunay,
    /// Remove the triangle on the k-th half-edge if it is a boundary half-edge.
    RemoveBoundaryTriangle(u16),
    /// Fill the ear on the k-th half-edge if it is a boundary half-edge.
    FillEar(u16),
    /// Remove the k-th vertex with its only triangle if it is a boundary ear.
    RemoveEar(u16),
}

/// A planar k x k grid of squares cut in two (2 k^2 triangles) as mesh file data, its rows
/// spaced by sqrt so that the cells differ: the benches' and timing examples' large mesh.
pub fn grid_mesh_data(k: usize) -> crate::io::MeshData {
    let mut points = Vec::with_capacity((k + 1) * (k + 1));
    for j in 0..=k {
        for i in 0..=k {
            points.push([i as f64 / k as f64 + 1e-9 * j as f64, (j as f64 / k as f64).sqrt(), 0.0]);
        }
    }
    let mut cells = Vec::with_capacity(6 * k * k);
    for j in 0..k {
        for i in 0..k {
            let a = j * (k + 1) + i;
            cells.extend_from_slice(&[a, a + 1, a + k + 2, a, a + k + 2, a + k + 1]);
        }
    }
    crate::io::MeshData { dim: 2, cell_type: crate::io::CellType::Triangle, points, cells, subdomain: None }
}

/// Applies one [`Op`] to a planar mesh.
pub fn apply_op(m: &mut TriMesh<DVec2>, op: Op) -> Result<(), Refusal> {
    fn nth<T>(mut it: impl Iterator<Item = T>, len: usize, k: u16) -> Option<T> {
        if len == 0 {
            None
        } else {
            it.nth(k as usize % len)
        }
    }
    match op {
        Op::Flip(k) => {
            let h = nth(m.half_edge_ids(), 2 * m.num_edges(), k).ok_or(Refusal::StaleKey)?;
            m.flip(h)
        }
        Op::Split(k, t) => {
            let h = nth(m.half_edge_ids(), 2 * m.num_edges(), k).ok_or(Refusal::StaleKey)?;
            let p = m.pos(m.origin(h)).lerp(m.pos(m.dest(h)), t as f64 / 255.0);
            m.split_edge(h, p).map(|_| ())
        }
        Op::Collapse(k, t) => {
            let h = nth(m.half_edge_ids(), 2 * m.num_edges(), k).ok_or(Refusal::StaleKey)?;
            let p = m.pos(m.origin(h)).lerp(m.pos(m.dest(h)), t as f64 / 255.0);
            m.collapse(h, p).map(|_| ())
        }
        Op::Insert(k, u, v) => {
            let f = nth(m.face_ids(), m.num_faces(), k).ok_or(Refusal::StaleKey)?;
            let [a, b, c] = m.face_points(f);
            let (wu, wv) = (1.0 + u as f64, 1.0 + v as f64);
            let p = (a * wu + b * wv + c * 256.0) / (wu + wv + 256.0);
            m.insert_in_face(f, p).map(|_| ())
        }
        Op::Relocate(k, dx, dy) => {
            let v = nth(m.vertex_ids(), m.num_vertices(), k).ok_or(Refusal::StaleKey)?;
            let len = m.outgoing(v).iter().map(|&h| m.edge_length(h)).fold(f64::INFINITY, f64::min);
            let p = m.pos(v) + DVec2::new(dx as f64, dy as f64) * (len / 64.0);
            m.relocate(v, p)
        }
        Op::Delaunay => {
            m.make_delaunay();
            Ok(())
        }
        Op::RemoveBoundaryTriangle(k) => {
            let h = nth(m.half_edge_ids(), 2 * m.num_edges(), k).ok_or(Refusal::StaleKey)?;
            m.remove_boundary_triangle(h).map(|_| ())
        }
        Op::FillEar(k) => {
            let h = nth(m.half_edge_ids(), 2 * m.num_edges(), k).ok_or(Refusal::StaleKey)?;
            m.fill_boundary_ear(h, 0).map(|_| ())
        }
        Op::RemoveEar(k) => {
            let v = nth(m.vertex_ids(), m.num_vertices(), k).ok_or(Refusal::StaleKey)?;
            m.remove_boundary_ear(v)
        }
    }
}

/// Runs `ops` on `m`, validating after every step; a refused op must leave the mesh unchanged.
/// Panics with the failing step on any violation (that is what tests and fuzzers look for).
pub fn check_ops(m: &mut TriMesh<DVec2>, ops: &[Op]) {
    for (i, &op) in ops.iter().enumerate() {
        let before = m.clone();
        match apply_op(m, op) {
            Ok(()) => {
                if let Err(e) = m.validate(Level::Geometry) {
                    panic!("step {i} {op:?}: {e}");
                }
            }
            Err(_) => assert!(*m == before, "step {i} {op:?}: a refused operation changed the mesh"),
        }
    }
}

/// The fuzz body: bytes choose a starting mesh and an operation sequence.
pub fn run_ops(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let kind: u8 = u.arbitrary().unwrap_or(0);
    let mut m = match kind % 5 {
        0 => single_triangle(),
        1 => two_triangles(),
        2 => vertex_onering(3 + (kind as usize / 5) % 8),
        3 => grid(1 + (kind as usize / 5) % 4, 1 + (kind as usize / 20) % 4, 0.2, kind as u64),
        _ => {
            let n = 3 + (kind as usize / 5) % 40;
            TriMesh::delaunay(&random_points(n, kind as u64)).expect("random points").0
        }
    };
    let mut ops = Vec::new();
    while let Ok(op) = u.arbitrary::<Op>() {
        ops.push(op);
        if ops.len() >= 256 || u.is_empty() {
            break;
        }
    }
    check_ops(&mut m, &ops);
}

// ===================== tetrahedral engine =====================

use crate::topology::{TVertexId, TetId, TetMesh, EDGE_VERTICES};
use glam::DVec3;

/// `n` uniform random points in the unit cube.
pub fn random_points_3d(n: usize, seed: u64) -> Vec<DVec3> {
    let mut r = Rng::new(seed);
    (0..n).map(|_| DVec3::new(r.f64(), r.f64(), r.f64())).collect()
}

/// One positive tetrahedron.
pub fn single_tet() -> TetMesh {
    let p =
        [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.1, 0.0), DVec3::new(0.2, 0.9, 0.1), DVec3::new(0.3, 0.2, 0.8)];
    TetMesh::from_arrays(&p, &[[0, 1, 2, 3]]).expect("valid").0
}

/// Two tets sharing the face (0, 1, 2), apexes 3 above and 4 below: a convex pair (2-3 flippable).
pub fn tet_pair() -> TetMesh {
    let p = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.4, 0.9, 0.0),
        DVec3::new(0.45, 0.3, 0.8),
        DVec3::new(0.5, 0.35, -0.7),
    ];
    TetMesh::from_arrays(&p, &[[0, 1, 2, 3], [0, 2, 1, 4]]).expect("valid").0
}

/// `n` tets around the interior edge from (0, 0, -1) to (0, 0, 1), ring on the unit circle.
pub fn edge_shell(n: usize) -> TetMesh {
    let mut p = vec![DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, 1.0)];
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        p.push(DVec3::new(a.cos(), a.sin(), 0.0));
    }
    let t: Vec<[usize; 4]> = (0..n).map(|k| [0, 1, 2 + k, 2 + (k + 1) % n]).collect();
    TetMesh::from_arrays(&p, &t).expect("valid").0
}

/// The Delaunay tetrahedralization of an n x n x n grid of unit spacing (degenerate: many
/// coplanar and cospherical points).
pub fn tet_grid(n: usize) -> TetMesh {
    let mut p = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                p.push(DVec3::new(i as f64, j as f64, k as f64));
            }
        }
    }
    TetMesh::delaunay(&p).expect("grid").0
}

/// One local operation on a [`TetMesh`], with element choices taken modulo the live counts.
#[derive(Clone, Copy, Debug, Arbitrary, PartialEq)]
pub enum TetOp {
    /// 2-3 flip of face f % 4 of the k-th tet.
    Flip23(u16, u8),
    /// 3-2 flip of edge e % 6 of the k-th tet.
    Flip32(u16, u8),
    /// Edge removal (dynamic programming) of edge e % 6 of the k-th tet.
    RemoveEdge(u16, u8),
    /// Split edge e % 6 of the k-th tet at parameter t/255.
    Split(u16, u8, u8),
    /// Collapse edge e % 6 of the k-th tet (direction by the flag); survivor at t/255.
    Collapse(u16, u8, bool, u8),
    /// Insert in the k-th tet at barycentric weights from (u, v, w).
    Insert(u16, u8, u8, u8),
    /// Move the k-th vertex by (dx, dy, dz)/64 of its shortest edge.
    Relocate(u16, i8, i8, i8),
}

/// Applies one [`TetOp`].
pub fn apply_tet_op(m: &mut TetMesh, op: TetOp) -> Result<(), Refusal> {
    fn nth_tet(m: &TetMesh, k: u16) -> Result<TetId, Refusal> {
        let n = m.num_tets();
        if n == 0 {
            return Err(Refusal::StaleKey);
        }
        m.tet_ids().nth(k as usize % n).ok_or(Refusal::StaleKey)
    }
    fn nth_vertex(m: &TetMesh, k: u16) -> Result<TVertexId, Refusal> {
        let n = m.num_vertices();
        if n == 0 {
            return Err(Refusal::StaleKey);
        }
        m.vertex_ids().nth(k as usize % n).ok_or(Refusal::StaleKey)
    }
    let edge_point = |m: &TetMesh, t: TetId, e: u8, s: u8, rev: bool| {
        let [mut i, mut j] = EDGE_VERTICES[e as usize % 6];
        if rev {
            std::mem::swap(&mut i, &mut j);
        }
        let v = m.tet(t).v;
        m.pos(v[i]).lerp(m.pos(v[j]), s as f64 / 255.0)
    };
    match op {
        TetOp::Flip23(k, f) => {
            let t = nth_tet(m, k)?;
            m.flip23(t, f as usize % 4).map(|_| ())
        }
        TetOp::Flip32(k, e) => {
            let t = nth_tet(m, k)?;
            m.flip32(t, e as usize % 6).map(|_| ())
        }
        TetOp::RemoveEdge(k, e) => {
            let t = nth_tet(m, k)?;
            m.remove_edge(t, e as usize % 6).map(|_| ())
        }
        TetOp::Split(k, e, s) => {
            let t = nth_tet(m, k)?;
            let p = edge_point(m, t, e, s, false);
            m.split_edge(t, e as usize % 6, p).map(|_| ())
        }
        TetOp::Collapse(k, e, rev, s) => {
            let t = nth_tet(m, k)?;
            // Survivor b ends on the chord; parameter measured from a.
            let p = edge_point(m, t, e, s, rev);
            m.collapse(t, e as usize % 6, rev, p).map(|_| ())
        }
        TetOp::Insert(k, u, v, w) => {
            let t = nth_tet(m, k)?;
            let q = m.tet_points(t);
            let wt = [1.0 + u as f64, 1.0 + v as f64, 1.0 + w as f64, 256.0];
            let p = (q[0] * wt[0] + q[1] * wt[1] + q[2] * wt[2] + q[3] * wt[3]) / wt.iter().sum::<f64>();
            m.insert_in_tet(t, p).map(|_| ())
        }
        TetOp::Relocate(k, dx, dy, dz) => {
            let v = nth_vertex(m, k)?;
            let len = m.vertex_neighbours(v).iter().map(|&w| m.pos(w).distance(m.pos(v))).fold(f64::INFINITY, f64::min);
            let p = m.pos(v) + DVec3::new(dx as f64, dy as f64, dz as f64) * (len / 64.0);
            m.relocate(v, p)
        }
    }
}

/// Runs `ops` on `m`, validating after every step; a refused op must leave the mesh unchanged.
pub fn check_tet_ops(m: &mut TetMesh, ops: &[TetOp]) {
    for (i, &op) in ops.iter().enumerate() {
        let before = m.clone();
        match apply_tet_op(m, op) {
            Ok(()) => {
                if let Err(e) = m.validate(Level::Geometry) {
                    panic!("step {i} {op:?}: {e}");
                }
            }
            Err(_) => assert!(*m == before, "step {i} {op:?}: a refused operation changed the mesh"),
        }
    }
}

/// The tet fuzz body: bytes choose a starting mesh and an operation sequence.
pub fn run_tet_ops(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let kind: u8 = u.arbitrary().unwrap_or(0);
    let mut m = match kind % 5 {
        0 => single_tet(),
        1 => tet_pair(),
        2 => edge_shell(3 + (kind as usize / 5) % 6),
        3 => {
            let n = 5 + (kind as usize / 5) % 40;
            TetMesh::delaunay(&random_points_3d(n, kind as u64)).expect("random points").0
        }
        _ => tet_grid(2 + (kind as usize / 5) % 3),
    };
    let mut ops = Vec::new();
    while let Ok(op) = u.arbitrary::<TetOp>() {
        ops.push(op);
        if ops.len() >= 128 || u.is_empty() {
            break;
        }
    }
    check_tet_ops(&mut m, &ops);
}
