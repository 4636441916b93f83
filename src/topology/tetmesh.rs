//! The tetrahedral mesh: storage, local numbering and navigation.
//!
//! ```text
//!            3
//!           /|\          A tet (v0, v1, v2, v3) is positive: orient3d(p0, p1, p2, p3) > 0,
//!          / | \         i.e. det[p1 - p0, p2 - p0, p3 - p0] > 0.
//!         /  |  \        Face i is the face opposite vertex i; adj[i] = Some((u, j)) is the
//!        0---|---2       tet u across it, whose face j is the same triangle.
//!         \  |  /        Boundary faces have no neighbour.
//!          \ | /
//!            1
//! ```

use super::{Refusal, VertexTag};
use crate::predicates::{orient3d, Sign};
use glam::DVec3;
use slotmap::{new_key_type, Key, SlotMap};
use smallvec::SmallVec;

new_key_type! {
    /// A vertex of a [`TetMesh`].
    pub struct TVertexId;
    /// A tetrahedron of a [`TetMesh`].
    pub struct TetId;
}

/// Face i of a tet lists the three vertices other than i, ordered so that seen from outside
/// the tet they turn counter-clockwise: the normal (b - a) x (c - a) points away from vertex i,
/// so orient3d(a, b, c, v_i) is Negative.
///
/// ```text
///   face 0 = (1, 2, 3)   face 1 = (0, 3, 2)   face 2 = (0, 1, 3)   face 3 = (0, 2, 1)
/// ```
pub const FACE_VERTICES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// The six edges (i, j), i < j, in the order of [`crate::quality::tet_dihedral_angles_deg`].
/// `EDGE_OPPOSITE[e]` holds the other two local vertices (k, l), so that (i, j, k, l) is an even
/// permutation of (0, 1, 2, 3) and a positive tet stays positive read in that order.
pub const EDGE_VERTICES: [[usize; 2]; 6] = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];
/// See [`EDGE_VERTICES`].
pub const EDGE_OPPOSITE: [[usize; 2]; 6] = [[2, 3], [3, 1], [1, 2], [0, 3], [2, 0], [0, 1]];

/// A vertex record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TVertex {
    /// Position.
    pub pos: DVec3,
    /// One tet that holds the vertex.
    pub tet: TetId,
    /// What the vertex may do.
    pub tag: VertexTag,
}

/// A tetrahedron record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tet {
    /// The four vertices, positively oriented.
    pub v: [TVertexId; 4],
    /// The tet across face i and the index of the same face in it; none on the boundary.
    pub adj: [Option<(TetId, u8)>; 4],
    /// Subdomain label.
    pub label: u32,
}

/// The tets around an edge a-b, in order: `tets[k]` = `(a, b, ring[k], ring[k+1])` is positive
/// (indices modulo the ring length when `closed`). An open shell (boundary edge) has one more
/// ring vertex than tets.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EdgeShell {
    /// First end.
    pub a: TVertexId,
    /// Second end.
    pub b: TVertexId,
    /// The tets around the edge.
    pub tets: SmallVec<[TetId; 8]>,
    /// The ring (link) vertices.
    pub ring: SmallVec<[TVertexId; 8]>,
    /// True for an interior edge (the ring closes).
    pub closed: bool,
}

impl EdgeShell {
    /// The k-th ring vertex, cyclically.
    #[inline]
    pub fn ring_at(&self, k: usize) -> TVertexId {
        self.ring[k % self.ring.len()]
    }
}

/// What the topology changes made since [`TetMesh::open_journal`] touched, for callers that
/// keep arrays derived from the mesh and refresh only the touched part.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Journal {
    /// The vertices of every tet made or removed, with repeats.
    pub touched: Vec<TVertexId>,
    /// Whether a vertex was added or removed.
    pub vertices_changed: bool,
}

/// A tetrahedral mesh with face neighbours in slotmap arenas.
#[derive(Clone, Debug, Default)]
pub struct TetMesh {
    pub(crate) vertices: SlotMap<TVertexId, TVertex>,
    pub(crate) tets: SlotMap<TetId, Tet>,
    /// Bumped by every write; a plan remembers the revision it was checked against.
    pub(crate) revision: u64,
    /// Open while a caller wants to know what changes touch (see [`Journal`]).
    pub(crate) journal: Option<Journal>,
}

