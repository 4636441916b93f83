//! Rational Bézier surface patches meshed directly in space (seed section 3.6.2, eq. 3.28 to
//! 3.34). Meshing the parameter plane and mapping it distorts the triangles wherever the
//! parametrisation does; instead every node keeps its (u, v), moves in space under the truss
//! forces and is projected back onto the patch: interior nodes by damped Newton on
//! min |r(u,v) - p|^2 (eq. 3.29), trim-curve nodes by the two-step constrained projection (eq.
//! 3.31 and 3.32). Patch sides are placed by arc length at the target size and kept, so patches
//! that share a side get the same nodes there (beyond the seed).
//!
//! The pipeline of one patch, by stage: the start (`start.rs`: side nodes by arc length, an
//! interior grid spaced by arc length, a Delaunay triangulation in (u, v) cut to the trim),
//! then force steps (`equilibrium.rs`) with quality flips in space (`improve.rs`) after every
//! step and density control (`density.rs`) every few steps, retriangulating when the node set
//! changes. [`mesh_patches`] meshes several patches and welds them along their shared sides;
//! [`BezierQuality`] measures the result.

mod density;
mod equilibrium;
mod improve;
mod options;
mod report;
mod start;

pub use options::BezierOptions;
pub use report::BezierQuality;

use crate::Error;
use glam::{DVec2, DVec3};
use std::collections::HashMap;
use std::sync::Arc;

/// A trim function phi(u, v): the patch keeps phi <= 0.
pub type TrimFn = Arc<dyn Fn(f64, f64) -> f64 + Send + Sync>;

/// A tensor-product rational Bézier patch r(u, v), (u, v) in [0, 1]^2 (seed eq. 3.33, 3.34).
/// `control[i + (m + 1) j]` is the point of Bernstein index i in u (degree m) and j in v.
#[derive(Clone)]
pub struct RationalBezierPatch {
    /// Degrees (m, n) in u and v.
    pub degree: (usize, usize),
    /// (m + 1)(n + 1) control points, u fastest.
    pub control: Vec<DVec3>,
    /// One positive weight per control point.
    pub weights: Vec<f64>,
    /// Optional trim: the patch is the part of the unit square where trim(u, v) <= 0.
    pub trim: Option<TrimFn>,
}

impl std::fmt::Debug for RationalBezierPatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RationalBezierPatch")
            .field("degree", &self.degree)
            .field("control", &self.control)
            .field("weights", &self.weights)
            .field("trimmed", &self.trim.is_some())
            .finish()
    }
}

/// r and its first and second partial derivatives at one (u, v).
#[derive(Clone, Copy, Debug)]
pub struct PatchPoint {
    /// r(u, v).
    pub r: DVec3,
    /// dr/du.
    pub ru: DVec3,
    /// dr/dv.
    pub rv: DVec3,
    /// d2r/du2.
    pub ruu: DVec3,
    /// d2r/dudv.
    pub ruv: DVec3,
    /// d2r/dv2.
    pub rvv: DVec3,
}

/// Bernstein polynomials of degree `m` at `t` with first and second derivatives.
fn bernstein(m: usize, t: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    // Values of every degree up to m by the de Casteljau-like recursion; the derivatives of
    // degree m come from the degree m-1 and m-2 values.
    let mut levels: Vec<Vec<f64>> = vec![vec![1.0]];
    for k in 1..=m {
        let prev = &levels[k - 1];
        let mut b = vec![0.0; k + 1];
        for i in 0..=k {
            let left = if i > 0 { prev[i - 1] * t } else { 0.0 };
            let right = if i < k { prev[i] * (1.0 - t) } else { 0.0 };
            b[i] = left + right;
        }
        levels.push(b);
    }
    let get = |k: usize, i: isize| -> f64 {
        if i < 0 || i as usize > k {
            0.0
        } else {
            levels[k][i as usize]
        }
    };
    let mut d1 = vec![0.0; m + 1];
    let mut d2 = vec![0.0; m + 1];
    for i in 0..=m {
        let ii = i as isize;
        if m >= 1 {
            d1[i] = m as f64 * (get(m - 1, ii - 1) - get(m - 1, ii));
        }
        if m >= 2 {
            d2[i] = (m * (m - 1)) as f64 * (get(m - 2, ii - 2) - 2.0 * get(m - 2, ii - 1) + get(m - 2, ii));
        }
    }
    (levels[m].clone(), d1, d2)
}

