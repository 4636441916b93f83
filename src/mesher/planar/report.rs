//! What a meshing run reports.

use crate::mesher::report::Report;
use crate::topology::{MeshPoint, TriMesh};

/// Quality statistics of a triangle mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QualityStats {
    /// Number of triangles.
    pub triangles: usize,
    /// Number of vertices.
    pub vertices: usize,
    /// Minimum q = 2 r_in / r_out.
    pub q_min: f64,
    /// Mean q.
    pub q_mean: f64,
    /// Smallest angle in degrees.
    pub angle_min: f64,
    /// Largest angle in degrees.
    pub angle_max: f64,
}

impl QualityStats {
    /// The statistics of a mesh.
    pub fn of<P: MeshPoint>(m: &TriMesh<P>) -> Self {
        let mut s = QualityStats {
            triangles: m.num_faces(),
            vertices: m.num_vertices(),
            q_min: 1.0,
            angle_min: 180.0,
            ..Default::default()
        };
        let mut sum = 0.0;
        for f in m.face_ids() {
            let [a, b, c] = m.face_points(f);
            let (la, lb, lc) = (b.dist(c), c.dist(a), a.dist(b));
            let q = crate::quality::triangle_q_from_lengths(la, lb, lc);
            sum += q;
            s.q_min = s.q_min.min(q);
            for ang in crate::quality::triangle_angles_deg(la, lb, lc) {
                s.angle_min = s.angle_min.min(ang);
                s.angle_max = s.angle_max.max(ang);
            }
        }
        if s.triangles > 0 {
            s.q_mean = sum / s.triangles as f64;
        } else {
            s.q_min = 0.0;
        }
        s
    }
}

impl std::fmt::Display for Report<QualityStats> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let q = &self.quality;
        writeln!(
            f,
            "{} vertices, {} triangles in {:.3} s, {} iterations ({})",
            q.vertices, q.triangles, self.seconds, self.iterations, self.stop
        )?;
        if let Some(k) = self.kept_iteration {
            writeln!(f, "finished from the best state met, at iteration {k} (by the smallest quality)")?;
        }
        writeln!(
            f,
            "q min {:.4}, q mean {:.4}, angles {:.1} to {:.1} degrees",
            q.q_min, q.q_mean, q.angle_min, q.angle_max
        )?;
        write!(f, "{} flips, {} splits, {} collapses", self.ops.flips, self.ops.splits, self.ops.collapses)?;
        if self.feature_points > 0 {
            write!(f, "\n{} sharp corners held fixed", self.feature_points)?;
        }
        if let Some(m) = &self.metric {
            write!(f, "\nmetric: {m}")?;
        }
        // With a metric the triangles are meant to be stretched: their quality is measured in
        // the metric, and the isotropic q says nothing about them.
        if let Some(m) = self.metric.as_ref().filter(|m| m.q_min.is_nan() || m.q_min < crate::mesher::report::Q_FLOOR) {
            write!(
                f,
                "\nwarning: poor triangles in the metric: metric q min {:.4} is below {}",
                m.q_min,
                crate::mesher::report::Q_FLOOR
            )?;
        } else if self.metric.is_none()
            && q.triangles > 0
            && (q.q_min.is_nan() || q.q_min < crate::mesher::report::Q_FLOOR)
        {
            write!(
                f,
                "\nwarning: poor triangles: q min {:.4} is below {} (angles {:.1} to {:.1} degrees)",
                q.q_min,
                crate::mesher::report::Q_FLOOR,
                q.angle_min,
                q.angle_max
            )?;
        }
        self.warnings(f)
    }
}

/// Largest |d| / |grad d| over boundary vertices: how far the boundary nodes are from d = 0.
pub fn boundary_deviation(m: &TriMesh<glam::DVec2>, domain: &dyn crate::geometry::Implicit2) -> f64 {
    m.vertex_ids()
        .filter(|&v| m.is_boundary_vertex(v))
        .map(|v| {
            let p = m.pos(v);
            let d = domain.value(p).abs();
            if domain.is_distance() {
                d
            } else {
                d / domain.gradient(p).length()
            }
        })
        .fold(0.0, f64::max)
}

/// Total area of a planar mesh.
pub fn area(m: &TriMesh<glam::DVec2>) -> f64 {
    m.face_ids().map(|f| crate::quality::triangle_area(m.face_points(f))).sum()
}
