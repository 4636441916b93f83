//! Sharp features of the input: edges whose two triangles' normals differ by more than the
//! feature angle, corners where three or more such edges meet (or one ends, or a chain of them
//! turns by more than the feature angle), and the chains of feature edges between corners.

use super::creases::{smooth_tangent_at, CurveSegment, PIN_GAP};
use super::TriSurface;
use glam::DVec3;

/// The default feature angle in degrees: the same threshold at which the 3-D mesher calls the
/// normals on either side of an implicit domain's edge sharp, so that a box read from a file and
/// the same box written as a formula keep the same edges. A smooth surface triangulated with
/// about 10 triangles around a quarter circle turns about 9 degrees per edge, far below it.
pub const DEFAULT_FEATURE_ANGLE: f64 = 40.0;

/// The smallest turn (degrees) of a coarse crease that [`TriSurface::features_resolved`] holds.
pub const COARSE_TURN_DEG: f64 = 12.0;

/// The least width across a coarse crease of each of its two triangles, in mesh sizes. Walls
/// narrower than this meshed well unheld in the prism family (n-gons of 8 to 24 sides at h0
/// 0.06 to 0.1), while holding their creases lowered the mean radius ratio by up to 0.04; wider
/// walls, unheld, gave flat tetrahedra and self-crossing boundaries.
pub const COARSE_WIDTH: f64 = 1.5;

/// The sharp features of a surface at one feature angle. Indices are the surface's vertices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Features {
    /// The feature angle, degrees.
    pub angle: f64,
    /// The feature edges (lower vertex first), sorted.
    pub edges: Vec<[usize; 2]>,
    /// The corners, sorted.
    pub corners: Vec<usize>,
    /// The feature curves: chains of feature edges from corner to corner, or closed loops
    /// (first vertex repeated at the end).
    pub curves: Vec<Vec<usize>>,
}

impl TriSurface {
    /// The sharp features at `angle_deg` degrees (see [`Features`]).
    pub fn features(&self, angle_deg: f64) -> Features {
        self.features_resolved(angle_deg, None)
    }

    /// The sharp features at `angle_deg` degrees, and with `spacing` Some(h(p)) also the coarse
    /// creases a mesh of that edge length resolves: edges turning by more than
    /// [`COARSE_TURN_DEG`], at least `h` long, between two triangles each at least
    /// [`COARSE_WIDTH`] `h` wide across the edge (the walls of a cylinder a CAD export
    /// tessellates with sides longer than the mesh size). A mesher that treats such a crease as
    /// smooth projects every boundary node in the crease's outer wedge onto the crease line,
    /// where nearly collinear nodes make flat tetrahedra; held as a feature, the crease gets
    /// evenly spaced nodes instead. Creases of a fine tessellation (edges or triangles shorter
    /// than h) stay smooth, whatever their turn, so that noise is never taken for a feature.
    ///
    /// With `spacing`, an edge sharp at `angle_deg` counts only where it parts two of the smooth
    /// patches that the surface mesher labels at the smallest spacing at a vertex (patches
    /// narrower than a quarter of it merged, see [`Creases`](crate::geometry::Creases)): on a
    /// noisy scan the edges that turn past the angle are short and scattered, bound no patch,
    /// and held as fixed points they would pin the mesh at points closer than its edges.
    pub fn features_resolved(&self, angle_deg: f64, spacing: Option<&dyn Fn(DVec3) -> f64>) -> Features {
        let cos_max = angle_deg.to_radians().cos();
        let p = &self.points;
        let patches = spacing.map(|h| {
            let hmin = p.iter().map(|&x| h(x)).filter(|v| *v > 0.0 && v.is_finite()).fold(f64::INFINITY, f64::min);
            super::creases::CreaseData::new(self, angle_deg, hmin.is_finite().then_some(hmin)).map(|d| d.patch)
        });
        // Whether triangles t and w lie in different patches (always, without a spacing).
        let parted = |t: usize, w: usize| match &patches {
            None => true,
            Some(None) => false,
            Some(Some(patch)) => patch[t] != patch[w],
        };
        let mut edges = Vec::new();
        for (t, tri) in self.tris.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let w = self.neighbors[t][k];
                // Each edge once, from the lower-numbered triangle.
                if w < t {
                    continue;
                }
                let cos = self.normals.face(t).dot(self.normals.face(w));
                let coarse = || spacing.is_some_and(|h| self.coarse_crease(t, k, h((p[a] + p[b]) * 0.5)));
                if (cos < cos_max && parted(t, w)) || coarse() {
                    edges.push([a.min(b), a.max(b)]);
                }
            }
        }
        edges.sort_unstable();
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); self.points.len()];
        for &[a, b] in &edges {
            adj[a].push(b);
            adj[b].push(a);
        }
        for list in &mut adj {
            list.sort_unstable();
        }
        let corner = |v: usize, adj: &[Vec<usize>]| match adj[v].len() {
            0 => false,
            2 => {
                let (d1, d2) = (p[adj[v][0]] - p[v], p[v] - p[adj[v][1]]);
                d1.normalize_or_zero().dot(d2.normalize_or_zero()) < cos_max
            }
            _ => true,
        };
        let is_corner: Vec<bool> = (0..p.len()).map(|v| corner(v, &adj)).collect();
        let corners: Vec<usize> = (0..p.len()).filter(|&v| is_corner[v]).collect();
        // Walk the chains: from each corner along each of its edges, then the closed loops.
        let mut used = std::collections::HashSet::new();
        let mut curves = Vec::new();
        let walk = |start: usize, next: usize, used: &mut std::collections::HashSet<[usize; 2]>| {
            let mut curve = vec![start];
            let (mut prev, mut cur) = (start, next);
            used.insert([prev.min(cur), prev.max(cur)]);
            loop {
                curve.push(cur);
                if is_corner[cur] || cur == start {
                    break;
                }
                let Some(&n) = adj[cur].iter().find(|&&n| n != prev && !used.contains(&[cur.min(n), cur.max(n)]))
                else {
                    break;
                };
                used.insert([cur.min(n), cur.max(n)]);
                (prev, cur) = (cur, n);
            }
            curve
        };
        for &c in &corners {
            for &n in &adj[c] {
                if !used.contains(&[c.min(n), c.max(n)]) {
                    curves.push(walk(c, n, &mut used));
                }
            }
        }
        for &[a, b] in &edges {
            if !used.contains(&[a, b]) {
                curves.push(walk(a, b, &mut used));
            }
        }
        Features { angle: angle_deg, edges, corners, curves }
    }
}

