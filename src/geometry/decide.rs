//! Distance or level set, decided from the function itself.
//!
//! A signed distance has |grad d| = 1 (seed section 2.1), and then p - d grad d lands on d = 0
//! in one step; a general level set (an ellipse `x^2/4 + y^2 - 1`, a power `d^3`) does not, and
//! the one-step projection overshoots, sometimes far enough to leave the region where the
//! function is finite. Geometries that know what they are say so
//! ([`Implicit2::declared_distance`]); for the rest (closures, expressions) the meshers sample
//! |grad d| over the box, near d = 0 and along first-order projections onto it (seed eq. 3.9),
//! and call the function a distance only when nearly every sample has |grad d| = 1.

use super::{Implicit2, Implicit3};
use glam::{DMat2, DMat3, DVec2, DVec3};

/// Sample points per side of the box (2-D, 3-D).
const SIDE: [usize; 2] = [41, 15];
/// Projection paths followed from the samples nearest to d = 0.
const PATHS: usize = 48;
/// Steps per projection path.
const PATH_STEPS: usize = 40;
/// |grad d| within this of 1 counts as a distance's.
const UNIT_TOL: f64 = 0.02;
/// The fraction of samples that must be within [`UNIT_TOL`] (kinks of min and max, the medial
/// axis, where a difference quotient mixes two gradients, may miss).
const UNIT_FRACTION: f64 = 0.95;

/// Where in its cell each sample lies, per axis: not 0.5, so that samples avoid the box's
/// diagonals and midlines.
const OFFSET: [f64; 3] = [0.381_966, 0.572_949, 0.427_051];

/// What sampling |grad d| found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradientSurvey {
    /// Finite |grad d| samples taken (near d = 0 and along the projections onto it).
    pub samples: usize,
    /// The smallest |grad d| sampled.
    pub grad_min: f64,
    /// The largest |grad d| sampled.
    pub grad_max: f64,
    /// The fraction of samples with |grad d| within 0.02 of 1.
    pub unit_fraction: f64,
    /// The verdict: a signed distance (true) or a level set.
    pub distance: bool,
}

/// Samples |grad d| of a 2-D geometry over the box `[lo, hi]`; see the module notes.
pub fn survey_gradient2(g: &dyn Implicit2, lo: DVec2, hi: DVec2) -> GradientSurvey {
    survey::<2>(
        &|p| g.value(DVec2::from_array(p)),
        &|p| g.gradient(DVec2::from_array(p)).to_array(),
        lo.to_array(),
        hi.to_array(),
    )
}

/// Samples |grad d| of a 3-D geometry over the box `[lo, hi]`; see the module notes.
pub fn survey_gradient3(g: &dyn Implicit3, lo: DVec3, hi: DVec3) -> GradientSurvey {
    survey::<3>(
        &|p| g.value(DVec3::from_array(p)),
        &|p| g.gradient(DVec3::from_array(p)).to_array(),
        lo.to_array(),
        hi.to_array(),
    )
}

fn norm<const N: usize>(v: [f64; N]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn survey<const N: usize>(
    value: &dyn Fn([f64; N]) -> f64,
    grad: &dyn Fn([f64; N]) -> [f64; N],
    lo: [f64; N],
    hi: [f64; N],
) -> GradientSurvey {
    let side = SIDE[N - 2];
    let diag = norm::<N>(std::array::from_fn(|i| hi[i] - lo[i]));
    let finite = |v: f64, g: &[f64; N]| v.is_finite() && g.iter().all(|x| x.is_finite());
    // (approximate distance |d| / |grad d|, |grad d|, point), every finite grid sample.
    let mut grid: Vec<(f64, f64, [f64; N])> = Vec::with_capacity(side.pow(N as u32));
    for k in 0..side.pow(N as u32) {
        let mut r = k;
        let p: [f64; N] = std::array::from_fn(|i| {
            let j = r % side;
            r /= side;
            // Cell centres moved off the box's symmetry lines (where min and max kink).
            lo[i] + (hi[i] - lo[i]) * (j as f64 + OFFSET[i]) / side as f64
        });
        let (v, g) = (value(p), grad(p));
        if finite(v, &g) {
            let gl = norm(g);
            let a = if gl > 0.0 { v.abs() / gl } else { f64::INFINITY };
            grid.push((a, gl, p));
        }
    }
    // The samples nearest d = 0: a fifth of them, at least 32 (ties by grid order).
    grid.sort_by(|x, y| x.0.total_cmp(&y.0));
    let band = grid.len().min((grid.len() / 5).max(32));
    let mut lengths: Vec<f64> = grid[..band].iter().map(|s| s.1).collect();
    // Along first-order projections from evenly spread band samples.
    let paths = band.min(PATHS);
    for k in 0..paths {
        let mut x = grid[k * band / paths.max(1)].2;
        for _ in 0..PATH_STEPS {
            let (v, g) = (value(x), grad(x));
            if !finite(v, &g) {
                break;
            }
            let g2 = g.iter().map(|c| c * c).sum::<f64>();
            if g2.is_nan() || g2 <= 0.0 {
                break;
            }
            lengths.push(g2.sqrt());
            if v.abs() / g2.sqrt() <= 1e-9 * diag {
                break;
            }
            x = std::array::from_fn(|i| x[i] - v * g[i] / g2);
        }
    }
    let samples = lengths.len();
    let unit = lengths.iter().filter(|&&l| (l - 1.0).abs() <= UNIT_TOL).count();
    let unit_fraction = if samples == 0 { 1.0 } else { unit as f64 / samples as f64 };
    GradientSurvey {
        samples,
        grad_min: lengths.iter().copied().fold(f64::INFINITY, f64::min),
        grad_max: lengths.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        unit_fraction,
        distance: unit_fraction >= UNIT_FRACTION,
    }
}

/// A geometry with its distance-or-level-set verdict attached: the meshers wrap an undeclared
/// domain in it after [`survey_gradient2`], and `--implicit` wraps the command line's domain.
#[derive(Clone, Copy)]
pub struct Declared<'a, G: ?Sized> {
    /// The geometry.
    pub inner: &'a G,
    /// True for a signed distance, false for a level set.
    pub distance: bool,
}

