//! Projection of points onto the zero set of an implicit function (seed sections 2.4 and 3.2).
//!
//! The mesher moves boundary nodes back onto the boundary with these. A signed distance projects
//! in one exact step; a general level-set function needs first-order (seed eq. 3.9),
//! second-order (seed eq. 3.10-3.16) or Newton closest-point (seed eq. 2.10-2.13) projections.
//! Every loop is capped by `max_iter`, and nothing here panics: bad values come back as
//! [`ProjectError`].

// `!(x > 0.0)` is deliberate: it rejects NaN too. Index loops mirror the matrix formulas.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use super::{fd_step, Implicit2, Implicit3};
use glam::{DVec2, DVec3};
use thiserror::Error;

/// How to project.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Projection {
    /// [`Projection::Exact`] for signed distances, else [`Projection::FirstOrder`].
    #[default]
    Auto,
    /// p - d grad d / |grad d|, repeated until |d| < tol: one step for a true distance.
    Exact,
    /// p - phi grad phi / |grad phi|^2 (seed eq. 3.9), repeated until |phi| / |grad phi| < tol.
    FirstOrder,
    /// The second-order step of seed eq. 3.10-3.16 (needs the Hessian; a first-order step
    /// where there is none or the quadratic model has no real root), repeated.
    SecondOrder,
    /// The true closest point by damped Newton (seed eq. 2.10-2.12), started from a first-order
    /// projection; falls back to that first-order point when Newton fails.
    Newton,
}

/// Why a projection failed.
#[derive(Clone, Copy, Debug, PartialEq, Error)]
pub enum ProjectError {
    /// The function, its gradient or the input point was NaN or infinite.
    #[error("non-finite value {value} in {kind} at {at:?}")]
    NonFinite {
        /// The offending number.
        value: f64,
        /// Which number it was.
        kind: NonFiniteIn,
        /// Where: the point the function was evaluated at (a point the projection reached,
        /// not necessarily the one it started from), z = 0 in the plane.
        at: [f64; 3],
    },
    /// The gradient vanished off the zero set, so there is no direction to move in.
    #[error("zero gradient away from the boundary: no direction to project along")]
    ZeroGradient,
    /// The iteration cap was reached.
    #[error("projection did not converge; residual {residual}")]
    NoConvergence {
        /// The last |phi| / |grad phi| (|d| for exact projections).
        residual: f64,
    },
}

/// Which number of a projection was not finite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NonFiniteIn {
    /// The point to project.
    Point,
    /// The function's value.
    Value,
    /// The function's gradient (a derived quantity: the function itself may be finite there).
    Gradient,
}

impl std::fmt::Display for NonFiniteIn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NonFiniteIn::Point => "the input point",
            NonFiniteIn::Value => "the function's value",
            NonFiniteIn::Gradient => "the function's gradient",
        })
    }
}

fn at3<const N: usize>(x: &[f64; N]) -> [f64; 3] {
    std::array::from_fn(|i| x.get(i).copied().unwrap_or(0.0))
}

/// Projects `p` onto the zero set of `g`. `tol` bounds the final residual (see [`Projection`]);
/// `max_iter` caps the steps (0 only checks `p`).
pub fn project2(
    g: &dyn Implicit2,
    p: DVec2,
    method: Projection,
    tol: f64,
    max_iter: usize,
) -> Result<DVec2, ProjectError> {
    project(&G2(g), p.to_array(), method, tol, max_iter).map(DVec2::from_array)
}

/// Projects `p` onto the zero set of `g`; see [`project2`].
pub fn project3(
    g: &dyn Implicit3,
    p: DVec3,
    method: Projection,
    tol: f64,
    max_iter: usize,
) -> Result<DVec3, ProjectError> {
    project(&G3(g), p.to_array(), method, tol, max_iter).map(DVec3::from_array)
}

/// The signed distance from `p` to the zero set of any implicit `g`: sign(phi(p)) |p - P| with
/// P the Newton closest point (seed eq. 2.13).
pub fn newton_distance2(g: &dyn Implicit2, p: DVec2, tol: f64, max_iter: usize) -> Result<f64, ProjectError> {
    let q = project2(g, p, Projection::Newton, tol, max_iter)?;
    Ok((p - q).length().copysign(g.value(p)))
}

