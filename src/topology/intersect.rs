//! Exact intersection tests for the embedding checks: closed segments and triangles in the
//! plane and in space, decided by the signs of orient2d / orient3d only (touching counts as
//! meeting), and the candidate pairs of a set of boxes found through a uniform grid of buckets
//! (expected linear time for meshes whose elements have comparable sizes).

use crate::predicates::{orient2d, orient3d, Sign};
use glam::{DVec2, DVec3};
use rayon::prelude::*;

/// True when c, known collinear with a and b, lies on the closed segment ab (exact: coordinate
/// comparisons).
fn on_segment(a: DVec2, b: DVec2, c: DVec2) -> bool {
    a.x.min(b.x) <= c.x && c.x <= a.x.max(b.x) && a.y.min(b.y) <= c.y && c.y <= a.y.max(b.y)
}

fn opposite(a: Sign, b: Sign) -> bool {
    matches!((a, b), (Sign::Positive, Sign::Negative) | (Sign::Negative, Sign::Positive))
}

/// Whether the closed segments pq and rs share a point. Segments whose boxes are apart cannot
/// meet (exact comparisons): most pairs asked about are, and skip the four predicates.
pub(crate) fn segments_meet(p: DVec2, q: DVec2, r: DVec2, s: DVec2) -> bool {
    if p.x.max(q.x) < r.x.min(s.x)
        || r.x.max(s.x) < p.x.min(q.x)
        || p.y.max(q.y) < r.y.min(s.y)
        || r.y.max(s.y) < p.y.min(q.y)
    {
        return false;
    }
    let (o1, o2) = (orient2d(p, q, r), orient2d(p, q, s));
    let (o3, o4) = (orient2d(r, s, p), orient2d(r, s, q));
    if opposite(o1, o2) && opposite(o3, o4) {
        return true;
    }
    (o1 == Sign::Zero && on_segment(p, q, r))
        || (o2 == Sign::Zero && on_segment(p, q, s))
        || (o3 == Sign::Zero && on_segment(r, s, p))
        || (o4 == Sign::Zero && on_segment(r, s, q))
}

/// Whether p lies in the closed triangle abc (either orientation, non-degenerate).
fn in_triangle_2d(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    let s = [orient2d(a, b, p), orient2d(b, c, p), orient2d(c, a, p)];
    !(s.contains(&Sign::Positive) && s.contains(&Sign::Negative))
}

/// The projection that drops one coordinate and keeps triangle abc non-degenerate (exists for
/// any non-degenerate triangle; dropping a coordinate is exact and keeps incidence in the plane).
fn projection(a: DVec3, b: DVec3, c: DVec3) -> Option<fn(DVec3) -> DVec2> {
    let drops: [fn(DVec3) -> DVec2; 3] = [|p| DVec2::new(p.y, p.z), |p| DVec2::new(p.z, p.x), |p| DVec2::new(p.x, p.y)];
    drops.into_iter().find(|f| orient2d(f(a), f(b), f(c)) != Sign::Zero)
}

/// Whether the closed segment pq meets the closed triangle abc (non-degenerate) in space.
pub(crate) fn segment_meets_triangle(p: DVec3, q: DVec3, a: DVec3, b: DVec3, c: DVec3) -> bool {
    let (op, oq) = (orient3d(a, b, c, p), orient3d(a, b, c, q));
    if op == oq && op != Sign::Zero {
        return false;
    }
    if op == Sign::Zero && oq == Sign::Zero {
        let Some(f) = projection(a, b, c) else { return false };
        let (p, q, a, b, c) = (f(p), f(q), f(a), f(b), f(c));
        return in_triangle_2d(p, a, b, c)
            || in_triangle_2d(q, a, b, c)
            || segments_meet(p, q, a, b)
            || segments_meet(p, q, b, c)
            || segments_meet(p, q, c, a);
    }
    // The line pq crosses the plane within the segment: it meets the triangle when it passes
    // on one side of (or through) every edge.
    let s = [orient3d(p, q, a, b), orient3d(p, q, b, c), orient3d(p, q, c, a)];
    !(s.contains(&Sign::Positive) && s.contains(&Sign::Negative))
}

