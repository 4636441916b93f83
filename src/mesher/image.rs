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

/// Pictures of more pixels than this are refused before decoding, whatever the memory: at
/// about 75 bytes a pixel for the distance and the sizes, 2^28 pixels already need 20 GB.
pub const MAX_PIXELS: u64 = 1 << 28;

/// What a PNG file's header (its IHDR chunk) claims, read without decoding anything.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PngHeader {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl PngHeader {
    /// Width times height.
    pub fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }
}

fn bad_png(name: &str, message: String) -> Error {
    Error::Parse { path: name.to_string(), line: 0, message }
}

/// Reads the header of a PNG file from its first bytes (33 are enough): the signature, then
/// the IHDR chunk with the width and height. `name` names the file in errors.
pub fn png_header(bytes: &[u8], name: &str) -> Result<PngHeader, Error> {
    const SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
    if bytes.len() < 8 || bytes[..8] != SIGNATURE {
        return Err(bad_png(name, "not a PNG picture (the file does not start with the PNG signature)".into()));
    }
    if bytes.len() < 24 || &bytes[12..16] != b"IHDR" {
        return Err(bad_png(name, "a truncated PNG picture: the header chunk (IHDR) is missing".into()));
    }
    let be = |k: usize| u32::from_be_bytes([bytes[k], bytes[k + 1], bytes[k + 2], bytes[k + 3]]);
    let (width, height) = (be(16), be(20));
    if width == 0 || height == 0 || width > i32::MAX as u32 || height > i32::MAX as u32 {
        return Err(bad_png(name, format!("the PNG header claims {width} x {height} pixels, which no PNG can have")));
    }
    Ok(PngHeader { width, height })
}

/// Reads the header of the PNG file at `path` (its first 33 bytes only).
pub fn read_png_header(path: &std::path::Path) -> Result<PngHeader, Error> {
    use std::io::Read;
    let name = path.display().to_string();
    let io = |e: std::io::Error| Error::Io { path: name.clone(), message: format!("cannot read the picture: {e}") };
    let mut head = Vec::with_capacity(33);
    std::fs::File::open(path).map_err(io)?.take(33).read_to_end(&mut head).map_err(io)?;
    png_header(&head, &name)
}

