//! Curvature adaptation (seed section 4.2): curvature of the level sets from second-order
//! differences (eq. 4.2) and the corrected narrow-band size h_curv (eq. 4.3-4.4).

use crate::geometry::{Grid2, Grid3};
use glam::{DMat3, DVec3};

#[inline]
fn clamp_mid(c: usize, n: usize) -> usize {
    if n < 3 {
        0
    } else {
        c.clamp(1, n - 2)
    }
}

/// Level-set curvature div(grad phi / |grad phi|) at every node (seed eq. 4.2), central
/// differences; border nodes take their inner neighbour's value. Positive for convex shapes
/// with phi < 0 inside. Zero where the gradient vanishes.
pub fn curvature_2d(phi: &Grid2) -> Vec<f64> {
    let (nx, ny) = phi.dims();
    let (v, h) = (phi.values(), phi.spacing());
    let mut out = vec![0.0; nx * ny];
    if nx < 3 || ny < 3 {
        return out;
    }
    for j in 0..ny {
        for i in 0..nx {
            let (ci, cj) = (clamp_mid(i, nx), clamp_mid(j, ny));
            out[i + nx * j] = kappa2(v, nx, ci, cj, h);
        }
    }
    out
}

/// Eq. 4.2 at interior node (i, j).
#[inline]
pub(crate) fn kappa2(v: &[f64], nx: usize, i: usize, j: usize, h: f64) -> f64 {
    let f = |a: isize, b: isize| v[(i as isize + a) as usize + nx * (j as isize + b) as usize];
    let c = f(0, 0);
    let px = (f(1, 0) - f(-1, 0)) / (2.0 * h);
    let py = (f(0, 1) - f(0, -1)) / (2.0 * h);
    let pxx = (f(1, 0) - 2.0 * c + f(-1, 0)) / (h * h);
    let pyy = (f(0, 1) - 2.0 * c + f(0, -1)) / (h * h);
    let pxy = (f(1, 1) - f(1, -1) - f(-1, 1) + f(-1, -1)) / (4.0 * h * h);
    let g2 = px * px + py * py;
    if g2 < 1e-24 {
        return 0.0;
    }
    (pxx * py * py - 2.0 * px * py * pxy + pyy * px * px) / (g2 * g2.sqrt())
}

/// The curvature size of seed eq. 4.4 at every node of a signed distance grid `phi`:
/// |(1 - kappa phi) / (K kappa)| - g phi where |phi| <= 2 dx, infinity elsewhere (and where
/// kappa = 0). The seed prints 1 + kappa phi; with kappa = div(grad phi/|grad phi|) the radius at
/// the boundary is 1/kappa - phi, and this sign makes the correction exact for circles and lines.
pub fn curvature_size_2d(phi: &Grid2, k: f64, g: f64) -> Vec<f64> {
    let kap = curvature_2d(phi);
    size_from(phi.values(), &kap, phi.spacing(), k, g)
}

pub(crate) fn size_from(phi: &[f64], kap: &[f64], dx: f64, k: f64, g: f64) -> Vec<f64> {
    phi.iter()
        .zip(kap)
        .map(|(&p, &c)| {
            if p.abs() > 2.0 * dx || c == 0.0 || k <= 0.0 {
                f64::INFINITY
            } else {
                ((1.0 - c * p) / (k * c)).abs() - g * p
            }
        })
        .collect()
}

