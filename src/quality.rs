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

/// Circumradius of a tetrahedron (infinite when flat).
pub fn tet_circumradius(p: [DVec3; 4]) -> f64 {
    let (a, b, c) = (p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    let num = a.length_squared() * b.cross(c) + b.length_squared() * c.cross(a) + c.length_squared() * a.cross(b);
    num.length() / (2.0 * a.dot(b.cross(c)).abs())
}

/// Dihedral angle of the regular tetrahedron, degrees.
pub(crate) const REGULAR_DIHEDRAL: f64 = 70.528_779_365_509_3;

/// The dihedral angle of the tet (a, b, c, d) at its edge (a, b), in radians (0 to pi).
pub(crate) fn dihedral_angle_at(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    let e = (b - a).normalize_or_zero();
    let (u, w) = (c - a, d - a);
    let (u, w) = (u - e * u.dot(e), w - e * w.dot(e));
    u.cross(w).length().atan2(u.dot(w))
}

/// Dihedral quality of a tetrahedron: 1 for the regular tet, 0 when a dihedral angle reaches 0
/// or 180 degrees; min(theta_min / 70.5, (180 - theta_max) / 109.5). Negative for inverted
/// tets. This is the measure the 3-D mesher's targets are stated in (minimum and maximum
/// dihedral angle).
pub(crate) fn tet_dihedral_quality(p: [DVec3; 4]) -> f64 {
    match tet_dihedral_cos_extremes(p) {
        None => -1.0,
        Some((cmax, cmin)) => dihedral_quality_of_cosines(cmax, cmin),
    }
}

/// The largest and the smallest dihedral cosine of a positive tet; `None` when it is not
/// positive (or not finite).
#[inline]
pub(crate) fn tet_dihedral_cos_extremes(p: [DVec3; 4]) -> Option<(f64, f64)> {
    let v = tet_volume(p);
    if v <= 0.0 || !v.is_finite() {
        return None;
    }
    // Outward face normals; the dihedral at the edge shared by faces i and j has cosine
    // -n_i . n_j. Only the extreme cosines need an acos (this runs on every tet every step).
    let n = |a: usize, b: usize, c: usize| (p[b] - p[a]).cross(p[c] - p[a]).normalize_or_zero();
    let f = [n(1, 2, 3), n(0, 3, 2), n(0, 1, 3), n(0, 2, 1)];
    let (mut cmax, mut cmin) = (-1.0f64, 1.0f64);
    for i in 0..4 {
        for j in i + 1..4 {
            let c = -f[i].dot(f[j]);
            cmax = cmax.max(c);
            cmin = cmin.min(c);
        }
    }
    Some((cmax, cmin))
}

/// [`tet_dihedral_quality`] from the extreme cosines: the smallest angle (largest cosine) and
/// the largest angle (smallest cosine) against the regular tet's.
#[inline]
fn dihedral_quality_of_cosines(cmax: f64, cmin: f64) -> f64 {
    let lo = cmax.clamp(-1.0, 1.0).acos().to_degrees();
    let hi = cmin.clamp(-1.0, 1.0).acos().to_degrees();
    (lo / REGULAR_DIHEDRAL).min((180.0 - hi) / (180.0 - REGULAR_DIHEDRAL))
}

/// Whether [`tet_dihedral_quality`] is below `thr`, without an acos: theta_min < thr 70.53
/// degrees or theta_max > 180 - thr 109.47 degrees, compared as cosines (the scan over every
/// tet every step). `cos_lo` and `cos_hi` come from [`dihedral_quality_cos_bounds`].
pub(crate) fn tet_dihedral_quality_below(p: [DVec3; 4], cos_lo: f64, cos_hi: f64) -> bool {
    if tet_volume(p) <= 0.0 {
        return true;
    }
    let n = |a: usize, b: usize, c: usize| (p[b] - p[a]).cross(p[c] - p[a]).normalize_or_zero();
    let f = [n(1, 2, 3), n(0, 3, 2), n(0, 1, 3), n(0, 2, 1)];
    for i in 0..4 {
        for j in i + 1..4 {
            let c = -f[i].dot(f[j]);
            if c > cos_lo || c < cos_hi {
                return true;
            }
        }
    }
    false
}

/// The cosine bounds of [`tet_dihedral_quality_below`] for a threshold.
pub(crate) fn dihedral_quality_cos_bounds(thr: f64) -> (f64, f64) {
    ((thr * REGULAR_DIHEDRAL).to_radians().cos(), (180.0 - thr * (180.0 - REGULAR_DIHEDRAL)).to_radians().cos())
}

/// Standard deviation over mean of `samples` (0 for none): the spread measure of the size
/// deviation.
fn spread(samples: &[f64]) -> f64 {
    let n = samples.len().max(1) as f64;
    let mean = samples.iter().sum::<f64>() / n;
    let var = samples.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    var.sqrt() / mean
}

/// Size deviation of a triangle mesh: std / mean over triangles of circumradius / h(centroid)
/// (seed section 2.7).
pub fn size_deviation(m: &crate::topology::TriMesh<DVec2>, h: &dyn Fn(DVec2) -> f64) -> f64 {
    let v: Vec<f64> = m
        .face_ids()
        .map(|f| {
            let [a, b, c] = m.face_points(f);
            circumradius_from_lengths(b.distance(c), c.distance(a), a.distance(b)) / h((a + b + c) / 3.0)
        })
        .collect();
    spread(&v)
}

/// Size deviation of a tetrahedral mesh: std / mean over tetrahedra of circumradius /
/// h(centroid) (seed section 2.7).
pub fn size_deviation_3d(m: &crate::topology::TetMesh, h: &dyn Fn(DVec3) -> f64) -> f64 {
    let v: Vec<f64> = m
        .tet_ids()
        .map(|t| {
            let p = m.tet_points(t);
            tet_circumradius(p) / h((p[0] + p[1] + p[2] + p[3]) / 4.0)
        })
        .collect();
    spread(&v)
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

    #[test]
    fn regular_tet_has_dihedral_quality_one() {
        let s = 1.0 / 2f64.sqrt();
        let p =
            [DVec3::new(1.0, 0.0, -s), DVec3::new(-1.0, 0.0, -s), DVec3::new(0.0, 1.0, s), DVec3::new(0.0, -1.0, s)];
        let p = if tet_volume(p) > 0.0 { p } else { [p[1], p[0], p[2], p[3]] };
        assert!((tet_dihedral_quality(p) - 1.0).abs() < 1e-9, "{}", tet_dihedral_quality(p));
        let flat = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)];
        assert!(tet_dihedral_quality(flat) < 0.0);
    }

    #[test]
    fn dihedral_quality_below_agrees_with_the_quality() {
        let (cl, ch) = dihedral_quality_cos_bounds(0.5);
        let mut rng = crate::testing::Rng::new(crate::testing::SEED);
        let mut seen = [0usize; 2];
        for _ in 0..2000 {
            let p = [0; 4].map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64()));
            let q = tet_dihedral_quality(p);
            if (q - 0.5).abs() > 1e-9 {
                assert_eq!(tet_dihedral_quality_below(p, cl, ch), q < 0.5, "quality {q}");
                seen[(q < 0.5) as usize] += 1;
            }
        }
        assert!(seen[0] > 0 && seen[1] > 0, "both sides sampled: {seen:?}");
    }
}
