//! Delaunay by local flipping: the Lawson flip loop with exact in-circle, and incremental
//! insertion from one enclosing triangle (walk to locate, split, flip).

use super::tri_ops::{FlipPlan, InsertPlan};
use super::trimesh::{FaceId, HalfEdgeId, TriMesh, VertexId, VertexTag};
use crate::predicates::{incircle, orient2d, Sign};
use glam::DVec2;
use rayon::prelude::*;

/// Indices of `points` sorted along a Hilbert curve over their bounding box, so that
/// consecutive points are near each other (short location walks, cache-friendly arenas).
pub fn hilbert_order(points: &[DVec2]) -> Vec<usize> {
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let span = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    const ORDER: u32 = 16;
    let scale = ((1u64 << ORDER) - 1) as f64 / span;
    // In parallel: the (key, index) pairs are distinct, so the order is the same for any
    // thread count.
    let mut keyed: Vec<(u64, usize)> = points
        .par_iter()
        .enumerate()
        .with_min_len(4096)
        .map(|(i, p)| {
            let q = (*p - lo) * scale;
            (hilbert_index(q.x as u32, q.y as u32, ORDER), i)
        })
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// Position of (x, y) along the Hilbert curve of the given order (classic rotate-and-reflect).
fn hilbert_index(mut x: u32, mut y: u32, order: u32) -> u64 {
    let n: u32 = 1 << order;
    let mut d: u64 = 0;
    let mut s = n / 2;
    while s > 0 {
        let rx = u32::from(x & s > 0);
        let ry = u32::from(y & s > 0);
        d += (s as u64) * (s as u64) * ((3 * rx) ^ ry) as u64;
        if ry == 0 {
            if rx == 1 {
                x = n - 1 - x;
                y = n - 1 - y;
            }
            std::mem::swap(&mut x, &mut y);
        }
        s /= 2;
    }
    d
}

/// Where a point falls in a triangulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// Strictly inside a face.
    Face(FaceId),
    /// On the edge of this half-edge (the half-edge's face holds the point).
    Edge(HalfEdgeId),
    /// On an existing vertex.
    Vertex(VertexId),
    /// Outside the mesh (across this boundary half-edge's twin).
    Outside(HalfEdgeId),
}

impl TriMesh<DVec2> {
    /// Flips every interior, unconstrained edge that fails the exact in-circle test until none
    /// does (Lawson). Terminates on any valid planar triangulation; returns the flip count.
    /// A zero in-circle (cocircular) counts as legal.
    pub fn make_delaunay(&mut self) -> usize {
        // The edges that fail the test are found first, in parallel (on a mesh that is almost
        // Delaunay, the test of every edge is most of the work); the flips then start from them
        // alone: an edge that passes changes only when a flip next to it pushes it.
        use rayon::prelude::*;
        let edges: Vec<HalfEdgeId> = self.edge_ids().collect();
        let stack: Vec<HalfEdgeId> = edges
            .par_iter()
            .with_min_len(4096)
            .filter(|&&h| {
                self.interior_quad(h).is_some_and(|plan| {
                    let (pa, pb, pc, pd) = (self.pos(plan.a), self.pos(plan.b), self.pos(plan.c), self.pos(plan.d));
                    incircle(pa, pb, pc, pd) == Sign::Positive
                })
            })
            .copied()
            .collect();
        self.legalize(stack)
    }

    /// Lawson flips starting from the given edges (exact in-circle; terminates on any valid
    /// planar triangulation, so no cap).
    pub(crate) fn legalize(&mut self, stack: Vec<HalfEdgeId>) -> usize {
        self.legalize_with(stack, usize::MAX, |a, b, c, d| incircle(a, b, c, d) == Sign::Positive)
    }

    /// Lawson flips (exact in-circle) from the star of `v` ([`TriMesh::star_edges`]): what a
    /// split, a collapse or a move at `v` needs to restore the Delaunay property around it.
    /// Returns the flip count.
    pub fn legalize_star(&mut self, v: VertexId) -> usize {
        let stack = self.star_edges(&[v]);
        self.legalize(stack)
    }

    /// [`TriMesh::legalize_star`] by a caller's test (see [`TriMesh::legalize_with`]).
    pub fn legalize_star_with(
        &mut self,
        v: VertexId,
        cap: usize,
        illegal: impl Fn(DVec2, DVec2, DVec2, DVec2) -> bool,
    ) -> usize {
        let stack = self.star_edges(&[v]);
        self.legalize_with(stack, cap, illegal)
    }