impl RationalBezierPatch {
    /// A patch with checked input: counts match the degrees, weights positive and finite,
    /// control points finite.
    pub fn new(degree: (usize, usize), control: Vec<DVec3>, weights: Vec<f64>) -> Result<Self, Error> {
        let p = RationalBezierPatch { degree, control, weights, trim: None };
        p.check()?;
        Ok(p)
    }
    /// The same patch trimmed to trim(u, v) <= 0.
    pub fn with_trim(mut self, trim: TrimFn) -> Self {
        self.trim = Some(trim);
        self
    }

    /// Checks the counts, weights and points.
    pub fn check(&self) -> Result<(), Error> {
        let (m, n) = self.degree;
        if m == 0 || n == 0 || m > 32 || n > 32 {
            return Err(Error::Invalid(format!("patch degrees ({m}, {n}) must be between 1 and 32")));
        }
        let want = (m + 1) * (n + 1);
        if self.control.len() != want {
            return Err(Error::Invalid(format!(
                "a degree ({m}, {n}) patch needs {want} control points, got {}",
                self.control.len()
            )));
        }
        if self.weights.len() != want {
            return Err(Error::Invalid(format!(
                "a degree ({m}, {n}) patch needs {want} weights, got {}",
                self.weights.len()
            )));
        }
        for c in &self.control {
            for x in c.to_array() {
                if !x.is_finite() {
                    return Err(Error::BadCoordinate { what: "Bézier control point", value: x });
                }
            }
        }
        for &w in &self.weights {
            if !(w > 0.0 && w.is_finite()) {
                return Err(Error::Invalid(format!("Bézier weight {w} must be positive and finite")));
            }
        }
        Ok(())
    }

