//! Sharp features of an implicit surface, held by the surface mesher: the start mesh is cut
//! along the edges where two faces of phi = 0 meet, its triangles labelled by the smooth patch
//! they lie on (edges between labels are the feature edges, which the engine never flips), the
//! vertices on them tagged `InternalBoundary` (they slide along their curve and are projected
//! onto it) and the corners where three patches meet `Fixed`.
//!
//! Found from phi as the 3-D mesher finds them (`crate::mesher::sharp`): two points whose normals
//! differ by more than SHARP_DEG straddle an edge, which passes through the point of both
//! tangent planes nearest them; three faces meet at a corner. A geometry that gives its
//! features exactly (`Implicit3::creases`: a triangulated surface's feature edges) has them cut
//! in instead, its patches as the labels, and its own curves to slide along.

use super::geom::{self, project};
use super::improve::move_if_no_fold_g;
use crate::geometry::Implicit3;
use crate::mesher::sharp::{self, Zero};
use crate::topology::{FaceId, HalfEdgeId, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec3;
use slotmap::SecondaryMap;
use smallvec::SmallVec;

mod corners;
mod given;

use corners::{fix_corner, start_curves};
use given::imprint_given;
pub(super) use given::input_start;

/// Passes over the edges cutting the ones that straddle a sharp edge.
const CUT_PASSES: usize = 4;
/// A cut point this close (as a fraction of the edge) to an end moves that end instead.
const CUT_END: f64 = 0.15;
/// A vertex farther than this many local sizes from the given curve of its two labels does not
/// move onto it.
const GIVEN_REACH: f64 = 0.5;
/// An edge between two labels whose midpoint is farther than this many edge lengths from the
/// given curve of the two is not along it (a chord of the curve sags far less).
const GIVEN_SAG: f64 = 0.1;
/// A vertex within this many edge lengths of a given curve is on it.
const ON_CURVE: f64 = 1e-9;
/// Vertices tried, nearest first, for each corner.
const CORNER_TRIES: usize = 12;
/// Faces of another patch beyond which a labelled region is taken to have leaked across a
/// curve (strays near a corner are a few).
const LEAK_FACES: usize = 4;
/// A pin farther than this many edge lengths from the nearest curve edge is not on the cut
/// curve (see `given::hold_pins`).
const PIN_REACH: f64 = 0.5;
/// A triangle of lower quality than this is flat: its normal says nothing of the patch it is on.
const FLAT_Q: f64 = 0.05;
/// Steps of the projection onto a feature curve.
const CURVE_STEPS: usize = 8;

/// phi seen by the shared feature constructions.
pub(super) struct Phi<'a> {
    pub(super) phi: &'a dyn Implicit3,
    pub(super) tol: f64,
}

impl Zero for Phi<'_> {
    fn project(&self, p: DVec3) -> Result<Option<DVec3>, Error> {
        match project(self.phi, p, self.tol) {
            Ok(q) => Ok(Some(q)),
            Err(e @ Error::NonFinite { .. }) => Err(e),
            Err(_) => Ok(None),
        }
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.phi.gradient(p)
    }
}

/// The curve id of the feature edges between patches `a` and `b`.
fn curve_id(a: u32, b: u32) -> u32 {
    a.min(b) * 65_536 + a.max(b)
}

/// The geometric unit normal of a face.
fn face_normal(m: &TriMesh<DVec3>, f: FaceId) -> DVec3 {
    let [a, b, c] = m.face_vertices(f).map(|v| m.pos(v));
    (b - a).cross(c - a).normalize_or_zero()
}

/// The normals of the two patches meeting at the curve vertex `v` (the mean normals of its
/// triangles of either label), or `None` if its triangles do not carry exactly two labels.
pub(super) fn curve_normals(m: &TriMesh<DVec3>, v: VertexId) -> Option<(DVec3, DVec3)> {
    let mut groups: SmallVec<[(u32, DVec3); 3]> = SmallVec::new();
    for h in m.outgoing(v) {
        let Some(f) = m.face_of(h) else { continue };
        let l = m.face(f).label;
        let n = face_normal(m, f);
        match groups.iter_mut().find(|g| g.0 == l) {
            Some(g) => g.1 += n,
            None => groups.push((l, n)),
        }
    }
    match groups.as_slice() {
        [a, b] => Some((a.1.normalize_or_zero(), b.1.normalize_or_zero())),
        _ => None,
    }
}

