//! Values on a regular grid from a file: a NumPy `.npy` array or a VTK ImageData `.vti` file
//! (the seed's example 1 from a grid, section 3.1: distances sampled on a Cartesian grid and
//! interpolated).
//!
//! The `.npy` reader is written here: the format (NumPy's NEP 1) is a short text header and one
//! flat array, and only its float32 and float64 arrays of two or three axes are needed. The
//! crates that read it (`npyz`, `ndarray-npy`, both MIT/Apache-2.0) bring their own type
//! traits and derive macros or the `ndarray` crate for that.

use crate::geometry::{Grid2, Grid3};
use crate::Error;
use glam::{DVec2, DVec3};
use std::path::Path;

/// Grid values as read from a file: samples per axis (x, y, z; z = 1 for a 2-D grid), the
/// values with x fastest, then y, and the origin and spacing if the file gives them.
#[derive(Clone, Debug, PartialEq)]
pub struct GridFile {
    /// 2 or 3.
    pub dim: usize,
    /// Samples along x, y and z.
    pub dims: [usize; 3],
    /// `values[i + nx * (j + ny * k)]` is the sample at `origin + spacing * (i, j, k)`.
    pub values: Vec<f64>,
    /// The first sample's position (`.vti` files give it; `.npy` files do not).
    pub origin: Option<[f64; 3]>,
    /// The spacing along each axis (`.vti` files give it; `.npy` files do not).
    pub spacing: Option<[f64; 3]>,
    /// The array's name (`.vti` point data).
    pub name: Option<String>,
}

fn bad(path: &str, message: impl Into<String>) -> Error {
    Error::Invalid(format!("{path}: {}", message.into()))
}

/// Whether `path` names a grid file this module reads (by its extension).
pub fn is_grid_file(path: &str) -> bool {
    let p = path.trim().to_ascii_lowercase();
    p.ends_with(".npy") || p.ends_with(".vti")
}

/// Reads a `.npy` or `.vti` grid file (by its extension).
pub fn read_grid_file(path: &Path) -> Result<GridFile, Error> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::Io { path: name.clone(), message: e.to_string() })?;
    let lower = name.to_ascii_lowercase();
    let g = if lower.ends_with(".npy") {
        read_npy(&bytes, &name)?
    } else if lower.ends_with(".vti") {
        super::vtu::read_image(&bytes, &name)?
    } else {
        return Err(bad(&name, "a grid file must end in .npy or .vti"));
    };
    g.check(&name)?;
    Ok(g)
}

impl GridFile {
    /// Checks the sample counts against the values and that every value is finite.
    pub fn check(&self, path: &str) -> Result<(), Error> {
        let axes = &self.dims[..self.dim];
        if !(2..=3).contains(&self.dim) || (self.dim == 2 && self.dims[2] != 1) {
            return Err(bad(path, format!("a grid of {:?} samples is neither 2-D nor 3-D", self.dims)));
        }
        if let Some(n) = axes.iter().find(|&&n| n < 2) {
            return Err(bad(path, format!("the grid has {n} sample(s) along an axis; at least 2 are needed")));
        }
        let total = axes.iter().try_fold(1usize, |a, &n| a.checked_mul(n));
        if total != Some(self.values.len()) {
            return Err(bad(
                path,
                match total {
                    Some(t) => {
                        format!("the grid's shape {axes:?} needs {t} values but the file holds {}", self.values.len())
                    }
                    None => format!("the grid's shape {axes:?} is too large"),
                },
            ));
        }
        if let Some(i) = self.values.iter().position(|v| !v.is_finite()) {
            let (nx, ny) = (self.dims[0], self.dims[1]);
            let at = [i % nx, (i / nx) % ny, i / (nx * ny)];
            return Err(bad(
                path,
                format!("the value at sample {:?} (x, y, z index) is {}", &at[..self.dim], self.values[i]),
            ));
        }
        Ok(())
    }