    /// r(u, v) with first and second derivatives: the homogeneous sums of eq. 3.33 and 3.34,
    /// then the quotient rule.
    pub fn eval(&self, u: f64, v: f64) -> PatchPoint {
        let (m, n) = self.degree;
        let (bu, du, ddu) = bernstein(m, u);
        let (bv, dv, ddv) = bernstein(n, v);
        let (mut p, mut pu, mut pv, mut puu, mut puv, mut pvv) =
            (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
        let (mut w, mut wu, mut wv, mut wuu, mut wuv, mut wvv) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for j in 0..=n {
            for i in 0..=m {
                let k = i + (m + 1) * j;
                let wk = self.weights[k];
                let c = self.control[k] * wk;
                let terms =
                    [bu[i] * bv[j], du[i] * bv[j], bu[i] * dv[j], ddu[i] * bv[j], du[i] * dv[j], bu[i] * ddv[j]];
                p += terms[0] * c;
                pu += terms[1] * c;
                pv += terms[2] * c;
                puu += terms[3] * c;
                puv += terms[4] * c;
                pvv += terms[5] * c;
                w += terms[0] * wk;
                wu += terms[1] * wk;
                wv += terms[2] * wk;
                wuu += terms[3] * wk;
                wuv += terms[4] * wk;
                wvv += terms[5] * wk;
            }
        }
        let r = p / w;
        let ru = (pu - wu * r) / w;
        let rv = (pv - wv * r) / w;
        let ruu = (puu - 2.0 * wu * ru - wuu * r) / w;
        let rvv = (pvv - 2.0 * wv * rv - wvv * r) / w;
        let ruv = (puv - wu * rv - wv * ru - wuv * r) / w;
        PatchPoint { r, ru, rv, ruu, ruv, rvv }
    }

    /// r(u, v).
    pub fn point(&self, uv: DVec2) -> DVec3 {
        self.eval(uv.x, uv.y).r
    }

    fn trim_value(&self, uv: DVec2) -> f64 {
        match &self.trim {
            Some(t) => t(uv.x, uv.y),
            None => -1.0,
        }
    }
    fn trim_grad(&self, uv: DVec2) -> DVec2 {
        let e = 1e-7;
        DVec2::new(
            (self.trim_value(uv + DVec2::X * e) - self.trim_value(uv - DVec2::X * e)) / (2.0 * e),
            (self.trim_value(uv + DVec2::Y * e) - self.trim_value(uv - DVec2::Y * e)) / (2.0 * e),
        )
    }

    /// The (u, v) of the point of the patch nearest `p`, from `start`: damped Newton on
    /// f = |r(u,v) - p|^2 / 2 (seed eq. 3.29) with the full Hessian J^T J + (r - p) . r_ab,
    /// falling back to Gauss-Newton where that is not positive definite; (u, v) stay in the
    /// unit square. `fix` = Some((axis, value)) keeps one parameter (the constrained projection
    /// onto a patch side, eq. 3.30).
    pub fn project(&self, p: DVec3, start: DVec2, fix: Option<(usize, f64)>) -> DVec2 {
        let mut uv = start.clamp(DVec2::ZERO, DVec2::ONE);
        if let Some((a, val)) = fix {
            uv[a] = val;
        }
        let f = |uv: DVec2| (self.point(uv) - p).length_squared();
        let mut fx = f(uv);
        for _ in 0..50 {
            let e = self.eval(uv.x, uv.y);
            let d = e.r - p;
            let g = DVec2::new(e.ru.dot(d), e.rv.dot(d));
            let (huu, huv, hvv) =
                (e.ru.dot(e.ru) + d.dot(e.ruu), e.ru.dot(e.rv) + d.dot(e.ruv), e.rv.dot(e.rv) + d.dot(e.rvv));
            let (guu, guv, gvv) = (e.ru.dot(e.ru), e.ru.dot(e.rv), e.rv.dot(e.rv));
            let solve = |a: f64, b: f64, c: f64| -> Option<DVec2> {
                match fix {
                    Some((0, _)) => (c > 0.0).then(|| DVec2::new(0.0, -g.y / c)),
                    Some(_) => (a > 0.0).then(|| DVec2::new(-g.x / a, 0.0)),
                    None => {
                        let det = a * c - b * b;
                        (a > 0.0 && det > 0.0)
                            .then(|| DVec2::new(-(c * g.x - b * g.y) / det, -(a * g.y - b * g.x) / det))
                    }
                }
            };
            let Some(step) = solve(huu, huv, hvv).or_else(|| solve(guu, guv, gvv)) else { break };
            let mut t = 1.0;
            let mut moved = false;
            for _ in 0..30 {
                let cand = (uv + t * step).clamp(DVec2::ZERO, DVec2::ONE);
                let fc = f(cand);
                if fc <= fx {
                    moved = cand != uv;
                    uv = cand;
                    fx = fc;
                    break;
                }
                t *= 0.5;
            }
            if !moved || (t * step).length() < 1e-15 {
                break;
            }
        }
        uv
    }

    /// (u, v) moved onto the trim curve trim = 0 by steps along its gradient in the parameter
    /// plane (the second step of eq. 3.31, 3.32); a parameter fixed by `fix` stays.
    fn to_trim_curve(&self, mut uv: DVec2, fix: Option<(usize, f64)>) -> DVec2 {
        for _ in 0..50 {
            let t = self.trim_value(uv);
            let mut g = self.trim_grad(uv);
            if let Some((a, _)) = fix {
                g[a] = 0.0;
            }
            let g2 = g.length_squared();
            if t.abs() < 1e-14 || g2 == 0.0 || !t.is_finite() {
                break;
            }
            uv = (uv - t / g2 * g).clamp(DVec2::ZERO, DVec2::ONE);
        }
        uv
    }
}

/// How a node may move.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Interior,
    /// On the trim curve: slides along it (eq. 3.31, 3.32).
    Trim,
    /// A side node (kept where arc length put it) or a trim-curve end on a side.
    Fixed,
}

