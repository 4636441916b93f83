//! The curvature of a triangulated surface at its vertices, for automatic sizes (the distance
//! to flat triangles has no curvature to sample). At a vertex v with area A = a third of its
//! triangles' areas:
//! - the mean curvature H = sum |e| theta_e / (4 A) over its edges, theta_e the signed turn of
//!   the normals across e (the integral of H over a polyhedral surface is half the sum of
//!   |e| theta_e over its edges);
//! - the Gaussian curvature K = (2 pi - the angles at v) / A (the angle defect);
//! - the largest principal curvature |H| + sqrt(max(H^2 - K, 0)): 1/R on a sphere or a
//!   cylinder of radius R cut into flat facets of any shape.
//!
//! Sharp edges at the feature angle count for nothing: the meshers hold them as curves rather
//! than resolving them by size (and a corner's angle defect leaves no curvature either).

use super::TriSurface;
use glam::DVec3;

impl TriSurface {
    /// The largest principal curvature at every vertex (see the module notes), with feature
    /// edges at `feature_angle` degrees left out (None: every edge counts).
    pub(super) fn vertex_curvature(&self, feature_angle: Option<f64>) -> Vec<f64> {
        let cos_max = feature_angle.map_or(f64::NEG_INFINITY, |a| a.to_radians().cos());
        let n = self.points.len();
        let (mut area, mut turn, mut angles) = (vec![0.0f64; n], vec![0.0f64; n], vec![0.0f64; n]);
        let p = &self.points;
        for (t, tri) in self.tris.iter().enumerate() {
            let [a, b, c] = tri.map(|v| p[v]);
            let third = (b - a).cross(c - a).length() / 6.0;
            for k in 0..3 {
                let (v, prev, next) = (tri[k], p[tri[(k + 2) % 3]], p[tri[(k + 1) % 3]]);
                area[v] += third;
                angles[v] += (prev - p[v]).angle_between(next - p[v]);
                let w = self.neighbors[t][k];
                // Each edge once, from the lower-numbered triangle.
                if w < t {
                    continue;
                }
                let (n1, n2) = (self.normals.face(t), self.normals.face(w));
                let cos = n1.dot(n2).clamp(-1.0, 1.0);
                if cos < cos_max {
                    continue;
                }
                let (ea, eb) = (tri[k], tri[(k + 1) % 3]);
                // Convex where the far triangle lies behind this one's plane.
                let far = self.tris[w].iter().map(|&u| p[u]).sum::<DVec3>() / 3.0;
                let sign = if n1.dot(far - p[ea]) < 0.0 { 1.0 } else { -1.0 };
                let x = p[ea].distance(p[eb]) * cos.acos() * sign;
                turn[ea] += x;
                turn[eb] += x;
            }
        }
        (0..n)
            .map(|v| {
                if area[v] <= 0.0 {
                    return 0.0;
                }
                let h = turn[v] / (4.0 * area[v]);
                let k = (std::f64::consts::TAU - angles[v]) / area[v];
                h.abs() + (h * h - k).max(0.0).sqrt()
            })
            .collect()
    }

    /// The curvature of the surface at its point nearest `p`: the largest of the nearest
    /// triangle's corners.
    pub(super) fn curvature_near(&self, p: DVec3) -> f64 {
        let kappa = self.curvature.get_or_init(|| self.vertex_curvature(self.feature_angle));
        self.tris[self.closest(p).triangle].iter().map(|&v| kappa[v]).fold(0.0, f64::max)
    }
}
