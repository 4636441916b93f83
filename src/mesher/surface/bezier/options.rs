//! What the Bézier patch mesher is asked for.

/// Options of [`mesh_patches`](super::mesh_patches).
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct BezierOptions {
    /// Target edge length in space.
    pub h0: f64,
    /// Force iterations.
    pub max_iter: usize,
    /// Bars pushed toward Fscale h (seed eq. 2.6).
    pub fscale: f64,
    /// Forward Euler step.
    pub deltat: f64,
    /// Mesh in space (true) or, for comparison, in the parameter plane with the same loop.
    pub in_space: bool,
}

impl BezierOptions {
    /// Target size `h0` in space, 300 iterations, Fscale 1.2, time step 0.2.
    pub fn new(h0: f64) -> Self {
        BezierOptions { h0, max_iter: 300, fscale: 1.2, deltat: 0.2, in_space: true }
    }
}

crate::mesher::options::setters!(BezierOptions {
    /// Sets the iteration cap.
    with_max_iter => max_iter: usize,
    /// Sets the internal pressure Fscale (seed eq. 2.6).
    with_fscale => fscale: f64,
    /// Sets the forward Euler time step (seed eq. 2.4).
    with_deltat => deltat: f64,
    /// Meshes in space (true, the default) or in the parameter plane (for comparison).
    with_in_space => in_space: bool,
});