/// Whether two triangles in space, `shared` of whose corners are the same vertices, meet
/// anywhere other than in what they share. `t` and `u` list corners with the shared ones first
/// (in matching order).
pub(crate) fn triangles_meet(t: [DVec3; 3], u: [DVec3; 3], shared: usize) -> bool {
    match shared {
        0 => {
            // Quick rejection: one triangle strictly on one side of the other's plane.
            let side = |x: [DVec3; 3], y: [DVec3; 3]| {
                let s = y.map(|p| orient3d(x[0], x[1], x[2], p));
                s.iter().all(|&v| v == Sign::Positive) || s.iter().all(|&v| v == Sign::Negative)
            };
            if side(t, u) || side(u, t) {
                return false;
            }
            (0..3).any(|k| segment_meets_triangle(t[k], t[(k + 1) % 3], u[0], u[1], u[2]))
                || (0..3).any(|k| segment_meets_triangle(u[k], u[(k + 1) % 3], t[0], t[1], t[2]))
        }
        // Sharing a: beyond a they meet exactly when the far edge of one meets the other.
        1 => {
            segment_meets_triangle(t[1], t[2], u[0], u[1], u[2]) || segment_meets_triangle(u[1], u[2], t[0], t[1], t[2])
        }
        // Sharing the edge ab: they meet beyond it only folded flat onto each other (coplanar,
        // apexes on the same side of ab).
        2 => {
            if orient3d(t[0], t[1], t[2], u[2]) != Sign::Zero {
                return false;
            }
            let Some(f) = projection(t[0], t[1], t[2]) else { return false };
            orient2d(f(t[0]), f(t[1]), f(t[2])) == orient2d(f(t[0]), f(t[1]), f(u[2]))
        }
        _ => true,
    }
}

/// An axis-aligned box (z = 0 in the plane).
pub(crate) type Box3 = (DVec3, DVec3);

