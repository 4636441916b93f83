//! Set operations on implicit functions (seed eq. 2.7-2.9) and the exact-corner correction
//! (seed eq. 2.26-2.28).
//!
//! Each type works in 2-D and 3-D: it implements [`Implicit2`] when both operands do, and
//! [`Implicit3`] likewise. Derivatives come from the active branch. The min/max forms ignore
//! "closest corners", so off a convex corner the value is a lower bound on the distance; the
//! seed meshes with it as a distance, and so `is_distance` is true when both operands are.

use super::{Implicit2, Implicit3};
use glam::{DMat2, DMat3, DVec2, DVec3};

/// A ∪ B: min(dA, dB) (seed eq. 2.7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Union<A, B> {
    /// First operand.
    pub a: A,
    /// Second operand.
    pub b: B,
}

/// A \ B: max(dA, -dB) (seed eq. 2.8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Difference<A, B> {
    /// The set kept.
    pub a: A,
    /// The set removed.
    pub b: B,
}

/// A ∩ B: max(dA, dB) (seed eq. 2.9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intersection<A, B> {
    /// First operand.
    pub a: A,
    /// Second operand.
    pub b: B,
}

/// A ∩ B with exact corners: sqrt(dA^2 + dB^2) where both are positive, else max(dA, dB)
/// (seed eq. 2.26-2.28). Exact when the two boundaries meet at right angles, as a cylinder's
/// side and cap do; elsewhere a better bound than the plain max.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExactCorners<A, B> {
    /// First operand.
    pub a: A,
    /// Second operand.
    pub b: B,
}

macro_rules! ctor {
    ($t:ident, $doc:literal) => {
        impl<A, B> $t<A, B> {
            #[doc = $doc]
            pub fn new(a: A, b: B) -> Self {
                $t { a, b }
            }
        }
    };
}
ctor!(Union, "The union of `a` and `b`.");
ctor!(Difference, "`a` with `b` cut away.");
ctor!(Intersection, "The intersection of `a` and `b`.");
ctor!(ExactCorners, "The intersection of `a` and `b` with corrected corners.");

/// The union of `a` and `b`.
pub fn union<A, B>(a: A, b: B) -> Union<A, B> {
    Union { a, b }
}
/// `a` with `b` cut away.
pub fn difference<A, B>(a: A, b: B) -> Difference<A, B> {
    Difference { a, b }
}
/// The intersection of `a` and `b`.
pub fn intersection<A, B>(a: A, b: B) -> Intersection<A, B> {
    Intersection { a, b }
}
/// The intersection of `a` and `b` with exact corners (seed eq. 2.28).
pub fn exact_corners<A, B>(a: A, b: B) -> ExactCorners<A, B> {
    ExactCorners { a, b }
}