impl PartialEq for TetMesh {
    /// Equal when both arenas hold the same keys (with versions) and records in the same order.
    fn eq(&self, other: &Self) -> bool {
        self.vertices.len() == other.vertices.len()
            && self.tets.len() == other.tets.len()
            && self.vertices.iter().zip(other.vertices.iter()).all(|(a, b)| a == b)
            && self.tets.iter().zip(other.tets.iter()).all(|(a, b)| a == b)
    }
}

/// The parity of a permutation of (0, 1, 2, 3): true when even.
#[inline]
pub(crate) fn even_permutation(p: [usize; 4]) -> bool {
    let mut inv = 0;
    for i in 0..4 {
        for j in i + 1..4 {
            if p[i] > p[j] {
                inv += 1;
            }
        }
    }
    inv % 2 == 0
}

/// Shared faces as pairs of face codes, and the third tet on a face if any (see [`match_faces`]).
type FaceMatches = (Vec<(u32, u32)>, Option<usize>);

/// The faces two tets share, as pairs of codes 4 tet + face, and the first tet in input order
/// that is the third to hold some face. Faces are grouped by their smallest point with a
/// counting sort and matched inside each group (a few dozen faces) after a small sort: no
/// hash map, whose probes cost more than the rest of a 10^6-tet build.
fn match_faces(n: usize, tets: &[[usize; 4]]) -> FaceMatches {
    use rayon::prelude::*;
    let sorted = |k: usize, i: usize| {
        let f = FACE_VERTICES[i].map(|x| tets[k][x] as u32);
        let (mut a, mut b, mut c) = (f[0], f[1], f[2]);
        if a > b {
            std::mem::swap(&mut a, &mut b);
        }
        if b > c {
            std::mem::swap(&mut b, &mut c);
        }
        if a > b {
            std::mem::swap(&mut a, &mut b);
        }
        (a, b, c)
    };
    let mut start = vec![0u32; n + 1];
    for k in 0..tets.len() {
        for i in 0..4 {
            start[sorted(k, i).0 as usize + 1] += 1;
        }
    }
    for a in 0..n {
        start[a + 1] += start[a];
    }
    let mut fill = start.clone();
    let mut rec = vec![(0u32, 0u32, 0u32); 4 * tets.len()];
    for k in 0..tets.len() {
        for i in 0..4 {
            let (a, b, c) = sorted(k, i);
            rec[fill[a as usize] as usize] = (b, c, (4 * k + i) as u32);
            fill[a as usize] += 1;
        }
    }
    const BLOCK: usize = 1024;
    let parts: Vec<FaceMatches> = (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(|blk| {
            let mut pairs = Vec::new();
            let mut third: Option<usize> = None;
            let mut group = Vec::new();
            for a in blk * BLOCK..((blk + 1) * BLOCK).min(n) {
                group.clear();
                group.extend_from_slice(&rec[start[a] as usize..start[a + 1] as usize]);
                group.sort_unstable();
                let mut r = 0;
                while r < group.len() {
                    let mut e = r + 1;
                    while e < group.len() && (group[e].0, group[e].1) == (group[r].0, group[r].1) {
                        e += 1;
                    }
                    if e - r >= 2 {
                        pairs.push((group[r].2, group[r + 1].2));
                    }
                    if e - r >= 3 {
                        let ti = (group[r + 2].2 >> 2) as usize;
                        third = Some(third.map_or(ti, |x| x.min(ti)));
                    }
                    r = e;
                }
            }
            (pairs, third)
        })
        .collect();
    let third = parts.iter().filter_map(|p| p.1).min();
    (parts.into_iter().flat_map(|p| p.0).collect(), third)
}

/// The three keys sorted: a face's identity regardless of orientation.
#[inline]
pub(crate) fn face_key(mut f: [TVertexId; 3]) -> [TVertexId; 3] {
    if f[0] > f[1] {
        f.swap(0, 1);
    }
    if f[1] > f[2] {
        f.swap(1, 2);
    }
    if f[0] > f[1] {
        f.swap(0, 1);
    }
    f
}

impl TetMesh {
    /// An empty mesh.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty mesh with room for about `n` vertices.
    pub fn with_capacity(n: usize) -> Self {
        TetMesh {
            vertices: SlotMap::with_capacity_and_key(n),
            tets: SlotMap::with_capacity_and_key(7 * n + 8),
            revision: 0,
            journal: None,
        }
    }

    // ----- counts and access -----

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.vertices.len()
    }
    /// Number of tets.
    pub fn num_tets(&self) -> usize {
        self.tets.len()
    }
    /// Number of faces (interior faces once, boundary faces once).
    pub fn num_faces(&self) -> usize {
        let b = self.boundary_faces().len();
        (4 * self.tets.len() - b) / 2 + b
    }
    /// Number of edges.
    pub fn num_edges(&self) -> usize {
        self.edges().len()
    }
    /// The vertex record.
    #[inline]
    pub fn vertex(&self, v: TVertexId) -> &TVertex {
        &self.vertices[v]
    }
    /// The revision counter: it changes with every successful write.
    pub fn revision(&self) -> u64 {
        self.revision
    }
    /// The tet record.
    #[inline]
    pub fn tet(&self, t: TetId) -> &Tet {
        &self.tets[t]
    }
    /// Whether the key names a live vertex.
    pub fn contains_vertex(&self, v: TVertexId) -> bool {
        self.vertices.contains_key(v)
    }
    /// Whether the key names a live tet.
    pub fn contains_tet(&self, t: TetId) -> bool {
        self.tets.contains_key(t)
    }
    /// Position of a vertex.
    #[inline]
    pub fn pos(&self, v: TVertexId) -> DVec3 {
        self.vertices[v].pos
    }
    /// Tag of a vertex.
    #[inline]
    pub fn tag(&self, v: TVertexId) -> VertexTag {
        self.vertices[v].tag
    }
    /// Sets the tag of a vertex.
    pub fn set_tag(&mut self, v: TVertexId, tag: VertexTag) {
        self.vertices[v].tag = tag;
    }
    /// Tags every vertex of a boundary face `Boundary` (unless `Fixed`); returns how many.
    pub fn tag_boundary_vertices(&mut self) -> usize {
        let mut n = 0;
        for (t, i) in self.boundary_faces() {
            for v in self.face_vertices(t, i) {
                let tag = &mut self.vertices[v].tag;
                if !matches!(tag, VertexTag::Boundary | VertexTag::Fixed) {
                    *tag = VertexTag::Boundary;
                    n += 1;
                }
            }
        }
        n
    }
    /// Subdomain label of a tet.
    pub fn label(&self, t: TetId) -> u32 {
        self.tets[t].label
    }
    /// Sets the subdomain label of a tet.
    pub fn set_label(&mut self, t: TetId, label: u32) {
        self.tets[t].label = label;
    }
    /// Starts recording what topology changes touch (a journal already open starts over).
    pub fn open_journal(&mut self) {
        self.journal = Some(Journal::default());
    }
    /// Closes the journal and returns it (`None` if none was open).
    pub fn take_journal(&mut self) -> Option<Journal> {
        self.journal.take()
    }
    /// Records a tet made or removed.
    #[inline]
    pub(crate) fn note_tet(&mut self, v: [TVertexId; 4]) {
        if let Some(j) = &mut self.journal {
            j.touched.extend_from_slice(&v);
        }
    }
    /// Records a vertex added or removed.
    #[inline]
    pub(crate) fn note_vertex_set(&mut self) {
        if let Some(j) = &mut self.journal {
            j.vertices_changed = true;
        }
    }
    /// Moves a vertex without any check; use `relocate` for a checked move.
    pub fn set_pos_unchecked(&mut self, v: TVertexId, p: DVec3) {
        self.vertices[v].pos = p;
    }
    /// Iterator over vertex keys.
    pub fn vertex_ids(&self) -> impl Iterator<Item = TVertexId> + '_ {
        self.vertices.keys()
    }
    /// Iterator over tet keys.
    pub fn tet_ids(&self) -> impl Iterator<Item = TetId> + '_ {
        self.tets.keys()
    }
    /// The four positions of a tet.
    #[inline]
    pub fn tet_points(&self, t: TetId) -> [DVec3; 4] {
        let v = self.tets[t].v;
        [self.pos(v[0]), self.pos(v[1]), self.pos(v[2]), self.pos(v[3])]
    }
    /// Exact orientation of a tet.
    pub fn tet_orientation(&self, t: TetId) -> Sign {
        let [a, b, c, d] = self.tet_points(t);
        orient3d(a, b, c, d)
    }
    /// Signed volume of a tet.
    pub fn tet_volume(&self, t: TetId) -> f64 {
        crate::quality::tet_volume(self.tet_points(t))
    }
    /// Radius ratio 3 r_in / r_out of a tet (1 regular, 0 flat).
    pub fn tet_quality(&self, t: TetId) -> f64 {
        crate::quality::tet_radius_ratio(self.tet_points(t))
    }
    /// Smallest and largest dihedral angle of a tet, in degrees.
    pub fn tet_dihedral_range(&self, t: TetId) -> (f64, f64) {
        let a = crate::quality::tet_dihedral_angles_deg(self.tet_points(t));
        (a.iter().copied().fold(f64::INFINITY, f64::min), a.iter().copied().fold(0.0, f64::max))
    }
    /// Smallest and largest dihedral angle over the mesh, in degrees.
    pub fn dihedral_range(&self) -> (f64, f64) {
        self.tets
            .keys()
            .map(|t| self.tet_dihedral_range(t))
            .fold((f64::INFINITY, 0.0), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)))
    }
    /// Total signed volume.
    pub fn volume(&self) -> f64 {
        self.tets.keys().map(|t| self.tet_volume(t)).sum()
    }

    // ----- navigation -----

    /// The local index of `v` in tet `t`.
    #[inline]
    pub fn local_index(&self, t: TetId, v: TVertexId) -> Option<usize> {
        self.tets[t].v.iter().position(|&x| x == v)
    }
    /// The vertices of face i of t, counter-clockwise seen from outside t.
    #[inline]
    pub fn face_vertices(&self, t: TetId, i: usize) -> [TVertexId; 3] {
        let v = self.tets[t].v;
        let f = FACE_VERTICES[i];
        [v[f[0]], v[f[1]], v[f[2]]]
    }
    /// The tet across face i of t and its matching face index.
    #[inline]
    pub fn neighbour(&self, t: TetId, i: usize) -> Option<(TetId, u8)> {
        self.tets[t].adj[i]
    }
    /// Every boundary face as (tet, face index).
    pub fn boundary_faces(&self) -> Vec<(TetId, usize)> {
        let mut out = Vec::new();
        for (t, tx) in self.tets.iter() {
            for i in 0..4 {
                if tx.adj[i].is_none() {
                    out.push((t, i));
                }
            }
        }
        out
    }
    /// The tets around `v` (its star), by a walk over face neighbours from its stored tet.
    pub fn vertex_tets(&self, v: TVertexId) -> SmallVec<[TetId; 32]> {
        // Breadth-first over the faces around v. The visited set is a small open-addressing
        // table on the stack: a linear `contains` made this walk quadratic in the star (about
        // 25 tets), and it is the most frequent query of the mesher's swaps and smoothing.
        const SLOTS: usize = 256;
        let mut seen = [u64::MAX; SLOTS];
        let mut visit = |t: TetId| -> bool {
            let key = t.data().as_ffi();
            let mut h = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 56) as usize;
            loop {
                if seen[h] == u64::MAX {
                    seen[h] = key;
                    return true;
                }
                if seen[h] == key {
                    return false;
                }
                h = (h + 1) % SLOTS;
            }
        };
        let mut out: SmallVec<[TetId; 32]> = SmallVec::new();
        let start = self.vertices[v].tet;
        out.push(start);
        visit(start);
        let mut k = 0;
        while k < out.len() {
            let t = out[k];
            k += 1;
            let tx = &self.tets[t];
            for i in 0..4 {
                if tx.v[i] == v {
                    continue;
                }
                if let Some((u, _)) = tx.adj[i] {
                    // Past half the table (a star of more than 128 tets), fall back to a scan.
                    let new = if out.len() < SLOTS / 2 { visit(u) } else { !out.contains(&u) };
                    if new {
                        out.push(u);
                    }
                }
            }
        }
        out
    }
    /// The vertices joined to `v` by an edge.
    pub fn vertex_neighbours(&self, v: TVertexId) -> SmallVec<[TVertexId; 32]> {
        let mut out: SmallVec<[TVertexId; 32]> = SmallVec::new();
        for t in self.vertex_tets(v) {
            for &w in &self.tets[t].v {
                if w != v && !out.contains(&w) {
                    out.push(w);
                }
            }
        }
        out
    }
    /// True when some face around `v` is a boundary face.
    pub fn is_boundary_vertex(&self, v: TVertexId) -> bool {
        self.vertex_tets(v).iter().any(|&t| {
            let tx = &self.tets[t];
            (0..4).any(|i| tx.v[i] != v && tx.adj[i].is_none())
        })
    }
    /// A tet holding both a and b, if the edge exists.
    pub fn find_edge(&self, a: TVertexId, b: TVertexId) -> Option<TetId> {
        if !self.vertices.contains_key(a) || !self.vertices.contains_key(b) {
            return None;
        }
        self.vertex_tets(a).into_iter().find(|&t| self.tets[t].v.contains(&b))
    }
    /// True when the triangle (a, b, c) is a face of some tet.
    pub fn has_face(&self, a: TVertexId, b: TVertexId, c: TVertexId) -> bool {
        self.vertex_tets(a).into_iter().any(|t| self.tets[t].v.contains(&b) && self.tets[t].v.contains(&c))
    }
    /// Every edge once, as (smaller key, larger key).
    pub fn edges(&self) -> Vec<(TVertexId, TVertexId)> {
        let mut e: Vec<(TVertexId, TVertexId)> = Vec::with_capacity(self.tets.len() * 7);
        for tx in self.tets.values() {
            for [i, j] in EDGE_VERTICES {
                let (a, b) = (tx.v[i], tx.v[j]);
                e.push(if a < b { (a, b) } else { (b, a) });
            }
        }
        e.sort_unstable();
        e.dedup();
        e
    }

    /// The shell of the edge (local vertices `i`, `j` of tet `t`), walking face neighbours.
    pub fn edge_shell(&self, t: TetId, i: usize, j: usize) -> EdgeShell {
        debug_assert!(i < 4 && j < 4 && i != j);
        let tx = &self.tets[t];
        let (a, b) = (tx.v[i], tx.v[j]);
        // The other two, ordered so (a, b, x, y) is positive.
        let mut kl = [0usize; 2];
        let mut n = 0;
        for k in 0..4 {
            if k != i && k != j {
                kl[n] = k;
                n += 1;
            }
        }
        if !even_permutation([i, j, kl[0], kl[1]]) {
            kl.swap(0, 1);
        }
        let mut tets: SmallVec<[TetId; 8]> = SmallVec::new();
        let mut ring: SmallVec<[TVertexId; 8]> = SmallVec::new();
        // Forward: from (a, b, x, y) cross the face opposite x to reach (a, b, y, z).
        let mut cur = t;
        let mut x = tx.v[kl[0]];
        let mut y = tx.v[kl[1]];
        ring.push(x);
        let closed = loop {
            tets.push(cur);
            ring.push(y);
            let ix = self.local_index(cur, x).expect("shell walk");
            match self.tets[cur].adj[ix] {
                None => break false,
                Some((u, _)) if u == t => break true,
                Some((u, _)) => {
                    let ux = &self.tets[u];
                    let z = ux.v.iter().copied().find(|&w| w != a && w != b && w != y).expect("shell walk");
                    cur = u;
                    x = y;
                    y = z;
                }
            }
            if tets.len() > self.tets.len() {
                break true;
            }
        };
        if closed {
            ring.pop();
            return EdgeShell { a, b, tets, ring, closed };
        }
        // Backward from t: cross the face opposite y of (a, b, x, y) to reach (a, b, w, x).
        let mut back_t: SmallVec<[TetId; 8]> = SmallVec::new();
        let mut back_r: SmallVec<[TVertexId; 8]> = SmallVec::new();
        let mut cur = t;
        let mut x = tx.v[kl[0]];
        let mut y = tx.v[kl[1]];
        loop {
            let iy = self.local_index(cur, y).expect("shell walk");
            match self.tets[cur].adj[iy] {
                None => break,
                Some((u, _)) => {
                    let w = self.tets[u].v.iter().copied().find(|&w| w != a && w != b && w != x).expect("shell walk");
                    back_t.push(u);
                    back_r.push(w);
                    cur = u;
                    y = x;
                    x = w;
                }
            }
            if back_t.len() > self.tets.len() {
                break;
            }
        }
        back_t.reverse();
        back_r.reverse();
        back_t.extend(tets);
        back_r.extend(ring);
        EdgeShell { a, b, tets: back_t, ring: back_r, closed: false }
    }

    /// The shell of edge a-b, if the edge exists.
    pub fn edge_shell_of(&self, a: TVertexId, b: TVertexId) -> Option<EdgeShell> {
        let t = self.find_edge(a, b)?;
        Some(self.edge_shell(t, self.local_index(t, a)?, self.local_index(t, b)?))
    }

    // ----- construction -----

    /// Builds a mesh from points and tets (indices into `points`). Negatively oriented tets are
    /// reordered; flat ones are an error, as are unused points and faces shared by more than two
    /// tets. Returns the mesh and the vertex key of each point.
    pub fn from_arrays(points: &[DVec3], tets: &[[usize; 4]]) -> Result<(Self, Vec<TVertexId>), crate::Error> {
        use crate::Error::InvalidMesh;
        use rayon::prelude::*;
        if let Some(i) = points.iter().position(|p| !p.is_finite()) {
            return Err(InvalidMesh(format!("point {i} is not finite")));
        }
        // Face codes (4 tet + face) and point indices are u32 below.
        if points.len() >= u32::MAX as usize || tets.len() >= (1 << 30) {
            return Err(InvalidMesh(format!("{} points and {} tets: past the u32 indices", points.len(), tets.len())));
        }
        // Checked and oriented in parallel; errors are reported for the first bad tet in input
        // order, as a sequential build would meet them.
        let check = |ti: usize, t: &[usize; 4]| -> Result<[usize; 4], String> {
            let mut t = *t;
            if t.iter().any(|&i| i >= points.len()) {
                return Err(format!("tet {ti} refers past the {} points", points.len()));
            }
            if (0..4).any(|i| (i + 1..4).any(|j| t[i] == t[j])) {
                return Err(format!("tet {ti} repeats a vertex"));
            }
            match orient3d(points[t[0]], points[t[1]], points[t[2]], points[t[3]]) {
                Sign::Positive => {}
                Sign::Negative => t.swap(2, 3),
                Sign::Zero => return Err(format!("tet {ti} is flat")),
            }
            Ok(t)
        };
        let oriented: Vec<[usize; 4]> = tets
            .par_iter()
            .enumerate()
            .with_min_len(4096)
            .map(|(ti, t)| check(ti, t).unwrap_or([usize::MAX; 4]))
            .collect();
        let valid = oriented.par_iter().position_first(|t| t[0] == usize::MAX).unwrap_or(tets.len());
        let (pairs, third) = match_faces(points.len(), &oriented[..valid]);
        if let Some(ti) = third {
            return Err(InvalidMesh(format!("tet {ti}: a face is shared by more than two tets")));
        }
        if valid < tets.len() {
            return Err(InvalidMesh(check(valid, &tets[valid]).expect_err("the first bad tet")));
        }
        let mut m = TetMesh::with_capacity(points.len());
        let ids: Vec<TVertexId> = points
            .iter()
            .map(|&p| m.vertices.insert(TVertex { pos: p, tet: TetId::null(), tag: VertexTag::Interior }))
            .collect();
        let mut tet_ids = Vec::with_capacity(oriented.len());
        for t in &oriented {
            let v = t.map(|i| ids[i]);
            let id = m.tets.insert(Tet { v, adj: [None; 4], label: 0 });
            for &x in &v {
                m.vertices[x].tet = id;
            }
            tet_ids.push(id);
        }
        for &(a, b) in &pairs {
            let (ta, fa, tb, fb) = (tet_ids[(a >> 2) as usize], a & 3, tet_ids[(b >> 2) as usize], b & 3);
            m.tets[ta].adj[fa as usize] = Some((tb, fb as u8));
            m.tets[tb].adj[fb as usize] = Some((ta, fa as u8));
        }
        if let Some(i) = ids.iter().position(|&v| m.vertices[v].tet.is_null()) {
            return Err(InvalidMesh(format!("point {i} is used by no tet")));
        }
        // Two tets on one face must lie on opposite sides of it.
        let apart = |t: TetId, i: usize, u: TetId, j: usize| {
            let f = m.face_vertices(t, i).map(|v| m.pos(v));
            orient3d(f[0], f[1], f[2], m.pos(m.tets[u].v[j])) == Sign::Positive
        };
        let overlap = pairs.par_iter().with_min_len(4096).any(|&(a, b)| {
            let (ta, fa, tb, fb) =
                (tet_ids[(a >> 2) as usize], (a & 3) as usize, tet_ids[(b >> 2) as usize], (b & 3) as usize);
            !apart(ta, fa, tb, fb) || !apart(tb, fb, ta, fa)
        });
        if overlap {
            return Err(InvalidMesh("two tets overlap across a shared face".into()));
        }
        Ok((m, ids))
    }

    /// Compacted arrays: the points, the positive tets, the labels, and the key of each point.
    pub fn to_arrays(&self) -> super::MeshArrays<DVec3, 4, TVertexId> {
        let mut index = slotmap::SecondaryMap::with_capacity(self.vertices.len());
        let mut points = Vec::with_capacity(self.vertices.len());
        let mut keys = Vec::with_capacity(self.vertices.len());
        for (v, vx) in self.vertices.iter() {
            index.insert(v, points.len());
            points.push(vx.pos);
            keys.push(v);
        }
        let mut out = Vec::with_capacity(self.tets.len());
        let mut labels = Vec::with_capacity(self.tets.len());
        for tx in self.tets.values() {
            out.push([index[tx.v[0]], index[tx.v[1]], index[tx.v[2]], index[tx.v[3]]]);
            labels.push(tx.label);
        }
        super::MeshArrays { points, cells: out, labels, keys }
    }

    /// The boundary surface as a triangle mesh, faces counter-clockwise seen from outside.
    pub fn to_boundary_trimesh(&self) -> Result<super::TriMesh<DVec3>, crate::Error> {
        let mut index: slotmap::SecondaryMap<TVertexId, usize> = slotmap::SecondaryMap::new();
        let mut points = Vec::new();
        let mut tris = Vec::new();
        for (t, i) in self.boundary_faces() {
            let f = self.face_vertices(t, i);
            let mut tri = [0usize; 3];
            for k in 0..3 {
                tri[k] = *index.entry(f[k]).unwrap().or_insert_with(|| {
                    points.push(self.pos(f[k]));
                    points.len() - 1
                });
            }
            tris.push(tri);
        }
        Ok(super::TriMesh::from_arrays(&points, &tris)?.0)
    }

    /// Checks that a tet key is live, as a refusal.
    #[inline]
    pub(crate) fn live_tet(&self, t: TetId) -> Result<&Tet, Refusal> {
        self.tets.get(t).ok_or(Refusal::StaleKey)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::predicates::orient3d_dir;

    fn reference() -> [DVec3; 4] {
        [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z]
    }

    #[test]
    fn face_table_points_outward() {
        let p = reference();
        assert_eq!(orient3d(p[0], p[1], p[2], p[3]), Sign::Positive);
        for (i, f) in FACE_VERTICES.iter().enumerate() {
            assert!(!f.contains(&i), "face {i} must not hold vertex {i}");
            assert_eq!(orient3d(p[f[0]], p[f[1]], p[f[2]], p[i]), Sign::Negative, "face {i}");
            // The outward normal points away from the centroid.
            let c = (p[0] + p[1] + p[2] + p[3]) / 4.0;
            assert_eq!(orient3d_dir(p[f[0]], p[f[1]], p[f[2]], p[f[0]] - c), Sign::Positive);
        }
    }

    #[test]
    fn edge_tables_are_even() {
        let p = reference();
        for e in 0..6 {
            let [i, j] = EDGE_VERTICES[e];
            let [k, l] = EDGE_OPPOSITE[e];
            assert!(i < j);
            let mut all = [i, j, k, l];
            assert!(even_permutation(all));
            assert_eq!(orient3d(p[i], p[j], p[k], p[l]), Sign::Positive);
            all.sort();
            assert_eq!(all, [0, 1, 2, 3]);
        }
    }
}
