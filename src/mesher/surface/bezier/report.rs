//! What a mesh of Bézier patches is worth: element quality and sizes in space.

use super::edges_sorted;
use crate::quality::{triangle_angles_deg, triangle_q3};
use glam::DVec3;

/// Measured figures of a mesh in space, h the target size.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BezierQuality {
    /// Vertices.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
    /// Smallest angle, degrees.
    pub min_angle: f64,
    /// Smallest q.
    pub min_q: f64,
    /// Mean q.
    pub mean_q: f64,
    /// std / mean of edge length / h.
    pub size_deviation: f64,
    /// mean edge length / h.
    pub mean_size_ratio: f64,
}

impl BezierQuality {
    /// Measures a triangle list in space against the size `h`.
    pub fn measure(points: &[DVec3], tris: &[[usize; 3]], h: f64) -> BezierQuality {
        let (mut min_angle, mut min_q, mut sum_q) = (180.0f64, 1.0f64, 0.0);
        for t in tris {
            let [a, b, c] = t.map(|i| points[i]);
            min_q = min_q.min(triangle_q3([a, b, c]));
            sum_q += triangle_q3([a, b, c]);
            for ang in triangle_angles_deg(b.distance(c), c.distance(a), a.distance(b)) {
                min_angle = min_angle.min(ang);
            }
        }
        // Sorted edges: the sums, and so the figures, are the same bits every run.
        let r: Vec<f64> = edges_sorted(tris).iter().map(|&((a, b), _)| points[a].distance(points[b]) / h).collect();
        let n = r.len().max(1) as f64;
        let mean = r.iter().sum::<f64>() / n;
        let var = r.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
        BezierQuality {
            vertices: points.len(),
            triangles: tris.len(),
            min_angle,
            min_q,
            mean_q: sum_q / tris.len().max(1) as f64,
            size_deviation: var.sqrt() / mean,
            mean_size_ratio: mean,
        }
    }
}