/// 3-D [`newton_distance2`].
pub fn newton_distance3(g: &dyn Implicit3, p: DVec3, tol: f64, max_iter: usize) -> Result<f64, ProjectError> {
    let q = project3(g, p, Projection::Newton, tol, max_iter)?;
    Ok((p - q).length().copysign(g.value(p)))
}

// ---------------------------------------------------------------------------------------------
// One body for both dimensions, over plain arrays.

type Vector<const N: usize> = [f64; N];
type Matrix<const N: usize> = [[f64; N]; N];

trait Geom<const N: usize> {
    fn value(&self, p: Vector<N>) -> f64;
    fn gradient(&self, p: Vector<N>) -> Vector<N>;
    /// Values at many points at once (the geometry's batch evaluation).
    fn values(&self, ps: &[Vector<N>]) -> Vec<f64>;
    /// Gradients at many points at once.
    fn gradients(&self, ps: &[Vector<N>]) -> Vec<Vector<N>>;
    fn hessian(&self, p: Vector<N>) -> Option<Matrix<N>>;
    fn is_distance(&self) -> bool;
}

struct G2<'a>(&'a dyn Implicit2);
struct G3<'a>(&'a dyn Implicit3);

impl Geom<2> for G2<'_> {
    fn value(&self, p: Vector<2>) -> f64 {
        self.0.value(DVec2::from_array(p))
    }
    fn gradient(&self, p: Vector<2>) -> Vector<2> {
        self.0.gradient(DVec2::from_array(p)).to_array()
    }
    fn values(&self, ps: &[Vector<2>]) -> Vec<f64> {
        let ps: Vec<DVec2> = ps.iter().map(|&p| DVec2::from_array(p)).collect();
        let mut out = vec![0.0; ps.len()];
        self.0.values(&ps, &mut out);
        out
    }
    fn gradients(&self, ps: &[Vector<2>]) -> Vec<Vector<2>> {
        let ps: Vec<DVec2> = ps.iter().map(|&p| DVec2::from_array(p)).collect();
        let mut out = vec![DVec2::ZERO; ps.len()];
        self.0.gradients(&ps, &mut out);
        out.into_iter().map(|g| g.to_array()).collect()
    }
    fn hessian(&self, p: Vector<2>) -> Option<Matrix<2>> {
        // Column-major from glam; the Hessian is symmetric, so rows = columns.
        self.0.hessian(DVec2::from_array(p)).map(|m| m.to_cols_array_2d())
    }
    fn is_distance(&self) -> bool {
        self.0.is_distance()
    }
}

impl Geom<3> for G3<'_> {
    fn value(&self, p: Vector<3>) -> f64 {
        self.0.value(DVec3::from_array(p))
    }
    fn gradient(&self, p: Vector<3>) -> Vector<3> {
        self.0.gradient(DVec3::from_array(p)).to_array()
    }
    fn values(&self, ps: &[Vector<3>]) -> Vec<f64> {
        let ps: Vec<DVec3> = ps.iter().map(|&p| DVec3::from_array(p)).collect();
        let mut out = vec![0.0; ps.len()];
        self.0.values(&ps, &mut out);
        out
    }
    fn gradients(&self, ps: &[Vector<3>]) -> Vec<Vector<3>> {
        let ps: Vec<DVec3> = ps.iter().map(|&p| DVec3::from_array(p)).collect();
        let mut out = vec![DVec3::ZERO; ps.len()];
        self.0.gradients(&ps, &mut out);
        out.into_iter().map(|g| g.to_array()).collect()
    }
    fn hessian(&self, p: Vector<3>) -> Option<Matrix<3>> {
        self.0.hessian(DVec3::from_array(p)).map(|m| m.to_cols_array_2d())
    }
    fn is_distance(&self) -> bool {
        self.0.is_distance()
    }
}

#[inline]
fn dot<const N: usize>(a: Vector<N>, b: Vector<N>) -> f64 {
    (0..N).map(|i| a[i] * b[i]).sum()
}
#[inline]
fn axpy<const N: usize>(x: Vector<N>, s: f64, y: Vector<N>) -> Vector<N> {
    std::array::from_fn(|i| x[i] + s * y[i])
}
#[inline]
fn norm<const N: usize>(a: Vector<N>) -> f64 {
    dot(a, a).sqrt()
}

