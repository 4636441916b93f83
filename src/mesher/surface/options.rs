//! What the surface mesher is asked for: the size rule, the iteration parameters, and the size
//! field they give.

use super::geom::SizeField;
use super::start::MAX_GRID_NODES;
use crate::geometry::Implicit3;
use crate::mesher::options::{truss_builders, ProgressFn};
use crate::size::{auto_size_3d, SizeParams};
use crate::Error;
use glam::DVec3;

/// How the target edge length varies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SurfaceSize {
    /// h0 everywhere.
    Uniform,
    /// h = 1 / (k |kappa_max|) clamped to [h0, hmax], then gradient limited to |grad h| <= g
    /// (seed eq. 4.4 and Algorithm 4-2).
    Curvature {
        /// Elements per radian.
        k: f64,
        /// Gradient limit.
        g: f64,
        /// Largest size.
        hmax: f64,
    },
}

/// Options of [`mesh_surface`](super::mesh_surface). Defaults: uniform size, 1000 iterations, Fscale 1.2,
/// time step 0.3, movement tolerance 1e-3 h.
#[derive(Clone)]
#[non_exhaustive]
pub struct SurfaceOptions {
    /// Target edge length (the smallest one with curvature sizes).
    pub h0: f64,
    /// A box that contains the whole surface.
    pub bbox: [DVec3; 2],
    /// Size rule.
    pub size: SurfaceSize,
    /// Iteration cap of each force loop (one per level of the coarse-to-fine start).
    pub max_iter: usize,
    /// Bar lengths are pushed toward Fscale h (seed eq. 2.6).
    pub fscale: f64,
    /// Time step of the forward Euler move.
    pub deltat: f64,
    /// Stop when no node moves more than dptol h in an iteration.
    pub dptol: f64,
    /// Progress callback, called as (stages done, stages): the start, each level of the
    /// coarse-to-fine start (remeshing, force loop, subdivision), the length equalisation.
    pub progress: Option<ProgressFn>,
    /// Relative sizes h(x) (only ratios matter: the smallest near the surface becomes h0),
    /// sampled on a grid of spacing h0 / 2 over the box padded by 2 h0; not with curvature sizes.
    pub relative_size: Option<crate::mesher::SizeFn3>,
}

impl std::fmt::Debug for SurfaceOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceOptions")
            .field("h0", &self.h0)
            .field("bbox", &self.bbox)
            .field("size", &self.size)
            .field("max_iter", &self.max_iter)
            .field("fscale", &self.fscale)
            .field("deltat", &self.deltat)
            .field("dptol", &self.dptol)
            .field("progress", &self.progress.as_ref().map(|_| "fn"))
            .field("relative_size", &self.relative_size.as_ref().map(|_| "fn"))
            .finish()
    }
}

impl SurfaceOptions {
    /// Default iteration cap.
    pub const DEFAULT_MAX_ITER: usize = 1000;
    /// Default Fscale.
    pub const DEFAULT_FSCALE: f64 = 1.2;
    /// Default time step.
    pub const DEFAULT_DELTAT: f64 = 0.3;
    /// Default movement tolerance.
    pub const DEFAULT_DPTOL: f64 = 1e-3;

    /// Uniform size `h0` for a surface inside the box [min, max] (arrays or vectors).
    pub fn uniform(h0: f64, min: impl Into<DVec3>, max: impl Into<DVec3>) -> Self {
        SurfaceOptions {
            h0,
            bbox: [min.into(), max.into()],
            size: SurfaceSize::Uniform,
            max_iter: Self::DEFAULT_MAX_ITER,
            fscale: Self::DEFAULT_FSCALE,
            deltat: Self::DEFAULT_DELTAT,
            dptol: Self::DEFAULT_DPTOL,
            progress: None,
            relative_size: None,
        }
    }
    /// Relative sizes h(x): see [`SurfaceOptions::relative_size`].
    pub fn with_size(mut self, h: impl Fn(DVec3) -> f64 + Send + Sync + 'static) -> Self {
        self.relative_size = Some(std::sync::Arc::new(h));
        self
    }
    /// Sizes from curvature (see [`SurfaceSize::Curvature`]).
    pub fn with_curvature(mut self, k: f64, g: f64, hmax: f64) -> Self {
        self.size = SurfaceSize::Curvature { k, g, hmax };
        self
    }

