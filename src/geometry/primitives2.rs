//! Planar primitives: circle, rectangle (exact and cheap), polygon, ellipse (seed section 2.4).

use super::polygons::segment::{closest_on_segment, crosses_ray};
use super::Implicit2;
use glam::{DMat2, DVec2};

/// Unit vector along `v`, or `fallback` when `v` is zero: distance gradients must stay unit
/// length even at the medial axis, where any direction is a valid subgradient.
#[inline]
fn unit_or(v: DVec2, fallback: DVec2) -> DVec2 {
    let l = v.length();
    if l > 0.0 {
        v / l
    } else {
        fallback
    }
}

/// A disc, as the seed's `dcircle`: d = |p - c| - r, an exact signed distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    /// Centre.
    pub center: DVec2,
    /// Radius.
    pub radius: f64,
}

impl Circle {
    /// The disc of radius `r` about `center`.
    pub fn new(center: impl Into<DVec2>, r: f64) -> Self {
        Circle { center: center.into(), radius: r }
    }
}

impl Implicit2 for Circle {
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
    fn value(&self, p: DVec2) -> f64 {
        (p - self.center).length() - self.radius
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        unit_or(p - self.center, DVec2::X)
    }
    /// (I - n n^T) / |p - c|; undefined at the centre.
    fn hessian(&self, p: DVec2) -> Option<DMat2> {
        let v = p - self.center;
        let l = v.length();
        if l == 0.0 {
            return None;
        }
        let n = v / l;
        Some((DMat2::IDENTITY - outer2(n, n)) * (1.0 / l))
    }
}

/// Outer product a b^T.
#[inline]
pub(crate) fn outer2(a: DVec2, b: DVec2) -> DMat2 {
    DMat2::from_cols(a * b.x, a * b.y)
}

/// An axis-aligned rectangle. The exact form rounds the distance about outside corners; the
/// cheap form is the seed's `drectangle` (max over the four edge lines), exact inside and along
/// the edges but too small off the corners, which the seed keeps out of play by fixing them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rectangle {
    /// Lower-left corner.
    pub min: DVec2,
    /// Upper-right corner.
    pub max: DVec2,
    /// True for the cheap max-form.
    pub cheap: bool,
}

impl Rectangle {
    /// Exact signed distance to the rectangle `[min, max]`.
    pub fn new(min: impl Into<DVec2>, max: impl Into<DVec2>) -> Self {
        Rectangle { min: min.into(), max: max.into(), cheap: false }
    }
    /// The seed's `drectangle`: -min(y - y1, y2 - y, x - x1, x2 - x).
    pub fn cheap(min: impl Into<DVec2>, max: impl Into<DVec2>) -> Self {
        Rectangle { cheap: true, ..Rectangle::new(min, max) }
    }
    /// Per-axis signed distance to the slab, and the sign of the side.
    #[inline]
    fn slabs(&self, p: DVec2) -> (DVec2, DVec2) {
        let c = 0.5 * (self.min + self.max);
        let half = 0.5 * (self.max - self.min);
        let rel = p - c;
        let sign = DVec2::new(if rel.x < 0.0 { -1.0 } else { 1.0 }, if rel.y < 0.0 { -1.0 } else { 1.0 });
        (rel.abs() - half, sign)
    }
}

impl Implicit2 for Rectangle {
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
    fn value(&self, p: DVec2) -> f64 {
        let (q, _) = self.slabs(p);
        if self.cheap {
            return q.max_element();
        }
        q.max(DVec2::ZERO).length() + q.max_element().min(0.0)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        let (q, s) = self.slabs(p);
        let out = q.max(DVec2::ZERO);
        if !self.cheap && out.x > 0.0 && out.y > 0.0 {
            return out.normalize() * s;
        }
        if q.x >= q.y {
            DVec2::new(s.x, 0.0)
        } else {
            DVec2::new(0.0, s.y)
        }
    }
}

/// A polygon with exact signed distance: the distance to the nearest edge, negative inside by
/// the even-odd crossing rule, so any orientation and non-convex shapes work.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    vertices: Vec<DVec2>,
    /// +1 when counter-clockwise, -1 when clockwise (turns an edge's left normal outward).
    orientation: f64,
}

