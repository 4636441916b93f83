//! The density band of the truss (seed section 2.4, density control): an edge longer than
//! `split_above` target lengths is split, one shorter than `collapse_below` is collapsed.

/// Density control's thresholds, in target lengths (the length the size function asks for).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityBand {
    /// Edges longer than this many target lengths are split.
    pub split_above: f64,
    /// Edges shorter than this many target lengths are collapsed.
    pub collapse_below: f64,
}

impl DensityBand {
    /// The band (split above, collapse below).
    pub const fn new(split_above: f64, collapse_below: f64) -> Self {
        DensityBand { split_above, collapse_below }
    }
    /// Whether an edge of `ratio` target lengths is to be split.
    #[inline]
    pub fn splits(&self, ratio: f64) -> bool {
        ratio > self.split_above
    }
    /// Whether an edge of `ratio` target lengths is to be collapsed.
    #[inline]
    pub fn collapses(&self, ratio: f64) -> bool {
        ratio < self.collapse_below
    }
}
