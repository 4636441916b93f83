//! What a surface mesh is worth: topology, distance to the surface and element quality, measured
//! the same way for every mesh (ours, or a file from elsewhere).

use super::geom::{residual, SizeField};
use crate::geometry::Implicit3;
use crate::mesher::report::Report;
use crate::predicates::{orient3d_dir, Sign};
use crate::quality::{triangle_angles_deg, triangle_q_from_lengths};
use crate::topology::{Level, TriMesh};
use glam::DVec3;
use std::fmt;

/// Measured figures of a surface mesh of phi = 0.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceQuality {
    /// Vertices.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
    /// V - E + F.
    pub euler: i64,
    /// The engine's topology check passed and there is no boundary edge.
    pub closed_manifold: bool,
    /// Triangles whose normal points against grad phi at their centroid and at all three
    /// corners (0 when consistently oriented outward).
    pub inward_faces: usize,
    /// Largest |phi| / |grad phi| at a vertex, divided by the smallest target size.
    pub vertex_residual: f64,
    /// Largest |phi| / |grad phi| at a triangle centroid, divided by the local target size.
    pub centroid_deviation_max: f64,
    /// Mean of the same.
    pub centroid_deviation_mean: f64,
    /// Smallest angle, degrees.
    pub min_angle: f64,
    /// Largest angle, degrees.
    pub max_angle: f64,
    /// Smallest q = 2 r_in / r_out.
    pub min_q: f64,
    /// Mean q.
    pub mean_q: f64,
    /// Standard deviation over mean of edge length / h(midpoint).
    pub size_deviation: f64,
    /// The project's size deviation (docs/quality.md, seed section 2.7): standard deviation
    /// over mean, over triangles, of circumradius / h(centroid).
    pub circumradius_deviation: f64,
    /// Mean edge length / h(midpoint).
    pub mean_size_ratio: f64,
}

impl SurfaceQuality {
    /// Measures `m` against the surface `phi` and the target sizes `size`.
    pub fn measure(m: &TriMesh<DVec3>, phi: &dyn Implicit3, size: &SizeField) -> SurfaceQuality {
        let hmin = size.min();
        let closed_manifold = m.validate(Level::Topology).is_ok() && m.boundary_loops().is_empty();
        let vertex_residual = m.vertices().map(|(_, v)| residual(phi, v.pos)).fold(0.0, f64::max) / hmin;
        let (mut min_angle, mut max_angle, mut min_q, mut sum_q) = (180.0f64, 0.0f64, 1.0f64, 0.0);
        let (mut cmax, mut csum, mut inward) = (0.0f64, 0.0, 0);
        let mut radii = Vec::with_capacity(m.num_faces());
        for f in m.face_ids() {
            let [a, b, c] = m.face_points(f);
            let (la, lb, lc) = (b.distance(c), c.distance(a), a.distance(b));
            let q = triangle_q_from_lengths(la, lb, lc);
            min_q = min_q.min(q);
            sum_q += q;
            for ang in triangle_angles_deg(la, lb, lc) {
                min_angle = min_angle.min(ang);
                max_angle = max_angle.max(ang);
            }
            let cen = (a + b + c) / 3.0;
            radii.push(crate::quality::circumradius_from_lengths(la, lb, lc) / size.at(cen));
            let dev = residual(phi, cen) / size.at(cen);
            cmax = cmax.max(dev);
            csum += dev;
            // Against grad phi at the centroid and at all three corners: beside a sharp edge a
            // face whose centroid lies nearer the other side's plane (a fraction of a degree
            // past the right angle there) is against grad phi at its centroid only.
            if [cen, a, b, c].into_iter().all(|p| orient3d_dir(a, b, c, phi.gradient(p)) != Sign::Positive) {
                inward += 1;
            }
        }
        let nf = m.num_faces().max(1) as f64;
        let ratios: Vec<f64> = m
            .edge_ids()
            .map(|h| {
                let (p, q) = (m.pos(m.origin(h)), m.pos(m.dest(h)));
                p.distance(q) / size.at(0.5 * (p + q))
            })
            .collect();
        let ne = ratios.len().max(1) as f64;
        let mean = ratios.iter().sum::<f64>() / ne;
        let var = ratios.iter().map(|r| (r - mean) * (r - mean)).sum::<f64>() / ne;
        let rmean = radii.iter().sum::<f64>() / nf;
        let rvar = radii.iter().map(|r| (r - rmean) * (r - rmean)).sum::<f64>() / nf;
        SurfaceQuality {
            circumradius_deviation: rvar.sqrt() / rmean,
            vertices: m.num_vertices(),
            triangles: m.num_faces(),
            euler: m.euler_characteristic(),
            closed_manifold,
            inward_faces: inward,
            vertex_residual,
            centroid_deviation_max: cmax,
            centroid_deviation_mean: csum / nf,
            min_angle,
            max_angle,
            min_q,
            mean_q: sum_q / nf,
            size_deviation: var.sqrt() / mean,
            mean_size_ratio: mean,
        }
    }
}

impl fmt::Display for Report<SurfaceQuality> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let q = &self.quality;
        let st = self.stages.unwrap_or_default();
        writeln!(
            f,
            "surface: {} vertices, {} triangles, Euler characteristic {} ({}closed manifold, {} inward faces)",
            q.vertices,
            q.triangles,
            q.euler,
            if q.closed_manifold { "" } else { "NOT " },
            q.inward_faces
        )?;
        writeln!(
            f,
            "iterations {} ({}), kept {}, on coarser levels {}; remesh passes {}, equalising sweeps {}; splits {}, collapses {}, flips {}, undone moves {}",
            self.iterations,
            self.stop,
            st.kept_iteration,
            st.coarse_iterations,
            st.remesh_passes,
            st.equalize_sweeps,
            self.ops.splits,
            self.ops.collapses,
            self.ops.flips,
            self.ops.undone
        )?;
        writeln!(
            f,
            "min angle {:.1}, max angle {:.1}, min q {:.3}, mean q {:.4}, size deviation {:.1}% (circumradius/h; edge length/h: {:.1}%, mean length/h {:.3})",
            q.min_angle,
            q.max_angle,
            q.min_q,
            q.mean_q,
            100.0 * q.circumradius_deviation,
            100.0 * q.size_deviation,
            q.mean_size_ratio
        )?;
        write!(
            f,
            "vertex residual {:.1e} h, centroid deviation max {:.2e} h, mean {:.2e} h; {:.2} s (start {:.2}, remeshing {:.2}, force loop {:.2}, equalising {:.2})",
            q.vertex_residual,
            q.centroid_deviation_max,
            q.centroid_deviation_mean,
            self.seconds,
            st.stage_seconds[0],
            st.stage_seconds[1],
            st.stage_seconds[2],
            st.stage_seconds[3]
        )?;
        if q.triangles > 0 && (q.min_q.is_nan() || q.min_q < crate::mesher::report::Q_FLOOR) {
            write!(f, "\nwarning: poor triangles: min q {:.3} is below {}", q.min_q, crate::mesher::report::Q_FLOOR)?;
        }
        if q.inward_faces > 0 || !q.closed_manifold {
            write!(
                f,
                "\nwarning: the surface is {}a closed manifold and has {} inward faces",
                if q.closed_manifold { "" } else { "NOT " },
                q.inward_faces
            )?;
        }
        self.warnings(f)
    }
}