/// Triangles whose normals differ by less than this (degrees) lie in one flat facet.
const FLAT_DEG: f64 = 1.0;

impl TriSurface {
    /// Whether the edge `k` of triangle `t` is a coarse crease at mesh size `h` (see
    /// [`TriSurface::features_resolved`]).
    fn coarse_crease(&self, t: usize, k: usize, h: f64) -> bool {
        let p = &self.points;
        let w = self.neighbors[t][k];
        // The height of triangle `t` over its edge `k`.
        let height = |t: usize, k: usize| {
            let tri = self.tris[t];
            let (a, b, c) = (p[tri[k]], p[tri[(k + 1) % 3]], p[tri[(k + 2) % 3]]);
            let len = a.distance(b);
            if len > 0.0 {
                (b - a).cross(c - a).length() / len
            } else {
                0.0
            }
        };
        let (a, b) = (p[self.tris[t][k]], p[self.tris[t][(k + 1) % 3]]);
        h > 0.0
            && self.normals.face(t).dot(self.normals.face(w)) < COARSE_TURN_DEG.to_radians().cos()
            && a.distance(b) >= h
            && height(t, k) >= COARSE_WIDTH * h
            && (0..3).find(|&j| self.neighbors[w][j] == t).is_some_and(|j| height(w, j) >= COARSE_WIDTH * h)
    }

