//! The medial axis and local feature size of a 3-D signed distance grid: seed Algorithm 4-1
//! applied along the grid lines of all three axes, and lfs = |phi| + |phi_MA| (eq. 4.6).

use super::curvature_3d;
use super::march::fast_march_3d;
use super::medial::{crossing, MedialAxisParams};
use crate::geometry::Grid3;
use glam::DVec3;

/// Distance from each node to the medial axis of the interior (phi < 0) where a grid edge
/// next to it crosses the axis (else infinity), by Algorithm 4-1 along every grid line: the
/// quadratics fitted to phi at s = -2,-1,0 and s = 1,2,3 cross once in [0, 1] with a growing
/// difference; the one-sided unit gradients at the edge's nodes differ by more than fronts of
/// curvature max(|kappa|, kappa_tol) (the largest principal curvature) times gamma would; the
/// strongest crossing within [-2, 3] of a line wins.
pub fn medial_axis_3d(phi: &Grid3, params: &MedialAxisParams) -> Vec<f64> {
    let n = phi.dims();
    let h = phi.spacing();
    let v: Vec<f64> = phi.values().iter().map(|p| p / h).collect();
    let mut out = vec![f64::INFINITY; v.len()];
    if n.iter().any(|&k| k < 6) {
        return out;
    }
    // Curvature per grid spacing.
    let kap: Vec<f64> = curvature_3d(phi).iter().map(|k| k * h).collect();
    let stride = [1, n[0], n[0] * n[1]];
    let at = |c: [usize; 3]| c[0] + n[0] * (c[1] + n[1] * c[2]);
    for axis in 0..3 {
        let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
        let s = stride[axis] as isize;
        for l2 in 0..n[a2] {
            for l1 in 0..n[a1] {
                let mut c = [0usize; 3];
                c[a1] = l1;
                c[a2] = l2;
                let base = at(c);
                let node = |t: usize| (base as isize + s * t as isize) as usize;
                // (position on the line, s0, strength, |n . e_axis|)
                let mut cands: Vec<(usize, f64, f64, f64)> = Vec::new();
                for i in 2..n[axis] - 3 {
                    let f = |k: isize| v[node((i as isize + k) as usize)];
                    if f(0) >= 0.0 || f(1) >= 0.0 {
                        continue;
                    }
                    let Some((s0, strength)) = crossing([f(-2), f(-1), f(0)], [f(1), f(2), f(3)]) else {
                        continue;
                    };
                    // One-sided second-order gradient along the line, central across it.
                    let grad = |t: usize, fwd: bool| -> DVec3 {
                        let along = if fwd {
                            -(3.0 * v[node(t)] - 4.0 * v[node(t + 1)] + v[node(t + 2)]) / 2.0
                        } else {
                            (3.0 * v[node(t)] - 4.0 * v[node(t - 1)] + v[node(t - 2)]) / 2.0
                        };
                        let mut g = DVec3::ZERO;
                        g[axis] = along;
                        for (b, lb) in [(a1, l1), (a2, l2)] {
                            let lc = lb.clamp(1, n[b] - 2) as isize;
                            let here = node(t) as isize + (lc - lb as isize) * stride[b] as isize;
                            let sb = stride[b] as isize;
                            g[b] = 0.5 * (v[(here + sb) as usize] - v[(here - sb) as usize]);
                        }
                        g.normalize_or_zero()
                    };
                    let (g1, g2) = (grad(i, false), grad(i + 1, true));
                    let k = kap[node(i - 1)].abs().max(kap[node(i + 2)].abs()).max(params.kappa_tol);
                    if g1.dot(g2) >= 1.0 - params.gamma * params.gamma * k * k / 2.0 {
                        continue;
                    }
                    let nrm = (g1 - g2).normalize_or_zero();
                    cands.push((i, s0, strength, nrm[axis].abs()));
                }
                for &(i, s0, strength, na) in &cands {
                    let beaten = cands.iter().any(|&(j, _, sj, _)| {
                        j != i && j + 2 >= i && j <= i + 2 && (sj > strength || (sj == strength && j < i))
                    });
                    if beaten {
                        continue;
                    }
                    let (n0, n1) = (node(i), node(i + 1));
                    out[n0] = out[n0].min(na * h * s0);
                    out[n1] = out[n1].min(na * h * (1.0 - s0));
                }
            }
        }
    }
    out
}

/// Local feature size lfs = |phi| + |phi_MA| (seed eq. 4.6) at every node of a 3-D signed
/// distance grid, phi_MA by fast marching from the nodes [`medial_axis_3d`] seeds; infinite
/// everywhere when no medial axis is found.
pub fn feature_size_3d(phi: &Grid3, params: &MedialAxisParams) -> Vec<f64> {
    let mut dma = medial_axis_3d(phi, params);
    let known: Vec<bool> = dma.iter().map(|d| d.is_finite()).collect();
    if known.iter().any(|&k| k) {
        fast_march_3d(&mut dma, &known, phi.dims(), phi.spacing()).expect("grid layout");
    }
    phi.values().iter().zip(&dma).map(|(p, m)| p.abs() + m.abs()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Implicit3;

    /// A slab |z| < t between two planes: the medial axis is z = 0, and lfs at the walls is
    /// the half thickness t.
    #[test]
    fn the_feature_size_of_a_slab_is_its_half_thickness() {
        struct Slab(f64);
        impl Implicit3 for Slab {
            fn value(&self, p: DVec3) -> f64 {
                p.z.abs() - self.0
            }
        }
        let t = 0.1;
        let g = Grid3::sample(&Slab(t), [-0.3, -0.3, -0.3], [0.3, 0.3, 0.3], 0.02).unwrap();
        let lfs = feature_size_3d(&g, &MedialAxisParams::default());
        let [nx, ny, nz] = g.dims();
        let mut worst = 0.0f64;
        for k in 0..nz {
            let z = g.origin().z + 0.02 * k as f64;
            if z.abs() <= t + 1e-12 {
                for j in 2..ny - 2 {
                    for i in 2..nx - 2 {
                        worst = worst.max((lfs[i + nx * (j + ny * k)] - t).abs());
                    }
                }
            }
        }
        assert!(worst < 0.2 * t, "lfs off the half thickness {t} by {worst}");
    }
}