fn first_non_finite(xs: &[f64]) -> Option<f64> {
    xs.iter().copied().find(|v| !v.is_finite())
}

/// phi and grad phi at `x`, screened for NaN and infinity.
fn eval<const N: usize>(g: &impl Geom<N>, x: Vector<N>) -> Result<(f64, Vector<N>), ProjectError> {
    let phi = g.value(x);
    if !phi.is_finite() {
        return Err(ProjectError::NonFinite { value: phi, kind: NonFiniteIn::Value, at: at3(&x) });
    }
    let grad = g.gradient(x);
    if let Some(value) = first_non_finite(&grad) {
        return Err(ProjectError::NonFinite { value, kind: NonFiniteIn::Gradient, at: at3(&x) });
    }
    Ok((phi, grad))
}

fn project<const N: usize>(
    g: &impl Geom<N>,
    p: Vector<N>,
    method: Projection,
    tol: f64,
    max_iter: usize,
) -> Result<Vector<N>, ProjectError> {
    if let Some(value) = first_non_finite(&p) {
        return Err(ProjectError::NonFinite { value, kind: NonFiniteIn::Point, at: at3(&p) });
    }
    let method = resolve(g, method);
    if method == Projection::Newton {
        return newton(g, p, tol, max_iter);
    }
    let mut x = p;
    let mut residual = f64::INFINITY;
    // The previous first-order step, for the multiplicity estimate below.
    let mut previous: Option<Vector<N>> = None;
    for it in 0..=max_iter {
        let Some(Probe { phi, grad, g2, residual: r }) = probe(g, x, method, tol)? else { return Ok(x) };
        residual = r;
        let gl = g2.sqrt();
        if it == max_iter {
            break;
        }
        let first = axpy([0.0; N], -phi / g2, grad); // seed eq. 3.9
        let step = match method {
            Projection::Exact => axpy([0.0; N], -phi / gl, grad),
            Projection::SecondOrder => second_order_step(g, x, phi, grad).unwrap_or(first),
            _ => {
                let m = previous.map_or(1.0, |s| multiplicity(s, first));
                previous = Some(first);
                let long = axpy([0.0; N], m, first);
                if m != 1.0 && scaled_step_taken(m, phi, g.value(axpy(x, 1.0, long))) {
                    previous = None;
                    long
                } else {
                    first
                }
            }
        };
        x = axpy(x, 1.0, step);
    }
    if matches!(method, Projection::Exact | Projection::FirstOrder) {
        return crease_mode(g, x, method, tol, max_iter);
    }
    Err(ProjectError::NoConvergence { residual })
}

/// phi, its gradient, |grad|^2 and the stopping residual at an iterate not yet on d = 0.
struct Probe<const N: usize> {
    phi: f64,
    grad: Vector<N>,
    g2: f64,
    residual: f64,
}

/// The stopping test at `x`: `None` when x is on d = 0 (phi 0, or the residual below `tol`:
/// |phi| for Exact, |phi| / |grad| otherwise), else the values for the next step.
fn probe<const N: usize>(
    g: &impl Geom<N>,
    x: Vector<N>,
    method: Projection,
    tol: f64,
) -> Result<Option<Probe<N>>, ProjectError> {
    let phi = g.value(x);
    if !phi.is_finite() {
        return Err(ProjectError::NonFinite { value: phi, kind: NonFiniteIn::Value, at: at3(&x) });
    }
    // Exact: the residual is |phi|, and a point already on d = 0 needs no gradient (the
    // last probe of every projection).
    if phi == 0.0 || (method == Projection::Exact && phi.abs() < tol) {
        return Ok(None);
    }
    let grad = g.gradient(x);
    if let Some(value) = first_non_finite(&grad) {
        return Err(ProjectError::NonFinite { value, kind: NonFiniteIn::Gradient, at: at3(&x) });
    }
    let g2 = dot(grad, grad);
    if !(g2 > 0.0) {
        return Err(ProjectError::ZeroGradient);
    }
    let residual = if method == Projection::Exact { phi.abs() } else { phi.abs() / g2.sqrt() };
    Ok((residual >= tol).then_some(Probe { phi, grad, g2, residual }))
}

