//! Internal boundaries (seed section 3.4): curves d_I = 0 inside the domain that no triangle
//! may cross. The initial mesh is aligned with them (crossing edges snapped or split), faces
//! are labelled by the side of d_I they lie on, and the vertices on edges between labels are
//! tagged `InternalBoundary`; the engine never flips such edges, and the mesher keeps those
//! vertices on d_I = 0.

use crate::geometry::project::{project2, Projection};
use crate::geometry::Implicit2;
use crate::mesher::truss::domain::{projection_non_finite, Function};
use crate::topology::{FaceId, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec2;
use slotmap::SecondaryMap;

/// Labels during a run: the side of d_I (0 where d_I < 0, 1 where d_I > 0). The finished
/// mesh is relabelled by connected subdomains ([`label_subdomains`]).
const SIDE_NEG: u32 = 0;
const SIDE_POS: u32 = 1;

/// The internal-boundary function with its projection settings.
pub(crate) struct Internal<'a> {
    pub d: &'a dyn Implicit2,
    pub projection: Projection,
    /// Projection tolerance (absolute).
    pub tol: f64,
}

impl Internal<'_> {
    pub fn new(d: &dyn Implicit2, h0: f64) -> Internal<'_> {
        // First-order steps (seed eq. 3.9) whatever the function claims: for a true distance
        // they are the exact step, and a level set handed over as a distance (a closure, or an
        // expression without --implicit) would make the exact step overshoot by |grad d|
        // and leave curve nodes off the curve (0.028 for an ellipse with |grad| up to 7).
        let projection = Projection::FirstOrder;
        Internal { d, projection, tol: 1e-9 * h0 }
    }

    /// d_I, failing on a non-finite value.
    pub fn value(&self, p: DVec2) -> Result<f64, Error> {
        let v = self.d.value(p);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(Error::NonFinite { what: "the internal-boundary function", value: v, at: [p.x, p.y, 0.0] })
        }
    }

    /// Approximate distance to d_I = 0: the value over the gradient's length.
    pub fn approx_dist(&self, p: DVec2) -> Result<f64, Error> {
        let v = self.value(p)?;
        if self.d.is_distance() {
            return Ok(v);
        }
        let g = self.d.gradient(p).length();
        Ok(if g > 0.0 && g.is_finite() { v / g } else { v })
    }

    /// Projects onto d_I = 0; `Ok(None)` when the projection does not converge.
    pub fn project(&self, p: DVec2) -> Result<Option<DVec2>, Error> {
        match project2(self.d, p, self.projection, self.tol, 30) {
            Ok(q) => Ok(Some(q)),
            Err(e) => match projection_non_finite(&e, Function::Internal) {
                Some(err) => Err(err),
                None => Ok(None),
            },
        }
    }

    /// The point where d_I changes sign on the segment a-b (bisection; d_I(a) d_I(b) < 0).
    fn crossing(&self, a: DVec2, b: DVec2) -> Result<DVec2, Error> {
        let (mut lo, mut hi) = (0.0, 1.0);
        let sa = self.value(a)? < 0.0;
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if (self.value(a.lerp(b, mid))? < 0.0) == sa {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(a.lerp(b, 0.5 * (lo + hi)))
    }
}

/// True when the vertex counts as lying on d_I = 0 during alignment.
fn on_curve(m: &TriMesh<DVec2>, v: VertexId, di: &Internal, tol: f64) -> Result<bool, Error> {
    Ok(match m.tag(v) {
        VertexTag::InternalBoundary { .. } => true,
        VertexTag::Fixed => di.approx_dist(m.pos(v))?.abs() <= tol,
        _ => false,
    })
}

