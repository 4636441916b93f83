//! Improvement in space: flips toward quality or valence (the engine's checked flip plus the
//! surface's fold test), tangential smoothing, length equalisation, and the fold-checked moves
//! they share with the force iteration.

use super::density::{edge_list, edge_now};
use super::features;
use super::geom::{faces_out, project_grad, SizeField};
use crate::geometry::Implicit3;
use crate::predicates::{orient3d_dir, Sign};
use crate::quality::triangle_q3;
use crate::topology::{HalfEdgeId, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec3;
use rayon::prelude::*;
use slotmap::SecondaryMap;

/// The smallest cosine between a new triangle's normal and grad phi at its centroid that a
/// flip or collapse may leave (60 degrees of normal deviation).
pub const FOLD_COS: f64 = 0.5;

/// Length-equalising sweeps after the force iteration (stopping early when nothing moves).
const EQUALIZE_SWEEPS: usize = 10;

/// Why a flip is wanted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlipGoal {
    /// Raise the worse quality of the two triangles.
    Quality,
    /// Bring the four valences closer to 6 without a triangle worse than `MIN_Q_VALENCE`.
    Valence,
}

/// The worst new triangle a valence flip may make.
const MIN_Q_VALENCE: f64 = 0.4;

/// Tries to flip the edge of `h` toward `goal`. Returns whether it flipped. The new triangles
/// must face outward (normal deviation below 60 degrees). `valence` holds every vertex's
/// valence for [`FlipGoal::Valence`] and is kept up to date.
pub fn try_flip(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    h: HalfEdgeId,
    goal: FlipGoal,
    valence: &mut SecondaryMap<VertexId, u32>,
) -> bool {
    // The cheap tests first (quality, valence), then the engine's check.
    let t = m.twin(h);
    if m.face_of(h).is_none() || m.face_of(t).is_none() {
        return false;
    }
    let (a, b) = (m.origin(h), m.origin(t));
    let (c, d) = (m.dest(m.next(h)), m.dest(m.next(t)));
    let (pa, pb, pc, pd) = (m.pos(a), m.pos(b), m.pos(c), m.pos(d));
    let old = triangle_q3([pa, pb, pc]).min(triangle_q3([pb, pa, pd]));
    let new = triangle_q3([pc, pa, pd]).min(triangle_q3([pd, pb, pc]));
    let wanted = match goal {
        FlipGoal::Quality => new > old + 1e-9,
        FlipGoal::Valence => {
            let val = |v: VertexId| valence.get(v).map_or_else(|| m.valence(v), |&k| k as usize) as i64;
            let (va, vb, vc, vd) = (val(a), val(b), val(c), val(d));
            // A vertex of valence 3 would drop to 2: never.
            if va <= 3 || vb <= 3 {
                return false;
            }
            let dev = |v: i64| (v - 6) * (v - 6);
            let before = dev(va) + dev(vb) + dev(vc) + dev(vd);
            let after = dev(va - 1) + dev(vb - 1) + dev(vc + 1) + dev(vd + 1);
            after < before && new >= MIN_Q_VALENCE.min(old)
        }
    };
    if !wanted {
        return false;
    }
    let Ok(plan) = m.check_flip(h) else {
        return false;
    };
    debug_assert!(plan.a == a && plan.b == b && plan.c == c && plan.d == d);
    if !faces_out(phi, pc, pa, pd, FOLD_COS) || !faces_out(phi, pd, pb, pc, FOLD_COS) {
        return false;
    }
    m.apply_flip(plan);
    if goal == FlipGoal::Valence {
        for (v, delta) in [(a, -1i32), (b, -1), (c, 1), (d, 1)] {
            if let Some(k) = valence.get_mut(v) {
                *k = (*k as i32 + delta) as u32;
            }
        }
    }
    true
}

/// Every vertex's valence, counted once over the half-edges.
fn valences(m: &TriMesh<DVec3>) -> SecondaryMap<VertexId, u32> {
    let mut out: SecondaryMap<VertexId, u32> = SecondaryMap::with_capacity(m.num_vertices());
    for v in m.vertex_ids() {
        out.insert(v, 0);
    }
    for h in m.half_edge_ids() {
        if let Some(k) = out.get_mut(m.origin(h)) {
            *k += 1;
        }
    }
    out
}

/// Sweeps over all edges flipping toward `goal` until a sweep flips nothing (at most
/// `max_sweeps`). Returns the number of flips.
pub fn flip_pass(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, goal: FlipGoal, max_sweeps: usize) -> usize {
    let mut total = 0;
    let mut valence = if goal == FlipGoal::Valence { valences(m) } else { SecondaryMap::new() };
    for _ in 0..max_sweeps {
        let mut n = 0;
        for e in edge_list(m) {
            if let Some(h) = edge_now(m, e) {
                if try_flip(m, phi, h, goal, &mut valence) {
                    n += 1;
                }
            }
        }
        total += n;
        if n == 0 {
            break;
        }
    }
    total
}