/// The distinct labels of the triangles at `v`, in the order met.
fn labels_at(m: &TriMesh<DVec3>, v: VertexId) -> SmallVec<[u32; 4]> {
    let mut ls: SmallVec<[u32; 4]> = SmallVec::new();
    for h in m.outgoing(v) {
        if let Some(f) = m.face_of(h) {
            let l = m.face(f).label;
            if !ls.contains(&l) {
                ls.push(l);
            }
        }
    }
    ls
}

/// The two labels of the triangles at the curve vertex `v` (lower first), or `None` if its
/// triangles do not carry exactly two.
fn curve_labels(m: &TriMesh<DVec3>, v: VertexId) -> Option<(u32, u32)> {
    match labels_at(m, v).as_slice() {
        [a, b] => Some(((*a).min(*b), (*a).max(*b))),
        _ => None,
    }
}

/// The neighbours of `v` along feature edges.
pub(super) fn curve_neighbours(m: &TriMesh<DVec3>, v: VertexId) -> SmallVec<[VertexId; 2]> {
    m.outgoing(v).into_iter().filter(|&h| m.is_constrained_edge(h)).map(|h| m.dest(h)).collect()
}

/// The point of the feature curve between the faces of normals `n1` and `n2` nearest `x`,
/// by [`sharp::crease_step`] with the faces sampled ever closer (from a tenth of `s`), and the
/// direction the fold test of a move there uses (between the faces' normals).
pub(super) fn onto_crease(
    phi: &dyn Implicit3,
    x: DVec3,
    n1: DVec3,
    n2: DVec3,
    s: f64,
    tol: f64,
) -> Result<Option<(DVec3, DVec3)>, Error> {
    let g = Phi { phi, tol };
    let (mut x, mut a, mut b) = (x, n1, n2);
    let mut delta = 0.1 * s;
    // The finest samples: a ten-thousandth of s, and clear of the curve by several steps of a
    // finite-difference gradient (a stencil across the edge mixes the faces' normals and
    // biased the point along a sphere's concave rim by 5e-7).
    let finest = (1e-4 * s).max(8.0 * crate::geometry::fd_step(x.abs().max_element()));
    let mut done = None;
    for _ in 0..CURVE_STEPS {
        let mut step = sharp::crease_step(&g, x, a, b, delta)?;
        // Farther from the curve than delta both samples fall on one face: wider ones then
        // (at the start, or when a step with fine samples lands beside the curve).
        while step.is_none() && delta < s {
            delta *= 3.0;
            step = sharp::crease_step(&g, x, a, b, delta)?;
        }
        let Some((y, m1, m2)) = step else { break };
        let d = y.distance(x);
        (x, a, b) = (y, m1, m2);
        done = Some((x, (a + b).normalize_or_zero()));
        if d <= 1e-12 * s || (delta <= finest && d <= tol) {
            break;
        }
        if d < 0.5 * delta {
            delta = (0.1 * delta).max(finest);
        }
    }
    // The tangent planes are taken delta away from the curve, so the point is off by about
    // curvature x delta^2 on a curved face: from the points at the finest samples and at twice
    // them, the error's square law gives the limit (Richardson), kept when phi still holds it.
    if let Some((x0, dir)) = done {
        if delta <= finest {
            let at = |d: f64| -> Result<Option<DVec3>, Error> { Ok(sharp::crease_step(&g, x0, a, b, d)?.map(|r| r.0)) };
            if let (Some(y1), Some(y2)) = (at(finest)?, at(2.0 * finest)?) {
                let y = (4.0 * y1 - y2) / 3.0;
                if let Some(z) = g.project(y)? {
                    if z.distance(y1) <= finest {
                        done = Some((z, dir));
                    }
                }
            }
        }
    }
    Ok(done)
}