    /// The spacing: `given` (for files without one) or the file's own, which must be the same
    /// along every axis (the grids are square or cubic).
    fn spacing_or(&self, given: Option<f64>, path: &str) -> Result<f64, Error> {
        let h = match (self.spacing, given) {
            (_, Some(h)) => h,
            (Some(s), None) => {
                let s = &s[..self.dim];
                if s.iter().any(|&v| (v - s[0]).abs() > 1e-9 * s[0].abs()) {
                    return Err(bad(
                        path,
                        format!("the grid's spacing {s:?} differs between axes; it must be one number"),
                    ));
                }
                s[0]
            }
            (None, None) => return Err(bad(path, "a .npy file has no spacing: give --spacing H")),
        };
        if !(h.is_finite() && h > 0.0) {
            return Err(bad(path, format!("grid spacing {h} is not positive and finite")));
        }
        Ok(h)
    }

    fn origin_or(&self, given: Option<[f64; 3]>) -> [f64; 3] {
        given.or(self.origin).unwrap_or([0.0; 3])
    }

    /// The box the samples cover: the first sample to the last.
    pub fn extent(&self, origin: Option<[f64; 3]>, spacing: Option<f64>, path: &str) -> Result<[[f64; 3]; 2], Error> {
        let (o, h) = (self.origin_or(origin), self.spacing_or(spacing, path)?);
        let mut hi = o;
        for k in 0..self.dim {
            hi[k] = o[k] + h * (self.dims[k] - 1) as f64;
        }
        Ok([o, hi])
    }

    /// As a 2-D grid (origin and spacing given, or the file's own).
    pub fn to_grid2(&self, origin: Option<[f64; 3]>, spacing: Option<f64>, path: &str) -> Result<Grid2, Error> {
        if self.dim != 2 {
            return Err(bad(path, format!("the grid is {}-D, not 2-D", self.dim)));
        }
        let (o, h) = (self.origin_or(origin), self.spacing_or(spacing, path)?);
        Grid2::new(DVec2::new(o[0], o[1]), h, self.dims[0], self.dims[1], self.values.clone())
    }

    /// As a 3-D grid (origin and spacing given, or the file's own).
    pub fn to_grid3(&self, origin: Option<[f64; 3]>, spacing: Option<f64>, path: &str) -> Result<Grid3, Error> {
        if self.dim != 3 {
            return Err(bad(path, format!("the grid is {}-D, not 3-D", self.dim)));
        }
        let (o, h) = (self.origin_or(origin), self.spacing_or(spacing, path)?);
        Grid3::new(DVec3::from_array(o), h, self.dims, self.values.clone())
    }
}

/// The value of `key` in the header's Python dict literal, as its source text.
fn dict_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let at = header.find(&format!("'{key}'")).or_else(|| header.find(&format!("\"{key}\"")))?;
    let rest = header[at + key.len() + 2..].trim_start().strip_prefix(':')?.trim_start();
    let end = if rest.starts_with('(') {
        rest.find(')')? + 1
    } else if let Some(q) = rest.chars().next().filter(|c| *c == '\'' || *c == '"') {
        rest[1..].find(q)? + 2
    } else {
        rest.find([',', '}']).unwrap_or(rest.len())
    };
    Some(rest[..end].trim())
}

