//! Rigid motions and uniform scaling, the seed's `pshift` and `protate` applied to the geometry
//! instead of the points: all three keep a distance a distance.

use super::{Implicit2, Implicit3};
use glam::{DMat2, DMat3, DVec2, DVec3};

/// The shape moved by `offset`: d(p - offset). `V` is `DVec2` or `DVec3`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Translate<G, V> {
    /// The shape before the move.
    pub inner: G,
    /// The displacement.
    pub offset: V,
}

impl<G, V> Translate<G, V> {
    /// `inner` moved by `offset`.
    pub fn new(inner: G, offset: V) -> Self {
        Translate { inner, offset }
    }
}

impl<G: Implicit2> Implicit2 for Translate<G, DVec2> {
    fn value(&self, p: DVec2) -> f64 {
        self.inner.value(p - self.offset)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        self.inner.gradient(p - self.offset)
    }
    fn hessian(&self, p: DVec2) -> Option<DMat2> {
        self.inner.hessian(p - self.offset)
    }
    fn declared_distance(&self) -> Option<bool> {
        self.inner.declared_distance()
    }
}

impl<G: Implicit3> Implicit3 for Translate<G, DVec3> {
    fn value(&self, p: DVec3) -> f64 {
        self.inner.value(p - self.offset)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.inner.gradient(p - self.offset)
    }
    fn hessian(&self, p: DVec3) -> Option<DMat3> {
        self.inner.hessian(p - self.offset)
    }
    fn declared_distance(&self) -> Option<bool> {
        self.inner.declared_distance()
    }
}

/// The shape rotated about the origin by `rotation` (`DMat2` or `DMat3`, orthonormal):
/// d(R^T p), gradient R grad d, Hessian R H R^T.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rotate<G, M> {
    /// The shape before the rotation.
    pub inner: G,
    /// The rotation matrix R; it must be orthonormal, or distances are not kept.
    pub rotation: M,
}

impl<G> Rotate<G, DMat2> {
    /// `inner` turned counter-clockwise by `angle` radians about the origin.
    pub fn new(inner: G, angle: f64) -> Self {
        Rotate { inner, rotation: DMat2::from_angle(angle) }
    }
}

impl<G> Rotate<G, DMat3> {
    /// `inner` rotated by the orthonormal matrix `rotation`.
    pub fn from_matrix(inner: G, rotation: DMat3) -> Self {
        Rotate { inner, rotation }
    }
    /// `inner` rotated by `angle` radians about `axis` (normalised here; zero axis means no turn).
    pub fn axis_angle(inner: G, axis: impl Into<DVec3>, angle: f64) -> Self {
        let axis = axis.into().normalize_or_zero();
        let rotation = if axis == DVec3::ZERO { DMat3::IDENTITY } else { DMat3::from_axis_angle(axis, angle) };
        Rotate { inner, rotation }
    }
}

impl<G: Implicit2> Implicit2 for Rotate<G, DMat2> {
    fn value(&self, p: DVec2) -> f64 {
        self.inner.value(self.rotation.transpose() * p)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        self.rotation * self.inner.gradient(self.rotation.transpose() * p)
    }
    fn hessian(&self, p: DVec2) -> Option<DMat2> {
        let r = self.rotation;
        Some(r * self.inner.hessian(r.transpose() * p)? * r.transpose())
    }
    fn declared_distance(&self) -> Option<bool> {
        self.inner.declared_distance()
    }
}

impl<G: Implicit3> Implicit3 for Rotate<G, DMat3> {
    fn value(&self, p: DVec3) -> f64 {
        self.inner.value(self.rotation.transpose() * p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.rotation * self.inner.gradient(self.rotation.transpose() * p)
    }
    fn hessian(&self, p: DVec3) -> Option<DMat3> {
        let r = self.rotation;
        Some(r * self.inner.hessian(r.transpose() * p)? * r.transpose())
    }
    fn declared_distance(&self) -> Option<bool> {
        self.inner.declared_distance()
    }
}

/// The shape scaled by `s > 0` about the origin: s d(p / s), which keeps a distance a distance
/// (and keeps the zero set of any implicit function scaled correctly).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale<G> {
    /// The shape before scaling.
    pub inner: G,
    /// The factor; must be positive and finite.
    pub factor: f64,
}

impl<G> Scale<G> {
    /// `inner` scaled by `factor` about the origin.
    pub fn new(inner: G, factor: f64) -> Self {
        Scale { inner, factor }
    }
}

impl<G: Implicit2> Implicit2 for Scale<G> {
    fn value(&self, p: DVec2) -> f64 {
        self.factor * self.inner.value(p / self.factor)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        self.inner.gradient(p / self.factor)
    }
    fn hessian(&self, p: DVec2) -> Option<DMat2> {
        Some(self.inner.hessian(p / self.factor)? * (1.0 / self.factor))
    }
    fn declared_distance(&self) -> Option<bool> {
        self.inner.declared_distance()
    }
}

impl<G: Implicit3> Implicit3 for Scale<G> {
    fn value(&self, p: DVec3) -> f64 {
        self.factor * self.inner.value(p / self.factor)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.inner.gradient(p / self.factor)
    }
    fn hessian(&self, p: DVec3) -> Option<DMat3> {
        Some(self.inner.hessian(p / self.factor)? * (1.0 / self.factor))
    }
    fn declared_distance(&self) -> Option<bool> {
        self.inner.declared_distance()
    }
}

