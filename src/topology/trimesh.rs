//! The half-edge triangle mesh: storage and navigation.
//!
//! ```text
//!            c
//!           / ^
//!   h.next /   \ h.next.next
//!         v  f  \
//!        a ----> b        h: a -> b, face f = (a, b, c) counter-clockwise (face on the left)
//!          <----          twin(h): b -> a, face on the other side or none (boundary)
//! ```
//! Boundary half-edges exist and have no face; they form loops that run clockwise around the
//! mesh (the mesh on their right). Each vertex points to one outgoing half-edge, a boundary one
//! if the vertex is on the boundary, so one-ring walks start right.

use super::Refusal;
use crate::predicates::{orient2d, Sign};
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use slotmap::{new_key_type, SlotMap};
use smallvec::SmallVec;

new_key_type! {
    /// A vertex of a [`TriMesh`].
    pub struct VertexId;
    /// A half-edge of a [`TriMesh`].
    pub struct HalfEdgeId;
    /// A face (triangle) of a [`TriMesh`].
    pub struct FaceId;
}

/// What a vertex may do: where it may move and whether it may be removed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum VertexTag {
    /// Free to move and to be removed.
    #[default]
    Interior,
    /// On the domain boundary d = 0; moves along it; removed only along the boundary.
    Boundary,
    /// Never moves, never removed.
    Fixed,
    /// On an internal boundary curve d_I = 0; moves along it; removed only along it.
    InternalBoundary {
        /// Which curve.
        curve: u32,
    },
}

/// A mesh as compact arrays: `points`, `cells` (indices into `points`: counter-clockwise
/// triangles, or positive tetrahedra), one label per cell (the subdomain), and the vertex key
/// of each point.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshArrays<P, const N: usize, K> {
    /// The points.
    pub points: Vec<P>,
    /// The cells, as indices into `points`.
    pub cells: Vec<[usize; N]>,
    /// The label (subdomain) of each cell.
    pub labels: Vec<u32>,
    /// The mesh's vertex key of each point.
    pub keys: Vec<K>,
}

/// A point type the engine can hold: planar ([`DVec2`]) or in space ([`DVec3`]).
pub trait MeshPoint: Copy + PartialEq + std::fmt::Debug + Send + Sync + 'static {
    /// The point in 3-D (z = 0 for planar points).
    fn to_3d(self) -> DVec3;
    /// Euclidean distance.
    fn dist(self, other: Self) -> f64;
    /// Linear interpolation a + t (b - a).
    fn lerp_to(self, other: Self, t: f64) -> Self;
    /// True when every coordinate is finite.
    fn finite(self) -> bool;
    /// The exact orientation of triangle (a, b, c). Planar points: exact orient2d. Points in
    /// space have no global orientation: `Zero` when the triangle is exactly degenerate (its
    /// cross product vanishes), else `Positive`; surface meshers check folds with normals.
    fn orientation(a: Self, b: Self, c: Self) -> Sign;
    /// Whether a flip must search the one-ring for an existing copy of the new edge. In a
    /// valid planar triangulation the new diagonal of a strictly convex quad lies inside the
    /// two old triangles, so it cannot exist yet and planar points skip the search (it still
    /// runs when a flip is refused, to report [`super::Refusal::DuplicateEdge`] first, as
    /// before). Points in space have no such guarantee and keep the search.
    const NEEDS_DUPLICATE_EDGE_CHECK: bool = true;
    /// The embedding check of a mesh whose faces all passed [`MeshPoint::orientation`]:
    /// planar points, one winding around every vertex and an uncrossed boundary; points in
    /// space, no self-intersection (see `embedding`).
    fn embedding(m: &TriMesh<Self>) -> Result<(), super::InvariantViolation>;
    /// Whether the fan of positive sectors (b, c) around `v` turns exactly once (`first` none:
    /// a closed fan) or by less than 2 pi from its first ring point `first` (an open fan).
    /// Planar points: exact (see `embedding`). Points in space have no plane to wind in and
    /// always pass: surface meshers check folds by normals and self-intersection.
    fn fan_winds_once(v: Self, sectors: impl Iterator<Item = (Self, Self)>, first: Option<Self>) -> bool;
    /// Whether moving the boundary path `old` (between its boundary neighbours `first` and
    /// `last`; `into_last` its loop half-edge into `last`) to the single point `p` keeps the new
    /// boundary edges clear of the rest of the boundary loop. Planar points: exact (see `fan`).
    /// Points in space pass (see [`MeshPoint::fan_winds_once`]).
    fn boundary_move_clear(
        m: &TriMesh<Self>,
        old: &[VertexId],
        p: Self,
        first: VertexId,
        last: VertexId,
        into_last: HalfEdgeId,
    ) -> bool;
}

