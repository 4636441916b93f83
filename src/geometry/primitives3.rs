//! Solid primitives: ball, box (exact and cheap), cylinder with exact corners (seed eq. 2.22-2.28).

use super::Implicit3;
use glam::{DMat3, DVec3};

#[inline]
fn unit_or(v: DVec3, fallback: DVec3) -> DVec3 {
    let l = v.length();
    if l > 0.0 {
        v / l
    } else {
        fallback
    }
}

/// Outer product a b^T.
#[inline]
pub(crate) fn outer3(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// A ball: d = |p - c| - r, an exact signed distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ball {
    /// Centre.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
}

impl Ball {
    /// The ball of radius `r` about `center`.
    pub fn new(center: impl Into<DVec3>, r: f64) -> Self {
        Ball { center: center.into(), radius: r }
    }
}

impl Implicit3 for Ball {
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
    fn value(&self, p: DVec3) -> f64 {
        (p - self.center).length() - self.radius
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        unit_or(p - self.center, DVec3::X)
    }
    /// (I - n n^T) / |p - c|; undefined at the centre.
    fn hessian(&self, p: DVec3) -> Option<DMat3> {
        let v = p - self.center;
        let l = v.length();
        if l == 0.0 {
            return None;
        }
        let n = v / l;
        Some((DMat3::IDENTITY - outer3(n, n)) * (1.0 / l))
    }
}

/// An axis-aligned box; exact (rounded about edges and corners outside) or the cheap max over
/// the six face planes, the 3-D `drectangle`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Box3 {
    /// Lowest corner.
    pub min: DVec3,
    /// Highest corner.
    pub max: DVec3,
    /// True for the max-form.
    pub cheap: bool,
}

impl Box3 {
    /// Exact signed distance to `[min, max]`.
    pub fn new(min: impl Into<DVec3>, max: impl Into<DVec3>) -> Self {
        Box3 { min: min.into(), max: max.into(), cheap: false }
    }
    /// Max over the six face planes: exact inside and off faces, too small off edges and corners.
    pub fn cheap(min: impl Into<DVec3>, max: impl Into<DVec3>) -> Self {
        Box3 { cheap: true, ..Box3::new(min, max) }
    }
    #[inline]
    fn slabs(&self, p: DVec3) -> (DVec3, DVec3) {
        let rel = p - 0.5 * (self.min + self.max);
        let half = 0.5 * (self.max - self.min);
        let sign = DVec3::select(rel.cmplt(DVec3::ZERO), -DVec3::ONE, DVec3::ONE);
        (rel.abs() - half, sign)
    }
}

/// The unit axis of the largest component of `q`, signed by `s`.
#[inline]
fn max_axis(q: DVec3, s: DVec3) -> DVec3 {
    let i = if q.x >= q.y && q.x >= q.z {
        0
    } else if q.y >= q.z {
        1
    } else {
        2
    };
    let mut e = DVec3::ZERO;
    e[i] = s[i];
    e
}

impl Implicit3 for Box3 {
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
    fn value(&self, p: DVec3) -> f64 {
        let (q, _) = self.slabs(p);
        if self.cheap {
            return q.max_element();
        }
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let (q, s) = self.slabs(p);
        let out = q.max(DVec3::ZERO);
        if !self.cheap && out != DVec3::ZERO {
            return out.normalize() * s;
        }
        max_axis(q, s)
    }
}

/// The cylinder x^2 + y^2 <= r^2, z0 <= z <= z1 with the seed's exact corners (eq. 2.26-2.28):
/// max(d1, d2, d3) with d1 = sqrt(x^2+y^2) - r, d2 = z - z1, d3 = z0 - z, replaced by the norm
/// of the two positive ones off the rims, so the value is the true signed distance everywhere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    /// Radius.
    pub radius: f64,
    /// Bottom.
    pub z0: f64,
    /// Top.
    pub z1: f64,
}

impl Cylinder {
    /// The cylinder of `radius` about the z axis between `z0` and `z1`.
    pub fn new(radius: f64, z0: f64, z1: f64) -> Self {
        Cylinder { radius, z0, z1 }
    }
    /// The three distances and the radial unit vector.
    #[inline]
    fn parts(&self, p: DVec3) -> (f64, f64, f64, DVec3) {
        let rho = p.x.hypot(p.y);
        let radial = if rho > 0.0 { DVec3::new(p.x / rho, p.y / rho, 0.0) } else { DVec3::X };
        (rho - self.radius, p.z - self.z1, self.z0 - p.z, radial)
    }
}

