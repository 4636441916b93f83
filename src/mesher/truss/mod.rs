//! The truss, shared by the planar, volume and surface meshers: what every force loop does the
//! same way, written once (seed chapter 2).
//!
//! - [`force`]: the bar-force kernel (seed eq. 2.5) and the rest-length scale (eq. 2.6);
//! - [`step`]: step control, so that no forward Euler step (eq. 2.4) inverts an element;
//! - [`band`]: the density band, splits above and collapses below a length in target units;
//! - [`stop`]: the stop tests (node movement below dptol, quality plateau);
//! - [`domain`]: d and h evaluated with their inputs checked (a typed error naming the bad
//!   value and where it came from);
//! - [`parallel`]: deterministic parallel sums and O(1)-cleared marks for the hot loops.

/// The seed's ttol: connectivity is looked at again once a node moved this many local sizes
/// since the last look (every mesher; the seed retriangulates there).
pub(crate) const TTOL: f64 = 0.1;

/// What a node of a force loop is, which says how it moves (the same in every mesher).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum NodeKind {
    /// Free: moved by the bar forces alone.
    Interior,
    /// On the boundary: moved by the forces, then projected onto d = 0.
    Boundary,
    /// Held where it is (given fixed points, sharp features, a frozen far field).
    Fixed,
    /// On an internal boundary d_I = 0 (2-D): moved, then projected onto it.
    Internal,
    /// Removed from the mesh since the snapshot was built (a 3-D snapshot refresh).
    Dead,
}

impl NodeKind {
    /// The kind of a vertex of the given tag.
    pub(crate) fn of(tag: crate::topology::VertexTag) -> Self {
        use crate::topology::VertexTag;
        match tag {
            VertexTag::Fixed => NodeKind::Fixed,
            VertexTag::Boundary => NodeKind::Boundary,
            VertexTag::InternalBoundary { .. } => NodeKind::Internal,
            VertexTag::Interior => NodeKind::Interior,
        }
    }
}

pub(crate) mod band;
pub(crate) mod domain;
pub(crate) mod force;
pub(crate) mod parallel;
pub(crate) mod step;
pub(crate) mod stop;

pub use band::DensityBand;
pub(crate) use force::{bar_force, RestScale};
pub(crate) use parallel::{det_sum, Flags, CHUNK};
pub(crate) use step::{backtrack, guard_inversions, Backoff};
pub(crate) use stop::Plateau;
