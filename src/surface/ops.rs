//! Local operations in space: the engine's checked flip, split and collapse plus the surface
//! conditions the engine cannot know (no fold against grad phi, quality, valence).

use super::geom::{faces_out, project, project_grad, SizeField};
use crate::geometry::Implicit3;
use crate::quality::triangle_q3;
use crate::topology::{HalfEdgeId, TriMesh, VertexId};
use crate::Error;
use glam::DVec3;
use rayon::prelude::*;
use slotmap::SecondaryMap;

/// The smallest cosine between a new triangle's normal and grad phi at its centroid that a
/// flip or collapse may leave (60 degrees of normal deviation).
pub const FOLD_COS: f64 = 0.5;

/// Counts of operations done, for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpCounts {
    /// Edge splits.
    pub splits: usize,
    /// Edge collapses.
    pub collapses: usize,
    /// Edge flips.
    pub flips: usize,
}

/// Every edge as one half-edge and its two end vertices, in arena order: a stable list to walk
/// while the mesh changes. [`edge_now`] finds the edge again.
pub fn edge_list(m: &TriMesh<DVec3>) -> Vec<(HalfEdgeId, VertexId, VertexId)> {
    m.edge_ids().map(|h| (h, m.origin(h), m.dest(h))).collect()
}

/// The half-edge a -> b of a listed edge now, or `None` if the edge is gone. The listed
/// half-edge usually still runs a -> b (an O(1) check); otherwise a search around a.
#[inline]
pub fn edge_now(m: &TriMesh<DVec3>, (h, a, b): (HalfEdgeId, VertexId, VertexId)) -> Option<HalfEdgeId> {
    if m.contains_half_edge(h) && m.origin(h) == a && m.dest(h) == b {
        return Some(h);
    }
    if !m.contains_vertex(a) || !m.contains_vertex(b) {
        return None;
    }
    m.find_half_edge(a, b)
}

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

/// Splits every edge longer than `hi` times h(midpoint) at its midpoint projected onto the
/// surface. Returns the number of splits.
pub fn split_long(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    hi: f64,
    tol: f64,
) -> Result<usize, Error> {
    let mut n = 0;
    for e in edge_list(m) {
        let Some(h) = edge_now(m, e) else { continue };
        let (a, b) = (e.1, e.2);
        let (pa, pb) = (m.pos(a), m.pos(b));
        let mid = 0.5 * (pa + pb);
        if pa.distance(pb) <= hi * size.at(mid) {
            continue;
        }
        let p = project(phi, mid, tol)?;
        if m.split_edge(h, p).is_ok() {
            n += 1;
        }
    }
    Ok(n)
}

/// The triangles around `a` and `b` that survive collapsing the edge a-b, with both ends moved
/// to `pos`, as point triples (counter-clockwise).
fn collapse_ring(m: &TriMesh<DVec3>, h: HalfEdgeId, pos: DVec3) -> (Vec<[DVec3; 3]>, Vec<DVec3>) {
    let t = m.twin(h);
    let (a, b) = (m.origin(h), m.origin(t));
    let gone = [m.face_of(h), m.face_of(t)];
    let mut tris = Vec::new();
    let mut ring = Vec::new();
    for v in [a, b] {
        for x in m.outgoing(v) {
            let w = m.dest(x);
            if w != a && w != b {
                ring.push(m.pos(w));
            }
            let Some(f) = m.face_of(x) else { continue };
            if gone.contains(&Some(f)) {
                continue;
            }
            let y = m.next(x);
            tris.push([pos, m.pos(m.origin(y)), m.pos(m.dest(y))]);
        }
    }
    (tris, ring)
}

/// Collapses every edge shorter than `lo` times h(midpoint) into its projected midpoint, when
/// the link condition holds (the engine's check), no new triangle folds or falls below quality
/// `min_q`, and no new edge passes `hi` times h. Returns the number of collapses.
#[allow(clippy::too_many_arguments)]
pub fn collapse_short(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    lo: f64,
    hi: f64,
    min_q: f64,
    tol: f64,
) -> Result<usize, Error> {
    let mut n = 0;
    for e in edge_list(m) {
        let Some(h) = edge_now(m, e) else { continue };
        let (a, b) = (e.1, e.2);
        let (pa, pb) = (m.pos(a), m.pos(b));
        let mid = 0.5 * (pa + pb);
        let hm = size.at(mid);
        if pa.distance(pb) >= lo * hm || m.num_vertices() <= 4 {
            continue;
        }
        let p = project(phi, mid, tol)?;
        let (tris, ring) = collapse_ring(m, h, p);
        let hp = size.at(p);
        if ring.iter().any(|&r| r.distance(p) > hi * hp) {
            continue;
        }
        if tris.iter().any(|t| triangle_q3(*t) < min_q || !faces_out(phi, t[0], t[1], t[2], FOLD_COS)) {
            continue;
        }
        if m.collapse(h, p).is_ok() {
            n += 1;
        }
    }
    Ok(n)
}