impl Implicit3 for Cylinder {
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
    fn value(&self, p: DVec3) -> f64 {
        let (d1, d2, d3, _) = self.parts(p);
        if d1 > 0.0 && d2 > 0.0 {
            d1.hypot(d2) // seed eq. 2.26
        } else if d1 > 0.0 && d3 > 0.0 {
            d1.hypot(d3) // seed eq. 2.27
        } else {
            d1.max(d2).max(d3) // seed eq. 2.25
        }
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let (d1, d2, d3, radial) = self.parts(p);
        if d1 > 0.0 && d2 > 0.0 {
            (d1 * radial + d2 * DVec3::Z) / d1.hypot(d2)
        } else if d1 > 0.0 && d3 > 0.0 {
            (d1 * radial - d3 * DVec3::Z) / d1.hypot(d3)
        } else if d1 >= d2 && d1 >= d3 {
            radial
        } else if d2 >= d3 {
            DVec3::Z
        } else {
            -DVec3::Z
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::testing::{check_gradient3, check_hessian3, Rng};

    #[test]
    fn ball_and_box_distances() {
        let b = Ball::new([1.0, 0.0, 0.0], 2.0);
        assert!((b.value(DVec3::new(1.0, 0.0, 0.0)) + 2.0).abs() < 1e-15);
        assert!((b.value(DVec3::new(1.0, 3.0, 4.0)) - 3.0).abs() < 1e-15);
        let x = Box3::new([0.0; 3], [1.0, 2.0, 3.0]);
        let k = Box3::cheap([0.0; 3], [1.0, 2.0, 3.0]);
        let inside = DVec3::new(0.5, 0.4, 1.0);
        assert!((x.value(inside) + 0.4).abs() < 1e-15);
        assert!((k.value(inside) + 0.4).abs() < 1e-15);
        let corner = DVec3::new(2.0, 4.0, 5.0); // offsets 1, 2, 2 from (1, 2, 3)
        assert!((x.value(corner) - 3.0).abs() < 1e-14);
        assert!((k.value(corner) - 2.0).abs() < 1e-14);
    }

    #[test]
    fn cylinder_exact_corners() {
        let c = Cylinder::new(1.0, -1.0, 1.0);
        // Inside: nearest of side, top, bottom.
        assert!((c.value(DVec3::new(0.0, 0.0, 0.0)) + 1.0).abs() < 1e-15);
        assert!((c.value(DVec3::new(0.0, 0.5, 0.8)) + 0.2).abs() < 1e-15);
        // Off the side, off the top: plain distances.
        assert!((c.value(DVec3::new(3.0, 0.0, 0.5)) - 2.0).abs() < 1e-15);
        assert!((c.value(DVec3::new(0.3, 0.2, 2.5)) - 1.5).abs() < 1e-15);
        // Off the top rim: distance to the rim circle (eq. 2.26), not the max (eq. 2.25).
        let p = DVec3::new(0.0, 4.0, 5.0); // 3 out, 4 up
        assert!((c.value(p) - 5.0).abs() < 1e-14);
        // Off the bottom rim (eq. 2.27).
        let p = DVec3::new(-1.6, -1.2, -5.0); // rho = 2: 1 out, 4 down
        assert!((c.value(p) - 17f64.sqrt()).abs() < 1e-14);
        // Brute force: distance to sampled rim points never beats the value.
        let mut rng = Rng::new(7);
        for _ in 0..200 {
            let p = rng.point3(3.0);
            let v = c.value(p);
            if v > 0.0 {
                for k in 0..64 {
                    let a = std::f64::consts::TAU * k as f64 / 64.0;
                    for z in [-1.0, 1.0] {
                        let q = DVec3::new(a.cos(), a.sin(), z);
                        assert!(v <= (p - q).length() + 1e-12);
                    }
                }
            }
        }
    }

    #[test]
    fn gradients_match_finite_differences() {
        let mut rng = Rng::new(0x3d_5eed);
        let shapes: Vec<Box<dyn Implicit3>> = vec![
            Box::new(Ball::new([0.3, -0.2, 0.1], 0.8)),
            Box::new(Box3::new([-1.0, -0.5, -0.2], [1.0, 0.7, 0.9])),
            Box::new(Box3::cheap([-1.0, -0.5, -0.2], [1.0, 0.7, 0.9])),
            Box::new(Cylinder::new(0.7, -0.5, 1.0)),
        ];
        for g in &shapes {
            let mut checked = 0;
            for _ in 0..300 {
                let p = rng.point3(3.0);
                checked += check_gradient3(g.as_ref(), p, 1e-6) as usize;
                check_hessian3(g.as_ref(), p, 1e-5);
            }
            assert!(checked > 250);
        }
    }
}
