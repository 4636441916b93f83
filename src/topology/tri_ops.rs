//! Local operations on [`TriMesh`]: flip, split, collapse, insertion in a face, relocation and
//! boundary ear filling. Each is a `check_*` that only reads and returns a plan or a
//! [`Refusal`], and an `apply_*` that only writes and cannot fail.

use super::trimesh::{Face, FaceId, HalfEdge, HalfEdgeId, MeshPoint, TriMesh, Vertex, VertexId, VertexTag};
use super::Refusal;
use crate::predicates::Sign;
use smallvec::SmallVec;

/// Maps an exact orientation to a refusal: only `Positive` passes.
#[inline]
fn positive(s: Sign) -> Result<(), Refusal> {
    match s {
        Sign::Positive => Ok(()),
        Sign::Zero => Err(Refusal::WouldDegenerate),
        Sign::Negative => Err(Refusal::WouldInvert),
    }
}

/// What a checked edge flip will do.
///
/// ```text
///        c                 c
///       / \               /|\
///      / f1\             / | \
///     a-----b    ==>    a f1|f2 b      h: a->b becomes d->c
///      \ f2/             \ | /
///       \ /               \|/
///        d                 d
/// ```
#[derive(Clone, Copy, Debug)]
pub struct FlipPlan {
    pub(crate) h: HalfEdgeId,
    pub(crate) t: HalfEdgeId,
    pub(crate) h_bc: HalfEdgeId,
    pub(crate) h_ca: HalfEdgeId,
    pub(crate) t_ad: HalfEdgeId,
    pub(crate) t_db: HalfEdgeId,
    pub(crate) a: VertexId,
    pub(crate) b: VertexId,
    pub(crate) c: VertexId,
    pub(crate) d: VertexId,
    pub(crate) f1: FaceId,
    pub(crate) f2: FaceId,
}

/// What a checked edge split will do.
#[derive(Clone, Copy, Debug)]
pub struct SplitPlan<P> {
    h: HalfEdgeId,
    p: P,
    tag: VertexTag,
    /// The boundary half-edge before twin(h), when twin(h) is on the boundary.
    t_prev: Option<HalfEdgeId>,
}

/// What a checked edge collapse will do: vertex `a` = origin(h) merges into `b` = dest(h),
/// which ends at `pos`.
#[derive(Clone, Debug)]
pub struct CollapsePlan<P> {
    h: HalfEdgeId,
    pos: P,
    a_out: SmallVec<[HalfEdgeId; 8]>,
    h_prev: Option<HalfEdgeId>,
    t_prev: Option<HalfEdgeId>,
}

/// What a checked insertion of a vertex inside a face will do.
#[derive(Clone, Copy, Debug)]
pub struct InsertPlan<P> {
    pub(crate) f: FaceId,
    pub(crate) p: P,
}

impl<P: MeshPoint> TriMesh<P> {
    // ===================== flip =====================

    /// Checks the flip of the edge of `h`: both sides must be faces of the same label, the new
    /// edge must not exist yet, and both new triangles must be positively oriented (exact).
    pub fn check_flip(&self, h: HalfEdgeId) -> Result<FlipPlan, Refusal> {
        let eh = *self.half_edges.get(h).ok_or(Refusal::StaleKey)?;
        let t = eh.twin;
        let et = self.half_edges[t];
        let f1 = eh.face.ok_or(Refusal::BoundaryEdge)?;
        let f2 = et.face.ok_or(Refusal::BoundaryEdge)?;
        // An edge between subdomains is an internal boundary.
        if self.faces[f1].label != self.faces[f2].label {
            return Err(Refusal::Constrained);
        }
        let plan = self.flip_quad(h, eh, t, et, f1, f2);
        let (a, b, c, d) = (plan.a, plan.b, plan.c, plan.d);
        // The new edge c-d must not already exist elsewhere (see `NEEDS_DUPLICATE_EDGE_CHECK`).
        if c == d || (P::NEEDS_DUPLICATE_EDGE_CHECK && self.find_half_edge(c, d).is_some()) {
            return Err(Refusal::DuplicateEdge);
        }
        let (pa, pb, pc, pd) = (self.pos(a), self.pos(b), self.pos(c), self.pos(d));
        // Both new triangles positive: the quad a-d-b-c is strictly convex at a and b.
        let convex = positive(P::orientation(pc, pa, pd)).and_then(|()| positive(P::orientation(pd, pb, pc)));
        if convex.is_err() && !P::NEEDS_DUPLICATE_EDGE_CHECK && self.find_half_edge(c, d).is_some() {
            // The skipped search still decides the reason of a refusal, as it always did.
            return Err(Refusal::DuplicateEdge);
        }
        convex.map(|()| plan)
    }

