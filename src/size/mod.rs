//! Mesh size functions (seed chapter 4): fast marching, curvature and local-feature-size
//! adaptation, and gradient limiting |grad h| <= g, on Cartesian grids ([`Grid2`], [`Grid3`])
//! and on unstructured triangle meshes.
//!
//! [`auto_size_2d`] puts them together: h = gradlimit(min(h_curv, h_lfs, hmax)) (seed eq. 4.18).

mod curvature;
mod heap;
mod limit;
mod march;
mod medial;
mod medial3;

pub(crate) use curvature::max_principal;
pub use curvature::{curvature_2d, curvature_3d, curvature_size_2d, curvature_size_3d};
pub use limit::{
    gradient_limit_fast_2d, gradient_limit_fast_3d, gradient_limit_hj_2d, gradient_limit_hj_3d, gradient_limit_mesh,
};
pub use march::{
    fast_march_2d, fast_march_3d, reinitialize_2d, reinitialize_3d, signed_distance_2d, signed_distance_3d,
};
pub use medial::{feature_size_2d, medial_axis_2d, MedialAxis, MedialAxisParams};
pub use medial3::{feature_size_3d, medial_axis_3d};

use crate::geometry::{Grid2, Grid3, Implicit2, Implicit3};
use crate::Error;
use glam::{DVec2, DVec3};

/// The gradient limit g of |grad h| <= g: constant, space-dependent (one value per node, e.g.
/// sampled from a closure or grid) or solution-dependent g(h).
#[derive(Clone, Copy)]
pub enum Slope<'a> {
    /// One g everywhere.
    Constant(f64),
    /// g at each node (same layout as the sizes).
    PerNode(&'a [f64]),
    /// g as a function of the size itself (e.g. g(h) = c h for geometric grading).
    OfSize(&'a (dyn Fn(f64) -> f64 + Sync)),
}

impl Slope<'_> {
    /// g at node `i` where the size is `h`.
    #[inline]
    pub fn at(&self, i: usize, h: f64) -> f64 {
        match self {
            Slope::Constant(g) => *g,
            Slope::PerNode(gs) => gs[i],
            Slope::OfSize(f) => f(h),
        }
    }
}

/// Parameters of the automatic size function (seed section 4.1).
#[derive(Clone, Copy, Debug)]
pub struct SizeParams {
    /// Elements per radian of boundary curvature (h_curv = 1/(K |kappa|)); 0 turns it off.
    pub k: f64,
    /// Half the number of elements across narrow regions (h_lfs = lfs / R); 0 turns it off.
    pub r: f64,
    /// Gradient limit g = G - 1.
    pub g: f64,
    /// Smallest size.
    pub hmin: f64,
    /// Largest size.
    pub hmax: f64,
    /// Medial axis detection.
    pub medial: MedialAxisParams,
}

impl Default for SizeParams {
    fn default() -> Self {
        SizeParams { k: 2.0, r: 2.0, g: 0.3, hmin: 0.0, hmax: f64::INFINITY, medial: MedialAxisParams::default() }
    }
}

fn check_params(p: &SizeParams) -> Result<(), Error> {
    let ok = p.k >= 0.0
        && p.k.is_finite()
        && p.r >= 0.0
        && p.r.is_finite()
        && p.g > 0.0
        && p.g.is_finite()
        && p.hmin >= 0.0
        && p.hmax > p.hmin;
    if ok {
        Ok(())
    } else {
        Err(Error::BadSize(format!("size parameters {p:?}")))
    }
}

/// Combines the sources into h0 (eq. 4.18), limits its gradient (Algorithm 4-2) and clamps.
fn finish(phi: &[f64], hc: &[f64], lfs: Option<&[f64]>, p: &SizeParams, dims: [usize; 3], dx: f64) -> Vec<f64> {
    let cap = if p.hmax.is_finite() {
        p.hmax
    } else {
        // Some finite size, large for the box: the box's diagonal.
        dx * dims.iter().map(|&n| (n * n) as f64).sum::<f64>().sqrt()
    };
    let mut h: Vec<f64> = (0..phi.len())
        .map(|i| {
            let mut v = hc[i].min(cap);
            if let Some(l) = lfs {
                if phi[i] <= 0.0 && l[i].is_finite() {
                    v = v.min(l[i] / p.r);
                }
            }
            v.max(p.hmin)
        })
        .collect();
    let lat = march::Lattice { n: dims, h: dx };
    march::march(&lat, &mut h, None, &Slope::Constant(p.g));
    for v in &mut h {
        *v = v.clamp(p.hmin.max(f64::MIN_POSITIVE), cap);
    }
    h
}

