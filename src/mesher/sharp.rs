//! The thresholds of sharp-feature detection, shared by the 2-D corner finder
//! (`planar::features`) and the 3-D edge and corner finder (`volume::features`). Lengths are
//! in sample spacings: the 2-D grid's spacing, or the 3-D surface start points' gap (times h).

/// Normals differing by more than this many degrees mark a corner or an edge.
pub(crate) const SHARP_DEG: f64 = 40.0;
/// Pairs of boundary samples are looked at up to this many spacings apart.
pub(crate) const REACH: f64 = 1.6;
/// A point where tangent lines (planes) meet is kept when the projection moves it by at most
/// this many spacings: more, and the boundary is curved, not sharp, there.
pub(crate) const TOL: f64 = 0.1;
/// The probes on either side of a sample are this many spacings away from it.
pub(crate) const PROBE: f64 = 1e-3;
/// Held points are at least this many target lengths (h0 h) apart, and as far from the user's
/// fixed points.
pub(crate) const SPACING: f64 = 1.0;
/// Steps of the refinement onto a curved side or edge (tangents taken ever closer).
pub(crate) const REFINE_STEPS: usize = 3;

/// The two probe normals that differ most (smallest dot product), with that dot product: a
/// sample whose probes split this widely lies on a sharp feature itself.
pub(crate) fn widest_split<P: Copy>(probes: &[P], dot: impl Fn(P, P) -> f64) -> Option<(f64, P, P)> {
    probes
        .iter()
        .flat_map(|&a| probes.iter().map(move |&b| (a, b)))
        .map(|(a, b)| (dot(a, b), a, b))
        .min_by(|x, y| x.0.total_cmp(&y.0))
}
