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
use crate::geometry::{Creases, Implicit3};
use crate::mesher::sharp::{self, Zero};
use crate::topology::{FaceId, HalfEdgeId, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec3;
use slotmap::SecondaryMap;
use smallvec::SmallVec;

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
/// curve (see [`hold_pins`]).
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

/// Fixes a vertex on the corner `c`: of the CORNER_TRIES vertices nearest it that can move
/// there without folding (fold test along `dir`), the nearest, or with `best` the one whose
/// triangles keep the best worst quality there. That vertex, or `None`. The nearest alone often
/// cannot move: a marching start's vertex 0.6 h from a rotated box's corner folded its fan. For
/// corners found from phi the next nearest that can may stretch its fan (an L prism's corner
/// lost 3.6 degrees of min angle), hence `best`; for given corners, cut into an even mesh, the
/// nearest that can is kept (`best` there left a turned box with an inward triangle).
fn fix_corner(m: &mut TriMesh<DVec3>, c: DVec3, dir: DVec3, best: bool) -> Option<VertexId> {
    let mut near: Vec<(f64, VertexId)> = m.vertex_ids().map(|v| (m.pos(v).distance(c), v)).collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut chosen: Option<(f64, VertexId)> = None;
    for &(_, v) in near.iter().take(CORNER_TRIES) {
        let p = m.pos(v);
        if m.tag(v) == VertexTag::Fixed || !place(m, v, c, dir) {
            continue;
        }
        let q = m
            .vertex_faces(v)
            .iter()
            .map(|&f| crate::quality::triangle_q3(m.face_vertices(f).map(|w| m.pos(w))))
            .fold(f64::INFINITY, f64::min);
        m.set_pos_unchecked(v, p);
        if chosen.is_none_or(|b| q > b.0) {
            chosen = Some((q, v));
        }
        if !best {
            break;
        }
    }
    let (_, v) = chosen?;
    m.set_pos_unchecked(v, c);
    m.set_tag(v, VertexTag::Fixed);
    Some(v)
}

/// Angle in degrees within which a vertex of a corner's fan already lies along a curve leaving
/// the corner, seen along the corner's mean normal.
const CURVE_START_DEG: f64 = 20.0;
/// How far (as a fraction of the distance gone) phi may leave zero along a curve leaving a
/// corner: a curve of radius three lengths sags by a sixth of the length.
const CURVE_OFF: f64 = 0.2;
/// Cosine of the angle within which a vertex's normal is a face's.
const SAME_FACE_COS: f64 = 0.94;

/// Starts the three feature curves out of the corner `v` (faces of normals `n`, mean outward
/// normal `dir`, curves about `h` long between vertices): each leaves along the cross product of
/// its two faces' normals, on the side where phi stays zero, and crosses one triangle of the
/// fan (seen along `dir`). Unless that triangle's far edge joins a vertex of each of the two
/// faces (`normal`: the vertices' normals; the cut passes split such an edge), the fan vertex
/// already along the curve moves onto it, or else the far edge splits where the curve crosses
/// it. Without this a fan triangle could bridge a face's corner (seen on a rotated box: one
/// triangle from the corner to a point of one edge and a point of the next face), and no edge
/// followed the curve out of it.
#[allow(clippy::too_many_arguments)]
fn start_curves(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    v: VertexId,
    n: [DVec3; 3],
    dir: DVec3,
    h: f64,
    tol: f64,
    normal: &SecondaryMap<VertexId, DVec3>,
    on_edge: &mut SecondaryMap<VertexId, (DVec3, DVec3)>,
) -> Result<(), Error> {
    // Three faces, each turned from the others: two samples of one curved face (a circular
    // rim's cylinder side taken for two) start no curve.
    let faces_apart = distinct(n[0], n[1]) && distinct(n[1], n[2]) && distinct(n[2], n[0]);
    if dir.length_squared() < 0.5 || !faces_apart {
        return Ok(());
    }
    let c = m.pos(v);
    let u1 = dir.any_orthonormal_vector();
    let u2 = dir.cross(u1);
    let angle = |p: DVec3| (p - c).dot(u2).atan2((p - c).dot(u1));
    let wrap = |a: f64| {
        let t = std::f64::consts::TAU;
        a - t * ((a + std::f64::consts::PI) / t).floor()
    };
    let near_deg = CURVE_START_DEG.to_radians();
    for (i, j) in [(0, 1), (1, 2), (2, 0)] {
        let Some(t0) = n[i].cross(n[j]).try_normalize() else { continue };
        let probe = 0.3 * h;
        let (fwd, back) = (phi.value(c + t0 * probe).abs(), phi.value(c - t0 * probe).abs());
        // Along a curve phi stays zero but for the curve's sag: a direction off the surface on
        // both sides is no curve (normals mixed across an edge give such).
        if fwd.min(back) > CURVE_OFF * probe {
            continue;
        }
        let t = if fwd <= back { t0 } else { -t0 };
        let at = angle(c + t);
        // The fan triangle (v, a, b), counter-clockwise about dir, whose angle holds t.
        let mut hit = None;
        for hh in m.outgoing(v) {
            if m.face_of(hh).is_none() {
                continue;
            }
            let ab = m.next(hh);
            let (a, b) = (m.origin(ab), m.dest(ab));
            let (ra, rb) = (wrap(angle(m.pos(a)) - at), wrap(angle(m.pos(b)) - at));
            if ra <= 0.0 && rb > 0.0 && rb - ra < std::f64::consts::PI {
                hit = Some((ab, a, b, ra, rb));
                break;
            }
        }
        let Some((ab, a, b, ra, rb)) = hit else { continue };
        // An edge from one face's vertex to the other's straddles the curve: the cut passes
        // split it where the planes meet.
        let on = |x: VertexId, k: usize| normal.get(x).is_some_and(|&q| q.dot(n[k]) > SAME_FACE_COS);
        if on(a, i) && on(b, j) || on(a, j) && on(b, i) {
            continue;
        }
        // A fan vertex already along the curve: it moves onto it (or is on it already).
        let close = if -ra <= rb { (a, -ra) } else { (b, rb) };
        if close.1 < near_deg {
            let w = close.0;
            if m.tag(w) == VertexTag::Interior {
                let len = m.pos(w).distance(c);
                if let Some((y, d)) = onto_crease(phi, m.pos(w), n[i], n[j], len, tol)? {
                    if place(m, w, y, d) {
                        m.set_tag(w, VertexTag::InternalBoundary { curve: 0 });
                        on_edge.insert(w, (n[i], n[j]));
                    }
                }
            }
            continue;
        }
        // Else the opposite edge splits where the curve crosses it.
        let (pa, pb) = (m.pos(a), m.pos(b));
        let x = project(phi, pa + (pb - pa) * (-ra / (rb - ra)), tol)?;
        let len = pa.distance(pb);
        let Some((y, d)) = onto_crease(phi, x, n[i], n[j], len, tol)? else { continue };
        let Ok(w) = m.split_edge(ab, x) else { continue };
        if place(m, w, y, d) {
            m.set_tag(w, VertexTag::InternalBoundary { curve: 0 });
            on_edge.insert(w, (n[i], n[j]));
        }
    }
    Ok(())
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

/// [`imprint`] with the sharp features the geometry gives exactly (`c`), into an even mesh of
/// the surface: vertices already on a curve are held there; the nearest vertex that can move
/// onto each corner without folding does so and is fixed; every edge between two patches is
/// cut where the curve of those two crosses it (or its end near the curve moves onto it); the
/// faces are labelled by [`label_given`], the vertices tagged by the labels around them (the
/// placed corners stay fixed), and the curve vertices put on their curve. Returns false,
/// leaving `m` untouched, when a vertex has no patch.
fn imprint_given(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, c: &dyn Creases) -> bool {
    let mut patch: SecondaryMap<VertexId, u32> = SecondaryMap::new();
    for v in m.vertex_ids() {
        let Some(l) = c.patch(m.pos(v)) else { return false };
        patch.insert(v, l);
    }
    // Vertices already on a curve (projections onto a convex edge land on it) are held there.
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    for &v in &ids {
        let p = m.pos(v);
        for w in m.neighbours(v) {
            let (a, b) = (patch[v], patch[w]);
            if a == b {
                continue;
            }
            if let Some((q, _)) = c.onto(a, b, p) {
                if q.distance(p) <= ON_CURVE * p.distance(m.pos(w)) {
                    m.set_tag(v, VertexTag::InternalBoundary { curve: curve_id(a, b) });
                    break;
                }
            }
        }
    }
    for &k in c.corners() {
        fix_corner(m, k, phi.gradient(k).normalize_or_zero(), false);
    }
    for _ in 0..CUT_PASSES {
        let mut cuts = Vec::new();
        for e in super::density::edge_list(m) {
            let (a, b) = (e.1, e.2);
            if m.tag(a) != VertexTag::Interior || m.tag(b) != VertexTag::Interior || patch[a] == patch[b] {
                continue;
            }
            let (pa, pb) = (m.pos(a), m.pos(b));
            let (mid, len) = (0.5 * (pa + pb), pa.distance(pb));
            if let Some((x, _)) = c.onto(patch[a], patch[b], mid) {
                if x.distance(mid) <= len {
                    cuts.push((e, x, patch[a].min(patch[b]), patch[a].max(patch[b])));
                }
            }
        }
        if cuts.is_empty() {
            break;
        }
        for (e, x, la, lb) in cuts {
            let Some(hh) = super::density::edge_now(m, e) else { continue };
            if m.tag(e.1) != VertexTag::Interior || m.tag(e.2) != VertexTag::Interior {
                continue;
            }
            let (pa, pb) = (m.pos(e.1), m.pos(e.2));
            let len = pa.distance(pb);
            let dir = (phi.gradient(pa) + phi.gradient(pb)).normalize_or_zero();
            // An end already near the curve moves onto it (a cut there would leave a sliver).
            let (da, db) = (x.distance(pa), x.distance(pb));
            let end = if da <= db { e.1 } else { e.2 };
            let mut v = (da.min(db) < CUT_END * len && place(m, end, x, dir)).then_some(end);
            if v.is_none() {
                v = m.split_edge(hh, x).ok();
            }
            if let Some(v) = v {
                m.set_tag(v, VertexTag::InternalBoundary { curve: curve_id(la, lb) });
            }
        }
    }
    unflatten(m);
    let corners: Vec<VertexId> = m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed).collect();
    label_given(m, c);
    tag_by_labels(m);
    for v in corners {
        m.set_tag(v, VertexTag::Fixed);
    }
    // A vertex where three patches meet that is not on a corner yet (the nearest vertex could
    // not move there without folding its star) goes onto the nearest corner: its star spans
    // the patches around it.
    let held: Vec<VertexId> = m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed).collect();
    for v in held {
        let p = m.pos(v);
        let near = c.corners().iter().copied().min_by(|a, b| a.distance(p).total_cmp(&b.distance(p)));
        if let Some(k) = near {
            if k != p {
                place(m, v, k, phi.gradient(k).normalize_or_zero());
            }
        }
    }
    let curve: Vec<VertexId> =
        m.vertex_ids().filter(|&v| matches!(m.tag(v), VertexTag::InternalBoundary { .. })).collect();
    for v in curve {
        let (Some((a, b)), Some((n1, n2))) = (curve_labels(m, v), curve_normals(m, v)) else { continue };
        if let Some((q, _)) = c.onto(a, b, m.pos(v)) {
            place(m, v, q, (n1 + n2).normalize_or_zero());
        }
    }
    hold_pins(m, c.pins());
    true
}