impl Polygon {
    /// The closed polygon through `vertices` (the last joins the first). With fewer than three
    /// vertices nothing is inside and the value is the distance to the points (infinite if none).
    pub fn new<P: Into<DVec2>>(vertices: impl IntoIterator<Item = P>) -> Self {
        let vertices: Vec<DVec2> = vertices.into_iter().map(Into::into).collect();
        let n = vertices.len();
        let twice_area: f64 = (0..n).map(|i| vertices[i].perp_dot(vertices[(i + 1) % n])).sum();
        Polygon { vertices, orientation: if twice_area < 0.0 { -1.0 } else { 1.0 } }
    }
    /// The vertices, in the order given.
    pub fn vertices(&self) -> &[DVec2] {
        &self.vertices
    }
    /// Nearest point on the boundary and the index of its edge.
    fn nearest(&self, p: DVec2) -> Option<(DVec2, usize)> {
        let n = self.vertices.len();
        let mut best: Option<(f64, DVec2, usize)> = None;
        for i in 0..n {
            let (q, _) = closest_on_segment(p, self.vertices[i], self.vertices[(i + 1) % n]);
            let d2 = (p - q).length_squared();
            if best.is_none_or(|(bd, _, _)| d2 < bd) {
                best = Some((d2, q, i));
            }
        }
        best.map(|(_, q, i)| (q, i))
    }
    /// Even-odd crossing number: a horizontal ray to +x crosses the boundary an odd number of
    /// times (exact orientation signs, as [`super::Polygons2`]).
    fn contains(&self, p: DVec2) -> bool {
        let n = self.vertices.len();
        if n < 3 {
            return false;
        }
        (0..n).filter(|&i| crosses_ray(p, self.vertices[i], self.vertices[(i + 1) % n])).count() % 2 == 1
    }
}

impl Implicit2 for Polygon {
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
    fn value(&self, p: DVec2) -> f64 {
        match self.nearest(p) {
            None => f64::INFINITY,
            Some((q, _)) => {
                let d = (p - q).length();
                if self.contains(p) {
                    -d
                } else {
                    d
                }
            }
        }
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        let Some((q, i)) = self.nearest(p) else {
            return DVec2::ZERO;
        };
        let v = p - q;
        let l = v.length();
        if l > 0.0 {
            return if self.contains(p) { -v / l } else { v / l };
        }
        // On the boundary: the outward edge normal.
        let n = self.vertices.len();
        let e = self.vertices[(i + 1) % n] - self.vertices[i];
        unit_or(DVec2::new(e.y, -e.x) * self.orientation, DVec2::X)
    }
}

/// The implicit ellipse phi = ((x-cx)/a)^2 + ((y-cy)/b)^2 - 1: not a distance, but smooth with
/// constant Hessian, the seed's model case for the projections of section 3.2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse {
    /// Centre.
    pub center: DVec2,
    /// Semi-axis along x.
    pub a: f64,
    /// Semi-axis along y.
    pub b: f64,
}

impl Ellipse {
    /// The ellipse with semi-axes `a` (x) and `b` (y) about `center`.
    pub fn new(center: impl Into<DVec2>, a: f64, b: f64) -> Self {
        Ellipse { center: center.into(), a, b }
    }
}