/// Grey levels in [0, 1] of a PNG picture in memory, row by row from the top, with its width
/// and height. The header is read first: a picture of more than [`MAX_PIXELS`] pixels is
/// refused before anything is decoded. `name` names the picture in errors.
pub fn decode_png_grey(bytes: &[u8], name: &str) -> Result<(Vec<f64>, usize, usize), Error> {
    let head = png_header(bytes, name)?;
    if head.pixels() > MAX_PIXELS {
        return Err(bad_png(
            name,
            format!(
                "the picture is {} x {} pixels ({:.2e}), past the {:.2e} pixels that can be meshed",
                head.width,
                head.height,
                head.pixels() as f64,
                MAX_PIXELS as f64
            ),
        ));
    }
    let pix = tiny_skia::Pixmap::decode_png(bytes)
        .map_err(|e| bad_png(name, format!("cannot decode the PNG picture: {e}")))?;
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

/// Grey levels in [0, 1] of a PNG file, row by row from the top, with its width and height
/// (see [`decode_png_grey`]; the header is checked before the rest of the file is read).
pub fn read_png_grey(path: &std::path::Path) -> Result<(Vec<f64>, usize, usize), Error> {
    let head = read_png_header(path)?;
    let name = path.display().to_string();
    if head.pixels() > MAX_PIXELS {
        // The same refusal as decode_png_grey's, without reading the file.
        return decode_png_grey(&png_header_bytes(head), &name);
    }
    let bytes = std::fs::read(path)
        .map_err(|e| Error::Io { path: name.clone(), message: format!("cannot read the picture: {e}") })?;
    decode_png_grey(&bytes, &name)
}

/// The first 24 bytes of a PNG with this header (enough for [`png_header`]).
fn png_header_bytes(h: PngHeader) -> Vec<u8> {
    let mut b = vec![0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n', 0, 0, 0, 13];
    b.extend_from_slice(b"IHDR");
    b.extend_from_slice(&h.width.to_be_bytes());
    b.extend_from_slice(&h.height.to_be_bytes());
    b
}

/// Fuzz body: decoding any bytes returns (a picture or an error) without panicking or
/// allocating for pixels the header only claims.
pub fn fuzz_decode_png(data: &[u8]) {
    // The refusal past MAX_PIXELS is checked without decoding; below it, pictures up to 2^22
    // pixels are decoded (a larger claim would only spend the fuzzer's memory limit).
    match png_header(data, "<fuzz>") {
        Ok(head) if head.pixels() > MAX_PIXELS => {
            assert!(decode_png_grey(data, "<fuzz>").is_err());
            return;
        }
        Ok(head) if head.pixels() > 1 << 22 => return,
        _ => {}
    }
    if let Ok((grey, w, h)) = decode_png_grey(data, "<fuzz>") {
        assert_eq!(grey.len(), w * h);
        assert!(grey.iter().all(|g| (0.0..=1.0).contains(g)));
        if w * h <= 4096 {
            let _ = image_distance(&grey, w, h, 0.5, false);
        }
    }
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
    if threshold.is_nan() || threshold <= 0.0 || threshold >= 1.0 {
        let why = if threshold >= 1.0 {
            format!("no pixel is brighter than {threshold}, so the mask would be empty (or, with --invert, all)")
        } else {
            format!("no pixel is darker than {threshold}, so nothing lies outside (or, with --invert, inside)")
        };
        return Err(Error::Invalid(format!(
            "the threshold {threshold} must lie strictly between 0 and 1: grey levels run from 0 (black) to 1 \
             (white), and {why}"
        )));
    }
    if let Some(v) = grey.iter().find(|v| !(0.0..=1.0).contains(*v)) {
        return Err(Error::Invalid(format!("a grey level of {v} is outside [0, 1]")));
    }
    let side = if invert { "darker" } else { "brighter" };
    let raw_inside = grey.iter().filter(|&&g| if invert { g < threshold } else { g > threshold }).count();
    let (lo_g, hi_g) = grey.iter().fold((1.0f64, 0.0f64), |(a, b), &g| (a.min(g), b.max(g)));
    if raw_inside == 0 {
        return Err(Error::EmptyDomain(format!(
            "no pixel of the picture is {side} than the threshold {threshold} (its grey levels run from {lo_g:.3} to \
             {hi_g:.3}): the mask is empty; choose a threshold inside that range{}",
            if invert { "" } else { ", or --invert to mesh the dark part" }
        )));
    }
    // A region whose every pixel lies within this of the threshold has no edge to find.
    const CONTRAST: f64 = 0.02;
    if grey.iter().all(|g| (g - threshold).abs() < CONTRAST) {
        return Err(Error::Invalid(format!(
            "the picture has no contrast at the threshold {threshold}: every grey level lies within {CONTRAST} of it \
             ({lo_g:.3} to {hi_g:.3}), so the region's edge cannot be found; mesh a picture with distinct bright and \
             dark parts"
        )));
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
            "the {raw_inside} pixel{} {side} than the threshold {threshold} form{} features under 3 pixels across, \
             which the 3 x 3 smoothing of the picture removes: nothing is left to mesh",
            if raw_inside == 1 { "" } else { "s" },
            if raw_inside == 1 { "s" } else { "" }
        )));
    }
    // Where most pixels have a neighbour on the other side, the pattern is finer than any
    // element (a checkerboard, noise): the region has no shape to mesh.
    let cross = |a: f64, b: f64| (a < 0.0) != (b < 0.0);
    let mut edges = 0usize;
    for j in PAD..h + PAD {
        for i in PAD..w + PAD {
            let v = phi[i + nx * j];
            if cross(v, phi[i + 1 + nx * j]) || cross(v, phi[i + nx * (j + 1)]) {
                edges += 1;
            }
        }
    }
    let fraction = edges as f64 / (w * h) as f64;
    if fraction > 0.25 {
        return Err(Error::Invalid(format!(
            "{:.0}% of the picture's pixels lie on an edge between inside and outside: its pattern (a checkerboard, \
             noise) is finer than a few pixels, and no mesh can follow it; smooth or simplify the picture first",
            100.0 * fraction
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
    fn declared_distance(&self) -> Option<bool> {
        Some(true)
    }
}

/// Meshes the region of an image: distance by fast marching, an automatic size function
/// (feature size and gradient limiting, seed chapter 4), then [`mesh_2d`].
pub fn mesh_image(grey: &[f64], w: usize, h: usize, opts: &ImageOptions) -> Result<MeshOutput2, Error> {
    mesh_image_checked(grey, w, h, opts, &|_| Ok(()))
}

/// [`mesh_image`], with `check` handed the mesher's estimate of the triangle count before
/// meshing starts (a memory budget refuses there, with an [`Error::OverBudget`]).
pub fn mesh_image_checked(
    grey: &[f64],
    w: usize,
    h: usize,
    opts: &ImageOptions,
    check: &dyn Fn(f64) -> Result<(), Error>,
) -> Result<MeshOutput2, Error> {
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
    // A ratio of 1 asks for uniform elements: no size function to build.
    let size = if opts.max_ratio > 1.0 {
        let params = SizeParams {
            k: 0.5 / opts.h0,
            r: 2.0,
            g: 0.3,
            hmin: opts.h0,
            hmax: opts.h0 * opts.max_ratio,
            ..SizeParams::default()
        };
        Some(auto_size_2d(&dist, [lo, hi], 1.0, &params)?)
    } else {
        None
    };
    let s = opts.scale;
    let domain = Scaled { g: &dist, s };
    let mut o = Options2::uniform(opts.h0 * s, [lo.x * s, lo.y * s], [hi.x * s, hi.y * s]);
    if let Some(size) = size {
        o = o.with_size(move |p| size.value(p / s));
    }
    check(super::estimated_elements(super::Survey::Planar(&domain, &o))?)?;
    mesh_2d(&domain, &o)
}
