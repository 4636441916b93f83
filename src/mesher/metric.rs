//! Metric fields for anisotropic meshes (seed section 3.5): a symmetric positive definite M(x)
//! replaces the size h(x); every desired edge has length one in it, the length of an edge u
//! being sqrt(u^T M u) (seed eq. 3.18) with M averaged at its endpoints.

use crate::Error;
use glam::{DMat2, DMat3, DVec2, DVec3};
use std::sync::Arc;

/// A 2x2 symmetric metric [[a, b], [b, c]] (seed eq. 3.19).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metric2 {
    /// M_xx.
    pub a: f64,
    /// M_xy = M_yx.
    pub b: f64,
    /// M_yy.
    pub c: f64,
}

/// A metric field M(x) in 2-D.
pub type MetricFn2 = Arc<dyn Fn(DVec2) -> Metric2 + Send + Sync>;

impl Metric2 {
    /// [[a, b], [b, c]].
    pub const fn new(a: f64, b: f64, c: f64) -> Self {
        Metric2 { a, b, c }
    }
    /// The isotropic metric I / h^2 of a size h.
    pub fn isotropic(h: f64) -> Self {
        Metric2 { a: 1.0 / (h * h), b: 0.0, c: 1.0 / (h * h) }
    }
    /// R diag(1/h1^2, 1/h2^2) R^T (seed eq. 3.20): size `h1` along `dir`, `h2` across it.
    /// `dir` need not be unit length; a zero `dir` gives a non-finite metric, which the mesher
    /// rejects with an error naming the point.
    pub fn from_sizes(dir: DVec2, h1: f64, h2: f64) -> Self {
        let u = dir.normalize_or_zero();
        let w = DVec2::new(-u.y, u.x);
        let (l1, l2) = (1.0 / (h1 * h1), 1.0 / (h2 * h2));
        if u == DVec2::ZERO {
            return Metric2 { a: f64::NAN, b: f64::NAN, c: f64::NAN };
        }
        Metric2 {
            a: l1 * u.x * u.x + l2 * w.x * w.x,
            b: l1 * u.x * u.y + l2 * w.x * w.y,
            c: l1 * u.y * u.y + l2 * w.y * w.y,
        }
    }
    /// As a matrix.
    pub fn matrix(&self) -> DMat2 {
        DMat2::from_cols(DVec2::new(self.a, self.b), DVec2::new(self.b, self.c))
    }
    /// Finite and positive definite.
    pub fn is_spd(&self) -> bool {
        self.a.is_finite()
            && self.b.is_finite()
            && self.c.is_finite()
            && self.a > 0.0
            && self.c > 0.0
            && self.a * self.c - self.b * self.b > 0.0
    }
    /// The length of `u` in this metric, sqrt(u^T M u) (seed eq. 3.18).
    #[inline]
    pub fn length(&self, u: DVec2) -> f64 {
        (self.a * u.x * u.x + 2.0 * self.b * u.x * u.y + self.c * u.y * u.y).max(0.0).sqrt()
    }
    /// (M + N) / 2.
    #[inline]
    pub fn mean(&self, o: &Metric2) -> Metric2 {
        Metric2 { a: 0.5 * (self.a + o.a), b: 0.5 * (self.b + o.b), c: 0.5 * (self.c + o.c) }
    }
    /// Eigenvalues, smaller first.
    pub fn eigenvalues(&self) -> (f64, f64) {
        let m = 0.5 * (self.a + self.c);
        let r = (0.25 * (self.a - self.c) * (self.a - self.c) + self.b * self.b).sqrt();
        (m - r, m + r)
    }
    /// The smallest desired size, 1 / sqrt(largest eigenvalue).
    pub fn smallest_size(&self) -> f64 {
        1.0 / self.eigenvalues().1.sqrt()
    }
    /// The largest desired size, 1 / sqrt(smallest eigenvalue).
    pub fn largest_size(&self) -> f64 {
        1.0 / self.eigenvalues().0.sqrt()
    }
    /// An F with F^T F = M (upper Cholesky factor): |F u| is the metric length of u, and F
    /// maps a neighbourhood to the space where the metric is the identity.
    #[inline]
    pub fn factor(&self) -> DMat2 {
        let s = self.a.sqrt();
        let t = self.b / s;
        let r = (self.c - t * t).max(0.0).sqrt();
        DMat2::from_cols(DVec2::new(s, 0.0), DVec2::new(t, r))
    }
    /// The mean of several metrics.
    pub fn average(ms: &[Metric2]) -> Metric2 {
        let n = ms.len().max(1) as f64;
        let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
        for m in ms {
            a += m.a;
            b += m.b;
            c += m.c;
        }
        Metric2 { a: a / n, b: b / n, c: c / n }
    }
}