/// Moves every vertex toward the average of its neighbours by `lambda`, in the tangent plane
/// only, then projects it; a move that would fold a triangle is skipped.
pub fn smooth_tangential(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, lambda: f64, tol: f64) -> Result<(), Error> {
    // Targets and their projections depend on the positions before the pass only: computed in
    // parallel, then applied in arena order.
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    let mesh = &*m;
    let moves: Vec<Option<(DVec3, DVec3)>> = ids
        .par_iter()
        .map(|&v| {
            let p = mesh.pos(v);
            if mesh.tag(v) != VertexTag::Interior {
                // Along the curve, toward the middle of its two neighbours on it.
                let nb = features::curve_neighbours(mesh, v);
                if nb.len() != 2 {
                    return Ok(None);
                }
                let c = 0.5 * (mesh.pos(nb[0]) + mesh.pos(nb[1]));
                let s = p.distance(c).max(mesh.pos(nb[0]).distance(mesh.pos(nb[1])));
                return features::held_target(mesh, phi, v, lambda * (c - p), s, tol);
            }
            let nb = mesh.neighbours(v);
            let c = nb.iter().map(|&w| mesh.pos(w)).sum::<DVec3>() / nb.len().max(1) as f64;
            let n = super::geom::normal(phi, p);
            let d = c - p;
            project_grad(phi, p + lambda * (d - d.dot(n) * n), tol).map(Some)
        })
        .collect::<Result<_, Error>>()?;
    for (&v, mv) in ids.iter().zip(&moves) {
        if let Some((p, g)) = *mv {
            move_if_no_fold_g(m, v, p, g);
        }
    }
    Ok(())
}

/// Moves `v` to `p` unless a triangle around it would fold (turn its normal more than 90
/// degrees from grad phi at p); returns whether it moved. One gradient at p serves the whole
/// star: its triangles are within an edge length of p, where grad phi turns by a few degrees at
/// most on any surface the mesh resolves, far inside the 90 degrees this test allows.
pub fn move_if_no_fold(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, v: VertexId, p: DVec3) -> bool {
    move_if_no_fold_g(m, v, p, phi.gradient(p))
}

/// [`move_if_no_fold`] with grad phi at `p` already known.
pub fn move_if_no_fold_g(m: &mut TriMesh<DVec3>, v: VertexId, p: DVec3, g: DVec3) -> bool {
    // NaN fails the comparison too: no gradient, no move.
    if g.length_squared().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return false;
    }
    let start = m.vertex(v).out;
    let mut x = start;
    loop {
        if m.face_of(x).is_some() {
            let y = m.next(x);
            let (b, c) = (m.pos(m.origin(y)), m.pos(m.dest(y)));
            if orient3d_dir(p, b, c, g) != Sign::Positive {
                return false;
            }
        }
        x = m.next(m.twin(x));
        if x == start {
            break;
        }
    }
    m.set_pos_unchecked(v, p);
    true
}

/// Moves `v` to `p` unless, near a feature ([`near_feature`]), the surface then crosses itself
/// there and did not before (a surface already crossing itself may still move out of it).
/// Returns whether it moved.
pub fn move_unless_crossing(m: &mut TriMesh<DVec3>, v: VertexId, p: DVec3) -> bool {
    let from = m.pos(v);
    m.set_pos_unchecked(v, p);
    if near_feature(m, v) && crate::topology::surface_star_meets(m, v) {
        m.set_pos_unchecked(v, from);
        if !crate::topology::surface_star_meets(m, v) {
            return false;
        }
        m.set_pos_unchecked(v, p);
    }
    true
}

/// Whether `v` or a neighbour is held on a feature (a curve vertex or a corner): there the
/// surface turns sharply, and a star with no fold of its own can pass through the faces across
/// the curve (the final projection checks that there; the force loop's moves, a thousand times
/// as many, do not: measured on the part, the check would cost five times the run).
pub(super) fn near_feature(m: &TriMesh<DVec3>, v: VertexId) -> bool {
    m.tag(v) != VertexTag::Interior || m.neighbours(v).iter().any(|&w| m.tag(w) != VertexTag::Interior)
}

