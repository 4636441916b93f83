//! Options of the 3-D mesher, with their defaults.

use crate::geometry::project::Projection;
use glam::DVec3;
use std::sync::Arc;

use crate::mesher::options::{domain_builders, setters, truss_builders, ProgressFn};

/// A relative size function h(x) in 3-D (only ratios matter; h0 sets the scale).
pub type SizeFn3 = Arc<dyn Fn(DVec3) -> f64 + Send + Sync>;

/// Options of [`crate::mesher::mesh_3d`].
#[derive(Clone)]
#[non_exhaustive]
pub struct Options3 {
    /// Initial edge length h0 (the absolute scale of the relative size h).
    pub h0: f64,
    /// Bounding box (min, max) that contains the domain.
    pub bbox: [DVec3; 2],
    /// Relative size h(x); `None` is uniform.
    pub size: Option<SizeFn3>,
    /// Points that become fixed mesh vertices.
    pub fixed: Vec<DVec3>,
    /// Iteration cap; the last valid mesh is returned with `converged == false`.
    pub max_iter: usize,
    /// Seed for every random choice (same input and seed, same output bit for bit).
    pub seed: u64,
    /// How boundary nodes are projected onto d = 0.
    pub projection: Projection,
    /// Refuse to start when the estimated tetrahedron count passes this.
    pub max_elements: u64,
    /// Internal pressure: unstretched bar length over the actual mean (seed eq. 2.6).
    pub fscale: f64,
    /// Forward Euler time step (seed eq. 2.4).
    pub deltat: f64,
    /// Stop when every node moves less than dptol h in a step (seed).
    pub dptol: f64,
    /// Sliver removal rounds after the force equilibrium (swaps, smoothing, perturbation).
    pub polish_rounds: usize,
    /// Progress callback: (iteration, iteration cap).
    pub progress: Option<ProgressFn>,
    /// Find the domain's sharp edges and corners from d and hold points on them fixed (on by
    /// default).
    pub sharp_edges: bool,
}

impl std::fmt::Debug for Options3 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Options3")
            .field("h0", &self.h0)
            .field("bbox", &self.bbox)
            .field("size", &self.size.as_ref().map(|_| "fn"))
            .field("fixed", &self.fixed)
            .field("max_iter", &self.max_iter)
            .field("seed", &self.seed)
            .field("projection", &self.projection)
            .field("fscale", &self.fscale)
            .field("deltat", &self.deltat)
            .field("sharp_edges", &self.sharp_edges)
            .finish()
    }
}

impl Options3 {
    /// Default iteration cap.
    pub const DEFAULT_MAX_ITER: usize = 300;
    /// Default element limit.
    pub const DEFAULT_MAX_ELEMENTS: u64 = 50_000_000;
    /// Default internal pressure (the seed uses 1.1 in 3-D).
    pub const DEFAULT_FSCALE: f64 = 1.1;
    /// Default time step (seed: 0.1 in 3-D).
    pub const DEFAULT_DELTAT: f64 = 0.1;
    /// Default movement tolerance (seed: 0.001).
    pub const DEFAULT_DPTOL: f64 = 0.001;
    /// Default number of sliver removal rounds.
    pub const DEFAULT_POLISH_ROUNDS: usize = 8;

    /// Uniform size h0 in the box [min, max], every other option at its default.
    pub fn uniform(h0: f64, min: impl Into<DVec3>, max: impl Into<DVec3>) -> Self {
        Options3 {
            h0,
            bbox: [min.into(), max.into()],
            size: None,
            fixed: Vec::new(),
            max_iter: Self::DEFAULT_MAX_ITER,
            seed: 0,
            projection: Projection::Auto,
            max_elements: Self::DEFAULT_MAX_ELEMENTS,
            fscale: Self::DEFAULT_FSCALE,
            deltat: Self::DEFAULT_DELTAT,
            dptol: Self::DEFAULT_DPTOL,
            polish_rounds: Self::DEFAULT_POLISH_ROUNDS,
            progress: None,
            sharp_edges: true,
        }
    }
    /// Whether to find the domain's sharp edges and corners and hold points on them fixed
    /// (default true; off, they are rounded off unless given as fixed points).
    pub fn with_sharp_edges(mut self, on: bool) -> Self {
        self.sharp_edges = on;
        self
    }
}

truss_builders!(Options3);
domain_builders!(Options3, DVec3);
setters!(Options3 {
    /// Sets the number of sliver removal rounds after the force equilibrium.
    with_polish_rounds => polish_rounds: usize,
});