/// The metric length of the edge u integrated along it by Simpson's rule, from the metrics at
/// its start, midpoint and end: consistent where M varies fast along the edge (a boundary
/// layer), where the endpoint average of eq. 3.18 overestimates.
#[inline]
pub fn simpson_length(ma: &Metric2, mm: &Metric2, mb: &Metric2, u: DVec2) -> f64 {
    (ma.length(u) + 4.0 * mm.length(u) + mb.length(u)) / 6.0
}

/// Evaluates a metric field, failing on a non-finite or non-positive-definite value.
pub(crate) fn eval_metric(f: &MetricFn2, p: DVec2) -> Result<Metric2, Error> {
    let m = f(p);
    if m.is_spd() {
        Ok(m)
    } else if !(m.a.is_finite() && m.b.is_finite() && m.c.is_finite()) {
        let bad = [m.a, m.b, m.c].into_iter().find(|v| !v.is_finite()).unwrap_or(f64::NAN);
        Err(Error::NonFinite { what: "the metric", value: bad, at: [p.x, p.y, 0.0] })
    } else {
        Err(Error::BadSize(format!(
            "the metric [[{}, {}], [{}, {}]] at ({}, {}) is not positive definite (need a > 0, c > 0, ac - b^2 > 0)",
            m.a, m.b, m.b, m.c, p.x, p.y
        )))
    }
}

/// Quality of a triangle measured in a metric: q of its image under the metric's factor
/// (1 for a triangle equilateral in the metric).
pub fn metric_triangle_q(m: &Metric2, [a, b, c]: [DVec2; 3]) -> f64 {
    let f = m.factor();
    crate::quality::triangle_q([f * a, f * b, f * c])
}

/// A metric given on the nodes of a Cartesian grid, bilinearly interpolated (a convex
/// combination of positive definite matrices stays positive definite).
#[derive(Clone, Debug)]
pub struct MetricGrid2 {
    origin: DVec2,
    spacing: DVec2,
    nx: usize,
    ny: usize,
    values: Vec<Metric2>,
}

impl MetricGrid2 {
    /// `values` row by row (x fastest), `nx * ny` of them, each positive definite.
    pub fn new(origin: [f64; 2], spacing: [f64; 2], nx: usize, ny: usize, values: Vec<Metric2>) -> Result<Self, Error> {
        if nx < 2 || ny < 2 || values.len() != nx * ny {
            return Err(Error::Invalid(format!(
                "a metric grid needs at least 2 x 2 nodes and nx * ny values, got {nx} x {ny} and {}",
                values.len()
            )));
        }
        if !(spacing[0] > 0.0 && spacing[1] > 0.0 && spacing[0].is_finite() && spacing[1].is_finite()) {
            return Err(Error::Invalid(format!("metric grid spacing must be positive, got {spacing:?}")));
        }
        if let Some(i) = values.iter().position(|m| !m.is_spd()) {
            return Err(Error::BadSize(format!(
                "metric grid value {i} ({:?}) is not finite and positive definite",
                values[i]
            )));
        }
        Ok(MetricGrid2 { origin: origin.into(), spacing: spacing.into(), nx, ny, values })
    }
    /// The interpolated metric at `p` (clamped to the grid).
    pub fn at(&self, p: DVec2) -> Metric2 {
        let t = (p - self.origin) / self.spacing;
        let fx = t.x.clamp(0.0, (self.nx - 1) as f64);
        let fy = t.y.clamp(0.0, (self.ny - 1) as f64);
        let (i, j) = ((fx as usize).min(self.nx - 2), (fy as usize).min(self.ny - 2));
        let (u, v) = (fx - i as f64, fy - j as f64);
        let g = |i: usize, j: usize| self.values[j * self.nx + i];
        let (m00, m10, m01, m11) = (g(i, j), g(i + 1, j), g(i, j + 1), g(i + 1, j + 1));
        let w = [(1.0 - u) * (1.0 - v), u * (1.0 - v), (1.0 - u) * v, u * v];
        let ms = [m00, m10, m01, m11];
        let mut out = Metric2::new(0.0, 0.0, 0.0);
        for k in 0..4 {
            out.a += w[k] * ms[k].a;
            out.b += w[k] * ms[k].b;
            out.c += w[k] * ms[k].c;
        }
        out
    }
}