/// Up to `steps` more steps from `x`, where an Exact or FirstOrder projection stood after
/// max_iter steps without converging: mostly one zigzagging into a crease (see
/// [`crease_point`]), so each plain step is weighed against the crease point. Projections that
/// converge within max_iter never come here, and the batch projection shares this tail.
fn crease_mode<const N: usize>(
    g: &impl Geom<N>,
    mut x: Vector<N>,
    method: Projection,
    tol: f64,
    steps: usize,
) -> Result<Vector<N>, ProjectError> {
    let mut residual = f64::INFINITY;
    // The previous iterate with its phi and gradient.
    let mut last: Option<(Vector<N>, f64, Vector<N>)> = None;
    for it in 0..=steps {
        let Some(Probe { phi, grad, g2, residual: r }) = probe(g, x, method, tol)? else { return Ok(x) };
        residual = r;
        let gl = g2.sqrt();
        if it == steps {
            break;
        }
        let step = if method == Projection::Exact {
            axpy([0.0; N], -phi / gl, grad)
        } else {
            axpy([0.0; N], -phi / g2, grad) // seed eq. 3.9
        };
        let mut next = axpy(x, 1.0, step);
        // Only where the plain step crawls (a zigzag shrinks |phi| by cos^2 of the angle per
        // round), and not far beyond it: a node in the force loop that jumped into a distant
        // crease at every step cost the step control up to three times the run's time.
        if let Some(y) = last.and_then(|(xp, pp, gp)| crease_point(xp, pp, gp, x, phi, grad)) {
            let pn = g.value(next);
            if pn.abs() > CREASE_CRAWL * phi.abs() && norm(axpy(y, -1.0, x)) <= CREASE_REACH * norm(step) {
                let py = g.value(y);
                if py.is_finite() && py.abs() < pn.abs() {
                    next = y;
                }
            }
        }
        last = Some((x, phi, grad));
        x = next;
    }
    Err(ProjectError::NoConvergence { residual })
}

/// Successive gradients closer in direction than this (the cosine of their angle) are one
/// surface's; farther apart, the iterates may zigzag into a crease (see [`crease_point`]).
const CREASE_COS: f64 = 0.98;
/// The crease step is tried when the plain step leaves more than this fraction of |phi|.
const CREASE_CRAWL: f64 = 0.25;
/// ... and taken when it moves at most this many times as far as the plain step.
const CREASE_REACH: f64 = 4.0;

/// The point nearest `x` on both linearisations, phi_p + g_p.(y - x_p) = 0 and
/// phi + g.(y - x) = 0, when two successive iterates lie on the same side of the zero set and
/// their gradients differ: near a crease of a max or min of two functions (a concave edge of a
/// union, a convex one of an intersection) the plain steps land on each function's zero set in
/// turn and zigzag into the crease, shrinking by cos^2 of the angle between the surfaces per
/// round (a node 1 h inside a union of a ball and a cylinder still 3e-5 off after 20 steps).
/// The crease is where both vanish: for planar sides this step lands on it at once. None when
/// the gradients are one surface's, the sides differ, or the two planes are nearly parallel.
fn crease_point<const N: usize>(
    xp: Vector<N>,
    pp: f64,
    gp: Vector<N>,
    x: Vector<N>,
    phi: f64,
    g: Vector<N>,
) -> Option<Vector<N>> {
    if (pp < 0.0) != (phi < 0.0) {
        return None;
    }
    let (aa, ab, bb) = (dot(gp, gp), dot(gp, g), dot(g, g));
    if !(aa > 0.0 && bb > 0.0) || ab > CREASE_COS * (aa * bb).sqrt() {
        return None;
    }
    let det = aa * bb - ab * ab;
    if !(det > 1e-12 * aa * bb) {
        return None;
    }
    // y = x + s g_p + t g: the smallest change meeting both planes lies in their normals' span.
    let r1 = -pp - dot(gp, axpy(x, -1.0, xp));
    let r2 = -phi;
    let s = (bb * r1 - ab * r2) / det;
    let t = (aa * r2 - ab * r1) / det;
    let y = axpy(axpy(x, s, gp), t, g);
    y.iter().all(|v| v.is_finite()).then_some(y)
}