    /// The width of the flat facet across the edge `k` of triangle `t` at `q` (a point of that
    /// edge): the length of the segment from `q` into `t`, perpendicular to the edge in the
    /// facet's plane, until it leaves the facet (crosses an edge that turns by more than
    /// FLAT_DEG, or the surface's last triangle); at most `limit`. Walls between parallel
    /// creases are as wide everywhere; the facets of a cone narrow to nothing at its apex.
    pub(super) fn width_across(&self, t: usize, k: usize, q: DVec3, limit: f64) -> f64 {
        let p = &self.points;
        let cos_flat = FLAT_DEG.to_radians().cos();
        let (a, b) = (p[self.tris[t][k]], p[self.tris[t][(k + 1) % 3]]);
        let n = self.normals.face(t);
        let mut d = n.cross(b - a).normalize_or_zero();
        if d.dot(p[self.tris[t][(k + 2) % 3]] - a) < 0.0 {
            d = -d;
        }
        let (mut cur, mut entry, mut x, mut gone) = (t, k, q, 0.0);
        for _ in 0..64 {
            // The exit: the nearer crossing of the ray with the two other edges of `cur`.
            let mut exit: Option<(f64, usize)> = None;
            for e in (0..3).filter(|&e| e != entry) {
                let (u, v) = (p[self.tris[cur][e]], p[self.tris[cur][(e + 1) % 3]]);
                let m = self.normals.face(cur).cross(v - u);
                let dm = d.dot(m);
                if dm.abs() < 1e-300 {
                    continue;
                }
                let sd = (u - x).dot(m) / dm;
                let along = (x + d * sd - u).dot(v - u) / (v - u).length_squared();
                if sd > 0.0 && (-1e-9..=1.0 + 1e-9).contains(&along) && exit.is_none_or(|(s0, _)| sd < s0) {
                    exit = Some((sd, e));
                }
            }
            let Some((sd, e)) = exit else { return gone };
            gone += sd;
            if gone >= limit {
                return limit;
            }
            let w = self.neighbors[cur][e];
            if self.normals.face(cur).dot(self.normals.face(w)) < cos_flat {
                return gone;
            }
            let Some(back) = (0..3).find(|&j| self.neighbors[w][j] == cur) else { return gone };
            (cur, entry, x) = (w, back, x + d * sd);
        }
        gone
    }
}

impl Features {
    /// Points on the feature curves about `spacing(p)` apart (absolute lengths): every corner,
    /// then on each curve points at equal steps of the integral of 1 / spacing along it, the
    /// number of steps rounded (at least one per open curve, three per loop). The points lie on
    /// the input's edges, or, where edges shorter than the spacing turn gently, on the smooth
    /// curve through their vertices that the surface mesher holds too (within about theta s / 8
    /// of the edges for a turn theta and an edge s). A curve point nearer than half the spacing to one
    /// already placed (of another curve) is left out.
    pub fn sample(&self, surface: &TriSurface, spacing: &dyn Fn(DVec3) -> f64) -> Vec<DVec3> {
        self.sample_where(surface, spacing, &|_, _| true)
    }

