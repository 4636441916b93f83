//! Public-API tests of `trussmesh::geometry`: distances, CSG, transforms, grids, projections.

use glam::{DMat3, DVec2, DVec3};
use std::f64::consts::TAU;
use trussmesh::geometry::{
    difference, project2, project3, union, Ball, Box3, Circle, Cylinder, Ellipse, Grid2, Implicit2, Implicit2Ext,
    Implicit3, Polygon, ProjectError, Projection, Rectangle,
};

const TOL: f64 = 1e-12;

/// y - sin(2 pi x) with its Hessian: the seed's figure 3-2 function.
struct Sine;
impl Implicit2 for Sine {
    fn value(&self, p: DVec2) -> f64 {
        p.y - (TAU * p.x).sin()
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        DVec2::new(-TAU * (TAU * p.x).cos(), 1.0)
    }
    fn hessian(&self, p: DVec2) -> Option<glam::DMat2> {
        Some(glam::DMat2::from_cols(DVec2::new(TAU * TAU * (TAU * p.x).sin(), 0.0), DVec2::ZERO))
    }
    fn is_distance(&self) -> bool {
        false
    }
}

/// The ellipsoid x^2/4 + y^2 + z^2/0.25 - 1 with its Hessian.
struct Ellipsoid;
impl Implicit3 for Ellipsoid {
    fn value(&self, p: DVec3) -> f64 {
        p.x * p.x / 4.0 + p.y * p.y + 4.0 * p.z * p.z - 1.0
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        DVec3::new(p.x / 2.0, 2.0 * p.y, 8.0 * p.z)
    }
    fn hessian(&self, _p: DVec3) -> Option<DMat3> {
        Some(DMat3::from_diagonal(DVec3::new(0.5, 2.0, 8.0)))
    }
    fn is_distance(&self) -> bool {
        false
    }
}

#[test]
fn primitive_distances_are_negative_inside() {
    let c = Circle::new([0.0, 0.0], 1.0);
    assert_eq!(c.value(DVec2::new(0.0, 0.25)), -0.75);
    assert_eq!(c.value(DVec2::new(3.0, 4.0)), 4.0);
    let r = Rectangle::new([0.0, 0.0], [2.0, 1.0]);
    assert!((r.value(DVec2::new(1.0, 0.5)) + 0.5).abs() < 1e-15);
    assert!((r.value(DVec2::new(5.0, 5.0)) - 5.0).abs() < 1e-14);
    assert!((Rectangle::cheap([0.0, 0.0], [2.0, 1.0]).value(DVec2::new(5.0, 5.0)) - 4.0).abs() < 1e-14);
    let b = Ball::new([0.0; 3], 2.0);
    assert_eq!(b.value(DVec3::new(0.0, 0.0, 1.0)), -1.0);
    let x = Box3::new([0.0; 3], [1.0; 3]);
    assert!((x.value(DVec3::new(2.0, 2.0, 2.0)) - 3f64.sqrt()).abs() < 1e-14);
}

#[test]
fn cylinder_rims_use_exact_corners() {
    // Seed eq. 2.22-2.28 with r = 1, z in [-1, 1].
    let c = Cylinder::new(1.0, -1.0, 1.0);
    assert!((c.value(DVec3::new(4.0, 0.0, 5.0)) - 5.0).abs() < 1e-14); // rim: 3-4-5
    assert!((c.value(DVec3::new(0.0, -4.0, -5.0)) - 5.0).abs() < 1e-14);
    assert!((c.value(DVec3::new(0.0, 0.5, 0.0)) + 0.5).abs() < 1e-15);
    let g = c.gradient(DVec3::new(4.0, 0.0, 5.0));
    assert!((g - DVec3::new(0.6, 0.0, 0.8)).length() < 1e-14);
}

#[test]
fn polygon_sign_nonconvex() {
    // A "U": the slot between the arms is outside.
    let u =
        Polygon::new([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0], [2.0, 3.0], [2.0, 1.0], [1.0, 1.0], [1.0, 3.0], [0.0, 3.0]]);
    assert!((u.value(DVec2::new(1.5, 2.0)) - 0.5).abs() < 1e-15);
    assert!((u.value(DVec2::new(0.5, 2.0)) + 0.5).abs() < 1e-15);
    assert!((u.value(DVec2::new(1.5, 0.5)) + 0.5).abs() < 1e-15);
    assert!(u.value(DVec2::new(-1.0, 1.0)) > 0.0);
}