/// `Auto` made definite: exact for a signed distance, first order otherwise.
fn resolve<const N: usize>(g: &impl Geom<N>, method: Projection) -> Projection {
    match method {
        Projection::Auto if g.is_distance() => Projection::Exact,
        Projection::Auto => Projection::FirstOrder,
        m => m,
    }
}

/// Whether a step scaled by the multiplicity `m` (see [`multiplicity`]) from a point where the
/// function is `phi` is taken, the function being `v` where it lands: a longer one (m > 1) only
/// when it stays on this side of the zero set (it does not jump over the boundary to another
/// branch), a shorter one (m < 1) only when it lands nearer (on the zero set, up to rounding on
/// either side). Shared by the point, batch and surface projections.
pub(crate) fn scaled_step_taken(m: f64, phi: f64, v: f64) -> bool {
    let same_side = v.is_finite() && (v == 0.0 || (v < 0.0) == (phi < 0.0));
    let nearer = v.is_finite() && v.abs() < phi.abs();
    (m > 1.0 && same_side) || (m < 1.0 && nearer)
}

/// [`multiplicity`] for the surface mesher's own projection (`mesher::surface::geom`), whose
/// steps are 3-D vectors.
pub(crate) fn step_multiplicity3(s0: DVec3, s1: DVec3) -> f64 {
    multiplicity::<3>(s0.to_array(), s1.to_array())
}

/// The root multiplicity that two successive first-order steps `s0`, `s1` along one line
/// suggest: for phi = c t^m each step is -t / m, so the second is the first times
/// rho = 1 - 1/m, and m = 1 / (1 - rho). Above 1 (at most 10) when the steps point the same
/// way and shrink linearly (0.2 < rho < 0.95), as they do towards a multiple root (a power of
/// a distance, d^3) or far out on a steep level set (x^6 + y^6 - 1), where plain first-order
/// steps crawl. Below 1 (at least 0.05) when they point opposite ways (rho < -0.2): a root with
/// an infinite slope (cbrt(F), a signed square root), where plain steps overshoot by 1/m and
/// swing about the root (rho = -1 for a square root) or out (rho = -2 for a cube root). 1 (no
/// change) otherwise.
fn multiplicity<const N: usize>(s0: Vector<N>, s1: Vector<N>) -> f64 {
    let (l0, l1) = (norm(s0), norm(s1));
    if !(l0 > 0.0 && l1 > 0.0) {
        return 1.0;
    }
    let r = l1 / l0;
    if dot(s0, s1) >= 0.99 * l0 * l1 && r > 0.2 && r < 0.95 {
        (1.0 / (1.0 - r)).min(10.0)
    } else if dot(s0, s1) <= -0.99 * l0 * l1 && r > 0.2 {
        (1.0 / (1.0 + r)).max(0.05)
    } else {
        1.0
    }
}

// ---------------------------------------------------------------------------------------------
// Second order (seed eq. 3.10-3.16).
//
// With the quadratic Taylor model phi + g.D + D^T H D / 2 = 0 and D + t (g + H D) = 0
// (seed eq. 3.11-3.12), D(t) = -t adj(I + tH) g / det(I + tH) (seed eq. 3.13-3.14). Putting D in
// the model and multiplying by det^2 gives a polynomial in t: the quartic of seed eq. 3.15-3.16
// in 2-D, a sextic in 3-D. It is built here by polynomial arithmetic, not from the expanded
// coefficients, so one body serves both dimensions.

/// Polynomial coefficients, lowest degree first; degree 6 is the most needed.
type Poly = [f64; 7];

fn pmul(a: &Poly, b: &Poly) -> Poly {
    let mut c = [0.0; 7];
    for i in 0..7 {
        for j in 0..7 - i {
            c[i + j] += a[i] * b[j];
        }
    }
    c
}
fn padd(a: &Poly, b: &Poly, s: f64) -> Poly {
    std::array::from_fn(|i| a[i] + s * b[i])
}
fn pconst(c: f64) -> Poly {
    let mut p = [0.0; 7];
    p[0] = c;
    p
}
fn peval(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * t + ci)
}

