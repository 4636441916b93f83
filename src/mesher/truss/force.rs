//! The bar-force kernel and the rest-length scale of the truss (seed eqs. 2.5 and 2.6).

use glam::{DVec2, DVec3};
use std::ops::{Add, AddAssign, Mul, Sub, SubAssign};

/// A node position of a truss: planar (`DVec2`) or in space (`DVec3`).
pub(crate) trait TrussPoint:
    Copy
    + PartialEq
    + Send
    + Sync
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<f64, Output = Self>
    + AddAssign
    + SubAssign
{
    /// The zero vector.
    const ZERO: Self;
}

impl TrussPoint for DVec2 {
    const ZERO: Self = DVec2::ZERO;
}

impl TrussPoint for DVec3 {
    const ZERO: Self = DVec3::ZERO;
}

/// The force of one bar on the node at its end `d` away from the other end, `l = |d|` (or the
/// bar's length in a metric), rest length `l0`: seed eq. 2.5 with k = 1, repulsive only,
/// F = (l0 - l) / l along d when l < l0, else nothing (a bar never pulls).
#[inline]
pub(crate) fn bar_force<P: TrussPoint>(d: P, l: f64, l0: f64) -> P {
    if l > 0.0 && l0 > l {
        d * ((l0 - l) / l)
    } else {
        P::ZERO
    }
}

/// The sums of seed eq. 2.6 over the bars: the rest length of a bar is
/// L0 = h_bar Fscale (sum L^k / sum h_bar^k)^(1/k), k the dimension of the elements (2 for
/// triangles, in the plane or on a surface; 3 for tetrahedra), so that the bars, a little
/// longer than the mesh's own scale, push outward and fill the domain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RestScale {
    /// The element dimension k (2 or 3).
    pub k: u32,
    /// sum L^k.
    pub sum_l: f64,
    /// sum h_bar^k.
    pub sum_h: f64,
}

impl RestScale {
    /// Empty sums for elements of dimension `k` (2 or 3).
    pub(crate) fn new(k: u32) -> Self {
        debug_assert!(k == 2 || k == 3);
        RestScale { k, sum_l: 0.0, sum_h: 0.0 }
    }

    /// The terms of one bar: its squared length and its relative size h_bar.
    #[inline]
    pub(crate) fn terms(k: u32, l_squared: f64, h_bar: f64) -> (f64, f64) {
        if k == 2 {
            (l_squared, h_bar * h_bar)
        } else {
            (l_squared.sqrt().powi(3), h_bar * h_bar * h_bar)
        }
    }

    /// Adds one bar.
    #[inline]
    pub(crate) fn add(&mut self, l_squared: f64, h_bar: f64) {
        let (a, b) = Self::terms(self.k, l_squared, h_bar);
        self.sum_l += a;
        self.sum_h += b;
    }

    /// Sums already made (by [`super::det_sum`] over [`RestScale::terms`]).
    pub(crate) fn from_sums(k: u32, (sum_l, sum_h): (f64, f64)) -> Self {
        RestScale { k, sum_l, sum_h }
    }

    /// The mesh's own length per unit of relative size: (sum L^k / sum h_bar^k)^(1/k).
    pub(crate) fn unit(&self) -> f64 {
        let r = self.sum_l / self.sum_h;
        if self.k == 2 {
            r.sqrt()
        } else {
            r.cbrt()
        }
    }

    /// Fscale times [`RestScale::unit`]: a bar's rest length per unit of h_bar.
    pub(crate) fn scale(&self, fscale: f64) -> f64 {
        fscale * self.unit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bar_pushes_only_when_compressed() {
        let d = DVec2::new(0.5, 0.0);
        assert_eq!(bar_force(d, 0.5, 1.0), DVec2::new(0.5, 0.0));
        assert_eq!(bar_force(d, 0.5, 0.4), DVec2::ZERO);
        assert_eq!(bar_force(DVec3::ZERO, 0.0, 1.0), DVec3::ZERO);
    }

    #[test]
    fn the_scale_is_the_kth_root_of_the_ratio() {
        let mut s2 = RestScale::new(2);
        s2.add(4.0, 1.0);
        s2.add(4.0, 1.0);
        assert_eq!(s2.unit(), 2.0);
        assert_eq!(s2.scale(1.2), 2.4);
        let mut s3 = RestScale::new(3);
        s3.add(4.0, 1.0);
        assert!((s3.unit() - 2.0).abs() < 1e-15);
    }
}
