//! A geometry from a closed triangle mesh (STL, OBJ, PLY, Medit, Gmsh, VTU): the exact signed
//! distance to the triangles, so that the 3-D and surface meshers take a scanned or exported
//! surface like any formula (seed section 3.1: "the distance function ... to the triangles").
//!
//! - Distance and nearest point: a bounding-volume hierarchy (module `bvh`) over the triangles, the
//!   nearest point of each candidate triangle by its Voronoi regions ([`distance`]).
//! - Sign: angle-weighted pseudo-normals at the nearest feature, the generalised winding number
//!   where they leave it undecided (module `sign`).
//! - Gradient: (p - c) / d with c the nearest point, the unit vector along which the distance
//!   grows; on the surface itself the pseudo-normal. So p - d grad d = c: projection onto the
//!   input is exact in one step.
//! - Checks (module `check`): empty, degenerate, open, non-manifold, non-orientable and
//!   self-intersecting input is refused with [`SurfaceError`], naming a triangle and where it
//!   is; a reversed triangle among consistent ones is turned, exact duplicate vertices merged.
//! - Sharp features (module `features`): edges of high dihedral angle, corners, and points on them
//!   for the meshers to hold.

mod bvh;
mod check;
mod creases;
mod curvature;
pub mod distance;
mod features;
mod options;
pub mod read;
mod sign;

pub use bvh::Closest;
pub use check::SurfaceError;
pub use distance::Feature;
pub use features::{Features, COARSE_TURN_DEG, COARSE_WIDTH, DEFAULT_FEATURE_ANGLE};

use super::Implicit3;
use crate::io::MeshData;
use crate::Error;
use glam::DVec3;
use std::path::Path;

/// A closed, oriented, non-self-intersecting triangle mesh as a signed-distance geometry
/// (negative inside). Build it with [`TriSurface::new`] from arrays or [`TriSurface::read`] from
/// a file.
#[derive(Clone, Debug)]
pub struct TriSurface {
    points: Vec<DVec3>,
    tris: Vec<[usize; 3]>,
    neighbors: Vec<[usize; 3]>,
    bvh: bvh::Bvh,
    normals: sign::Normals,
    bbox: [DVec3; 2],
    /// Below this distance from the surface the gradient is the pseudo-normal.
    tiny: f64,
    /// The feature angle at which the surface mesher holds the input's sharp edges (None: it
    /// holds none).
    feature_angle: Option<f64>,
    /// Faces of the input narrower than NARROW_FACE times this (twice their area over their
    /// perimeter) are merged into a neighbour before the surface mesher holds the curves
    /// (None: none is merged).
    feature_size: Option<f64>,
    /// The patches and curves at `feature_angle`, made when first asked for.
    creases: std::sync::OnceLock<Option<creases::CreaseData>>,
    /// The curvature at each vertex at `feature_angle`, made when first asked for.
    curvature: std::sync::OnceLock<Vec<f64>>,
    /// Input triangles dropped for a repeated corner (see [`TriSurface::dropped_triangles`]).
    dropped: usize,
}