/// adj(I + tH) and det(I + tH) as polynomials in t.
fn adjugate_det<const N: usize>(h: &Matrix<N>) -> ([[Poly; N]; N], Poly) {
    // m[i][j] = delta_ij + t h_ij.
    let m: [[Poly; N]; N] = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let mut p = pconst(if i == j { 1.0 } else { 0.0 });
            p[1] = h[i][j];
            p
        })
    });
    let mut adj = [[[0.0; 7]; N]; N];
    let det;
    if N == 2 {
        adj[0][0] = m[1][1];
        adj[1][1] = m[0][0];
        adj[0][1] = padd(&[0.0; 7], &m[0][1], -1.0);
        adj[1][0] = padd(&[0.0; 7], &m[1][0], -1.0);
        det = padd(&pmul(&m[0][0], &m[1][1]), &pmul(&m[0][1], &m[1][0]), -1.0);
    } else {
        // Cofactor C_ji of the transpose: adj[i][j] = C_ji.
        for i in 0..N {
            for j in 0..N {
                let (r0, r1) = ((j + 1) % 3, (j + 2) % 3);
                let (c0, c1) = ((i + 1) % 3, (i + 2) % 3);
                adj[i][j] = padd(&pmul(&m[r0][c0], &m[r1][c1]), &pmul(&m[r0][c1], &m[r1][c0]), -1.0);
            }
        }
        det = (0..N).fold([0.0; 7], |acc, j| padd(&acc, &pmul(&m[0][j], &adj[j][0]), 1.0));
    }
    (adj, det)
}

/// The seed's second-order correction from `x`, or None without a Hessian or a usable root.
fn second_order_step<const N: usize>(g: &impl Geom<N>, x: Vector<N>, phi: f64, grad: Vector<N>) -> Option<Vector<N>> {
    let h = g.hessian(x)?;
    if h.iter().flatten().any(|v| !v.is_finite()) {
        return None;
    }
    let (adj, det) = adjugate_det(&h);
    // numerator[i] = -t sum_j adj[i][j] g_j, so that D = numerator / det.
    let mut minus_t = [0.0; 7];
    minus_t[1] = -1.0;
    let num: [Poly; N] = std::array::from_fn(|i| {
        let s = (0..N).fold([0.0; 7], |acc, j| padd(&acc, &adj[i][j], grad[j]));
        pmul(&minus_t, &s)
    });
    // det^2 phi + det (g . num) + num^T H num / 2.
    let mut quartic = padd(&[0.0; 7], &pmul(&det, &det), phi);
    let g_num = (0..N).fold([0.0; 7], |acc, i| padd(&acc, &num[i], grad[i]));
    quartic = padd(&quartic, &pmul(&det, &g_num), 1.0);
    for i in 0..N {
        for j in 0..N {
            quartic = padd(&quartic, &pmul(&num[i], &num[j]), 0.5 * h[i][j]);
        }
    }
    let mut best: Option<(f64, Vector<N>)> = None;
    for t in real_roots(&quartic) {
        let dt = peval(&det, t);
        // Roots where I + tH is singular are artefacts of clearing the denominator.
        if !(dt.abs() > 1e-10) {
            continue;
        }
        let step: Vector<N> = std::array::from_fn(|i| peval(&num[i], t) / dt);
        if first_non_finite(&step).is_some() {
            continue;
        }
        if best.is_none_or(|(bt, _)| t.abs() < bt.abs()) {
            best = Some((t, step));
        }
    }
    best.map(|(_, s)| s)
}

