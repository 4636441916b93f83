//! Implicit geometries: d(x) < 0 inside, a signed distance or any smooth level-set function.
//!
//! The geometry knows nothing of meshes. Closures are geometries.

use glam::{DMat2, DMat3, DVec2, DVec3};

mod csg;
mod decide;
pub(crate) mod grid;
mod level_set;
pub mod levelset;
pub mod polygons;
mod primitives2;
mod primitives3;
pub mod project;
#[cfg(test)]
mod testing;
mod transform;
pub mod trisurf;

pub use csg::{
    difference, exact_corners, intersection, union, Difference, ExactCorners, Intersection, Shape2, Shape3, Union,
};
pub(crate) use decide::{decide2, decide3};
pub use decide::{survey_gradient2, survey_gradient3, Declared, GradientSurvey};
pub use grid::{Grid2, Grid3};
pub use level_set::LevelSet;
pub use polygons::Polygons2;
pub use primitives2::{Circle, Ellipse, Polygon, Rectangle};
pub use primitives3::{Ball, Box3, Cylinder};
pub use project::{
    newton_distance2, newton_distance3, project2, project3, project_many2, project_many3, NonFiniteIn, ProjectError,
    Projection,
};
pub use transform::{Implicit2Ext, Implicit3Ext, Rotate, Scale, Translate};
pub use trisurf::TriSurface;

/// A 2-D implicit function. `value` is negative inside.
pub trait Implicit2: Sync + Send {
    /// The function value at `p`.
    fn value(&self, p: DVec2) -> f64;
    /// The gradient; the default is a central finite difference with a step scaled to `p`.
    fn gradient(&self, p: DVec2) -> DVec2 {
        let h = fd_step(p.abs().max_element());
        let dx = DVec2::new(h, 0.0);
        let dy = DVec2::new(0.0, h);
        DVec2::new(
            (self.value(p + dx) - self.value(p - dx)) / (2.0 * h),
            (self.value(p + dy) - self.value(p - dy)) / (2.0 * h),
        )
    }
    /// The values at many points: `out[i] = value(ps[i])`, bit for bit. The meshers call it
    /// where they evaluate d over a whole set of nodes (every step of the force loop, the
    /// boundary projections), so that a function with a cost per call (a Python callable, a
    /// kernel on another device) is called once per set. The default evaluates point by point,
    /// in parallel.
    fn values(&self, ps: &[DVec2], out: &mut [f64]) {
        batch(ps, out, |p| self.value(p));
    }
    /// The gradients at many points: `out[i] = gradient(ps[i])`, bit for bit (see
    /// [`Implicit2::values`]).
    fn gradients(&self, ps: &[DVec2], out: &mut [DVec2]) {
        batch(ps, out, |p| self.gradient(p));
    }
    /// The Hessian, if the geometry can give it (needed by second-order projections).
    fn hessian(&self, _p: DVec2) -> Option<DMat2> {
        None
    }
    /// True when `value` is a signed distance (|grad d| = 1), so that p - d grad d projects exactly:
    /// the declaration when there is one, else true (the seed's convention). The meshers do not
    /// take this default on trust: for an undeclared geometry they sample |grad d| over the box
    /// and decide ([`survey_gradient2`]).
    fn is_distance(&self) -> bool {
        self.declared_distance().unwrap_or(true)
    }
    /// `Some(true)` when the geometry knows it is a signed distance (primitives, CSG of them),
    /// `Some(false)` when it knows it is not ([`LevelSet`], [`Ellipse`]), `None` (closures and
    /// expressions) when it does not know: the meshers then decide from sampled gradients.
    fn declared_distance(&self) -> Option<bool> {
        None
    }
}

