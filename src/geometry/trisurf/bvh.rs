//! A flat bounding-volume hierarchy over the input triangles: axis-aligned boxes split at the
//! median centroid along the longest axis, nodes in depth-first order in one array, leaves of
//! at most LEAF triangles whose corners are stored contiguously.
//!
//! Written here rather than taken from a crate: `bvh` answers ray queries but not nearest-point
//! ones, and `parry3d-f64` (which has both) brings nalgebra and its own vector and mesh types
//! for the one query this module needs; the hierarchy below is about a hundred lines.

use super::distance::{closest_on_triangle, Feature};
use glam::DVec3;

/// Triangles per leaf.
const LEAF: usize = 4;

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first triangle (in `order`); inner node: the index of the second child (the
    /// first is the next node).
    start: u32,
    /// Triangles in the leaf; 0 for an inner node.
    count: u32,
}

/// The hierarchy: nodes, the triangles in leaf order and their corners.
#[derive(Clone, Debug)]
pub(super) struct Bvh {
    nodes: Vec<Node>,
    /// Input triangle index of each slot.
    order: Vec<u32>,
    /// Corners of each slot's triangle.
    corners: Vec<[DVec3; 3]>,
}

/// The nearest point of the surface to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// The nearest point.
    pub point: DVec3,
    /// Its squared distance to the query.
    pub dist2: f64,
    /// The input triangle it lies on.
    pub triangle: usize,
    /// Where on that triangle: its inside, an edge or a corner.
    pub feature: Feature,
}

fn box_dist2(lo: DVec3, hi: DVec3, p: DVec3) -> f64 {
    let d = (lo - p).max(p - hi).max(DVec3::ZERO);
    d.length_squared()
}

impl Bvh {
    /// Builds the hierarchy over `tris` (corner coordinates); the triangle list must not be empty.
    pub(super) fn new(tris: &[[DVec3; 3]]) -> Bvh {
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let centroids: Vec<DVec3> = tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let mut nodes = Vec::with_capacity(2 * tris.len() / LEAF + 1);
        build(&mut nodes, &mut order, 0, tris, &centroids);
        let corners = order.iter().map(|&t| tris[t as usize]).collect();
        Bvh { nodes, order, corners }
    }

    /// The nearest point of the triangles to `p`. Children are visited nearer box first and
    /// boxes no nearer than the best so far are skipped; ties keep the first triangle found, in
    /// a fixed traversal order, so the answer is the same on every run.
    pub(super) fn closest(&self, p: DVec3) -> Closest {
        self.closest_below(p, f64::INFINITY)
    }

    /// [`Bvh::closest`] among the points closer than `sqrt(bound2)` to `p` (boxes no nearer
    /// are skipped from the start): the same answer when the nearest point is that close, and
    /// `dist2` infinite when none is. Far from the surface a query that needs only to know
    /// that nothing is near is then as cheap as one next to it.
    pub(super) fn closest_below(&self, p: DVec3, bound2: f64) -> Closest {
        let mut best = Closest { point: p, dist2: f64::INFINITY, triangle: 0, feature: Feature::Face };
        let mut bound = bound2;
        let mut stack: [u32; 64] = [0; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let ni = stack[top] as usize;
            let n = &self.nodes[ni];
            if box_dist2(n.lo, n.hi, p) >= bound {
                continue;
            }
            if n.count > 0 {
                for s in n.start as usize..(n.start + n.count) as usize {
                    let [a, b, c] = self.corners[s];
                    let (q, f) = closest_on_triangle(p, a, b, c);
                    let d2 = (p - q).length_squared();
                    if d2 < bound {
                        best = Closest { point: q, dist2: d2, triangle: self.order[s] as usize, feature: f };
                        bound = d2;
                    }
                }
                continue;
            }
            let (l, r) = (ni + 1, n.start as usize);
            let (dl, dr) =
                (box_dist2(self.nodes[l].lo, self.nodes[l].hi, p), box_dist2(self.nodes[r].lo, self.nodes[r].hi, p));
            // Push the farther child first so that the nearer one is searched first.
            let (first, second) = if dl <= dr { (r, l) } else { (l, r) };
            stack[top] = first as u32;
            stack[top + 1] = second as u32;
            top += 2;
        }
        best
    }

    /// Calls `f` with every input triangle whose box overlaps [lo, hi].
    pub(super) fn overlapping(&self, lo: DVec3, hi: DVec3, mut f: impl FnMut(usize)) {
        let mut stack = vec![0usize];
        while let Some(ni) = stack.pop() {
            let n = &self.nodes[ni];
            if n.lo.cmpgt(hi).any() || n.hi.cmplt(lo).any() {
                continue;
            }
            if n.count > 0 {
                for s in n.start as usize..(n.start + n.count) as usize {
                    let t = &self.corners[s];
                    let (tl, th) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                    if !(tl.cmpgt(hi).any() || th.cmplt(lo).any()) {
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

/// Builds the subtree over `order[first..first + len]` (len from the slice), depth first.
fn build(nodes: &mut Vec<Node>, order: &mut [u32], first: usize, tris: &[[DVec3; 3]], cen: &[DVec3]) {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let (mut clo, mut chi) = (lo, hi);
    for &t in order.iter() {
        for q in tris[t as usize] {
            lo = lo.min(q);
            hi = hi.max(q);
        }
        clo = clo.min(cen[t as usize]);
        chi = chi.max(cen[t as usize]);
    }
    let me = nodes.len();
    nodes.push(Node { lo, hi, start: first as u32, count: order.len() as u32 });
    if order.len() <= LEAF {
        return;
    }
    let ext = chi - clo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    // Ties broken by index so that the split does not depend on the sort's internals.
    order.select_nth_unstable_by(mid, |&a, &b| cen[a as usize][axis].total_cmp(&cen[b as usize][axis]).then(a.cmp(&b)));
    let (left, right) = order.split_at_mut(mid);
    build(nodes, left, first, tris, cen);
    let second = nodes.len();
    build(nodes, right, first + mid, tris, cen);
    nodes[me].start = second as u32;
    nodes[me].count = 0;
}
