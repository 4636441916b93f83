//! Python functions as geometries: values sampled in batches on a Cartesian grid (one call of
//! the Python function per slab of grid nodes, before the run), interpolated by cubic
//! convolution (Catmull-Rom: C1, third order) while the mesher runs without the GIL.
//!
//! The library asks for d and h one point at a time, from many threads; a Python call per point
//! would cost microseconds each and serialise the run on the GIL. Sampled once, the geometry is
//! a plain Rust function again.
//!
//! Inside the grid (one node in from its border, where the 4-point stencils fit) the value is
//! the interpolant; outside it is continued as `v(c) + |grad v(c)| |p - c|` from the nearest
//! point `c` of that region, so it keeps rising away from the data. Interpolation rounds a kink
//! of d (a corner) within two grid cells; at the given fixed points, which sit on such corners,
//! a bump of radius two cells restores the exact value, so that they are on d = 0 as given.

use std::collections::HashMap;

use trussmesh::glam::{DVec2, DVec3};

/// Catmull-Rom weights of the nodes -1, 0, 1, 2 at t in [0, 1], and their derivatives.
#[inline(always)]
fn weights(t: f64) -> ([f64; 4], [f64; 4]) {
    let t2 = t * t;
    let t3 = t2 * t;
    (
        [
            0.5 * (-t3 + 2.0 * t2 - t),
            0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
            0.5 * (-3.0 * t3 + 4.0 * t2 + t),
            0.5 * (t3 - t2),
        ],
        [
            0.5 * (-3.0 * t2 + 4.0 * t - 1.0),
            0.5 * (9.0 * t2 - 10.0 * t),
            0.5 * (-9.0 * t2 + 8.0 * t + 1.0),
            0.5 * (3.0 * t2 - 2.0 * t),
        ],
    )
}

/// The Catmull-Rom weights alone.
#[inline(always)]
fn values_only(t: f64) -> [f64; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [0.5 * (-t3 + 2.0 * t2 - t), 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0), 0.5 * (-3.0 * t3 + 4.0 * t2 + t), 0.5 * (t3 - t2)]
}

/// One axis: `n` nodes from `origin` at spacing `h`. Interpolation is defined on
/// [origin + h, origin + (n - 2) h].
#[derive(Clone, Copy, Debug)]
struct Axis {
    origin: f64,
    h: f64,
    n: usize,
}

impl Axis {
    fn lo(&self) -> f64 {
        self.origin + self.h
    }
    fn hi(&self) -> f64 {
        self.origin + (self.n - 2) as f64 * self.h
    }
    /// The cell (index of its node 0, from 1 to n - 3) and the local coordinate of `x`, which
    /// must lie in [lo, hi].
    #[inline(always)]
    fn cell(&self, x: f64) -> (usize, f64) {
        let u = (x - self.origin) / self.h;
        let i = (u.floor() as isize).clamp(1, self.n as isize - 3) as usize;
        (i, u - i as f64)
    }
}

/// Exact values at chosen points (the fixed points): `value` is added within `radius` of `at`
/// with the weight (1 - r^2 / radius^2)^2.
#[derive(Clone, Debug)]
struct Bump<P> {
    at: P,
    delta: f64,
}

/// Bumps found by cell: each bump is listed in every cell of side `radius` its disc touches.
#[derive(Clone, Debug, Default)]
struct Bumps<P> {
    radius: f64,
    all: Vec<Bump<P>>,
    /// Used when there are many bumps.
    cells: HashMap<[i64; 3], Vec<u32>>,
}

/// Below this many bumps they are scanned; above, looked up by cell.
const SCAN_BUMPS: usize = 16;

fn cell_key(c: &[f64], radius: f64) -> [i64; 3] {
    let mut k = [0i64; 3];
    for (i, x) in c.iter().enumerate() {
        k[i] = (x / radius).floor() as i64;
    }
    k
}

/// Bump weight and its derivative with respect to r^2.
#[inline]
fn bump_weight(r2: f64, radius: f64) -> (f64, f64) {
    let s = 1.0 - r2 / (radius * radius);
    (s * s, -2.0 * s / (radius * radius))
}