impl MeshPoint for DVec2 {
    const NEEDS_DUPLICATE_EDGE_CHECK: bool = false;
    #[inline]
    fn to_3d(self) -> DVec3 {
        self.extend(0.0)
    }
    #[inline]
    fn dist(self, other: Self) -> f64 {
        self.distance(other)
    }
    #[inline]
    fn lerp_to(self, other: Self, t: f64) -> Self {
        self + (other - self) * t
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
    #[inline]
    fn orientation(a: Self, b: Self, c: Self) -> Sign {
        orient2d(a, b, c)
    }
    fn embedding(m: &TriMesh<Self>) -> Result<(), super::InvariantViolation> {
        super::embedding::planar(m)
    }
    #[inline]
    fn fan_winds_once(v: Self, sectors: impl Iterator<Item = (Self, Self)>, first: Option<Self>) -> bool {
        super::embedding::fan_winds_once(v, sectors, first)
    }
    fn boundary_move_clear(
        m: &TriMesh<Self>,
        old: &[VertexId],
        p: Self,
        first: VertexId,
        last: VertexId,
        into_last: HalfEdgeId,
    ) -> bool {
        super::fan::boundary_move_clear(m, old, p, first, last, into_last)
    }
}

impl MeshPoint for DVec3 {
    #[inline]
    fn to_3d(self) -> DVec3 {
        self
    }
    #[inline]
    fn dist(self, other: Self) -> f64 {
        self.distance(other)
    }
    #[inline]
    fn lerp_to(self, other: Self, t: f64) -> Self {
        self + (other - self) * t
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn orientation(a: Self, b: Self, c: Self) -> Sign {
        // Exactly degenerate when all three coordinate-plane projections are collinear.
        let xy = orient2d(DVec2::new(a.x, a.y), DVec2::new(b.x, b.y), DVec2::new(c.x, c.y));
        let yz = orient2d(DVec2::new(a.y, a.z), DVec2::new(b.y, b.z), DVec2::new(c.y, c.z));
        let zx = orient2d(DVec2::new(a.z, a.x), DVec2::new(b.z, b.x), DVec2::new(c.z, c.x));
        if xy == Sign::Zero && yz == Sign::Zero && zx == Sign::Zero {
            Sign::Zero
        } else {
            Sign::Positive
        }
    }
    fn embedding(m: &TriMesh<Self>) -> Result<(), super::InvariantViolation> {
        super::embedding::surface(m)
    }
    #[inline]
    fn fan_winds_once(_: Self, _: impl Iterator<Item = (Self, Self)>, _: Option<Self>) -> bool {
        true
    }
    fn boundary_move_clear(
        _: &TriMesh<Self>,
        _: &[VertexId],
        _: Self,
        _: VertexId,
        _: VertexId,
        _: HalfEdgeId,
    ) -> bool {
        true
    }
}

/// A vertex record.
#[derive(Clone, Debug, PartialEq)]
pub struct Vertex<P> {
    /// Position.
    pub pos: P,
    /// One outgoing half-edge; a boundary one when the vertex is on the boundary.
    pub out: HalfEdgeId,
    /// What the vertex may do.
    pub tag: VertexTag,
}

/// A half-edge record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HalfEdge {
    /// The vertex it leaves.
    pub origin: VertexId,
    /// The opposite half-edge of the same edge.
    pub twin: HalfEdgeId,
    /// The next half-edge around the face (or the boundary loop).
    pub next: HalfEdgeId,
    /// The face on its left, none on the boundary.
    pub face: Option<FaceId>,
}

/// A face record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Face {
    /// One of its three half-edges.
    pub half_edge: HalfEdgeId,
    /// Subdomain label; an edge between faces of different labels is an internal boundary.
    pub label: u32,
}