    /// The flip plan of the interior edge of `h` (records `eh` of `h` and `et` of its twin `t`,
    /// faces `f1` and `f2`): topology only, nothing checked.
    #[inline]
    fn flip_quad(&self, h: HalfEdgeId, eh: HalfEdge, t: HalfEdgeId, et: HalfEdge, f1: FaceId, f2: FaceId) -> FlipPlan {
        let h_bc = eh.next;
        let h_ca = self.half_edges[h_bc].next;
        let t_ad = et.next;
        let t_db = self.half_edges[t_ad].next;
        let c = self.half_edges[h_ca].origin;
        let d = self.half_edges[t_db].origin;
        FlipPlan { h, t, h_bc, h_ca, t_ad, t_db, a: eh.origin, b: et.origin, c, d, f1, f2 }
    }

    /// Applies a checked flip. Afterwards `h` runs d -> c and `twin(h)` c -> d.
    #[inline]
    pub fn apply_flip(&mut self, p: FlipPlan) {
        let he = &mut self.half_edges;
        let x = &mut he[p.h];
        x.origin = p.d;
        x.next = p.h_ca;
        he[p.h_ca].next = p.t_ad;
        let x = &mut he[p.t_ad];
        x.next = p.h;
        x.face = Some(p.f1);
        let x = &mut he[p.t];
        x.origin = p.c;
        x.next = p.t_db;
        he[p.t_db].next = p.h_bc;
        let x = &mut he[p.h_bc];
        x.next = p.t;
        x.face = Some(p.f2);
        self.faces[p.f1].half_edge = p.h;
        self.faces[p.f2].half_edge = p.t;
        let va = &mut self.vertices[p.a];
        if va.out == p.h {
            va.out = p.t_ad;
        }
        let vb = &mut self.vertices[p.b];
        if vb.out == p.t {
            vb.out = p.h_bc;
        }
    }

    /// Flips the edge of `h` if allowed.
    pub fn flip(&mut self, h: HalfEdgeId) -> Result<(), Refusal> {
        let plan = self.check_flip(h)?;
        self.apply_flip(plan);
        Ok(())
    }

    /// The flip plan of `h` when both sides are faces of the same label, else `None`: for
    /// Lawson loops, which then decide by in-circle and orientation themselves.
    #[inline]
    pub(crate) fn interior_quad(&self, h: HalfEdgeId) -> Option<FlipPlan> {
        let eh = self.half_edges[h];
        let t = eh.twin;
        let et = self.half_edges[t];
        let (f1, f2) = (eh.face?, et.face?);
        if self.faces[f1].label != self.faces[f2].label {
            return None;
        }
        Some(self.flip_quad(h, eh, t, et, f1, f2))
    }

    // ===================== split =====================

