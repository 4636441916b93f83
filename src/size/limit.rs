//! Gradient limiting |grad h| <= g (seed section 4.4): the iterative Hamilton-Jacobi scheme
//! (eq. 4.16-4.17), the fast solver (Algorithm 4-2) and an unstructured-mesh solver.

use super::heap::IndexedHeap;
use super::march::{march, Lattice};
use super::Slope;
use crate::Error;
use glam::DVec2;

fn check(h: &[f64], slope: &Slope) -> Result<(), Error> {
    if let Some(v) = h.iter().find(|v| v.is_nan() || **v < 0.0) {
        return Err(Error::BadSize(format!("size value {v}")));
    }
    match slope {
        Slope::Constant(g) if !(g.is_finite() && *g >= 0.0) => Err(Error::BadSize(format!("gradient limit {g}"))),
        Slope::PerNode(gs) if gs.len() != h.len() => {
            Err(Error::BadSize(format!("{} per-node gradient limits for {} nodes", gs.len(), h.len())))
        }
        _ => Ok(()),
    }
}

/// Fast gradient limiting (seed Algorithm 4-2) on an `nx` by `ny` grid of sizes `h` (x
/// fastest, spacing `dx`), in place: all nodes start in a min-heap; the smallest is fixed and
/// its neighbours lowered to the upwind solution of |grad h| = g. O(n log n). Infinite values
/// are allowed and stay infinite only where nothing finite reaches them.
pub fn gradient_limit_fast_2d(h: &mut [f64], dims: (usize, usize), dx: f64, slope: &Slope) -> Result<(), Error> {
    let lat = Lattice::new([dims.0, dims.1, 1], dx, h.len())?;
    check(h, slope)?;
    march(&lat, h, None, slope);
    Ok(())
}

/// [`gradient_limit_fast_2d`] on a 3-D grid.
pub fn gradient_limit_fast_3d(h: &mut [f64], dims: [usize; 3], dx: f64, slope: &Slope) -> Result<(), Error> {
    let lat = Lattice::new(dims, dx, h.len())?;
    check(h, slope)?;
    march(&lat, h, None, slope);
    Ok(())
}

/// Iterative gradient limiting, seed eq. 4.16: h += dt (min(grad+, g) - grad+) with dt = dx/2
/// and the first-order upwind grad+ of eq. 4.17 in Godunov form (per axis the larger of the
/// one-sided terms, so it has the same steady state as the fast solver), Jacobi sweeps until
/// the largest change is at most `tol`. Returns the number of sweeps. Infinite input values are
/// first replaced by a finite cap above every finite value.
pub fn gradient_limit_hj_2d(
    h: &mut [f64],
    dims: (usize, usize),
    dx: f64,
    slope: &Slope,
    tol: f64,
    max_iter: usize,
) -> Result<usize, Error> {
    let lat = Lattice::new([dims.0, dims.1, 1], dx, h.len())?;
    check(h, slope)?;
    Ok(hj(&lat, h, slope, tol, max_iter))
}

/// [`gradient_limit_hj_2d`] on a 3-D grid.
pub fn gradient_limit_hj_3d(
    h: &mut [f64],
    dims: [usize; 3],
    dx: f64,
    slope: &Slope,
    tol: f64,
    max_iter: usize,
) -> Result<usize, Error> {
    let lat = Lattice::new(dims, dx, h.len())?;
    check(h, slope)?;
    Ok(hj(&lat, h, slope, tol, max_iter))
}

fn hj(lat: &Lattice, h: &mut [f64], slope: &Slope, tol: f64, max_iter: usize) -> usize {
    let fmax = h.iter().copied().filter(|v| v.is_finite()).fold(0.0, f64::max);
    let cap = 2.0 * fmax + 1.0;
    for v in h.iter_mut() {
        *v = v.min(cap);
    }
    let dt = 0.5 * lat.h;
    let mut next = h.to_vec();
    for it in 1..=max_iter {
        let mut change: f64 = 0.0;
        for i in 0..lat.len() {
            let c = lat.coords(i);
            let u = h[i];
            let mut s2 = 0.0;
            for axis in 0..lat.dims() {
                let [lo, hi] = lat.pair(i, &c, axis);
                // max(D^-x h, 0) and -min(D^+x h, 0): both non-negative.
                let back = lo.map_or(0.0, |j| (u - h[j]).max(0.0));
                let fwd = hi.map_or(0.0, |j| (u - h[j]).max(0.0));
                let d = back.max(fwd) / lat.h;
                s2 += d * d;
            }
            let grad = s2.sqrt();
            let g = slope.at(i, u);
            let du = dt * (grad.min(g) - grad);
            next[i] = u + du;
            change = change.max(-du);
        }
        h.copy_from_slice(&next);
        if change <= tol {
            return it;
        }
    }
    max_iter
}