/// Aligns a triangulation with d_I = 0 (seed 3.4: "start with an initial mesh that aligns
/// with the boundaries"): the endpoint of each crossing edge nearer the curve is moved onto
/// it, or, where that would invert a triangle, the edge is split at the crossing; then every
/// face is labelled by its side and the vertices between labels are tagged.
/// `tol` is the distance within which a fixed point counts as on the curve.
pub(crate) fn align(m: &mut TriMesh<DVec2>, di: &Internal, tol: f64) -> Result<(), Error> {
    for _round in 0..8 {
        let mut crossing = Vec::new();
        let mut hidden = Vec::new();
        for h in m.edge_ids() {
            let (a, b) = (m.origin(h), m.dest(h));
            let (ca, cb) = (on_curve(m, a, di, tol)?, on_curve(m, b, di, tol)?);
            if !ca && !cb && (di.value(m.pos(a))? < 0.0) != (di.value(m.pos(b))? < 0.0) {
                crossing.push((a, b));
            } else if let Some(x) = hidden_crossing(di, m.pos(a), m.pos(b), ca, cb)? {
                // The curve enters and leaves the edge between its ends (a corner of the
                // curve next to the edge, or a thin feature): split there.
                hidden.push((a, b, x));
            }
        }
        if crossing.is_empty() && hidden.is_empty() {
            break;
        }
        for (a, b, x) in hidden {
            let Some(h) = m.find_half_edge(a, b) else { continue };
            if let Ok(v) = m.split_edge(h, x) {
                m.set_tag(v, VertexTag::InternalBoundary { curve: 0 });
                if let Some(q) = di.project(x)? {
                    let _ = m.relocate(v, q);
                }
            }
        }
        for (a, b) in crossing {
            let Some(h) = m.find_half_edge(a, b) else { continue };
            if on_curve(m, a, di, tol)? || on_curve(m, b, di, tol)? {
                continue;
            }
            let (pa, pb) = (m.pos(a), m.pos(b));
            if (di.value(pa)? < 0.0) == (di.value(pb)? < 0.0) {
                continue;
            }
            let len = pa.distance(pb);
            let (da, db) = (di.approx_dist(pa)?.abs(), di.approx_dist(pb)?.abs());
            let order = if da <= db { [(a, pa), (b, pb)] } else { [(b, pb), (a, pa)] };
            let mut done = false;
            // Snap an endpoint that lies within a third of the edge from the curve.
            for (v, pv) in order {
                if m.tag(v) == VertexTag::Fixed {
                    continue;
                }
                if let Some(q) = di.project(pv)? {
                    if q.distance(pv) < len / 3.0 && m.relocate(v, q).is_ok() {
                        m.set_tag(v, VertexTag::InternalBoundary { curve: 0 });
                        done = true;
                        break;
                    }
                }
            }
            if !done {
                let x = di.crossing(pa, pb)?;
                if let Ok(v) = m.split_edge(h, x) {
                    m.set_tag(v, VertexTag::InternalBoundary { curve: 0 });
                    if let Some(q) = di.project(x)? {
                        let _ = m.relocate(v, q);
                    }
                }
            }
        }
    }
    label_sides(m, di, tol)?;
    tag_interface(m);
    Ok(())
}

/// A point where d_I changes sign strictly inside the segment a-b although its ends do not
/// show it (ends on the curve, or of the same sign; the caller handles ends of opposite
/// signs): samples at quarters, then bisection.
fn hidden_crossing(di: &Internal, a: DVec2, b: DVec2, a_on: bool, b_on: bool) -> Result<Option<DVec2>, Error> {
    let mut prev: Option<(DVec2, bool)> = if a_on { None } else { Some((a, di.value(a)? < 0.0)) };
    for k in 1..=4 {
        let t = k as f64 / 4.0;
        let (x, on) = if k == 4 { (b, b_on) } else { (a.lerp(b, t), false) };
        if on {
            break;
        }
        let v = di.value(x)?;
        if v == 0.0 {
            prev = None;
            continue;
        }
        let side = v < 0.0;
        if let Some((px, ps)) = prev {
            if ps != side {
                return Ok(Some(di.crossing(px, x)?));
            }
        }
        prev = Some((x, side));
    }
    Ok(None)
}

/// Labels each face by the side of d_I its off-curve vertices lie on (the centroid decides
/// when all three are on the curve or, after a failed alignment, they disagree).
fn label_sides(m: &mut TriMesh<DVec2>, di: &Internal, tol: f64) -> Result<(), Error> {
    let faces: Vec<FaceId> = m.face_ids().collect();
    for f in faces {
        let vs = m.face_vertices(f);
        let mut neg = 0;
        let mut pos = 0;
        for v in vs {
            if !on_curve(m, v, di, tol)? {
                if di.value(m.pos(v))? < 0.0 {
                    neg += 1;
                } else {
                    pos += 1;
                }
            }
        }
        let label = if neg > 0 && pos == 0 {
            SIDE_NEG
        } else if pos > 0 && neg == 0 {
            SIDE_POS
        } else {
            let [a, b, c] = m.face_points(f);
            if di.value((a + b + c) / 3.0)? < 0.0 {
                SIDE_NEG
            } else {
                SIDE_POS
            }
        };
        m.set_label(f, label);
    }
    Ok(())
}

/// Tags `InternalBoundary` exactly the non-fixed vertices on an edge between two labels that
/// are not on the outer boundary; other `InternalBoundary` tags become `Interior`.
pub(crate) fn tag_interface(m: &mut TriMesh<DVec2>) {
    let mut on: SecondaryMap<VertexId, ()> = SecondaryMap::new();
    for h in m.edge_ids() {
        if m.is_constrained_edge(h) {
            on.insert(m.origin(h), ());
            on.insert(m.dest(h), ());
        }
    }
    let vs: Vec<VertexId> = m.vertex_ids().collect();
    for v in vs {
        let tag = m.tag(v);
        if tag == VertexTag::Fixed || m.is_boundary_vertex(v) {
            continue;
        }
        if on.contains_key(v) {
            m.set_tag(v, VertexTag::InternalBoundary { curve: 0 });
        } else if matches!(tag, VertexTag::InternalBoundary { .. }) {
            m.set_tag(v, VertexTag::Interior);
        }
    }
}