    /// Checks splitting the edge of `h` (a -> b) at `p`: every new triangle must be positive.
    ///
    /// ```text
    ///        c                 c
    ///       / \               /|\
    ///      /   \             / | \
    ///     a-----b    ==>    a--v--b
    ///      \   /             \ | /
    ///       \ /               \|/
    ///        d                 d
    /// ```
    /// The new vertex is tagged `Boundary` on a boundary edge, `InternalBoundary` on an edge
    /// between subdomains, `Interior` otherwise.
    pub fn check_split(&self, h: HalfEdgeId, p: P) -> Result<SplitPlan<P>, Refusal> {
        self.live_he(h)?;
        if !p.finite() {
            return Err(Refusal::NonFinite);
        }
        let t = self.twin(h);
        let (a, b) = (self.origin(h), self.origin(t));
        let (pa, pb) = (self.pos(a), self.pos(b));
        if let Some(_f1) = self.face_of(h) {
            let c = self.origin(self.prev(h));
            let pc = self.pos(c);
            positive(P::orientation(pa, p, pc))?;
            positive(P::orientation(p, pb, pc))?;
        }
        if let Some(_f2) = self.face_of(t) {
            let d = self.origin(self.prev(t));
            let pd = self.pos(d);
            positive(P::orientation(pb, p, pd))?;
            positive(P::orientation(p, pa, pd))?;
        }
        let tag = if self.is_boundary_edge(h) {
            VertexTag::Boundary
        } else if self.is_constrained_edge(h) {
            let curve = match (self.tag(a), self.tag(b)) {
                (VertexTag::InternalBoundary { curve }, _) | (_, VertexTag::InternalBoundary { curve }) => curve,
                _ => 0,
            };
            VertexTag::InternalBoundary { curve }
        } else {
            VertexTag::Interior
        };
        let t_prev = if self.face_of(t).is_none() { Some(self.prev(t)) } else { None };
        Ok(SplitPlan { h, p, tag, t_prev })
    }

    /// Applies a checked split and returns the new vertex. Afterwards `h` runs a -> v.
    pub fn apply_split(&mut self, plan: SplitPlan<P>) -> VertexId {
        let h = plan.h;
        let t = self.twin(h);
        let a = self.origin(h);
        let b = self.origin(t);
        let f1 = self.face_of(h);
        let f2 = self.face_of(t);
        let hn = self.next(h);
        let v = self.vertices.insert(Vertex { pos: plan.p, out: h, tag: plan.tag });
        let h2 = self.half_edges.insert(HalfEdge { origin: v, twin: t, next: hn, face: f1 });
        let t2 = self.half_edges.insert(HalfEdge { origin: b, twin: h2, next: t, face: f2 });
        self.half_edges[h2].twin = t2;
        self.half_edges[t].origin = v;
        let _ = a;
        if self.vertices[b].out == t {
            self.vertices[b].out = t2;
        }
        // Side of h.
        match f1 {
            Some(f1) => {
                let h_bc = hn;
                let h_ca = self.next(h_bc);
                let c = self.origin(h_ca);
                let label = self.faces[f1].label;
                let f3 = self.faces.insert(Face { half_edge: h2, label });
                let m = self.half_edges.insert(HalfEdge { origin: v, twin: h, next: h_ca, face: Some(f1) });
                let mt = self.half_edges.insert(HalfEdge { origin: c, twin: m, next: h2, face: Some(f3) });
                self.half_edges[m].twin = mt;
                self.half_edges[h].next = m;
                self.half_edges[h2].face = Some(f3);
                self.half_edges[h2].next = h_bc;
                self.half_edges[h_bc].next = mt;
                self.half_edges[h_bc].face = Some(f3);
                self.faces[f1].half_edge = h;
            }
            None => {
                self.half_edges[h].next = h2;
                self.half_edges[h2].next = hn;
            }
        }
        // Side of t (now v -> a); t2 is b -> v.
        match f2 {
            Some(f2) => {
                let t_ad = self.next(t);
                let t_db = self.next(t_ad);
                let d = self.origin(t_db);
                let label = self.faces[f2].label;
                let f4 = self.faces.insert(Face { half_edge: t2, label });
                let n = self.half_edges.insert(HalfEdge { origin: v, twin: t, next: t_db, face: Some(f4) });
                let nt = self.half_edges.insert(HalfEdge { origin: d, twin: n, next: t, face: Some(f2) });
                self.half_edges[n].twin = nt;
                self.half_edges[t_ad].next = nt;
                self.half_edges[t2].next = n;
                self.half_edges[t2].face = Some(f4);
                self.half_edges[t_db].next = t2;
                self.half_edges[t_db].face = Some(f4);
                self.faces[f2].half_edge = t;
            }
            None => {
                let tp = plan.t_prev.expect("split plan without the boundary predecessor");
                self.half_edges[tp].next = t2;
                self.half_edges[t2].next = t;
            }
        }
        // The new vertex points at a boundary half-edge if it is on the boundary.
        self.vertices[v].out = if f1.is_none() {
            h2
        } else if f2.is_none() {
            t
        } else {
            h2
        };
        self.half_edges[h].twin = t;
        v
    }