/// Where the held vertex `v` goes when asked to move by `d`: nowhere for a corner; for a curve
/// vertex the move along the curve's tangent, projected onto the curve (with the fold test's
/// direction). `None` when it cannot move.
pub(super) fn held_target(
    m: &TriMesh<DVec3>,
    phi: &dyn Implicit3,
    v: VertexId,
    d: DVec3,
    s: f64,
    tol: f64,
) -> Result<Option<(DVec3, DVec3)>, Error> {
    if !matches!(m.tag(v), VertexTag::InternalBoundary { .. }) {
        return Ok(None);
    }
    let Some((n1, n2)) = curve_normals(m, v) else { return Ok(None) };
    let p = m.pos(v);
    if let Some(c) = phi.creases() {
        // The input's own curve: along its tangent, then onto it.
        let Some((a, b)) = curve_labels(m, v) else { return Ok(None) };
        // A vertex far from its pair's curve is mislabelled: it stays rather than jump there.
        let Some((q0, t)) = c.onto(a, b, p) else { return Ok(None) };
        if q0.distance(p) > GIVEN_REACH * s {
            return Ok(None);
        }
        return Ok(c.onto(a, b, p + d.dot(t) * t).map(|(q, _)| (q, (n1 + n2).normalize_or_zero())));
    }
    let Some(t) = n1.cross(n2).try_normalize() else { return Ok(None) };
    onto_crease(phi, p + d.dot(t) * t, n1, n2, s, tol)
}

/// The point where the edge of `h` splits: on the feature curve for a feature edge (`None` if
/// the curve is not found), else the midpoint projected onto phi = 0.
pub(super) fn split_point(
    m: &TriMesh<DVec3>,
    phi: &dyn Implicit3,
    h: HalfEdgeId,
    s: f64,
    tol: f64,
) -> Result<Option<DVec3>, Error> {
    let mid = 0.5 * (m.pos(m.origin(h)) + m.pos(m.dest(h)));
    if !m.is_constrained_edge(h) {
        return project(phi, mid, tol).map(Some);
    }
    let (Some(f1), Some(f2)) = (m.face_of(h), m.face_of(m.twin(h))) else { return Ok(None) };
    if let Some(c) = phi.creases() {
        // An edge between two labels that is not along their curve is not split onto it.
        let len = m.pos(m.origin(h)).distance(m.pos(m.dest(h)));
        let q = c.onto(m.face(f1).label, m.face(f2).label, mid).map(|x| x.0);
        return Ok(q.filter(|q| q.distance(mid) <= GIVEN_SAG * len));
    }
    Ok(onto_crease(phi, mid, face_normal(m, f1), face_normal(m, f2), s, tol)?.map(|x| x.0))
}

/// Splits the edge of `h` at `p` (from [`split_point`]); a new vertex on a feature edge is
/// tagged with that edge's curve. Returns the new vertex.
pub(super) fn split(m: &mut TriMesh<DVec3>, h: HalfEdgeId, p: DVec3) -> Option<VertexId> {
    let labels = match (m.face_of(h), m.face_of(m.twin(h))) {
        (Some(a), Some(b)) if m.is_constrained_edge(h) => Some((m.face(a).label, m.face(b).label)),
        _ => None,
    };
    let v = m.split_edge(h, p).ok()?;
    if let Some((a, b)) = labels {
        m.set_tag(v, VertexTag::InternalBoundary { curve: curve_id(a, b) });
    }
    Some(v)
}

/// How the edge of `h` may collapse: the half-edge whose origin goes and the point the survivor
/// ends at. A free vertex goes into a held one (which stays where it is); a curve vertex goes
/// only along its curve, into a vertex of the same curve (at the midpoint on the curve) or a
/// corner; corners never go. `None` when the edge may not collapse.
pub(super) fn collapse_choice(
    m: &TriMesh<DVec3>,
    phi: &dyn Implicit3,
    h: HalfEdgeId,
    s: f64,
    tol: f64,
) -> Result<Option<(HalfEdgeId, DVec3)>, Error> {
    let (a, b) = (m.origin(h), m.dest(h));
    let t = m.twin(h);
    let along = m.is_constrained_edge(h);
    Ok(match (m.tag(a), m.tag(b)) {
        (VertexTag::Interior, VertexTag::Interior) => Some((h, project(phi, 0.5 * (m.pos(a) + m.pos(b)), tol)?)),
        (VertexTag::Interior, _) => Some((h, m.pos(b))),
        (_, VertexTag::Interior) => Some((t, m.pos(a))),
        (VertexTag::InternalBoundary { curve: ca }, VertexTag::InternalBoundary { curve: cb }) if along && ca == cb => {
            split_point(m, phi, h, s, tol)?.map(|p| (h, p))
        }
        (VertexTag::InternalBoundary { .. }, VertexTag::Fixed) if along => Some((h, m.pos(b))),
        (VertexTag::Fixed, VertexTag::InternalBoundary { .. }) if along => Some((t, m.pos(a))),
        _ => None,
    })
}

