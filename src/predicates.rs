//! Exact geometric predicates (Shewchuk 1997, through the `robust` crate), returning [`Sign`].
//!
//! Raw determinants never leave this module: validity decisions are made on exact signs only.
//! Floating-point quality measures choose among valid moves but never decide validity.

use glam::{DVec2, DVec3};

/// The exact sign of a determinant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Sign {
    /// Strictly negative.
    Negative,
    /// Exactly zero (degenerate).
    Zero,
    /// Strictly positive.
    Positive,
}

impl Sign {
    #[inline]
    fn of(x: f64) -> Sign {
        if x > 0.0 {
            Sign::Positive
        } else if x < 0.0 {
            Sign::Negative
        } else {
            Sign::Zero
        }
    }
    /// True for [`Sign::Positive`].
    #[inline]
    pub fn is_positive(self) -> bool {
        self == Sign::Positive
    }
}

#[inline]
fn c2(p: DVec2) -> robust::Coord<f64> {
    robust::Coord { x: p.x, y: p.y }
}
#[inline]
fn c3(p: DVec3) -> robust::Coord3D<f64> {
    robust::Coord3D { x: p.x, y: p.y, z: p.z }
}

/// Positive when a, b, c turn counter-clockwise; zero when collinear.
#[inline]
pub fn orient2d(a: DVec2, b: DVec2, c: DVec2) -> Sign {
    Sign::of(robust::orient2d(c2(a), c2(b), c2(c)))
}

/// Positive when d lies strictly inside the circle through the counter-clockwise a, b, c.
/// Zero (cocircular) means "legal, do not flip" to the Lawson loop, which then terminates.
#[inline]
pub fn incircle(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> Sign {
    Sign::of(robust::incircle(c2(a), c2(b), c2(c), c2(d)))
}

/// Positive when d lies below the plane of a, b, c, i.e. when (a, b, c, d) is a positively
/// oriented tetrahedron in the convention det[b-a, c-a, d-a] > 0.
#[inline]
pub fn orient3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Sign {
    // robust's orient3d is positive when d is below the plane (a, b, c seen counter-clockwise
    // from above), which is det[a-d, b-d, c-d] > 0 = -det[b-a, c-a, d-a]; flip it.
    Sign::of(-robust::orient3d(c3(a), c3(b), c3(c), c3(d)))
}

/// Positive when e lies strictly inside the sphere through the positively oriented (a, b, c, d)
/// (orientation as in [`orient3d`]).
#[inline]
pub fn insphere(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> Sign {
    // robust's insphere is positive inside for its own orientation convention, which is the
    // opposite of ours, so negate.
    Sign::of(-robust::insphere(c3(a), c3(b), c3(c), c3(d), c3(e)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orient2d_signs() {
        let a = DVec2::new(0.0, 0.0);
        let b = DVec2::new(1.0, 0.0);
        assert_eq!(orient2d(a, b, DVec2::new(0.0, 1.0)), Sign::Positive);
        assert_eq!(orient2d(a, b, DVec2::new(0.0, -1.0)), Sign::Negative);
        assert_eq!(orient2d(a, b, DVec2::new(3.0, 0.0)), Sign::Zero);
        // Nearly collinear points where naive floating point gets the sign wrong.
        let p = DVec2::new(0.5, 0.5);
        let q = DVec2::new(12.0, 12.0);
        let r = DVec2::new(24.0, 24.0);
        assert_eq!(orient2d(p, q, r), Sign::Zero);
    }

    #[test]
    fn incircle_signs() {
        let a = DVec2::new(1.0, 0.0);
        let b = DVec2::new(0.0, 1.0);
        let c = DVec2::new(-1.0, 0.0);
        assert_eq!(incircle(a, b, c, DVec2::ZERO), Sign::Positive);
        assert_eq!(incircle(a, b, c, DVec2::new(0.0, -1.0)), Sign::Zero);
        assert_eq!(incircle(a, b, c, DVec2::new(0.0, -2.0)), Sign::Negative);
    }

    #[test]
    fn orient3d_and_insphere_signs() {
        let a = DVec3::new(0.0, 0.0, 0.0);
        let b = DVec3::new(1.0, 0.0, 0.0);
        let c = DVec3::new(0.0, 1.0, 0.0);
        let d = DVec3::new(0.0, 0.0, 1.0);
        // det[b-a, c-a, d-a] = 1 > 0
        assert_eq!(orient3d(a, b, c, d), Sign::Positive);
        assert_eq!(orient3d(a, c, b, d), Sign::Negative);
        assert_eq!(orient3d(a, b, c, DVec3::new(1.0, 1.0, 0.0)), Sign::Zero);
        let inside = DVec3::new(0.25, 0.25, 0.25);
        let outside = DVec3::new(2.0, 2.0, 2.0);
        assert_eq!(insphere(a, b, c, d, inside), Sign::Positive);
        assert_eq!(insphere(a, b, c, d, outside), Sign::Negative);
        assert_eq!(insphere(a, b, c, d, DVec3::new(1.0, 1.0, 0.0)), Sign::Zero);
    }
}