/// A 2-D function sampled on a grid: `values[i + nx * j]` at `origin + h (i, j)`.
#[derive(Clone, Debug)]
pub struct Grid2 {
    ax: [Axis; 2],
    values: Vec<f64>,
    bumps: Bumps<DVec2>,
    /// Gradients shorter than this are returned as zero (see [`tiny_slope`]).
    tiny: f64,
}

impl Grid2 {
    /// Needs at least 4 nodes per axis, a positive spacing and `nx ny` finite values.
    pub fn new(origin: [f64; 2], h: f64, nx: usize, ny: usize, values: Vec<f64>) -> Result<Self, String> {
        check(&origin, h, &[nx, ny], &values)?;
        let tiny = tiny_slope(&values, h);
        Ok(Grid2 {
            ax: [Axis { origin: origin[0], h, n: nx }, Axis { origin: origin[1], h, n: ny }],
            values,
            bumps: Bumps::default(),
            tiny,
        })
    }

    /// The grid spacing.
    pub fn spacing(&self) -> f64 {
        self.ax[0].h
    }

    /// Makes the interpolant take the value `exact[k]` at `points[k]` (bumps of radius two cells).
    pub fn pin(&mut self, points: &[DVec2], exact: &[f64]) {
        let radius = 2.0 * self.ax[0].h;
        let mut all = Vec::new();
        for (&p, &v) in points.iter().zip(exact) {
            let (now, _) = self.eval(p);
            all.push(Bump { at: p, delta: v - now });
        }
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        if all.len() > SCAN_BUMPS {
            for (k, b) in all.iter().enumerate() {
                let base = cell_key(&[b.at.x, b.at.y], radius);
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        cells.entry([base[0] + dx, base[1] + dy, 0]).or_default().push(k as u32);
                    }
                }
            }
        }
        self.bumps = Bumps { radius, all, cells };
    }

    /// The interpolant on its region, without bumps.
    #[inline]
    fn interp(&self, p: DVec2) -> (f64, DVec2) {
        let (i, s) = self.ax[0].cell(p.x);
        let (j, t) = self.ax[1].cell(p.y);
        let (wx, dx) = weights(s);
        let (wy, dy) = weights(t);
        let nx = self.ax[0].n;
        let mut v = 0.0;
        let mut gx = 0.0;
        let mut gy = 0.0;
        for (b, (&wyb, &dyb)) in wy.iter().zip(&dy).enumerate() {
            let row = &self.values[(j + b - 1) * nx + i - 1..(j + b - 1) * nx + i + 3];
            let (mut r, mut rd) = (0.0, 0.0);
            for a in 0..4 {
                r += wx[a] * row[a];
                rd += dx[a] * row[a];
            }
            v += wyb * r;
            gx += wyb * rd;
            gy += dyb * r;
        }
        (v, DVec2::new(gx, gy) / self.ax[0].h)
    }

    /// The interpolant's value alone on its region (half the work of [`Grid2::interp`]).
    #[inline]
    fn interp_value(&self, p: DVec2) -> f64 {
        let (i, s) = self.ax[0].cell(p.x);
        let (j, t) = self.ax[1].cell(p.y);
        let wx = values_only(s);
        let wy = values_only(t);
        let nx = self.ax[0].n;
        let mut v = 0.0;
        for (b, &wyb) in wy.iter().enumerate() {
            let start = (j + b - 1) * nx + i - 1;
            let row = &self.values[start..start + 4];
            v += wyb * (wx[0] * row[0] + wx[1] * row[1] + wx[2] * row[2] + wx[3] * row[3]);
        }
        v
    }

    /// The value at any point (as [`Grid2::eval`]'s).
    #[inline]
    pub fn value(&self, p: DVec2) -> f64 {
        let lo = DVec2::new(self.ax[0].lo(), self.ax[1].lo());
        let hi = DVec2::new(self.ax[0].hi(), self.ax[1].hi());
        let c = p.clamp(lo, hi);
        if c != p || !self.bumps.all.is_empty() {
            return self.eval(p).0;
        }
        self.interp_value(p)
    }

    /// Value and gradient at any point.
    #[inline]
    pub fn eval(&self, p: DVec2) -> (f64, DVec2) {
        let lo = DVec2::new(self.ax[0].lo(), self.ax[1].lo());
        let hi = DVec2::new(self.ax[0].hi(), self.ax[1].hi());
        let c = p.clamp(lo, hi);
        let (mut v, mut g) = self.interp(c);
        if !self.bumps.all.is_empty() {
            self.add_bumps(c, &mut v, &mut g);
        }
        if c != p {
            let e = p - c;
            let len = e.length();
            let slope = g.length();
            let slope = if slope > 0.0 && slope.is_finite() { slope } else { 1.0 };
            v += slope * len;
            // Along a clamped axis the continuation's slope replaces the interpolant's.
            let n = e * (slope / len);
            if e.x != 0.0 {
                g.x = n.x;
            }
            if e.y != 0.0 {
                g.y = n.y;
            }
        }
        if g.length() < self.tiny {
            g = DVec2::ZERO;
        }
        (v, g)
    }

    fn add_bumps(&self, p: DVec2, v: &mut f64, g: &mut DVec2) {
        let b = &self.bumps;
        let mut one = |k: &Bump<DVec2>| {
            let e = p - k.at;
            let r2 = e.length_squared();
            if r2 < b.radius * b.radius {
                let (w, dw) = bump_weight(r2, b.radius);
                *v += k.delta * w;
                *g += k.delta * dw * 2.0 * e;
            }
        };
        if b.cells.is_empty() {
            b.all.iter().for_each(&mut one);
        } else if let Some(list) = b.cells.get(&cell_key(&[p.x, p.y], b.radius)) {
            list.iter().for_each(|&k| one(&b.all[k as usize]));
        }
    }
}