/// The first pair (i, j), i < j, in a fixed order, of items whose closed boxes overlap and for
/// which `hits(i, j)` holds. Boxes are bucketed on a uniform grid sized by the mean box; each
/// candidate pair is tested once (in the bucket of the low corner of the boxes' overlap). The
/// result does not depend on the thread count.
pub(crate) fn first_hit<F>(boxes: &[Box3], dim: usize, hits: F) -> Option<(usize, usize)>
where
    F: Fn(usize, usize) -> bool + Sync,
{
    let n = boxes.len();
    if n < 2 {
        return None;
    }
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let mut mean = 0.0;
    for b in boxes {
        lo = lo.min(b.0);
        hi = hi.max(b.1);
        mean += (b.1 - b.0).max_element();
    }
    mean /= n as f64;
    let span = (hi - lo).max_element();
    if !span.is_finite() || !mean.is_finite() {
        return None;
    }
    // Buckets of about the mean box (a surface's triangles fill a 2-D part of 3-D space, so
    // no count-based size); keys hold 2^20 buckets per axis.
    let cell = mean.max(span / (1u64 << 20) as f64).max(f64::MIN_POSITIVE);
    let dims: Vec<u64> =
        (0..3).map(|k| if k < dim { (((hi[k] - lo[k]) / cell) as u64 + 1).min(1 << 20) } else { 1 }).collect();
    let coord = |p: DVec3, k: usize| -> u64 {
        if k >= dim {
            return 0;
        }
        (((p[k] - lo[k]) / cell).max(0.0) as u64).min(dims[k] - 1)
    };
    let key = |c: [u64; 3]| (c[2] << 40) | (c[1] << 20) | c[0];
    // Items covering more than a few buckets per axis are tested against everything.
    const WIDE: u64 = 8;
    let mut entries: Vec<(u64, u32)> = Vec::with_capacity(n * if dim == 3 { 4 } else { 2 });
    let mut wide = Vec::new();
    for (i, b) in boxes.iter().enumerate() {
        let (a, z) = ([0, 1, 2].map(|k| coord(b.0, k)), [0, 1, 2].map(|k| coord(b.1, k)));
        if (0..3).any(|k| z[k] - a[k] >= WIDE) {
            wide.push(i);
            continue;
        }
        for cz in a[2]..=z[2] {
            for cy in a[1]..=z[1] {
                for cx in a[0]..=z[0] {
                    entries.push((key([cx, cy, cz]), i as u32));
                }
            }
        }
    }
    entries.par_sort_unstable();
    let overlap = |i: usize, j: usize| {
        let (a, b) = (boxes[i], boxes[j]);
        (0..dim).all(|k| a.0[k] <= b.1[k] && b.0[k] <= a.1[k])
    };
    let mut groups = Vec::new();
    let mut g = 0;
    while g < entries.len() {
        let mut e = g + 1;
        while e < entries.len() && entries[e].0 == entries[g].0 {
            e += 1;
        }
        if e - g > 1 {
            groups.push((g, e));
        }
        g = e;
    }
    let found = groups.par_iter().find_map_first(|&(g, e)| {
        let here = entries[g].0;
        let list = &entries[g..e];
        let mut best: Option<(usize, usize)> = None;
        for (x, &(_, a)) in list.iter().enumerate() {
            for &(_, b) in &list[x + 1..] {
                let (a, b) = (a.min(b) as usize, a.max(b) as usize);
                let low = boxes[a].0.max(boxes[b].0);
                if key([0, 1, 2].map(|k| coord(low, k))) != here || !overlap(a, b) {
                    continue;
                }
                if best.is_none_or(|p| (a, b) < p) && hits(a, b) {
                    best = Some((a, b));
                }
            }
        }
        best
    });
    if found.is_some() {
        return found;
    }
    wide.par_iter().find_map_first(|&w| {
        (0..n)
            .filter(|&j| j != w && overlap(w, j) && !(wide.contains(&j) && j < w))
            .find(|&j| hits(w.min(j), w.max(j)))
            .map(|j| (w.min(j), w.max(j)))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_and_triangles() {
        let d = |x: f64, y: f64| DVec2::new(x, y);
        assert!(segments_meet(d(0., 0.), d(1., 1.), d(0., 1.), d(1., 0.)));
        assert!(segments_meet(d(0., 0.), d(1., 0.), d(1., 0.), d(2., 5.)), "touching at an end");
        assert!(!segments_meet(d(0., 0.), d(1., 0.), d(2., 0.), d(3., 0.)), "collinear apart");
        assert!(segments_meet(d(0., 0.), d(2., 0.), d(1., 0.), d(3., 0.)), "collinear overlap");
        let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let t = [v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.)];
        assert!(segment_meets_triangle(v(0.2, 0.2, -1.), v(0.2, 0.2, 1.), t[0], t[1], t[2]));
        assert!(!segment_meets_triangle(v(0.8, 0.8, -1.), v(0.8, 0.8, 1.), t[0], t[1], t[2]));
        assert!(segment_meets_triangle(v(-1., 0.2, 0.), v(2., 0.2, 0.), t[0], t[1], t[2]), "coplanar");
        // Two triangles through each other, none sharing a vertex.
        let u = [v(0.2, 0.2, -1.), v(0.3, 0.2, 1.), v(5., 5., 0.5)];
        assert!(triangles_meet(t, u, 0));
        let u = [v(0.2, 0.2, 0.5), v(0.3, 0.2, 1.), v(5., 5., 0.5)];
        assert!(!triangles_meet(t, u, 0));
        // Sharing the edge: folded flat meets, a hinge does not.
        assert!(triangles_meet(t, [t[0], t[1], v(0.5, 0.5, 0.)], 2));
        assert!(!triangles_meet(t, [t[0], t[1], v(0.5, -0.5, 0.)], 2));
        assert!(!triangles_meet(t, [t[0], t[1], v(0.5, 0.5, 0.1)], 2));
        // Sharing a vertex: a fan that opens, and one that passes through.
        assert!(!triangles_meet(t, [t[0], v(-1., 0., 0.), v(0., -1., 0.)], 1));
        assert!(triangles_meet(t, [t[0], v(0.5, 0.1, -1.), v(0.1, 0.5, 1.)], 1));
    }
}