/// A half-edge triangle mesh over planar or spatial points, in slotmap arenas.
#[derive(Clone, Debug)]
pub struct TriMesh<P> {
    pub(crate) vertices: SlotMap<VertexId, Vertex<P>>,
    pub(crate) half_edges: SlotMap<HalfEdgeId, HalfEdge>,
    pub(crate) faces: SlotMap<FaceId, Face>,
}

impl<P: MeshPoint> PartialEq for TriMesh<P> {
    /// Equal when every arena holds the same keys (with versions) and records in the same order.
    fn eq(&self, other: &Self) -> bool {
        self.vertices.len() == other.vertices.len()
            && self.half_edges.len() == other.half_edges.len()
            && self.faces.len() == other.faces.len()
            && self.vertices.iter().zip(other.vertices.iter()).all(|(a, b)| a == b)
            && self.half_edges.iter().zip(other.half_edges.iter()).all(|(a, b)| a == b)
            && self.faces.iter().zip(other.faces.iter()).all(|(a, b)| a == b)
    }
}

impl<P: MeshPoint> Default for TriMesh<P> {
    fn default() -> Self {
        Self::new()
    }
}

impl<P: MeshPoint> TriMesh<P> {
    /// An empty mesh.
    pub fn new() -> Self {
        TriMesh { vertices: SlotMap::with_key(), half_edges: SlotMap::with_key(), faces: SlotMap::with_key() }
    }

    /// An empty mesh with room for about `n` vertices.
    pub fn with_capacity(n: usize) -> Self {
        TriMesh {
            vertices: SlotMap::with_capacity_and_key(n),
            half_edges: SlotMap::with_capacity_and_key(6 * n + 6),
            faces: SlotMap::with_capacity_and_key(2 * n + 2),
        }
    }