    /// Splits the edge of `h` at `p` if allowed; returns the new vertex.
    pub fn split_edge(&mut self, h: HalfEdgeId, p: P) -> Result<VertexId, Refusal> {
        let plan = self.check_split(h, p)?;
        Ok(self.apply_split(plan))
    }

    // ===================== collapse =====================

    /// Checks collapsing the edge of `h`: a = origin(h) merges into b = dest(h), which moves to
    /// `pos`. Refused when it fails the link condition, would invert or degenerate a triangle,
    /// would fold a fan or cross the boundary (see `fan`), would pinch the boundary, or a tag
    /// protects a vertex: fixed vertices never go and never
    /// move; boundary vertices go only along boundary edges into boundary or fixed vertices;
    /// internal-boundary vertices only along internal-boundary edges into the same curve.
    pub fn check_collapse(&self, h: HalfEdgeId, pos: P) -> Result<CollapsePlan<P>, Refusal> {
        self.live_he(h)?;
        if !pos.finite() {
            return Err(Refusal::NonFinite);
        }
        let t = self.twin(h);
        let (a, b) = (self.origin(h), self.origin(t));
        let (f1, f2) = (self.face_of(h), self.face_of(t));
        let (tag_a, tag_b) = (self.tag(a), self.tag(b));
        let boundary_edge = f1.is_none() || f2.is_none();
        // Tags.
        match tag_a {
            VertexTag::Fixed => return Err(Refusal::Protected(tag_a)),
            VertexTag::Boundary => {
                if !boundary_edge || !matches!(tag_b, VertexTag::Boundary | VertexTag::Fixed) {
                    return Err(Refusal::Protected(tag_a));
                }
            }
            VertexTag::InternalBoundary { curve } => {
                let same = matches!(tag_b, VertexTag::InternalBoundary { curve: cb } if cb == curve)
                    || tag_b == VertexTag::Fixed;
                if !self.is_constrained_edge(h) || !same {
                    return Err(Refusal::Protected(tag_a));
                }
            }
            VertexTag::Interior => {}
        }
        if tag_b == VertexTag::Fixed && pos != self.pos(b) {
            return Err(Refusal::Protected(tag_b));
        }
        // An interior edge between two boundary vertices would pinch the domain.
        if !boundary_edge && self.is_boundary_vertex(a) && self.is_boundary_vertex(b) {
            return Err(Refusal::LinkCondition);
        }
        // Link condition: the common neighbours are exactly the opposite vertices.
        let a_out = self.outgoing(a);
        let nb = self.neighbours(b);
        let mut opposite: SmallVec<[VertexId; 2]> = SmallVec::new();
        if f1.is_some() {
            opposite.push(self.origin(self.prev(h)));
        }
        if f2.is_some() {
            opposite.push(self.origin(self.prev(t)));
        }
        let mut common = 0;
        for &x in a_out.iter() {
            let w = self.dest(x);
            if nb.contains(&w) {
                if !opposite.contains(&w) {
                    return Err(Refusal::LinkCondition);
                }
                common += 1;
            }
        }
        if common != opposite.len() {
            return Err(Refusal::LinkCondition);
        }
        // A removed face whose two other edges are both on the boundary would leave a dangling edge.
        for (side, f) in [(h, f1), (t, f2)] {
            if f.is_some() {
                let e1 = self.twin(self.next(side));
                let e2 = self.twin(self.prev(side));
                if self.face_of(e1).is_none() && self.face_of(e2).is_none() {
                    return Err(Refusal::TooSmall);
                }
            }
        }
        // Geometry: every surviving face around a and b stays positive with b at pos.
        for &x in a_out.iter() {
            if let Some(f) = self.face_of(x) {
                if Some(f) == f1 || Some(f) == f2 {
                    continue;
                }
                let y = self.next(x);
                let (p1, p2) = (self.pos(self.origin(y)), self.pos(self.dest(y)));
                positive(P::orientation(pos, p1, p2))?;
            }
        }
        for x in self.outgoing(b) {
            if let Some(f) = self.face_of(x) {
                if Some(f) == f1 || Some(f) == f2 {
                    continue;
                }
                let y = self.next(x);
                let (p1, p2) = (self.pos(self.origin(y)), self.pos(self.dest(y)));
                positive(P::orientation(pos, p1, p2))?;
            }
        }
        self.check_move_fans(&super::fan::Move { gone: a, kept: b, pos, skip: [f1, f2] })?;
        let h_prev = if f1.is_none() { Some(self.prev(h)) } else { None };
        let t_prev = if f2.is_none() { Some(self.prev(t)) } else { None };
        Ok(CollapsePlan { h, pos, a_out, h_prev, t_prev })
    }

