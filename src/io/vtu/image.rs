//! VTK XML ImageData (.vti): a regular grid's extent, origin and spacing, and one point-data
//! array of samples (ASCII, inline base64 or appended, as in .vtu files).

use super::decode::Stored;
use super::scan::{scan, Scanned, Tag};
use crate::io::grid_file::GridFile;
use crate::io::text::{perr, Tokens};
use crate::Error;

/// `n` numbers of attribute `key` of `t` (None when the attribute is absent).
fn numbers(t: &Tag, key: &str, n: usize, path: &str) -> Result<Option<Vec<f64>>, Error> {
    let Some(v) = t.get(key) else { return Ok(None) };
    let parsed: Option<Vec<f64>> = v.split_whitespace().map(|s| s.parse::<f64>().ok()).collect();
    match parsed {
        Some(p) if p.len() == n && p.iter().all(|x| x.is_finite()) => Ok(Some(p)),
        _ => Err(perr(path, t.line, format!("{} {key}={v:?} is not {n} finite numbers", t.name))),
    }
}

/// Reads a `.vti` file: the grid of its point-data array (the one named by PointData's
/// `Scalars`, or its only array).
pub(crate) fn read_image(bytes: &[u8], path: &str) -> Result<GridFile, Error> {
    let Scanned { layout, arrays, tags, last_line } = scan(bytes, path, "ImageData")?;
    let img = tags
        .iter()
        .find(|t| t.name == "ImageData")
        .ok_or_else(|| perr(path, last_line, "no ImageData element in the vti file"))?;
    let extent = numbers(img, "WholeExtent", 6, path)?
        .ok_or_else(|| perr(path, img.line, "ImageData needs a WholeExtent attribute"))?;
    if extent.iter().any(|e| e.fract() != 0.0) || (0..3).any(|k| extent[2 * k + 1] < extent[2 * k]) {
        return Err(perr(path, img.line, format!("WholeExtent {extent:?} is not three integer ranges lo hi")));
    }
    if let Some(piece) = tags.iter().find(|t| t.name == "Piece") {
        if let Some(e) = numbers(piece, "Extent", 6, path)? {
            if e != extent {
                return Err(perr(path, piece.line, format!("Piece Extent {e:?} is not the WholeExtent {extent:?}")));
            }
        }
    }
    let origin = numbers(img, "Origin", 3, path)?.unwrap_or(vec![0.0; 3]);
    let spacing = numbers(img, "Spacing", 3, path)?.unwrap_or(vec![1.0; 3]);
    if let Some(d) = numbers(img, "Direction", 9, path)? {
        if d != [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] {
            return Err(perr(
                path,
                img.line,
                format!("ImageData Direction {d:?} is not the identity (rotated images are not supported)"),
            ));
        }
    }
    let dims = [0, 1, 2].map(|k| (extent[2 * k + 1] - extent[2 * k]) as usize + 1);
    let dim = if dims[2] > 1 { 3 } else { 2 };
    let first = [0, 1, 2].map(|k| origin[k] + spacing[k] * extent[2 * k]);
    let point_data: Vec<_> = arrays.iter().filter(|a| a.parent == "PointData").collect();
    let scalars = tags.iter().find(|t| t.name == "PointData").and_then(|t| t.get("Scalars"));
    let array = match scalars {
        Some(name) => point_data.iter().find(|a| a.name == name).copied(),
        None if point_data.len() == 1 => Some(point_data[0]),
        None => None,
    }
    .ok_or_else(|| {
        let names: Vec<&str> = point_data.iter().map(|a| a.name.as_str()).collect();
        perr(
            path,
            last_line,
            match (scalars, names.is_empty()) {
                (_, true) => "the vti file has no PointData array".to_string(),
                (Some(s), false) => format!("PointData Scalars={s:?} names none of its arrays {names:?}"),
                (None, false) => {
                    format!("PointData has several arrays {names:?} and no Scalars attribute to choose one")
                }
            },
        )
    })?;
    if array.components != 1 {
        return Err(perr(
            path,
            array.line,
            format!("PointData {:?} has {} components, not 1", array.name, array.components),
        ));
    }
    let values = if array.stored == Stored::Ascii {
        let mut t = Tokens::new(&array.text, path, None, array.line);
        let mut v = Vec::with_capacity(t.remaining());
        while t.peek().is_some() {
            v.push(t.f64("grid value")?);
        }
        v
    } else {
        layout.floats(array)?
    };
    Ok(GridFile {
        dim,
        dims: if dim == 2 { [dims[0], dims[1], 1] } else { dims },
        values,
        origin: Some(first),
        spacing: Some([spacing[0], spacing[1], spacing[2]]),
        name: Some(array.name.clone()),
    })
}
