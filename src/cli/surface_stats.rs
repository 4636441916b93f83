//! `stats` of a surface mesh (triangles in space): topology (Euler characteristic, components,
//! genus, closed, manifold) and the distance of every vertex to phi = 0.

use serde::Serialize;
use std::collections::HashMap;
use trussmesh::expr::Expr;
use trussmesh::io::MeshData;
use trussmesh::topology::DisjointSets;

/// What `stats` reports of a surface mesh.
#[derive(Serialize, Debug, Clone)]
pub struct SurfaceStats {
    /// V - E + F.
    pub euler_characteristic: i64,
    /// Connected pieces (through shared edges and vertices).
    pub components: usize,
    /// Edges of one triangle only (0: closed).
    pub boundary_edges: usize,
    /// Edges of more than two triangles.
    pub non_manifold_edges: usize,
    /// Every edge in one or two triangles, and every vertex's triangles forming one fan.
    pub manifold: bool,
    /// (2 components - chi) / 2 for a closed manifold mesh.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub genus: Option<i64>,
    /// max |phi| / |grad phi| over all vertices (with --domain).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_distance: Option<f64>,
    /// Mean of |phi| / |grad phi| over all vertices (with --domain).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_distance: Option<f64>,
}

/// The surface figures of `m`; `fans_ok` is the validity checks' verdict on vertex fans.
pub fn compute(m: &MeshData, phi: Option<&Expr>, fans_ok: bool) -> SurfaceStats {
    let mut edges: HashMap<[usize; 2], u32> = HashMap::new();
    let mut sets = DisjointSets::new(m.points.len());
    let mut used = vec![false; m.points.len()];
    for i in 0..m.num_cells() {
        let c = m.cell(i);
        for k in 0..3 {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            *edges.entry([a.min(b), a.max(b)]).or_insert(0) += 1;
            sets.join(a, b);
            used[a] = true;
        }
    }
    let vertices = used.iter().filter(|&&u| u).count();
    let mut roots: Vec<usize> = (0..m.points.len()).filter(|&v| used[v]).map(|v| sets.root(v)).collect();
    roots.sort_unstable();
    roots.dedup();
    let boundary_edges = edges.values().filter(|&&n| n == 1).count();
    let non_manifold_edges = edges.values().filter(|&&n| n > 2).count();
    let chi = vertices as i64 - edges.len() as i64 + m.num_cells() as i64;
    let manifold = non_manifold_edges == 0 && fans_ok;
    let closed = boundary_edges == 0;
    let genus = (closed && manifold).then(|| (2 * roots.len() as i64 - chi) / 2);
    let dist: Option<Vec<f64>> = phi.map(|e| {
        (0..m.points.len())
            .filter(|&v| used[v])
            .map(|v| {
                let [x, y, z] = m.points[v];
                let (f, g) = e.eval_grad(x, y, z);
                let gn = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                if gn > 0.0 {
                    f.abs() / gn
                } else {
                    f.abs()
                }
            })
            .collect()
    });
    SurfaceStats {
        euler_characteristic: chi,
        components: roots.len(),
        boundary_edges,
        non_manifold_edges,
        manifold,
        genus,
        max_distance: dist.as_ref().map(|d| d.iter().copied().fold(0.0, f64::max)),
        mean_distance: dist.as_ref().map(|d| d.iter().sum::<f64>() / d.len().max(1) as f64),
    }
}

impl std::fmt::Display for SurfaceStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let closed = if self.boundary_edges == 0 {
            "closed".to_string()
        } else {
            format!("open ({} boundary edges)", self.boundary_edges)
        };
        let manifold = if self.manifold {
            "manifold".to_string()
        } else if self.non_manifold_edges > 0 {
            format!("NOT manifold ({} edges of more than two triangles)", self.non_manifold_edges)
        } else {
            "NOT manifold (a vertex whose triangles form more than one fan)".to_string()
        };
        write!(
            f,
            "surface: {closed}, {manifold}, {} component{}, Euler characteristic {}",
            self.components,
            if self.components == 1 { "" } else { "s" },
            self.euler_characteristic
        )?;
        match self.genus {
            Some(g) => writeln!(f, ", genus {g}")?,
            None => writeln!(f)?,
        }
        if let (Some(max), Some(mean)) = (self.max_distance, self.mean_distance) {
            writeln!(f, "distance to phi = 0 (|phi| / |grad phi| over all vertices): max {max:.3e}, mean {mean:.3e}")?;
        }
        Ok(())
    }
}