impl TriSurface {
    /// Checks and indexes a triangle mesh: exact duplicate vertices are merged, triangles that
    /// then repeat a vertex dropped (see [`TriSurface::dropped_triangles`]) and unused vertices
    /// too (so vertex numbers in errors and [`Features`] are of the merged mesh),
    /// triangles turned to a consistent outward orientation. Errors: [`SurfaceError`].
    pub fn new(points: Vec<[f64; 3]>, tris: Vec<[usize; 3]>) -> Result<TriSurface, Error> {
        let (points, tris, dropped) = weld(points, tris)?;
        let checked = check::check(&points, tris)?;
        let corners: Vec<[DVec3; 3]> = checked.tris.iter().map(|t| t.map(|v| points[v])).collect();
        let bvh = bvh::Bvh::new(&corners);
        if let Some([i, j]) = check::self_intersection(&points, &checked.tris, &bvh) {
            return Err(SurfaceError::SelfIntersecting { triangles: [i, j], at: corners[i][0].to_array() }.into());
        }
        let normals = sign::Normals::new(&points, &checked.tris, &checked.neighbors);
        let (lo, hi) = points
            .iter()
            .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(l, h), &p| (l.min(p), h.max(p)));
        let tiny = 1e-12 * (hi - lo).length().max(f64::MIN_POSITIVE);
        Ok(TriSurface {
            points,
            tris: checked.tris,
            neighbors: checked.neighbors,
            bvh,
            normals,
            bbox: [lo, hi],
            tiny,
            feature_angle: Some(DEFAULT_FEATURE_ANGLE),
            feature_size: None,
            creases: std::sync::OnceLock::new(),
            curvature: std::sync::OnceLock::new(),
            dropped,
        })
    }

    /// How many input triangles were dropped because two of their corners coincide (after
    /// merging exact duplicates): zero-length edges, collapsed.
    pub fn dropped_triangles(&self) -> usize {
        self.dropped
    }

    /// The surface with the feature angle (degrees) at which the surface mesher holds its
    /// sharp edges, or `None` to hold none (the default is [`DEFAULT_FEATURE_ANGLE`]).
    pub fn with_feature_angle(mut self, angle_deg: Option<f64>) -> TriSurface {
        self.feature_angle = angle_deg;
        self.creases = std::sync::OnceLock::new();
        self.curvature = std::sync::OnceLock::new();
        self
    }

    /// The surface with the mesh size `h` its features are held at: a face of the input (a
    /// patch between sharp edges) narrower than a quarter of `h`, measured as twice its area
    /// over its perimeter, cannot be held at that size (its two sides would be a fraction of
    /// an edge apart), and is merged into the neighbour it shares the longest border with: a
    /// chamfer one triangle wide along a rim becomes part of a face, rounded. The command line
    /// sets the smallest size; None (the default) merges nothing.
    pub fn with_feature_size(mut self, h: Option<f64>) -> TriSurface {
        self.feature_size = h;
        self.creases = std::sync::OnceLock::new();
        self
    }

    /// The patches and curves the surface mesher holds, if any.
    fn crease_data(&self) -> Option<&creases::CreaseData> {
        self.creases
            .get_or_init(|| self.feature_angle.and_then(|a| creases::CreaseData::new(self, a, self.feature_size)))
            .as_ref()
    }

    /// Reads and checks a surface file (.stl ASCII or binary, .obj, .ply ASCII or binary,
    /// .mesh, .msh, .vtu, .json; a tet mesh gives its boundary).
    pub fn read(path: &Path) -> Result<TriSurface, Error> {
        let (p, t) = read::read_triangles(path)?;
        TriSurface::new(p, t)
    }

    /// The surface of a mesh in plain arrays (a tet mesh gives its boundary).
    pub fn from_mesh_data(m: &MeshData) -> Result<TriSurface, Error> {
        let (p, t) = read::from_mesh_data(m);
        TriSurface::new(p, t)
    }

    /// The vertices (after merging duplicates).
    pub fn points(&self) -> &[DVec3] {
        &self.points
    }
    /// The triangles, counter-clockwise seen from outside.
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.tris
    }
    /// The bounding box of the vertices: minimum and maximum corner.
    pub fn bbox(&self) -> [DVec3; 2] {
        self.bbox
    }
    /// The enclosed volume (divergence theorem over the oriented triangles).
    pub fn volume(&self) -> f64 {
        self.tris.iter().map(|t| self.points[t[0]].dot(self.points[t[1]].cross(self.points[t[2]]))).sum::<f64>() / 6.0
    }
    /// The total area.
    pub fn area(&self) -> f64 {
        self.tris
            .iter()
            .map(|t| {
                0.5 * (self.points[t[1]] - self.points[t[0]]).cross(self.points[t[2]] - self.points[t[0]]).length()
            })
            .sum()
    }
    /// V - E + F (2 per sphere-like component, 0 per torus).
    pub fn euler_characteristic(&self) -> i64 {
        self.points.len() as i64 - (3 * self.tris.len() / 2) as i64 + self.tris.len() as i64
    }
    /// The mean edge length.
    pub fn mean_edge(&self) -> f64 {
        let sum: f64 = self
            .tris
            .iter()
            .map(|t| (0..3).map(|k| self.points[t[k]].distance(self.points[t[(k + 1) % 3]])).sum::<f64>())
            .sum();
        sum / (3 * self.tris.len()) as f64
    }

    /// The nearest point of the surface to `p`, through the hierarchy.
    pub fn closest(&self, p: DVec3) -> Closest {
        self.bvh.closest(p)
    }

    /// The nearest point by trying every triangle: the reference the hierarchy is tested against.
    pub fn closest_brute_force(&self, p: DVec3) -> Closest {
        let mut best = Closest { point: p, dist2: f64::INFINITY, triangle: 0, feature: Feature::Face };
        for (t, tri) in self.tris.iter().enumerate() {
            let [a, b, c] = tri.map(|v| self.points[v]);
            let (q, f) = distance::closest_on_triangle(p, a, b, c);
            let d2 = (p - q).length_squared();
            if d2 < best.dist2 {
                best = Closest { point: q, dist2: d2, triangle: t, feature: f };
            }
        }
        best
    }

    /// The generalised winding number at `p` (about 1 inside, 0 outside; sums every triangle).
    pub fn winding_number(&self, p: DVec3) -> f64 {
        sign::winding_number(&self.points, &self.tris, p)
    }

    /// The outward pseudo-normal at the nearest point `c`.
    fn pseudo_normal(&self, c: &Closest) -> DVec3 {
        self.normals.at(c.triangle, &self.tris[c.triangle], c.feature)
    }

    /// The signed distance and its gradient at `p`, from one nearest-point query.
    pub fn distance_and_gradient(&self, p: DVec3) -> (f64, DVec3) {
        self.signed(p, &self.closest(p))
    }

    /// The signed distance and gradient at `p` from its nearest point `c`.
    fn signed(&self, p: DVec3, c: &Closest) -> (f64, DVec3) {
        let v = p - c.point;
        let len = c.dist2.sqrt();
        let n = self.pseudo_normal(c);
        if len <= self.tiny {
            return (len.copysign(v.dot(n)), n);
        }
        let s = v.dot(n);
        let outside = if s.abs() > 1e-6 * len { s > 0.0 } else { self.winding_number(p) < 0.5 };
        let d = if outside { len } else { -len };
        (d, v / d)
    }

    /// The signed distance at `p`: negative inside.
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        self.distance_and_gradient(p).0
    }
}