    /// Lawson flips by a caller's in-circle test (`illegal(a, b, c, d)`: the edge a-b with
    /// opposite vertices c (left of a->b) and d should flip), e.g. the in-circle test of a
    /// metric space (seed section 3.5). Such a test need not define a global triangulation, so
    /// the flips stop after `cap`; returns the flip count.
    pub fn legalize_with(
        &mut self,
        mut stack: Vec<HalfEdgeId>,
        cap: usize,
        illegal: impl Fn(DVec2, DVec2, DVec2, DVec2) -> bool,
    ) -> usize {
        let mut flips = 0;
        while let Some(h) = stack.pop() {
            if flips >= cap {
                break;
            }
            if !self.contains_half_edge(h) {
                continue;
            }
            let Some(plan) = self.interior_quad(h) else {
                continue;
            };
            let (pa, pb, pc, pd) = (self.pos(plan.a), self.pos(plan.b), self.pos(plan.c), self.pos(plan.d));
            if !illegal(pa, pb, pc, pd) {
                continue;
            }
            if self.quad_flippable(&plan, pa, pb, pc, pd) {
                self.apply_flip(plan);
                flips += 1;
                stack.push(plan.h_ca);
                stack.push(plan.t_ad);
                stack.push(plan.t_db);
                stack.push(plan.h_bc);
            }
        }
        flips
    }

    /// What [`TriMesh::check_flip`] decides for an interior quad of equal labels, given its
    /// four positions: no repeated vertex and both new triangles strictly positive (the new
    /// edge cannot exist yet in a planar triangulation, see `NEEDS_DUPLICATE_EDGE_CHECK`).
    #[inline]
    fn quad_flippable(&self, plan: &FlipPlan, pa: DVec2, pb: DVec2, pc: DVec2, pd: DVec2) -> bool {
        plan.c != plan.d && orient2d(pc, pa, pd) == Sign::Positive && orient2d(pd, pb, pc) == Sign::Positive
    }

