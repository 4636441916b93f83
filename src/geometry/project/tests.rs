//! Tests of the projections onto d = 0.

use super::*;
use crate::geometry::{Ball, Circle, Ellipse};
use glam::DMat2;
use std::f64::consts::TAU;

/// phi = y - sin(2 pi x), the seed's figure 3-2 function, with its Hessian.
struct Sine;
impl Implicit2 for Sine {
    fn value(&self, p: DVec2) -> f64 {
        p.y - (TAU * p.x).sin()
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        DVec2::new(-TAU * (TAU * p.x).cos(), 1.0)
    }
    fn hessian(&self, p: DVec2) -> Option<DMat2> {
        Some(DMat2::from_cols(DVec2::new(TAU * TAU * (TAU * p.x).sin(), 0.0), DVec2::ZERO))
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(false)
    }
}

#[test]
fn real_roots_of_known_polynomials() {
    // (t - 1)(t + 2)(t - 3)(t + 0.5), multiplied out.
    let roots = [1.0, -2.0, 3.0, -0.5];
    let mut poly: Poly = pconst(1.0);
    for r in roots {
        let mut lin = pconst(-r);
        lin[1] = 1.0;
        poly = pmul(&poly, &lin);
    }
    let found = real_roots(&poly);
    assert_eq!(found.len(), 4);
    for (f, w) in found.iter().zip([-2.0, -0.5, 1.0, 3.0]) {
        assert!((f - w).abs() < 1e-12, "{found:?}");
    }
    // t^4 + 1: none.
    assert!(real_roots(&[1.0, 0.0, 0.0, 0.0, 1.0]).is_empty());
    // Sextic with two real roots: (t^2 - 2)(t^4 + t^2 + 1).
    let r = real_roots(&[-2.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0]);
    assert_eq!(r.len(), 2);
    assert!((r[1] - 2f64.sqrt()).abs() < 1e-14);
}

#[test]
fn seed_quartic_coefficients_match() {
    // Check the built polynomial against the seed's p0..p2 of eq. 3.16 at a sample point.
    let (phi, gx, gy, hxx, hxy, hyy) = (0.3, 0.7, -1.1, 0.9, -0.4, 1.3);
    let h = [[hxx, hxy], [hxy, hyy]];
    let (adj, det) = adjugate_det(&h);
    let grad = [gx, gy];
    let mut minus_t = [0.0; 7];
    minus_t[1] = -1.0;
    let num: [Poly; 2] = std::array::from_fn(|i| {
        let s = (0..2).fold([0.0; 7], |acc, j| padd(&acc, &adj[i][j], grad[j]));
        pmul(&minus_t, &s)
    });
    // Seed eq. 3.13: numerator of dx = (gy hxy - gx hyy) t^2 - gx t.
    assert!((num[0][1] + gx).abs() < 1e-15);
    assert!((num[0][2] - (gy * hxy - gx * hyy)).abs() < 1e-15);
    assert!((det[2] - (hxx * hyy - hxy * hxy)).abs() < 1e-15);
    let mut q = padd(&[0.0; 7], &pmul(&det, &det), phi);
    let g_num = (0..2).fold([0.0; 7], |acc, i| padd(&acc, &num[i], grad[i]));
    q = padd(&q, &pmul(&det, &g_num), 1.0);
    for i in 0..2 {
        for j in 0..2 {
            q = padd(&q, &pmul(&num[i], &num[j]), 0.5 * h[i][j]);
        }
    }
    let p1 = 2.0 * phi * (hxx + hyy) - gx * gx - gy * gy;
    let p2 = phi * hxx * hxx + phi * hyy * hyy + 4.0 * phi * hyy * hxx
        - 2.0 * gy * gy * hxx
        - 2.0 * gx * gx * hyy
        - 2.0 * phi * hxy * hxy
        - 0.5 * gy * gy * hyy
        - 0.5 * gx * gx * hxx
        + 3.0 * gx * hxy * gy;
    let p4 = -gx * hxy.powi(3) * gy + phi * hyy * hyy * hxx * hxx + phi * hxy.powi(4)
        - 2.0 * phi * hxy * hxy * hyy * hxx
        + 0.5 * gy * gy * hxx * hxy * hxy
        - 0.5 * gy * gy * hxx * hxx * hyy
        - 0.5 * gx * gx * hyy * hyy * hxx
        + 0.5 * gx * gx * hyy * hxy * hxy
        + gx * hxy * gy * hyy * hxx;
    assert!((q[0] - phi).abs() < 1e-14);
    assert!((q[1] - p1).abs() < 1e-14);
    assert!((q[2] - p2).abs() < 1e-14, "{} vs {p2}", q[2]);
    assert!((q[4] - p4).abs() < 1e-14, "{} vs {p4}", q[4]);
    assert_eq!(q[5], 0.0);
}