/// Unit normals a hair's breadth inside phi = 0 on every side of `q` (`eps` away).
fn probes(phi: &dyn Implicit3, q: DVec3, eps: f64) -> SmallVec<[DVec3; 6]> {
    let n = geom::normal(phi, q);
    [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z]
        .map(|e| phi.gradient(q + (e - n) * eps).normalize_or_zero())
        .into_iter()
        .filter(|n| n.length_squared() > 0.5)
        .collect()
}

/// Whether two unit normals belong to different faces of a sharp edge.
fn distinct(a: DVec3, b: DVec3) -> bool {
    let c = sharp::SHARP_DEG.to_radians().cos();
    let d = a.dot(b);
    d < c && d > -c
}

/// Moves `v` to `p` with the fold test taken along `g`, whatever the surface's gradient is there
/// (on an edge or a corner it is one face's).
fn place(m: &mut TriMesh<DVec3>, v: VertexId, p: DVec3, g: DVec3) -> bool {
    move_if_no_fold_g(m, v, p, g)
}

/// Cuts the start mesh `m` (nodes on phi = 0, edges about `h`) along the sharp edges of phi and
/// labels and tags it (see the module). Returns false, leaving `m` untouched, when phi shows no
/// sharp edge.
pub(super) fn imprint(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, h: f64, tol: f64) -> Result<bool, Error> {
    if let Some(c) = phi.creases() {
        return Ok(imprint_given(m, phi, c));
    }
    let g = Phi { phi, tol };
    let eps = sharp::PROBE * h;
    // The normal of every vertex, and the two faces' of those on an edge.
    let mut normal: SecondaryMap<VertexId, DVec3> = SecondaryMap::new();
    let mut on_edge: SecondaryMap<VertexId, (DVec3, DVec3)> = SecondaryMap::new();
    let mut found: Vec<(DVec3, DVec3, DVec3)> = Vec::new();
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    for &v in &ids {
        let q = m.pos(v);
        let pr = probes(phi, q, eps);
        let n = geom::normal(phi, q - geom::normal(phi, q) * eps);
        normal.insert(v, n);
        if let Some((c, a, b)) = sharp::widest_split(&pr, DVec3::dot) {
            if c < sharp::SHARP_DEG.to_radians().cos() {
                on_edge.insert(v, (a, b));
                found.push((q, a, b));
            }
        }
    }
    let cuts = straddling(m, phi, &normal, &on_edge)?;
    found.extend(cuts.iter().map(|c| (c.1, c.2, c.3)));
    if found.is_empty() {
        return Ok(false);
    }
    // Corners first: the nearest vertex moves onto each and is fixed.
    let limits = |_: DVec3| Ok((sharp::REACH * h, sharp::TOL * h));
    let mut corners: Vec<sharp::Corner> = Vec::new();
    for (c, n) in sharp::corner_points(&g, &found, h, &limits)? {
        if corners.iter().all(|k| k.0.distance(c) >= 0.5 * h) {
            let finest = (1e-4 * h).max(8.0 * crate::geometry::fd_step(c.abs().max_element()));
            corners.push(sharp::refine_corner(&g, c, n, h, finest)?);
        }
    }
    for &(c, n) in &corners {
        let dir = probes(phi, c, eps).iter().sum::<DVec3>().normalize_or_zero();
        if let Some(v) = fix_corner(m, c, dir, true) {
            on_edge.remove(v);
            start_curves(m, phi, v, n, dir, h, tol, &normal, &mut on_edge)?;
        }
    }
    for (v, _) in on_edge.iter() {
        m.set_tag(v, VertexTag::InternalBoundary { curve: 0 });
    }
    // Then the edges that straddle a sharp edge, cut where it crosses them.
    for _ in 0..CUT_PASSES {
        let cuts = straddling(m, phi, &normal, &on_edge)?;
        if cuts.is_empty() {
            break;
        }
        for (e, start, n1, n2) in cuts {
            let Some(hh) = super::density::edge_now(m, e) else { continue };
            let (pa, pb) = (m.pos(e.1), m.pos(e.2));
            if m.tag(e.1) == VertexTag::Fixed || m.tag(e.2) == VertexTag::Fixed {
                continue;
            }
            let len = pa.distance(pb);
            let Some((x, _)) = onto_crease(phi, start, n1, n2, len, tol)? else { continue };
            // An end already near the edge moves onto it (a cut there would leave a sliver).
            let end = |v: VertexId, p: DVec3| -> Result<Option<(f64, VertexId, DVec3, DVec3)>, Error> {
                if m.tag(v) != VertexTag::Interior {
                    return Ok(None);
                }
                Ok(onto_crease(phi, p, n1, n2, len, tol)?.map(|(y, d)| (y.distance(p), v, y, d)))
            };
            let near = [end(e.1, pa)?, end(e.2, pb)?].into_iter().flatten().min_by(|u, w| u.0.total_cmp(&w.0));
            let mut v = match near {
                Some((d, v, y, dir)) if d < CUT_END * len => place(m, v, y, dir).then_some(v),
                _ => None,
            };
            if v.is_none() {
                v = m.split_edge(hh, x).ok();
            }
            if let Some(v) = v {
                m.set_tag(v, VertexTag::InternalBoundary { curve: 0 });
                on_edge.insert(v, (n1, n2));
            }
        }
    }
    unflatten(m);
    // A placed corner stays one, whatever labels end up around it.
    let placed: Vec<VertexId> = m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed).collect();
    label(m, phi, eps);
    for v in placed {
        m.set_tag(v, VertexTag::Fixed);
    }
    Ok(true)
}

