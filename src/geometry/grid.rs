//! Geometries given by values on a Cartesian grid, interpolated (the seed's `dmatrix`: level-set
//! data and reinitialised distances come this way, section 2.4).
//!
//! Outside the grid the border cell's polynomial is extended, so the gradient stays non-zero
//! and projections still walk back toward the data.

use super::{Implicit2, Implicit3};
use crate::Error;
use glam::{DMat2, DMat3, DVec2, DVec3};
use rayon::prelude::*;

/// Number of samples covering `[lo, hi]` at spacing `h`; tolerant of round-off in (hi-lo)/h.
/// Nodes along an axis from `lo` at spacing `h` up to the first at or past `hi`.
pub(crate) fn count(lo: f64, hi: f64, h: f64) -> usize {
    ((hi - lo) / h - 1e-9).ceil().max(1.0) as usize + 1
}

fn check_spacing(h: f64) -> Result<(), Error> {
    if h.is_finite() && h > 0.0 {
        Ok(())
    } else {
        Err(Error::BadSize(format!("grid spacing {h} is not positive and finite")))
    }
}

/// Cell index and local coordinate along one axis: the cell is clamped, the coordinate is not.
#[inline]
fn locate(x: f64, origin: f64, h: f64, n: usize) -> (usize, f64) {
    let s = (x - origin) / h;
    let i = if s.is_nan() { 0 } else { (s.floor().max(0.0) as usize).min(n - 2) };
    (i, s - i as f64)
}

/// Values on an `nx` by `ny` grid, bilinearly interpolated.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid2 {
    origin: DVec2,
    spacing: f64,
    nx: usize,
    ny: usize,
    /// Row-major with x fastest: `values[i + nx * j]` at `origin + h (i, j)`.
    values: Vec<f64>,
    distance: bool,
}

impl Grid2 {
    /// A grid from its values (x fastest). Needs two samples per axis, a positive spacing and
    /// `nx * ny` finite values. `is_distance` defaults to true, as for the seed's `dmatrix`.
    pub fn new(origin: impl Into<DVec2>, spacing: f64, nx: usize, ny: usize, values: Vec<f64>) -> Result<Self, Error> {
        check_spacing(spacing)?;
        let origin = origin.into();
        if !origin.is_finite() {
            return Err(Error::BadBox(format!("grid origin {origin} is not finite")));
        }
        if nx < 2 || ny < 2 {
            return Err(Error::BadBox(format!("grid of {nx} x {ny} samples: need at least 2 x 2")));
        }
        if nx.checked_mul(ny) != Some(values.len()) {
            return Err(Error::BadSize(format!("grid of {nx} x {ny} samples given {} values", values.len())));
        }
        if let Some(&v) = values.iter().find(|v| !v.is_finite()) {
            return Err(Error::NonFinite { what: "grid value", value: v, at: [origin.x, origin.y, 0.0] });
        }
        Ok(Grid2 { origin, spacing, nx, ny, values, distance: true })
    }