/// A 3-D implicit function. `value` is negative inside.
pub trait Implicit3: Sync + Send {
    /// The function value at `p`.
    fn value(&self, p: DVec3) -> f64;
    /// The gradient; the default is a central finite difference with a step scaled to `p`.
    fn gradient(&self, p: DVec3) -> DVec3 {
        let h = fd_step(p.abs().max_element());
        let mut g = DVec3::ZERO;
        for i in 0..3 {
            let mut e = DVec3::ZERO;
            e[i] = h;
            g[i] = (self.value(p + e) - self.value(p - e)) / (2.0 * h);
        }
        g
    }
    /// The value and the gradient together; geometries that compute both in one pass (compiled
    /// expressions) override it. Must agree bit for bit with `value` and `gradient`.
    fn value_and_gradient(&self, p: DVec3) -> (f64, DVec3) {
        (self.value(p), self.gradient(p))
    }
    /// The value at `p` where the surface d = 0 may pass within `r` of `p`: `Some` of exactly
    /// `value(p)`, or `None` when the geometry knows that its nearest point is farther than `r`
    /// (a signed distance that can bound its search: a triangulated surface), leaving the
    /// caller to take the sign from a neighbour (a segment shorter than `r` from `p` does not
    /// cross d = 0). The default is always `Some(value(p))`.
    fn value_near(&self, p: DVec3, _r: f64) -> Option<f64> {
        Some(self.value(p))
    }
    /// The values at many points, bit for bit as `value`: see [`Implicit2::values`].
    fn values(&self, ps: &[DVec3], out: &mut [f64]) {
        batch(ps, out, |p| self.value(p));
    }
    /// The gradients at many points, bit for bit as `gradient`.
    fn gradients(&self, ps: &[DVec3], out: &mut [DVec3]) {
        batch(ps, out, |p| self.gradient(p));
    }
    /// The Hessian, if the geometry can give it.
    fn hessian(&self, _p: DVec3) -> Option<DMat3> {
        None
    }
    /// True when `value` is a signed distance: see [`Implicit2::is_distance`].
    fn is_distance(&self) -> bool {
        self.declared_distance().unwrap_or(true)
    }
    /// What the geometry declares: see [`Implicit2::declared_distance`].
    fn declared_distance(&self) -> Option<bool> {
        None
    }
    /// Sharp features the geometry knows exactly (a triangulated surface's feature edges), for
    /// the surface mesher to hold in place of those it would find from the function; `None`
    /// (the default) lets it find them itself.
    fn creases(&self) -> Option<&dyn Creases> {
        None
    }
    /// True when `creases` is the whole truth: the geometry gives its sharp features itself
    /// (a triangulated surface, whose `creases` is None when it has none or holding them is
    /// turned off), so the surface mesher never looks for them in the function. The default is
    /// false.
    fn creases_given(&self) -> bool {
        false
    }
    /// The largest principal curvature (its magnitude) of the surface d = 0 near `p`, when the
    /// geometry knows it better than second differences of its values would: the distance to a
    /// triangulated surface is flat over each triangle and kinked at each edge. `None` (the
    /// default): the automatic sizes take the curvature from the values.
    fn surface_curvature(&self, _p: DVec3) -> Option<f64> {
        None
    }
}

/// Sharp features given exactly: the surface split into smooth patches, the curves where two
/// patches meet, and the corners where three or more do. The surface mesher labels each of its
/// triangles by the patch under it, holds its vertices between two labels on that pair's curve
/// and its vertices nearest the corners on them.
pub trait Creases: Sync {
    /// The patch under the surface point nearest `p`.
    fn patch(&self, p: DVec3) -> Option<u32>;
    /// The corners.
    fn corners(&self) -> &[DVec3];
    /// The point nearest `p` on the curve between patches `a` and `b` (for a triangulated
    /// input, the curve through its feature edges' vertices at the nearest edge point), with
    /// the curve's unit tangent there; `None` when the two patches do not meet.
    fn onto(&self, a: u32, b: u32, p: DVec3) -> Option<(DVec3, DVec3)>;
    /// Points on the curves (not corners) that the mesh holds a vertex at: where a curve given
    /// in coarse steps turns sharply. None by default.
    fn pins(&self) -> &[DVec3] {
        &[]
    }
    /// The surface as a closed triangulation whose edges include every curve: a start that
    /// has the features as its own edges. None by default.
    fn triangulation(&self) -> Option<LabelledTriangulation> {
        None
    }
}

/// A closed triangulated surface with the patch of each triangle ([`Creases::triangulation`]).
#[derive(Clone, Debug)]
pub struct LabelledTriangulation {
    /// The vertices.
    pub points: Vec<DVec3>,
    /// The triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[usize; 3]>,
    /// The patch of each triangle.
    pub patch: Vec<u32>,
}

/// Points per parallel task of the default batch evaluations.
const BATCH_CHUNK: usize = 256;

/// `out[i] = f(ps[i])`, in parallel for large sets (each output depends on its point alone, so
/// the result is the same for any thread count).
fn batch<P: Copy + Sync, T: Send>(ps: &[P], out: &mut [T], f: impl Fn(P) -> T + Sync) {
    use rayon::prelude::*;
    assert_eq!(ps.len(), out.len(), "batch evaluation: as many outputs as points");
    if ps.len() <= BATCH_CHUNK {
        for (o, &p) in out.iter_mut().zip(ps) {
            *o = f(p);
        }
    } else {
        out.par_iter_mut().zip(ps.par_iter()).with_min_len(BATCH_CHUNK).for_each(|(o, &p)| *o = f(p));
    }
}

/// Central-difference step: cube root of machine epsilon (optimal for second-order differences),
/// scaled with the coordinate magnitude.
#[inline]
pub fn fd_step(scale: f64) -> f64 {
    6.055454452393343e-6 * scale.max(1.0)
}

impl<F: Fn(DVec2) -> f64 + Sync + Send> Implicit2 for F {
    fn value(&self, p: DVec2) -> f64 {
        self(p)
    }
}

impl<F: Fn(DVec3) -> f64 + Sync + Send> Implicit3 for F {
    fn value(&self, p: DVec3) -> f64 {
        self(p)
    }
}
