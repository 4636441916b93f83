//! A planar domain bounded by closed polylines read from a file (OBJ `l` records, a text file
//! of x y lines, the boundary edges of a triangle mesh): the exact signed distance to the
//! segments, so that the 2-D mesher takes a drawn or exported outline like any formula, and its
//! corners held as fixed points (seed section 2.5: sharp features are kept by fixed nodes).
//!
//! - Distance and nearest point: a bounding-volume hierarchy over the segments (module `bvh`).
//! - Sign: the even-odd rule, the crossings of a ray to +x counted with exact orientation signs,
//!   so outer boundaries and holes nest by containment whatever their orientation in the file.
//! - Gradient: (p - c) / d with c the nearest point; on the boundary the outward normal of the
//!   segment (at a vertex, of the two segments). So p - d grad d = c: projection onto the input
//!   is exact in one step.
//! - Checks (module `check`): empty input, non-finite coordinates, loops of fewer than three
//!   points, crossing, touching or overlapping segments are refused with [`PolygonError`].
//! - Corners: points where the polyline turns by more than a feature angle
//!   ([`DEFAULT_FEATURE_ANGLE`], the 3-D default), held fixed by the mesher.

mod bvh;
mod check;
pub mod read;
pub(crate) mod segment;

pub use super::trisurf::DEFAULT_FEATURE_ANGLE;
pub use bvh::NearestSegment;
pub use check::PolygonError;

use super::Implicit2;
use crate::mesher::{Options2, SizeFn2};
use crate::Error;
use glam::DVec2;
use std::path::Path;

/// Closed, non-crossing polylines as a signed-distance geometry (negative inside by the
/// even-odd rule). Build it with [`Polygons2::new`] from arrays or [`Polygons2::read`] from a
/// file.
#[derive(Clone, Debug)]
pub struct Polygons2 {
    /// The loops, without a repeated closing point and without consecutive duplicates.
    loops: Vec<Vec<DVec2>>,
    /// The segments, loop after loop.
    segs: Vec<[DVec2; 2]>,
    /// Each segment's loop and index within it.
    ids: Vec<(u32, u32)>,
    /// Per loop: whether the domain lies left of its segments (a counter-clockwise outer
    /// boundary, a clockwise hole).
    inside_left: Vec<bool>,
    /// Per loop: whether some other loops' count containing it is odd (a hole).
    hole: Vec<bool>,
    bvh: bvh::SegmentBvh,
    bbox: [DVec2; 2],
    /// Below this distance from the boundary the gradient is the boundary's normal.
    tiny: f64,
}