/// Gradient limiting on an unstructured triangle mesh (seed section 4.4.2, positive-coefficient
/// spirit): Dijkstra-like ordering by h; when node j is fixed, each neighbour i is lowered to
/// h_j + g |x_i - x_j| (the edge update) and, for every triangle (i, j, k) with k fixed too, to
/// the triangle-wise upwind value of |grad h| = g on the plane through the triangle.
/// O(n log n) in the number of nodes for bounded valence. `h` is changed in place.
pub fn gradient_limit_mesh(
    points: &[DVec2],
    triangles: &[[usize; 3]],
    h: &mut [f64],
    slope: &Slope,
) -> Result<(), Error> {
    let n = points.len();
    if h.len() != n {
        return Err(Error::InvalidMesh(format!("{} sizes for {n} points", h.len())));
    }
    check(h, slope)?;
    if let Some(t) = triangles.iter().find(|t| t.iter().any(|&v| v >= n)) {
        return Err(Error::InvalidMesh(format!("triangle {t:?} out of range")));
    }
    // Triangles around each node (compressed rows).
    let around = crate::topology::Incidence::new(n, triangles);
    let top = h.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut heap = IndexedHeap::from_keys(h, top);
    let mut fixed = vec![false; n];
    while let Some((j, _)) = heap.pop() {
        fixed[j] = true;
        for &ti in around.of(j) {
            let t = triangles[ti as usize];
            let r = t.iter().position(|&v| v == j).unwrap();
            for s in 1..3 {
                let i = t[(r + s) % 3];
                let k = t[(r + 3 - s) % 3];
                if fixed[i] {
                    continue;
                }
                let g = |u: f64| slope.at(i, u);
                let mut u = h[j] + g(h[j]) * points[i].distance(points[j]);
                if let Slope::OfSize(_) = slope {
                    for _ in 0..4 {
                        u = h[j] + g(u) * points[i].distance(points[j]);
                    }
                }
                if fixed[k] {
                    let gi = g(u.min(h[i]));
                    if let Some(v) = triangle_update(points[i], points[j], points[k], h[j], h[k], gi) {
                        u = u.min(v);
                    }
                }
                if u < h[i] {
                    h[i] = u;
                    heap.push_or_decrease(i, u);
                }
            }
        }
    }
    Ok(())
}

/// Upwind value at `xi` from the plane through (xj, hj), (xk, hk) with slope `g`: the value
/// hj + g |x - y| minimised over y on the segment xj..xk with h linear along it, taken only
/// when the minimiser is strictly inside the segment (the edge updates cover the ends).
fn triangle_update(xi: DVec2, xj: DVec2, xk: DVec2, hj: f64, hk: f64, g: f64) -> Option<f64> {
    // y(t) = xj + t (xk - xj), value hj + t (hk - hj) + g |xi - y(t)|, minimise over t in (0,1).
    let e = xk - xj;
    let l = e.length();
    if l == 0.0 || g <= 0.0 {
        return None;
    }
    let dh = (hk - hj) / l; // slope along the edge
    if dh.abs() >= g {
        return None; // the front moves along the edge faster than g: an end is optimal
    }
    let w = xi - xj;
    let along = w.dot(e) / l; // foot of the perpendicular, measured from xj
    let perp = (w.length_squared() - along * along).max(0.0).sqrt();
    // d/ds [dh s + g sqrt((along - s)^2 + perp^2)] = 0  =>  along - s = perp dh / sqrt(g^2 - dh^2)
    let s = along - perp * dh / (g * g - dh * dh).sqrt();
    if s <= 0.0 || s >= l {
        return None;
    }
    Some(hj + dh * s + g * ((along - s).powi(2) + perp * perp).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_triangle_update_matches_point_source() {
        // Point source at (0,-10) with h = 1 and g = 0.3: the front reaching the edge is exact.
        let src = DVec2::new(0.0, -10.0);
        let ex = |p: DVec2| 1.0 + 0.3 * p.distance(src);
        let (xj, xk, xi) = (DVec2::new(-0.5, 0.0), DVec2::new(0.6, 0.0), DVec2::new(0.1, 0.8));
        let u = triangle_update(xi, xj, xk, ex(xj), ex(xk), 0.3).unwrap();
        // Linear interpolation along the edge: error O(edge^2 / distance).
        assert!((u - ex(xi)).abs() < 5e-3, "{u} vs {}", ex(xi));
    }
}