impl Implicit2 for Declared<'_, dyn Implicit2 + '_> {
    fn value(&self, p: DVec2) -> f64 {
        self.inner.value(p)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        self.inner.gradient(p)
    }
    fn values(&self, ps: &[DVec2], out: &mut [f64]) {
        self.inner.values(ps, out)
    }
    fn gradients(&self, ps: &[DVec2], out: &mut [DVec2]) {
        self.inner.gradients(ps, out)
    }
    fn hessian(&self, p: DVec2) -> Option<DMat2> {
        self.inner.hessian(p)
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(self.distance)
    }
}

impl Implicit3 for Declared<'_, dyn Implicit3 + '_> {
    fn value(&self, p: DVec3) -> f64 {
        self.inner.value(p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.inner.gradient(p)
    }
    fn value_and_gradient(&self, p: DVec3) -> (f64, DVec3) {
        self.inner.value_and_gradient(p)
    }
    fn value_near(&self, p: DVec3, r: f64) -> Option<f64> {
        self.inner.value_near(p, r)
    }
    fn values(&self, ps: &[DVec3], out: &mut [f64]) {
        self.inner.values(ps, out)
    }
    fn gradients(&self, ps: &[DVec3], out: &mut [DVec3]) {
        self.inner.gradients(ps, out)
    }
    fn hessian(&self, p: DVec3) -> Option<DMat3> {
        self.inner.hessian(p)
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(self.distance)
    }
}

/// `domain` as the meshers take it: declared geometries as they are, the rest decided by
/// [`survey_gradient2`] over the box. Returns the verdict and the survey when one was taken.
pub(crate) fn decide2(domain: &dyn Implicit2, lo: DVec2, hi: DVec2) -> (bool, Option<GradientSurvey>) {
    match domain.declared_distance() {
        Some(d) => (d, None),
        None => {
            let s = survey_gradient2(domain, lo, hi);
            (s.distance, Some(s))
        }
    }
}

/// 3-D [`decide2`].
pub(crate) fn decide3(domain: &dyn Implicit3, lo: DVec3, hi: DVec3) -> (bool, Option<GradientSurvey>) {
    match domain.declared_distance() {
        Some(d) => (d, None),
        None => {
            let s = survey_gradient3(domain, lo, hi);
            (s.distance, Some(s))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Circle;

    #[test]
    fn distances_and_level_sets_told_apart() {
        let (lo, hi) = (DVec2::splat(-2.0), DVec2::splat(2.0));
        let circle = |p: DVec2| p.length() - 1.0;
        let square = |p: DVec2| (p.x.abs() - 1.0).max(p.y.abs() - 1.0);
        let ellipse = |p: DVec2| p.x * p.x / 4.0 + p.y * p.y - 1.0;
        let cubed = |p: DVec2| (p.length() - 1.0).powi(3);
        let expd = |p: DVec2| (p.length() - 1.0).exp() - 1.0;
        let x6 = |p: DVec2| p.x.powi(6) + p.y.powi(6) - 1.0;
        for (name, g, want) in [
            ("circle", &circle as &dyn Implicit2, true),
            ("square", &square, true),
            ("ellipse", &ellipse, false),
            ("d^3", &cubed, false),
            ("exp(d)-1", &expd, false),
            ("x^6+y^6-1", &x6, false),
        ] {
            let s = survey_gradient2(g, lo, hi);
            println!("{name:10} {s:?}");
            assert_eq!(s.distance, want, "{name}: {s:?}");
        }
        assert_eq!(decide2(&Circle::new([0.0, 0.0], 1.0), lo, hi), (true, None));
        let ball = |p: DVec3| p.length() - 1.0;
        let cube = |p: DVec3| p.x.abs().max(p.y.abs()).max(p.z.abs()) - 1.0;
        let blob = |p: DVec3| p.length_squared() * (1.0 + p.x * p.x) - 1.0;
        for (g, want) in [(&ball as &dyn Implicit3, true), (&cube, true), (&blob, false)] {
            let s = survey_gradient3(g, DVec3::splat(-1.5), DVec3::splat(1.5));
            assert_eq!(s.distance, want, "{s:?}");
        }
    }
}