    /// [`Features::sample`], keeping only the curve points `q` for which `keep(q, [a, b])` holds,
    /// where a-b is the input edge under q (corners are all kept).
    pub fn sample_where(
        &self,
        surface: &TriSurface,
        spacing: &dyn Fn(DVec3) -> f64,
        keep: &dyn Fn(DVec3, [usize; 2]) -> bool,
    ) -> Vec<DVec3> {
        let p = &surface.points;
        let mut out: Vec<DVec3> = self.corners.iter().map(|&c| p[c]).collect();
        for curve in &self.curves {
            let closed = curve.first() == curve.last();
            // Cumulative integral of 1 / spacing, by the midpoint rule per edge.
            let mut acc = vec![0.0];
            for w in curve.windows(2) {
                let (a, b) = (p[w[0]], p[w[1]]);
                let h = spacing((a + b) * 0.5);
                let step = if h > 0.0 && h.is_finite() { a.distance(b) / h } else { 0.0 };
                acc.push(acc.last().copied().unwrap_or(0.0) + step);
            }
            let total = acc.last().copied().unwrap_or(0.0);
            // The curve the points lie on: the input's edges, or the smooth curve through
            // their vertices where finer edges turn gently (as the surface mesher holds it).
            let last = curve.len() - 1;
            let tangent = |k: usize| {
                let prev = if k > 0 { Some(k - 1) } else { closed.then(|| last - 1) };
                let next = if k < last { Some(k + 1) } else { closed.then_some(1) };
                let (a, b) = (prev?, next?);
                let v = p[curve[k]];
                smooth_tangent_at(p[curve[a]], v, p[curve[b]], PIN_GAP * spacing(v))
            };
            let piece = |k: usize| CurveSegment::new(p[curve[k]], p[curve[k + 1]], tangent(k), tangent(k + 1));
            let n = (total.round() as usize).max(if closed { 3 } else { 1 });
            let mut seg = 0;
            let first = out.len();
            // Open curves: their ends are corners, already placed; loops: their start too.
            let range = if closed { 0..n } else { 1..n };
            for i in range {
                let s = total * i as f64 / n as f64;
                while seg + 1 < acc.len() - 1 && acc[seg + 1] < s {
                    seg += 1;
                }
                let (s0, s1) = (acc[seg], acc[seg + 1]);
                let u = if s1 > s0 { ((s - s0) / (s1 - s0)).clamp(0.0, 1.0) } else { 0.0 };
                let q = piece(seg).at(u).0;
                let h = spacing(q);
                if out[..first].iter().any(|o| o.distance(q) < 0.5 * h) || !keep(q, [curve[seg], curve[seg + 1]]) {
                    continue;
                }
                out.push(q);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A prism over a regular n-gon of radius `r` (height 1), or with `apex` a cone of height 1.
    fn polygon_solid(n: usize, r: f64, apex: bool) -> TriSurface {
        let mut pts: Vec<[f64; 3]> = vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let ring = |z: f64| {
            (0..n).map(move |k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                [r * a.cos(), r * a.sin(), z]
            })
        };
        pts.extend(ring(0.0));
        if !apex {
            pts.extend(ring(1.0));
        }
        let mut tris = Vec::new();
        for k in 0..n {
            let (a, b) = (2 + k, 2 + (k + 1) % n);
            tris.push([0, b, a]);
            if apex {
                tris.push([1, a, b]);
            } else {
                let (c, d) = (a + n, b + n);
                tris.extend([[1, c, d], [a, b, d], [a, d, c]]);
            }
        }
        TriSurface::new(pts, tris).expect("closed")
    }

    /// The input vertex at `x`.
    fn at(s: &TriSurface, x: [f64; 3]) -> usize {
        s.points.iter().position(|p| p.distance(DVec3::from_array(x)) < 1e-12).expect("a vertex there")
    }

    /// The two sides (triangle, edge index) of the input edge a-b.
    fn sides(s: &TriSurface, a: usize, b: usize) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for (t, tri) in s.tris.iter().enumerate() {
            for k in 0..3 {
                let (u, v) = (tri[k], tri[(k + 1) % 3]);
                if (u, v) == (a, b) || (u, v) == (b, a) {
                    out.push((t, k));
                }
            }
        }
        assert_eq!(out.len(), 2, "edge {a}-{b}");
        out
    }

    #[test]
    fn a_prism_wall_is_as_wide_everywhere_and_a_cone_facet_narrows() {
        let n = 12;
        let wall = 2.0 * 0.4 * (std::f64::consts::PI / n as f64).sin();
        let prism = polygon_solid(n, 0.4, false);
        // The crease over the ring's first vertex, from both of its sides, at three heights.
        let (lo, hi) = (at(&prism, [0.4, 0.0, 0.0]), at(&prism, [0.4, 0.0, 1.0]));
        let (pl, ph) = (prism.points[lo], prism.points[hi]);
        for (t, k) in sides(&prism, lo, hi) {
            for z in [0.05, 0.5, 0.95] {
                let w = prism.width_across(t, k, pl.lerp(ph, z), 1.0);
                assert!((w - wall).abs() < 1e-12, "wall width {w} vs {wall}");
            }
            // Capped at the limit.
            assert_eq!(prism.width_across(t, k, pl.lerp(ph, 0.5), 0.01), 0.01);
        }
        // A cone's facet: its width across the slant edge falls linearly to zero at the apex
        // (from the foot of the facet's height over that edge, near the base).
        let cone = polygon_solid(n, 0.4, true);
        let (apex, base) = (at(&cone, [0.0, 0.0, 1.0]), at(&cone, [0.4, 0.0, 0.0]));
        let (pa, pb) = (cone.points[apex], cone.points[base]);
        for (t, k) in sides(&cone, apex, base) {
            let width = |s: f64| cone.width_across(t, k, pa.lerp(pb, s), 1.0);
            let full = width(0.9) / 0.9;
            assert!(full > 0.1, "{full}");
            for s in [0.01, 0.25, 0.5, 0.75] {
                assert!((width(s) - s * full).abs() < 1e-9, "width at {s}: {} vs {}", width(s), s * full);
            }
        }
    }

    #[test]
    fn coarse_creases_are_held_only_where_the_mesh_resolves_them() {
        let prism = polygon_solid(12, 0.4, false);
        let wall = 2.0 * 0.4 * (std::f64::consts::PI / 12.0).sin();
        let plain = prism.features(DEFAULT_FEATURE_ANGLE);
        // At h = wall / 2 the 12 wall creases join the 24 rim edges.
        let fine = prism.features_resolved(DEFAULT_FEATURE_ANGLE, Some(&|_| 0.5 * wall));
        assert_eq!((plain.edges.len(), fine.edges.len()), (24, 36));
        assert_eq!(fine.corners.len(), 24);
        // At h = wall the walls are narrower than COARSE_WIDTH h: smooth.
        let coarse = prism.features_resolved(DEFAULT_FEATURE_ANGLE, Some(&|_| wall));
        assert_eq!(coarse.edges, plain.edges);
    }
}
