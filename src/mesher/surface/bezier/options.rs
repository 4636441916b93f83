//! What the Bézier patch mesher is asked for.

/// Options of [`mesh_patches`](super::mesh_patches).
#[derive(Clone, Debug)]
pub struct BezierOptions {
    /// Target edge length in space.
    pub h0: f64,
    /// Force iterations.
    pub max_iterations: usize,
    /// Bars pushed toward Fscale h (seed eq. 2.6).
    pub fscale: f64,
    /// Forward Euler step.
    pub dt: f64,
    /// Mesh in space (true) or, for comparison, in the parameter plane with the same loop.
    pub in_space: bool,
}

impl BezierOptions {
    /// Target size `h0` in space, 300 iterations, Fscale 1.2, dt 0.2.
    pub fn new(h0: f64) -> Self {
        BezierOptions { h0, max_iterations: 300, fscale: 1.2, dt: 0.2, in_space: true }
    }
}