/// The geometry's own triangulation ([`Creases::triangulation`]) as a start: its curves are its
/// edges, so nothing is cut; its faces are labelled by their patches, its vertices tagged by
/// the labels around them, and the pins held. None when the geometry gives none or it does not
/// load into the engine.
pub(super) fn input_start(c: &dyn Creases) -> Option<TriMesh<DVec3>> {
    let t = c.triangulation()?;
    let (mut m, _) = TriMesh::from_arrays(&t.points, &t.triangles).ok()?;
    let patch = t.patch;
    // The engine numbers the faces in the order of the triangles given.
    let faces: Vec<_> = m.face_ids().collect();
    if faces.len() != patch.len() {
        return None;
    }
    for (f, l) in faces.into_iter().zip(patch) {
        m.set_label(f, l);
    }
    tag_by_labels(&mut m);
    hold_pins(&mut m, c.pins());
    Some(m)
}

/// Holds a vertex at each pin (a point on a curve, [`Creases::pins`]): the curve edge nearest
/// the pin is split there, or its end moves onto it when near, and the vertex is fixed. A pin
/// with no curve edge within PIN_REACH edge lengths is left (its curve was not cut there).
fn hold_pins(m: &mut TriMesh<DVec3>, pins: &[DVec3]) {
    if pins.is_empty() {
        return;
    }
    let mut edges: Vec<(VertexId, VertexId)> =
        m.edge_ids().filter(|&h| m.is_constrained_edge(h)).map(|h| (m.origin(h), m.dest(h))).collect();
    for &k in pins {
        // The nearest curve edge, its parameter at the pin and the pin's distance from it.
        let mut best: Option<(f64, usize, f64)> = None;
        for (i, &(a, b)) in edges.iter().enumerate() {
            if !m.contains_vertex(a) || !m.contains_vertex(b) {
                continue;
            }
            let (pa, pb) = (m.pos(a), m.pos(b));
            let d = pb - pa;
            let t = ((k - pa).dot(d) / d.length_squared()).clamp(0.0, 1.0);
            let dist = k.distance(pa + d * t);
            if best.is_none_or(|x| dist < x.0) {
                best = Some((dist, i, t));
            }
        }
        let Some((dist, i, t)) = best else { return };
        let (a, b) = edges[i];
        let Some(h) = m.find_half_edge(a, b) else { continue };
        let len = m.pos(a).distance(m.pos(b));
        // A chord of the curve cuts a turn theta by up to theta len / 4.
        if dist > PIN_REACH * len {
            continue;
        }
        let (n1, n2) = match (m.face_of(h), m.face_of(m.twin(h))) {
            (Some(f), Some(g)) => (face_normal(m, f), face_normal(m, g)),
            _ => continue,
        };
        let dir = (n1 + n2).normalize_or_zero();
        // The nearer end, if it slides on the curve, moves onto the pin (the curve's vertices
        // then even out around it); a split would leave an edge shorter than half the others.
        let end = if t < 0.5 { a } else { b };
        if t.min(1.0 - t) < CUT_END && m.tag(end) == VertexTag::Fixed {
            continue;
        }
        if matches!(m.tag(end), VertexTag::InternalBoundary { .. }) && place(m, end, k, dir) {
            m.set_tag(end, VertexTag::Fixed);
            continue;
        }
        if let Some(v) = split(m, h, k) {
            m.set_tag(v, VertexTag::Fixed);
            edges[i] = (a, v);
            edges.push((v, b));
        }
    }
}