#[test]
fn csg_and_transforms_compose() {
    // Seed example 3a: square with a hole; the builder and the free functions agree.
    let a = difference(Rectangle::cheap([-1.0, -1.0], [1.0, 1.0]), Circle::new([0.0, 0.0], 0.4));
    let b = Rectangle::cheap([-1.0, -1.0], [1.0, 1.0]).difference(Circle::new([0.0, 0.0], 0.4));
    for p in [DVec2::new(0.1, 0.1), DVec2::new(0.9, 0.0), DVec2::new(2.0, 0.3)] {
        assert_eq!(a.value(p), b.value(p));
    }
    assert!((a.value(DVec2::new(0.1, 0.0)) - 0.3).abs() < 1e-15);
    // Two unit discs side by side, built from one by moving it.
    let one = Circle::new([0.0, 0.0], 1.0);
    let two = union(one, one.translate([3.0, 0.0]));
    assert!((two.value(DVec2::new(3.0, 0.0)) + 1.0).abs() < 1e-15);
    assert!((two.value(DVec2::new(1.5, 0.0)) - 0.5).abs() < 1e-15);
    // Scaling keeps distances: a unit disc at (1, 0) scaled by 2.
    let s = Circle::new([1.0, 0.0], 1.0).scale(2.0);
    assert!((s.value(DVec2::new(6.0, 0.0)) - 2.0).abs() < 1e-14);
    let t = Rectangle::new([-2.0, -0.5], [2.0, 0.5]).rotate(TAU / 4.0);
    assert!((t.value(DVec2::new(0.0, 2.5)) - 0.5).abs() < 1e-14);
}

#[test]
fn grid_circle_projects_onto_its_zero_set() {
    // Seed example 1 from a grid: d sampled at spacing 0.1 on [-1.1, 1.1]^2.
    let c = Circle::new([0.0, 0.0], 1.0);
    let g = Grid2::sample(&c, [-1.1, -1.1], [1.1, 1.1], 0.1).unwrap();
    let q = project2(&g, DVec2::new(1.05, 0.37), Projection::Auto, TOL, 50).unwrap();
    assert!(g.value(q).abs() < 1e-10);
    assert!(c.value(q).abs() < 5e-3);
}

#[test]
fn every_projection_lands_on_circle_and_ellipse() {
    let c = Circle::new([0.0, 0.0], 1.0);
    let e = Ellipse::new([0.0, 0.0], 2.0, 1.0);
    let all =
        [Projection::Auto, Projection::Exact, Projection::FirstOrder, Projection::SecondOrder, Projection::Newton];
    for p in [DVec2::new(1.9, -1.3), DVec2::new(0.2, 0.1), DVec2::new(-0.5, 4.0)] {
        for m in all {
            let q = project2(&c, p, m, TOL, 50).unwrap();
            assert!(c.value(q).abs() < 1e-10, "{m:?} circle from {p}");
            if m != Projection::Exact {
                let q = project2(&e, p, m, TOL, 100).unwrap();
                assert!(e.value(q).abs() < 1e-10, "{m:?} ellipse from {p}");
            }
        }
        let q = project2(&e, p, Projection::Newton, TOL, 100).unwrap();
        assert!((p - q).perp_dot(e.gradient(q).normalize()).abs() < 1e-8);
    }
}

