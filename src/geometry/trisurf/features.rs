//! Sharp features of the input: edges whose two triangles' normals differ by more than the
//! feature angle, corners where three or more such edges meet (or one ends, or a chain of them
//! turns by more than the feature angle), and the chains of feature edges between corners.

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
    pub fn features_resolved(&self, angle_deg: f64, spacing: Option<&dyn Fn(DVec3) -> f64>) -> Features {
        let cos_max = angle_deg.to_radians().cos();
        let p = &self.points;
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
                if cos < cos_max || coarse() {
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
}

impl Features {
    /// Points on the feature curves about `spacing(p)` apart (absolute lengths): every corner,
    /// then on each curve points at equal steps of the integral of 1 / spacing along it, the
    /// number of steps rounded (at least one per open curve, three per loop). Points exactly on
    /// the input's edges, so on the surface. A curve point nearer than half the spacing to one
    /// already placed (of another curve) is left out.
    pub fn sample(&self, surface: &TriSurface, spacing: &dyn Fn(DVec3) -> f64) -> Vec<DVec3> {
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
                let q = p[curve[seg]].lerp(p[curve[seg + 1]], u);
                let h = spacing(q);
                if out[..first].iter().any(|o| o.distance(q) < 0.5 * h) {
                    continue;
                }
                out.push(q);
            }
        }
        out
    }
}