/// The pair of patches a curve vertex was cut or found on.
fn pair_of(tag: VertexTag) -> Option<(u32, u32)> {
    match tag {
        VertexTag::InternalBoundary { curve } => Some((curve / 65_536, curve % 65_536)),
        _ => None,
    }
}

/// Labels the faces of the cut mesh by the given patches: regions flooded across every edge but
/// those along a curve (both ends held, the midpoint on the curve of an end's pair), each region
/// labelled by the patch under most of its triangles' centroids. A triangle whose centroid
/// strays across a curve (near a corner) so keeps the label of its side.
fn label_given(m: &mut TriMesh<DVec3>, c: &dyn Creases) {
    let along = |m: &TriMesh<DVec3>, h: HalfEdgeId| -> bool {
        let (a, b) = (m.origin(h), m.dest(h));
        if m.tag(a) == VertexTag::Interior || m.tag(b) == VertexTag::Interior {
            return false;
        }
        let (pa, pb) = (m.pos(a), m.pos(b));
        let (mid, len) = (0.5 * (pa + pb), pa.distance(pb));
        match (pair_of(m.tag(a)), pair_of(m.tag(b))) {
            (None, None) => true,
            (x, y) => [x, y]
                .into_iter()
                .flatten()
                .any(|(p, q)| c.onto(p, q, mid).is_some_and(|(on, _)| on.distance(mid) <= GIVEN_SAG * len)),
        }
    };
    let faces: Vec<FaceId> = m.face_ids().collect();
    let mut region: SecondaryMap<FaceId, usize> = SecondaryMap::new();
    let mut regions: Vec<Vec<FaceId>> = Vec::new();
    for &f0 in &faces {
        if region.contains_key(f0) {
            continue;
        }
        let k = regions.len();
        region.insert(f0, k);
        let mut members = vec![f0];
        let mut i = 0;
        while i < members.len() {
            let f = members[i];
            i += 1;
            for h in m.face_half_edges(f) {
                let Some(g) = m.face_of(m.twin(h)) else { continue };
                if region.contains_key(g) || along(m, h) {
                    continue;
                }
                region.insert(g, k);
                members.push(g);
            }
        }
        regions.push(members);
    }
    for members in regions {
        // The patch under each triangle's centroid, once.
        let own: Vec<Option<u32>> = members
            .iter()
            .map(|&f| c.patch(m.face_vertices(f).map(|v| m.pos(v)).iter().sum::<DVec3>() / 3.0))
            .collect();
        let mut votes: Vec<(u32, usize)> = Vec::new();
        for l in own.iter().map(|l| l.unwrap_or(0)) {
            match votes.iter_mut().find(|x| x.0 == l) {
                Some(x) => x.1 += 1,
                None => votes.push((l, 1)),
            }
        }
        // Most votes; the lower patch on a tie (deterministic).
        let best = votes.iter().max_by(|x, y| x.1.cmp(&y.1).then(y.0.cmp(&x.0))).map_or(0, |x| x.0);
        // A region with many faces of another patch has leaked through a gap in the cut
        // curves: its faces take their own patches, and the faces at the gap meet along
        // edges that the pipeline then holds on the curve between them.
        let leaked = votes.iter().any(|&(l, n)| l != best && n > LEAK_FACES.max(members.len() / 20));
        for (&f, l) in members.iter().zip(own) {
            let l = if leaked { l.unwrap_or(best) } else { best };
            m.set_label(f, l.min(65_535));
        }
    }
}