/// Signed principal curvature of largest magnitude of the level sets at every node (3-D),
/// from the eigenvalues of the shape operator P Hess P / |grad phi| (P projects on the
/// tangent plane): k = H +- sqrt(H^2 - K_gauss).
pub fn curvature_3d(phi: &Grid3) -> Vec<f64> {
    let n = phi.dims();
    let (v, h) = (phi.values(), phi.spacing());
    let mut out = vec![0.0; n[0] * n[1] * n[2]];
    if n.iter().any(|&k| k < 3) {
        return out;
    }
    let at = |i: usize, j: usize, k: usize| v[i + n[0] * (j + n[1] * k)];
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let c = [clamp_mid(i, n[0]), clamp_mid(j, n[1]), clamp_mid(k, n[2])];
                let f = |d: [isize; 3]| {
                    at(
                        (c[0] as isize + d[0]) as usize,
                        (c[1] as isize + d[1]) as usize,
                        (c[2] as isize + d[2]) as usize,
                    )
                };
                let e = |a: usize| {
                    let mut d = [0isize; 3];
                    d[a] = 1;
                    d
                };
                let neg = |d: [isize; 3]| [-d[0], -d[1], -d[2]];
                let add = |a: [isize; 3], b: [isize; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
                let f0 = f([0; 3]);
                let mut grad = DVec3::ZERO;
                let mut hes = DMat3::ZERO;
                for a in 0..3 {
                    grad[a] = (f(e(a)) - f(neg(e(a)))) / (2.0 * h);
                    hes.col_mut(a)[a] = (f(e(a)) - 2.0 * f0 + f(neg(e(a)))) / (h * h);
                    for b in (a + 1)..3 {
                        let x = (f(add(e(a), e(b))) - f(add(e(a), neg(e(b)))) - f(add(neg(e(a)), e(b)))
                            + f(add(neg(e(a)), neg(e(b)))))
                            / (4.0 * h * h);
                        hes.col_mut(a)[b] = x;
                        hes.col_mut(b)[a] = x;
                    }
                }
                out[i + n[0] * (j + n[1] * k)] = max_principal(grad, hes);
            }
        }
    }
    out
}

/// Largest-magnitude principal curvature from a gradient and Hessian.
pub(crate) fn max_principal(grad: DVec3, hes: DMat3) -> f64 {
    let gl = grad.length();
    if gl < 1e-12 {
        return 0.0;
    }
    let nrm = grad / gl;
    let p = DMat3::IDENTITY - DMat3::from_cols(nrm * nrm.x, nrm * nrm.y, nrm * nrm.z);
    let s = p * hes * p * (1.0 / gl);
    let tr = s.x_axis.x + s.y_axis.y + s.z_axis.z;
    let minors = s.x_axis.x * s.y_axis.y - s.y_axis.x * s.x_axis.y + s.x_axis.x * s.z_axis.z - s.z_axis.x * s.x_axis.z
        + s.y_axis.y * s.z_axis.z
        - s.z_axis.y * s.y_axis.z;
    let hm = 0.5 * tr;
    let r = (hm * hm - minors).max(0.0).sqrt();
    if (hm + r).abs() >= (hm - r).abs() {
        hm + r
    } else {
        hm - r
    }
}

/// 3-D eq. 4.4 with the maximum principal curvature (exact for spheres and planes).
pub fn curvature_size_3d(phi: &Grid3, k: f64, g: f64) -> Vec<f64> {
    let kap = curvature_3d(phi);
    size_from(phi.values(), &kap, phi.spacing(), k, g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Ball, Circle};

    #[test]
    fn size_curvature_of_circle_and_ball() {
        let c = Circle::new([0.1, 0.0], 0.6);
        let g = Grid2::sample(&c, [-1.0, -1.0], [1.0, 1.0], 0.02).unwrap();
        let hc = curvature_size_2d(&g, 10.0, 0.3);
        let (nx, _) = g.dims();
        let mut n = 0;
        for (idx, &v) in hc.iter().enumerate() {
            if v.is_finite() {
                n += 1;
                let phi = g.values()[idx];
                let want = 0.6 / 10.0 - 0.3 * phi;
                assert!((v - want).abs() < 1e-3, "node {} {}: {v} vs {want}", idx % nx, idx / nx);
            }
        }
        assert!(n > 100);
        let b = Ball::new([0.0, 0.0, 0.0], 0.5);
        let g3 = Grid3::sample(&b, [-0.8; 3], [0.8; 3], 0.05).unwrap();
        let h3 = curvature_size_3d(&g3, 5.0, 0.0);
        for &v in h3.iter().filter(|v| v.is_finite()) {
            assert!((v - 0.1).abs() < 3e-3, "{v}");
        }
    }
}