/// An automatic size function for `domain` on a grid of spacing `grid_h` covering `bbox`
/// (seed section 4.5): the signed distance (sampled, or reinitialised by fast marching if the
/// domain is not a distance), h_curv (eq. 4.4), h_lfs = lfs/R (eq. 4.6), h0 = min(h_curv,
/// h_lfs, hmax) clamped below by hmin, then gradient limited with g. The result is a
/// [`Grid2`]; `value(p)` is h(p). Positive and finite everywhere; meaningful inside.
pub fn auto_size_2d(
    domain: &dyn Implicit2,
    bbox: [DVec2; 2],
    grid_h: f64,
    params: &SizeParams,
) -> Result<Grid2, Error> {
    check_params(params)?;
    // Curvature from the sampled function itself (eq. 4.2 holds for any level-set function;
    // second differences of a first-order reinitialised distance would be noise).
    let raw = Grid2::sample(domain, bbox[0], bbox[1], grid_h)?;
    let phi = if domain.is_distance() { raw.clone() } else { reinitialize_2d(&raw) };
    let (nx, ny) = phi.dims();
    let hc = if params.k > 0.0 {
        curvature::size_from(phi.values(), &curvature_2d(&raw), grid_h, params.k, params.g)
    } else {
        vec![f64::INFINITY; nx * ny]
    };
    let lfs = (params.r > 0.0).then(|| feature_size_2d(&phi, &params.medial).0);
    let h = finish(phi.values(), &hc, lfs.as_deref(), params, [nx, ny, 1], grid_h);
    Ok(Grid2::new(phi.origin(), grid_h, nx, ny, h)?.with_distance(false))
}

/// 3-D automatic size function (seed section 4.5 in space): h_curv from the maximum principal
/// curvature (eq. 4.4), h_lfs = lfs / R from the medial axis found along the grid lines of all
/// three axes (Algorithm 4-1, eq. 4.6; `r` = 0 turns it off), h0 = min(h_curv, h_lfs, hmax)
/// clamped below by hmin, then gradient limited with g.
pub fn auto_size_3d(
    domain: &dyn Implicit3,
    bbox: [DVec3; 2],
    grid_h: f64,
    params: &SizeParams,
) -> Result<Grid3, Error> {
    check_params(params)?;
    // Without local feature sizes only the nodes near the surface matter: a distance is then
    // sampled exactly in a band only (see `sample_band`).
    let raw = if params.r == 0.0 && domain.is_distance() {
        sample_band(domain, bbox, grid_h)?
    } else {
        Grid3::sample(domain, bbox[0], bbox[1], grid_h)?
    };
    let phi = if domain.is_distance() { raw.clone() } else { reinitialize_3d(&raw) };
    let n = phi.dims();
    let mut hc = if params.k > 0.0 {
        curvature::size_from(phi.values(), &curvature_3d(&raw), grid_h, params.k, params.g)
    } else {
        vec![f64::INFINITY; phi.values().len()]
    };
    if params.k > 0.0 && domain.surface_curvature(phi.origin()).is_some() {
        given_curvature_size(domain, &phi, params, &mut hc);
    }
    let lfs = (params.r > 0.0).then(|| feature_size_3d(&phi, &params.medial));
    let h = finish(phi.values(), &hc, lfs.as_deref(), params, n, grid_h);
    Ok(Grid3::new(phi.origin(), grid_h, n, h)?.with_distance(false))
}

/// h_curv from the curvature the geometry gives ([`Implicit3::surface_curvature`]) in place of
/// the grid's second differences, at the nodes within 2 dx of the surface: 1 / (K kappa) at the
/// surface, less g phi off it (as eq. 4.4 corrects the grid's value), infinite where flat.
fn given_curvature_size(domain: &dyn Implicit3, phi: &Grid3, params: &SizeParams, hc: &mut [f64]) {
    use rayon::prelude::*;
    let (n, dx, origin) = (phi.dims(), phi.spacing(), phi.origin());
    hc.par_iter_mut().zip(phi.values().par_iter()).enumerate().with_min_len(4096).for_each(|(i, (h, &d))| {
        if d.abs() > 2.0 * dx {
            return;
        }
        let c = DVec3::new((i % n[0]) as f64, ((i / n[0]) % n[1]) as f64, (i / (n[0] * n[1])) as f64);
        let kappa = domain.surface_curvature(origin + c * dx).unwrap_or(0.0);
        *h = if kappa > 0.0 { 1.0 / (params.k * kappa) - params.g * d } else { f64::INFINITY };
    });
}

/// Stride of the coarse pass of [`sample_band`], in grid spacings.
const BAND_STRIDE: usize = 4;
/// Half-width of the band [`sample_band`] samples exactly, in grid spacings: the curvature
/// sizes are set within 2 spacings of the surface from differences reaching one node further.
const BAND_HALF_WIDTH: f64 = 4.0;