/// A 3-D function sampled on a grid: `values[i + nx (j + ny k)]` at `origin + h (i, j, k)`.
#[derive(Clone, Debug)]
pub struct Grid3 {
    ax: [Axis; 3],
    values: Vec<f64>,
    bumps: Bumps<DVec3>,
    /// Gradients shorter than this are returned as zero (see [`tiny_slope`]).
    tiny: f64,
}

impl Grid3 {
    /// Needs at least 4 nodes per axis, a positive spacing and `nx ny nz` finite values.
    pub fn new(origin: [f64; 3], h: f64, n: [usize; 3], values: Vec<f64>) -> Result<Self, String> {
        check(&origin, h, &n, &values)?;
        let tiny = tiny_slope(&values, h);
        Ok(Grid3 {
            ax: [
                Axis { origin: origin[0], h, n: n[0] },
                Axis { origin: origin[1], h, n: n[1] },
                Axis { origin: origin[2], h, n: n[2] },
            ],
            values,
            bumps: Bumps::default(),
            tiny,
        })
    }

    /// The grid spacing.
    pub fn spacing(&self) -> f64 {
        self.ax[0].h
    }

    /// Makes the interpolant take the value `exact[k]` at `points[k]` (bumps of radius two cells).
    pub fn pin(&mut self, points: &[DVec3], exact: &[f64]) {
        let radius = 2.0 * self.ax[0].h;
        let mut all = Vec::new();
        for (&p, &v) in points.iter().zip(exact) {
            let (now, _) = self.eval(p);
            all.push(Bump { at: p, delta: v - now });
        }
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        if all.len() > SCAN_BUMPS {
            for (k, b) in all.iter().enumerate() {
                let base = cell_key(&b.at.to_array(), radius);
                for dz in -1..=1 {
                    for dy in -1..=1 {
                        for dx in -1..=1 {
                            cells.entry([base[0] + dx, base[1] + dy, base[2] + dz]).or_default().push(k as u32);
                        }
                    }
                }
            }
        }
        self.bumps = Bumps { radius, all, cells };
    }