#[test]
fn every_method_lands_on_circle_and_ellipse() {
    let c = Circle::new([0.2, -0.1], 1.3);
    let e = Ellipse::new([0.0, 0.0], 2.0, 1.0);
    let methods =
        [Projection::Auto, Projection::Exact, Projection::FirstOrder, Projection::SecondOrder, Projection::Newton];
    for p in [DVec2::new(2.5, 1.0), DVec2::new(0.1, 0.3), DVec2::new(-3.0, -0.2)] {
        for m in methods {
            let q = project2(&c, p, m, 1e-12, 50).unwrap();
            assert!(c.value(q).abs() < 1e-10, "{m:?} circle from {p}");
            if m == Projection::Exact {
                continue; // assumes a distance; Auto picks first order for the ellipse
            }
            let q = project2(&e, p, m, 1e-12, 100).unwrap();
            assert!(e.value(q).abs() < 1e-10, "{m:?} ellipse from {p}");
        }
    }
    // For the circle Newton is the radial point.
    let p = DVec2::new(2.5, 1.0);
    let q = project2(&c, p, Projection::Newton, 1e-12, 50).unwrap();
    let want = c.center + (p - c.center).normalize() * c.radius;
    assert!((q - want).length() < 1e-12);
}

#[test]
fn ellipse_newton_is_the_closest_point() {
    let e = Ellipse::new([0.0, 0.0], 2.0, 1.0);
    let p = DVec2::new(1.7, 1.4);
    let q = project2(&e, p, Projection::Newton, 1e-13, 50).unwrap();
    // Brute force over the parametrisation.
    let best = (0..200_000)
        .map(|k| {
            let a = TAU * k as f64 / 200_000.0;
            (DVec2::new(2.0 * a.cos(), a.sin()) - p).length()
        })
        .fold(f64::INFINITY, f64::min);
    assert!((q - p).length() <= best + 1e-9);
    let n = e.gradient(q).normalize();
    assert!((p - q).perp_dot(n).abs() < 1e-10);
}

#[test]
fn seed_figure_3_2() {
    let s = Sine;
    let p = DVec2::new(0.23, (TAU * 0.23).sin() + 0.05);
    let q1 = project2(&s, p, Projection::FirstOrder, 1e-12, 100).unwrap();
    let q2 = project2(&s, p, Projection::SecondOrder, 1e-12, 100).unwrap();
    let qn = project2(&s, p, Projection::Newton, 1e-12, 100).unwrap();
    for q in [q1, q2, qn] {
        assert!(s.value(q).abs() < 1e-10);
    }
    // The true closest point: minimise |(x, sin 2 pi x) - p| by dense search then Newton.
    let f = |x: f64| (DVec2::new(x, (TAU * x).sin()) - p).length();
    let mut xb =
        (0..100_000).map(|k| 0.23 + (k as f64 / 100_000.0 - 0.5) * 0.2).min_by(|a, b| f(*a).total_cmp(&f(*b))).unwrap();
    for _ in 0..50 {
        let h = 1e-6;
        let d1 = (f(xb + h) - f(xb - h)) / (2.0 * h);
        let d2 = (f(xb + h) - 2.0 * f(xb) + f(xb - h)) / (h * h);
        xb -= d1 / d2;
    }
    let truth = DVec2::new(xb, (TAU * xb).sin());
    let e1 = (q1 - truth).length();
    let e2 = (q2 - truth).length();
    let en = (qn - truth).length();
    assert!(e2 < e1, "second order {e2} vs first {e1}");
    assert!(en < e1 && en < 1e-7, "newton {en} vs first {e1}");
    // Closest-point optimality of Newton's answer (seed eq. 2.10).
    let n = s.gradient(qn).normalize();
    assert!((p - qn).perp_dot(n).abs() < 1e-8);
}

