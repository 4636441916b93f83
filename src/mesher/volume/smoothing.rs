//! Vertex smoothing: optimisation-based moves for the worst tet of a star, uphill moves on a
//! star's summed radius ratio, and independent classes of vertices so that moves run in parallel.

use super::features::on_sharp_feature;
use super::snapshot::Snapshot;
use super::{Ctx, RR_SLACK, RR_TQ_FLOOR};
use crate::quality::{
    dihedral_quality_cos_bounds, tet_dihedral_cos_extremes, tet_dihedral_quality, tet_dihedral_quality_below,
    REGULAR_DIHEDRAL,
};
use crate::topology::{TVertexId, TetMesh, VertexTag};
use crate::Error;
use glam::DVec3;
use rayon::prelude::*;
use slotmap::SecondaryMap;
use smallvec::SmallVec;

/// Gradient steps per vertex in the mean-quality smoothing. Four: ten gave the same mean
/// radius ratio to 1e-4 on both quality examples and at h0 = 0.05, at 1.5x the cost.
const RR_SMOOTH_STEPS: usize = 4;
/// Whether boundary vertices take part in the mean-quality smoothing.
const RR_SMOOTH_BOUNDARY: bool = true;

/// The star of `v` as point quadruples with `v`'s slot marked, for moving `v` around.
pub(super) fn star_of(m: &TetMesh, v: TVertexId) -> Vec<([DVec3; 4], usize)> {
    m.vertex_tets(v)
        .iter()
        .map(|&t| {
            let k = m.local_index(t, v).expect("star");
            (m.tet_points(t), k)
        })
        .collect()
}

/// The worst [`tet_dihedral_quality`] of the star with its vertex at `x`, and that tet's place
/// in the star. Both terms of tq are monotone in one extreme cosine, so the star's worst is tq
/// of the star's extreme cosines: two acos per call instead of two per tet.
pub(super) fn star_min(star: &[([DVec3; 4], usize)], x: DVec3) -> (f64, usize) {
    let (mut cmax, mut imax, mut cmin, mut imin) = (f64::NEG_INFINITY, 0, f64::INFINITY, 0);
    for (n, (p, k)) in star.iter().enumerate() {
        let mut p = *p;
        p[*k] = x;
        let Some((a, b)) = tet_dihedral_cos_extremes(p) else { return (-1.0, n) };
        if a > cmax {
            (cmax, imax) = (a, n);
        }
        if b < cmin {
            (cmin, imin) = (b, n);
        }
    }
    if star.is_empty() {
        return (f64::INFINITY, 0);
    }
    let lo = cmax.clamp(-1.0, 1.0).acos().to_degrees() / REGULAR_DIHEDRAL;
    let hi = (180.0 - cmin.clamp(-1.0, 1.0).acos().to_degrees()) / (180.0 - REGULAR_DIHEDRAL);
    match lo.total_cmp(&hi) {
        std::cmp::Ordering::Less => (lo, imax),
        std::cmp::Ordering::Greater => (hi, imin),
        std::cmp::Ordering::Equal => (lo, imax.min(imin)),
    }
}

/// Optimisation-based smoothing: moves `v` uphill on the quality of the worst tet of its star
/// (finite-difference gradient, halving line search) while the star's worst tq improves.
/// Boundary vertices move in the tangent plane and are projected back onto d = 0.
pub(super) fn smooth_vertex(ctx: &mut Ctx, m: &mut TetMesh, v: TVertexId) -> Result<bool, Error> {
    if let Some(x) = smooth_target(ctx, m, v)? {
        if m.relocate(v, x).is_ok() {
            ctx.report.ops.smoothings += 1;
            return Ok(true);
        }
    }
    Ok(false)
}

/// Where [`smooth_vertex`] would move `v`, if anywhere (read-only).
pub(super) fn smooth_target(ctx: &Ctx, m: &TetMesh, v: TVertexId) -> Result<Option<DVec3>, Error> {
    if !m.contains_vertex(v) || m.tag(v) == VertexTag::Fixed {
        return Ok(None);
    }
    let boundary = m.tag(v) == VertexTag::Boundary;
    let star = star_of(m, v);
    let x0 = m.pos(v);
    let nb = m.vertex_neighbours(v);
    let len = nb.iter().map(|&w| m.pos(w).distance(x0)).sum::<f64>() / nb.len().max(1) as f64;
    let (f0, _) = star_min(&star, x0);
    let (mut x, mut fx) = (x0, f0);
    for _ in 0..20 {
        let (_, w) = star_min(&star, x);
        let (p, k) = star[w];
        let eps = 1e-6 * len;
        let mut g = DVec3::ZERO;
        for axis in 0..3 {
            let mut e = DVec3::ZERO;
            e[axis] = eps;
            let (mut pp, mut pm) = (p, p);
            pp[k] = x + e;
            pm[k] = x - e;
            g[axis] = (tet_dihedral_quality(pp) - tet_dihedral_quality(pm)) / (2.0 * eps);
        }
        let mut step = 0.1 * len;
        let better = |y: DVec3| Some(star_min(&star, y).0).filter(|&fy| fy > fx + 1e-9);
        match ascend(ctx, x, g, boundary, &mut step, 8, better)? {
            Some((y, fy)) => (x, fx) = (y, fy),
            None => break,
        }
    }
    Ok((fx > f0 + 1e-9 && star_rr(&star, x) > star_rr(&star, x0) - RR_SLACK).then_some(x))
}

