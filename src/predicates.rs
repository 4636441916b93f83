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

// Error bounds of the floating-point stage (Shewchuk 1997, section 4.3: o3derrboundA and
// isperrboundA), with epsilon = 2^-53.
const EPS: f64 = 1.0 / 9_007_199_254_740_992.0;
const O3D_BOUND: f64 = (7.0 + 56.0 * EPS) * EPS;
const ISP_BOUND: f64 = (16.0 + 224.0 * EPS) * EPS;

/// Positive when d lies below the plane of a, b, c, i.e. when (a, b, c, d) is a positively
/// oriented tetrahedron in the convention det[b-a, c-a, d-a] > 0.
#[inline(always)]
pub fn orient3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Sign {
    // The floating-point stage of Shewchuk's orient3d, inlined because the 3-D Delaunay kernel
    // and the step control call it in their innermost loops; undecided cases go to `robust`.
    // Shewchuk's determinant is det[a-d, b-d, c-d] = -det[b-a, c-a, d-a], hence the negations.
    let (ad, bd, cd) = (a - d, b - d, c - d);
    let (bdxcdy, cdxbdy) = (bd.x * cd.y, cd.x * bd.y);
    let (cdxady, adxcdy) = (cd.x * ad.y, ad.x * cd.y);
    let (adxbdy, bdxady) = (ad.x * bd.y, bd.x * ad.y);
    let det = ad.z * (bdxcdy - cdxbdy) + bd.z * (cdxady - adxcdy) + cd.z * (adxbdy - bdxady);
    let permanent = (bdxcdy.abs() + cdxbdy.abs()) * ad.z.abs()
        + (cdxady.abs() + adxcdy.abs()) * bd.z.abs()
        + (adxbdy.abs() + bdxady.abs()) * cd.z.abs();
    let bound = O3D_BOUND * permanent;
    // As in `insphere`: one branch the filter almost always takes, then the sign as a select.
    if det.abs() > bound {
        return if det > 0.0 { Sign::Negative } else { Sign::Positive };
    }
    orient3d_exact(a, b, c, d)
}

#[cold]
#[inline(never)]
fn orient3d_exact(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Sign {
    Sign::of(-robust::orient3d(c3(a), c3(b), c3(c), c3(d)))
}

/// Positive when e lies strictly inside the sphere through the positively oriented (a, b, c, d)
/// (orientation as in [`orient3d`]).
#[inline(always)]
pub fn insphere(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> Sign {
    // The floating-point stage of Shewchuk's insphere, inlined for the same reason as
    // `orient3d`. His sign convention is the opposite of ours (he orients the other way).
    let (ae, be, ce, de) = (a - e, b - e, c - e, d - e);
    let (aexbey, bexaey) = (ae.x * be.y, be.x * ae.y);
    let (bexcey, cexbey) = (be.x * ce.y, ce.x * be.y);
    let (cexdey, dexcey) = (ce.x * de.y, de.x * ce.y);
    let (dexaey, aexdey) = (de.x * ae.y, ae.x * de.y);
    let (aexcey, cexaey) = (ae.x * ce.y, ce.x * ae.y);
    let (bexdey, dexbey) = (be.x * de.y, de.x * be.y);
    let (ab, bc, cd, da) = (aexbey - bexaey, bexcey - cexbey, cexdey - dexcey, dexaey - aexdey);
    let (ac, bd) = (aexcey - cexaey, bexdey - dexbey);
    let abc = ae.z * bc - be.z * ac + ce.z * ab;
    let bcd = be.z * cd - ce.z * bd + de.z * bc;
    let cda = ce.z * da + de.z * ac + ae.z * cd;
    let dab = de.z * ab + ae.z * bd + be.z * da;
    let (alift, blift, clift, dlift) =
        (ae.length_squared(), be.length_squared(), ce.length_squared(), de.length_squared());
    let det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
    let (az, bz, cz, dz) = (ae.z.abs(), be.z.abs(), ce.z.abs(), de.z.abs());
    let (p_ab, p_bc, p_cd) = (aexbey.abs() + bexaey.abs(), bexcey.abs() + cexbey.abs(), cexdey.abs() + dexcey.abs());
    let (p_da, p_ac, p_bd) = (dexaey.abs() + aexdey.abs(), aexcey.abs() + cexaey.abs(), bexdey.abs() + dexbey.abs());
    let permanent = (p_cd * bz + p_bd * cz + p_bc * dz) * alift
        + (p_da * cz + p_ac * dz + p_cd * az) * blift
        + (p_ab * dz + p_bd * az + p_da * bz) * clift
        + (p_bc * az + p_ac * bz + p_ab * cz) * dlift;
    let bound = ISP_BOUND * permanent;
    // One branch that the filter almost always takes, then the sign as a select: callers that
    // compute several tests before looking at them keep them free of branches on the data.
    if det.abs() > bound {
        return if det > 0.0 { Sign::Negative } else { Sign::Positive };
    }
    insphere_exact(a, b, c, d, e)
}

#[cold]
#[inline(never)]
fn insphere_exact(a: DVec3, b: DVec3, c: DVec3, d: DVec3, e: DVec3) -> Sign {
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
