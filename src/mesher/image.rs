//! Meshing images (seed section 5.3): a grey or binary picture becomes a smoothed implicit
//! function, a signed distance by fast marching, an automatic size function, and a mesh.
//!
//! Coordinates are in pixels with the origin at the image's top-left corner, x to the right
//! and y down (pixel (i, j) has its centre at (i + 0.5, j + 0.5)), scaled by `scale`.

use super::{mesh_2d, MeshOutput2, Options2};
use crate::geometry::{Grid2, Grid3, Implicit2};
use crate::size::{auto_size_2d, reinitialize_2d, SizeParams};
use crate::Error;
use glam::{DVec2, DVec3};

/// Options of [`mesh_image`].
#[derive(Clone, Debug)]
pub struct ImageOptions {
    /// Grey level in [0, 1] that separates inside from outside.
    pub threshold: f64,
    /// Inside is darker than the threshold instead of brighter.
    pub invert: bool,
    /// Smallest edge length, in pixels (before scaling).
    pub h0: f64,
    /// Largest edge length over the smallest.
    pub max_ratio: f64,
    /// Size of a pixel in output units.
    pub scale: f64,
}

impl Default for ImageOptions {
    fn default() -> Self {
        ImageOptions { threshold: 0.5, invert: false, h0: 4.0, max_ratio: 4.0, scale: 1.0 }
    }
}

/// Grey levels in [0, 1] of a PNG file, row by row from the top, with its width and height.
pub fn read_png_grey(path: &std::path::Path) -> Result<(Vec<f64>, usize, usize), Error> {
    let pix = tiny_skia::Pixmap::load_png(path).map_err(|e| Error::Io {
        path: path.display().to_string(),
        message: format!("cannot read the PNG image: {e}"),
    })?;
    let (w, h) = (pix.width() as usize, pix.height() as usize);
    let grey = pix
        .pixels()
        .iter()
        .map(|c| {
            let c = c.demultiply();
            // Transparent pixels count as black.
            let a = c.alpha() as f64 / 255.0;
            a * (0.299 * c.red() as f64 + 0.587 * c.green() as f64 + 0.114 * c.blue() as f64) / 255.0
        })
        .collect();
    Ok((grey, w, h))
}

/// The signed distance (in pixels) of the region of `grey` (w x h, row by row from the top)
/// brighter than `threshold` (darker when `invert`): phi = threshold - grey, smoothed once by a
/// 3 x 3 box filter, padded with outside pixels, reinitialised by fast marching.
pub fn image_distance(grey: &[f64], w: usize, h: usize, threshold: f64, invert: bool) -> Result<Grid2, Error> {
    if w < 2 || h < 2 || grey.len() != w * h {
        return Err(Error::Invalid(format!(
            "an image of {w} x {h} pixels with {} values cannot be meshed",
            grey.len()
        )));
    }
    if !(0.0..=1.0).contains(&threshold) {
        return Err(Error::Invalid(format!("threshold {threshold} is outside [0, 1]")));
    }
    const PAD: usize = 3;
    let (nx, ny) = (w + 2 * PAD, h + 2 * PAD);
    let level = |i: usize, j: usize| -> f64 {
        if i < PAD || j < PAD || i >= w + PAD || j >= h + PAD {
            return 1.0; // outside
        }
        let g = grey[(i - PAD) + w * (j - PAD)];
        if invert {
            g - threshold
        } else {
            threshold - g
        }
    };
    let mut phi = vec![0.0; nx * ny];
    let mut inside = 0usize;
    for j in 0..ny {
        for i in 0..nx {
            // Box filter over the 3 x 3 neighbourhood (clamped at the border).
            let mut s = 0.0;
            for dj in -1i64..=1 {
                for di in -1i64..=1 {
                    let (ii, jj) = (
                        (i as i64 + di).clamp(0, nx as i64 - 1) as usize,
                        (j as i64 + dj).clamp(0, ny as i64 - 1) as usize,
                    );
                    s += level(ii, jj);
                }
            }
            phi[i + nx * j] = s / 9.0;
            if phi[i + nx * j] < 0.0 {
                inside += 1;
            }
        }
    }
    if inside == 0 {
        return Err(Error::EmptyDomain(format!(
            "no pixel is {} than the threshold {threshold}: the mask is empty",
            if invert { "darker" } else { "brighter" }
        )));
    }
    // Pixel centres at (i + 0.5, j + 0.5) in image coordinates.
    let origin = DVec2::new(0.5 - PAD as f64, 0.5 - PAD as f64);
    let raw = Grid2::new(origin, 1.0, nx, ny, phi)?.with_distance(false);
    Ok(reinitialize_2d(&raw))
}