/// Implements one trait for the three min/max combinators; `$sel` picks the branch.
macro_rules! csg_impl {
    ($tr:ident, $v:ty, $m:ty) => {
        impl<A: $tr, B: $tr> $tr for Union<A, B> {
            fn value(&self, p: $v) -> f64 {
                self.a.value(p).min(self.b.value(p))
            }
            fn gradient(&self, p: $v) -> $v {
                if self.a.value(p) <= self.b.value(p) {
                    self.a.gradient(p)
                } else {
                    self.b.gradient(p)
                }
            }
            fn hessian(&self, p: $v) -> Option<$m> {
                if self.a.value(p) <= self.b.value(p) {
                    self.a.hessian(p)
                } else {
                    self.b.hessian(p)
                }
            }
            fn declared_distance(&self) -> Option<bool> {
                both_distances(self.a.declared_distance(), self.b.declared_distance())
            }
        }

        impl<A: $tr, B: $tr> $tr for Difference<A, B> {
            fn value(&self, p: $v) -> f64 {
                self.a.value(p).max(-self.b.value(p))
            }
            fn gradient(&self, p: $v) -> $v {
                if self.a.value(p) >= -self.b.value(p) {
                    self.a.gradient(p)
                } else {
                    -self.b.gradient(p)
                }
            }
            fn hessian(&self, p: $v) -> Option<$m> {
                if self.a.value(p) >= -self.b.value(p) {
                    self.a.hessian(p)
                } else {
                    self.b.hessian(p).map(|h| -h)
                }
            }
            fn declared_distance(&self) -> Option<bool> {
                both_distances(self.a.declared_distance(), self.b.declared_distance())
            }
        }

        impl<A: $tr, B: $tr> $tr for Intersection<A, B> {
            fn value(&self, p: $v) -> f64 {
                self.a.value(p).max(self.b.value(p))
            }
            fn gradient(&self, p: $v) -> $v {
                if self.a.value(p) >= self.b.value(p) {
                    self.a.gradient(p)
                } else {
                    self.b.gradient(p)
                }
            }
            fn hessian(&self, p: $v) -> Option<$m> {
                if self.a.value(p) >= self.b.value(p) {
                    self.a.hessian(p)
                } else {
                    self.b.hessian(p)
                }
            }
            fn declared_distance(&self) -> Option<bool> {
                both_distances(self.a.declared_distance(), self.b.declared_distance())
            }
        }

        impl<A: $tr, B: $tr> $tr for ExactCorners<A, B> {
            fn value(&self, p: $v) -> f64 {
                let (da, db) = (self.a.value(p), self.b.value(p));
                if da > 0.0 && db > 0.0 {
                    da.hypot(db)
                } else {
                    da.max(db)
                }
            }
            fn gradient(&self, p: $v) -> $v {
                let (da, db) = (self.a.value(p), self.b.value(p));
                if da > 0.0 && db > 0.0 {
                    (da * self.a.gradient(p) + db * self.b.gradient(p)) / da.hypot(db)
                } else if da >= db {
                    self.a.gradient(p)
                } else {
                    self.b.gradient(p)
                }
            }
            fn hessian(&self, p: $v) -> Option<$m> {
                let (da, db) = (self.a.value(p), self.b.value(p));
                if da > 0.0 && db > 0.0 {
                    // H = (ga ga^T + da Ha + gb gb^T + db Hb - g g^T) / d with g the gradient.
                    let d = da.hypot(db);
                    let (ga, gb) = (self.a.gradient(p), self.b.gradient(p));
                    let g = (da * ga + db * gb) / d;
                    let sum =
                        outer(ga, ga) + self.a.hessian(p)? * da + outer(gb, gb) + self.b.hessian(p)? * db - outer(g, g);
                    Some(sum * (1.0 / d))
                } else if da >= db {
                    self.a.hessian(p)
                } else {
                    self.b.hessian(p)
                }
            }
            fn declared_distance(&self) -> Option<bool> {
                both_distances(self.a.declared_distance(), self.b.declared_distance())
            }
        }
    };
}

/// What a set operation of two geometries declares: a distance when both are, a level set when
/// either is, undeclared otherwise.
fn both_distances(a: Option<bool>, b: Option<bool>) -> Option<bool> {
    match (a, b) {
        (Some(false), _) | (_, Some(false)) => Some(false),
        (Some(true), Some(true)) => Some(true),
        _ => None,
    }
}

trait Outer: Sized {
    type M;
    fn outer_with(self, b: Self) -> Self::M;
}
impl Outer for DVec2 {
    type M = DMat2;
    fn outer_with(self, b: Self) -> DMat2 {
        super::primitives2::outer2(self, b)
    }
}
impl Outer for DVec3 {
    type M = DMat3;
    fn outer_with(self, b: Self) -> DMat3 {
        super::primitives3::outer3(self, b)
    }
}
#[inline]
fn outer<V: Outer>(a: V, b: V) -> V::M {
    a.outer_with(b)
}

csg_impl!(Implicit2, DVec2, DMat2);
csg_impl!(Implicit3, DVec3, DMat3);

/// A boxed planar geometry, for shapes built at run time (the expression language, trees of
/// unknown depth). Closures and references cannot get a blanket `Box` impl without clashing
/// with the closure impl, hence the newtype.
pub struct Shape2(pub Box<dyn Implicit2>);

/// A boxed solid geometry; see [`Shape2`].
pub struct Shape3(pub Box<dyn Implicit3>);

impl Shape2 {
    /// Boxes `g`.
    pub fn new(g: impl Implicit2 + 'static) -> Self {
        Shape2(Box::new(g))
    }
}
impl Shape3 {
    /// Boxes `g`.
    pub fn new(g: impl Implicit3 + 'static) -> Self {
        Shape3(Box::new(g))
    }
}