impl Implicit2 for Ellipse {
    fn value(&self, p: DVec2) -> f64 {
        let r = p - self.center;
        (r.x / self.a).powi(2) + (r.y / self.b).powi(2) - 1.0
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        let r = p - self.center;
        DVec2::new(2.0 * r.x / (self.a * self.a), 2.0 * r.y / (self.b * self.b))
    }
    fn hessian(&self, _p: DVec2) -> Option<DMat2> {
        Some(DMat2::from_diagonal(DVec2::new(2.0 / (self.a * self.a), 2.0 / (self.b * self.b))))
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::testing::{check_gradient2, check_hessian2, Rng};

    #[test]
    fn circle_distances() {
        let c = Circle::new([1.0, 2.0], 0.5);
        assert!((c.value(DVec2::new(1.0, 2.0)) + 0.5).abs() < 1e-15);
        assert!((c.value(DVec2::new(4.0, 6.0)) - 4.5).abs() < 1e-15);
        assert_eq!(c.gradient(DVec2::new(1.0, 2.0)), DVec2::X);
        assert!(c.is_distance());
    }

    #[test]
    fn rectangle_exact_and_cheap() {
        let r = Rectangle::new([-1.0, -1.0], [1.0, 2.0]);
        let k = Rectangle::cheap([-1.0, -1.0], [1.0, 2.0]);
        // Inside: both equal minus the distance to the nearest edge.
        let p = DVec2::new(0.5, 0.0);
        assert!((r.value(p) + 0.5).abs() < 1e-15);
        assert!((k.value(p) + 0.5).abs() < 1e-15);
        // Off an edge: both exact.
        let p = DVec2::new(0.0, 3.0);
        assert!((r.value(p) - 1.0).abs() < 1e-15);
        assert!((k.value(p) - 1.0).abs() < 1e-15);
        // Off a corner: exact rounds, cheap takes the max.
        let p = DVec2::new(4.0, 6.0);
        assert!((r.value(p) - 5.0).abs() < 1e-14);
        assert!((k.value(p) - 4.0).abs() < 1e-14);
        assert!(k.is_distance() && r.is_distance());
    }

    #[test]
    fn polygon_nonconvex_sign() {
        // An L: the notch at (1.5, 1.5) is outside although inside the bounding box.
        let l = Polygon::new(vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(2.0, 1.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(1.0, 2.0),
            DVec2::new(0.0, 2.0),
        ]);
        assert!((l.value(DVec2::new(1.5, 1.5)) - 0.5).abs() < 1e-15);
        assert!((l.value(DVec2::new(0.5, 0.5)) + 0.5).abs() < 1e-15);
        assert!((l.value(DVec2::new(0.5, 1.5)) + 0.5).abs() < 1e-15);
        // Off the convex corner (2, 0): Euclidean distance to the vertex.
        assert!((l.value(DVec2::new(5.0, -4.0)) - 5.0).abs() < 1e-14);
        // Orientation does not matter.
        let mut rev = l.vertices().to_vec();
        rev.reverse();
        let r = Polygon::new(rev);
        for p in [DVec2::new(1.5, 1.5), DVec2::new(0.3, 0.7), DVec2::new(-1.0, 3.0)] {
            assert_eq!(l.value(p), r.value(p));
        }
        // On the boundary the gradient is the outward normal, for both orientations.
        let on = DVec2::new(1.0, 1.5);
        assert!((l.gradient(on) - DVec2::X).length() < 1e-15);
        assert!((r.gradient(on) - DVec2::X).length() < 1e-15);
    }

    #[test]
    fn ellipse_is_not_a_distance() {
        let e = Ellipse::new([0.0, 0.0], 2.0, 1.0);
        assert!(!e.is_distance());
        assert!(e.value(DVec2::new(2.0, 0.0)).abs() < 1e-15);
        assert!((e.value(DVec2::ZERO) + 1.0).abs() < 1e-15);
    }

    #[test]
    fn gradients_match_finite_differences() {
        let mut rng = Rng::new(0x2d_5eed);
        let l = Polygon::new([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]);
        let shapes: Vec<Box<dyn Implicit2>> = vec![
            Box::new(Circle::new([0.3, -0.2], 0.8)),
            Box::new(Rectangle::new([-1.0, -0.5], [1.0, 0.7])),
            Box::new(Rectangle::cheap([-1.0, -0.5], [1.0, 0.7])),
            Box::new(l),
            Box::new(Ellipse::new([0.1, 0.2], 2.0, 1.0)),
        ];
        for g in &shapes {
            for _ in 0..200 {
                let p = DVec2::new(rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0));
                check_gradient2(g.as_ref(), p, 1e-6);
                check_hessian2(g.as_ref(), p, 1e-5);
            }
        }
    }
}