    #[inline]
    fn interp(&self, p: DVec3) -> (f64, DVec3) {
        let (i, s) = self.ax[0].cell(p.x);
        let (j, t) = self.ax[1].cell(p.y);
        let (k, u) = self.ax[2].cell(p.z);
        let (wx, dx) = weights(s);
        let (wy, dy) = weights(t);
        let (wz, dz) = weights(u);
        let (nx, ny) = (self.ax[0].n, self.ax[1].n);
        let mut v = 0.0;
        let mut g = DVec3::ZERO;
        for c in 0..4 {
            // The plane k + c - 1, interpolated in x and y.
            let (mut pv, mut px, mut py) = (0.0, 0.0, 0.0);
            for b in 0..4 {
                let start = ((k + c - 1) * ny + j + b - 1) * nx + i - 1;
                let row = &self.values[start..start + 4];
                let (mut r, mut rd) = (0.0, 0.0);
                for a in 0..4 {
                    r += wx[a] * row[a];
                    rd += dx[a] * row[a];
                }
                pv += wy[b] * r;
                px += wy[b] * rd;
                py += dy[b] * r;
            }
            v += wz[c] * pv;
            g += DVec3::new(wz[c] * px, wz[c] * py, dz[c] * pv);
        }
        (v, g / self.ax[0].h)
    }

    #[inline]
    fn interp_value(&self, p: DVec3) -> f64 {
        let (i, s) = self.ax[0].cell(p.x);
        let (j, t) = self.ax[1].cell(p.y);
        let (k, u) = self.ax[2].cell(p.z);
        let (wx, wy, wz) = (values_only(s), values_only(t), values_only(u));
        let (nx, ny) = (self.ax[0].n, self.ax[1].n);
        let mut v = 0.0;
        for (c, &wzc) in wz.iter().enumerate() {
            let mut pv = 0.0;
            for (b, &wyb) in wy.iter().enumerate() {
                let start = ((k + c - 1) * ny + j + b - 1) * nx + i - 1;
                let row = &self.values[start..start + 4];
                pv += wyb * (wx[0] * row[0] + wx[1] * row[1] + wx[2] * row[2] + wx[3] * row[3]);
            }
            v += wzc * pv;
        }
        v
    }

    /// The value at any point (as [`Grid3::eval`]'s).
    #[inline]
    pub fn value(&self, p: DVec3) -> f64 {
        let lo = DVec3::new(self.ax[0].lo(), self.ax[1].lo(), self.ax[2].lo());
        let hi = DVec3::new(self.ax[0].hi(), self.ax[1].hi(), self.ax[2].hi());
        let c = p.clamp(lo, hi);
        if c != p || !self.bumps.all.is_empty() {
            return self.eval(p).0;
        }
        self.interp_value(p)
    }

    /// Value and gradient at any point.
    #[inline]
    pub fn eval(&self, p: DVec3) -> (f64, DVec3) {
        let lo = DVec3::new(self.ax[0].lo(), self.ax[1].lo(), self.ax[2].lo());
        let hi = DVec3::new(self.ax[0].hi(), self.ax[1].hi(), self.ax[2].hi());
        let c = p.clamp(lo, hi);
        let (mut v, mut g) = self.interp(c);
        if !self.bumps.all.is_empty() {
            self.add_bumps(c, &mut v, &mut g);
        }
        if c != p {
            let e = p - c;
            let len = e.length();
            let slope = g.length();
            let slope = if slope > 0.0 && slope.is_finite() { slope } else { 1.0 };
            v += slope * len;
            let n = e * (slope / len);
            for a in 0..3 {
                if e[a] != 0.0 {
                    g[a] = n[a];
                }
            }
        }
        if g.length() < self.tiny {
            g = DVec3::ZERO;
        }
        (v, g)
    }

    fn add_bumps(&self, p: DVec3, v: &mut f64, g: &mut DVec3) {
        let b = &self.bumps;
        let mut one = |k: &Bump<DVec3>| {
            let e = p - k.at;
            let r2 = e.length_squared();
            if r2 < b.radius * b.radius {
                let (w, dw) = bump_weight(r2, b.radius);
                *v += k.delta * w;
                *g += k.delta * dw * 2.0 * e;
            }
        };
        if b.cells.is_empty() {
            b.all.iter().for_each(&mut one);
        } else if let Some(list) = b.cells.get(&cell_key(&p.to_array(), b.radius)) {
            list.iter().for_each(|&k| one(&b.all[k as usize]));
        }
    }
}