    /// Applies a checked collapse; returns the surviving vertex b.
    pub fn apply_collapse(&mut self, plan: CollapsePlan<P>) -> VertexId {
        let h = plan.h;
        let t = self.twin(h);
        let a = self.origin(h);
        let b = self.origin(t);
        let f1 = self.face_of(h);
        let f2 = self.face_of(t);
        for &x in plan.a_out.iter() {
            if x != h {
                self.half_edges[x].origin = b;
            }
        }
        let mut b_out_candidate = None;
        match f1 {
            Some(f1) => {
                let h_bc = self.next(h);
                let h_ca = self.next(h_bc);
                let c = self.origin(h_ca);
                let e1 = self.twin(h_bc); // c -> b
                let e2 = self.twin(h_ca); // was a -> c, now b -> c
                self.half_edges[e1].twin = e2;
                self.half_edges[e2].twin = e1;
                if self.vertices[c].out == h_ca {
                    self.vertices[c].out = e1;
                }
                self.half_edges.remove(h_bc);
                self.half_edges.remove(h_ca);
                self.faces.remove(f1);
                b_out_candidate = Some(e2);
            }
            None => {
                let hp = plan.h_prev.expect("collapse plan without boundary predecessor");
                let hn = self.next(h);
                self.half_edges[hp].next = hn;
                b_out_candidate.get_or_insert(hn);
            }
        }
        match f2 {
            Some(f2) => {
                let t_ad = self.next(t);
                let t_db = self.next(t_ad);
                let d = self.origin(t_db);
                let e3 = self.twin(t_ad); // was d -> a, now d -> b
                let e4 = self.twin(t_db); // b -> d
                self.half_edges[e3].twin = e4;
                self.half_edges[e4].twin = e3;
                if self.vertices[d].out == t_db {
                    self.vertices[d].out = e3;
                }
                self.half_edges.remove(t_ad);
                self.half_edges.remove(t_db);
                self.faces.remove(f2);
                b_out_candidate.get_or_insert(e4);
            }
            None => {
                let tp = plan.t_prev.expect("collapse plan without boundary predecessor");
                let tn = self.next(t);
                self.half_edges[tp].next = tn;
                b_out_candidate = Some(tn);
            }
        }
        self.half_edges.remove(h);
        self.half_edges.remove(t);
        self.vertices.remove(a);
        self.vertices[b].pos = plan.pos;
        let start = b_out_candidate.expect("an edge has a face on at least one side");
        self.vertices[b].out = start;
        self.fix_out(b);
        b
    }

    /// Collapses the edge of `h` (origin into destination, which ends at `pos`) if allowed.
    pub fn collapse(&mut self, h: HalfEdgeId, pos: P) -> Result<VertexId, Refusal> {
        let plan = self.check_collapse(h, pos)?;
        Ok(self.apply_collapse(plan))
    }

