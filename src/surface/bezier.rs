//! Rational Bézier surface patches meshed directly in space (seed section 3.6.2, eq. 3.28 to
//! 3.34). Meshing the parameter plane and mapping it distorts the triangles wherever the
//! parametrisation does; instead every node keeps its (u, v), moves in space under the truss
//! forces and is projected back onto the patch: interior nodes by damped Newton on
//! min |r(u,v) - p|^2 (eq. 3.29), trim-curve nodes by the two-step constrained projection (eq.
//! 3.31 and 3.32). Patch sides are placed by arc length at the target size and kept, so patches
//! that share a side get the same nodes there (beyond the seed).

use crate::quality::{triangle_angles_deg, triangle_q3};
use crate::topology::TriMesh;
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

/// Options of [`mesh_patches`].
#[derive(Clone, Debug)]
pub struct BezierOptions {
    /// Target edge length in space.
    pub h0: f64,
    /// Force iterations.
    pub max_iterations: usize,
    /// Bars pushed toward Fscale h (seed eq. 2.6).
    pub fscale: f64,
    /// Forward Euler step.
    pub dt: f64,
    /// Mesh in space (true) or, for comparison, in the parameter plane with the same loop.
    pub in_space: bool,
}

impl BezierOptions {
    /// Target size `h0` in space, 300 iterations, Fscale 1.2, dt 0.2.
    pub fn new(h0: f64) -> Self {
        BezierOptions { h0, max_iterations: 300, fscale: 1.2, dt: 0.2, in_space: true }
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

/// Measured figures of a mesh in space, h the target size.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BezierQuality {
    /// Vertices.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
    /// Smallest angle, degrees.
    pub min_angle: f64,
    /// Smallest q.
    pub min_q: f64,
    /// Mean q.
    pub mean_q: f64,
    /// std / mean of edge length / h.
    pub size_deviation: f64,
    /// mean edge length / h.
    pub mean_size_ratio: f64,
}

impl BezierQuality {
    /// Measures a triangle list in space against the size `h`.
    pub fn measure(points: &[DVec3], tris: &[[usize; 3]], h: f64) -> BezierQuality {
        let (mut min_angle, mut min_q, mut sum_q) = (180.0f64, 1.0f64, 0.0);
        for t in tris {
            let [a, b, c] = t.map(|i| points[i]);
            min_q = min_q.min(triangle_q3([a, b, c]));
            sum_q += triangle_q3([a, b, c]);
            for ang in triangle_angles_deg(b.distance(c), c.distance(a), a.distance(b)) {
                min_angle = min_angle.min(ang);
            }
        }
        // Sorted edges: the sums, and so the figures, are the same bits every run.
        let r: Vec<f64> = edges_sorted(tris).iter().map(|&((a, b), _)| points[a].distance(points[b]) / h).collect();
        let n = r.len().max(1) as f64;
        let mean = r.iter().sum::<f64>() / n;
        let var = r.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
        BezierQuality {
            vertices: points.len(),
            triangles: tris.len(),
            min_angle,
            min_q,
            mean_q: sum_q / tris.len().max(1) as f64,
            size_deviation: var.sqrt() / mean,
            mean_size_ratio: mean,
        }
    }
}

/// Every undirected edge (small index first) with the triangles on it.
fn edge_map(tris: &[[usize; 3]]) -> HashMap<(usize, usize), Vec<usize>> {
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
fn edges_sorted(tris: &[[usize; 3]]) -> Vec<((usize, usize), Vec<usize>)> {
    let mut v: Vec<_> = edge_map(tris).into_iter().collect();
    v.sort_unstable_by_key(|e| e.0);
    v
}

/// Side s of the unit square: 0 v = 0, 1 u = 1, 2 v = 1, 3 u = 0. Returns (fixed axis, value).
fn side_fix(s: usize) -> (usize, f64) {
    match s {
        0 => (1, 0.0),
        1 => (0, 1.0),
        2 => (1, 1.0),
        _ => (0, 0.0),
    }
}

/// The point of side s at parameter t (t runs from the side's first corner).
fn side_uv(s: usize, t: f64) -> DVec2 {
    match s {
        0 => DVec2::new(t, 0.0),
        1 => DVec2::new(1.0, t),
        2 => DVec2::new(t, 1.0),
        _ => DVec2::new(0.0, t),
    }
}

/// Parameters t_0 = 0 < ... < t_k = 1 that split the side curve into k arcs of equal length
/// near h (from a fine polyline; the shared-curve placement of the conforming meshing).
fn side_params(p: &RationalBezierPatch, s: usize, h: f64) -> Vec<f64> {
    const FINE: usize = 2000;
    let mut cum = vec![0.0];
    let mut prev = p.point(side_uv(s, 0.0));
    for i in 1..=FINE {
        let q = p.point(side_uv(s, i as f64 / FINE as f64));
        cum.push(cum[i - 1] + prev.distance(q));
        prev = q;
    }
    let total = cum[FINE];
    let k = ((total / h).round() as usize).max(1);
    let mut out = vec![0.0];
    let mut j = 0;
    for i in 1..k {
        let target = total * i as f64 / k as f64;
        while cum[j + 1] < target {
            j += 1;
        }
        let f = (target - cum[j]) / (cum[j + 1] - cum[j]).max(1e-300);
        out.push((j as f64 + f) / FINE as f64);
    }
    out.push(1.0);
    out
}

/// Arc-length reparametrisation of one direction: parameters where the average length along
/// `axis` (sampled over the other parameter) is split into k equal parts.
fn axis_params(p: &RationalBezierPatch, axis: usize, h: f64) -> Vec<f64> {
    const FINE: usize = 400;
    const ACROSS: usize = 9;
    let mut cum = vec![0.0; FINE + 1];
    for a in 0..ACROSS {
        let o = a as f64 / (ACROSS - 1) as f64;
        let at = |t: f64| if axis == 0 { DVec2::new(t, o) } else { DVec2::new(o, t) };
        let mut prev = p.point(at(0.0));
        let mut acc = 0.0;
        for (i, c) in cum.iter_mut().enumerate().skip(1) {
            let q = p.point(at(i as f64 / FINE as f64));
            acc += prev.distance(q);
            *c += acc / ACROSS as f64;
            prev = q;
        }
    }
    let total = cum[FINE];
    let k = ((total / h).round() as usize).max(1);
    let mut out = Vec::new();
    let mut j = 0;
    for i in 0..=k {
        let target = total * i as f64 / k as f64;
        while j + 1 < FINE && cum[j + 1] < target {
            j += 1;
        }
        let f = ((target - cum[j]) / (cum[j + 1] - cum[j]).max(1e-300)).clamp(0.0, 1.0);
        out.push((j as f64 + f) / FINE as f64);
    }
    out
}

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
    if !(ok(opts.fscale) && ok(opts.dt)) {
        return Err(Error::Invalid(format!("fscale {} and dt {} must be positive and finite", opts.fscale, opts.dt)));
    }
    // Estimated node count: refuse before allocating.
    let est = (side_params_len(sides) as f64 / 4.0).powi(2);
    if est > 4e6 {
        return Err(Error::TooManyElements { estimated: (2.0 * est) as u64, limit: 8_000_000 });
    }
    // Start points: the side nodes, then an interior grid spaced by arc length (in space mode)
    // or uniformly (parameter-plane mode), kept off the sides by half a spacing.
    let mut uv: Vec<DVec2> = Vec::new();
    let mut kind: Vec<Kind> = Vec::new();
    for (s, ts) in sides.iter().enumerate() {
        for &t in ts {
            let q = side_uv(s, t);
            // Corners end two sides: once.
            if !uv.contains(&q) {
                uv.push(q);
                kind.push(Kind::Fixed);
            }
        }
    }
    let (us, vs) = if opts.in_space {
        (axis_params(p, 0, opts.h0), axis_params(p, 1, opts.h0))
    } else {
        let k = ((sides[0].len() + sides[1].len() + sides[2].len() + sides[3].len()) as f64 / 4.0).round().max(2.0)
            as usize;
        let g: Vec<f64> = (0..k).map(|i| i as f64 / (k - 1) as f64).collect();
        (g.clone(), g)
    };
    for (j, &v) in vs.iter().enumerate().take(vs.len().saturating_sub(1)).skip(1) {
        for (i, &u) in us.iter().enumerate().take(us.len().saturating_sub(1)).skip(1) {
            // Shift odd rows by half a cell: a start close to equilateral.
            let u = if j % 2 == 1 && i + 1 < us.len() { 0.5 * (u + us[i + 1]) } else { u };
            let du = 0.35 * (us[1] - us[0]).min(us[us.len() - 1] - us[us.len() - 2]);
            let dv = 0.35 * (vs[1] - vs[0]).min(vs[vs.len() - 1] - vs[vs.len() - 2]);
            if u < du || u > 1.0 - du || v < dv || v > 1.0 - dv {
                continue;
            }
            uv.push(DVec2::new(u, v));
            kind.push(Kind::Interior);
        }
    }
    let mut tris = triangulate(p, &mut uv, &mut kind)?;
    let pos_of = |uv: DVec2| if opts.in_space { p.point(uv) } else { DVec3::new(uv.x, uv.y, 0.0) };
    let h = if opts.in_space { opts.h0 } else { 1.0 / ((sides[0].len() + sides[2].len()) as f64 / 2.0 - 1.0).max(1.0) };
    let mut pts: Vec<DVec3> = uv.iter().map(|&q| pos_of(q)).collect();
    flip_pass(&pts, &uv, &mut tris);
    for it in 1..=opts.max_iterations {
        let (moved, rebuild) = force_step(p, &mut pts, &mut uv, &mut kind, &tris, h, opts, &pos_of);
        if rebuild {
            tris = triangulate(p, &mut uv, &mut kind)?;
            pts = uv.iter().map(|&q| pos_of(q)).collect();
        }
        flip_pass(&pts, &uv, &mut tris);
        let late = it + DENSITY_EVERY > opts.max_iterations;
        if it % DENSITY_EVERY == 0 && !late && density(p, &mut pts, &mut uv, &mut kind, &tris, h, opts, &pos_of) {
            tris = triangulate(p, &mut uv, &mut kind)?;
            flip_pass(&pts, &uv, &mut tris);
            continue;
        }
        if moved < 1e-4 && it > DENSITY_EVERY && it % DENSITY_EVERY != 1 {
            break;
        }
    }
    let points = uv.iter().map(|&q| p.point(q)).collect();
    Ok(PatchMesh { points, uv, triangles: tris })
}

/// Density control runs every this many force iterations (not in the last stretch).
const DENSITY_EVERY: usize = 20;
/// Largest node count [`mesh_patches`] accepts (estimated from the control polygon's box).
const MAX_NODES: f64 = 4e6;

/// Delaunay triangulation of the nodes in (u, v), cut to the trim (triangles whose centroid is
/// outside are dropped, their outside nodes moved onto the curve), compacted to the used nodes.
/// A start only: the flips in space then make it good in space.
fn triangulate(p: &RationalBezierPatch, uv: &mut Vec<DVec2>, kind: &mut Vec<Kind>) -> Result<Vec<[usize; 3]>, Error> {
    let (dm, ids) = TriMesh::<DVec2>::delaunay(uv)?;
    let (_, tris_raw, _, keys) = dm.to_arrays();
    let mut key_to_input = HashMap::new();
    for (i, k) in ids.iter().enumerate() {
        key_to_input.entry(*k).or_insert(i);
    }
    let remap: Vec<usize> = keys.iter().map(|k| key_to_input[k]).collect();
    let mut tris: Vec<[usize; 3]> = tris_raw.iter().map(|t| t.map(|i| remap[i])).collect();
    if p.trim.is_some() {
        tris.retain(|t| p.trim_value((uv[t[0]] + uv[t[1]] + uv[t[2]]) / 3.0) <= 0.0);
        let used = used_nodes(uv.len(), &tris);
        for i in 0..uv.len() {
            if used[i] && kind[i] != Kind::Trim && p.trim_value(uv[i]) > 0.0 {
                let fix = side_of(uv[i]);
                uv[i] = p.to_trim_curve(uv[i], fix);
                kind[i] = if fix.is_some() { Kind::Fixed } else { Kind::Trim };
            }
        }
        // Boundary nodes of the kept region that are inside but not on a side go to the curve.
        for ((a, b), ts) in edges_sorted(&tris) {
            if ts.len() == 1 {
                for i in [a, b] {
                    if kind[i] == Kind::Interior {
                        uv[i] = p.to_trim_curve(uv[i], None);
                        kind[i] = Kind::Trim;
                    }
                }
            }
        }
        tris.retain(|t| orient(uv[t[0]], uv[t[1]], uv[t[2]]) > 0.0);
        if tris.is_empty() {
            return Err(Error::EmptyDomain("the trim leaves no triangle of the patch".into()));
        }
    }
    let used = used_nodes(uv.len(), &tris);
    let mut new_index = vec![usize::MAX; uv.len()];
    let (mut uv2, mut kind2) = (Vec::new(), Vec::new());
    for i in 0..uv.len() {
        if used[i] {
            new_index[i] = uv2.len();
            uv2.push(uv[i]);
            kind2.push(kind[i]);
        }
    }
    *uv = uv2;
    *kind = kind2;
    Ok(tris.iter().map(|t| t.map(|i| new_index[i])).collect())
}

/// Density control (seed section 2.4): a free node on an edge shorter than h/2 is removed, an
/// interior edge longer than 1.6 h gets its midpoint (projected onto the patch). Removing nodes
/// that the pressure pushed against a fixed side is what keeps slivers off the sides. Returns
/// whether anything changed (the caller then retriangulates).
#[allow(clippy::too_many_arguments)]
fn density(
    p: &RationalBezierPatch,
    pts: &mut Vec<DVec3>,
    uv: &mut Vec<DVec2>,
    kind: &mut Vec<Kind>,
    tris: &[[usize; 3]],
    h: f64,
    opts: &BezierOptions,
    pos_of: &dyn Fn(DVec2) -> DVec3,
) -> bool {
    let mut gone = vec![false; pts.len()];
    let mut add: Vec<DVec2> = Vec::new();
    let mut add_trim: Vec<DVec2> = Vec::new();
    for ((a, b), ts) in edges_sorted(tris) {
        let l = pts[a].distance(pts[b]);
        if l < 0.5 * h {
            if gone[a] || gone[b] {
                continue;
            }
            let victim = [b, a].into_iter().find(|&i| kind[i] != Kind::Fixed);
            if let Some(i) = victim {
                gone[i] = true;
            }
        } else if l > 1.6 * h && ts.len() == 2 && kind[a] != Kind::Fixed && kind[b] != Kind::Fixed {
            let mid = 0.5 * (uv[a] + uv[b]);
            add.push(if opts.in_space { p.project(0.5 * (pts[a] + pts[b]), mid, None) } else { mid });
        } else if l > 1.6 * h && ts.len() == 1 && (kind[a] == Kind::Trim || kind[b] == Kind::Trim) {
            // A long piece of the trim curve: a new node on the curve.
            let mid = 0.5 * (uv[a] + uv[b]);
            let q = if opts.in_space { p.project(0.5 * (pts[a] + pts[b]), mid, None) } else { mid };
            add_trim.push(p.to_trim_curve(q, None));
        }
    }
    // A sliver left by a node pressed against the boundary loses that node (the one opposite
    // its longest edge) when it is free.
    for t in tris {
        let q = t.map(|i| pts[i]);
        if triangle_q3(q) >= 0.2 || t.iter().any(|&i| gone[i]) {
            continue;
        }
        let opp = (0..3).max_by(|&a, &b| {
            let la = q[(a + 1) % 3].distance(q[(a + 2) % 3]);
            let lb = q[(b + 1) % 3].distance(q[(b + 2) % 3]);
            la.total_cmp(&lb)
        });
        if let Some(k) = opp {
            if kind[t[k]] != Kind::Fixed {
                gone[t[k]] = true;
            }
        }
    }
    if add.is_empty() && add_trim.is_empty() && !gone.iter().any(|&g| g) {
        return false;
    }
    let mut k = 0;
    uv.retain(|_| {
        k += 1;
        !gone[k - 1]
    });
    k = 0;
    kind.retain(|_| {
        k += 1;
        !gone[k - 1]
    });
    for q in add {
        uv.push(q);
        kind.push(Kind::Interior);
    }
    for q in add_trim {
        uv.push(q);
        kind.push(Kind::Trim);
    }
    *pts = uv.iter().map(|&q| pos_of(q)).collect();
    true
}

fn side_params_len(sides: &[Vec<f64>; 4]) -> usize {
    sides.iter().map(|s| s.len()).sum()
}

fn used_nodes(n: usize, tris: &[[usize; 3]]) -> Vec<bool> {
    let mut used = vec![false; n];
    for t in tris {
        for &i in t {
            used[i] = true;
        }
    }
    used
}

/// Which side of the unit square `uv` lies on, as a (fixed axis, value) pair.
fn side_of(uv: DVec2) -> Option<(usize, f64)> {
    for s in 0..4 {
        let (a, val) = side_fix(s);
        if uv[a] == val {
            return Some((a, val));
        }
    }
    None
}

/// Exact orientation in the parameter plane: a regular patch keeps a triangle unfolded in
/// space exactly when it keeps it counter-clockwise in (u, v).
fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    robust::orient2d(
        robust::Coord { x: a.x, y: a.y },
        robust::Coord { x: b.x, y: b.y },
        robust::Coord { x: c.x, y: c.y },
    )
}

