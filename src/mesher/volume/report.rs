//! What a 3-D meshing run reports.

use crate::geometry::Implicit3;
use crate::mesher::report::Report;
use crate::topology::{TetId, TetMesh};

/// Quality statistics of a tetrahedral mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QualityStats3 {
    /// Number of tetrahedra.
    pub tets: usize,
    /// Number of vertices.
    pub vertices: usize,
    /// Smallest radius ratio 3 r_in / r_out.
    pub rr_min: f64,
    /// Mean radius ratio.
    pub rr_mean: f64,
    /// Smallest dihedral angle in degrees.
    pub dihedral_min: f64,
    /// Largest dihedral angle in degrees.
    pub dihedral_max: f64,
}

impl QualityStats3 {
    /// The statistics of a mesh.
    pub fn of(m: &TetMesh) -> Self {
        use rayon::prelude::*;
        let mut s = QualityStats3 {
            tets: m.num_tets(),
            vertices: m.num_vertices(),
            rr_min: 1.0,
            dihedral_min: 180.0,
            ..Default::default()
        };
        // Fixed chunks summed in order: the same figures whatever the thread count.
        let ids: Vec<TetId> = m.tet_ids().collect();
        let parts: Vec<(f64, f64, f64, f64)> = ids
            .par_chunks(4096)
            .map(|chunk| {
                let (mut sum, mut rr_min, mut lo, mut hi) = (0.0, 1.0f64, 180.0f64, 0.0f64);
                for &t in chunk {
                    let p = m.tet_points(t);
                    let q = crate::quality::tet_radius_ratio(p);
                    sum += q;
                    rr_min = rr_min.min(q);
                    for a in crate::quality::tet_dihedral_angles_deg(p) {
                        lo = lo.min(a);
                        hi = hi.max(a);
                    }
                }
                (sum, rr_min, lo, hi)
            })
            .collect();
        let mut sum = 0.0;
        for (ps, pr, pl, ph) in parts {
            sum += ps;
            s.rr_min = s.rr_min.min(pr);
            s.dihedral_min = s.dihedral_min.min(pl);
            s.dihedral_max = s.dihedral_max.max(ph);
        }
        if s.tets > 0 {
            s.rr_mean = sum / s.tets as f64;
        } else {
            s.rr_min = 0.0;
        }
        s
    }
}

impl std::fmt::Display for Report<QualityStats3> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let q = &self.quality;
        writeln!(
            f,
            "{} vertices, {} tetrahedra in {:.3} s, {} iterations ({})",
            q.vertices, q.tets, self.seconds, self.iterations, self.stop
        )?;
        writeln!(
            f,
            "radius ratio min {:.4}, mean {:.4}; dihedral angles {:.1} to {:.1} degrees",
            q.rr_min, q.rr_mean, q.dihedral_min, q.dihedral_max
        )?;
        write!(
            f,
            "{} flips, {} splits, {} collapses, {} smoothing moves",
            self.ops.flips, self.ops.splits, self.ops.collapses, self.ops.smoothings
        )?;
        if self.feature_points > 0 {
            write!(f, "\n{} points held on sharp edges", self.feature_points)?;
        }
        if q.tets > 0 && (q.dihedral_min.is_nan() || q.dihedral_min < crate::mesher::report::DIHEDRAL_FLOOR) {
            write!(
                f,
                "\nwarning: poor tetrahedra: dihedral angles down to {:.1} degrees, below {}",
                q.dihedral_min,
                crate::mesher::report::DIHEDRAL_FLOOR
            )?;
        }
        self.warnings(f)
    }
}

/// Largest |d| / |grad d| over boundary vertices: how far the boundary nodes are from d = 0.
pub fn boundary_deviation_3d(m: &TetMesh, domain: &dyn Implicit3) -> f64 {
    let mut on = std::collections::BTreeSet::new();
    for (t, i) in m.boundary_faces() {
        on.extend(m.face_vertices(t, i));
    }
    on.into_iter()
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

/// The boundary vertices where the boundary is pinched: their boundary faces form more than one
/// fan (joined across the edges from the vertex they share), so two parts of the boundary meet
/// at that vertex alone and the mesh's boundary is no manifold surface there. Every tet is
/// still positive and the mesh an embedding; the report says so (see `run_once`).
pub fn pinched_boundary_vertices(m: &TetMesh) -> Vec<crate::topology::TVertexId> {
    use std::collections::HashMap;
    let mut around: HashMap<crate::topology::TVertexId, Vec<[crate::topology::TVertexId; 3]>> = HashMap::new();
    for (t, i) in m.boundary_faces() {
        let f = m.face_vertices(t, i);
        for v in f {
            around.entry(v).or_default().push(f);
        }
    }
    let mut out: Vec<crate::topology::TVertexId> = around
        .iter()
        .filter(|(&v, faces)| {
            let mut fans = crate::topology::DisjointSets::new(faces.len());
            for i in 0..faces.len() {
                for j in i + 1..faces.len() {
                    if faces[i].iter().any(|&w| w != v && faces[j].contains(&w)) {
                        fans.join(i, j);
                    }
                }
            }
            let first = fans.root(0);
            (1..faces.len()).any(|i| fans.root(i) != first)
        })
        .map(|(&v, _)| v)
        .collect();
    // HashMap order is not fixed: sorted by position for a deterministic report.
    out.sort_by(|&a, &b| m.pos(a).to_array().partial_cmp(&m.pos(b).to_array()).unwrap_or(std::cmp::Ordering::Equal));
    out
}
