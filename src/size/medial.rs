//! Medial axis detection with subgrid accuracy (seed Algorithm 4-1) and the local feature size
//! lfs = |phi| + |phi_MA| (seed eq. 4.6).

use super::curvature::kappa2;
use super::march::fast_march_2d;
use crate::geometry::Grid2;
use glam::DVec2;

/// Parameters of Algorithm 4-1, in units of the grid spacing.
#[derive(Clone, Copy, Debug)]
pub struct MedialAxisParams {
    /// Safety factor on the curvatures of the two fronts (the seed's gamma).
    pub gamma: f64,
    /// Smallest curvature considered, per grid spacing (the seed's kappa_tol): fronts meeting
    /// at a smaller angle than a circle of this curvature would give are not a shock.
    pub kappa_tol: f64,
}

impl Default for MedialAxisParams {
    fn default() -> Self {
        MedialAxisParams { gamma: 4.0, kappa_tol: 0.1 }
    }
}

/// Detected medial axis crossings and the seeded distances at grid nodes next to them.
#[derive(Clone, Debug, Default)]
pub struct MedialAxis {
    /// Points where grid edges cross the medial axis (inside the domain, phi < 0).
    pub points: Vec<DVec2>,
    /// Distance from each node to the medial axis where the detection gave one (else infinity).
    pub node_distance: Vec<f64>,
}

struct Candidate {
    i: usize, // position of the edge's first node along the line
    s0: f64,
    strength: f64,
    normal_axis: f64, // |n . e_axis|
}

/// Medial axis of the interior of a signed distance grid by seed Algorithm 4-1: along every
/// grid line, quadratics fitted to phi at s = -2,-1,0 and s = 1,2,3 cross exactly once in
/// s0 in [0, 1] with d(p2 - p1)/ds > 0 on [-2, 3]; the one-sided unit gradients at the edge's
/// nodes must differ more than fronts of curvature max(kappa(i-1), kappa(i+2), kappa_tol) times
/// gamma would (alpha < 1 - gamma^2 kappa^2 / 2, eq. 4.7); the strongest crossing within
/// [-2, 3] wins. The nodes get distances |n_axis| h s0 and |n_axis| h (1 - s0).
pub fn medial_axis_2d(phi: &Grid2, params: &MedialAxisParams) -> MedialAxis {
    let (nx, ny) = phi.dims();
    let h = phi.spacing();
    let v: Vec<f64> = phi.values().iter().map(|p| p / h).collect();
    let mut out = MedialAxis { points: vec![], node_distance: vec![f64::INFINITY; nx * ny] };
    if nx < 6 || ny < 6 {
        return out;
    }
    // Unit-spacing curvature, clamped at the border.
    let kap = |i: usize, j: usize| kappa2(&v, nx, i.clamp(1, nx - 2), j.clamp(1, ny - 2), 1.0);
    for axis in 0..2 {
        let (len, lines) = if axis == 0 { (nx, ny) } else { (ny, nx) };
        // Node index of position t on line l.
        let idx = |l: usize, t: usize| if axis == 0 { t + nx * l } else { l + nx * t };
        let ij = |l: usize, t: usize| if axis == 0 { (t, l) } else { (l, t) };
        let mut cands: Vec<Candidate> = Vec::new();
        for l in 0..lines {
            cands.clear();
            for i in 2..len - 3 {
                let f = |k: isize| v[idx(l, (i as isize + k) as usize)];
                if f(0) >= 0.0 || f(1) >= 0.0 {
                    continue;
                }
                let Some((s0, strength)) = crossing([f(-2), f(-1), f(0)], [f(1), f(2), f(3)]) else {
                    continue;
                };
                // Second-order one-sided gradients at the edge's two nodes, each from its own
                // side only (so a shock inside the edge is not smeared into them).
                let grad = |t: usize, fwd: bool| -> DVec2 {
                    let along = if fwd {
                        -(3.0 * v[idx(l, t)] - 4.0 * v[idx(l, t + 1)] + v[idx(l, t + 2)]) / 2.0
                    } else {
                        (3.0 * v[idx(l, t)] - 4.0 * v[idx(l, t - 1)] + v[idx(l, t - 2)]) / 2.0
                    };
                    let lc = l.clamp(1, lines - 2);
                    let across = 0.5 * (v[idx(lc + 1, t)] - v[idx(lc - 1, t)]);
                    let g = if axis == 0 { DVec2::new(along, across) } else { DVec2::new(across, along) };
                    g.normalize_or_zero()
                };
                let (g1, g2) = (grad(i, false), grad(i + 1, true));
                let alpha = g1.dot(g2);
                let (a1, b1) = ij(l, i - 1);
                let (a2, b2) = ij(l, i + 2);
                let k = kap(a1, b1).abs().max(kap(a2, b2).abs()).max(params.kappa_tol);
                if alpha >= 1.0 - params.gamma * params.gamma * k * k / 2.0 {
                    continue;
                }
                let dn = g1 - g2;
                let n = dn.normalize_or_zero();
                cands.push(Candidate { i, s0, strength, normal_axis: if axis == 0 { n.x.abs() } else { n.y.abs() } });
            }
            for c in &cands {
                let beaten = cands.iter().any(|o| {
                    o.i != c.i
                        && o.i + 2 >= c.i
                        && o.i <= c.i + 2
                        && (o.strength > c.strength || (o.strength == c.strength && o.i < c.i))
                });
                if beaten {
                    continue;
                }
                let (gi, gj) = ij(l, c.i);
                let mut p = phi.origin() + h * DVec2::new(gi as f64, gj as f64);
                p[axis] += h * c.s0;
                out.points.push(p);
                let (n0, n1) = (idx(l, c.i), idx(l, c.i + 1));
                let d0 = c.normal_axis * h * c.s0;
                let d1 = c.normal_axis * h * (1.0 - c.s0);
                out.node_distance[n0] = out.node_distance[n0].min(d0);
                out.node_distance[n1] = out.node_distance[n1].min(d1);
            }
        }
    }
    out
}