/// Gauss-Seidel sweeps that move each vertex in its tangent plane to bring the lengths of its
/// edges toward `scale` h(midpoint): one Gauss-Newton step on sum (|p - n_j| - t_j)^2 per
/// vertex and sweep, limited to a fifth of h, then projected; moves that would fold are skipped.
/// The force iteration's equilibrium balances forces, not lengths; this lowers the spread of
/// the edge lengths directly. Returns the largest move relative to h.
pub fn equalize_lengths(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    scale: f64,
    tol: f64,
) -> Result<f64, Error> {
    use glam::DMat3;
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    // A vertex has not moved yet when its turn comes (only its neighbours have), so the
    // normals at the sweep's start are the ones it needs: computed in parallel.
    let mesh = &*m;
    let normals: Vec<DVec3> = ids.par_iter().map(|&v| super::geom::normal(phi, mesh.pos(v))).collect();
    let mut largest = 0.0f64;
    for (&v, &n) in ids.iter().zip(&normals) {
        let p = m.pos(v);
        if m.tag(v) != VertexTag::Interior {
            if let Some(step) = held_step(m, v, size, scale) {
                let h = size.at(p);
                if let Some((target, g)) = features::held_target(m, phi, v, step, h, tol)? {
                    if move_keeping_quality(m, v, target, g) {
                        largest = largest.max(target.distance(p) / h);
                    }
                }
            }
            continue;
        }
        let mut a = DMat3::from_cols(n * n.x, n * n.y, n * n.z);
        let mut rhs = DVec3::ZERO;
        for w in m.neighbours(v) {
            let q = m.pos(w);
            let d = p - q;
            let l = d.length();
            if l == 0.0 {
                continue;
            }
            let u = d / l;
            let u = u - u.dot(n) * n;
            let r = l - scale * size.at(0.5 * (p + q));
            a += DMat3::from_cols(u * u.x, u * u.y, u * u.z);
            rhs -= r * u;
        }
        if a.determinant().abs() < 1e-12 {
            continue;
        }
        let mut step = a.inverse() * rhs;
        let h = size.at(p);
        if step.length() > 0.2 * h {
            step *= 0.2 * h / step.length();
        }
        let (target, g) = project_grad(phi, p + step, tol)?;
        if move_keeping_quality(m, v, target, g) {
            largest = largest.max(target.distance(p) / h);
        }
    }
    Ok(largest)
}

/// Below this quality an equalising move may not take a triangle, nor further down one already
/// there.
const EQUALIZE_Q: f64 = 0.5;

/// The worst triangle quality around `v`.
fn star_min_q(m: &TriMesh<DVec3>, v: VertexId) -> f64 {
    m.outgoing(v).into_iter().filter_map(|h| m.face_of(h)).map(|f| m.face_quality(f)).fold(1.0, f64::min)
}

/// [`move_if_no_fold_g`], undone when the worst triangle around `v` ends below
/// min(EQUALIZE_Q, its quality before): evening out lengths must not make a triangle poor (on a
/// noisy input the projection of a small tangential step can land a node next to another).
fn move_keeping_quality(m: &mut TriMesh<DVec3>, v: VertexId, p: DVec3, g: DVec3) -> bool {
    let (from, before) = (m.pos(v), star_min_q(m, v));
    if !move_if_no_fold_g(m, v, p, g) {
        return false;
    }
    if star_min_q(m, v) < before.min(EQUALIZE_Q) {
        m.set_pos_unchecked(v, from);
        return false;
    }
    true
}

/// The Gauss-Newton step of [`equalize_lengths`] for a vertex on a feature curve: along the
/// curve's tangent only, toward the lengths of its two feature edges, limited to a fifth of h.
fn held_step(m: &TriMesh<DVec3>, v: VertexId, size: &SizeField, scale: f64) -> Option<DVec3> {
    let (n1, n2) = features::curve_normals(m, v)?;
    let t = n1.cross(n2).try_normalize()?;
    let p = m.pos(v);
    let (mut a, mut rhs) = (0.0, 0.0);
    for w in features::curve_neighbours(m, v) {
        let q = m.pos(w);
        let d = p - q;
        let l = d.length();
        if l == 0.0 {
            continue;
        }
        let u = (d / l).dot(t);
        a += u * u;
        rhs -= (l - scale * size.at(0.5 * (p + q))) * u;
    }
    if a < 1e-6 {
        return None;
    }
    let mut step = rhs / a;
    let h = size.at(p);
    step = step.clamp(-0.2 * h, 0.2 * h);
    Some(step * t)
}

/// sum(L h) / sum(h^2): the scale that best fits the edge lengths L to the sizes h.
fn mean_ratio(m: &TriMesh<DVec3>, size: &SizeField) -> f64 {
    let (mut lh, mut hh) = (0.0, 0.0);
    for e in m.edge_ids() {
        let (p, q) = (m.pos(m.origin(e)), m.pos(m.dest(e)));
        let h = size.at(0.5 * (p + q));
        lh += p.distance(q) * h;
        hh += h * h;
    }
    lh / hh
}

/// Up to EQUALIZE_SWEEPS sweeps of [`equalize_lengths`] toward the scale that best fits the
/// lengths to the sizes, stopping after the first sweep that moves no node more than `dptol`
/// h. Returns the number of sweeps.
pub(super) fn equalize(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    dptol: f64,
    tol: f64,
) -> Result<usize, Error> {
    let mut sweeps = 0;
    for _ in 0..EQUALIZE_SWEEPS {
        sweeps += 1;
        let scale = mean_ratio(m, size);
        if equalize_lengths(m, phi, size, scale, tol)? < dptol {
            break;
        }
    }
    Ok(sweeps)
}