/// Flips interior edges in space when the worse of the two triangles gets better and both new
/// triangles stay counter-clockwise in (u, v); sweeps until nothing flips.
fn flip_pass(pts: &[DVec3], uv: &[DVec2], tris: &mut [[usize; 3]]) -> usize {
    let mut total = 0;
    for _ in 0..20 {
        let mut n = 0;
        let mut edges = edge_map(tris);
        let mut keys: Vec<(usize, usize)> = edges.keys().copied().collect();
        keys.sort_unstable();
        for e in keys {
            let Some(ts) = edges.get(&e).cloned() else { continue };
            if ts.len() != 2 {
                continue;
            }
            let (a, b) = e;
            let (t0, t1) = (ts[0], ts[1]);
            let third = |t: [usize; 3]| t.iter().copied().find(|&x| x != a && x != b);
            let (Some(c), Some(d)) = (third(tris[t0]), third(tris[t1])) else { continue };
            if edges.contains_key(&(c.min(d), c.max(d))) {
                continue;
            }
            // Orient: t0 = (a, b, c) counter-clockwise or (b, a, c).
            let (a, b) = if orient(uv[a], uv[b], uv[c]) > 0.0 { (a, b) } else { (b, a) };
            let old = triangle_q3([pts[a], pts[b], pts[c]]).min(triangle_q3([pts[b], pts[a], pts[d]]));
            let n0 = [c, a, d];
            let n1 = [d, b, c];
            if orient(uv[n0[0]], uv[n0[1]], uv[n0[2]]) <= 0.0 || orient(uv[n1[0]], uv[n1[1]], uv[n1[2]]) <= 0.0 {
                continue;
            }
            let new = triangle_q3(n0.map(|i| pts[i])).min(triangle_q3(n1.map(|i| pts[i])));
            if new <= old + 1e-9 {
                continue;
            }
            tris[t0] = n0;
            tris[t1] = n1;
            for (x, y) in [(a, b), (c, a), (a, d), (d, b), (b, c), (c, d)] {
                edges.remove(&(x.min(y), x.max(y)));
            }
            for (k, t) in [(t0, n0), (t1, n1)] {
                for i in 0..3 {
                    let (x, y) = (t[i], t[(i + 1) % 3]);
                    edges.entry((x.min(y), x.max(y))).or_default().push(k);
                }
            }
            n += 1;
        }
        total += n;
        if n == 0 {
            break;
        }
    }
    total
}

