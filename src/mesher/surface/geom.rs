//! What the surface mesher asks of phi: projection onto phi = 0, the unit normal, the fold test
//! and the target edge length h(x).

use crate::geometry::{Grid3, Implicit3};
use crate::Error;
use glam::{DMat3, DVec3};

/// Projection steps allowed per node; each is a Newton step on phi along grad phi, so near the
/// surface a handful suffices.
const PROJECT_STEPS: usize = 60;

/// Projects `p` onto phi = 0 by repeated first-order steps p -= phi grad / |grad|^2 (seed eq.
/// 3.9; near the surface this is Newton's method along the gradient and converges
/// quadratically) until |phi| / |grad phi| <= `tol`. Returns the last point if the cap is
/// reached; the caller measures the residual.
pub fn project(phi: &dyn Implicit3, p: DVec3, tol: f64) -> Result<DVec3, Error> {
    project_grad(phi, p, tol).map(|(x, _)| x)
}

/// [`project`], also returning grad phi at the returned point (the last step computed it), so
/// that the fold test after a move needs no evaluation of its own.
pub fn project_grad(phi: &dyn Implicit3, p: DVec3, tol: f64) -> Result<(DVec3, DVec3), Error> {
    let mut x = p;
    for _ in 0..PROJECT_STEPS {
        let (v, g) = phi.value_and_gradient(x);
        if !v.is_finite() {
            return Err(Error::NonFinite { what: "phi", value: v, at: x.to_array() });
        }
        if !g.is_finite() {
            return Err(Error::NonFinite { what: "grad phi", value: g.max_element(), at: x.to_array() });
        }
        let g2 = g.length_squared();
        if g2 == 0.0 {
            return Err(Error::Invalid(format!("grad phi vanishes at {x}: no direction to project onto phi = 0")));
        }
        if v.abs() <= tol * g2.sqrt() {
            return Ok((x, g));
        }
        x -= (v / g2) * g;
    }
    Ok((x, phi.gradient(x)))
}

/// |phi| / |grad phi| at `p`: the first-order distance to the surface.
pub fn residual(phi: &dyn Implicit3, p: DVec3) -> f64 {
    let g = phi.gradient(p).length();
    if g > 0.0 {
        phi.value(p).abs() / g
    } else {
        f64::INFINITY
    }
}

/// The unit outward normal grad phi / |grad phi| (zero where the gradient vanishes).
pub fn normal(phi: &dyn Implicit3, p: DVec3) -> DVec3 {
    phi.gradient(p).normalize_or_zero()
}

/// Whether triangle (a, b, c) faces outward: its normal makes an angle with grad phi at its
/// centroid whose cosine is above `cos_min`. A degenerate triangle never passes. This is the
/// normal deviation test that keeps flips, collapses and moves from folding the surface.
pub fn faces_out(phi: &dyn Implicit3, a: DVec3, b: DVec3, c: DVec3, cos_min: f64) -> bool {
    let n = (b - a).cross(c - a);
    let g = phi.gradient((a + b + c) / 3.0);
    let (nl, gl) = (n.length(), g.length());
    nl > 0.0 && gl > 0.0 && n.dot(g) > cos_min * nl * gl
}

/// The target edge length h(x), absolute (in the units of the coordinates).
#[derive(Clone, Debug)]
pub enum SizeField {
    /// The same length everywhere.
    Uniform(f64),
    /// Trilinear interpolation of a grid of sizes (from curvature and gradient limiting).
    Grid(Grid3),
}

impl SizeField {
    /// h at `p`.
    pub fn at(&self, p: DVec3) -> f64 {
        match self {
            SizeField::Uniform(h) => *h,
            SizeField::Grid(g) => g.value(p),
        }
    }
    /// The same field times `s` (a coarser level of the start mesh).
    pub fn scaled(&self, s: f64) -> SizeField {
        match self {
            SizeField::Uniform(h) => SizeField::Uniform(h * s),
            SizeField::Grid(g) => {
                let v = g.values().iter().map(|h| h * s).collect();
                // The grid was valid and s is positive and finite, so this cannot fail.
                SizeField::Grid(
                    Grid3::new(g.origin(), g.spacing(), g.dims(), v)
                        .map(|n| n.with_distance(false))
                        .unwrap_or_else(|_| g.clone()),
                )
            }
        }
    }
    /// The smallest size anywhere.
    pub fn min(&self) -> f64 {
        match self {
            SizeField::Uniform(h) => *h,
            SizeField::Grid(g) => g.values().iter().copied().fold(f64::INFINITY, f64::min),
        }
    }
}

/// The principal curvature of largest magnitude of the level set through `p` (the Hessian from
/// phi if it has one, else central differences of the gradient).
pub fn max_curvature(phi: &dyn Implicit3, p: DVec3) -> f64 {
    let g = phi.gradient(p);
    let hes = phi.hessian(p).unwrap_or_else(|| {
        let e = 1e-4 * p.abs().max_element().max(1.0);
        let col = |d: DVec3| (phi.gradient(p + d) - phi.gradient(p - d)) / (2.0 * e);
        let m = DMat3::from_cols(col(DVec3::X * e), col(DVec3::Y * e), col(DVec3::Z * e));
        // Symmetrise: differences of a gradient are only nearly symmetric.
        (m + m.transpose()) * 0.5
    });
    let k = crate::size::max_principal(g, hes);
    if k.is_finite() {
        k
    } else {
        0.0
    }
}
