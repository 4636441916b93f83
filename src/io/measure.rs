//! What a picture colours its cells by: a named per-cell measure with its range, so that the
//! colour bar, the histogram and the summary line all say what they show.

use super::{CellType, MeshData};
use crate::quality::{tet_dihedral_angles_deg, triangle_q_from_lengths};
use glam::{DVec2, DVec3};
use rayon::prelude::*;

/// Cells per parallel task of the per-cell measures (each value depends on its cell alone, so
/// the result is the same for any thread count).
const PAR_CELLS: usize = 16_384;

/// The dihedral angle of the regular tetrahedron, arccos(1/3) in degrees: the largest smallest
/// dihedral angle a tetrahedron can have.
pub const REGULAR_DIHEDRAL_DEG: f64 = 70.528_779_365_509_3;

/// A per-cell measure: `values[i]` for cell i, drawn from `lo` (red, bad) to `hi` (green, good).
#[derive(Clone, Debug, PartialEq)]
pub struct Measure {
    /// The measure's name as the legend gives it ("q", "metric q", "min dihedral angle").
    pub name: String,
    /// What the numbers are in ("" or "°").
    pub unit: String,
    /// One value per cell.
    pub values: Vec<f64>,
    /// The worst value (red).
    pub lo: f64,
    /// The best value (green).
    pub hi: f64,
}

fn pt(m: &MeshData, i: usize) -> DVec3 {
    DVec3::from_array(m.points[i])
}

/// q = 2 r_in / r_out of every triangle (planar or in space).
pub fn triangle_q_values(m: &MeshData) -> Vec<f64> {
    (0..m.num_cells())
        .into_par_iter()
        .with_min_len(PAR_CELLS)
        .map(|i| {
            let c = m.cell(i);
            let p = [pt(m, c[0]), pt(m, c[1]), pt(m, c[2])];
            triangle_q_from_lengths(p[1].distance(p[2]), p[2].distance(p[0]), p[0].distance(p[1]))
        })
        .collect()
}

/// The radius ratio 3 r_in / r_out of every tetrahedron.
pub fn tet_radius_ratio_values(m: &MeshData) -> Vec<f64> {
    (0..m.num_cells())
        .into_par_iter()
        .with_min_len(PAR_CELLS)
        .map(|i| {
            let c = m.cell(i);
            crate::quality::tet_radius_ratio([pt(m, c[0]), pt(m, c[1]), pt(m, c[2]), pt(m, c[3])])
        })
        .collect()
}

/// The smallest dihedral angle of every tetrahedron, in degrees.
pub fn tet_min_dihedral_values(m: &MeshData) -> Vec<f64> {
    (0..m.num_cells())
        .into_par_iter()
        .with_min_len(PAR_CELLS)
        .map(|i| {
            let c = m.cell(i);
            let a = tet_dihedral_angles_deg([pt(m, c[0]), pt(m, c[1]), pt(m, c[2]), pt(m, c[3])]);
            a.into_iter().fold(f64::INFINITY, f64::min)
        })
        .collect()
}

impl Measure {
    /// The usual measure of a mesh: q for triangles, the smallest dihedral angle for tetrahedra.
    pub fn default_for(m: &MeshData) -> Measure {
        match m.cell_type {
            CellType::Triangle => {
                Measure { name: "q".into(), unit: String::new(), values: triangle_q_values(m), lo: 0.0, hi: 1.0 }
            }
            CellType::Tetra => Measure {
                name: "min dihedral angle".into(),
                unit: "°".into(),
                values: tet_min_dihedral_values(m),
                lo: 0.0,
                hi: REGULAR_DIHEDRAL_DEG,
            },
        }
    }

    /// q measured in a metric (1 for a triangle equilateral in the metric at its centroid): the
    /// quality an anisotropic mesh is made for. Planar triangles only; the metric is evaluated
    /// once per triangle.
    pub fn metric_q(m: &MeshData, metric: &dyn Fn(DVec2) -> crate::mesher::Metric2) -> Measure {
        let values = (0..m.num_cells())
            .map(|i| {
                let c = m.cell(i);
                let p = [0, 1, 2].map(|k| DVec2::new(m.points[c[k]][0], m.points[c[k]][1]));
                let centroid = (p[0] + p[1] + p[2]) / 3.0;
                crate::mesher::metric::metric_triangle_q(&metric(centroid), p)
            })
            .collect();
        Measure { name: "metric q".into(), unit: String::new(), values, lo: 0.0, hi: 1.0 }
    }

    /// Where `v` lies between `lo` (0) and `hi` (1), clamped; NaN counts as the worst.
    pub fn fraction(&self, v: f64) -> f64 {
        let t = (v - self.lo) / (self.hi - self.lo);
        if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// A value as the legend prints it: three decimals below 10, one above, and the unit.
    pub fn label(&self, v: f64) -> String {
        let s = if v == 0.0 || v == 1.0 {
            format!("{v}")
        } else if v.abs() >= 10.0 {
            format!("{v:.1}")
        } else {
            format!("{v:.3}")
        };
        let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
        format!("{s}{}", self.unit)
    }
}