/// One truss step: repulsive bar forces toward Fscale h (seed eq. 2.6, scaled so the bars fill
/// the surface), forward Euler in space, projection of each node back onto the patch (interior
/// eq. 3.29, trim curve eq. 3.31-3.32); a move that would turn a triangle in (u, v) is undone.
/// Returns the largest move relative to h and whether a node joined the trim boundary (then
/// the triangles must be rebuilt).
#[allow(clippy::too_many_arguments)]
fn force_step(
    p: &RationalBezierPatch,
    pts: &mut [DVec3],
    uv: &mut [DVec2],
    kind: &mut [Kind],
    tris: &[[usize; 3]],
    h: f64,
    opts: &BezierOptions,
    pos_of: &dyn Fn(DVec2) -> DVec3,
) -> (f64, bool) {
    let edges = edges_sorted(tris);
    let (mut sl, mut nb) = (0.0, 0.0);
    for ((a, b), _) in &edges {
        sl += pts[*a].distance_squared(pts[*b]);
        nb += 1.0;
    }
    let l0 = opts.fscale * (sl / nb).sqrt();
    let _ = h;
    let mut force = vec![DVec3::ZERO; pts.len()];
    for ((a, b), _) in &edges {
        let d = pts[*a] - pts[*b];
        let l = d.length();
        if l > 0.0 && l < l0 {
            let f = (l0 - l) / l * d;
            force[*a] += f;
            force[*b] -= f;
        }
    }
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); pts.len()];
    for (k, t) in tris.iter().enumerate() {
        for &i in t {
            around[i].push(k);
        }
    }
    let mut moved = 0.0f64;
    let mut became_boundary = false;
    for i in 0..pts.len() {
        if kind[i] == Kind::Fixed {
            continue;
        }
        let mut joined = false;
        let target = pts[i] + opts.dt * force[i];
        let new_uv = if opts.in_space {
            let q = p.project(target, uv[i], None);
            // As in DistMesh, a node pushed out of the trimmed domain becomes a boundary node.
            if kind[i] == Kind::Interior && p.trim_value(q) > 0.0 {
                kind[i] = Kind::Trim;
                became_boundary = true;
                joined = true;
            }
            if kind[i] == Kind::Trim {
                // Two steps (eq. 3.31, 3.32): the free projection, then back onto the curve,
                // repeated so the pair settles at the constrained minimum.
                let mut q = p.to_trim_curve(q, None);
                for _ in 0..3 {
                    q = p.to_trim_curve(p.project(target, q, None), None);
                }
                q
            } else {
                q
            }
        } else {
            let q = DVec2::new(target.x, target.y).clamp(DVec2::ZERO, DVec2::ONE);
            if kind[i] == Kind::Interior && p.trim_value(q) > 0.0 {
                kind[i] = Kind::Trim;
                became_boundary = true;
                joined = true;
            }
            if kind[i] == Kind::Trim {
                p.to_trim_curve(q, None)
            } else {
                q
            }
        };
        let old = uv[i];
        uv[i] = new_uv;
        // A node that joined the boundary moves regardless: the caller retriangulates.
        let ok = joined
            || around[i].iter().all(|&k| {
                let t = tris[k];
                orient(uv[t[0]], uv[t[1]], uv[t[2]]) > 0.0
            });
        if ok {
            let np = pos_of(new_uv);
            moved = moved.max(np.distance(pts[i]) / l0.max(1e-300));
            pts[i] = np;
        } else {
            uv[i] = old;
        }
    }
    (moved, became_boundary)
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