/// A 3x3 symmetric metric, ready for surfaces and volumes: the same operations as
/// [`Metric2`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metric3(pub DMat3);

impl Metric3 {
    /// I / h^2.
    pub fn isotropic(h: f64) -> Self {
        Metric3(DMat3::from_diagonal(DVec3::splat(1.0 / (h * h))))
    }
    /// R diag(1/h1^2, 1/h2^2, 1/h3^2) R^T with R's columns the orthonormal `axes`.
    pub fn from_axes(axes: [DVec3; 3], h: [f64; 3]) -> Self {
        let r = DMat3::from_cols(axes[0], axes[1], axes[2]);
        let d = DMat3::from_diagonal(DVec3::new(1.0 / (h[0] * h[0]), 1.0 / (h[1] * h[1]), 1.0 / (h[2] * h[2])));
        Metric3(r * d * r.transpose())
    }
    /// sqrt(u^T M u).
    pub fn length(&self, u: DVec3) -> f64 {
        u.dot(self.0 * u).max(0.0).sqrt()
    }
    /// Symmetric, finite and positive definite (Sylvester's criterion).
    pub fn is_spd(&self) -> bool {
        let m = self.0;
        let sym = (m.x_axis.y - m.y_axis.x).abs() <= 1e-12 * m.x_axis.y.abs().max(1.0)
            && (m.x_axis.z - m.z_axis.x).abs() <= 1e-12 * m.x_axis.z.abs().max(1.0)
            && (m.y_axis.z - m.z_axis.y).abs() <= 1e-12 * m.y_axis.z.abs().max(1.0);
        let m1 = m.x_axis.x;
        let m2 = m.x_axis.x * m.y_axis.y - m.x_axis.y * m.y_axis.x;
        m.is_finite() && sym && m1 > 0.0 && m2 > 0.0 && m.determinant() > 0.0
    }
    /// (M + N) / 2.
    pub fn mean(&self, o: &Metric3) -> Metric3 {
        Metric3((self.0 + o.0) * 0.5)
    }
}

/// The anisotropic report: metric edge lengths (integrated, [`simpson_length`]) and metric
/// element quality (q in M at the centroid).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MetricStats {
    /// Number of edges.
    pub edges: usize,
    /// Share of edges with metric length in [1/sqrt 2, sqrt 2].
    pub in_band: f64,
    /// Smallest, mean and largest metric edge length.
    pub len_min: f64,
    /// Mean metric edge length.
    pub len_mean: f64,
    /// Largest metric edge length.
    pub len_max: f64,
    /// Smallest metric triangle quality.
    pub q_min: f64,
    /// Mean metric triangle quality.
    pub q_mean: f64,
}