    /// Points `v.out` at its boundary half-edge if it has one.
    pub(crate) fn fix_out(&mut self, v: VertexId) {
        let start = self.vertices[v].out;
        let mut x = start;
        loop {
            if self.half_edges[x].face.is_none() {
                self.vertices[v].out = x;
                return;
            }
            x = self.next(self.twin(x));
            if x == start {
                return;
            }
        }
    }

    // ===================== insertion in a face =====================

    /// Checks inserting a vertex at `p` strictly inside face `f`.
    pub fn check_insert_in_face(&self, f: FaceId, p: P) -> Result<InsertPlan<P>, Refusal> {
        if !self.faces.contains_key(f) {
            return Err(Refusal::StaleKey);
        }
        if !p.finite() {
            return Err(Refusal::NonFinite);
        }
        let [a, b, c] = self.face_points(f);
        positive(P::orientation(a, b, p))?;
        positive(P::orientation(b, c, p))?;
        positive(P::orientation(c, a, p))?;
        Ok(InsertPlan { f, p })
    }

    /// Applies a checked insertion; returns the new vertex.
    ///
    /// ```text
    ///        c
    ///       /|\
    ///      / v \        face (a, b, c) becomes (a, b, v), (b, c, v), (c, a, v)
    ///     /_/ \_\
    ///    a-------b
    /// ```
    pub fn apply_insert_in_face(&mut self, plan: InsertPlan<P>) -> VertexId {
        self.insert_in_face_raw(plan).0
    }

    /// [`TriMesh::apply_insert_in_face`], also returning the three old edges of the face
    /// (a -> b, b -> c, c -> a), now the link of the new vertex.
    pub(crate) fn insert_in_face_raw(&mut self, plan: InsertPlan<P>) -> (VertexId, [HalfEdgeId; 3]) {
        let f = plan.f;
        let Face { half_edge: hab, label } = self.faces[f];
        let hbc = self.half_edges[hab].next;
        let e_bc = self.half_edges[hbc];
        let hca = e_bc.next;
        let a = self.half_edges[hab].origin;
        let b = e_bc.origin;
        let c = self.half_edges[hca].origin;
        let v = self.vertices.insert(Vertex { pos: plan.p, out: hab, tag: VertexTag::Interior });
        let f2 = self.faces.insert(Face { half_edge: hbc, label });
        let f3 = self.faces.insert(Face { half_edge: hca, label });
        // Inserted in the order va, av, vb, bv, vc, cv; the keys not known yet are patched after.
        let he = &mut self.half_edges;
        let va = he.insert(HalfEdge { origin: v, twin: hab, next: hab, face: Some(f) });
        let av = he.insert(HalfEdge { origin: a, twin: va, next: hab, face: Some(f3) });
        let vb = he.insert(HalfEdge { origin: v, twin: hab, next: hbc, face: Some(f2) });
        let bv = he.insert(HalfEdge { origin: b, twin: vb, next: va, face: Some(f) });
        let vc = he.insert(HalfEdge { origin: v, twin: hab, next: hca, face: Some(f3) });
        let cv = he.insert(HalfEdge { origin: c, twin: vc, next: vb, face: Some(f2) });
        he[va].twin = av;
        let x = &mut he[av];
        x.next = vc;
        he[vb].twin = bv;
        he[vc].twin = cv;
        // (a, b, v), (b, c, v), (c, a, v)
        he[hab].next = bv;
        let x = &mut he[hbc];
        x.next = cv;
        x.face = Some(f2);
        let x = &mut he[hca];
        x.next = av;
        x.face = Some(f3);
        self.vertices[v].out = va;
        (v, [hab, hbc, hca])
    }

    /// Inserts a vertex at `p` inside face `f` if allowed.
    pub fn insert_in_face(&mut self, f: FaceId, p: P) -> Result<VertexId, Refusal> {
        let plan = self.check_insert_in_face(f, p)?;
        Ok(self.apply_insert_in_face(plan))
    }