/// Flips away the flat triangles the cut leaves on an edge (three held vertices in a line): the
/// longest side of each flips to the apex of the triangle across it.
fn unflatten(m: &mut TriMesh<DVec3>) {
    for _ in 0..CUT_PASSES {
        let mut flipped = 0;
        let faces: Vec<FaceId> = m.face_ids().collect();
        for f in faces {
            if !m.contains_face(f) {
                continue;
            }
            let hs = m.face_half_edges(f);
            let vs = m.face_vertices(f);
            if vs.iter().any(|&v| m.tag(v) == VertexTag::Interior) {
                continue;
            }
            let ps = vs.map(|v| m.pos(v));
            if crate::quality::triangle_q3(ps) > FLAT_Q {
                continue;
            }
            let longest = hs.into_iter().max_by(|&a, &b| {
                let la = m.pos(m.origin(a)).distance(m.pos(m.dest(a)));
                let lb = m.pos(m.origin(b)).distance(m.pos(m.dest(b)));
                la.total_cmp(&lb)
            });
            if let Some(h) = longest {
                if m.flip(h).is_ok() {
                    flipped += 1;
                }
            }
        }
        if flipped == 0 {
            break;
        }
    }
}

/// The edges that straddle a sharp edge (ends of distinct normals, not both held), each with
/// the point where it crosses the edge and the two faces' normals.
type Cut = ((HalfEdgeId, VertexId, VertexId), DVec3, DVec3, DVec3);

fn straddling(
    m: &TriMesh<DVec3>,
    phi: &dyn Implicit3,
    normal: &SecondaryMap<VertexId, DVec3>,
    on_edge: &SecondaryMap<VertexId, (DVec3, DVec3)>,
) -> Result<Vec<Cut>, Error> {
    let mut out = Vec::new();
    for e in super::density::edge_list(m) {
        let (a, b) = (e.1, e.2);
        if m.tag(a) == VertexTag::Fixed || m.tag(b) == VertexTag::Fixed {
            continue;
        }
        let sides = |v: VertexId| -> SmallVec<[DVec3; 2]> {
            match (on_edge.get(v), normal.get(v)) {
                (Some(&(x, y)), _) => [x, y].into_iter().collect(),
                (None, Some(&n)) => [n].into_iter().collect(),
                _ => SmallVec::new(),
            }
        };
        let (sa, sb) = (sides(a), sides(b));
        if sa.len() == 2 && sb.len() == 2 {
            continue;
        }
        let (pa, pb) = (m.pos(a), m.pos(b));
        let (mid, len) = (0.5 * (pa + pb), pa.distance(pb));
        let mut best: Option<(f64, DVec3, DVec3, DVec3)> = None;
        for &na in &sa {
            for &nb in &sb {
                if !sa.iter().all(|&x| distinct(x, nb)) || !sb.iter().all(|&y| distinct(na, y)) {
                    continue;
                }
                let x = sharp::planes_meet(pa, na, pb, nb, mid);
                if !x.is_finite() || x.distance(mid) > len {
                    continue;
                }
                let p = project(phi, x, 1e-9 * len)?;
                let off = p.distance(x);
                if off <= sharp::TOL * len && best.is_none_or(|b| off < b.0) {
                    best = Some((off, p, na, nb));
                }
            }
        }
        if let Some((_, p, na, nb)) = best {
            out.push((e, p, na, nb));
        }
    }
    Ok(out)
}