/// Builder methods for planar shapes: `Circle::new(..).translate(..).union(other)`.
pub trait Implicit2Ext: Implicit2 + Sized {
    /// Moved by `offset`.
    fn translate(self, offset: impl Into<DVec2>) -> Translate<Self, DVec2> {
        Translate::new(self, offset.into())
    }
    /// Turned counter-clockwise by `angle` radians about the origin.
    fn rotate(self, angle: f64) -> Rotate<Self, DMat2> {
        Rotate::new(self, angle)
    }
    /// Scaled by `factor` about the origin.
    fn scale(self, factor: f64) -> Scale<Self> {
        Scale::new(self, factor)
    }
    /// Union with `other`.
    fn union<B: Implicit2>(self, other: B) -> super::Union<Self, B> {
        super::Union::new(self, other)
    }
    /// `other` cut away.
    fn difference<B: Implicit2>(self, other: B) -> super::Difference<Self, B> {
        super::Difference::new(self, other)
    }
    /// Intersection with `other`.
    fn intersection<B: Implicit2>(self, other: B) -> super::Intersection<Self, B> {
        super::Intersection::new(self, other)
    }
    /// Boxed, for trees built at run time.
    fn boxed(self) -> super::Shape2
    where
        Self: 'static,
    {
        super::Shape2::new(self)
    }
}
impl<T: Implicit2 + Sized> Implicit2Ext for T {}

/// Builder methods for solid shapes; see [`Implicit2Ext`].
pub trait Implicit3Ext: Implicit3 + Sized {
    /// Moved by `offset`.
    fn translate3(self, offset: impl Into<DVec3>) -> Translate<Self, DVec3> {
        Translate::new(self, offset.into())
    }
    /// Rotated by `angle` radians about `axis` through the origin.
    fn rotate3(self, axis: impl Into<DVec3>, angle: f64) -> Rotate<Self, DMat3> {
        Rotate::axis_angle(self, axis, angle)
    }
    /// Scaled by `factor` about the origin.
    fn scale3(self, factor: f64) -> Scale<Self> {
        Scale::new(self, factor)
    }
    /// Union with `other`.
    fn union3<B: Implicit3>(self, other: B) -> super::Union<Self, B> {
        super::Union::new(self, other)
    }
    /// `other` cut away.
    fn difference3<B: Implicit3>(self, other: B) -> super::Difference<Self, B> {
        super::Difference::new(self, other)
    }
    /// Intersection with `other`.
    fn intersection3<B: Implicit3>(self, other: B) -> super::Intersection<Self, B> {
        super::Intersection::new(self, other)
    }
    /// Boxed, for trees built at run time.
    fn boxed3(self) -> super::Shape3
    where
        Self: 'static,
    {
        super::Shape3::new(self)
    }
}
impl<T: Implicit3 + Sized> Implicit3Ext for T {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::testing::{check_gradient2, check_gradient3, check_hessian2, Rng};
    use crate::geometry::{Box3, Circle, Ellipse, Rectangle};

    #[test]
    fn translate_rotate_scale_2d() {
        let r = Rectangle::new([-1.0, -0.5], [1.0, 0.5]);
        // A quarter turn swaps the axes.
        let q = r.rotate(std::f64::consts::FRAC_PI_2);
        assert!((q.value(DVec2::new(0.0, 1.5)) - 0.5).abs() < 1e-14);
        assert!((q.value(DVec2::new(1.5, 0.0)) - 1.0).abs() < 1e-14);
        let t = Circle::new([0.0, 0.0], 1.0).translate([2.0, 0.0]);
        assert!((t.value(DVec2::new(2.0, 0.0)) + 1.0).abs() < 1e-15);
        let s = Circle::new([1.0, 0.0], 1.0).scale(3.0);
        assert!((s.value(DVec2::new(3.0, 0.0)) + 3.0).abs() < 1e-14);
        assert!((s.value(DVec2::new(10.0, 0.0)) - 4.0).abs() < 1e-14);
        let e = Ellipse::new([0.5, 0.0], 2.0, 1.0).rotate(0.7).scale(1.5).translate([0.3, 0.1]);
        assert!(!e.is_distance());
        let mut rng = Rng::new(3);
        for _ in 0..200 {
            let p = rng.point2(3.0);
            check_gradient2(&q, p, 1e-6);
            check_gradient2(&e, p, 1e-6);
            check_hessian2(&e, p, 1e-5);
        }
    }

    #[test]
    fn rotate_3d_about_an_axis() {
        let b = Box3::new([-1.0, -0.5, -0.25], [1.0, 0.5, 0.25]);
        let r = b.rotate3([0.0, 0.0, 1.0], std::f64::consts::FRAC_PI_2);
        assert!((r.value(DVec3::new(0.0, 1.5, 0.0)) - 0.5).abs() < 1e-14);
        let m = Rotate::from_matrix(b, DMat3::from_rotation_x(0.3) * DMat3::from_rotation_y(1.1));
        let s = m.scale3(2.0).translate3([1.0, 2.0, 3.0]);
        let mut rng = Rng::new(4);
        for _ in 0..200 {
            check_gradient3(&s, rng.point3(4.0), 1e-6);
        }
    }
}
