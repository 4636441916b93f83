//! Segment primitives shared by the planar polygon geometries ([`crate::geometry::Polygon`] and
//! [`super::Polygons2`]): the nearest point of a segment, the even-odd ray crossing and the
//! crossing of two segments, the last two decided by exact orientation signs.

use crate::predicates::{orient2d, Sign};
use glam::DVec2;

/// The nearest point of segment [a, b] to `p` and its parameter t in [0, 1] (a degenerate
/// segment gives its start).
#[inline]
pub(crate) fn closest_on_segment(p: DVec2, a: DVec2, b: DVec2) -> (DVec2, f64) {
    let e = b - a;
    let l2 = e.length_squared();
    let t = if l2 > 0.0 { ((p - a).dot(e) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (a + t * e, t)
}

/// Whether the ray from `p` towards +x crosses segment [a, b]: one end strictly above p.y and
/// the other at or below (so a vertex on the ray counts once), and the crossing strictly right
/// of `p`, decided by the exact sign of orient2d(a, b, p). Points on the segment count as not
/// crossed (their distance is zero, so the sign does not matter).
#[inline]
pub(crate) fn crosses_ray(p: DVec2, a: DVec2, b: DVec2) -> bool {
    if (a.y > p.y) == (b.y > p.y) {
        return false;
    }
    if a.x.max(b.x) < p.x {
        return false;
    }
    // Upward edges cross right of p when p is on their left; downward ones when on their right.
    let want = if b.y > a.y { Sign::Positive } else { Sign::Negative };
    orient2d(a, b, p) == want
}

/// Whether point `c`, collinear with [a, b], lies on the closed segment.
#[inline]
fn on_collinear(a: DVec2, b: DVec2, c: DVec2) -> bool {
    c.cmpge(a.min(b)).all() && c.cmple(a.max(b)).all()
}

/// Whether the closed segments [a, b] and [c, d] have a point in common (exact).
pub(crate) fn segments_meet(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let (o1, o2) = (orient2d(a, b, c), orient2d(a, b, d));
    let (o3, o4) = (orient2d(c, d, a), orient2d(c, d, b));
    if o1 != o2 && o3 != o4 && o1 != Sign::Zero && o2 != Sign::Zero && o3 != Sign::Zero && o4 != Sign::Zero {
        return true;
    }
    (o1 == Sign::Zero && on_collinear(a, b, c))
        || (o2 == Sign::Zero && on_collinear(a, b, d))
        || (o3 == Sign::Zero && on_collinear(c, d, a))
        || (o4 == Sign::Zero && on_collinear(c, d, b))
}

/// Whether consecutive segments [a, b] and [b, c] overlap beyond their shared end: they fold
/// back on one line (c on the ray from b through a).
pub(crate) fn folds_back(a: DVec2, b: DVec2, c: DVec2) -> bool {
    orient2d(a, b, c) == Sign::Zero && (a - b).dot(c - b) > 0.0
}

/// A point where [a, b] and [c, d] meet (for messages): the crossing of their lines, or the
/// end of one that lies on the other when they are parallel.
pub(crate) fn meeting_point(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> DVec2 {
    let (e, f) = (b - a, d - c);
    let den = e.perp_dot(f);
    if den != 0.0 {
        let t = ((c - a).perp_dot(f) / den).clamp(0.0, 1.0);
        return a + t * e;
    }
    [c, d, a, b]
        .into_iter()
        .find(|&q| {
            let (s, t) = if q == c || q == d { (a, b) } else { (c, d) };
            on_collinear(s, t, q)
        })
        .unwrap_or(a)
}