    /// Samples `f` at spacing `h` on a grid from `min` covering `max` (seed example 1: the
    /// circle sampled at 0.1 on [-1.1, 1.1]^2). Keeps `f`'s `is_distance`.
    pub fn sample(f: &dyn Implicit2, min: impl Into<DVec2>, max: impl Into<DVec2>, h: f64) -> Result<Self, Error> {
        check_spacing(h)?;
        let (min, max) = (min.into(), max.into());
        if !(min.is_finite() && max.is_finite() && min.cmplt(max).all()) {
            return Err(Error::BadBox(format!("grid box {min} .. {max}")));
        }
        let (nx, ny) = (count(min.x, max.x, h), count(min.y, max.y, h));
        // A row at a time, rows in parallel: each value is the function's own at its node, so
        // the grid is the same for any thread count.
        let mut values = vec![0.0; nx * ny];
        values.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            let ps: Vec<DVec2> = (0..nx).map(|i| min + h * DVec2::new(i as f64, j as f64)).collect();
            f.values(&ps, row);
        });
        let mut g = Grid2::new(min, h, nx, ny, values)?;
        g.distance = f.is_distance();
        Ok(g)
    }

    /// Sets what [`Implicit2::is_distance`] reports.
    pub fn with_distance(mut self, is_distance: bool) -> Self {
        self.distance = is_distance;
        self
    }
    /// Samples per axis.
    pub fn dims(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }
    /// The lower-left sample's position.
    pub fn origin(&self) -> DVec2 {
        self.origin
    }
    /// The spacing.
    pub fn spacing(&self) -> f64 {
        self.spacing
    }
    /// The samples, x fastest.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The four corner values of the cell and the local coordinates in it.
    #[inline]
    fn cell(&self, p: DVec2) -> ([f64; 4], f64, f64) {
        let (i, s) = locate(p.x, self.origin.x, self.spacing, self.nx);
        let (j, t) = locate(p.y, self.origin.y, self.spacing, self.ny);
        let k = i + self.nx * j;
        let v = &self.values;
        ([v[k], v[k + 1], v[k + self.nx], v[k + self.nx + 1]], s, t)
    }
}

impl Implicit2 for Grid2 {
    fn value(&self, p: DVec2) -> f64 {
        let ([v00, v10, v01, v11], s, t) = self.cell(p);
        (1.0 - t) * ((1.0 - s) * v00 + s * v10) + t * ((1.0 - s) * v01 + s * v11)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        let ([v00, v10, v01, v11], s, t) = self.cell(p);
        DVec2::new((1.0 - t) * (v10 - v00) + t * (v11 - v01), (1.0 - s) * (v01 - v00) + s * (v11 - v10)) / self.spacing
    }
    /// The interpolant's own Hessian: only the cross term is non-zero.
    fn hessian(&self, p: DVec2) -> Option<DMat2> {
        let ([v00, v10, v01, v11], _, _) = self.cell(p);
        let c = (v11 - v10 - v01 + v00) / (self.spacing * self.spacing);
        Some(DMat2::from_cols(DVec2::new(0.0, c), DVec2::new(c, 0.0)))
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(self.distance)
    }
}

/// Values on an `nx` by `ny` by `nz` grid, trilinearly interpolated.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid3 {
    origin: DVec3,
    spacing: f64,
    n: [usize; 3],
    /// x fastest, then y: `values[i + nx * (j + ny * k)]`.
    values: Vec<f64>,
    distance: bool,
}

impl Grid3 {
    /// A grid from its values (x fastest, then y); see [`Grid2::new`].
    pub fn new(origin: impl Into<DVec3>, spacing: f64, n: [usize; 3], values: Vec<f64>) -> Result<Self, Error> {
        check_spacing(spacing)?;
        let origin = origin.into();
        if !origin.is_finite() {
            return Err(Error::BadBox(format!("grid origin {origin} is not finite")));
        }
        if n.iter().any(|&k| k < 2) {
            return Err(Error::BadBox(format!("grid of {n:?} samples: need at least 2 per axis")));
        }
        let total = n[0].checked_mul(n[1]).and_then(|m| m.checked_mul(n[2]));
        if total != Some(values.len()) {
            return Err(Error::BadSize(format!("grid of {n:?} samples given {} values", values.len())));
        }
        if let Some(&v) = values.iter().find(|v| !v.is_finite()) {
            return Err(Error::NonFinite { what: "grid value", value: v, at: origin.to_array() });
        }
        Ok(Grid3 { origin, spacing, n, values, distance: true })
    }