impl Implicit2 for Shape2 {
    fn value(&self, p: DVec2) -> f64 {
        self.0.value(p)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        self.0.gradient(p)
    }
    fn hessian(&self, p: DVec2) -> Option<DMat2> {
        self.0.hessian(p)
    }
    fn declared_distance(&self) -> Option<bool> {
        self.0.declared_distance()
    }
}

impl Implicit3 for Shape3 {
    fn value(&self, p: DVec3) -> f64 {
        self.0.value(p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.0.gradient(p)
    }
    fn hessian(&self, p: DVec3) -> Option<DMat3> {
        self.0.hessian(p)
    }
    fn declared_distance(&self) -> Option<bool> {
        self.0.declared_distance()
    }
}

impl std::fmt::Debug for Shape2 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Shape2(..)")
    }
}
impl std::fmt::Debug for Shape3 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Shape3(..)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::testing::{check_gradient2, check_gradient3, check_hessian3, Rng};
    use crate::geometry::{Ball, Box3, Circle, Cylinder, Rectangle};

    #[test]
    fn seed_example_2_annulus() {
        // ddiff(dcircle(0,0,1), dcircle(0,0,0.4)) = -0.3 + |0.7 - r| (SEED-EXAMPLES #2).
        let g = difference(Circle::new([0.0, 0.0], 1.0), Circle::new([0.0, 0.0], 0.4));
        let mut rng = Rng::new(11);
        for _ in 0..100 {
            let p = rng.point2(1.5);
            let want = -0.3 + (0.7 - p.length()).abs();
            assert!((g.value(p) - want).abs() < 1e-14);
            check_gradient2(&g, p, 1e-6);
        }
        assert!(g.is_distance());
    }

    #[test]
    fn union_intersection_values() {
        let a = Circle::new([-0.5, 0.0], 1.0);
        let b = Circle::new([0.5, 0.0], 1.0);
        let p = DVec2::new(-1.2, 0.0);
        assert!((union(a, b).value(p) + 0.3).abs() < 1e-15);
        assert!((intersection(a, b).value(p) - 0.7).abs() < 1e-15);
        assert_eq!(intersection(a, b).gradient(p), DVec2::new(-1.0, 0.0));
        let not_dist = union(a, |p: DVec2| p.x);
        assert!(not_dist.is_distance()); // closures default to distances
        let e = union(a, crate::geometry::Ellipse::new([0.0, 0.0], 2.0, 1.0));
        assert!(!e.is_distance());
    }

    #[test]
    fn exact_corners_match_the_cylinder_and_the_box() {
        // A cylinder as ExactCorners of the side and the slab: same as Cylinder off the rims.
        let side = |p: DVec3| p.x.hypot(p.y) - 1.0;
        let top = |p: DVec3| p.z - 1.0;
        let g = exact_corners(side, top);
        let c = Cylinder::new(1.0, -10.0, 1.0);
        let mut rng = Rng::new(5);
        for _ in 0..200 {
            let p = rng.point3(3.0);
            assert!((g.value(p) - c.value(p)).abs() < 1e-14);
            check_gradient3(&g, p, 1e-6);
        }
        // A rectangle from two strips: equal to the exact rectangle.
        let sx = |p: DVec2| p.x.abs() - 1.0;
        let sy = |p: DVec2| p.y.abs() - 0.5;
        let r = exact_corners(sx, sy);
        let exact = Rectangle::new([-1.0, -0.5], [1.0, 0.5]);
        for _ in 0..200 {
            let p = rng.point2(3.0);
            assert!((r.value(p) - exact.value(p)).abs() < 1e-14);
        }
    }

    #[test]
    fn exact_corner_hessian() {
        let g = exact_corners(Ball::new([0.0; 3], 1.0), Ball::new([1.0, 0.0, 0.0], 1.0));
        let mut rng = Rng::new(9);
        for _ in 0..100 {
            check_hessian3(&g, rng.point3(3.0), 1e-5);
        }
    }

    #[test]
    fn boxed_shapes_compose() {
        let parts: Vec<Shape3> =
            vec![Shape3::new(Ball::new([0.0; 3], 1.0)), Shape3::new(Box3::new([0.0; 3], [2.0; 3]))];
        let mut it = parts.into_iter();
        let first = it.next().unwrap();
        let u = it.fold(Shape3::new(first), |acc, s| Shape3::new(union(acc, s)));
        assert!((u.value(DVec3::new(1.5, 1.0, 1.0)) + 0.5).abs() < 1e-15);
    }
}