impl MetricStats {
    /// The statistics of `m` in the metric `f`.
    pub fn of(m: &crate::topology::TriMesh<DVec2>, f: &dyn Fn(DVec2) -> Metric2) -> Self {
        let mut s = MetricStats { len_min: f64::INFINITY, q_min: 1.0, ..Default::default() };
        let (lo, hi) = (std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::SQRT_2);
        let mut inside = 0usize;
        let mut sum = 0.0;
        for h in m.edge_ids() {
            let (a, b) = (m.pos(m.origin(h)), m.pos(m.dest(h)));
            let l = simpson_length(&f(a), &f((a + b) * 0.5), &f(b), b - a);
            s.edges += 1;
            sum += l;
            s.len_min = s.len_min.min(l);
            s.len_max = s.len_max.max(l);
            if (lo..=hi).contains(&l) {
                inside += 1;
            }
        }
        if s.edges > 0 {
            s.in_band = inside as f64 / s.edges as f64;
            s.len_mean = sum / s.edges as f64;
        }
        let mut qs = 0.0;
        for t in m.face_ids() {
            let p = m.face_points(t);
            let q = metric_triangle_q(&f((p[0] + p[1] + p[2]) / 3.0), p);
            qs += q;
            s.q_min = s.q_min.min(q);
        }
        s.q_mean = qs / m.num_faces().max(1) as f64;
        s
    }
}

impl std::fmt::Display for MetricStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} edges, {:.1}% with metric length in [0.707, 1.414] (min {:.3}, mean {:.3}, max {:.3}); metric q min {:.3}, mean {:.4}",
            self.edges,
            100.0 * self.in_band,
            self.len_min,
            self.len_mean,
            self.len_max,
            self.q_min,
            self.q_mean
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_along_and_across_a_direction() {
        let m = Metric2::from_sizes(DVec2::new(1.0, 1.0), 0.01, 0.2);
        assert!(m.is_spd());
        let u = DVec2::new(1.0, 1.0).normalize();
        assert!((m.length(u * 0.01) - 1.0).abs() < 1e-12);
        assert!((m.length(DVec2::new(-u.y, u.x) * 0.2) - 1.0).abs() < 1e-12);
        assert!((m.smallest_size() - 0.01).abs() < 1e-12);
        assert!((m.largest_size() - 0.2).abs() < 1e-9);
        let f = m.factor();
        let v = DVec2::new(0.3, -0.7);
        assert!(((f * v).length() - m.length(v)).abs() < 1e-9 * m.length(v));
    }

    #[test]
    fn bad_metrics_are_errors() {
        let f: MetricFn2 = Arc::new(|_| Metric2::new(1.0, 2.0, 1.0));
        assert!(matches!(eval_metric(&f, DVec2::ZERO), Err(Error::BadSize(_))));
        let g: MetricFn2 = Arc::new(|_| Metric2::new(f64::NAN, 0.0, 1.0));
        assert!(matches!(eval_metric(&g, DVec2::ZERO), Err(Error::NonFinite { .. })));
        assert!(!Metric2::from_sizes(DVec2::ZERO, 0.1, 0.2).is_spd());
    }

    #[test]
    fn grid_interpolation_stays_positive_definite() {
        let vals = vec![
            Metric2::isotropic(0.1),
            Metric2::from_sizes(DVec2::X, 0.01, 0.2),
            Metric2::from_sizes(DVec2::Y, 0.05, 0.1),
            Metric2::isotropic(1.0),
        ];
        let g = MetricGrid2::new([0.0, 0.0], [1.0, 1.0], 2, 2, vals.clone()).unwrap();
        assert_eq!(g.at(DVec2::new(1.0, 0.0)), vals[1]);
        assert!(g.at(DVec2::new(0.3, 0.6)).is_spd());
        assert!(MetricGrid2::new([0.0, 0.0], [1.0, 1.0], 2, 2, vec![Metric2::new(1.0, 2.0, 1.0); 4]).is_err());
    }

    #[test]
    fn metric3_lengths() {
        let m = Metric3::from_axes([DVec3::X, DVec3::Y, DVec3::Z], [0.1, 0.2, 0.5]);
        assert!(m.is_spd());
        assert!((m.length(DVec3::new(0.0, 0.2, 0.0)) - 1.0).abs() < 1e-12);
    }
}