    /// Samples `f` at spacing `h` on a grid from `min` covering `max`.
    pub fn sample(f: &dyn Implicit3, min: impl Into<DVec3>, max: impl Into<DVec3>, h: f64) -> Result<Self, Error> {
        check_spacing(h)?;
        let (min, max) = (min.into(), max.into());
        if !(min.is_finite() && max.is_finite() && min.cmplt(max).all()) {
            return Err(Error::BadBox(format!("grid box {min} .. {max}")));
        }
        let n = [count(min.x, max.x, h), count(min.y, max.y, h), count(min.z, max.z, h)];
        // A row at a time, rows in parallel (see [`Grid2::sample`]).
        let total = n[0].checked_mul(n[1]).and_then(|m| m.checked_mul(n[2]));
        let Some(total) = total else { return Err(Error::BadBox(format!("grid of {n:?} samples"))) };
        let mut values = vec![0.0; total];
        values.par_chunks_mut(n[0]).enumerate().for_each(|(r, row)| {
            let (j, k) = (r % n[1], r / n[1]);
            let ps: Vec<DVec3> = (0..n[0]).map(|i| min + h * DVec3::new(i as f64, j as f64, k as f64)).collect();
            f.values(&ps, row);
        });
        let mut g = Grid3::new(min, h, n, values)?;
        g.distance = f.is_distance();
        Ok(g)
    }

    /// Sets what [`Implicit3::is_distance`] reports.
    pub fn with_distance(mut self, is_distance: bool) -> Self {
        self.distance = is_distance;
        self
    }
    /// Samples per axis.
    pub fn dims(&self) -> [usize; 3] {
        self.n
    }
    /// The lowest sample's position.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }
    /// The spacing.
    pub fn spacing(&self) -> f64 {
        self.spacing
    }
    /// The samples, x fastest.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The eight corner values (bit 0 = x, bit 1 = y, bit 2 = z) and local coordinates.
    #[inline]
    fn cell(&self, p: DVec3) -> ([f64; 8], DVec3) {
        let (i, s) = locate(p.x, self.origin.x, self.spacing, self.n[0]);
        let (j, t) = locate(p.y, self.origin.y, self.spacing, self.n[1]);
        let (k, u) = locate(p.z, self.origin.z, self.spacing, self.n[2]);
        let (nx, nxy) = (self.n[0], self.n[0] * self.n[1]);
        let base = i + nx * j + nxy * k;
        let mut c = [0.0; 8];
        for (b, cb) in c.iter_mut().enumerate() {
            *cb = self.values[base + (b & 1) + nx * ((b >> 1) & 1) + nxy * (b >> 2)];
        }
        (c, DVec3::new(s, t, u))
    }
}

/// Trilinear weights' factors along one axis for corner bit `on` at local coordinate `s`.
#[inline]
fn w(on: bool, s: f64) -> f64 {
    if on {
        s
    } else {
        1.0 - s
    }
}
#[inline]
fn dw(on: bool) -> f64 {
    if on {
        1.0
    } else {
        -1.0
    }
}