/// A `.npy` array (format versions 1 to 3): float32 or float64 of either byte order, 2 or 3
/// axes, C or Fortran order. The axes are (y, x) or (z, y, x), as `numpy.meshgrid(x, y)` makes
/// them and as an image is stored: the last axis is x.
pub fn read_npy(bytes: &[u8], path: &str) -> Result<GridFile, Error> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(bad(path, "not a .npy file (no \\x93NUMPY magic)"));
    }
    let (len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10usize),
        2 | 3 if bytes.len() >= 12 => (u32::from_le_bytes(bytes[8..12].try_into().expect("4")) as usize, 12),
        v => return Err(bad(path, format!(".npy format version {v} is not 1, 2 or 3 (or the file is truncated)"))),
    };
    let header = bytes
        .get(start..start.saturating_add(len))
        .ok_or_else(|| bad(path, format!("the header claims {len} bytes; the file ends first (truncated)")))?;
    let header = std::str::from_utf8(header).map_err(|_| bad(path, "the .npy header is not text"))?;
    let descr = dict_value(header, "descr")
        .ok_or_else(|| bad(path, format!("the header has no 'descr': {header:?}")))?
        .trim_matches(['\'', '"']);
    let (width, big) = match descr {
        "<f8" | "=f8" | "f8" => (8, false),
        ">f8" => (8, true),
        "<f4" | "=f4" | "f4" => (4, false),
        ">f4" => (4, true),
        d => return Err(bad(path, format!("dtype {d:?} is not float32 or float64 ('<f4', '<f8', or big-endian)"))),
    };
    let fortran = match dict_value(header, "fortran_order") {
        Some("True") => true,
        Some("False") => false,
        v => return Err(bad(path, format!("'fortran_order' is {v:?}, not True or False"))),
    };
    let shape_text = dict_value(header, "shape").ok_or_else(|| bad(path, "the header has no 'shape'"))?;
    let shape: Vec<usize> = shape_text
        .trim_matches(['(', ')'])
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>().map_err(|_| bad(path, format!("bad shape {shape_text}"))))
        .collect::<Result<_, _>>()?;
    if !(2..=3).contains(&shape.len()) {
        return Err(bad(path, format!("the array has shape {shape_text}: a grid needs 2 or 3 axes")));
    }
    let count = shape.iter().try_fold(1usize, |a, &n| a.checked_mul(n)).ok_or_else(|| bad(path, "shape too large"))?;
    let data = &bytes[start + len..];
    if data.len() != count.saturating_mul(width) {
        return Err(bad(
            path,
            format!(
                "shape {shape_text} of {descr} needs {} bytes of data, the file holds {}{}",
                count.saturating_mul(width),
                data.len(),
                if data.len() < count.saturating_mul(width) { " (truncated)" } else { "" }
            ),
        ));
    }
    let flat: Vec<f64> = data
        .chunks_exact(width)
        .map(|c| match (width, big) {
            (8, false) => f64::from_le_bytes(c.try_into().expect("8")),
            (8, true) => f64::from_be_bytes(c.try_into().expect("8")),
            (_, false) => f32::from_le_bytes(c.try_into().expect("4")) as f64,
            (_, true) => f32::from_be_bytes(c.try_into().expect("4")) as f64,
        })
        .collect();
    // Axes in array order are (y, x) or (z, y, x): reversed, they are x, y (, z).
    let dim = shape.len();
    let mut dims = [1usize; 3];
    for k in 0..dim {
        dims[k] = shape[dim - 1 - k];
    }
    let values = if fortran {
        // Fortran order: the first array axis (y or z) is fastest; x is slowest.
        let (nx, ny, nz) = (dims[0], dims[1], dims[2]);
        let mut v = vec![0.0; count];
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let src = if dim == 2 { j + ny * i } else { k + nz * (j + ny * i) };
                    v[i + nx * (j + ny * k)] = flat[src];
                }
            }
        }
        v
    } else {
        flat
    };
    Ok(GridFile { dim, dims, values, origin: None, spacing: None, name: None })
}

/// The bytes of a `.npy` file (version 1, little-endian float64, C order) holding `values`
/// (x fastest) on a grid of `dims` samples (z = 1 for 2-D): the inverse of [`read_npy`].
pub fn npy_bytes(dims: [usize; 3], dim: usize, values: &[f64]) -> Vec<u8> {
    let shape = if dim == 2 {
        format!("({}, {})", dims[1], dims[0])
    } else {
        format!("({}, {}, {})", dims[2], dims[1], dims[0])
    };
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}");
    // Data starts on a multiple of 64 bytes; the header ends in a newline.
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_round_trip_and_orders() {
        let values: Vec<f64> = (0..12).map(|i| i as f64 * 0.5).collect();
        let b = npy_bytes([4, 3, 1], 2, &values);
        let g = read_npy(&b, "a.npy").unwrap();
        assert_eq!((g.dim, g.dims, &g.values), (2, [4, 3, 1], &values));
        // The same array in Fortran order, float32, big-endian.
        let mut f = b"\x93NUMPY\x01\x00".to_vec();
        let h = "{'descr': '>f4', 'fortran_order': True, 'shape': (3, 4), }\n";
        f.extend_from_slice(&(h.len() as u16).to_le_bytes());
        f.extend_from_slice(h.as_bytes());
        for i in 0..4 {
            for j in 0..3 {
                f.extend_from_slice(&(values[i + 4 * j] as f32).to_be_bytes());
            }
        }
        let g = read_npy(&f, "f.npy").unwrap();
        assert_eq!(g.values, values);
        assert!(read_npy(&b[..b.len() - 3], "t.npy").is_err());
        let ints = String::from_utf8_lossy(&b).replace("<f8", "<i8");
        assert!(read_npy(ints.as_bytes(), "i.npy").is_err());
    }
}
