//! Fast marching on Cartesian grids (seed section 3.1.2) and the shared first-order upwind
//! update, also used by the fast gradient limiter (Algorithm 4-2).

use super::heap::IndexedHeap;
use super::Slope;
use crate::geometry::{Grid2, Grid3, Implicit2, Implicit3};
use crate::Error;
use glam::{DVec2, DVec3};

/// Node layout of a 2-D (`n[2] == 1`) or 3-D grid, x fastest.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lattice {
    pub n: [usize; 3],
    pub h: f64,
}

impl Lattice {
    pub fn new(n: [usize; 3], h: f64, len: usize) -> Result<Self, Error> {
        if !(h.is_finite() && h > 0.0) {
            return Err(Error::BadSize(format!("grid spacing {h}")));
        }
        if n.iter().product::<usize>() != len || n.contains(&0) {
            return Err(Error::BadSize(format!("grid of {n:?} nodes given {len} values")));
        }
        Ok(Lattice { n, h })
    }
    #[inline]
    pub fn len(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }
    #[inline]
    pub fn stride(&self, axis: usize) -> usize {
        match axis {
            0 => 1,
            1 => self.n[0],
            _ => self.n[0] * self.n[1],
        }
    }
    #[inline]
    pub fn coords(&self, i: usize) -> [usize; 3] {
        let (nx, ny) = (self.n[0], self.n[1]);
        [i % nx, (i / nx) % ny, i / (nx * ny)]
    }
    /// The neighbours of node `i` (coordinates `c`) along `axis`: below and above.
    #[inline]
    pub fn pair(&self, i: usize, c: &[usize; 3], axis: usize) -> [Option<usize>; 2] {
        let s = self.stride(axis);
        [(c[axis] > 0).then(|| i - s), (c[axis] + 1 < self.n[axis]).then(|| i + s)]
    }
    pub fn dims(&self) -> usize {
        if self.n[2] == 1 {
            2
        } else {
            3
        }
    }
}

/// Solves the first-order upwind equation sum_d max(u - a_d, 0)^2 = r^2 for the smallest root
/// above all used `a_d` (infinite entries are absent axes).
#[inline]
pub(crate) fn upwind(a: &mut [f64; 3], r: f64) -> f64 {
    a.sort_unstable_by(|x, y| x.total_cmp(y));
    let mut u = a[0] + r;
    if u <= a[1] {
        return u;
    }
    let (s, q) = (a[0] + a[1], a[0] * a[0] + a[1] * a[1]);
    let disc = s * s - 2.0 * (q - r * r);
    u = 0.5 * (s + disc.max(0.0).sqrt());
    if u <= a[2] {
        return u;
    }
    let (s, q) = (s + a[2], q + a[2] * a[2]);
    let disc = s * s - 3.0 * (q - r * r);
    (s + disc.max(0.0).sqrt()) / 3.0
}

/// The upwind value at `i` from accepted neighbours, with right-hand side `slope * h`
/// (solution-dependent slopes by a few fixed-point steps from below).
#[inline]
fn update(lat: &Lattice, vals: &[f64], accepted: &[bool], i: usize, slope: &Slope) -> f64 {
    let c = lat.coords(i);
    let mut a = [f64::INFINITY; 3];
    for (axis, ad) in a.iter_mut().enumerate().take(lat.dims()) {
        for j in lat.pair(i, &c, axis).into_iter().flatten() {
            if accepted[j] && vals[j] < *ad {
                *ad = vals[j];
            }
        }
    }
    if a.iter().all(|v| v.is_infinite()) {
        return f64::INFINITY;
    }
    match slope {
        Slope::OfSize(f) => {
            let amin = a.iter().copied().fold(f64::INFINITY, f64::min);
            let mut u = amin;
            for _ in 0..6 {
                let mut b = a;
                u = upwind(&mut b, f(u) * lat.h);
            }
            u
        }
        _ => upwind(&mut a, slope.at(i, 0.0) * lat.h),
    }
}

/// The marching core: every node starts in the heap; nodes are accepted in increasing order
/// and their neighbours lowered to the upwind value (never raised). `frozen` nodes keep their
/// values. Nodes at the largest value (or infinite) can lower nobody, so they enter the heap
/// only once lowered (a narrow band, as in fast marching). O(n log n).
pub(crate) fn march(lat: &Lattice, vals: &mut [f64], frozen: Option<&[bool]>, slope: &Slope) {
    let top = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut heap = IndexedHeap::from_keys(vals, top);
    let mut accepted = vec![false; lat.len()];
    while let Some((i, _)) = heap.pop() {
        accepted[i] = true;
        let c = lat.coords(i);
        for axis in 0..lat.dims() {
            for j in lat.pair(i, &c, axis).into_iter().flatten() {
                if accepted[j] || frozen.is_some_and(|f| f[j]) {
                    continue;
                }
                let u = update(lat, vals, &accepted, j, slope);
                if u < vals[j] {
                    vals[j] = u;
                    heap.push_or_decrease(j, u);
                }
            }
        }
    }
}

/// Extends non-negative distances from the `known` nodes to the whole `nx` by `ny` grid
/// (x fastest) by fast marching with unit speed; other nodes' values are overwritten.
/// First-order upwind, O(n log n).
pub fn fast_march_2d(values: &mut [f64], known: &[bool], dims: (usize, usize), h: f64) -> Result<(), Error> {
    fast_march(values, known, [dims.0, dims.1, 1], h)
}