/// Mean radius ratio of the star with `v` at `x`: a move for the worst tet may not cost the
/// others more than RR_SLACK of it.
pub(super) fn star_rr(star: &[([DVec3; 4], usize)], x: DVec3) -> f64 {
    star_rr_sum(star, x) / star.len().max(1) as f64
}

/// Summed radius ratio of the star with its vertex at `x`.
pub(super) fn star_rr_sum(star: &[([DVec3; 4], usize)], x: DVec3) -> f64 {
    star.iter()
        .map(|(p, k)| {
            let mut p = *p;
            p[*k] = x;
            crate::quality::tet_radius_ratio(p)
        })
        .sum()
}

/// The summed radius ratio of a star as a function of its vertex x, with what does not depend
/// on x computed once: the mean-quality smoothing evaluates it about 25 times per vertex.
/// Per tet (x, q0, q1, q2), with a = q1 - q0, b = q2 - q0, c = x - q0 and n = a x b:
/// 6V = |n . c|, twice the area is |n| + |b x c| + |c x a| + |b x c + n + c x a|, the
/// circumcentre is q0 + (|a|^2 b x c + |b|^2 c x a + |c|^2 n) / (12 V), and
/// 3 r_in / r_out = 6 (6V)^2 / (2 area |12 V (circumcentre - q0)|).
pub(super) struct StarRr {
    parts: SmallVec<[RrTerm; 32]>,
}

/// One tet of a [`StarRr`]: q0, a, b, n = a x b, |a|^2, |b|^2 and |n|.
#[derive(Clone, Copy)]
struct RrTerm {
    q0: DVec3,
    a: DVec3,
    b: DVec3,
    n: DVec3,
    aa: f64,
    bb: f64,
    nn: f64,
}

impl StarRr {
    pub(super) fn new(star: &[([DVec3; 4], usize)]) -> Self {
        let parts = star
            .iter()
            .map(|(p, k)| {
                let [q0, q1, q2] = [(k + 1) % 4, (k + 2) % 4, (k + 3) % 4].map(|i| p[i]);
                let (a, b) = (q1 - q0, q2 - q0);
                let n = a.cross(b);
                RrTerm { q0, a, b, n, aa: a.length_squared(), bb: b.length_squared(), nn: n.length() }
            })
            .collect();
        StarRr { parts }
    }

    pub(super) fn sum(&self, x: DVec3) -> f64 {
        self.parts
            .iter()
            .map(|t| {
                let c = x - t.q0;
                let v6 = t.n.dot(c).abs();
                if v6 == 0.0 {
                    return 0.0;
                }
                let (bc, ca) = (t.b.cross(c), c.cross(t.a));
                let area2 = t.nn + bc.length() + ca.length() + (bc + t.n + ca).length();
                let num = t.aa * bc + t.bb * ca + c.length_squared() * t.n;
                (6.0 * v6 * v6 / (area2 * num.length())).clamp(0.0, 1.0)
            })
            .sum()
    }
}

/// One line search of the smoothing ascents: from `x` along the gradient `g` (in the tangent
/// plane of d = 0 for boundary vertices, which are projected back), halving `step` up to
/// `tries` times until `better` returns the new objective value. `None`: no better point.
fn ascend(
    ctx: &Ctx,
    x: DVec3,
    mut g: DVec3,
    boundary: bool,
    step: &mut f64,
    tries: usize,
    better: impl Fn(DVec3) -> Option<f64>,
) -> Result<Option<(DVec3, f64)>, Error> {
    if boundary {
        let nrm = ctx.domain.gradient(x).normalize_or_zero();
        g -= nrm * g.dot(nrm);
    }
    if g.length() <= 0.0 || !g.is_finite() {
        return Ok(None);
    }
    let dir = g.normalize();
    for _ in 0..tries {
        let mut y = x + dir * *step;
        if boundary {
            match ctx.project(y)? {
                Some(q) => y = q,
                None => {
                    *step *= 0.5;
                    continue;
                }
            }
        }
        if let Some(fy) = better(y) {
            return Ok(Some((y, fy)));
        }
        *step *= 0.5;
    }
    Ok(None)
}

