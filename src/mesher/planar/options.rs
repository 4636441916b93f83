//! Options of the 2-D mesher, with their defaults.

use crate::geometry::project::Projection;
use crate::geometry::Implicit2;
use crate::mesher::metric::{Metric2, MetricFn2};
use crate::mesher::options::{domain_builders, truss_builders, ProgressFn};
use glam::DVec2;
use std::sync::Arc;

/// A relative size function h(x) (only ratios matter; h0 sets the scale).
pub type SizeFn2 = Arc<dyn Fn(DVec2) -> f64 + Send + Sync>;

/// How connectivity is maintained.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Strategy {
    /// Local flips, splits and collapses on the half-edge engine (trussmesh's way).
    #[default]
    Local,
    /// The seed's classic algorithm: rejection-sampled grid start and global Delaunay
    /// retriangulation (through spade) whenever nodes moved far; the reference to beat.
    GlobalDelaunay,
}

/// Options of [`crate::mesher::mesh_2d`].
#[derive(Clone)]
#[non_exhaustive]
pub struct Options2 {
    /// Initial edge length h0 (the absolute scale of the relative size h).
    pub h0: f64,
    /// Bounding box (min, max) that contains the domain.
    pub bbox: [DVec2; 2],
    /// Relative size h(x); `None` is uniform.
    pub size: Option<SizeFn2>,
    /// Points that become fixed mesh vertices.
    pub fixed: Vec<DVec2>,
    /// Iteration cap; the best mesh so far is returned with `converged == false`.
    pub max_iter: usize,
    /// Seed of the random choices: only the classic strategy (`Strategy::GlobalDelaunay`) makes
    /// any; the local strategy is deterministic and does not read it.
    pub seed: u64,
    /// How boundary nodes are projected onto d = 0.
    pub projection: Projection,
    /// Connectivity strategy.
    pub strategy: Strategy,
    /// Refuse to start when the estimated element count passes this.
    pub max_elements: u64,
    /// Internal pressure: unstretched bar length over the actual mean (seed eq. 2.6).
    pub fscale: f64,
    /// Forward Euler time step (seed eq. 2.4).
    pub deltat: f64,
    /// Stop when every interior node moves less than dptol h0 in a step (seed).
    pub dptol: f64,
    /// Progress callback.
    pub progress: Option<ProgressFn>,
    /// Internal boundaries: the zero set of this function (any number of non-crossing curves,
    /// seed section 3.4). Triangles never cross it and are labelled by subdomain.
    pub internal: Option<Arc<dyn Implicit2>>,
    /// Anisotropic mode: a metric field M(x) replacing h (seed section 3.5); every desired
    /// edge has length one in M. h0 then only sets tolerances and should be about the
    /// smallest size.
    pub metric: Option<MetricFn2>,
    /// Find the domain's sharp corners from d and hold them fixed (on by default; a fresh mesh
    /// without a metric).
    pub sharp_corners: bool,
}

impl std::fmt::Debug for Options2 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Options2")
            .field("h0", &self.h0)
            .field("bbox", &self.bbox)
            .field("size", &self.size.as_ref().map(|_| "fn"))
            .field("fixed", &self.fixed)
            .field("max_iter", &self.max_iter)
            .field("seed", &self.seed)
            .field("projection", &self.projection)
            .field("strategy", &self.strategy)
            .field("internal", &self.internal.as_ref().map(|_| "fn"))
            .field("metric", &self.metric.as_ref().map(|_| "fn"))
            .field("sharp_corners", &self.sharp_corners)
            .finish()
    }
}

impl Options2 {
    /// Default iteration cap.
    pub const DEFAULT_MAX_ITER: usize = 1000;
    /// Default element limit.
    pub const DEFAULT_MAX_ELEMENTS: u64 = 50_000_000;
    /// Default internal pressure (seed: 1.2 in 2-D).
    pub const DEFAULT_FSCALE: f64 = 1.2;
    /// Internal pressure with a metric: lower than the isotropic 1.2, which crowds the rows of
    /// a boundary layer against the boundary.
    pub const METRIC_FSCALE: f64 = 1.05;
    /// Default time step (seed: 0.2).
    pub const DEFAULT_DELTAT: f64 = 0.2;
    /// Default movement tolerance (seed: 0.001).
    pub const DEFAULT_DPTOL: f64 = 0.001;

    /// Uniform size h0 in the box [min, max] (arrays or vectors), every other option at its
    /// default.
    pub fn uniform(h0: f64, min: impl Into<DVec2>, max: impl Into<DVec2>) -> Self {
        Options2 {
            h0,
            bbox: [min.into(), max.into()],
            size: None,
            fixed: Vec::new(),
            max_iter: Self::DEFAULT_MAX_ITER,
            seed: 0,
            projection: Projection::Auto,
            strategy: Strategy::Local,
            max_elements: Self::DEFAULT_MAX_ELEMENTS,
            fscale: Self::DEFAULT_FSCALE,
            deltat: Self::DEFAULT_DELTAT,
            dptol: Self::DEFAULT_DPTOL,
            progress: None,
            internal: None,
            metric: None,
            sharp_corners: true,
        }
    }
    /// Whether to find the domain's sharp corners and hold them fixed (default true; off, they
    /// are rounded off unless given as fixed points).
    pub fn with_sharp_corners(mut self, on: bool) -> Self {
        self.sharp_corners = on;
        self
    }
    /// Sets the connectivity strategy.
    pub fn with_strategy(mut self, s: Strategy) -> Self {
        self.strategy = s;
        self
    }
    /// Sets the internal boundaries: the zero set of `d_i` (seed section 3.4).
    pub fn with_internal(mut self, d_i: impl Implicit2 + 'static) -> Self {
        self.internal = Some(Arc::new(d_i));
        self
    }
    /// Sets the metric field (anisotropic mode, seed section 3.5) and the internal pressure
    /// tuned for it, [`Options2::METRIC_FSCALE`] (set `fscale` afterwards to override).
    pub fn with_metric(mut self, m: impl Fn(DVec2) -> Metric2 + Send + Sync + 'static) -> Self {
        self.metric = Some(Arc::new(m));
        self.fscale = Self::METRIC_FSCALE;
        self
    }
}

truss_builders!(Options2);
domain_builders!(Options2, DVec2);
