//! What the surface mesher is asked for: the size rule, the iteration parameters, and the size
//! field they give.

use super::geom::SizeField;
use super::start::MAX_GRID_NODES;
use crate::geometry::Implicit3;
use crate::mesher::ProgressFn;
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

/// Options of [`mesh_implicit_surface`](super::mesh_implicit_surface). Defaults: uniform size, 1000 iterations, Fscale 1.2,
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
    pub max_iterations: usize,
    /// Bar lengths are pushed toward Fscale h (seed eq. 2.6).
    pub fscale: f64,
    /// Time step of the forward Euler move.
    pub dt: f64,
    /// Stop when no node moves more than dptol h in an iteration.
    pub dptol: f64,
    /// Progress callback, called as (stages done, stages): the start, each level of the
    /// coarse-to-fine start (remeshing, force loop, subdivision), the length equalisation.
    pub progress: Option<ProgressFn>,
}

impl std::fmt::Debug for SurfaceOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceOptions")
            .field("h0", &self.h0)
            .field("bbox", &self.bbox)
            .field("size", &self.size)
            .field("max_iterations", &self.max_iterations)
            .field("fscale", &self.fscale)
            .field("dt", &self.dt)
            .field("dptol", &self.dptol)
            .field("progress", &self.progress.as_ref().map(|_| "fn"))
            .finish()
    }
}

impl SurfaceOptions {
    /// Default iteration cap.
    pub const DEFAULT_MAX_ITERATIONS: usize = 1000;
    /// Default Fscale.
    pub const DEFAULT_FSCALE: f64 = 1.2;
    /// Default time step.
    pub const DEFAULT_DT: f64 = 0.3;
    /// Default movement tolerance.
    pub const DEFAULT_DPTOL: f64 = 1e-3;

    /// Uniform size `h0` for a surface inside `bbox`.
    pub fn uniform(h0: f64, bbox: [DVec3; 2]) -> Self {
        SurfaceOptions {
            h0,
            bbox,
            size: SurfaceSize::Uniform,
            max_iterations: Self::DEFAULT_MAX_ITERATIONS,
            fscale: Self::DEFAULT_FSCALE,
            dt: Self::DEFAULT_DT,
            dptol: Self::DEFAULT_DPTOL,
            progress: None,
        }
    }
    /// Sizes from curvature (see [`SurfaceSize::Curvature`]).
    pub fn with_curvature(mut self, k: f64, g: f64, hmax: f64) -> Self {
        self.size = SurfaceSize::Curvature { k, g, hmax };
        self
    }
    /// Sets the progress callback (see [`SurfaceOptions::progress`]).
    pub fn with_progress(mut self, f: impl Fn(usize, usize) + Send + Sync + 'static) -> Self {
        self.progress = Some(std::sync::Arc::new(f));
        self
    }
    /// Sets the iteration cap.
    pub fn with_max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = n;
        self
    }

    pub(super) fn check(&self) -> Result<(), Error> {
        if !(self.h0 > 0.0 && self.h0.is_finite()) {
            return Err(Error::BadSize(format!("h0 = {} must be positive and finite", self.h0)));
        }
        let [lo, hi] = self.bbox;
        if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
            return Err(Error::BadBox(format!("{lo} .. {hi}")));
        }
        if let SurfaceSize::Curvature { k, g, hmax } = self.size {
            if !(k > 0.0 && k.is_finite() && g > 0.0 && g.is_finite() && hmax >= self.h0) {
                return Err(Error::BadSize(format!(
                    "curvature sizes k = {k}, g = {g}, hmax = {hmax} (need k > 0, g > 0, hmax >= h0)"
                )));
            }
        }
        let ok = |v: f64| v > 0.0 && v.is_finite();
        if !(ok(self.fscale) && ok(self.dt) && ok(self.dptol)) {
            return Err(Error::Invalid(format!(
                "fscale {}, dt {}, dptol {} must be positive and finite",
                self.fscale, self.dt, self.dptol
            )));
        }
        Ok(())
    }

    /// The size field of these options: h0 everywhere, or the curvature sizes on a grid of
    /// spacing h0 / 2 over the box padded by 2 h0 (refused before allocating when that grid
    /// would be too large).
    pub(super) fn size_field(&self, phi: &dyn Implicit3) -> Result<SizeField, Error> {
        Ok(match self.size {
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
