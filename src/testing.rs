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
        3 => grid(1 + (kind as usize / 5) % 4, 1 + (kind as usize / 20) % 4, 0.3, kind as u64),
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
