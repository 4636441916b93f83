//! The insertion kernel behind [`super::TetMesh::delaunay`]: Bowyer-Watson cavities (Bowyer
//! 1981, Watson 1981) in flat arrays with `u32` indices, converted to the arena mesh once at
//! the end.
//!
//! Why a separate kernel: building 10^6 points through the arena's keyed records (generational
//! keys, `Option` neighbours, vertex back pointers kept up to date) spent more time in
//! bookkeeping than in the predicates. Here a tet is 32 bytes of vertices and neighbours, slots
//! of the cavity are reused, and nothing else is written per insertion.
//!
//! Why a cavity and not a flip sequence: for a point in general position the 1-4 split plus
//! Lawson's flips (Joe 1991) end in exactly the triangulation this makes, but do about 19 flips
//! with 50-odd insphere and 60-80 orientation tests; the cavity needs one insphere per tet it
//! meets and no orientation at all. It is exactly robust with exact predicates and no special
//! cases: in a Delaunay triangulation the tets whose circumsphere *strictly* holds p form a
//! region star-shaped from p, strictly (for a cavity face f between t inside and u outside, the
//! part of t's ball beyond f lies in u's ball, so p on or beyond f's plane would be strictly
//! inside u's ball too). So replacing, in each cavity tet, the vertex opposite a cavity
//! boundary face by p gives positive tets, also for cospherical input and for points on faces
//! or edges. A point located in a tet whose sphere does not strictly hold it is one of its
//! vertices (a closed tet meets its circumsphere only at its corners): a duplicate.

use crate::predicates::{insphere, orient3d, Sign};
use glam::DVec3;

use super::tetmesh::FACE_VERTICES;

/// No neighbour (the faces of the enclosing tetrahedron).
pub(crate) const NONE: u32 = u32::MAX;

/// The largest number of points the kernel takes: neighbour codes pack a tet index and a face
/// index into 32 bits, and a triangulation has about 6.7 tets per point.
pub(crate) const MAX_POINTS: usize = 100_000_000;

/// Flags kept in the two high bits of a tet's last vertex during one insertion (vertex indices
/// stay below 2^30): in the cavity, or tested and outside it. Kept in the tet rather than in a
/// side array because the insphere test reads the tet anyway; a side array costs one more cache
/// miss per tested tet, and cache misses are what this loop waits for.
const IN: u32 = 1 << 31;
const OUT: u32 = 1 << 30;
const VERTEX: u32 = OUT - 1;

/// A Delaunay tetrahedralization under construction. Vertices 0..4 are the enclosing
/// tetrahedron's; tets are positively oriented (det[b-a, c-a, d-a] > 0) and `tn[t][i]` is
/// `(u << 2) | j` for the tet u across face i (opposite vertex i) of t, whose face j it is.
pub(crate) struct Kernel {
    /// Vertex positions.
    pub pts: Vec<DVec3>,
    /// The tets, vertices and neighbours together (one cache line holds two).
    pub tets: Vec<KTet>,
    free: Vec<u32>,
    /// Scratch, kept between insertions so that the loop does not allocate.
    stack: Vec<u32>,
    cavity: Vec<u32>,
    /// Cavity boundary faces: the new tet's vertices, the index of p in it, the outer code.
    boundary: Vec<([u32; 4], u8, u32)>,
    edges: EdgeTable,
    rot: u32,
}

/// `OTHER_TWO[i][j]`: the two local indices of a tet other than i and j (i != j).
const OTHER_TWO: [[[usize; 2]; 4]; 4] = [
    [[2, 3], [2, 3], [1, 3], [1, 2]],
    [[2, 3], [2, 3], [0, 3], [0, 2]],
    [[1, 3], [0, 3], [0, 1], [0, 1]],
    [[1, 2], [0, 2], [0, 1], [0, 1]],
];

/// One tet: `v[0] == NONE` marks a free slot.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
pub(crate) struct KTet {
    /// Vertices, positively oriented.
    pub v: [u32; 4],
    /// Neighbour codes (see [`Kernel`]), [`NONE`] on the outer hull.
    pub n: [u32; 4],
}