/// [`fast_march_2d`] on an `n[0]` by `n[1]` by `n[2]` grid.
pub fn fast_march_3d(values: &mut [f64], known: &[bool], dims: [usize; 3], h: f64) -> Result<(), Error> {
    fast_march(values, known, dims, h)
}

fn fast_march(values: &mut [f64], known: &[bool], n: [usize; 3], h: f64) -> Result<(), Error> {
    let lat = Lattice::new(n, h, values.len())?;
    if known.len() != values.len() {
        return Err(Error::BadSize("known mask length differs from values".into()));
    }
    for (v, &k) in values.iter_mut().zip(known) {
        if !k {
            *v = f64::INFINITY;
        } else if !(v.is_finite() && *v >= 0.0) {
            return Err(Error::BadSize(format!("known distance {v}")));
        }
    }
    march(&lat, values, Some(known), &Slope::Constant(1.0));
    Ok(())
}

/// Reinitialises level-set values `phi` to a signed distance (seed section 3.1.2): nodes next to
/// a sign change get first-order distances from linear interpolation of `phi` along the grid
/// axes, combined as 1/d^2 = sum_d 1/t_d^2; fast marching extends them, signs are kept.
pub(crate) fn reinit(lat: &Lattice, phi: &[f64]) -> Vec<f64> {
    let mut d = vec![f64::INFINITY; lat.len()];
    let mut known = vec![false; lat.len()];
    for i in 0..lat.len() {
        let p = phi[i];
        if p == 0.0 {
            d[i] = 0.0;
            known[i] = true;
            continue;
        }
        let c = lat.coords(i);
        let mut inv2 = 0.0;
        for axis in 0..lat.dims() {
            let mut t = f64::INFINITY;
            for j in lat.pair(i, &c, axis).into_iter().flatten() {
                let q = phi[j];
                if p * q <= 0.0 {
                    t = t.min(lat.h * p / (p - q));
                }
            }
            if t.is_finite() {
                inv2 += 1.0 / (t * t);
            }
        }
        if inv2 > 0.0 {
            d[i] = 1.0 / inv2.sqrt();
            known[i] = true;
        }
    }
    march(lat, &mut d, Some(&known), &Slope::Constant(1.0));
    for (v, &p) in d.iter_mut().zip(phi) {
        if p < 0.0 {
            *v = -*v;
        }
        if !v.is_finite() {
            // No zero crossing at all: a constant-sign grid, far from any boundary.
            *v = p.signum() * lat.h * (lat.n.iter().sum::<usize>() as f64);
        }
    }
    d
}

/// A signed distance grid from level-set values on a grid (narrow band plus fast marching).
pub fn reinitialize_2d(phi: &Grid2) -> Grid2 {
    let (nx, ny) = phi.dims();
    let lat = Lattice { n: [nx, ny, 1], h: phi.spacing() };
    let d = reinit(&lat, phi.values());
    Grid2::new(phi.origin(), phi.spacing(), nx, ny, d).expect("same layout").with_distance(true)
}

/// 3-D [`reinitialize_2d`].
pub fn reinitialize_3d(phi: &Grid3) -> Grid3 {
    let lat = Lattice { n: phi.dims(), h: phi.spacing() };
    let d = reinit(&lat, phi.values());
    Grid3::new(phi.origin(), phi.spacing(), phi.dims(), d).expect("same layout").with_distance(true)
}

/// Samples `f` on a grid covering `[min, max]` at spacing `h`; unless `f` reports
/// [`Implicit2::is_distance`], reinitialises it to a signed distance.
pub fn signed_distance_2d(
    f: &dyn Implicit2,
    min: impl Into<DVec2>,
    max: impl Into<DVec2>,
    h: f64,
) -> Result<Grid2, Error> {
    let g = Grid2::sample(f, min, max, h)?;
    Ok(if f.is_distance() { g } else { reinitialize_2d(&g) })
}

/// 3-D [`signed_distance_2d`].
pub fn signed_distance_3d(
    f: &dyn Implicit3,
    min: impl Into<DVec3>,
    max: impl Into<DVec3>,
    h: f64,
) -> Result<Grid3, Error> {
    let g = Grid3::sample(f, min, max, h)?;
    Ok(if f.is_distance() { g } else { reinitialize_3d(&g) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_upwind_one_two_three_axes() {
        let inf = f64::INFINITY;
        assert_eq!(upwind(&mut [1.0, inf, inf], 0.5), 1.5);
        // Two equal neighbours: u - a = r / sqrt 2.
        let u = upwind(&mut [0.0, 0.0, inf], 1.0);
        assert!((u - 0.5f64.sqrt()).abs() < 1e-15);
        let u = upwind(&mut [0.0, 0.0, 0.0], 1.0);
        assert!((u - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        // A far second neighbour is not used.
        assert_eq!(upwind(&mut [5.0, 0.0, inf], 1.0), 1.0);
    }

    #[test]
    fn size_fast_march_plane_is_exact() {
        // Distance to the line x = 0.25 from the two nodes next to it: exact for planes.
        let (nx, ny, h) = (21, 11, 0.1);
        let mut v = vec![0.0; nx * ny];
        let mut known = vec![false; nx * ny];
        for j in 0..ny {
            for i in 2..4 {
                v[i + nx * j] = (i as f64 * h - 0.25).abs();
                known[i + nx * j] = true;
            }
        }
        fast_march_2d(&mut v, &known, (nx, ny), h).unwrap();
        for j in 0..ny {
            for i in 3..nx {
                let e = (i as f64 * h - 0.25).abs();
                assert!((v[i + nx * j] - e).abs() < 1e-12);
            }
        }
    }
}
