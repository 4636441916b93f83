//! An existing mesh as the background of a remeshing (seed section 5.2): its boundary gives the
//! distance function, and a size field at its nodes, gradient limited on the mesh, gives h.

use crate::geometry::Implicit2;
use crate::topology::{Location, TriMesh};
use crate::Error;
use glam::DVec2;

/// Signed distance to the boundary loops of a planar mesh: the distance to the nearest boundary
/// segment, negative inside (crossing number over every loop, so holes count).
#[derive(Clone, Debug)]
pub struct BoundaryDistance {
    segments: Vec<[DVec2; 2]>,
}

impl BoundaryDistance {
    /// The boundary of `m`.
    pub fn of(m: &TriMesh<DVec2>) -> Self {
        let mut segments = Vec::new();
        for lp in m.boundary_loops() {
            for h in lp {
                segments.push([m.pos(m.origin(h)), m.pos(m.dest(h))]);
            }
        }
        BoundaryDistance { segments }
    }
}

impl Implicit2 for BoundaryDistance {
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
    fn value(&self, p: DVec2) -> f64 {
        let mut best = f64::INFINITY;
        let mut inside = false;
        for &[a, b] in &self.segments {
            let ab = b - a;
            let t = ((p - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
            best = best.min(p.distance(a + ab * t));
            // Crossing number: the segment straddles the horizontal line through p, to its right.
            if (a.y > p.y) != (b.y > p.y) {
                let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
                if x > p.x {
                    inside = !inside;
                }
            }
        }
        if inside {
            -best
        } else {
            best
        }
    }
}

/// A size field given at the nodes of a mesh, gradient limited on it (`g`, seed eq. 4.8 by the
/// unstructured solver) and interpolated linearly inside its triangles; outside the mesh the
/// nearest node's size.
#[derive(Clone, Debug)]
pub struct MeshSize {
    mesh: TriMesh<DVec2>,
    index: slotmap::SecondaryMap<crate::topology::VertexId, usize>,
    h: Vec<f64>,
}

impl MeshSize {
    /// The field `h` (one value per vertex, in `m.vertex_ids()` order), limited to slope `g`.
    pub fn new(m: &TriMesh<DVec2>, mut h: Vec<f64>, g: f64) -> Result<Self, Error> {
        let crate::topology::MeshArrays { points, cells: tris, keys, .. } = m.to_arrays();
        if h.len() != points.len() {
            return Err(Error::InvalidMesh(format!("{} sizes for {} vertices", h.len(), points.len())));
        }
        if let Some(bad) = h.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
            return Err(Error::BadSize(format!("size {bad} at a node: sizes must be positive and finite")));
        }
        crate::size::gradient_limit_mesh(&points, &tris, &mut h, &crate::size::Slope::Constant(g))?;
        let mut index = slotmap::SecondaryMap::new();
        for (i, k) in keys.iter().enumerate() {
            index.insert(*k, i);
        }
        Ok(MeshSize { mesh: m.clone(), index, h })
    }

    /// The limited size at the vertices, in `vertex_ids()` order of the mesh given to `new`.
    pub fn values(&self) -> &[f64] {
        &self.h
    }

    /// The size at `p`.
    pub fn at(&self, p: DVec2) -> f64 {
        let start = match self.mesh.face_ids().next() {
            Some(f) => f,
            None => return self.h.iter().copied().fold(f64::INFINITY, f64::min),
        };
        let f = match self.mesh.locate(p, start) {
            Location::Face(f) => f,
            Location::Edge(h) => self.mesh.face_of(h).unwrap_or(start),
            Location::Vertex(v) => return self.h[self.index[v]],
            Location::Outside(_) => {
                // Nearest node (rare: the mesher samples inside).
                let (mut best, mut hv) = (f64::INFINITY, 1.0);
                for (v, vx) in self.mesh.vertices() {
                    let d = vx.pos.distance(p);
                    if d < best {
                        best = d;
                        hv = self.h[self.index[v]];
                    }
                }
                return hv;
            }
        };
        let [a, b, c] = self.mesh.face_vertices(f);
        let [pa, pb, pc] = [self.mesh.pos(a), self.mesh.pos(b), self.mesh.pos(c)];
        let area = (pb - pa).perp_dot(pc - pa);
        let wa = (pb - p).perp_dot(pc - p) / area;
        let wb = (pc - p).perp_dot(pa - p) / area;
        let wc = 1.0 - wa - wb;
        wa * self.h[self.index[a]] + wb * self.h[self.index[b]] + wc * self.h[self.index[c]]
    }
}