/// What became of one inserted point.
pub(crate) enum Inserted {
    /// A new vertex; a tet holding it.
    New(u32),
    /// The point coincides with this vertex.
    Duplicate(u32),
}

impl Kernel {
    /// The enclosing tetrahedron, four vertices `far` away from `centre` (regular directions).
    pub fn new(centre: DVec3, far: f64, capacity: usize) -> Kernel {
        let dirs = [
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(-1.0, -1.0, 1.0),
        ];
        let mut pts = Vec::with_capacity(capacity + 4);
        pts.extend(dirs.iter().map(|d| centre + *d * far));
        let mut v = [0, 1, 2, 3];
        if orient3d(pts[0], pts[1], pts[2], pts[3]) != Sign::Positive {
            v.swap(2, 3);
        }
        let mut tets = Vec::with_capacity(7 * capacity + 16);
        tets.push(KTet { v, n: [NONE; 4] });
        Kernel {
            pts,
            tets,
            free: Vec::new(),
            stack: Vec::with_capacity(64),
            cavity: Vec::with_capacity(64),
            boundary: Vec::with_capacity(128),
            edges: EdgeTable::default(),
            rot: 0x9e37_79b9,
        }
    }

    /// Inserts `p`, walking from the tet `hint`. `None` when p is not strictly inside the
    /// enclosing tetrahedron.
    pub fn insert(&mut self, p: DVec3, hint: u32) -> Option<Inserted> {
        let t = self.locate(p, hint)?;
        let q = self.tet_points(t);
        // p lies in the closed tet, which meets its circumsphere only at its corners: p is a
        // corner or strictly inside the sphere (no insphere test needed).
        if let Some(k) = (0..4).find(|&k| q[k] == p) {
            return Some(Inserted::Duplicate(self.tets[t as usize].v[k] & VERTEX));
        }
        let pi = self.pts.len() as u32;
        self.pts.push(p);
        self.grow_cavity(t, p);
        Some(Inserted::New(self.fill_cavity(pi)))
    }

    #[inline]
    fn tet_points(&self, t: u32) -> [DVec3; 4] {
        // Written out: `array::map` does not always inline here, and this is the hot loop.
        let v = self.tets[t as usize].v;
        let d = (v[3] & VERTEX) as usize;
        [self.pts[v[0] as usize], self.pts[v[1] as usize], self.pts[v[2] as usize], self.pts[d]]
    }

