//! The option vocabulary every mesher shares: the same field names, types and `with_*`
//! builders in [`Options2`](super::Options2), [`Options3`](super::Options3) and
//! [`SurfaceOptions`](super::surface::SurfaceOptions) (h0, bbox, size, fixed, max_iter, seed,
//! projection, max_elements, fscale, deltat, dptol, progress). The builders are generated
//! here once, so that their names and meanings cannot drift apart.

/// Called with (iteration or stage done, iteration cap or stages) as a run goes.
pub type ProgressFn = std::sync::Arc<dyn Fn(usize, usize) + Send + Sync>;

/// `with_*` setters for plain fields: `setters!(Type { with_x => x: T, ... })`, each with its
/// doc comment.
macro_rules! setters {
    ($t:ty { $($(#[$doc:meta])* $name:ident => $field:ident : $ty:ty),* $(,)? }) => {
        impl $t {
            $(
                $(#[$doc])*
                pub fn $name(mut self, value: $ty) -> Self {
                    self.$field = value;
                    self
                }
            )*
        }
    };
}

/// The builders of the truss parameters every mesher has: max_iter, fscale, deltat, dptol and
/// the progress callback.
macro_rules! truss_builders {
    ($t:ty) => {
        crate::mesher::options::setters!($t {
            /// Sets the iteration cap.
            with_max_iter => max_iter: usize,
            /// Sets the internal pressure Fscale (seed eq. 2.6).
            with_fscale => fscale: f64,
            /// Sets the forward Euler time step (seed eq. 2.4).
            with_deltat => deltat: f64,
            /// Sets the movement tolerance (relative to the local size).
            with_dptol => dptol: f64,
        });
        impl $t {
            /// Sets the progress callback, called with (done, total).
            pub fn with_progress(mut self, f: impl Fn(usize, usize) + Send + Sync + 'static) -> Self {
                self.progress = Some(std::sync::Arc::new(f));
                self
            }
        }
    };
}

/// The builders of the domain meshers (2-D and 3-D), points of type `$p`: size, fixed points,
/// seed, projection and the element limit.
macro_rules! domain_builders {
    ($t:ty, $p:ty) => {
        crate::mesher::options::setters!($t {
            /// Sets the seed of every random choice.
            with_seed => seed: u64,
            /// Sets how boundary nodes are projected onto d = 0.
            with_projection => projection: crate::geometry::project::Projection,
            /// Sets the element limit (the run refuses to start past it).
            with_max_elements => max_elements: u64,
        });
        impl $t {
            /// Sets the relative size function h(x) (only ratios matter; h0 sets the scale).
            pub fn with_size(mut self, h: impl Fn($p) -> f64 + Send + Sync + 'static) -> Self {
                self.size = Some(std::sync::Arc::new(h));
                self
            }
            /// Sets the fixed points (arrays or vectors).
            pub fn with_fixed<Q: Into<$p>>(mut self, pts: impl IntoIterator<Item = Q>) -> Self {
                self.fixed = pts.into_iter().map(Into::into).collect();
                self
            }
        }
    };
}

pub(crate) use {domain_builders, setters, truss_builders};
