//! Corners of sharp features found from phi: a vertex fixed on each, and the three curves
//! leaving it started through its fan.

use super::{distinct, onto_crease, place, CORNER_TRIES};
use crate::geometry::Implicit3;
use crate::mesher::surface::geom::project;
use crate::topology::{TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec3;
use slotmap::SecondaryMap;

/// Fixes a vertex on the corner `c`: of the CORNER_TRIES vertices nearest it that can move
/// there without folding (fold test along `dir`), the nearest, or with `best` the one whose
/// triangles keep the best worst quality there. That vertex, or `None`. The nearest alone often
/// cannot move: a marching start's vertex 0.6 h from a rotated box's corner folded its fan. For
/// corners found from phi the next nearest that can may stretch its fan (an L prism's corner
/// lost 3.6 degrees of min angle), hence `best`; for given corners, cut into an even mesh, the
/// nearest that can is kept (`best` there left a turned box with an inward triangle).
pub(super) fn fix_corner(m: &mut TriMesh<DVec3>, c: DVec3, dir: DVec3, best: bool) -> Option<VertexId> {
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
pub(super) fn start_curves(
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