#[test]
fn ball_projections_3d() {
    let b = Ball::new([0.1, 0.2, 0.3], 0.9);
    let ell = |p: DVec3| p.x * p.x + 4.0 * p.y * p.y + 2.0 * p.z * p.z - 1.0;
    // The closure claims to be a distance by default, so Auto is left out for it.
    for m in [Projection::FirstOrder, Projection::SecondOrder, Projection::Newton] {
        let p = DVec3::new(1.5, -0.7, 0.4);
        let q = project3(&b, p, m, 1e-12, 50).unwrap();
        assert!(b.value(q).abs() < 1e-10);
        let q = project3(&ell, p, m, 1e-12, 100).unwrap();
        assert!(ell(q).abs() < 1e-10, "{m:?}");
    }
}

#[test]
fn random_points_converge_and_newton_is_optimal() {
    let mut rng = crate::geometry::testing::Rng::new(0x9e0);
    let e = Ellipse::new([0.3, -0.2], 2.0, 0.5);
    let shapes: [&dyn Implicit2; 2] = [&e, &Sine];
    let mut optimal = 0;
    for g in shapes {
        for _ in 0..300 {
            let p = rng.point2(3.0);
            for m in [Projection::FirstOrder, Projection::SecondOrder, Projection::Newton] {
                let q = project2(g, p, m, 1e-12, 200).unwrap_or_else(|err| panic!("{m:?} from {p}: {err}"));
                assert!(g.value(q).abs() < 1e-10, "{m:?} from {p}");
            }
            let q1 = project2(g, p, Projection::FirstOrder, 1e-12, 200).unwrap();
            let qn = project2(g, p, Projection::Newton, 1e-12, 200).unwrap();
            assert!((qn - p).length() <= (q1 - p).length() + 1e-9, "from {p}");
            let n = g.gradient(qn).normalize();
            optimal += ((p - qn).perp_dot(n).abs() < 1e-8) as usize;
        }
    }
    // Newton reaches a stationary point nearly always (else it falls back to first order).
    assert!(optimal >= 570, "{optimal} of 600 optimal");
}

#[test]
fn bad_inputs_are_errors() {
    let nan = |_: DVec2| f64::NAN;
    assert!(matches!(
        project2(&nan, DVec2::ONE, Projection::FirstOrder, 1e-12, 10),
        Err(ProjectError::NonFinite { .. })
    ));
    let flat = |_: DVec2| 1.0;
    for m in [Projection::Auto, Projection::FirstOrder, Projection::SecondOrder, Projection::Newton] {
        assert_eq!(project2(&flat, DVec2::ONE, m, 1e-12, 10), Err(ProjectError::ZeroGradient));
    }
    let c = Circle::new([0.0, 0.0], 1.0);
    assert!(matches!(
        project2(&c, DVec2::new(f64::INFINITY, 0.0), Projection::Exact, 1e-12, 10),
        Err(ProjectError::NonFinite { .. })
    ));
    // A cap of zero steps only checks.
    assert!(matches!(
        project2(&c, DVec2::new(3.0, 0.0), Projection::Exact, 1e-12, 0),
        Err(ProjectError::NoConvergence { residual }) if (residual - 2.0).abs() < 1e-15
    ));
}

/// Deterministic points scattered over [-2, 2]^2 (a fixed linear congruential sequence).
fn scatter2(n: usize) -> Vec<DVec2> {
    let mut s: u64 = 0x9e3779b97f4a7c15;
    let mut next = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
    };
    (0..n).map(|_| DVec2::new(next(), next())).collect()
}