impl Implicit3 for Grid3 {
    fn value(&self, p: DVec3) -> f64 {
        let (c, l) = self.cell(p);
        (0..8).map(|b| c[b] * w(b & 1 != 0, l.x) * w(b & 2 != 0, l.y) * w(b & 4 != 0, l.z)).sum()
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let (c, l) = self.cell(p);
        let mut g = DVec3::ZERO;
        for (b, &v) in c.iter().enumerate() {
            let (bx, by, bz) = (b & 1 != 0, b & 2 != 0, b & 4 != 0);
            g += v * DVec3::new(
                dw(bx) * w(by, l.y) * w(bz, l.z),
                w(bx, l.x) * dw(by) * w(bz, l.z),
                w(bx, l.x) * w(by, l.y) * dw(bz),
            );
        }
        g / self.spacing
    }
    /// The interpolant's own Hessian (zero diagonal).
    fn hessian(&self, p: DVec3) -> Option<DMat3> {
        let (c, l) = self.cell(p);
        let (mut hxy, mut hxz, mut hyz) = (0.0, 0.0, 0.0);
        for (b, &v) in c.iter().enumerate() {
            let (bx, by, bz) = (b & 1 != 0, b & 2 != 0, b & 4 != 0);
            hxy += v * dw(bx) * dw(by) * w(bz, l.z);
            hxz += v * dw(bx) * w(by, l.y) * dw(bz);
            hyz += v * w(bx, l.x) * dw(by) * dw(bz);
        }
        let h2 = self.spacing * self.spacing;
        Some(
            DMat3::from_cols(DVec3::new(0.0, hxy, hxz), DVec3::new(hxy, 0.0, hyz), DVec3::new(hxz, hyz, 0.0))
                * (1.0 / h2),
        )
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(self.distance)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::testing::{check_gradient2, check_gradient3, check_hessian2, check_hessian3, Rng};
    use crate::geometry::{Ball, Circle};

    #[test]
    fn seed_example_1_grid_circle() {
        let c = Circle::new([0.0, 0.0], 1.0);
        let g = Grid2::sample(&c, [-1.1, -1.1], [1.1, 1.1], 0.1).unwrap();
        assert_eq!(g.dims(), (23, 23));
        assert!(g.is_distance());
        // Exact at the nodes, close in between (the error is O(h^2 / r)).
        assert!((g.value(DVec2::new(0.5, -0.3)) - c.value(DVec2::new(0.5, -0.3))).abs() < 1e-14);
        let mut rng = Rng::new(1);
        for _ in 0..500 {
            let p = rng.point2(1.1);
            if p.length() > 0.3 {
                assert!((g.value(p) - c.value(p)).abs() < 5e-3, "at {p}");
            }
        }
    }

    #[test]
    fn bilinear_and_trilinear_derivatives() {
        let e = |p: DVec2| p.x * p.x + 2.0 * p.y * p.y - 1.0;
        let g = Grid2::sample(&e, [-2.0, -2.0], [2.0, 2.0], 0.25).unwrap().with_distance(false);
        let b = Ball::new([0.1, 0.0, -0.1], 0.8);
        let g3 = Grid3::sample(&b, [-1.0; 3], [1.0; 3], 0.2).unwrap().with_distance(false);
        let mut rng = Rng::new(2);
        for _ in 0..300 {
            let p = rng.point2(2.5); // includes extrapolation outside the box
            check_gradient2(&g, p, 1e-6);
            check_hessian2(&g, p, 1e-5);
            let q = rng.point3(1.2);
            check_gradient3(&g3, q, 1e-6);
            check_hessian3(&g3, q, 1e-5);
        }
        // Bilinear data is reproduced exactly.
        let bl = |p: DVec2| 1.0 + 2.0 * p.x - p.y + 0.5 * p.x * p.y;
        let g = Grid2::sample(&bl, [0.0, 0.0], [1.0, 1.0], 0.5).unwrap();
        let p = DVec2::new(0.3, 0.8);
        assert!((g.value(p) - bl(p)).abs() < 1e-14);
    }

    #[test]
    fn bad_grids_are_errors() {
        assert!(Grid2::new([0.0, 0.0], 0.1, 2, 2, vec![0.0; 3]).is_err());
        assert!(Grid2::new([0.0, 0.0], 0.0, 2, 2, vec![0.0; 4]).is_err());
        assert!(Grid2::new([0.0, 0.0], 0.1, 1, 4, vec![0.0; 4]).is_err());
        assert!(Grid2::new([0.0, 0.0], 0.1, 2, 2, vec![0.0, f64::NAN, 0.0, 0.0]).is_err());
        assert!(Grid3::new([0.0; 3], 0.1, [2, 2, 2], vec![0.0; 7]).is_err());
        let c = Circle::new([0.0, 0.0], 1.0);
        assert!(Grid2::sample(&c, [1.0, 0.0], [0.0, 1.0], 0.1).is_err());
    }
}
