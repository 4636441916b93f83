//! What makes a set of closed polylines the boundary of a planar domain, checked before any
//! distance is taken: some input, finite coordinates, at least three distinct points a loop,
//! and no two segments meeting other than consecutive ones at their shared end (no crossing,
//! touching or overlapping, within a loop or between loops).

use super::bvh::SegmentBvh;
use super::segment::{folds_back, meeting_point, segments_meet};
use glam::DVec2;
use rayon::prelude::*;
use thiserror::Error;

/// Why a set of polylines bounds no planar domain. Loops and their points are numbered from 0
/// in file order; segment k of a loop runs from its point k to point k + 1 (the last back to
/// point 0).
#[derive(Clone, Debug, PartialEq, Error)]
pub enum PolygonError {
    /// No loop at all.
    #[error("no closed polyline in the input (empty input)")]
    Empty,
    /// A NaN or infinite coordinate.
    #[error("point {point} of loop {polyline} has a non-finite coordinate ({}, {})", at[0], at[1])]
    NonFinite {
        /// The loop.
        polyline: usize,
        /// The point within it.
        point: usize,
        /// Its coordinates.
        at: [f64; 2],
    },
    /// A loop of fewer than three distinct points encloses nothing.
    #[error(
        "loop {polyline} has {count} distinct point(s), starting at ({}, {}); a closed polyline needs at least 3",
        at[0], at[1]
    )]
    TooFewPoints {
        /// The loop.
        polyline: usize,
        /// Its distinct points.
        count: usize,
        /// Its first point.
        at: [f64; 2],
    },
    /// A polyline that does not come back to its start.
    #[error("an open polyline: {what} ends at ({}, {}) without joining another segment; close it", at[0], at[1])]
    Open {
        /// Which polyline or record (as the reader names it).
        what: String,
        /// The loose end.
        at: [f64; 2],
    },
    /// A point where more than two segments meet: the polylines branch or touch there.
    #[error("{count} segments meet at the point ({}, {}); every point of a closed polyline joins two", at[0], at[1])]
    Branch {
        /// How many segments meet there.
        count: usize,
        /// The point.
        at: [f64; 2],
    },
    /// Two segments that cross, touch or overlap.
    #[error(
        "segment {} of loop {} and segment {} of loop {} {} near ({}, {}): the polylines must not cross or touch",
        segments[0][1], segments[0][0], segments[1][1], segments[1][0],
        if segments[0][0] == segments[1][0] { "cross (a self-intersecting loop)" } else { "cross (loops cross)" },
        at[0], at[1]
    )]
    Crossing {
        /// The two segments, each as [loop, segment].
        segments: [[usize; 2]; 2],
        /// About where they meet.
        at: [f64; 2],
    },
}

/// Segment `s` of the flat list: its loop and its index in it.
pub(super) type SegId = (u32, u32);

/// The first pair of segments (in input order) that meet other than at a shared end of
/// consecutive segments; `len[l]` is the number of segments of loop l.
pub(super) fn first_crossing(
    segs: &[[DVec2; 2]],
    ids: &[SegId],
    len: &[usize],
    bvh: &SegmentBvh,
) -> Option<PolygonError> {
    let next = |s: usize| -> usize {
        let (l, k) = ids[s];
        if k as usize + 1 == len[l as usize] {
            s + 1 - len[l as usize]
        } else {
            s + 1
        }
    };
    let pair = (0..segs.len()).into_par_iter().find_map_first(|i| {
        let [a, b] = segs[i];
        let mut hit: Option<usize> = None;
        bvh.overlapping(a.min(b), a.max(b), |j| {
            if j <= i || hit.is_some_and(|h| h < j) {
                return;
            }
            let [c, d] = segs[j];
            let bad = if next(i) == j {
                folds_back(a, b, d)
            } else if next(j) == i {
                folds_back(c, d, b)
            } else {
                segments_meet(a, b, c, d)
            };
            if bad {
                hit = Some(j);
            }
        });
        hit.map(|j| (i, j))
    });
    pair.map(|(i, j)| {
        let ([a, b], [c, d]) = (segs[i], segs[j]);
        let at = meeting_point(a, b, c, d);
        let id = |s: usize| [ids[s].0 as usize, ids[s].1 as usize];
        PolygonError::Crossing { segments: [id(i), id(j)], at: at.to_array() }
    })
}