/// One patch's mesh: points in space, their (u, v), counter-clockwise triangles in (u, v).
#[derive(Clone, Debug, Default)]
pub struct PatchMesh {
    /// Node positions r(u, v).
    pub points: Vec<DVec3>,
    /// Node parameters.
    pub uv: Vec<DVec2>,
    /// Triangles (counter-clockwise in the parameter plane).
    pub triangles: Vec<[usize; 3]>,
}

/// A mesh of several patches: the welded points, triangles, and per patch its node indices.
#[derive(Clone, Debug, Default)]
pub struct PatchesMesh {
    /// Welded points.
    pub points: Vec<DVec3>,
    /// Triangles, oriented consistently across shared sides (the first patch's orientation).
    pub triangles: Vec<[usize; 3]>,
    /// The patches' own meshes before welding.
    pub patches: Vec<PatchMesh>,
}

/// Every undirected edge (small index first) with the triangles on it.
pub(super) fn edge_map(tris: &[[usize; 3]]) -> HashMap<(usize, usize), Vec<usize>> {
    let mut m: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for (k, t) in tris.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            m.entry((a.min(b), a.max(b))).or_default().push(k);
        }
    }
    m
}

/// Sorted edge list (deterministic iteration).
pub(super) fn edges_sorted(tris: &[[usize; 3]]) -> Vec<((usize, usize), Vec<usize>)> {
    let mut v: Vec<_> = edge_map(tris).into_iter().collect();
    v.sort_unstable_by_key(|e| e.0);
    v
}

/// Exact orientation in the parameter plane: a regular patch keeps a triangle unfolded in
/// space exactly when it keeps it counter-clockwise in (u, v).
pub(super) fn ccw(a: DVec2, b: DVec2, c: DVec2) -> bool {
    crate::predicates::orient2d(a, b, c) == crate::predicates::Sign::Positive
}

/// Density control runs every this many force iterations (not in the last stretch).
const DENSITY_EVERY: usize = 20;
/// Largest node count [`mesh_patches`] accepts (estimated from the control polygon's box).
const MAX_NODES: f64 = 4e6;

/// Meshes one patch with the given side nodes (parameters along each of the 4 sides, each
/// from 0 to 1). Side nodes stay where they are.
pub fn mesh_patch_with_sides(
    p: &RationalBezierPatch,
    sides: &[Vec<f64>; 4],
    opts: &BezierOptions,
) -> Result<PatchMesh, Error> {
    p.check()?;
    if !(opts.h0 > 0.0 && opts.h0.is_finite()) {
        return Err(Error::BadSize(format!("h0 = {} must be positive and finite", opts.h0)));
    }
    let ok = |v: f64| v > 0.0 && v.is_finite();
    if !(ok(opts.fscale) && ok(opts.deltat)) {
        return Err(Error::Invalid(format!(
            "fscale {} and deltat {} must be positive and finite",
            opts.fscale, opts.deltat
        )));
    }
    // Estimated node count: refuse before allocating.
    let est = (start::side_params_len(sides) as f64 / 4.0).powi(2);
    if est > 4e6 {
        return Err(Error::TooManyElements { estimated: (2.0 * est) as u64, limit: 8_000_000 });
    }
    let (mut uv, mut kind) = start::start_nodes(p, sides, opts);
    let mut tris = start::triangulate(p, &mut uv, &mut kind)?;
    let pos_of = |uv: DVec2| if opts.in_space { p.point(uv) } else { DVec3::new(uv.x, uv.y, 0.0) };
    let h = if opts.in_space { opts.h0 } else { 1.0 / ((sides[0].len() + sides[2].len()) as f64 / 2.0 - 1.0).max(1.0) };
    let mut pts: Vec<DVec3> = uv.iter().map(|&q| pos_of(q)).collect();
    improve::flip_pass(&pts, &uv, &mut tris);
    for it in 1..=opts.max_iter {
        let (moved, rebuild) = equilibrium::force_step(p, &mut pts, &mut uv, &mut kind, &tris, h, opts, &pos_of);
        if rebuild {
            tris = start::triangulate(p, &mut uv, &mut kind)?;
            pts = uv.iter().map(|&q| pos_of(q)).collect();
        }
        improve::flip_pass(&pts, &uv, &mut tris);
        let late = it + DENSITY_EVERY > opts.max_iter;
        if it % DENSITY_EVERY == 0
            && !late
            && density::density(p, &mut pts, &mut uv, &mut kind, &tris, h, opts, &pos_of)
        {
            tris = start::triangulate(p, &mut uv, &mut kind)?;
            improve::flip_pass(&pts, &uv, &mut tris);
            continue;
        }
        if moved < 1e-4 && it > DENSITY_EVERY && it % DENSITY_EVERY != 1 {
            break;
        }
    }
    let points = uv.iter().map(|&q| p.point(q)).collect();
    Ok(PatchMesh { points, uv, triangles: tris })
}