impl Polygons2 {
    /// Checks and indexes closed polylines (each a list of points; the last joins the first, and
    /// a repeated first point at the end is dropped, as are consecutive duplicates). Errors:
    /// [`PolygonError`].
    pub fn new(loops: Vec<Vec<[f64; 2]>>) -> Result<Polygons2, Error> {
        let mut clean: Vec<Vec<DVec2>> = Vec::with_capacity(loops.len());
        for (l, pts) in loops.iter().enumerate() {
            if let Some((k, p)) = pts.iter().enumerate().find(|(_, p)| !(p[0].is_finite() && p[1].is_finite())) {
                return Err(PolygonError::NonFinite { polyline: l, point: k, at: *p }.into());
            }
            let mut c: Vec<DVec2> = Vec::with_capacity(pts.len());
            for p in pts {
                // -0 and 0 alike.
                let q = DVec2::new(p[0] + 0.0, p[1] + 0.0);
                if c.last() != Some(&q) {
                    c.push(q);
                }
            }
            while c.len() > 1 && c.first() == c.last() {
                c.pop();
            }
            if c.len() < 3 {
                let at = pts.first().copied().unwrap_or([f64::NAN; 2]);
                return Err(PolygonError::TooFewPoints { polyline: l, count: c.len(), at }.into());
            }
            clean.push(c);
        }
        if clean.is_empty() {
            return Err(PolygonError::Empty.into());
        }
        let mut segs = Vec::new();
        let mut ids = Vec::new();
        for (l, c) in clean.iter().enumerate() {
            for k in 0..c.len() {
                segs.push([c[k], c[(k + 1) % c.len()]]);
                ids.push((l as u32, k as u32));
            }
        }
        let bvh = bvh::SegmentBvh::new(&segs);
        let len: Vec<usize> = clean.iter().map(Vec::len).collect();
        if let Some(e) = check::first_crossing(&segs, &ids, &len, &bvh) {
            return Err(e.into());
        }
        // Nesting by containment: a loop inside an odd number of others is a hole.
        let hole: Vec<bool> =
            (0..clean.len()).map(|l| bvh.odd_crossings(clean[l][0], |s| ids[s].0 as usize != l)).collect();
        let inside_left = (0..clean.len()).map(|l| (signed_area(&clean[l]) > 0.0) != hole[l]).collect();
        let (lo, hi) = clean
            .iter()
            .flatten()
            .fold((DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)), |(l, h), &p| (l.min(p), h.max(p)));
        let tiny = 1e-12 * (hi - lo).length().max(f64::MIN_POSITIVE);
        Ok(Polygons2 { loops: clean, segs, ids, inside_left, hole, bvh, bbox: [lo, hi], tiny })
    }

    /// Reads and checks a polyline file: .obj (`v` and `l` records, or the boundary of its
    /// faces), .txt .xy .dat .csv (x y per line, loops separated by blank lines), or the
    /// boundary edges of a triangle mesh (.msh .vtu .mesh .json). See [`read`].
    pub fn read(path: &Path) -> Result<Polygons2, Error> {
        Polygons2::new(read::read_loops(path)?)
    }

    /// The loops (closing point not repeated).
    pub fn loops(&self) -> &[Vec<DVec2>] {
        &self.loops
    }
    /// The number of segments.
    pub fn num_segments(&self) -> usize {
        self.segs.len()
    }
    /// Whether loop `l` bounds a hole (lies inside an odd number of other loops).
    pub fn is_hole(&self, l: usize) -> bool {
        self.hole[l]
    }
    /// The bounding box of the points: minimum and maximum corner.
    pub fn bbox(&self) -> [DVec2; 2] {
        self.bbox
    }
    /// The enclosed area: outer loops' areas less the holes'.
    pub fn area(&self) -> f64 {
        self.loops.iter().zip(&self.hole).map(|(c, &h)| signed_area(c).abs() * if h { -1.0 } else { 1.0 }).sum()
    }
    /// The total length of the boundary.
    pub fn perimeter(&self) -> f64 {
        self.segs.iter().map(|[a, b]| a.distance(*b)).sum()
    }

    /// The nearest point of the boundary to `p`, through the hierarchy.
    pub fn nearest(&self, p: DVec2) -> NearestSegment {
        self.bvh.nearest(p)
    }

    /// The nearest point by trying every segment: the reference the hierarchy is tested against.
    pub fn nearest_brute_force(&self, p: DVec2) -> NearestSegment {
        let mut best = NearestSegment { point: p, dist2: f64::INFINITY, segment: 0, t: 0.0 };
        for (s, &[a, b]) in self.segs.iter().enumerate() {
            let (q, t) = segment::closest_on_segment(p, a, b);
            let d2 = (p - q).length_squared();
            if d2 < best.dist2 {
                best = NearestSegment { point: q, dist2: d2, segment: s, t };
            }
        }
        best
    }

    /// Whether `p` is inside by the even-odd rule (exact; a point on the boundary may go
    /// either way).
    pub fn contains(&self, p: DVec2) -> bool {
        self.bvh.odd_crossings(p, |_| true)
    }

    /// The even-odd rule by testing every segment: the reference for [`Polygons2::contains`].
    pub fn contains_brute_force(&self, p: DVec2) -> bool {
        self.segs.iter().filter(|[a, b]| segment::crosses_ray(p, *a, *b)).count() % 2 == 1
    }

    /// The outward unit normal of segment `s`.
    fn outward(&self, s: usize) -> DVec2 {
        let [a, b] = self.segs[s];
        let e = (b - a).normalize();
        let right = DVec2::new(e.y, -e.x);
        if self.inside_left[self.ids[s].0 as usize] {
            right
        } else {
            -right
        }
    }

    /// The segment before `s` in its loop.
    fn previous(&self, s: usize) -> usize {
        let (l, k) = self.ids[s];
        if k == 0 {
            s + self.loops[l as usize].len() - 1
        } else {
            s - 1
        }
    }

    /// The segment after `s` in its loop.
    fn following(&self, s: usize) -> usize {
        let (l, k) = self.ids[s];
        if k as usize + 1 == self.loops[l as usize].len() {
            s + 1 - self.loops[l as usize].len()
        } else {
            s + 1
        }
    }

    /// The signed distance and its gradient at `p`, from one nearest-point query and one ray.
    pub fn distance_and_gradient(&self, p: DVec2) -> (f64, DVec2) {
        let n = self.nearest(p);
        let len = n.dist2.sqrt();
        if len <= self.tiny {
            let s = n.segment;
            let g = if n.t == 0.0 {
                self.outward(s) + self.outward(self.previous(s))
            } else if n.t == 1.0 {
                self.outward(s) + self.outward(self.following(s))
            } else {
                self.outward(s)
            };
            let g = g.try_normalize().unwrap_or(self.outward(s));
            let d = if self.contains(p) { -len } else { len };
            return (d, g);
        }
        let d = if self.contains(p) { -len } else { len };
        (d, (p - n.point) / d)
    }

    /// The signed distance at `p`: negative inside.
    pub fn signed_distance(&self, p: DVec2) -> f64 {
        let len = self.nearest(p).dist2.sqrt();
        if self.contains(p) {
            -len
        } else {
            len
        }
    }

    /// The corners: points where the boundary turns by more than `angle_deg` degrees (the
    /// angle between the incoming and the outgoing segment's directions), loop by loop in
    /// file order. A smooth curve sampled with n segments a turn turns 360/n degrees at each
    /// point: none of its points is a corner at the default 40 degrees from n = 10 on.
    pub fn corners(&self, angle_deg: f64) -> Vec<DVec2> {
        let cos_max = angle_deg.to_radians().cos();
        let mut out = Vec::new();
        for c in &self.loops {
            let n = c.len();
            for k in 0..n {
                let (u, v, w) = (c[(k + n - 1) % n], c[k], c[(k + 1) % n]);
                let (e1, e2) = ((v - u).normalize(), (w - v).normalize());
                if e1.dot(e2) < cos_max {
                    out.push(v);
                }
            }
        }
        out
    }

    /// The bounding box grown by max(h0, 1e-3 of its diagonal) on every side.
    pub fn padded_box(&self, h0: f64) -> [DVec2; 2] {
        let [lo, hi] = self.bbox;
        let pad = DVec2::splat(h0.max(1e-3 * (hi - lo).length()));
        [lo - pad, hi + pad]
    }

    /// Options of [`crate::mesh_2d`] for this domain: the padded box, relative sizes `size`
    /// (None: uniform), and with `feature_angle` Some(deg) the [`Polygons2::corners`] at that
    /// angle held fixed in place of the mesher's own search for corners from d; with None no
    /// corner is held.
    pub fn options(&self, h0: f64, size: Option<SizeFn2>, feature_angle: Option<f64>) -> Options2 {
        let [lo, hi] = self.padded_box(h0);
        let mut o = Options2::uniform(h0, lo, hi).with_sharp_corners(false);
        if let Some(a) = feature_angle {
            o = o.with_fixed(self.corners(a));
        }
        o.size = size;
        o
    }
}

/// The signed area of a closed loop (shoelace), positive when counter-clockwise.
fn signed_area(c: &[DVec2]) -> f64 {
    let n = c.len();
    let o = c[0];
    0.5 * (0..n).map(|k| (c[k] - o).perp_dot(c[(k + 1) % n] - o)).sum::<f64>()
}

impl Implicit2 for Polygons2 {
    fn value(&self, p: DVec2) -> f64 {
        self.signed_distance(p)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        self.distance_and_gradient(p).1
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
}