impl Implicit3 for TriSurface {
    fn value(&self, p: DVec3) -> f64 {
        self.distance_and_gradient(p).0
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.distance_and_gradient(p).1
    }
    fn value_and_gradient(&self, p: DVec3) -> (f64, DVec3) {
        self.distance_and_gradient(p)
    }
    fn value_near(&self, p: DVec3, r: f64) -> Option<f64> {
        let c = self.bvh.closest_below(p, r * r);
        c.dist2.is_finite().then(|| self.signed(p, &c).0)
    }
    fn is_distance(&self) -> bool {
        true
    }
    /// Declared: the meshers need not sample |grad d| over the box to decide (deep samples
    /// are the slowest queries of a large input).
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
    fn creases_given(&self) -> bool {
        true
    }
    fn creases(&self) -> Option<&dyn super::Creases> {
        self.crease_data().map(|_| self as &dyn super::Creases)
    }
    fn surface_curvature(&self, p: DVec3) -> Option<f64> {
        Some(self.curvature_near(p))
    }
}

/// The vertices, the triangles and the number of triangles dropped by [`weld`].
type Welded = (Vec<DVec3>, Vec<[usize; 3]>, usize);

/// Merges vertices with exactly equal coordinates (-0 and 0 alike), drops the triangles that
/// then repeat a vertex (zero-length edges, which CAD exports write: dropping both triangles on
/// such an edge collapses it) and the vertices no triangle uses. Returns the vertices, the
/// triangles and the number of triangles dropped.
fn weld(points: Vec<[f64; 3]>, tris: Vec<[usize; 3]>) -> Result<Welded, SurfaceError> {
    let (merged, all) = weld_exact(points, tris)?;
    let kept: Vec<[usize; 3]> = all.iter().copied().filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]).collect();
    let dropped = all.len() - kept.len();
    if dropped == 0 {
        return Ok((merged, kept, 0));
    }
    if kept.is_empty() {
        return Err(SurfaceError::Empty);
    }
    let mut index = vec![usize::MAX; merged.len()];
    let mut out = Vec::new();
    let tris = kept
        .iter()
        .map(|t| {
            t.map(|v| {
                if index[v] == usize::MAX {
                    index[v] = out.len();
                    out.push(merged[v]);
                }
                index[v]
            })
        })
        .collect();
    Ok((out, tris, dropped))
}

/// Merges vertices with exactly equal coordinates (-0 and 0 alike) and drops unused ones.
fn weld_exact(points: Vec<[f64; 3]>, tris: Vec<[usize; 3]>) -> Result<(Vec<DVec3>, Vec<[usize; 3]>), SurfaceError> {
    if tris.is_empty() {
        return Err(SurfaceError::Empty);
    }
    let mut index: crate::FastMap<[u64; 3], usize> = crate::FastMap::default();
    let mut remap = vec![usize::MAX; points.len()];
    let mut out = Vec::new();
    let mut new_tris = Vec::with_capacity(tris.len());
    for (t, tri) in tris.iter().enumerate() {
        let mut nt = [0; 3];
        for k in 0..3 {
            let v = tri[k];
            if v >= points.len() {
                return Err(SurfaceError::BadIndex { triangle: t, vertex: v, count: points.len() });
            }
            if remap[v] == usize::MAX {
                let p = points[v].map(|c| if c == 0.0 { 0.0 } else { c });
                remap[v] = *index.entry(p.map(f64::to_bits)).or_insert_with(|| {
                    out.push(DVec3::from_array(p));
                    out.len() - 1
                });
            }
            nt[k] = remap[v];
        }
        new_tris.push(nt);
    }
    Ok((out, new_tris))
}
