//! `trussmesh stats`: counts and quality of a mesh file.

use super::mesh::parse_expr;
use super::Failure;
use clap::Args;
use glam::DVec3;
use serde::Serialize;
use std::path::PathBuf;
use trussmesh::expr::Expr;
use trussmesh::io::{CellType, MeshData};
use trussmesh::quality;

/// Print counts and quality statistics of a mesh file.
#[derive(Args, Debug)]
pub struct StatsArgs {
    /// A mesh file (.json .vtu .msh .mesh .obj .stl .ply).
    pub file: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Domain d(x, y[, z]): report the largest |d| over boundary vertices (for a surface mesh:
    /// phi, and the distance |phi| / |grad phi| over all vertices).
    #[arg(long, value_name = "EXPR", allow_hyphen_values = true)]
    pub domain: Option<String>,
    /// The domain is a level set: use |d| / |grad d| as the distance (needs --domain).
    #[arg(long, requires = "domain")]
    pub implicit: bool,
    /// Relative size h(x, y[, z]): report std/mean of circumradius / h(centroid).
    #[arg(long, value_name = "EXPR", allow_hyphen_values = true)]
    pub size: Option<String>,
    /// Exit with code 2 when the mesh is invalid (reversed, degenerate, duplicated or
    /// overlapping cells, non-manifold facets or vertices).
    #[arg(long)]
    pub check: bool,
}

/// Triangle quality.
#[derive(Serialize, Debug, Clone)]
pub struct TriStats {
    pub q_min: f64,
    pub q_mean: f64,
    pub q_p1: f64,
    pub q_p5: f64,
    pub q_p50: f64,
    pub angle_min: f64,
    pub angle_max: f64,
}

/// Tetrahedron quality.
#[derive(Serialize, Debug, Clone)]
pub struct TetStats {
    pub radius_ratio_min: f64,
    pub radius_ratio_mean: f64,
    pub dihedral_min: f64,
    pub dihedral_max: f64,
}

/// Everything `stats` reports.
#[derive(Serialize, Debug, Clone)]
pub struct MeshStats {
    /// No problem found by the validity checks.
    pub valid: bool,
    /// What the validity checks found, one line per kind of problem.
    pub problems: Vec<String>,
    pub dim: usize,
    pub cell_type: &'static str,
    pub nodes: usize,
    pub cells: usize,
    pub boundary_facets: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub triangles: Option<TriStats>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tets: Option<TetStats>,
    /// std / mean over cells of circumradius / h(centroid).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub size_deviation: Option<f64>,
    /// max |d| over the vertices of boundary facets (planar and tetrahedral meshes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub boundary_max_abs_d: Option<f64>,
    /// Topology and distance to phi = 0 of a surface mesh (triangles in space).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface: Option<super::surface_stats::SurfaceStats>,
}

fn pt(m: &MeshData, i: usize) -> DVec3 {
    DVec3::from_array(m.points[i])
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    let n = sorted.len();
    let k = ((p * n as f64).ceil() as usize).clamp(1, n);
    sorted[k - 1]
}

fn tet_circumradius(p: [DVec3; 4]) -> f64 {
    let (a, b, c) = (p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    let vol6 = a.dot(b.cross(c));
    if vol6 == 0.0 {
        return f64::INFINITY;
    }
    let num = a.length_squared() * b.cross(c) + b.length_squared() * c.cross(a) + c.length_squared() * a.cross(b);
    num.length() / (2.0 * vol6.abs())
}

/// Computes the statistics; `size` and `domain` are evaluated at (x, y, z).
pub fn compute(m: &MeshData, domain: Option<(&Expr, bool)>, size: Option<&Expr>) -> Result<MeshStats, Failure> {
    let n = m.num_cells();
    let mut radius = Vec::with_capacity(n);
    let mut centroid = Vec::with_capacity(n);
    let mut triangles = None;
    let mut tets = None;
    match m.cell_type {
        CellType::Triangle => {
            let mut qs = Vec::with_capacity(n);
            let (mut amin, mut amax) = (180.0f64, 0.0f64);
            for i in 0..n {
                let c = m.cell(i);
                let [a, b, d] = [pt(m, c[0]), pt(m, c[1]), pt(m, c[2])];
                let (la, lb, lc) = (b.distance(d), d.distance(a), a.distance(b));
                qs.push(quality::triangle_q_from_lengths(la, lb, lc));
                for ang in quality::triangle_angles_deg(la, lb, lc).into_iter().filter(|a| a.is_finite()) {
                    amin = amin.min(ang);
                    amax = amax.max(ang);
                }
                radius.push(quality::circumradius_from_lengths(la, lb, lc));
                centroid.push((a + b + d) / 3.0);
            }
            if amin <= amax {
                let mean = qs.iter().sum::<f64>() / n as f64;
                qs.sort_by(f64::total_cmp);
                triangles = Some(TriStats {
                    q_min: qs[0],
                    q_mean: mean,
                    q_p1: percentile(&qs, 0.01),
                    q_p5: percentile(&qs, 0.05),
                    q_p50: percentile(&qs, 0.5),
                    angle_min: amin,
                    angle_max: amax,
                });
            }
        }
        CellType::Tetra => {
            let (mut rmin, mut rsum) = (1.0f64, 0.0);
            let (mut dmin, mut dmax) = (180.0f64, 0.0f64);
            for i in 0..n {
                let c = m.cell(i);
                let p = [pt(m, c[0]), pt(m, c[1]), pt(m, c[2]), pt(m, c[3])];
                let r = quality::tet_radius_ratio(p);
                rmin = rmin.min(r);
                rsum += r;
                for a in quality::tet_dihedral_angles_deg(p).into_iter().filter(|a| a.is_finite()) {
                    dmin = dmin.min(a);
                    dmax = dmax.max(a);
                }
                radius.push(tet_circumradius(p));
                centroid.push((p[0] + p[1] + p[2] + p[3]) / 4.0);
            }
            if dmin <= dmax {
                tets = Some(TetStats {
                    radius_ratio_min: rmin,
                    radius_ratio_mean: rsum / n as f64,
                    dihedral_min: dmin,
                    dihedral_max: dmax,
                });
            }
        }
    }
    let size_deviation = match size {
        Some(h) => {
            let mut ratios = Vec::with_capacity(n);
            for (r, c) in radius.iter().zip(&centroid) {
                let hv = h.eval(c.x, c.y, c.z);
                if !(hv.is_finite() && hv > 0.0) {
                    return Err(Failure::bad(format!(
                        "--size {:?} is {hv} at ({}, {}, {}); it must be positive",
                        h.source(),
                        c.x,
                        c.y,
                        c.z
                    )));
                }
                if r.is_finite() {
                    ratios.push(r / hv);
                }
            }
            if ratios.is_empty() {
                None
            } else {
                let k = ratios.len() as f64;
                let mean = ratios.iter().sum::<f64>() / k;
                let var = ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / k;
                Some(var.sqrt() / mean)
            }
        }
        None => None,
    };
    let facets = m.boundary_facets();
    let is_surface = m.dim == 3 && m.cell_type == CellType::Triangle;
    let boundary_max_abs_d = domain.filter(|_| !is_surface).map(|(d, implicit)| {
        let mut on = vec![false; m.points.len()];
        for f in &facets {
            for &v in f {
                on[v] = true;
            }
        }
        let mut worst = 0.0f64;
        for (i, _) in on.iter().enumerate().filter(|(_, &b)| b) {
            let [x, y, z] = m.points[i];
            let dist = if implicit {
                let (v, g) = d.eval_grad(x, y, z);
                let gn = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                if gn > 0.0 {
                    v.abs() / gn
                } else {
                    v.abs()
                }
            } else {
                d.eval(x, y, z).abs()
            };
            worst = worst.max(dist);
        }
        worst
    });
    let check = trussmesh::io::check_mesh(m);
    let fans_ok = !check.problems.iter().any(|p| p.kind == trussmesh::io::ProblemKind::NonManifoldVertex);
    let surface = is_surface.then(|| super::surface_stats::compute(m, domain.map(|(d, _)| d), fans_ok));
    Ok(MeshStats {
        valid: check.is_valid(),
        problems: check.problems.iter().map(|p| p.message.clone()).collect(),
        dim: m.dim,
        cell_type: match m.cell_type {
            CellType::Triangle => "triangle",
            CellType::Tetra => "tetra",
        },
        nodes: m.points.len(),
        cells: n,
        boundary_facets: facets.len(),
        triangles,
        tets,
        size_deviation,
        boundary_max_abs_d,
        surface,
    })
}

impl std::fmt::Display for MeshStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.valid {
            writeln!(f, "valid: consistently oriented, no degenerate, duplicated or overlapping cells, manifold")?;
        } else {
            writeln!(
                f,
                "INVALID MESH: {} kind{} of problem; the figures below describe an invalid mesh",
                self.problems.len(),
                if self.problems.len() == 1 { "" } else { "s" }
            )?;
            for p in &self.problems {
                writeln!(f, "  - {p}")?;
            }
        }
        writeln!(
            f,
            "{}-D {} mesh: {} nodes, {} cells, {} boundary facets",
            self.dim, self.cell_type, self.nodes, self.cells, self.boundary_facets
        )?;
        if self.triangles.is_none() && self.tets.is_none() && self.cells > 0 {
            writeln!(f, "no quality figures: no cell has a positive size")?;
        }
        if let Some(t) = &self.triangles {
            writeln!(
                f,
                "q: min {:.4}, mean {:.4}, 1% {:.4}, 5% {:.4}, 50% {:.4}",
                t.q_min, t.q_mean, t.q_p1, t.q_p5, t.q_p50
            )?;
            writeln!(f, "angles: {:.2} to {:.2} degrees", t.angle_min, t.angle_max)?;
        }
        if let Some(t) = &self.tets {
            writeln!(f, "radius ratio: min {:.4}, mean {:.4}", t.radius_ratio_min, t.radius_ratio_mean)?;
            writeln!(f, "dihedral angles: {:.2} to {:.2} degrees", t.dihedral_min, t.dihedral_max)?;
        }
        if let Some(s) = self.size_deviation {
            writeln!(f, "size deviation (std/mean of circumradius/h): {s:.4}")?;
        }
        if let Some(d) = self.boundary_max_abs_d {
            writeln!(f, "boundary fidelity (max |d| on boundary vertices): {d:.3e}")?;
        }
        if let Some(s) = &self.surface {
            write!(f, "{s}")?;
        }
        Ok(())
    }
}

/// `trussmesh stats`.
pub fn run(a: StatsArgs) -> Result<(), Failure> {
    let domain = match &a.domain {
        Some(s) => Some(parse_expr("--domain", s)?),
        None => None,
    };
    let size = match &a.size {
        Some(s) => Some(parse_expr("--size", s)?),
        None => None,
    };
    let m = trussmesh::io::read_mesh(&a.file)?;
    let s = compute(&m, domain.as_ref().map(|d| (d, a.implicit)), size.as_ref())?;
    if a.json {
        let text =
            serde_json::to_string_pretty(&s).map_err(|e| Failure::internal(format!("cannot print JSON: {e}")))?;
        println!("{text}");
    } else {
        println!("file: {}", a.file.display());
        print!("{s}");
    }
    if a.check && !s.valid {
        return Err(Failure::bad(format!("{} is not a valid mesh: {}", a.file.display(), s.problems.join("; "))));
    }
    Ok(())
}
