//! Sizes capped by the local feature size where the requested size is wider than the domain:
//! a gap between a hole and a wall narrower than the elements asked for there has no start
//! node deep enough inside to survive the carve, and is left out. Run again with
//! h = min(h_user, lfs / R) (seed eq. 4.6, R = 1: two elements across the narrowest gap),
//! gradient limited (seed eq. 4.18), such parts are meshed.

use super::Options2;
use crate::geometry::Implicit2;
use crate::mesher::input::survey;
use crate::size::{auto_size_2d, SizeParams};
use crate::Error;
use glam::DVec2;
use std::sync::Arc;

/// Half the number of elements across a gap (R of seed eq. 4.6).
const ACROSS_HALF: f64 = 1.0;
/// The gradient limit of the cap.
const CAP_GRADIENT: f64 = 0.3;
/// Grid cells across the box's longer side, at most.
const MAX_CELLS: f64 = 2048.0;

/// `opts` with its size capped by the local feature size; `dropped` are the parts the first
/// run left out (a point of each, the element size there) and set how fine the grid is.
pub(super) fn capped_options(
    domain: &dyn Implicit2,
    opts: &Options2,
    dropped: &[([f64; 2], f64)],
) -> Result<Options2, Error> {
    let [lo, hi] = opts.bbox;
    let ext = (hi - lo).max_element();
    // Fine enough for gaps a quarter of the narrowest dropped part's element size, and for h0.
    let smallest = dropped.iter().map(|d| d.1).fold(f64::INFINITY, f64::min);
    let step = (0.5 * opts.h0).max(0.25 * smallest.min(4.0 * opts.h0)).max(ext / MAX_CELLS);
    let params = SizeParams { k: 0.0, r: ACROSS_HALF, g: CAP_GRADIENT, hmin: opts.h0, ..SizeParams::default() };
    let grid = auto_size_2d(domain, [lo - DVec2::splat(2.0 * step), hi + DVec2::splat(2.0 * step)], step, &params)?;
    // The mesher scales the relative size so that its smallest inside is h0: the cap (h0 or
    // more) goes in at the same scale.
    let floor = survey(domain, opts)?.h_floor;
    let user = opts.size.clone();
    let h0 = opts.h0;
    let mut capped = opts.clone();
    capped.size = Some(Arc::new(move |p: DVec2| {
        let h = user.as_ref().map_or(1.0, |f| f(p));
        h.min(grid.value(p) / h0 * floor)
    }));
    Ok(capped)
}
