//! A flat bounding-volume hierarchy over the segments of a set of polylines: axis-aligned boxes
//! split at the median midpoint along the longer axis, nodes in depth-first order in one array,
//! leaves of at most LEAF segments stored contiguously. The 2-D sibling of the triangle
//! hierarchy of [`crate::geometry::trisurf`], with the three queries a planar domain needs:
//! the nearest segment, the crossings of a ray to +x (the even-odd sign) and the segments whose
//! boxes overlap a box (the crossing check).

use super::segment::{closest_on_segment, crosses_ray};
use glam::DVec2;

/// Segments per leaf.
const LEAF: usize = 4;

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec2,
    hi: DVec2,
    /// Leaf: first slot; inner node: the index of the second child (the first is the next node).
    start: u32,
    /// Segments in the leaf; 0 for an inner node.
    count: u32,
}

/// The hierarchy: nodes, the segments in leaf order and their ends.
#[derive(Clone, Debug)]
pub(super) struct SegmentBvh {
    nodes: Vec<Node>,
    /// Input segment index of each slot.
    order: Vec<u32>,
    /// Ends of each slot's segment.
    ends: Vec<[DVec2; 2]>,
}

/// The nearest point of the polylines to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearestSegment {
    /// The nearest point.
    pub point: DVec2,
    /// Its squared distance to the query.
    pub dist2: f64,
    /// The segment it lies on (input numbering).
    pub segment: usize,
    /// Where on the segment, 0 at its start and 1 at its end.
    pub t: f64,
}

fn box_dist2(lo: DVec2, hi: DVec2, p: DVec2) -> f64 {
    (lo - p).max(p - hi).max(DVec2::ZERO).length_squared()
}

impl SegmentBvh {
    /// Builds the hierarchy over `segs`, which must not be empty.
    pub(super) fn new(segs: &[[DVec2; 2]]) -> SegmentBvh {
        let mut order: Vec<u32> = (0..segs.len() as u32).collect();
        let mids: Vec<DVec2> = segs.iter().map(|s| 0.5 * (s[0] + s[1])).collect();
        let mut nodes = Vec::with_capacity(2 * segs.len() / LEAF + 1);
        build(&mut nodes, &mut order, 0, segs, &mids);
        let ends = order.iter().map(|&s| segs[s as usize]).collect();
        SegmentBvh { nodes, order, ends }
    }

    /// The nearest point of the segments to `p`: nearer child first, boxes no nearer than the
    /// best so far skipped, ties kept by the first segment found in a fixed order (the same
    /// answer on every run).
    pub(super) fn nearest(&self, p: DVec2) -> NearestSegment {
        let mut best = NearestSegment { point: p, dist2: f64::INFINITY, segment: 0, t: 0.0 };
        let mut stack: [u32; 64] = [0; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let ni = stack[top] as usize;
            let n = &self.nodes[ni];
            if box_dist2(n.lo, n.hi, p) >= best.dist2 {
                continue;
            }
            if n.count > 0 {
                for s in n.start as usize..(n.start + n.count) as usize {
                    let [a, b] = self.ends[s];
                    let (q, t) = closest_on_segment(p, a, b);
                    let d2 = (p - q).length_squared();
                    if d2 < best.dist2 {
                        best = NearestSegment { point: q, dist2: d2, segment: self.order[s] as usize, t };
                    }
                }
                continue;
            }
            let (l, r) = (ni + 1, n.start as usize);
            let dl = box_dist2(self.nodes[l].lo, self.nodes[l].hi, p);
            let dr = box_dist2(self.nodes[r].lo, self.nodes[r].hi, p);
            let (first, second) = if dl <= dr { (r, l) } else { (l, r) };
            stack[top] = first as u32;
            stack[top + 1] = second as u32;
            top += 2;
        }
        best
    }

    /// Whether the ray from `p` to +x crosses the segments an odd number of times, counting
    /// only segments `keep` accepts (exact predicates, half-open in y: see [`crosses_ray`]).
    pub(super) fn odd_crossings(&self, p: DVec2, keep: impl Fn(usize) -> bool) -> bool {
        let mut odd = false;
        let mut stack: [u32; 64] = [0; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let ni = stack[top] as usize;
            let n = &self.nodes[ni];
            // A crossing segment has one end above p.y and one at or below, and a point right of p.
            if n.hi.x < p.x || n.hi.y <= p.y || n.lo.y > p.y {
                continue;
            }
            if n.count > 0 {
                for s in n.start as usize..(n.start + n.count) as usize {
                    let [a, b] = self.ends[s];
                    if crosses_ray(p, a, b) && keep(self.order[s] as usize) {
                        odd = !odd;
                    }
                }
            } else {
                stack[top] = n.start;
                stack[top + 1] = ni as u32 + 1;
                top += 2;
            }
        }
        odd
    }

    /// Calls `f` with every segment whose box overlaps [lo, hi] (boundaries included).
    pub(super) fn overlapping(&self, lo: DVec2, hi: DVec2, mut f: impl FnMut(usize)) {
        let mut stack = vec![0usize];
        while let Some(ni) = stack.pop() {
            let n = &self.nodes[ni];
            if n.lo.cmpgt(hi).any() || n.hi.cmplt(lo).any() {
                continue;
            }
            if n.count > 0 {
                for s in n.start as usize..(n.start + n.count) as usize {
                    let [a, b] = self.ends[s];
                    if !(a.min(b).cmpgt(hi).any() || a.max(b).cmplt(lo).any()) {
                        f(self.order[s] as usize);
                    }
                }
            } else {
                stack.push(n.start as usize);
                stack.push(ni + 1);
            }
        }
    }
}

/// Builds the subtree over `order` (whose first slot is `first`), depth first.
fn build(nodes: &mut Vec<Node>, order: &mut [u32], first: usize, segs: &[[DVec2; 2]], mids: &[DVec2]) {
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    let (mut clo, mut chi) = (lo, hi);
    for &s in order.iter() {
        let [a, b] = segs[s as usize];
        lo = lo.min(a).min(b);
        hi = hi.max(a).max(b);
        clo = clo.min(mids[s as usize]);
        chi = chi.max(mids[s as usize]);
    }
    let me = nodes.len();
    nodes.push(Node { lo, hi, start: first as u32, count: order.len() as u32 });
    if order.len() <= LEAF {
        return;
    }
    let ext = chi - clo;
    let axis = if ext.x >= ext.y { 0 } else { 1 };
    let mid = order.len() / 2;
    // Ties broken by index so that the split does not depend on the sort's internals.
    order.select_nth_unstable_by(mid, |&a, &b| {
        mids[a as usize][axis].total_cmp(&mids[b as usize][axis]).then(a.cmp(&b))
    });
    let (left, right) = order.split_at_mut(mid);
    build(nodes, left, first, segs, mids);
    let second = nodes.len();
    build(nodes, right, first + mid, segs, mids);
    nodes[me].start = second as u32;
    nodes[me].count = 0;
}