    /// Visibility walk with a rotating first face (exact orientations): a tet whose closure
    /// holds p. The walk terminates in a Delaunay triangulation (Edelsbrunner 1989).
    fn locate(&mut self, p: DVec3, start: u32) -> Option<u32> {
        let mut t = start;
        let mut came = NONE;
        'walk: loop {
            let q = self.tet_points(t);
            self.rot ^= self.rot << 13;
            self.rot ^= self.rot >> 17;
            self.rot ^= self.rot << 5;
            let r = (self.rot >> 8) as usize;
            let adj = self.tets[t as usize].n;
            for k in 0..4 {
                let i = (k + r) & 3;
                let nb = adj[i];
                if nb != NONE && nb >> 2 == came {
                    continue;
                }
                let f = FACE_VERTICES[i];
                if orient3d(q[f[0]], q[f[1]], q[f[2]], p) == Sign::Positive {
                    if nb == NONE {
                        return None;
                    }
                    came = t;
                    t = nb >> 2;
                    continue 'walk;
                }
            }
            return Some(t);
        }
    }

    /// Collects the tets whose circumsphere strictly holds p, grown from `t`, and the faces
    /// around them.
    fn grow_cavity(&mut self, t: u32, p: DVec3) {
        self.tets[t as usize].v[3] |= IN;
        self.stack.clear();
        self.cavity.clear();
        self.boundary.clear();
        self.stack.push(t);
        self.cavity.push(t);
        while let Some(c) = self.stack.pop() {
            let adj = self.tets[c as usize].n;
            for (i, &nb) in adj.iter().enumerate() {
                if nb != NONE {
                    let u = (nb >> 2) as usize;
                    let flags = self.tets[u].v[3] & !VERTEX;
                    if flags == IN {
                        continue;
                    }
                    if flags == 0 {
                        let q = self.tet_points(u as u32);
                        if insphere(q[0], q[1], q[2], q[3], p) == Sign::Positive {
                            self.tets[u].v[3] |= IN;
                            self.stack.push(u as u32);
                            self.cavity.push(u as u32);
                            continue;
                        }
                        self.tets[u].v[3] |= OUT;
                    }
                }
                let mut v = self.tets[c as usize].v;
                v[3] &= VERTEX;
                v[i] = NONE; // filled with p's index below
                self.boundary.push((v, i as u8, nb));
            }
        }
    }

    /// Replaces the cavity by the tets joining p (index `pi`) to its boundary faces; returns
    /// one of them.
    fn fill_cavity(&mut self, pi: u32) -> u32 {
        self.edges.reset(3 * self.boundary.len() / 2);
        let mut reuse = 0;
        let mut last = 0;
        for b in 0..self.boundary.len() {
            let (mut v, i, nb) = self.boundary[b];
            let i = i as usize;
            v[i] = pi;
            let s = if reuse < self.cavity.len() {
                reuse += 1;
                self.cavity[reuse - 1]
            } else if let Some(s) = self.free.pop() {
                s
            } else {
                self.tets.push(KTet { v: [NONE; 4], n: [NONE; 4] });
                (self.tets.len() - 1) as u32
            };
            let su = s as usize;
            self.tets[su].v = v;
            self.tets[su].n[i] = nb;
            if nb != NONE {
                // Every tet tested outside lies across a boundary face: its flag goes here.
                let o = &mut self.tets[(nb >> 2) as usize];
                o.n[(nb & 3) as usize] = (s << 2) | i as u32;
                o.v[3] &= VERTEX;
            }
            // The other three faces hold p and one edge of the boundary face: glue them to the
            // new tet on the other side of that edge.
            for (j, &[k, l]) in OTHER_TWO[i].iter().enumerate() {
                if j == i {
                    continue;
                }
                let (a, c) = (v[k], v[l]);
                let code = (s << 2) | j as u32;
                if let Some(other) = self.edges.take_or_put(a.min(c), a.max(c), code) {
                    self.tets[su].n[j] = other;
                    self.tets[(other >> 2) as usize].n[(other & 3) as usize] = code;
                }
            }
            last = s;
        }
        // Cavity slots left over (never: a cavity of k tets has 2k + 2 faces) go to the free list.
        for &c in &self.cavity[reuse..] {
            self.tets[c as usize].v = [NONE; 4];
            self.free.push(c);
        }
        last
    }
}

/// Open-addressing table from an edge (a < b) to the code of the first new tet face seen on
/// it, cleared by generation stamps so that a reset costs nothing.
#[derive(Default)]
struct EdgeTable {
    slots: Vec<(u32, u32, u32, u32)>, // (stamp, a, b, code)
    stamp: u32,
    mask: usize,
}

impl EdgeTable {
    /// Makes room for `n` edges and forgets the previous ones.
    fn reset(&mut self, n: usize) {
        let want = (4 * n).next_power_of_two().max(64);
        if want > self.slots.len() {
            self.slots = vec![(0, 0, 0, 0); want];
            self.stamp = 0;
        }
        self.mask = self.slots.len() - 1;
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.slots.iter_mut().for_each(|s| s.0 = 0);
            self.stamp = 1;
        }
    }

    /// The code stored for (a, b), removing it; or stores `code` and returns `None`.
    #[inline]
    fn take_or_put(&mut self, a: u32, b: u32, code: u32) -> Option<u32> {
        let h = (a.wrapping_mul(0x9E37_79B1) ^ b.wrapping_mul(0x85EB_CA77)) as usize;
        let mut k = h & self.mask;
        loop {
            let s = self.slots[k];
            if s.0 != self.stamp {
                self.slots[k] = (self.stamp, a, b, code);
                return None;
            }
            if s.1 == a && s.2 == b && s.3 != NONE {
                // Each edge of the cavity boundary is shared by exactly two faces: once taken,
                // the slot stays occupied (tombstone) so that probe chains are not cut.
                self.slots[k].3 = NONE;
                return Some(s.3);
            }
            k = (k + 1) & self.mask;
        }
    }
}