/// Moves every vertex toward the average of its neighbours by `lambda`, in the tangent plane
/// only, then projects it; a move that would fold a triangle is skipped.
pub fn smooth_tangential(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, lambda: f64, tol: f64) -> Result<(), Error> {
    // Targets and their projections depend on the positions before the pass only: computed in
    // parallel, then applied in arena order.
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    let mesh = &*m;
    let moves: Vec<(DVec3, DVec3)> = ids
        .par_iter()
        .map(|&v| {
            let p = mesh.pos(v);
            let nb = mesh.neighbours(v);
            let c = nb.iter().map(|&w| mesh.pos(w)).sum::<DVec3>() / nb.len().max(1) as f64;
            let n = super::geom::normal(phi, p);
            let d = c - p;
            project_grad(phi, p + lambda * (d - d.dot(n) * n), tol)
        })
        .collect::<Result<_, Error>>()?;
    for (&v, &(p, g)) in ids.iter().zip(&moves) {
        move_if_no_fold_g(m, v, p, g);
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
    if !(g.length_squared() > 0.0) {
        return false;
    }
    let start = m.vertex(v).out;
    let mut x = start;
    loop {
        if m.face_of(x).is_some() {
            let y = m.next(x);
            let (b, c) = (m.pos(m.origin(y)), m.pos(m.dest(y)));
            let n = (b - p).cross(c - p);
            if !(n.dot(g) > 0.0) {
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

/// The same surface rebuilt with its vertices in Hilbert-curve order and its faces by their
/// first vertex there, so that neighbours sit near each other in the arenas. Meshes grown by
/// splits and subdivision scatter them, and every sweep then waits on cache misses.
pub fn relayout(m: &TriMesh<DVec3>) -> Result<TriMesh<DVec3>, Error> {
    let (points, tris, _, _) = m.to_arrays();
    let order = crate::topology::hilbert_sort_3d(&points);
    let mut rank = vec![0usize; points.len()];
    for (r, &i) in order.iter().enumerate() {
        rank[i] = r;
    }
    let pts: Vec<DVec3> = order.iter().map(|&i| points[i]).collect();
    let mut faces: Vec<[usize; 3]> = tris.iter().map(|t| [rank[t[0]], rank[t[1]], rank[t[2]]]).collect();
    faces.sort_by_key(|t| (t[0].min(t[1]).min(t[2]), t[0], t[1], t[2]));
    let (out, _) = TriMesh::from_arrays(&pts, &faces)
        .map_err(|e| Error::Internal(format!("rebuilding a valid surface mesh failed: {e}")))?;
    Ok(out)
}

/// Regular 1-to-4 subdivision: every edge split at its projected midpoint, then every edge
/// from a new vertex to an old vertex that is not its parent flipped. New vertices get valence
/// 6, so the irregular vertices of the coarse mesh are all the fine mesh has.
pub fn subdivide(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, tol: f64) -> Result<usize, Error> {
    let mut old: SecondaryMap<VertexId, ()> = SecondaryMap::new();
    for v in m.vertex_ids() {
        old.insert(v, ());
    }
    let mut parent: SecondaryMap<VertexId, (VertexId, VertexId)> = SecondaryMap::new();
    let mut n = 0;
    for e in edge_list(m) {
        let Some(h) = edge_now(m, e) else { continue };
        let (a, b) = (e.1, e.2);
        let p = project(phi, 0.5 * (m.pos(a) + m.pos(b)), tol)?;
        if let Ok(v) = m.split_edge(h, p) {
            parent.insert(v, (a, b));
            n += 1;
        }
    }
    for e in edge_list(m) {
        let (a, b) = (e.1, e.2);
        let (new, o) = if parent.contains_key(a) && old.contains_key(b) {
            (a, b)
        } else if parent.contains_key(b) && old.contains_key(a) {
            (b, a)
        } else {
            continue;
        };
        let (p0, p1) = parent[new];
        if o == p0 || o == p1 {
            continue;
        }
        if let Some(h) = edge_now(m, e) {
            // A refused flip leaves a valence defect, never an invalid mesh.
            let _ = m.flip(h);
        }
    }
    Ok(n)
}

/// Number of connected components (by shared vertices) of a triangle list over `n` points.
pub fn components(n: usize, tris: &[[usize; 3]]) -> usize {
    let mut sets = crate::topology::DisjointSets::new(n);
    for t in tris {
        sets.join(t[0], t[1]);
        sets.join(t[0], t[2]);
    }
    (0..n).filter(|&i| sets.root(i) == i).count()
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
        if move_if_no_fold_g(m, v, target, g) {
            largest = largest.max(target.distance(p) / h);
        }
    }
    Ok(largest)
}