/// Moves `v` uphill on the summed radius ratio of its star (finite-difference gradient,
/// halving line search), keeping the star's worst tq at least min(old, RR_TQ_FLOOR); boundary
/// vertices move in the tangent plane and are projected back onto d = 0.
pub(super) fn mean_smooth_target(ctx: &Ctx, m: &TetMesh, v: TVertexId) -> Result<Option<DVec3>, Error> {
    if !m.contains_vertex(v) || m.tag(v) == VertexTag::Fixed {
        return Ok(None);
    }
    let boundary = m.tag(v) == VertexTag::Boundary;
    if boundary && !RR_SMOOTH_BOUNDARY {
        return Ok(None);
    }
    if boundary && on_sharp_feature(ctx, m, v) {
        return Ok(None);
    }
    let star = star_of(m, v);
    let x0 = m.pos(v);
    let nb = m.vertex_neighbours(v);
    let len = nb.iter().map(|&w| m.pos(w).distance(x0)).sum::<f64>() / nb.len().max(1) as f64;
    let rr = StarRr::new(&star);
    let sum_at = |x: DVec3| rr.sum(x);
    let (t0, _) = star_min(&star, x0);
    // The floor as cosine bounds: no acos per tet per trial point.
    let (cos_lo, cos_hi) = dihedral_quality_cos_bounds(t0.min(RR_TQ_FLOOR));
    let above_floor = |y: DVec3| {
        star.iter().all(|(p, k)| {
            let mut p = *p;
            p[*k] = y;
            !tet_dihedral_quality_below(p, cos_lo, cos_hi)
        })
    };
    let f0 = sum_at(x0);
    let (mut x, mut fx) = (x0, f0);
    let mut step = 0.05 * len;
    for _ in 0..RR_SMOOTH_STEPS {
        // Forward differences: only an uphill direction is needed, and the line search
        // checks every step.
        let eps = 1e-6 * len;
        let mut g = DVec3::ZERO;
        for axis in 0..3 {
            let mut e = DVec3::ZERO;
            e[axis] = eps;
            g[axis] = (sum_at(x + e) - fx) / eps;
        }
        let better = |y: DVec3| Some(sum_at(y)).filter(|&fy| fy > fx + 1e-9 && above_floor(y));
        match ascend(ctx, x, g, boundary, &mut step, 6, better)? {
            Some((y, fy)) => {
                (x, fx) = (y, fy);
                step *= 1.5;
            }
            None => break,
        }
    }
    Ok((fx > f0 + 1e-7).then_some(x))
}

/// Classes of vertices (all, or those of `subset`) no two of which share an edge (greedy
/// colouring in arena or subset order), so that no vertex of a class lies in the star of
/// another: their moves are independent.
fn independent_classes(m: &TetMesh, subset: Option<&[TVertexId]>) -> Vec<Vec<TVertexId>> {
    if let Some(verts) = subset {
        // Colours within the subset only; neighbours found in parallel.
        let nbs: Vec<SmallVec<[TVertexId; 32]>> = verts.par_iter().map(|&v| m.vertex_neighbours(v)).collect();
        let mut colour: SecondaryMap<TVertexId, u16> = SecondaryMap::with_capacity(verts.len());
        let mut classes: Vec<Vec<TVertexId>> = Vec::new();
        let mut used: SmallVec<[u16; 64]> = SmallVec::new();
        for (&v, nb) in verts.iter().zip(&nbs) {
            if colour.contains_key(v) {
                continue;
            }
            used.clear();
            used.extend(nb.iter().filter_map(|&w| colour.get(w).copied()));
            let c = (0..).find(|c| !used.contains(c)).expect("a free colour");
            colour.insert(v, c);
            if c as usize == classes.len() {
                classes.push(Vec::new());
            }
            classes[c as usize].push(v);
        }
        return classes;
    }
    let snap = Snapshot::build(m);
    let mut colour = vec![u16::MAX; snap.ids.len()];
    let mut classes: Vec<Vec<TVertexId>> = Vec::new();
    let mut used: SmallVec<[u16; 64]> = SmallVec::new();
    for i in 0..snap.ids.len() {
        used.clear();
        used.extend(snap.row(i).iter().map(|&j| colour[j as usize]).filter(|&c| c != u16::MAX));
        let c = (0..).find(|c| !used.contains(c)).expect("a free colour");
        colour[i] = c;
        if c as usize == classes.len() {
            classes.push(Vec::new());
        }
        classes[c as usize].push(snap.ids[i]);
    }
    classes
}

/// Moves every vertex to `target`'s point, class by class ([`independent_classes`]): a
/// class's targets are computed in parallel on the unchanged mesh, then applied in order
/// with the exact validity check. Deterministic; returns the moves made.
pub(super) fn coloured_smoothing(
    ctx: &mut Ctx,
    m: &mut TetMesh,
    subset: Option<&[TVertexId]>,
    target: impl Fn(&Ctx, &TetMesh, TVertexId) -> Result<Option<DVec3>, Error> + Sync,
) -> Result<usize, Error> {
    let mut moved = 0;
    for class in independent_classes(m, subset) {
        let targets: Vec<Option<DVec3>> = {
            let (c, mesh) = (&*ctx, &*m);
            class.par_iter().with_min_len(64).map(|&v| target(c, mesh, v)).collect::<Result<_, Error>>()?
        };
        for (&v, y) in class.iter().zip(targets) {
            if let Some(y) = y {
                if m.relocate(v, y).is_ok() {
                    moved += 1;
                }
            }
        }
    }
    ctx.report.ops.smoothings += moved;
    Ok(moved)
}