/// Meshes several patches at size `opts.h0`; sides that two patches share (same control
/// points and weights, either direction) get one set of nodes, computed once from the first
/// patch, so the union is conforming there.
pub fn mesh_patches(patches: &[RationalBezierPatch], opts: &BezierOptions) -> Result<PatchesMesh, Error> {
    if patches.is_empty() {
        return Err(Error::Invalid("no Bézier patch given".into()));
    }
    for p in patches {
        p.check()?;
    }
    if !(opts.h0 > 0.0 && opts.h0.is_finite()) {
        return Err(Error::BadSize(format!("h0 = {} must be positive and finite", opts.h0)));
    }
    // Refuse a size far below the patches before any allocation: the control polygon bounds
    // the patch (convex hull property), its diagonal bounds every side's length.
    let mut est = 0.0;
    for p in patches {
        let (lo, hi) =
            p.control.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), c| {
                (lo.min(*c), hi.max(*c))
            });
        let d = (hi - lo).length();
        est += (d / opts.h0 + 1.0).powi(2);
    }
    if est > MAX_NODES {
        return Err(Error::TooManyElements { estimated: est.min(u64::MAX as f64) as u64, limit: 2 * MAX_NODES as u64 });
    }
    let start::SidePlan { sides, shared, reversed } = start::plan_sides(patches, opts.h0);
    let mut out = PatchesMesh::default();
    // Global index of each side node, per patch and side, in the order of the side parameters.
    let mut side_global: Vec<[Vec<usize>; 4]> = Vec::new();
    for (k, p) in patches.iter().enumerate() {
        let pm = mesh_patch_with_sides(p, &sides[k], opts)?;
        let mut mine: [Vec<usize>; 4] = Default::default();
        for s in 0..4 {
            mine[s] = vec![usize::MAX; sides[k][s].len()];
        }
        let mut map = Vec::with_capacity(pm.points.len());
        let mut pm = pm;
        for i in 0..pm.points.len() {
            let uv = pm.uv[i];
            let on: Vec<(usize, usize)> = (0..4)
                .filter_map(|s| sides[k][s].iter().position(|&t| start::side_uv(s, t) == uv).map(|pos| (s, pos)))
                .collect();
            // A node on a shared side is the first patch's node: same index, same bits.
            let mut g = None;
            for &(s, pos) in &on {
                if let Some((j, t, rev)) = shared[k][s] {
                    let n = side_global[j][t].len();
                    let other = side_global[j][t][if rev { n - 1 - pos } else { pos }];
                    if other != usize::MAX {
                        g = Some(other);
                    }
                }
            }
            let g = match g {
                Some(g) => {
                    pm.points[i] = out.points[g];
                    g
                }
                None => {
                    out.points.push(pm.points[i]);
                    out.points.len() - 1
                }
            };
            for &(s, pos) in &on {
                mine[s][pos] = g;
            }
            map.push(g);
        }
        side_global.push(mine);
        let flip = reversed[k];
        out.triangles.extend(pm.triangles.iter().map(|t| {
            let g = t.map(|i| map[i]);
            if flip {
                [g[0], g[2], g[1]]
            } else {
                g
            }
        }));
        out.patches.push(pm);
    }
    Ok(out)
}