/// A signed distance on the grid of spacing `h` over `bbox`, exact at every node within
/// BAND_HALF_WIDTH spacings of the surface and trilinear from a coarse pass (every
/// BAND_STRIDE-th node) elsewhere. A distance changes by at most the distance moved, so where
/// the corners of a coarse cell all lie farther than the band plus the cell's diagonal, every
/// node in the cell lies outside the band, on the corners' side: the interpolated value there
/// is as far and of the same sign. Surfaces from triangle meshes take one nearest-triangle
/// query per exact node, so the coarse pass saves most of them.
fn sample_band(domain: &dyn Implicit3, bbox: [DVec3; 2], h: f64) -> Result<Grid3, Error> {
    use rayon::prelude::*;
    let coarse = Grid3::sample(domain, bbox[0], bbox[1], h * BAND_STRIDE as f64)?;
    let count = |a: usize| crate::geometry::grid::count(bbox[0][a], bbox[1][a], h);
    let n = [count(0), count(1), count(2)];
    let (cn, cv) = (coarse.dims(), coarse.values());
    let far = (BAND_HALF_WIDTH + 3f64.sqrt() * BAND_STRIDE as f64) * h;
    let mut values = vec![0.0; n[0] * n[1] * n[2]];
    values.par_chunks_mut(n[0]).enumerate().for_each(|(r, row)| {
        let (j, k) = (r % n[1], r / n[1]);
        for (i, out) in row.iter_mut().enumerate() {
            let c = [i, j, k];
            // The coarse cell holding the node, and where in it.
            let mut lo = [0usize; 3];
            let mut t = [0.0f64; 3];
            for a in 0..3 {
                lo[a] = (c[a] / BAND_STRIDE).min(cn[a].saturating_sub(2));
                t[a] = ((c[a] as f64) / BAND_STRIDE as f64 - lo[a] as f64).clamp(0.0, 1.0);
            }
            let corner = |d: [usize; 3]| {
                let q = [0, 1, 2].map(|a| (lo[a] + d[a]).min(cn[a] - 1));
                cv[q[0] + cn[0] * (q[1] + cn[1] * q[2])]
            };
            let mut sum = 0.0;
            let mut all_far = true;
            let mut sign = 0.0f64;
            for d in 0..8 {
                let dd = [d & 1, (d >> 1) & 1, (d >> 2) & 1];
                let v = corner(dd);
                // Every corner far, and all on one side.
                if v.abs() <= far || (sign != 0.0 && v.signum() != sign) {
                    all_far = false;
                    break;
                }
                sign = v.signum();
                let w: f64 = (0..3).map(|a| if dd[a] == 1 { t[a] } else { 1.0 - t[a] }).product();
                sum += w * v;
            }
            *out = if all_far { sum } else { domain.value(bbox[0] + h * DVec3::new(i as f64, j as f64, k as f64)) };
        }
    });
    Ok(Grid3::new(bbox[0], h, n, values)?.with_distance(true))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The band sampling is the exact sampling within the band, and elsewhere as far from the
    /// surface and on the same side, for shapes that fill the box and shapes far inside it.
    #[test]
    fn band_sampling_is_exact_near_the_surface() {
        let sphere = |p: DVec3| p.length() - 0.7;
        let slab = |p: DVec3| (p.z - 0.1).abs() - 0.2;
        let tube = |p: DVec3| (p.x * p.x + p.y * p.y).sqrt() - 0.05;
        let shapes: [&dyn Implicit3; 3] = [&sphere, &slab, &tube];
        for (s, f) in shapes.into_iter().enumerate() {
            for h in [0.013, 0.05] {
                let b = [DVec3::new(-1.0, -0.9, -1.1), DVec3::new(1.0, 1.05, 0.9)];
                let exact = Grid3::sample(f, b[0], b[1], h).unwrap();
                let band = sample_band(f, b, h).unwrap();
                assert_eq!(exact.dims(), band.dims());
                let mut interpolated = 0;
                for (k, (&e, &v)) in exact.values().iter().zip(band.values()).enumerate() {
                    if e.abs() <= BAND_HALF_WIDTH * h {
                        assert_eq!(e, v, "shape {s} h {h} node {k}");
                    } else {
                        assert!(v.signum() == e.signum() && v.abs() > BAND_HALF_WIDTH * h, "shape {s} node {k}");
                    }
                    interpolated += usize::from(e != v);
                }
                println!("shape {s}, h {h}: {interpolated} of {} nodes interpolated", exact.values().len());
            }
        }
    }
}