/// The signed distance (in voxels) of the region of a stack of slices (`grey`, w x h x d,
/// x fastest, then y, then slice) brighter than `threshold`: as [`image_distance`], phi =
/// threshold - grey smoothed by a 3 x 3 x 3 box filter, padded with outside voxels,
/// reinitialised by fast marching. Voxel centres lie at (i + 0.5, j + 0.5, k + 0.5).
pub fn stack_distance(grey: &[f64], w: usize, h: usize, d: usize, threshold: f64) -> Result<Grid3, Error> {
    if w < 2 || h < 2 || d < 2 || w.checked_mul(h).and_then(|n| n.checked_mul(d)) != Some(grey.len()) {
        return Err(Error::Invalid(format!(
            "a stack of {w} x {h} x {d} voxels with {} values cannot be meshed",
            grey.len()
        )));
    }
    if !(0.0..=1.0).contains(&threshold) {
        return Err(Error::Invalid(format!("threshold {threshold} is outside [0, 1]")));
    }
    if let Some(v) = grey.iter().find(|v| !v.is_finite()) {
        return Err(Error::NonFinite { what: "a voxel value", value: *v, at: [0.0; 3] });
    }
    const PAD: usize = 3;
    let n = [w + 2 * PAD, h + 2 * PAD, d + 2 * PAD];
    let level = |i: usize, j: usize, k: usize| -> f64 {
        if i < PAD || j < PAD || k < PAD || i >= w + PAD || j >= h + PAD || k >= d + PAD {
            return 1.0;
        }
        threshold - grey[(i - PAD) + w * ((j - PAD) + h * (k - PAD))]
    };
    let clamp = |x: usize, dx: i64, n: usize| (x as i64 + dx).clamp(0, n as i64 - 1) as usize;
    let mut phi = vec![0.0; n[0] * n[1] * n[2]];
    let mut inside = 0usize;
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let mut s = 0.0;
                for dk in -1i64..=1 {
                    for dj in -1i64..=1 {
                        for di in -1i64..=1 {
                            s += level(clamp(i, di, n[0]), clamp(j, dj, n[1]), clamp(k, dk, n[2]));
                        }
                    }
                }
                let v = s / 27.0;
                phi[i + n[0] * (j + n[1] * k)] = v;
                if v < 0.0 {
                    inside += 1;
                }
            }
        }
    }
    if inside == 0 {
        return Err(Error::EmptyDomain(format!(
            "no voxel is brighter than the threshold {threshold}: the mask is empty"
        )));
    }
    let origin = DVec3::splat(0.5 - PAD as f64);
    let raw = Grid3::new(origin, 1.0, n, phi)?.with_distance(false);
    Ok(crate::size::reinitialize_3d(&raw))
}

/// A scaled copy of a distance in pixels.
struct Scaled<'a> {
    g: &'a Grid2,
    s: f64,
}

impl Implicit2 for Scaled<'_> {
    fn value(&self, p: DVec2) -> f64 {
        self.g.value(p / self.s) * self.s
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        self.g.gradient(p / self.s)
    }
    fn is_distance(&self) -> bool {
        true
    }
}

/// Meshes the region of an image: distance by fast marching, an automatic size function
/// (feature size and gradient limiting, seed chapter 4), then [`mesh_2d`].
pub fn mesh_image(grey: &[f64], w: usize, h: usize, opts: &ImageOptions) -> Result<MeshOutput2, Error> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    // NaN fails every comparison: a ratio of NaN is refused with the rest.
    let ratio_ok = opts.max_ratio.partial_cmp(&1.0).is_some_and(|o| o.is_ge());
    if !(positive(opts.h0) && positive(opts.scale) && ratio_ok) {
        return Err(Error::BadSize(format!(
            "h0 {} and scale {} must be positive and the size ratio {} at least 1",
            opts.h0, opts.scale, opts.max_ratio
        )));
    }
    let dist = image_distance(grey, w, h, opts.threshold, opts.invert)?;
    let lo = DVec2::new(-1.0, -1.0);
    let hi = DVec2::new(w as f64 + 1.0, h as f64 + 1.0);
    let params = SizeParams {
        k: 0.5 / opts.h0,
        r: 2.0,
        g: 0.3,
        hmin: opts.h0,
        hmax: opts.h0 * opts.max_ratio,
        ..SizeParams::default()
    };
    let size = auto_size_2d(&dist, [lo, hi], 1.0, &params)?;
    let s = opts.scale;
    let domain = Scaled { g: &dist, s };
    let mut o = Options2::uniform(opts.h0 * s, [lo.x * s, lo.y * s], [hi.x * s, hi.y * s]);
    o = o.with_size(move |p| size.value(p / s));
    mesh_2d(&domain, &o)
}