/// The length below which a gradient of the interpolant is round-off: 1e-10 of the largest
/// slope between neighbouring samples. At a symmetric critical point (the centre of a level set
/// such as (x^4 + y^4)^(1/4)) interpolation leaves a gradient of 1e-17 instead of zero, and
/// the meshers' approximate distance d / |grad d| would then call the point infinitely far
/// outside; a zero gradient makes them fall back to d.
fn tiny_slope(values: &[f64], h: f64) -> f64 {
    let max = values.windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
    1e-10 * max / h
}

fn check(origin: &[f64], h: f64, n: &[usize], values: &[f64]) -> Result<(), String> {
    if !(h > 0.0 && h.is_finite()) {
        return Err(format!("grid spacing {h} is not positive and finite"));
    }
    if origin.iter().any(|x| !x.is_finite()) {
        return Err(format!("grid origin {origin:?} is not finite"));
    }
    if n.iter().any(|&k| k < 4) {
        return Err(format!("grid of {n:?} nodes: need at least 4 per axis"));
    }
    let total = n.iter().try_fold(1usize, |a, &k| a.checked_mul(k));
    if total != Some(values.len()) {
        return Err(format!("grid of {n:?} nodes given {} values", values.len()));
    }
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!("grid value {} at node {k} is not finite", values[k]));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample2(f: impl Fn(DVec2) -> f64, lo: [f64; 2], h: f64, nx: usize, ny: usize) -> Grid2 {
        let mut v = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                v.push(f(DVec2::new(lo[0] + i as f64 * h, lo[1] + j as f64 * h)));
            }
        }
        Grid2::new(lo, h, nx, ny, v).unwrap()
    }

    #[test]
    fn reproduces_quadratics_closely_and_nodes_exactly() {
        let f = |p: DVec2| p.x * p.x - 0.5 * p.x * p.y + 0.25 * p.y;
        let g = sample2(f, [-1.0, -1.0], 0.1, 21, 21);
        // Nodes exactly.
        let (v, _) = g.eval(DVec2::new(0.3, -0.2));
        assert!((v - f(DVec2::new(0.3, -0.2))).abs() < 1e-12);
        // Off nodes: Catmull-Rom is exact for quadratics.
        let p = DVec2::new(0.123, 0.456);
        let (v, gr) = g.eval(p);
        assert!((v - f(p)).abs() < 1e-12, "{v} vs {}", f(p));
        let exact = DVec2::new(2.0 * p.x - 0.5 * p.y, -0.5 * p.x + 0.25);
        assert!((gr - exact).length() < 1e-10, "{gr} vs {exact}");
    }

    #[test]
    fn continues_outside_and_pins_points() {
        let f = |p: DVec2| p.length() - 1.0;
        let mut g = sample2(f, [-1.5, -1.5], 0.05, 61, 61);
        let (v, gr) = g.eval(DVec2::new(3.0, 0.0));
        assert!(v > 1.9 && v < 2.1, "{v}");
        assert!(gr.x > 0.9, "{gr}");
        let q = DVec2::new(0.6, 0.8);
        g.pin(&[q], &[0.25]);
        assert!((g.eval(q).0 - 0.25).abs() < 1e-12);
        // Beyond two cells the bump has no effect.
        let far = DVec2::new(0.0, 1.0);
        assert!((g.eval(far).0 - f(far)).abs() < 1e-5);
    }

    #[test]
    fn tricubic_matches_a_sphere() {
        let h = 0.05;
        let n = 61;
        let mut v = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = DVec3::new(-1.5 + i as f64 * h, -1.5 + j as f64 * h, -1.5 + k as f64 * h);
                    v.push(p.length() - 1.0);
                }
            }
        }
        let g = Grid3::new([-1.5; 3], h, [n; 3], v).unwrap();
        let p = DVec3::new(0.31, -0.52, 0.77);
        let (val, gr) = g.eval(p);
        assert!((val - (p.length() - 1.0)).abs() < 1e-5, "{val}");
        assert!((gr - p.normalize()).length() < 1e-3, "{gr}");
    }
}