    pub(super) fn check(&self) -> Result<(), Error> {
        crate::mesher::truss::domain::check_input(self.h0, self.bbox[0], self.bbox[1], &[])?;
        if let SurfaceSize::Curvature { k, g, hmax } = self.size {
            if !(k > 0.0 && k.is_finite() && g > 0.0 && g.is_finite() && hmax >= self.h0) {
                return Err(Error::BadSize(format!(
                    "curvature sizes k = {k}, g = {g}, hmax = {hmax} (need k > 0, g > 0, hmax >= h0)"
                )));
            }
        }
        if self.relative_size.is_some() && self.size != SurfaceSize::Uniform {
            return Err(Error::Invalid("relative sizes and curvature sizes cannot be combined".into()));
        }
        let ok = |v: f64| v > 0.0 && v.is_finite();
        if !(ok(self.fscale) && ok(self.deltat) && ok(self.dptol)) {
            return Err(Error::Invalid(format!(
                "fscale {}, deltat {}, dptol {} must be positive and finite",
                self.fscale, self.deltat, self.dptol
            )));
        }
        Ok(())
    }

    /// The size field of these options: h0 everywhere, or the curvature sizes on a grid of
    /// spacing h0 / 2 over the box padded by 2 h0 (refused before allocating when that grid
    /// would be too large).
    pub(super) fn size_field(&self, phi: &dyn Implicit3) -> Result<SizeField, Error> {
        Ok(match self.size {
            SurfaceSize::Uniform if self.relative_size.is_some() => self.relative_field(phi)?,
            SurfaceSize::Uniform => SizeField::Uniform(self.h0),
            SurfaceSize::Curvature { k, g, hmax } => {
                // The size grid has spacing h0/2 over the padded box: refuse before allocating it.
                let span = self.bbox[1] - self.bbox[0] + DVec3::splat(4.0 * self.h0);
                let nodes = (span / (0.5 * self.h0)).ceil() + DVec3::ONE;
                let estimated = nodes.x * nodes.y * nodes.z;
                if estimated > MAX_GRID_NODES as f64 {
                    return Err(Error::TooManyElements { estimated: estimated as u64, limit: MAX_GRID_NODES });
                }
                let params = SizeParams { k, r: 0.0, g, hmin: self.h0, hmax, ..SizeParams::default() };
                let pad = DVec3::splat(2.0 * self.h0);
                let grid = auto_size_3d(phi, [self.bbox[0] - pad, self.bbox[1] + pad], 0.5 * self.h0, &params)?;
                SizeField::Grid(grid)
            }
        })
    }
}

impl SurfaceOptions {
    /// The grid of relative sizes scaled so that the smallest at a node within h0 of the
    /// surface (|phi| / |grad phi|) is h0.
    fn relative_field(&self, phi: &dyn Implicit3) -> Result<SizeField, Error> {
        let Some(h) = &self.relative_size else { return Ok(SizeField::Uniform(self.h0)) };
        let span = self.bbox[1] - self.bbox[0] + DVec3::splat(4.0 * self.h0);
        let nodes = (span / (0.5 * self.h0)).ceil() + DVec3::ONE;
        let estimated = nodes.x * nodes.y * nodes.z;
        if estimated > MAX_GRID_NODES as f64 {
            return Err(Error::TooManyElements { estimated: estimated as u64, limit: MAX_GRID_NODES });
        }
        let pad = DVec3::splat(2.0 * self.h0);
        let (lo, hi) = (self.bbox[0] - pad, self.bbox[1] + pad);
        let h = h.clone();
        let raw = crate::geometry::Grid3::sample(&move |p: DVec3| h(p), lo, hi, 0.5 * self.h0)?;
        let dims = raw.dims();
        let mut smin = f64::INFINITY;
        for (i, &v) in raw.values().iter().enumerate() {
            if !(v > 0.0 && v.is_finite()) {
                return Err(Error::BadSize(format!("the relative size is {v} at a grid node; it must be positive")));
            }
            let (x, y, z) = (i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1]));
            let p = raw.origin() + DVec3::new(x as f64, y as f64, z as f64) * raw.spacing();
            if crate::mesher::surface::geom::residual(phi, p) <= self.h0 {
                smin = smin.min(v);
            }
        }
        if !smin.is_finite() {
            return Err(Error::EmptyDomain("no grid node of the size field lies near the surface".into()));
        }
        let values = raw.values().iter().map(|v| self.h0 * v / smin).collect();
        Ok(SizeField::Grid(
            crate::geometry::Grid3::new(raw.origin(), raw.spacing(), dims, values)?.with_distance(false),
        ))
    }
}

truss_builders!(SurfaceOptions);