    /// Locates `p` by a visibility walk from face `start` (exact orientations; the edge to test
    /// first rotates so that the walk cannot cycle).
    pub fn locate(&self, p: DVec2, start: FaceId) -> Location {
        let mut f = start;
        let mut rot = 0usize;
        let mut steps = 0usize;
        'walk: loop {
            steps += 1;
            // The three half-edges and corner positions of f, each record read once; the
            // destination of hs[k] is the origin of hs[k + 1].
            let h0 = self.faces[f].half_edge;
            let e0 = self.half_edges[h0];
            let e1 = self.half_edges[e0.next];
            let e2 = self.half_edges[e1.next];
            let hs = [h0, e0.next, e1.next];
            let es = [e0, e1, e2];
            let ps = [self.pos(e0.origin), self.pos(e1.origin), self.pos(e2.origin)];
            rot = rot.wrapping_mul(1103515245).wrapping_add(12345);
            let r = (rot >> 16) % 3;
            let mut on_edge = None;
            for k in 0..3 {
                let i = (k + r) % 3;
                let j = if i == 2 { 0 } else { i + 1 };
                match orient2d(ps[i], ps[j], p) {
                    Sign::Negative => match self.half_edges[es[i].twin].face {
                        Some(g) => {
                            f = g;
                            if steps > 4 * self.num_faces() + 16 {
                                break 'walk;
                            }
                            continue 'walk;
                        }
                        None => return Location::Outside(hs[i]),
                    },
                    Sign::Zero => on_edge = Some(i),
                    Sign::Positive => {}
                }
            }
            if let Some(i) = on_edge {
                let j = if i == 2 { 0 } else { i + 1 };
                if p == ps[i] {
                    return Location::Vertex(es[i].origin);
                }
                if p == ps[j] {
                    return Location::Vertex(es[j].origin);
                }
                // On two edges at once means on their shared vertex, handled above.
                return Location::Edge(hs[i]);
            }
            return Location::Face(f);
        }
        // The walk is bounded; falling out means a broken mesh. Scan as a last resort.
        for g in self.face_ids() {
            let [a, b, c] = self.face_points(g);
            if orient2d(a, b, p) != Sign::Negative
                && orient2d(b, c, p) != Sign::Negative
                && orient2d(c, a, p) != Sign::Negative
            {
                return Location::Face(g);
            }
        }
        Location::Outside(self.faces[start].half_edge)
    }

    /// Inserts `p` into a Delaunay triangulation and restores the Delaunay property by flips.
    /// Returns the vertex (an existing one if `p` coincides with it) and a face next to it, or
    /// `None` when `p` lies outside the mesh.
    pub fn insert_delaunay(&mut self, p: DVec2, hint: FaceId) -> Option<(VertexId, FaceId)> {
        self.insert_delaunay_with(p, hint, &mut Vec::new())
    }

    /// [`TriMesh::insert_delaunay`] with a caller-owned flip stack, reused across insertions.
    fn insert_delaunay_with(
        &mut self,
        p: DVec2,
        hint: FaceId,
        stack: &mut Vec<HalfEdgeId>,
    ) -> Option<(VertexId, FaceId)> {
        stack.clear();
        let v = match self.locate(p, hint) {
            Location::Vertex(v) => return Some((v, self.face_of_vertex(v))),
            Location::Outside(_) => return None,
            Location::Face(f) => {
                // The walk found p strictly inside f: the insertion check can only refuse a
                // point that is not finite.
                if !p.is_finite() {
                    return None;
                }
                let (v, [hab, hbc, hca]) = self.insert_in_face_raw(InsertPlan { f, p });
                // The link edges in the order of the ring walk from v's out (v->a, v->c, v->b).
                stack.extend_from_slice(&[hab, hca, hbc]);
                v
            }
            Location::Edge(h) => {
                let v = self.split_edge(h, p).ok()?;
                // Legalize the edges opposite the new vertex.
                for x in self.outgoing(v) {
                    if self.face_of(x).is_some() {
                        stack.push(self.next(x));
                    }
                }
                v
            }
        };
        self.legalize_around(v, stack);
        Some((v, self.face_of_vertex(v)))
    }

    /// Lawson flips of the link edges of a freshly inserted vertex: each flip makes two new link
    /// edges (Guibas-Stolfi insertion).
    pub(crate) fn legalize_around(&mut self, v: VertexId, stack: &mut Vec<HalfEdgeId>) {
        let pv = self.pos(v);
        while let Some(h) = stack.pop() {
            // Boundary and constrained edges stay.
            let Some(plan) = self.interior_quad(h) else {
                continue;
            };
            let a = self.pos(plan.a);
            let b = self.pos(plan.b);
            let d = self.pos(plan.d);
            if incircle(a, b, pv, d) != Sign::Positive {
                continue;
            }
            let c = if plan.c == v { pv } else { self.pos(plan.c) };
            if self.quad_flippable(&plan, a, b, c, d) {
                self.apply_flip(plan);
                // h now runs d -> v; the new link edges are a -> d in face (d, v, a) and d -> b
                // in face (v, d, b).
                stack.push(plan.t_db);
                stack.push(plan.t_ad);
            }
        }
    }

    /// A face incident to `v` (vertices always have one).
    pub fn face_of_vertex(&self, v: VertexId) -> FaceId {
        let out = self.vertex(v).out;
        match self.face_of(out) {
            Some(f) => f,
            None => self.face_of(self.twin(out)).expect("an edge has a face on one side"),
        }
    }

    /// The Delaunay triangulation of `points` by incremental insertion from one enclosing
    /// triangle, Hilbert-ordered. Returns the mesh (its boundary is the convex hull) and the
    /// vertex of each input point (duplicates share one). Needs three non-collinear points.
    pub fn delaunay(points: &[DVec2]) -> Result<(TriMesh<DVec2>, Vec<VertexId>), crate::Error> {
        for p in points {
            if !p.is_finite() {
                return Err(crate::Error::BadCoordinate {
                    what: "delaunay input",
                    value: if p.x.is_finite() { p.y } else { p.x },
                });
            }
        }
        if points.len() < 3 {
            return Err(crate::Error::InvalidMesh("a triangulation needs at least three points".into()));
        }
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for p in points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let c = (lo + hi) * 0.5;
        let r = (hi - lo).max_element().max(1e-300);
        // A far enclosing triangle: hull edges are recovered exactly afterwards by ear filling
        // and flips, so its size only affects how many repairs that takes.
        let big = 1e4 * r;
        let s = [c + DVec2::new(-big, -big), c + DVec2::new(big, -big), c + DVec2::new(0.0, big)];
        let (mut m, sid) = TriMesh::from_arrays(&s, &[[0, 1, 2]]).map_err(|e| crate::Error::internal(e.to_string()))?;
        m.vertices.reserve(points.len());
        m.half_edges.reserve(6 * points.len());
        m.faces.reserve(2 * points.len());
        let order = hilbert_order(points);
        // Gather the points in insertion order up front and scatter the vertex keys back at the
        // end: in tight loops the cache misses of both overlap, in the insertion loop they stall.
        let sorted: Vec<DVec2> = order.iter().map(|&i| points[i]).collect();
        let mut inserted = Vec::with_capacity(points.len());
        let mut hint = m.face_ids().next().expect("one face");
        let mut stack = Vec::new();
        for &p in &sorted {
            let (v, f) = m
                .insert_delaunay_with(p, hint, &mut stack)
                .ok_or_else(|| crate::Error::internal("point outside the enclosing triangle"))?;
            inserted.push(v);
            hint = f;
        }
        let mut ids = vec![VertexId::default(); points.len()];
        for (&i, &v) in order.iter().zip(&inserted) {
            ids[i] = v;
        }
        m.remove_enclosing(&sid)?;
        Ok((m, ids))
    }

    /// Removes the enclosing triangle's vertices and every face touching them, then restores the
    /// convex hull by filling boundary ears that turn left, and the Delaunay property by flips.
    ///
    /// Only the faces around the three enclosing vertices are visited; every list is sorted by
    /// key, so removals and insertions happen in arena order, as a full scan would do them.
    fn remove_enclosing(&mut self, sid: &[VertexId]) -> Result<(), crate::Error> {
        let mut doomed: Vec<FaceId> = Vec::new();
        for &s in sid {
            for x in self.outgoing(s) {
                if let Some(f) = self.face_of(x) {
                    doomed.push(f);
                }
            }
        }
        doomed.sort_unstable();
        doomed.dedup();
        // Half-edges that may lose both faces: those of doomed faces and their twins.
        let mut touched: Vec<HalfEdgeId> = Vec::with_capacity(6 * doomed.len());
        for f in &doomed {
            for h in self.face_half_edges(*f) {
                touched.push(h);
                touched.push(self.twin(h));
            }
        }
        touched.sort_unstable();
        touched.dedup();
        for f in &doomed {
            for h in self.face_half_edges(*f) {
                self.half_edges[h].face = None;
            }
            self.faces.remove(*f);
        }
        // Drop edges with no face on either side.
        let dead: Vec<HalfEdgeId> = touched
            .iter()
            .copied()
            .filter(|&h| {
                let e = &self.half_edges[h];
                e.face.is_none() && self.half_edges[e.twin].face.is_none()
            })
            .collect();
        let dead_origins: Vec<VertexId> = dead.iter().map(|&h| self.origin(h)).collect();
        for &h in &dead {
            self.half_edges.remove(h);
        }
        for &v in sid {
            self.vertices.remove(v);
        }
        // Boundary half-edges: each surviving vertex on the boundary gets exactly one.
        let boundary: Vec<HalfEdgeId> =
            touched.iter().copied().filter(|&h| self.half_edges.get(h).is_some_and(|e| e.face.is_none())).collect();
        let mut seen = slotmap::SecondaryMap::new();
        for &h in &boundary {
            let v = self.origin(h);
            if seen.insert(v, ()).is_some() {
                return Err(crate::Error::internal("non-manifold hull after removing the enclosing triangle"));
            }
            self.vertices[v].out = h;
        }
        for &h in &boundary {
            let d = self.dest(h);
            self.half_edges[h].next = self.vertices[d].out;
        }
        // Vertices whose out half-edge was removed take any surviving outgoing one. Only the
        // origins of removed half-edges can need it; if one does, scan as before.
        let stale_out =
            dead_origins.iter().any(|&v| self.vertices.get(v).is_some_and(|vx| !self.half_edges.contains_key(vx.out)));
        if stale_out {
            let repoint: Vec<(VertexId, HalfEdgeId)> = self
                .half_edges
                .iter()
                .filter(|(_, e)| {
                    let out = self.vertices[e.origin].out;
                    !self.half_edges.contains_key(out) || self.half_edges[out].origin != e.origin
                })
                .map(|(h, e)| (e.origin, h))
                .collect();
            for (v, h) in repoint {
                self.vertices[v].out = h;
            }
        }
        // Convexify: fill every left turn of the boundary.
        let mut ears: Vec<FaceId> = Vec::new();
        let mut work: Vec<HalfEdgeId> = boundary.into_iter().filter(|h| self.half_edges.contains_key(*h)).collect();
        while let Some(h) = work.pop() {
            if !self.contains_half_edge(h) || self.face_of(h).is_some() {
                continue;
            }
            let g = self.next(h);
            let (a, b, c) = (self.pos(self.origin(h)), self.pos(self.origin(g)), self.pos(self.dest(g)));
            if orient2d(a, b, c) == Sign::Positive {
                if let Ok(f) = self.fill_boundary_ear(h, 0) {
                    ears.push(f);
                    let e = self.prev(h); // the new edge c -> a inside the new face
                    let et = self.twin(e); // a -> c, boundary
                    work.push(et);
                    work.push(self.prev(et));
                }
            }
        }
        for vx in self.vertices.values_mut() {
            vx.tag = VertexTag::Interior;
        }
        // Lawson flips. Every other edge lies between two faces of the Delaunay triangulation
        // with the enclosing vertices, so it is locally Delaunay, and a full pass would pop it
        // without flipping: starting from the edges of the ears that fail the in-circle test,
        // in edge (key) order, performs exactly the flips of the full pass, in the same order.
        let mut stack: Vec<HalfEdgeId> = Vec::with_capacity(3 * ears.len());
        for f in ears {
            for h in self.face_half_edges(f) {
                stack.push(h.min(self.twin(h)));
            }
        }
        stack.sort_unstable();
        stack.dedup();
        stack.retain(|&h| !self.is_boundary_edge(h) && !self.is_constrained_edge(h) && !self.is_locally_delaunay(h));
        self.legalize(stack);
        Ok(())
    }
}