/// Labels the faces by patch (flooding across every edge but those between two held vertices
/// whose triangles turn by more than SHARP_DEG, and those where grad phi at the two triangles'
/// centroids, `eps` inside, turns by as much: a triangle left across an edge joins one side),
/// then tags the vertices by the labels around
/// them: one is free, two a curve vertex, three or more a corner.
fn label(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, eps: f64) {
    let cos_max = sharp::SHARP_DEG.to_radians().cos();
    let faces: Vec<FaceId> = m.face_ids().collect();
    let mut inner: SecondaryMap<FaceId, DVec3> = SecondaryMap::new();
    for &f in &faces {
        let c = m.face_vertices(f).map(|v| m.pos(v)).iter().sum::<DVec3>() / 3.0;
        inner.insert(f, geom::normal(phi, c - face_normal(m, f) * eps));
    }
    let mut lab: SecondaryMap<FaceId, u32> = SecondaryMap::new();
    let mut next = 0u32;
    for &f0 in &faces {
        if lab.contains_key(f0) {
            continue;
        }
        lab.insert(f0, next);
        let mut stack = vec![f0];
        while let Some(f) = stack.pop() {
            for h in m.face_half_edges(f) {
                let Some(g) = m.face_of(m.twin(h)) else { continue };
                if lab.contains_key(g) {
                    continue;
                }
                let held = m.tag(m.origin(h)) != VertexTag::Interior && m.tag(m.dest(h)) != VertexTag::Interior;
                if held && face_normal(m, f).dot(face_normal(m, g)) < cos_max || inner[f].dot(inner[g]) < cos_max {
                    continue;
                }
                lab.insert(g, next);
                stack.push(g);
            }
        }
        next += 1;
    }
    merge_flat_islands(m, &mut lab);
    for &f in &faces {
        m.set_label(f, lab[f].min(65_535));
    }
    tag_by_labels(m);
}

/// Gives each patch of at most LEAK_FACES flat triangles (a sliver left along a cut edge, whose
/// normal turned it into a patch of its own) the label it shares the longest edges with; the
/// curve then runs along the sliver's sides, which the engine collapses. Left alone, such an
/// island made its vertices spurious corners (a rotated box's edge held three).
fn merge_flat_islands(m: &TriMesh<DVec3>, lab: &mut SecondaryMap<FaceId, u32>) {
    let mut members: std::collections::BTreeMap<u32, Vec<FaceId>> = std::collections::BTreeMap::new();
    for (f, &l) in lab.iter() {
        members.entry(l).or_default().push(f);
    }
    let flat = |f: FaceId| crate::quality::triangle_q3(m.face_vertices(f).map(|v| m.pos(v))) < FLAT_Q;
    for (l, fs) in members {
        if fs.len() > LEAK_FACES || !fs.iter().all(|&f| flat(f)) {
            continue;
        }
        let mut shared: SmallVec<[(u32, f64); 4]> = SmallVec::new();
        for &f in &fs {
            for h in m.face_half_edges(f) {
                let Some(g) = m.face_of(m.twin(h)) else { continue };
                let k = lab[g];
                if k == l {
                    continue;
                }
                let len = m.pos(m.origin(h)).distance(m.pos(m.dest(h)));
                match shared.iter_mut().find(|x| x.0 == k) {
                    Some(x) => x.1 += len,
                    None => shared.push((k, len)),
                }
            }
        }
        let Some(&(to, _)) = shared.iter().max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0))) else { continue };
        for &f in &fs {
            lab.insert(f, to);
        }
    }
}

/// Tags every vertex by the labels of its triangles: one is free, two a curve vertex, three or
/// more a corner.
fn tag_by_labels(m: &mut TriMesh<DVec3>) {
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    for v in ids {
        let tag = match labels_at(m, v).as_slice() {
            [_] => VertexTag::Interior,
            [a, b] => VertexTag::InternalBoundary { curve: curve_id(*a, *b) },
            _ => VertexTag::Fixed,
        };
        m.set_tag(v, tag);
    }
}