/// The real roots of the polynomial `c` (lowest degree first), found by isolating them between
/// the roots of the derivative and polishing by safeguarded Newton: no companion matrix, and
/// every root of odd multiplicity is found. Order is ascending.
fn real_roots(c: &[f64]) -> Vec<f64> {
    let mut n = c.len();
    while n > 0 && c[n - 1] == 0.0 {
        n -= 1;
    }
    let c = &c[..n];
    match n {
        0 | 1 => return Vec::new(),
        2 => return vec![-c[0] / c[1]],
        3 => {
            let (a, b, cc) = (c[2], c[1], c[0]);
            let disc = b * b - 4.0 * a * cc;
            if disc < 0.0 {
                return Vec::new();
            }
            let q = -0.5 * (b + disc.sqrt().copysign(b));
            let mut r = vec![q / a];
            if q != 0.0 {
                r.push(cc / q);
            }
            r.sort_by(f64::total_cmp);
            return r;
        }
        _ => {}
    }
    let lead = c[n - 1];
    let bound = 1.0 + c[..n - 1].iter().map(|ci| (ci / lead).abs()).fold(0.0, f64::max);
    if !bound.is_finite() {
        return Vec::new();
    }
    let deriv: Vec<f64> = (1..n).map(|i| i as f64 * c[i]).collect();
    let mut knots = vec![-bound];
    knots.extend(real_roots(&deriv).into_iter().filter(|r| r.abs() < bound));
    knots.push(bound);
    let mut roots: Vec<f64> = Vec::new();
    for w in knots.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (fa, fb) = (peval(c, a), peval(c, b));
        if fa == 0.0 {
            roots.push(a);
        } else if fa * fb < 0.0 {
            roots.push(bracketed_root(c, &deriv, a, b, fa));
        }
    }
    if peval(c, bound) == 0.0 {
        roots.push(bound);
    }
    roots.dedup();
    roots
}

/// A root in [a, b] where c changes sign: Newton steps kept inside a shrinking bracket.
fn bracketed_root(c: &[f64], deriv: &[f64], mut a: f64, mut b: f64, fa: f64) -> f64 {
    let sa = fa.signum();
    let mut x = 0.5 * (a + b);
    for _ in 0..200 {
        let fx = peval(c, x);
        if fx == 0.0 {
            return x;
        }
        if fx.signum() == sa {
            a = x;
        } else {
            b = x;
        }
        let d = peval(deriv, x);
        let newton = x - fx / d;
        let next = if newton > a.min(b) && newton < a.max(b) { newton } else { 0.5 * (a + b) };
        if next == x || (b - a).abs() <= 4.0 * f64::EPSILON * x.abs().max(f64::MIN_POSITIVE) {
            return next;
        }
        x = next;
    }
    x
}

// ---------------------------------------------------------------------------------------------
// Newton closest point (seed eq. 2.10-2.12).
//
// The seed's system L(P) = [phi; (x - x0) phi_y - (y - y0) phi_x] = 0 says phi = 0 and
// P - p0 parallel to grad phi. It is solved here in the equivalent Lagrange form of seed eq.
// 3.3-3.4, F(x, t) = [x - p + t grad phi(x); phi(x)] = 0, which is square in any dimension,
// with Jacobian [[I + t H, grad phi], [grad phi^T, 0]] and step halving on |F|.

fn newton<const N: usize>(
    g: &impl Geom<N>,
    p: Vector<N>,
    tol: f64,
    max_iter: usize,
) -> Result<Vector<N>, ProjectError> {
    let first = project(g, p, Projection::FirstOrder, tol, max_iter);
    let start = match first {
        Ok(x) => x,
        Err(ProjectError::NoConvergence { .. }) => p,
        Err(e) => return Err(e),
    };
    match newton_polish(g, p, start, tol, max_iter) {
        // A stationary point farther than the first-order point cannot be the closest one.
        Some(x) if first.map_or(true, |f| norm(sub(x, p)) <= norm(sub(f, p)) * (1.0 + 1e-8) + tol) => Ok(x),
        _ => first,
    }
}

#[inline]
fn sub<const N: usize>(a: Vector<N>, b: Vector<N>) -> Vector<N> {
    axpy(a, -1.0, b)
}

/// The Hessian, or central differences of the gradient when the geometry gives none.
fn hessian_or_fd<const N: usize>(g: &impl Geom<N>, x: Vector<N>) -> Matrix<N> {
    if let Some(h) = g.hessian(x) {
        return h;
    }
    let h = fd_step(x.iter().fold(0.0, |m: f64, v| m.max(v.abs())));
    let mut m = [[0.0; N]; N];
    for j in 0..N {
        let mut e = [0.0; N];
        e[j] = h;
        let (gp, gm) = (g.gradient(axpy(x, 1.0, e)), g.gradient(axpy(x, -1.0, e)));
        for i in 0..N {
            m[i][j] = (gp[i] - gm[i]) / (2.0 * h);
        }
    }
    // Symmetrise the difference quotient.
    for i in 0..N {
        for j in 0..i {
            let s = 0.5 * (m[i][j] + m[j][i]);
            m[i][j] = s;
            m[j][i] = s;
        }
    }
    m
}