    // ----- counts -----

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.vertices.len()
    }
    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.faces.len()
    }
    /// Number of edges.
    pub fn num_edges(&self) -> usize {
        self.half_edges.len() / 2
    }
    /// Euler characteristic V - E + F.
    pub fn euler_characteristic(&self) -> i64 {
        self.num_vertices() as i64 - self.num_edges() as i64 + self.num_faces() as i64
    }

    // ----- element access -----

    /// The vertex record (panics on a stale key, like indexing).
    #[inline]
    pub fn vertex(&self, v: VertexId) -> &Vertex<P> {
        &self.vertices[v]
    }
    /// The half-edge record.
    #[inline]
    pub fn half_edge(&self, h: HalfEdgeId) -> &HalfEdge {
        &self.half_edges[h]
    }
    /// The face record.
    #[inline]
    pub fn face(&self, f: FaceId) -> &Face {
        &self.faces[f]
    }
    /// Whether the key names a live vertex.
    pub fn contains_vertex(&self, v: VertexId) -> bool {
        self.vertices.contains_key(v)
    }
    /// Whether the key names a live half-edge.
    pub fn contains_half_edge(&self, h: HalfEdgeId) -> bool {
        self.half_edges.contains_key(h)
    }
    /// Whether the key names a live face.
    pub fn contains_face(&self, f: FaceId) -> bool {
        self.faces.contains_key(f)
    }
    /// Position of a vertex.
    #[inline]
    pub fn pos(&self, v: VertexId) -> P {
        self.vertices[v].pos
    }
    /// Tag of a vertex.
    #[inline]
    pub fn tag(&self, v: VertexId) -> VertexTag {
        self.vertices[v].tag
    }
    /// Sets the tag of a vertex (tags carry no topological invariant).
    pub fn set_tag(&mut self, v: VertexId, tag: VertexTag) {
        self.vertices[v].tag = tag;
    }
    /// Sets the subdomain label of a face.
    pub fn set_label(&mut self, f: FaceId, label: u32) {
        self.faces[f].label = label;
    }
    /// Moves a vertex without any check. Callers that need validity use `relocate`.
    pub fn set_pos_unchecked(&mut self, v: VertexId, p: P) {
        self.vertices[v].pos = p;
    }

    /// Iterator over vertex keys.
    pub fn vertex_ids(&self) -> impl Iterator<Item = VertexId> + '_ {
        self.vertices.keys()
    }
    /// Iterator over face keys.
    pub fn face_ids(&self) -> impl Iterator<Item = FaceId> + '_ {
        self.faces.keys()
    }
    /// Iterator over half-edge keys.
    pub fn half_edge_ids(&self) -> impl Iterator<Item = HalfEdgeId> + '_ {
        self.half_edges.keys()
    }
    /// One half-edge per edge (the one with the smaller key).
    pub fn edge_ids(&self) -> impl Iterator<Item = HalfEdgeId> + '_ {
        self.half_edges.iter().filter(|(h, e)| *h < e.twin).map(|(h, _)| h)
    }
    /// Iterator over (key, vertex).
    pub fn vertices(&self) -> impl Iterator<Item = (VertexId, &Vertex<P>)> + '_ {
        self.vertices.iter()
    }

    // ----- navigation -----

    /// The opposite half-edge.
    #[inline]
    pub fn twin(&self, h: HalfEdgeId) -> HalfEdgeId {
        self.half_edges[h].twin
    }
    /// The next half-edge around the face or boundary loop.
    #[inline]
    pub fn next(&self, h: HalfEdgeId) -> HalfEdgeId {
        self.half_edges[h].next
    }
    /// The previous half-edge: two steps on a face, a walk around the origin on the boundary.
    pub fn prev(&self, h: HalfEdgeId) -> HalfEdgeId {
        if self.half_edges[h].face.is_some() {
            return self.next(self.next(h));
        }
        // The incoming half-edge of origin(h) whose next is h: rotate around the origin.
        let mut x = h;
        loop {
            let t = self.twin(x);
            if self.next(t) == h {
                return t;
            }
            x = self.next(t);
            debug_assert!(x != h, "prev: broken boundary loop");
            if x == h {
                return t;
            }
        }
    }
    /// The vertex a half-edge leaves.
    #[inline]
    pub fn origin(&self, h: HalfEdgeId) -> VertexId {
        self.half_edges[h].origin
    }
    /// The vertex a half-edge reaches.
    #[inline]
    pub fn dest(&self, h: HalfEdgeId) -> VertexId {
        self.half_edges[self.half_edges[h].twin].origin
    }
    /// The face on the left of a half-edge.
    #[inline]
    pub fn face_of(&self, h: HalfEdgeId) -> Option<FaceId> {
        self.half_edges[h].face
    }
    /// True when the half-edge has no face.
    #[inline]
    pub fn is_boundary_half_edge(&self, h: HalfEdgeId) -> bool {
        self.half_edges[h].face.is_none()
    }
    /// True when either side of the edge has no face.
    #[inline]
    pub fn is_boundary_edge(&self, h: HalfEdgeId) -> bool {
        self.half_edges[h].face.is_none() || self.half_edges[self.half_edges[h].twin].face.is_none()
    }
    /// True when the edge separates faces of different labels (an internal boundary).
    pub fn is_constrained_edge(&self, h: HalfEdgeId) -> bool {
        match (self.half_edges[h].face, self.half_edges[self.twin(h)].face) {
            (Some(a), Some(b)) => self.faces[a].label != self.faces[b].label,
            _ => false,
        }
    }
    /// True when the vertex lies on the boundary.
    #[inline]
    pub fn is_boundary_vertex(&self, v: VertexId) -> bool {
        self.half_edges[self.vertices[v].out].face.is_none()
    }
    /// The three half-edges of a face, starting from its stored one.
    #[inline]
    pub fn face_half_edges(&self, f: FaceId) -> [HalfEdgeId; 3] {
        let h0 = self.faces[f].half_edge;
        let h1 = self.half_edges[h0].next;
        let h2 = self.half_edges[h1].next;
        [h0, h1, h2]
    }
    /// The three vertices of a face, counter-clockwise.
    #[inline]
    pub fn face_vertices(&self, f: FaceId) -> [VertexId; 3] {
        let [a, b, c] = self.face_half_edges(f);
        [self.origin(a), self.origin(b), self.origin(c)]
    }
    /// The three positions of a face.
    #[inline]
    pub fn face_points(&self, f: FaceId) -> [P; 3] {
        let [a, b, c] = self.face_vertices(f);
        [self.pos(a), self.pos(b), self.pos(c)]
    }
    /// The outgoing half-edges of `v`, in clockwise order, starting at its `out`.
    pub fn outgoing(&self, v: VertexId) -> SmallVec<[HalfEdgeId; 8]> {
        let start = self.vertices[v].out;
        let mut out = SmallVec::new();
        let mut h = start;
        loop {
            out.push(h);
            h = self.half_edges[self.half_edges[h].twin].next;
            if h == start || out.len() > self.half_edges.len() {
                break;
            }
        }
        out
    }
    /// The one-ring neighbours of `v`.
    pub fn neighbours(&self, v: VertexId) -> SmallVec<[VertexId; 8]> {
        self.outgoing(v).into_iter().map(|h| self.dest(h)).collect()
    }
    /// The half-edges from each vertex of `vs` and, after each one that has a face, the link
    /// edge opposite the vertex in that face: the edges whose Delaunay test a change at the
    /// vertex (an insertion, a collapse into it, a move) can alter.
    pub fn star_edges(&self, vs: &[VertexId]) -> Vec<HalfEdgeId> {
        let mut out = Vec::with_capacity(12 * vs.len());
        for &v in vs {
            for h in self.outgoing(v) {
                out.push(h);
                if self.face_of(h).is_some() {
                    out.push(self.next(h));
                }
            }
        }
        out
    }
    /// The faces around `v`.
    pub fn vertex_faces(&self, v: VertexId) -> SmallVec<[FaceId; 8]> {
        self.outgoing(v).into_iter().filter_map(|h| self.face_of(h)).collect()
    }
    /// Number of edges at `v`.
    pub fn valence(&self, v: VertexId) -> usize {
        self.outgoing(v).len()
    }
    /// The half-edge a -> b, if the edge exists.
    pub fn find_half_edge(&self, a: VertexId, b: VertexId) -> Option<HalfEdgeId> {
        let start = self.vertices.get(a)?.out;
        let mut h = start;
        let mut steps = 0;
        loop {
            // One record per step: the twin holds both the destination and the next outgoing.
            let t = &self.half_edges[self.half_edges[h].twin];
            if t.origin == b {
                return Some(h);
            }
            h = t.next;
            steps += 1;
            if h == start || steps > self.half_edges.len() {
                return None;
            }
        }
    }
    /// Every boundary loop as a list of half-edges in loop order.
    pub fn boundary_loops(&self) -> Vec<Vec<HalfEdgeId>> {
        let mut seen = slotmap::SecondaryMap::new();
        let mut loops = Vec::new();
        for (h, e) in self.half_edges.iter() {
            if e.face.is_some() || seen.contains_key(h) {
                continue;
            }
            let mut lp = Vec::new();
            let mut x = h;
            while !seen.contains_key(x) {
                seen.insert(x, ());
                lp.push(x);
                x = self.next(x);
            }
            loops.push(lp);
        }
        loops
    }
    /// Length of the edge of `h`.
    pub fn edge_length(&self, h: HalfEdgeId) -> f64 {
        self.pos(self.origin(h)).dist(self.pos(self.dest(h)))
    }
    /// Quality q = 2 r_in / r_out of a face.
    pub fn face_quality(&self, f: FaceId) -> f64 {
        let [a, b, c] = self.face_points(f);
        crate::quality::triangle_q_from_lengths(b.dist(c), c.dist(a), a.dist(b))
    }
    /// Exact orientation of a face.
    pub fn face_orientation(&self, f: FaceId) -> Sign {
        let [a, b, c] = self.face_points(f);
        P::orientation(a, b, c)
    }

    // ----- construction -----

    /// Builds a mesh from points and counter-clockwise triangles (indices into `points`).
    /// Every point must be used; the result must be manifold. Returns the mesh and the vertex
    /// key of each point.
    pub fn from_arrays(points: &[P], triangles: &[[usize; 3]]) -> Result<(Self, Vec<VertexId>), crate::Error> {
        use crate::Error::InvalidMesh;
        let n = points.len();
        let mut m = TriMesh::with_capacity(n);
        let mut ids = Vec::with_capacity(n);
        for (i, &p) in points.iter().enumerate() {
            if !p.finite() {
                return Err(InvalidMesh(format!("point {i} is not finite")));
            }
            ids.push(m.vertices.insert(Vertex { pos: p, out: HalfEdgeId::default(), tag: VertexTag::Interior }));
        }
        let mut used = vec![false; n];
        for (ti, t) in triangles.iter().enumerate() {
            for &i in t {
                if i >= n {
                    return Err(InvalidMesh(format!("triangle {ti} refers to point {i}, past the {n} points")));
                }
                used[i] = true;
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(InvalidMesh(format!("triangle {ti} repeats a vertex")));
            }
        }
        if let Some(i) = used.iter().position(|u| !u) {
            return Err(InvalidMesh(format!("point {i} is used by no triangle")));
        }
        // Half-edge e is side e % 3 of triangle e / 3. They are listed by origin (CSR), and a
        // twin or a repeated side is looked for among the few half-edges leaving one vertex:
        // a hash map over all sides waits on a cache miss per lookup, and at 10^6 triangles
        // took most of the time of building the mesh.
        let ne = 3 * triangles.len();
        if ne > u32::MAX as usize {
            return Err(crate::Error::TooManyElements {
                estimated: triangles.len() as u64,
                limit: u32::MAX as u64 / 3,
            });
        }
        let side = |e: usize| -> (usize, usize) {
            let t = &triangles[e / 3];
            (t[e % 3], t[(e % 3 + 1) % 3])
        };
        let mut start = vec![0u32; n + 1];
        for t in triangles {
            for &i in t {
                start[i + 1] += 1;
            }
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut by_origin = vec![0u32; ne];
        let mut fill: Vec<u32> = start[..n].to_vec();
        for e in 0..ne {
            let a = side(e).0;
            by_origin[fill[a] as usize] = e as u32;
            fill[a] += 1;
        }
        drop(fill);
        // Each vertex's half-edges sorted by destination: a repeated side is two neighbours in
        // its list, and a twin is a binary search (a fan of many triangles around one vertex
        // stays cheap).
        {
            let mut lists: Vec<&mut [u32]> = Vec::with_capacity(n);
            let mut rest: &mut [u32] = &mut by_origin;
            for a in 0..n {
                let (list, tail) = rest.split_at_mut((start[a + 1] - start[a]) as usize);
                lists.push(list);
                rest = tail;
            }
            lists.par_iter_mut().with_min_len(4096).for_each(|l| l.sort_unstable_by_key(|&e| (side(e as usize).1, e)));
        }
        let leaving = |a: usize| &by_origin[start[a] as usize..start[a + 1] as usize];
        // The first triangle (in input order) that repeats a side of an earlier one.
        let repeated = (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .flat_map_iter(|a| leaving(a).windows(2))
            .filter(|w| side(w[0] as usize).1 == side(w[1] as usize).1)
            .map(|w| w[1] as usize)
            .min();
        if let Some(e) = repeated {
            let (a, b) = side(e);
            return Err(InvalidMesh(format!(
                "edge {a}-{b} is used twice in the same direction (triangle {}): inconsistent orientation or non-manifold",
                e / 3
            )));
        }
        // Faces and their half-edges in triangle order, then the boundary half-edges in side
        // order: the arenas' layout follows the input's.
        let mut hid: Vec<HalfEdgeId> = Vec::with_capacity(ne);
        for t in triangles {
            let f = m.faces.insert(Face { half_edge: HalfEdgeId::default(), label: 0 });
            let mut hs = [HalfEdgeId::default(); 3];
            for k in 0..3 {
                let h = m.half_edges.insert(HalfEdge {
                    origin: ids[t[k]],
                    twin: HalfEdgeId::default(),
                    next: HalfEdgeId::default(),
                    face: Some(f),
                });
                hid.push(h);
                hs[k] = h;
            }
            for k in 0..3 {
                m.half_edges[hs[k]].next = hs[(k + 1) % 3];
            }
            m.faces[f].half_edge = hs[0];
        }
        // Twins (found in parallel); create boundary half-edges where the opposite side is
        // missing.
        let twin_of: Vec<u32> = (0..ne)
            .into_par_iter()
            .with_min_len(4096)
            .map(|e| {
                let (a, b) = side(e);
                leaving(b).binary_search_by_key(&a, |&x| side(x as usize).1).map_or(u32::MAX, |x| leaving(b)[x])
            })
            .collect();
        let mut boundary: Vec<(HalfEdgeId, usize)> = Vec::new();
        for (e, &h) in hid.iter().enumerate() {
            let b = side(e).1;
            if twin_of[e] != u32::MAX {
                m.half_edges[h].twin = hid[twin_of[e] as usize];
            } else {
                let t =
                    m.half_edges.insert(HalfEdge { origin: ids[b], twin: h, next: HalfEdgeId::default(), face: None });
                m.half_edges[h].twin = t;
                boundary.push((t, b));
            }
        }
        // Vertex outs: boundary half-edges first (a vertex with two is non-manifold).
        let mut has_boundary_out = vec![false; n];
        for &(b, i) in &boundary {
            if has_boundary_out[i] {
                return Err(InvalidMesh(format!("point {i} is a non-manifold boundary vertex (two boundary fans)")));
            }
            has_boundary_out[i] = true;
            m.vertices[ids[i]].out = b;
        }
        for &(b, _) in &boundary {
            let dest = m.dest(b);
            m.half_edges[b].next = m.vertices[dest].out;
        }
        for (e, &h) in hid.iter().enumerate() {
            let a = side(e).0;
            if !has_boundary_out[a] {
                m.vertices[ids[a]].out = h;
            }
        }
        // Manifold check: the ring walk from out must visit every outgoing half-edge.
        let fans = (0..n).into_par_iter().with_min_len(4096).find_first(|&i| {
            let count = (start[i + 1] - start[i]) as usize + has_boundary_out[i] as usize;
            m.outgoing(ids[i]).len() != count
        });
        if let Some(i) = fans {
            return Err(InvalidMesh(format!("point {i} is a non-manifold vertex (its triangles form several fans)")));
        }
        Ok((m, ids))
    }

    /// Compacted arrays: the points, the counter-clockwise triangles, the face labels, and the
    /// vertex key of each point.
    pub fn to_arrays(&self) -> MeshArrays<P, 3, VertexId> {
        let mut index = slotmap::SecondaryMap::with_capacity(self.vertices.len());
        let mut points = Vec::with_capacity(self.vertices.len());
        let mut keys = Vec::with_capacity(self.vertices.len());
        for (v, vx) in self.vertices.iter() {
            index.insert(v, points.len());
            points.push(vx.pos);
            keys.push(v);
        }
        let mut tris = Vec::with_capacity(self.faces.len());
        let mut labels = Vec::with_capacity(self.faces.len());
        for (f, fx) in self.faces.iter() {
            let [a, b, c] = self.face_vertices(f);
            tris.push([index[a], index[b], index[c]]);
            labels.push(fx.label);
        }
        MeshArrays { points, cells: tris, labels, keys }
    }

    /// Checks that a key is live, as a refusal.
    #[inline]
    pub(crate) fn live_he(&self, h: HalfEdgeId) -> Result<(), Refusal> {
        if self.half_edges.contains_key(h) {
            Ok(())
        } else {
            Err(Refusal::StaleKey)
        }
    }
}