#[test]
fn seed_figure_3_2_second_order_and_newton_beat_first_order() {
    let p = DVec2::new(0.23, (TAU * 0.23).sin() + 0.05);
    let q1 = project2(&Sine, p, Projection::FirstOrder, TOL, 100).unwrap();
    let q2 = project2(&Sine, p, Projection::SecondOrder, TOL, 100).unwrap();
    let qn = project2(&Sine, p, Projection::Newton, TOL, 100).unwrap();
    for q in [q1, q2, qn] {
        assert!(Sine.value(q).abs() < 1e-10);
    }
    // The true closest point by a fine search and a 1-D Newton polish.
    let f = |x: f64| (DVec2::new(x, (TAU * x).sin()) - p).length_squared();
    let mut x = (0..200_001).map(|k| 0.13 + 0.2 * k as f64 / 200_000.0).min_by(|a, b| f(*a).total_cmp(&f(*b))).unwrap();
    for _ in 0..20 {
        let h = 1e-5;
        x -= (f(x + h) - f(x - h)) / (2.0 * h) / ((f(x + h) - 2.0 * f(x) + f(x - h)) / (h * h));
    }
    let truth = DVec2::new(x, (TAU * x).sin());
    let (e1, e2, en) = ((q1 - truth).length(), (q2 - truth).length(), (qn - truth).length());
    assert!(e2 < e1, "second order {e2}, first order {e1}");
    assert!(en < e1 && en < 1e-8, "newton {en}, first order {e1}");
    assert!((p - qn).perp_dot(Sine.gradient(qn).normalize()).abs() < 1e-8);
}

#[test]
fn projections_in_3d() {
    let p = DVec3::new(1.2, 0.9, -0.6);
    for m in [Projection::FirstOrder, Projection::SecondOrder, Projection::Newton] {
        let q = project3(&Ellipsoid, p, m, TOL, 100).unwrap();
        assert!(Ellipsoid.value(q).abs() < 1e-10, "{m:?}");
    }
    let q = project3(&Ellipsoid, p, Projection::Newton, TOL, 100).unwrap();
    assert!((p - q).cross(Ellipsoid.gradient(q).normalize()).length() < 1e-8);
    let q1 = project3(&Ellipsoid, p, Projection::FirstOrder, TOL, 100).unwrap();
    assert!((p - q).length() <= (p - q1).length() + 1e-12);
    let cyl = Cylinder::new(1.0, -1.0, 1.0);
    let q = project3(&cyl, DVec3::new(2.0, 0.0, 3.0), Projection::Auto, TOL, 10).unwrap();
    assert!((q - DVec3::new(1.0, 0.0, 1.0)).length() < 1e-12);
}

#[test]
fn bad_functions_give_errors_not_panics() {
    let nan = |_: DVec2| f64::NAN;
    let r = project2(&nan, DVec2::ZERO, Projection::Auto, TOL, 10);
    assert!(matches!(r, Err(ProjectError::NonFinite { value, .. }) if value.is_nan()));
    let flat = |_: DVec2| 2.0;
    for m in [Projection::Auto, Projection::Exact, Projection::FirstOrder, Projection::SecondOrder, Projection::Newton]
    {
        assert_eq!(project2(&flat, DVec2::ZERO, m, TOL, 10), Err(ProjectError::ZeroGradient));
    }
    let flat3 = |_: DVec3| -1.0;
    assert_eq!(project3(&flat3, DVec3::ONE, Projection::Newton, TOL, 10), Err(ProjectError::ZeroGradient));
    // No zero set at all: x^2 + 1 never vanishes; the cap ends the search.
    let never = Ellipse::new([0.0, 0.0], 1.0, 1.0);
    let lifted = move |p: DVec2| never.value(p) + 2.0;
    let r = project2(&lifted, DVec2::new(0.5, 0.5), Projection::FirstOrder, TOL, 30);
    assert!(matches!(r, Err(ProjectError::NoConvergence { .. }) | Err(ProjectError::ZeroGradient)), "{r:?}");
}

#[test]
fn newton_distance_of_an_implicit_ellipse() {
    // Seed eq. 2.13: a true signed distance from any implicit function.
    use trussmesh::geometry::newton_distance2;
    let e = Ellipse::new([0.0, 0.0], 2.0, 1.0);
    let d = newton_distance2(&e, DVec2::new(0.0, 3.0), TOL, 50).unwrap();
    assert!((d - 2.0).abs() < 1e-10);
    let d = newton_distance2(&e, DVec2::new(0.0, 0.5), TOL, 50).unwrap();
    assert!((d + 0.5).abs() < 1e-10);
}
