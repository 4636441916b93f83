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
/// quadratically) until |phi| / |grad phi| <= `tol`. Two successive steps along one line that
/// shrink linearly (a multiple root, d^3) or swing about the root (an infinite slope, cbrt(d))
/// scale the next by the root's multiplicity they suggest, as the meshers' shared projection
/// does ([`crate::geometry::project`]). Returns the last point if the cap is reached; the
/// caller measures the residual.
pub fn project(phi: &dyn Implicit3, p: DVec3, tol: f64) -> Result<DVec3, Error> {
    project_grad(phi, p, tol).map(|(x, _)| x)
}

/// [`project`], also returning grad phi at the returned point (the last step computed it), so
/// that the fold test after a move needs no evaluation of its own.
pub fn project_grad(phi: &dyn Implicit3, p: DVec3, tol: f64) -> Result<(DVec3, DVec3), Error> {
    let mut x = p;
    let mut previous: Option<DVec3> = None;
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
        let step = -(v / g2) * g;
        let m = previous.map_or(1.0, |s| crate::geometry::project::step_multiplicity3(s, step));
        previous = Some(step);
        if m != 1.0 && crate::geometry::project::scaled_step_taken(m, v, phi.value(x + m * step)) {
            previous = None;
            x += m * step;
            continue;
        }
        x += step;
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

/// Distances along the normal, in units of the size, at which [`thinnest`] samples phi.
const THICKNESS_SAMPLES: [f64; 14] = [0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0];

/// The thinnest sheet or gap met from the points `on` of phi = 0 (its thickness, and the point
/// it was met from): from each point, phi is sampled along the unit normal inward and outward
/// at 0.25 to 32 times `h` up to `reach`, and the first sample on the other side
/// (beyond `tol` in distance, as far as |grad phi| tells) brackets the crossing, found by
/// bisection; the smallest such distance is returned. A shell thinner than a level's edges, or
/// two sheets closer than that, let a node's projection land on the wrong sheet. Only sheets
/// that face each other within `facing_deg` count (the normal where the ray crosses within that
/// angle of the opposite of the normal it left along; 180 counts every crossing): across the
/// wedge of a sharp edge the ray meets the other face at a slant. `None` when no sample
/// changes side.
pub fn thinnest(phi: &dyn Implicit3, on: &[DVec3], h: f64, reach: f64, tol: f64, facing_deg: f64) -> Option<Thinnest> {
    let cos_facing = facing_deg.to_radians().cos();
    use rayon::prelude::*;
    on.par_iter()
        .filter_map(|&p| {
            let (_, g) = phi.value_and_gradient(p);
            let n = g.normalize_or_zero();
            let slack = tol * g.length();
            if n == DVec3::ZERO || !slack.is_finite() {
                return None;
            }
            let mut best: Option<(f64, f64)> = None;
            for side in [-1.0, 1.0] {
                let mut before = 0.0;
                for &s in &THICKNESS_SAMPLES {
                    let t = s * h;
                    if t > reach {
                        break;
                    }
                    // Nothing within 1.5 steps of the sample (a bounded query, see
                    // `Implicit3::value_near`): the step from the last sample, more than half a
                    // step from the surface and not flipped, crossed nothing, so the sign stays.
                    let Some(v) = phi.value_near(p + side * t * n, 1.5 * (t - before)) else {
                        before = t;
                        continue;
                    };
                    if side * v < -slack {
                        // The crossing between the two samples, by bisection.
                        let (mut lo, mut hi) = (before, t);
                        for _ in 0..THICKNESS_BISECTIONS {
                            let mid = 0.5 * (lo + hi);
                            if side * phi.value(p + side * mid * n) < -slack {
                                hi = mid;
                            } else {
                                lo = mid;
                            }
                        }
                        let back = -phi.gradient(p + side * hi * n).normalize_or_zero().dot(n);
                        if (facing_deg >= 180.0 || back > cos_facing) && best.is_none_or(|b| hi < b.0) {
                            best = Some((hi, back.clamp(-1.0, 1.0).acos().to_degrees()));
                        }
                        break;
                    }
                    before = t;
                }
            }
            best.map(|(across, angle)| Thinnest { across, at: p, angle })
        })
        .min_by(|x, y| {
            let key = |t: &Thinnest| (t.across, t.at.x, t.at.y, t.at.z);
            let (a, b) = (key(x), key(y));
            a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.total_cmp(&b.2)).then(a.3.total_cmp(&b.3))
        })
}

/// What [`thinnest`] found: the distance `across` the sheet or gap, met from `at`.
#[derive(Clone, Copy, Debug)]
pub struct Thinnest {
    pub across: f64,
    pub at: DVec3,
    /// The angle in degrees between the two sheets there (0 for parallel sheets facing each
    /// other, the wedge's opening angle at a sharp edge).
    pub angle: f64,
}

/// Bisections of the interval where [`thinnest`] saw phi change side (to 1e-6 of it).
const THICKNESS_BISECTIONS: usize = 20;
