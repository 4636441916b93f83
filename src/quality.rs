//! Element quality measures (floating point: they choose among valid moves, never decide validity).

use glam::{DVec2, DVec3};

/// Triangle quality q = 2 r_in / r_out = (b+c-a)(c+a-b)(a+b-c)/(abc) (seed eq. 2.28's measure):
/// 1 for the equilateral triangle, 0 for a degenerate one. Works for points in any dimension
/// since it uses edge lengths only.
#[inline]
pub fn triangle_q_from_lengths(a: f64, b: f64, c: f64) -> f64 {
    let den = a * b * c;
    if den <= 0.0 {
        return 0.0;
    }
    ((b + c - a) * (c + a - b) * (a + b - c) / den).max(0.0)
}

/// [`triangle_q_from_lengths`] of a planar triangle.
#[inline]
pub fn triangle_q(p: [DVec2; 3]) -> f64 {
    triangle_q_from_lengths(p[1].distance(p[2]), p[2].distance(p[0]), p[0].distance(p[1]))
}

/// [`triangle_q_from_lengths`] of a triangle in space.
#[inline]
pub fn triangle_q3(p: [DVec3; 3]) -> f64 {
    triangle_q_from_lengths(p[1].distance(p[2]), p[2].distance(p[0]), p[0].distance(p[1]))
}

/// Signed area of a planar triangle (positive counter-clockwise).
#[inline]
pub fn triangle_area(p: [DVec2; 3]) -> f64 {
    0.5 * (p[1] - p[0]).perp_dot(p[2] - p[0])
}

/// Circumradius of a triangle given by its edge lengths (infinite when degenerate).
#[inline]
pub fn circumradius_from_lengths(a: f64, b: f64, c: f64) -> f64 {
    let s = (a + b + c) * (b + c - a) * (c + a - b) * (a + b - c);
    if s <= 0.0 {
        f64::INFINITY
    } else {
        a * b * c / s.sqrt()
    }
}

/// The three interior angles of a triangle in degrees (any dimension through the lengths).
pub fn triangle_angles_deg(a: f64, b: f64, c: f64) -> [f64; 3] {
    let ang = |opp: f64, s1: f64, s2: f64| {
        let cos = ((s1 * s1 + s2 * s2 - opp * opp) / (2.0 * s1 * s2)).clamp(-1.0, 1.0);
        cos.acos().to_degrees()
    };
    [ang(a, b, c), ang(b, c, a), ang(c, a, b)]
}

/// Signed volume of a tetrahedron, positive for det[b-a, c-a, d-a] > 0.
#[inline]
pub fn tet_volume(p: [DVec3; 4]) -> f64 {
    (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])) / 6.0
}

/// Tetrahedron radius ratio 3 r_in / r_out: 1 for the regular tetrahedron, 0 when flat.
pub fn tet_radius_ratio(p: [DVec3; 4]) -> f64 {
    let vol = tet_volume(p).abs();
    if vol == 0.0 {
        return 0.0;
    }
    let face = |a: DVec3, b: DVec3, c: DVec3| 0.5 * (b - a).cross(c - a).length();
    let area = face(p[1], p[2], p[3]) + face(p[0], p[2], p[3]) + face(p[0], p[1], p[3]) + face(p[0], p[1], p[2]);
    let r_in = 3.0 * vol / area;
    // Circumradius: |a|^2 (b x c) + |b|^2 (c x a) + |c|^2 (a x b) over 12 V, relative to p0.
    let a = p[1] - p[0];
    let b = p[2] - p[0];
    let c = p[3] - p[0];
    let num = a.length_squared() * b.cross(c) + b.length_squared() * c.cross(a) + c.length_squared() * a.cross(b);
    let r_out = num.length() / (12.0 * vol);
    (3.0 * r_in / r_out).clamp(0.0, 1.0)
}

/// The six dihedral angles of a tetrahedron in degrees, at edges 01, 02, 03, 12, 13, 23.
pub fn tet_dihedral_angles_deg(p: [DVec3; 4]) -> [f64; 6] {
    // The dihedral at edge (i, j) is between the faces that contain i, j and k, and i, j and l.
    const EDGES: [(usize, usize, usize, usize); 6] =
        [(0, 1, 2, 3), (0, 2, 1, 3), (0, 3, 1, 2), (1, 2, 0, 3), (1, 3, 0, 2), (2, 3, 0, 1)];
    let mut out = [0.0; 6];
    for (n, &(i, j, k, l)) in EDGES.iter().enumerate() {
        let e = (p[j] - p[i]).normalize_or_zero();
        let u = p[k] - p[i];
        let w = p[l] - p[i];
        let u = u - e * u.dot(e);
        let w = w - e * w.dot(e);
        let cos = (u.dot(w) / (u.length() * w.length())).clamp(-1.0, 1.0);
        out[n] = if cos.is_finite() { cos.acos().to_degrees() } else { 0.0 };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equilateral_is_one() {
        let t = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(0.5, 3f64.sqrt() / 2.0)];
        assert!((triangle_q(t) - 1.0).abs() < 1e-12);
        let ang = triangle_angles_deg(1.0, 1.0, 1.0);
        assert!(ang.iter().all(|a| (a - 60.0).abs() < 1e-9));
        assert!((circumradius_from_lengths(1.0, 1.0, 1.0) - 1.0 / 3f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn degenerate_is_zero() {
        assert_eq!(triangle_q_from_lengths(2.0, 1.0, 1.0), 0.0);
        assert_eq!(triangle_q_from_lengths(0.0, 1.0, 1.0), 0.0);
    }

    #[test]
    fn regular_tet() {
        let p = [
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(-1.0, -1.0, 1.0),
        ];
        assert!((tet_radius_ratio(p) - 1.0).abs() < 1e-12);
        let expect = (1.0f64 / 3.0).acos().to_degrees();
        for a in tet_dihedral_angles_deg(p) {
            assert!((a - expect).abs() < 1e-9);
        }
    }
}
