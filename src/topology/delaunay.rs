//! Delaunay by local flipping: the Lawson flip loop with exact in-circle, and incremental
//! insertion from one enclosing triangle (walk to locate, split, flip).

use super::trimesh::{FaceId, HalfEdgeId, TriMesh, VertexId, VertexTag};
use crate::predicates::{incircle, orient2d, Sign};
use glam::DVec2;

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
    let mut keyed: Vec<(u64, usize)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let q = (*p - lo) * scale;
            (hilbert_index(q.x as u32, q.y as u32, ORDER), i)
        })
        .collect();
    keyed.sort_unstable();
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
        let stack: Vec<HalfEdgeId> = self.edge_ids().collect();
        self.legalize(stack)
    }

    /// Lawson flips starting from the given edges.
    pub(crate) fn legalize(&mut self, mut stack: Vec<HalfEdgeId>) -> usize {
        let mut flips = 0;
        while let Some(h) = stack.pop() {
            if !self.contains_half_edge(h) || self.is_boundary_edge(h) || self.is_constrained_edge(h) {
                continue;
            }
            if self.is_locally_delaunay(h) {
                continue;
            }
            // A strictly non-Delaunay edge has a strictly convex quad, but check anyway: an
            // edge whose flip is refused (e.g. an existing c-d edge) is left alone.
            if self.flip(h).is_ok() {
                flips += 1;
                // h now runs d -> c; push the four outer edges of the quad.
                let t = self.twin(h);
                stack.push(self.next(h));
                stack.push(self.next(self.next(h)));
                stack.push(self.next(t));
                stack.push(self.next(self.next(t)));
            }
        }
        flips
    }

    /// Locates `p` by a visibility walk from face `start` (exact orientations; the edge to test
    /// first rotates so that the walk cannot cycle).
    pub fn locate(&self, p: DVec2, start: FaceId) -> Location {
        let mut f = start;
        let mut rot = 0usize;
        let mut steps = 0usize;
        'walk: loop {
            steps += 1;
            let hs = self.face_half_edges(f);
            rot = rot.wrapping_mul(1103515245).wrapping_add(12345);
            let r = (rot >> 16) % 3;
            let mut on_edge = None;
            for k in 0..3 {
                let h = hs[(k + r) % 3];
                let a = self.pos(self.origin(h));
                let b = self.pos(self.dest(h));
                match orient2d(a, b, p) {
                    Sign::Negative => {
                        let t = self.twin(h);
                        match self.face_of(t) {
                            Some(g) => {
                                f = g;
                                if steps > 4 * self.num_faces() + 16 {
                                    break 'walk;
                                }
                                continue 'walk;
                            }
                            None => return Location::Outside(h),
                        }
                    }
                    Sign::Zero => on_edge = Some(h),
                    Sign::Positive => {}
                }
            }
            if let Some(h) = on_edge {
                let a = self.pos(self.origin(h));
                let b = self.pos(self.dest(h));
                if p == a {
                    return Location::Vertex(self.origin(h));
                }
                if p == b {
                    return Location::Vertex(self.dest(h));
                }
                // On two edges at once means on their shared vertex, handled above.
                return Location::Edge(h);
            }
            return Location::Face(f);
        }
        // The walk is bounded; falling out means a broken mesh. Scan as a last resort.
        for g in self.face_ids() {
            let [a, b, c] = self.face_points(g);
            if orient2d(a, b, p) != Sign::Negative && orient2d(b, c, p) != Sign::Negative && orient2d(c, a, p) != Sign::Negative {
                return Location::Face(g);
            }
        }
        Location::Outside(self.faces[start].half_edge)
    }

    /// Inserts `p` into a Delaunay triangulation and restores the Delaunay property by flips.
    /// Returns the vertex (an existing one if `p` coincides with it) and a face next to it, or
    /// `None` when `p` lies outside the mesh.
    pub fn insert_delaunay(&mut self, p: DVec2, hint: FaceId) -> Option<(VertexId, FaceId)> {
        let v = match self.locate(p, hint) {
            Location::Vertex(v) => return Some((v, self.face_of_vertex(v))),
            Location::Outside(_) => return None,
            Location::Face(f) => self.insert_in_face(f, p).ok()?,
            Location::Edge(h) => self.split_edge(h, p).ok()?,
        };
        // Legalize the edges opposite the new vertex.
        let stack: Vec<HalfEdgeId> = self
            .outgoing(v)
            .into_iter()
            .filter(|&x| self.face_of(x).is_some())
            .map(|x| self.next(x))
            .collect();
        self.legalize_around(v, stack);
        Some((v, self.face_of_vertex(v)))
    }

    /// Lawson flips of the link edges of a freshly inserted vertex: each flip makes two new link
    /// edges (Guibas-Stolfi insertion).
    pub(crate) fn legalize_around(&mut self, v: VertexId, mut stack: Vec<HalfEdgeId>) {
        while let Some(h) = stack.pop() {
            let t = self.twin(h);
            if self.face_of(t).is_none() || self.is_constrained_edge(h) {
                continue;
            }
            let a = self.pos(self.origin(h));
            let b = self.pos(self.origin(t));
            let c = self.pos(v);
            let d = self.pos(self.origin(self.prev(t)));
            if incircle(a, b, c, d) == Sign::Positive && self.check_flip(h).is_ok() {
                self.flip_unchecked(h);
                // h now runs d -> v; the new link edges are next(twin(h)) and prev... in faces
                // (v, a, d) and (d, b, v): the edges a->d and d->b.
                let t = self.twin(h); // v -> d
                let e1 = self.next(t); // d -> b
                let e2 = self.next(self.next(h)); // a -> d
                stack.push(e1);
                stack.push(e2);
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
                return Err(crate::Error::BadCoordinate { what: "delaunay input", value: if p.x.is_finite() { p.y } else { p.x } });
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
        let s = [
            c + DVec2::new(-big, -big),
            c + DVec2::new(big, -big),
            c + DVec2::new(0.0, big),
        ];
        let (mut m, sid) = TriMesh::from_arrays(&s, &[[0, 1, 2]]).map_err(|e| crate::Error::Internal(e.to_string()))?;
        m.vertices.reserve(points.len());
        m.half_edges.reserve(6 * points.len());
        m.faces.reserve(2 * points.len());
        let order = hilbert_order(points);
        let mut ids = vec![VertexId::default(); points.len()];
        let mut hint = m.face_ids().next().expect("one face");
        for &i in &order {
            let (v, f) = m
                .insert_delaunay(points[i], hint)
                .ok_or_else(|| crate::Error::Internal("point outside the enclosing triangle".into()))?;
            ids[i] = v;
            hint = f;
        }
        m.remove_enclosing(&sid)?;
        Ok((m, ids))
    }

    /// Removes the enclosing triangle's vertices and every face touching them, then restores the
    /// convex hull by filling boundary ears that turn left, and the Delaunay property by flips.
    fn remove_enclosing(&mut self, sid: &[VertexId]) -> Result<(), crate::Error> {
        let is_super = |v: VertexId| sid.contains(&v);
        let doomed: Vec<FaceId> = self
            .faces
            .iter()
            .filter(|(f, _)| self.face_vertices(*f).iter().any(|&v| is_super(v)))
            .map(|(f, _)| f)
            .collect();
        for f in &doomed {
            for h in self.face_half_edges(*f) {
                self.half_edges[h].face = None;
            }
            self.faces.remove(*f);
        }
        // Drop edges with no face on either side.
        let dead: Vec<HalfEdgeId> = self
            .half_edges
            .iter()
            .filter(|(_, e)| e.face.is_none() && self.half_edges[e.twin].face.is_none())
            .map(|(h, _)| h)
            .collect();
        for h in dead {
            self.half_edges.remove(h);
        }
        for &v in sid {
            self.vertices.remove(v);
        }
        // Boundary half-edges: each surviving vertex on the boundary gets exactly one.
        let boundary: Vec<HalfEdgeId> = self.half_edges.iter().filter(|(_, e)| e.face.is_none()).map(|(h, _)| h).collect();
        let mut seen = slotmap::SecondaryMap::new();
        for &h in &boundary {
            let v = self.origin(h);
            if seen.insert(v, ()).is_some() {
                return Err(crate::Error::Internal("non-manifold hull after removing the enclosing triangle".into()));
            }
            self.vertices[v].out = h;
        }
        for &h in &boundary {
            let d = self.dest(h);
            self.half_edges[h].next = self.vertices[d].out;
        }
        // Vertices whose out half-edge was removed take any surviving outgoing one.
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
        // Convexify: fill every left turn of the boundary.
        let mut work: Vec<HalfEdgeId> = boundary.into_iter().filter(|h| self.half_edges.contains_key(*h)).collect();
        while let Some(h) = work.pop() {
            if !self.contains_half_edge(h) || self.face_of(h).is_some() {
                continue;
            }
            let g = self.next(h);
            let (a, b, c) = (self.pos(self.origin(h)), self.pos(self.origin(g)), self.pos(self.dest(g)));
            if orient2d(a, b, c) == Sign::Positive {
                if self.fill_boundary_ear(h, 0).is_ok() {
                    let e = self.prev(h); // the new edge c -> a inside the new face
                    let et = self.twin(e); // a -> c, boundary
                    work.push(et);
                    work.push(self.prev(et));
                }
            }
        }
        for v in self.vertices.keys().collect::<Vec<_>>() {
            self.vertices[v].tag = VertexTag::Interior;
        }
        self.make_delaunay();
        Ok(())
    }
}
