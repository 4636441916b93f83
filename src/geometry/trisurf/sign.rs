//! Inside or outside: angle-weighted pseudo-normals (Baerentzen and Aanaes 2005) decide the sign
//! from the nearest feature, exactly for a closed, outward-oriented surface: the vector from the
//! nearest point to the query makes an acute angle with the pseudo-normal there iff the query
//! is outside. Where that test is undecided (the vector nearly tangent, as on defects or
//! rounding), the generalised winding number (Jacobson et al. 2013) decides: the sum of the
//! solid angles of all triangles over 4 pi, 1 inside and 0 outside, and near those values for
//! slightly defective input.

use super::distance::{solid_angle, Feature};
use glam::DVec3;

/// The pseudo-normals: of each face, of each edge (per triangle, edge k from corner k), of each
/// vertex. All unit length and outward.
#[derive(Clone, Debug)]
pub(super) struct Normals {
    face: Vec<DVec3>,
    edge: Vec<[DVec3; 3]>,
    vertex: Vec<DVec3>,
}

impl Normals {
    pub(super) fn new(points: &[DVec3], tris: &[[usize; 3]], neighbors: &[[usize; 3]]) -> Normals {
        let face: Vec<DVec3> = tris
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| points[v]);
                (b - a).cross(c - a).normalize_or_zero()
            })
            .collect();
        let edge = (0..tris.len())
            .map(|t| std::array::from_fn(|k| (face[t] + face[neighbors[t][k]]).normalize_or_zero()))
            .collect();
        let mut vertex = vec![DVec3::ZERO; points.len()];
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                let p = points[tri[k]];
                let (e1, e2) = (points[tri[(k + 1) % 3]] - p, points[tri[(k + 2) % 3]] - p);
                let angle = e1.angle_between(e2);
                if angle.is_finite() {
                    vertex[tri[k]] += face[t] * angle;
                }
            }
        }
        for n in &mut vertex {
            *n = n.normalize_or_zero();
        }
        Normals { face, edge, vertex }
    }

    /// The unit normal of triangle `t`.
    pub(super) fn face(&self, t: usize) -> DVec3 {
        self.face[t]
    }

    /// The pseudo-normal at `feature` of triangle `t` (corners `tri`).
    pub(super) fn at(&self, t: usize, tri: &[usize; 3], feature: Feature) -> DVec3 {
        match feature {
            Feature::Face => self.face[t],
            Feature::Edge(k) => self.edge[t][k as usize],
            Feature::Vertex(k) => self.vertex[tri[k as usize]],
        }
    }
}

/// The generalised winding number of the triangles at `p`: about 1 inside a closed outward
/// surface, 0 outside. Sums in input order, so it is the same on every run.
pub(super) fn winding_number(points: &[DVec3], tris: &[[usize; 3]], p: DVec3) -> f64 {
    let sum: f64 = tris.iter().map(|t| solid_angle(p, points[t[0]], points[t[1]], points[t[2]])).sum();
    sum / (4.0 * std::f64::consts::PI)
}