#[test]
fn batch_projection_matches_point_by_point_bit_for_bit() {
    let pts = scatter2(700);
    let circle = Circle::new([0.1, -0.2], 0.8);
    let ellipse = Ellipse::new([0.0, 0.0], 1.5, 0.5);
    // A steep level set (x^6 + y^6 - 1) and a cubed distance, where first-order steps take
    // the accelerated form; and the seed's sine for Newton and second order.
    let steep = crate::geometry::LevelSet(|p: DVec2| p.x.powi(6) + p.y.powi(6) - 1.0);
    let cubed = crate::geometry::LevelSet(|p: DVec2| (p.length() - 1.0).powi(3));
    let geoms: [(&str, &dyn Implicit2); 5] =
        [("circle", &circle), ("ellipse", &ellipse), ("steep", &steep), ("cubed", &cubed), ("sine", &Sine)];
    let mut accelerated = 0;
    for (name, g) in geoms {
        for method in
            [Projection::Auto, Projection::Exact, Projection::FirstOrder, Projection::SecondOrder, Projection::Newton]
        {
            let batch = project_many2(g, &pts, method, 1e-10, 30);
            for (p, b) in pts.iter().zip(&batch) {
                let one = project2(g, *p, method, 1e-10, 30);
                match (one, b) {
                    (Ok(a), Ok(b)) => assert!(
                        a.x.to_bits() == b.x.to_bits() && a.y.to_bits() == b.y.to_bits(),
                        "{name} {method:?} at {p}: {a} vs {b}"
                    ),
                    (Err(a), Err(b)) => assert_eq!(format!("{a:?}"), format!("{b:?}"), "{name} {method:?} at {p}"),
                    (a, b) => panic!("{name} {method:?} at {p}: {a:?} vs {b:?}"),
                }
            }
            if name == "cubed" && method == Projection::FirstOrder {
                accelerated = batch.iter().filter(|r| r.is_ok()).count();
            }
        }
    }
    assert!(accelerated > 600, "the accelerated first-order steps were exercised: {accelerated}");
    // A non-finite point is reported as such.
    let bad = project_many2(&circle, &[DVec2::new(f64::NAN, 0.0)], Projection::Auto, 1e-10, 30);
    assert!(matches!(bad[0], Err(ProjectError::NonFinite { kind: NonFiniteIn::Point, .. })));
}

/// The wedge |y| < tan(20 degrees) x as the max of its two sides' signed distances: from the
/// left of its tip the plain steps land on each side's line in turn and zigzag into the tip,
/// shrinking by cos^2(40 degrees) per round.
struct Wedge;
impl Wedge {
    fn sides() -> [DVec2; 2] {
        let (s, c) = 20f64.to_radians().sin_cos();
        [DVec2::new(-s, c), DVec2::new(-s, -c)]
    }
}
impl Implicit2 for Wedge {
    fn value(&self, p: DVec2) -> f64 {
        let [a, b] = Self::sides();
        a.dot(p).max(b.dot(p))
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        let [a, b] = Self::sides();
        if a.dot(p) >= b.dot(p) {
            a
        } else {
            b
        }
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
}

#[test]
fn a_zigzag_into_a_crease_converges_in_the_crease_mode() {
    for p in [DVec2::new(-0.3, 0.01), DVec2::new(-1.0, -0.2), DVec2::new(-0.2, 0.3)] {
        // The plain steps alone do not reach the tolerance in 20 steps.
        let mut x = p;
        for _ in 0..20 {
            x -= Wedge.value(x) * Wedge.gradient(x);
        }
        assert!(Wedge.value(x).abs() > 1e-6, "{p}: {}", Wedge.value(x));
        for m in [Projection::Exact, Projection::FirstOrder] {
            let q = project2(&Wedge, p, m, 1e-12, 20).unwrap_or_else(|e| panic!("{m:?} from {p}: {e}"));
            assert!(Wedge.value(q).abs() < 1e-12 && q.length() < 1e-9, "{m:?} from {p}: {q}");
            // The batch projection takes the same path, bit for bit.
            let b = project_many2(&Wedge, &[p], m, 1e-12, 20).remove(0).expect("converges");
            assert!(b.x.to_bits() == q.x.to_bits() && b.y.to_bits() == q.y.to_bits(), "{m:?} from {p}: {b} vs {q}");
        }
    }
}