    // ===================== relocation =====================

    /// Checks moving `v` to `p`: fixed vertices never move; every face around `v` stays
    /// positive, and no fan folds (the open fans of a boundary vertex and of its two boundary
    /// neighbours turn by less than 2 pi; closed fans cannot fold, see `fan`).
    pub fn check_relocate(&self, v: VertexId, p: P) -> Result<(), Refusal> {
        let vx = self.vertices.get(v).ok_or(Refusal::StaleKey)?;
        if vx.tag == VertexTag::Fixed {
            return Err(Refusal::Protected(VertexTag::Fixed));
        }
        if !p.finite() {
            return Err(Refusal::NonFinite);
        }
        let start = vx.out;
        let mut x = start;
        loop {
            if self.half_edges[x].face.is_some() {
                let y = self.next(x);
                positive(P::orientation(p, self.pos(self.origin(y)), self.pos(self.dest(y))))?;
            }
            x = self.next(self.twin(x));
            if x == start {
                break;
            }
        }
        self.check_move_fans(&super::fan::Move { gone: v, kept: v, pos: p, skip: [None, None] })
    }

    /// Moves `v` to `p` if allowed.
    pub fn relocate(&mut self, v: VertexId, p: P) -> Result<(), Refusal> {
        self.check_relocate(v, p)?;
        self.vertices[v].pos = p;
        Ok(())
    }

    // ===================== boundary ear =====================

    /// Adds the triangle (a, b, c) on two consecutive boundary half-edges h = a -> b and
    /// next(h) = b -> c, when it is positive and the edge a-c does not exist yet.
    pub fn fill_boundary_ear(&mut self, h: HalfEdgeId, label: u32) -> Result<FaceId, Refusal> {
        self.live_he(h)?;
        if self.face_of(h).is_some() {
            return Err(Refusal::BoundaryEdge);
        }
        let g = self.next(h);
        let (a, b, c) = (self.origin(h), self.origin(g), self.dest(g));
        if a == c || self.find_half_edge(a, c).is_some() {
            return Err(Refusal::DuplicateEdge);
        }
        let (pa, pb, pc) = (self.pos(a), self.pos(b), self.pos(c));
        positive(P::orientation(pa, pb, pc))?;
        // Planar meshes: the ear must not cover a neighbouring vertex (it would overlap the
        // triangles there). Surfaces have no global orientation to test this with.
        if !P::NEEDS_DUPLICATE_EDGE_CHECK {
            for v in [a, b, c] {
                for w in self.neighbours(v) {
                    if w == a || w == b || w == c {
                        continue;
                    }
                    let pw = self.pos(w);
                    let inside = P::orientation(pa, pb, pw) != Sign::Negative
                        && P::orientation(pb, pc, pw) != Sign::Negative
                        && P::orientation(pc, pa, pw) != Sign::Negative;
                    if inside {
                        return Err(Refusal::NotConvex);
                    }
                }
            }
        }
        let hp = self.prev(h);
        let gn = self.next(g);
        let f = self.faces.insert(Face { half_edge: h, label });
        let e = self.half_edges.insert(HalfEdge { origin: c, twin: h, next: h, face: Some(f) });
        let et = self.half_edges.insert(HalfEdge { origin: a, twin: e, next: gn, face: None });
        self.half_edges[e].twin = et;
        self.half_edges[h].face = Some(f);
        self.half_edges[h].next = g;
        self.half_edges[g].face = Some(f);
        self.half_edges[g].next = e;
        self.half_edges[hp].next = et;
        self.vertices[a].out = et;
        self.fix_out(b);
        Ok(f)
    }
}

