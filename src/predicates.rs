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

/// Positive when the normal (b - a) x (c - a) of the triangle (a, b, c) points along `dir`,
/// i.e. the sign of det[b - a, c - a, dir]: [`orient3d`] with its fourth point at infinity in
/// the direction `dir`. Zero when the triangle is degenerate or its plane holds `dir`, and for
/// non-finite input. Exact (barring overflow and underflow), like the others.
#[inline]
pub fn orient3d_dir(a: DVec3, b: DVec3, c: DVec3, dir: DVec3) -> Sign {
    // The floating-point stage: the normal and its dot product with dir, with orient3d's error
    // bound (here only two columns are rounded differences, so it holds with room to spare).
    let (u, v) = (b - a, c - a);
    let det = u.cross(v).dot(dir);
    let permanent = (u.y * v.z).abs() * dir.x.abs()
        + (v.y * u.z).abs() * dir.x.abs()
        + ((u.z * v.x).abs() + (v.z * u.x).abs()) * dir.y.abs()
        + ((u.x * v.y).abs() + (v.x * u.y).abs()) * dir.z.abs();
    if det.is_nan() {
        return Sign::Zero;
    }
    if det.abs() > O3D_BOUND * permanent {
        return if det > 0.0 { Sign::Positive } else { Sign::Negative };
    }
    orient3d_dir_exact(a, b, c, dir)
}

/// [`orient3d_dir`] exactly: det[b - a, c - a, d] = det[b, c, d] + det[a, b, d] + det[c, a, d]
/// (multilinearity), each a sum of six products of three coordinates, summed as an expansion.
#[cold]
#[inline(never)]
fn orient3d_dir_exact(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Sign {
    if ![a, b, c, d].iter().all(|p| p.is_finite()) {
        return Sign::Zero;
    }
    let mut sum = Expansion::default();
    for (x, y) in [(b, c), (a, b), (c, a)] {
        // det[x, y, d] = x . (y x d)
        for (s, p, q, r) in [
            (1.0, x.x, y.y, d.z),
            (-1.0, x.x, y.z, d.y),
            (1.0, x.y, y.z, d.x),
            (-1.0, x.y, y.x, d.z),
            (1.0, x.z, y.x, d.y),
            (-1.0, x.z, y.y, d.x),
        ] {
            // p q r = (h + l) r exactly, each of h r and l r as two doubles.
            let (h, l) = two_product(s * p, q);
            let (h1, l1) = two_product(h, r);
            let (h2, l2) = two_product(l, r);
            for t in [l2, h2, l1, h1] {
                sum.add(t);
            }
        }
    }
    sum.sign()
}

/// x + y = a + b exactly, x = fl(a + b) (Knuth's two-sum).
#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let x = a + b;
    let bv = x - a;
    let av = x - bv;
    (x, (a - av) + (b - bv))
}

/// x + y = a b exactly, x = fl(a b): the fused multiply-add rounds only once, so it returns
/// the product's rounding error (exact unless it underflows).
#[inline]
fn two_product(a: f64, b: f64) -> (f64, f64) {
    let x = a * b;
    (x, a.mul_add(b, -x))
}

/// A sum of doubles held exactly as non-overlapping components of increasing magnitude, none
/// zero (Shewchuk 1997, section 2: grow-expansion with zero elimination).
#[derive(Default)]
struct Expansion {
    parts: Vec<f64>,
}

impl Expansion {
    fn add(&mut self, b: f64) {
        let mut q = b;
        let mut k = 0;
        for i in 0..self.parts.len() {
            let (s, h) = two_sum(q, self.parts[i]);
            q = s;
            if h != 0.0 {
                self.parts[k] = h;
                k += 1;
            }
        }
        self.parts.truncate(k);
        if q != 0.0 {
            self.parts.push(q);
        }
    }
    /// The sign of the sum: that of its largest component.
    fn sign(&self) -> Sign {
        self.parts.last().map_or(Sign::Zero, |&x| Sign::of(x))
    }
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
    fn orient3d_dir_is_exact() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        assert_eq!(orient3d_dir(a, b, c, DVec3::Z), Sign::Positive);
        assert_eq!(orient3d_dir(a, c, b, DVec3::Z), Sign::Negative);
        assert_eq!(orient3d_dir(a, b, c, DVec3::new(1.0, 2.0, 0.0)), Sign::Zero);
        assert_eq!(orient3d_dir(a, b, c, DVec3::new(0.0, 0.0, f64::NAN)), Sign::Zero);
        // Integer coordinates, exact in doubles, with dir = 2^20 u + w for u = b - a: the
        // determinant is det[u, v, w], tiny next to the terms, and zero for w = 0.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |bits: u32| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) % (1u64 << bits)) as i64 - (1i64 << (bits - 1))
        };
        let mut float_wrong = 0;
        for _ in 0..2000 {
            let a = [next(30), next(30), next(30)];
            let u = [next(30), next(30), next(30)];
            let v = [next(30), next(30), next(30)];
            let w = [next(2), next(2), next(2)];
            let d = [0, 1, 2].map(|k| (u[k] << 20) + w[k]);
            let det = |x: [i64; 3], y: [i64; 3], z: [i64; 3]| {
                let (x, y, z) = (x.map(i128::from), y.map(i128::from), z.map(i128::from));
                x[0] * (y[1] * z[2] - y[2] * z[1]) - x[1] * (y[0] * z[2] - y[2] * z[0])
                    + x[2] * (y[0] * z[1] - y[1] * z[0])
            };
            let want = det(u, v, w).signum();
            let p = |x: [i64; 3]| DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64);
            let pa = p(a);
            let (pb, pc) = (pa + p(u), pa + p(v));
            let got = match orient3d_dir(pa, pb, pc, p(d)) {
                Sign::Positive => 1,
                Sign::Zero => 0,
                Sign::Negative => -1,
            };
            assert_eq!(got, want, "a {a:?} u {u:?} v {v:?} w {w:?}");
            let naive = (pb - pa).cross(pc - pa).dot(p(d));
            float_wrong += usize::from((naive > 0.0) as i128 - (naive < 0.0) as i128 != want);
        }
        // The cases are hard enough that floating point alone gets some wrong.
        assert!(float_wrong > 0);
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