/// F(x, t) and |F|; None when the geometry gives non-finite numbers there.
fn lagrange_residual<const N: usize>(
    g: &impl Geom<N>,
    p: Vector<N>,
    x: Vector<N>,
    t: f64,
) -> Option<(Vector<N>, f64, Vector<N>, f64)> {
    let (phi, grad) = eval(g, x).ok()?;
    let r = std::array::from_fn(|i| x[i] - p[i] + t * grad[i]);
    let merit = (dot(r, r) + phi * phi).sqrt();
    Some((r, phi, grad, merit))
}

fn newton_polish<const N: usize>(
    g: &impl Geom<N>,
    p: Vector<N>,
    start: Vector<N>,
    tol: f64,
    max_iter: usize,
) -> Option<Vector<N>> {
    let mut x = start;
    let (_, g0) = eval(g, x).ok()?;
    let g02 = dot(g0, g0);
    if !(g02 > 0.0) {
        return None;
    }
    let mut t = dot(sub(p, x), g0) / g02;
    let (mut r, mut phi, mut grad, mut merit) = lagrange_residual(g, p, x, t)?;
    // Round-off floor for the parallel residual, which carries the size of the coordinates.
    let floor = 16.0 * f64::EPSILON * (1.0 + norm(p) + norm(x));
    for _ in 0..=max_iter {
        let gl = norm(grad);
        if !(gl > 0.0) {
            return None;
        }
        if phi.abs() / gl < tol && norm(r) < tol.max(floor) {
            return Some(x);
        }
        // J [dx; dt] = -[r; phi], J = [[I + tH, g], [g^T, 0]].
        let h = hessian_or_fd(g, x);
        let mut a = [[0.0; 5]; 4];
        for i in 0..N {
            for j in 0..N {
                a[i][j] = t * h[i][j] + if i == j { 1.0 } else { 0.0 };
            }
            a[i][N] = grad[i];
            a[N][i] = grad[i];
            a[i][N + 1] = -r[i];
        }
        a[N][N + 1] = -phi;
        let d = solve(&mut a, N + 1)?;
        let mut alpha = 1.0;
        let mut accepted = false;
        for _ in 0..40 {
            let xn: Vector<N> = std::array::from_fn(|i| x[i] + alpha * d[i]);
            let tn = t + alpha * d[N];
            if let Some((rn, phin, gradn, mn)) = lagrange_residual(g, p, xn, tn) {
                if mn < (1.0 - 1e-4 * alpha) * merit {
                    (x, t, r, phi, grad, merit) = (xn, tn, rn, phin, gradn, mn);
                    accepted = true;
                    break;
                }
            }
            alpha *= 0.5;
        }
        if !accepted {
            // Stuck at round-off: accept if already on the zero set and nearly optimal.
            let gl = norm(grad);
            return (phi.abs() / gl < tol && norm(r) < 1e3 * tol.max(floor)).then_some(x);
        }
    }
    None
}

/// Gaussian elimination with partial pivoting on the `n` by `n + 1` augmented system in `a`.
fn solve(a: &mut [[f64; 5]; 4], n: usize) -> Option<[f64; 4]> {
    let scale = a.iter().take(n).flat_map(|row| row[..n].iter()).fold(0.0, |m: f64, v| m.max(v.abs()));
    if !(scale > 0.0) {
        return None;
    }
    for k in 0..n {
        let piv = (k..n).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if !(a[piv][k].abs() > 1e-14 * scale) {
            return None;
        }
        a.swap(k, piv);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            for j in k..=n {
                a[i][j] -= f * a[k][j];
            }
        }
    }
    let mut x = [0.0; 4];
    for k in (0..n).rev() {
        let s: f64 = (k + 1..n).map(|j| a[k][j] * x[j]).sum();
        x[k] = (a[k][n] - s) / a[k][k];
    }
    first_non_finite(&x[..n]).is_none().then_some(x)
}

mod batch;
#[cfg(test)]
mod tests;

pub use batch::{project_many2, project_many3};