impl<P: MeshPoint> TriMesh<P> {
    /// Removes the triangle across the boundary half-edge `t` when its apex is an interior
    /// vertex, which then joins the boundary (the inverse of [`TriMesh::fill_boundary_ear`]).
    ///
    /// ```text
    ///        v                    v
    ///       / \                  / \
    ///      / f \       ==>      /   \        v becomes a boundary vertex
    ///     a-----b              a     b
    ///   ----t---->  boundary
    /// ```
    pub fn remove_boundary_triangle(&mut self, t: HalfEdgeId) -> Result<VertexId, Refusal> {
        self.live_he(t)?;
        if self.face_of(t).is_some() {
            return Err(Refusal::BoundaryEdge);
        }
        let h = self.twin(t);
        let f = self.face_of(h).ok_or(Refusal::BoundaryEdge)?;
        if self.faces.len() <= 1 {
            return Err(Refusal::TooSmall);
        }
        let h_bv = self.next(h);
        let h_va = self.next(h_bv);
        let v = self.origin(h_va);
        // The apex must be interior, or it would get two boundary fans.
        if self.is_boundary_vertex(v) {
            return Err(Refusal::LinkCondition);
        }
        let (a, b) = (self.origin(h), self.origin(t));
        let tp = self.prev(t);
        let tn = self.next(t);
        self.half_edges[tp].next = h_bv;
        self.half_edges[h_bv].next = h_va;
        self.half_edges[h_bv].face = None;
        self.half_edges[h_va].next = tn;
        self.half_edges[h_va].face = None;
        self.half_edges.remove(h);
        self.half_edges.remove(t);
        self.faces.remove(f);
        self.vertices[v].out = h_va;
        self.vertices[b].out = h_bv;
        if self.vertices[a].out == h {
            self.vertices[a].out = tn;
        }
        self.fix_out(a);
        Ok(v)
    }

    /// Removes the boundary vertex `v` together with its only triangle (a, v, c), whose edge
    /// a-c joins the boundary (the inverse of [`TriMesh::fill_boundary_ear`]). Used to peel
    /// off flat ears: three boundary vertices on a straight stretch of boundary joined by a
    /// triangle of (nearly) no area.
    ///
    /// ```text
    ///     a-----c              a-----c
    ///      \ f /       ==>
    ///       \ /                          v and f gone
    ///        v
    /// ```
    /// Refused unless `v` is tagged `Boundary` with exactly one triangle, a and c are
    /// `Boundary` or `Fixed`, and a-c has a triangle on its other side (so the rest stays).
    pub fn remove_boundary_ear(&mut self, v: VertexId) -> Result<(), Refusal> {
        let vx = self.vertices.get(v).ok_or(Refusal::StaleKey)?;
        if vx.tag != VertexTag::Boundary {
            return Err(Refusal::Protected(vx.tag));
        }
        // v's outgoing boundary half-edge v -> a, then the face's a -> v before it.
        let t_va = vx.out;
        if self.face_of(t_va).is_some() {
            return Err(Refusal::LinkCondition);
        }
        let h_av = self.twin(t_va);
        let f = self.face_of(h_av).ok_or(Refusal::TooSmall)?;
        let h_vc = self.next(h_av);
        let h_ca = self.next(h_vc);
        let t_cv = self.twin(h_vc);
        // Exactly one triangle: v's other edge is on the boundary too.
        if self.face_of(t_cv).is_some() {
            return Err(Refusal::LinkCondition);
        }
        let (a, c) = (self.origin(h_av), self.origin(h_ca));
        for u in [a, c] {
            if !matches!(self.tag(u), VertexTag::Boundary | VertexTag::Fixed) {
                return Err(Refusal::Protected(self.tag(u)));
            }
        }
        if self.face_of(self.twin(h_ca)).is_none() {
            return Err(Refusal::TooSmall);
        }
        let before = self.prev(t_cv);
        let after = self.next(t_va);
        self.half_edges[before].next = h_ca;
        self.half_edges[h_ca].next = after;
        self.half_edges[h_ca].face = None;
        for x in [h_av, h_vc, t_va, t_cv] {
            self.half_edges.remove(x);
        }
        self.faces.remove(f);
        self.vertices.remove(v);
        self.vertices[c].out = h_ca;
        self.vertices[a].out = after;
        Ok(())
    }
}