/// Relabels faces by connected subdomain (faces joined across edges of equal label), numbered
/// 0, 1, ... in face order, so that each region between internal boundaries has its own label.
pub(crate) fn label_subdomains(m: &mut TriMesh<DVec2>) {
    let mut comp: SecondaryMap<FaceId, u32> = SecondaryMap::new();
    let faces: Vec<FaceId> = m.face_ids().collect();
    let mut next = 0u32;
    let mut stack = Vec::new();
    for &f0 in &faces {
        if comp.contains_key(f0) {
            continue;
        }
        comp.insert(f0, next);
        stack.push(f0);
        while let Some(f) = stack.pop() {
            for h in m.face_half_edges(f) {
                if let Some(g) = m.face_of(m.twin(h)) {
                    if !comp.contains_key(g) && m.face(g).label == m.face(f).label {
                        comp.insert(g, next);
                        stack.push(g);
                    }
                }
            }
        }
        next += 1;
    }
    for f in faces {
        m.set_label(f, comp[f]);
    }
}

/// Internal-boundary nodes farther than `tol` from d_I = 0.
pub(crate) fn nodes_off(m: &TriMesh<DVec2>, di: &Internal, tol: f64) -> Result<usize, Error> {
    let mut n = 0;
    for v in m.vertex_ids() {
        if matches!(m.tag(v), VertexTag::InternalBoundary { .. }) && di.approx_dist(m.pos(v))?.abs() > tol {
            n += 1;
        }
    }
    Ok(n)
}

/// The side of d_I at p: -1 or 1, or 0 within `tol` (absolute distance) of the curve.
fn side(di: &Internal, p: DVec2, tol: f64) -> Result<i8, Error> {
    let d = di.approx_dist(p)?;
    Ok(if d.abs() <= tol {
        0
    } else if d < 0.0 {
        -1
    } else {
        1
    })
}

/// Triangles with vertices strictly on both sides of d_I (beyond `tol`, by the sign of d_I at
/// the vertices, whatever their tags say).
pub(crate) fn crossings(m: &TriMesh<DVec2>, di: &Internal, tol: f64) -> Result<usize, Error> {
    let mut n = 0;
    for f in m.face_ids() {
        let [a, b, c] = m.face_points(f);
        let s = [side(di, a, tol)?, side(di, b, tol)?, side(di, c, tol)?];
        if s.contains(&-1) && s.contains(&1) {
            n += 1;
        }
    }
    Ok(n)
}

/// The guarantee that no triangle crosses d_I, enforced on the finished mesh: every edge whose
/// ends lie strictly on both sides (by the sign of d_I at them) gets a vertex on the curve,
/// either its end nearer the curve moved there (when that keeps every triangle positive and
/// the end is free to move) or a new one where d_I changes sign along it (bisection). Then
/// faces are labelled by the sides of their vertices (the centroid's when all three are on the
/// curve) and, where a label changed, the interface retagged. Returns the number of edges repaired; the caller checks that none is left.
pub(crate) fn seal(m: &mut TriMesh<DVec2>, di: &Internal, tol: f64) -> Result<usize, Error> {
    let mut repaired = 0;
    for _round in 0..8 {
        let mut bad = Vec::new();
        for h in m.edge_ids() {
            let (a, b) = (m.origin(h), m.dest(h));
            if side(di, m.pos(a), tol)? * side(di, m.pos(b), tol)? < 0 {
                bad.push((a, b));
            }
        }
        if bad.is_empty() {
            break;
        }
        for (a, b) in bad {
            let Some(h) = m.find_half_edge(a, b) else { continue };
            let (pa, pb) = (m.pos(a), m.pos(b));
            if side(di, pa, tol)? * side(di, pb, tol)? >= 0 {
                continue;
            }
            let len = pa.distance(pb);
            let (da, db) = (di.approx_dist(pa)?.abs(), di.approx_dist(pb)?.abs());
            let order = if da <= db { [(a, pa), (b, pb)] } else { [(b, pb), (a, pa)] };
            let mut done = false;
            for (v, pv) in order {
                if !matches!(m.tag(v), VertexTag::Interior | VertexTag::InternalBoundary { .. }) {
                    continue;
                }
                if let Some(q) = di.project(pv)? {
                    if q.distance(pv) < len / 3.0 && side(di, q, tol)? == 0 && m.relocate(v, q).is_ok() {
                        done = true;
                        break;
                    }
                }
            }
            if !done {
                let x = di.crossing(pa, pb)?;
                if m.split_edge(h, x).is_err() {
                    continue;
                }
            }
            repaired += 1;
        }
    }
    // Labels follow the sides of the vertices (a label carried through the run can disagree
    // with them); a mesh whose labels already agree is left as it is.
    {
        let faces: Vec<FaceId> = m.face_ids().collect();
        let mut changed = false;
        for f in faces {
            let [a, b, c] = m.face_points(f);
            let s = [side(di, a, tol)?, side(di, b, tol)?, side(di, c, tol)?];
            let label = if s.contains(&-1) {
                SIDE_NEG
            } else if s.contains(&1) {
                SIDE_POS
            } else if di.value((a + b + c) / 3.0)? < 0.0 {
                SIDE_NEG
            } else {
                SIDE_POS
            };
            if m.face(f).label != label {
                m.set_label(f, label);
                changed = true;
            }
        }
        if changed || repaired > 0 {
            tag_interface(m);
        }
    }
    Ok(repaired)
}