/// The crossing of the quadratics through (-2,a0),(-1,a1),(0,a2) and (1,b0),(2,b1),(3,b2):
/// `(s0, d(p2 - p1)/ds at s0)` if it is unique in [0, 1] and the difference increases on [-2, 3].
pub(super) fn crossing(a: [f64; 3], b: [f64; 3]) -> Option<(f64, f64)> {
    // p1(s) = A1 s^2 + B1 s + C1.
    let a1 = 0.5 * (a[0] - 2.0 * a[1] + a[2]);
    let b1 = a1 + a[2] - a[1];
    let c1 = a[2];
    // p2 about s = 2, expanded in s.
    let a2 = 0.5 * (b[0] - 2.0 * b[1] + b[2]);
    let bt = 0.5 * (b[2] - b[0]);
    let b2 = bt - 4.0 * a2;
    let c2 = 4.0 * a2 - 2.0 * bt + b[1];
    let (qa, qb, qc) = (a2 - a1, b2 - b1, c2 - c1);
    let dd = |s: f64| 2.0 * qa * s + qb;
    if dd(-2.0) <= 0.0 || dd(3.0) <= 0.0 {
        return None;
    }
    // Strictly increasing on [-2, 3]: one root in [0, 1] iff the signs differ.
    let q = |s: f64| (qa * s + qb) * s + qc;
    // A shock through a node gives a root at 0 or 1 up to round-off: allow for it.
    let (q0, q1) = (q(0.0), q(1.0));
    let tol = 1e-9 * (qa.abs() + qb.abs() + qc.abs());
    if q0 > tol || q1 < -tol {
        return None;
    }
    let s0 = if q0 >= 0.0 {
        0.0
    } else if q1 <= 0.0 {
        1.0
    } else if qa.abs() < 1e-12 * qb.abs() {
        -qc / qb
    } else {
        // The root where the derivative is positive.
        let disc = (qb * qb - 4.0 * qa * qc).max(0.0).sqrt();
        let r = if qb >= 0.0 {
            let t = -0.5 * (qb + disc);
            // roots t/qa and qc/t; pick the one in [0, 1]
            pick(t / qa, if t != 0.0 { qc / t } else { f64::NAN })
        } else {
            let t = -0.5 * (qb - disc);
            pick(t / qa, if t != 0.0 { qc / t } else { f64::NAN })
        };
        r?
    };
    let s0 = s0.clamp(0.0, 1.0);
    Some((s0, dd(s0)))
}

fn pick(r1: f64, r2: f64) -> Option<f64> {
    let tol = 1e-9;
    [r1, r2].into_iter().find(|r| r.is_finite() && *r >= -tol && *r <= 1.0 + tol)
}

/// Local feature size lfs = |phi| + |phi_MA| (seed eq. 4.6) at every node, with phi_MA by fast
/// marching from the nodes seeded by [`medial_axis_2d`]. Without any detected medial axis the
/// result is infinite.
pub fn feature_size_2d(phi: &Grid2, params: &MedialAxisParams) -> (Vec<f64>, MedialAxis) {
    let ma = medial_axis_2d(phi, params);
    let (nx, ny) = phi.dims();
    let known: Vec<bool> = ma.node_distance.iter().map(|d| d.is_finite()).collect();
    let mut dma = ma.node_distance.clone();
    if known.iter().any(|&k| k) {
        fast_march_2d(&mut dma, &known, (nx, ny), phi.spacing()).expect("grid layout");
    }
    let lfs = phi.values().iter().zip(&dma).map(|(p, m)| p.abs() + m.abs()).collect();
    (lfs, ma)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_crossing_of_two_lines() {
        // V-shape |s - 0.3| - 5 sampled at -2..3: the kink is found exactly.
        let f = |s: f64| -(5.0 - (s - 0.3f64).abs());
        let (s0, d) = crossing([f(-2.0), f(-1.0), f(0.0)], [f(1.0), f(2.0), f(3.0)]).unwrap();
        assert!((s0 - 0.3).abs() < 1e-12);
        assert!((d - 2.0).abs() < 1e-12);
        // A smooth function does not cross with increasing difference (no shock).
        let g = |s: f64| 0.1 * s * s - 3.0;
        assert!(crossing([g(-2.0), g(-1.0), g(0.0)], [g(1.0), g(2.0), g(3.0)]).is_none());
    }
}
