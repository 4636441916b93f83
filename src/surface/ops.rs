//! Local operations in space: the engine's checked flip, split and collapse plus the surface
//! conditions the engine cannot know (no fold against grad phi, quality, valence).

use super::geom::{faces_out, project, SizeField};
use crate::geometry::Implicit3;
use crate::quality::triangle_q3;
use crate::topology::{HalfEdgeId, TriMesh, VertexId};
use crate::Error;
use glam::DVec3;

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

/// Every edge as its two end vertices, in arena order (a stable list to walk while the mesh
/// changes; an edge gone by the time it is reached is skipped).
pub fn edge_list(m: &TriMesh<DVec3>) -> Vec<(VertexId, VertexId)> {
    m.edge_ids().map(|h| (m.origin(h), m.dest(h))).collect()
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
/// must face outward (normal deviation below 60 degrees).
pub fn try_flip(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, h: HalfEdgeId, goal: FlipGoal) -> bool {
    let Ok(plan) = m.check_flip(h) else {
        return false;
    };
    let (a, b, c, d) = (plan.a, plan.b, plan.c, plan.d);
    let (pa, pb, pc, pd) = (m.pos(a), m.pos(b), m.pos(c), m.pos(d));
    let old = triangle_q3([pa, pb, pc]).min(triangle_q3([pb, pa, pd]));
    let new = triangle_q3([pc, pa, pd]).min(triangle_q3([pd, pb, pc]));
    let wanted = match goal {
        FlipGoal::Quality => new > old + 1e-9,
        FlipGoal::Valence => {
            let (va, vb, vc, vd) = (m.valence(a) as i64, m.valence(b) as i64, m.valence(c) as i64, m.valence(d) as i64);
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
    if !wanted || !faces_out(phi, pc, pa, pd, FOLD_COS) || !faces_out(phi, pd, pb, pc, FOLD_COS) {
        return false;
    }
    m.apply_flip(plan);
    true
}

/// Sweeps over all edges flipping toward `goal` until a sweep flips nothing (at most
/// `max_sweeps`). Returns the number of flips.
pub fn flip_pass(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, goal: FlipGoal, max_sweeps: usize) -> usize {
    let mut total = 0;
    for _ in 0..max_sweeps {
        let mut n = 0;
        for (a, b) in edge_list(m) {
            if let Some(h) = m.find_half_edge(a, b) {
                if try_flip(m, phi, h, goal) {
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
    for (a, b) in edge_list(m) {
        let Some(h) = m.find_half_edge(a, b) else { continue };
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
    for (a, b) in edge_list(m) {
        if !m.contains_vertex(a) || !m.contains_vertex(b) {
            continue;
        }
        let Some(h) = m.find_half_edge(a, b) else { continue };
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
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    let targets: Vec<DVec3> = ids
        .iter()
        .map(|&v| {
            let p = m.pos(v);
            let nb = m.neighbours(v);
            let c = nb.iter().map(|&w| m.pos(w)).sum::<DVec3>() / nb.len().max(1) as f64;
            let n = super::geom::normal(phi, p);
            let d = c - p;
            p + lambda * (d - d.dot(n) * n)
        })
        .collect();
    for (&v, &t) in ids.iter().zip(&targets) {
        let p = project(phi, t, tol)?;
        move_if_no_fold(m, phi, v, p);
    }
    Ok(())
}

/// Moves `v` to `p` unless a triangle around it would fold; returns whether it moved.
pub fn move_if_no_fold(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, v: VertexId, p: DVec3) -> bool {
    for x in m.outgoing(v) {
        if m.face_of(x).is_none() {
            continue;
        }
        let y = m.next(x);
        if !faces_out(phi, p, m.pos(m.origin(y)), m.pos(m.dest(y)), 0.0) {
            return false;
        }
    }
    m.set_pos_unchecked(v, p);
    true
}

/// Regular 1-to-4 subdivision: every edge split at its projected midpoint, then every edge
/// from a new vertex to an old vertex that is not its parent flipped. New vertices get valence
/// 6, so the irregular vertices of the coarse mesh are all the fine mesh has.
pub fn subdivide(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, tol: f64) -> Result<usize, Error> {
    use slotmap::SecondaryMap;
    let mut old: SecondaryMap<VertexId, ()> = SecondaryMap::new();
    for v in m.vertex_ids() {
        old.insert(v, ());
    }
    let mut parent: SecondaryMap<VertexId, (VertexId, VertexId)> = SecondaryMap::new();
    let mut n = 0;
    for (a, b) in edge_list(m) {
        let Some(h) = m.find_half_edge(a, b) else { continue };
        let p = project(phi, 0.5 * (m.pos(a) + m.pos(b)), tol)?;
        if let Ok(v) = m.split_edge(h, p) {
            parent.insert(v, (a, b));
            n += 1;
        }
    }
    for (a, b) in edge_list(m) {
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
        if let Some(h) = m.find_half_edge(a, b) {
            // A refused flip leaves a valence defect, never an invalid mesh.
            let _ = m.flip(h);
        }
    }
    Ok(n)
}

/// Number of connected components (by shared vertices) of a triangle list over `n` points.
pub fn components(n: usize, tris: &[[usize; 3]]) -> usize {
    let mut up: Vec<usize> = (0..n).collect();
    fn root(up: &mut [usize], mut i: usize) -> usize {
        while up[i] != i {
            up[i] = up[up[i]];
            i = up[i];
        }
        i
    }
    for t in tris {
        for k in 1..3 {
            let (x, y) = (root(&mut up, t[0]), root(&mut up, t[k]));
            if x != y {
                up[x.max(y)] = x.min(y);
            }
        }
    }
    (0..n).filter(|&i| root(&mut up, i) == i).count()
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
    let mut largest = 0.0f64;
    for v in ids {
        let p = m.pos(v);
        let n = super::geom::normal(phi, p);
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
        let target = project(phi, p + step, tol)?;
        if move_if_no_fold(m, phi, v, target) {
            largest = largest.max(target.distance(p) / h);
        }
    }
    Ok(largest)
}