/// Whether side s of patch a and side t of patch b are the same curve (same control points and
/// proportional weights, same or reversed direction). Returns Some(reversed).
fn same_side(a: &RationalBezierPatch, s: usize, b: &RationalBezierPatch, t: usize) -> Option<bool> {
    let row = |p: &RationalBezierPatch, s: usize| -> Vec<(DVec3, f64)> {
        let (m, n) = p.degree;
        let idx: Vec<usize> = match s {
            0 => (0..=m).collect(),
            1 => (0..=n).map(|j| m + (m + 1) * j).collect(),
            2 => (0..=m).map(|i| i + (m + 1) * n).collect(),
            _ => (0..=n).map(|j| (m + 1) * j).collect(),
        };
        idx.iter().map(|&k| (p.control[k], p.weights[k])).collect()
    };
    let (ra, rb) = (row(a, s), row(b, t));
    if ra.len() != rb.len() {
        return None;
    }
    let matches = |rb: &[(DVec3, f64)]| {
        let ratio = rb[0].1 / ra[0].1;
        ra.iter().zip(rb).all(|(x, y)| x.0 == y.0 && (y.1 - ratio * x.1).abs() <= 1e-14 * y.1)
    };
    if matches(&rb) {
        return Some(false);
    }
    let rev: Vec<_> = rb.iter().rev().copied().collect();
    if matches(&rev) {
        return Some(true);
    }
    None
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
    let mut sides: Vec<[Vec<f64>; 4]> = Vec::new();
    let mut shared: Vec<[Option<(usize, usize, bool)>; 4]> = Vec::new();
    for (k, p) in patches.iter().enumerate() {
        let mut mine: [Vec<f64>; 4] = Default::default();
        let mut links: [Option<(usize, usize, bool)>; 4] = [None; 4];
        for (s, slot) in mine.iter_mut().enumerate() {
            let mut found = None;
            'outer: for (j, q) in patches[..k].iter().enumerate() {
                for t in 0..4 {
                    if let Some(rev) = same_side(p, s, q, t) {
                        found = Some((j, t, rev));
                        break 'outer;
                    }
                }
            }
            // Same control row and weights up to a factor: the same rational curve with the
            // same parametrisation, so the first patch's parameters serve (mirrored if reversed).
            *slot = match found {
                Some((j, t, false)) => sides[j][t].clone(),
                Some((j, t, true)) => sides[j][t].iter().rev().map(|x| 1.0 - x).collect(),
                None => side_params(p, s, opts.h0),
            };
            links[s] = found;
        }
        sides.push(mine);
        shared.push(links);
    }
    // Orientation: the counter-clockwise boundary loop of the unit square runs sides 0 and 1
    // forward and sides 2 and 3 backward; two patches are consistently oriented when their
    // loops run the shared curve in opposite directions. A patch that is not gets its
    // triangles reversed in the union.
    let dir = |s: usize| if s < 2 { 1i32 } else { -1 };
    let mut reversed = vec![false; patches.len()];
    for k in 0..patches.len() {
        if let Some((s, (j, t, rev))) = shared[k].iter().enumerate().find_map(|(s, l)| l.map(|l| (s, l))) {
            let mine = dir(s) * if rev { -1 } else { 1 };
            reversed[k] = reversed[j] ^ (mine == dir(t));
        }
    }
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
                .filter_map(|s| sides[k][s].iter().position(|&t| side_uv(s, t) == uv).map(|pos| (s, pos)))
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
