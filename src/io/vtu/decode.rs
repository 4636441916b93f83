//! Binary data arrays of a .vtu file: inline base64 and appended (raw or base64) blocks,
//! either byte order, UInt32 or UInt64 size headers, any VTK scalar type.

use super::super::binary::base64_decode;
use super::super::text::perr;
use crate::Error;

/// Where an array's numbers are.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum Stored {
    /// Whitespace-separated text.
    Ascii,
    /// Inline base64 text.
    Base64,
    /// In the appended block, at this offset.
    Appended(usize),
}

/// One data array as found in the file.
pub(super) struct Array {
    pub parent: String,
    pub name: String,
    pub components: usize,
    pub text: String,
    pub line: usize,
    pub stored: Stored,
    pub vtk_type: String,
}

/// The appended block of a file, if any, and how it is encoded.
pub(super) struct Appended<'a> {
    pub data: &'a [u8],
    pub base64: bool,
}

/// Byte width of a VTK scalar type and whether it is floating point.
pub(super) fn type_width(t: &str) -> Option<(usize, bool)> {
    Some(match t {
        "Float64" => (8, true),
        "Float32" => (4, true),
        "Int8" | "UInt8" => (1, false),
        "Int16" | "UInt16" => (2, false),
        "Int32" | "UInt32" => (4, false),
        "Int64" | "UInt64" => (8, false),
        _ => return None,
    })
}

/// Settings of the whole file the binary decoding needs.
pub(super) struct Layout<'a> {
    pub header_bytes: usize,
    pub big_endian: bool,
    pub appended: Option<Appended<'a>>,
    pub path: &'a str,
}

impl Layout<'_> {
    /// The raw bytes of a binary array (without its size header), in file byte order.
    fn raw(&self, a: &Array) -> Result<Vec<u8>, Error> {
        let hb = self.header_bytes;
        let bad = |m: String| perr(self.path, a.line, format!("DataArray {:?}: {m}", a.name));
        let size_of = |h: &[u8]| -> usize {
            let mut b = [0u8; 8];
            if self.big_endian {
                b[8 - hb..].copy_from_slice(h);
                u64::from_be_bytes(b) as usize
            } else {
                b[..hb].copy_from_slice(h);
                u64::from_le_bytes(b) as usize
            }
        };
        let split = |mut bytes: Vec<u8>| -> Result<Vec<u8>, Error> {
            if bytes.len() < hb {
                return Err(bad("binary data shorter than its size header".into()));
            }
            let n = size_of(&bytes[..hb]);
            if bytes.len() - hb < n {
                return Err(bad(format!("size header says {n} bytes but {} follow", bytes.len() - hb)));
            }
            bytes.truncate(hb + n);
            bytes.drain(..hb);
            Ok(bytes)
        };
        match a.stored {
            Stored::Ascii => unreachable!("ASCII arrays are tokenised, not decoded"),
            Stored::Base64 => {
                split(base64_decode(a.text.as_bytes(), hb).ok_or_else(|| bad("invalid base64 text".into()))?)
            }
            Stored::Appended(off) => {
                let ap = self.appended.as_ref().ok_or_else(|| bad("format=\"appended\" but no AppendedData".into()))?;
                let rest = ap.data.get(off..).ok_or_else(|| bad(format!("offset {off} is past the appended data")))?;
                if !ap.base64 {
                    let h = rest.get(..hb).ok_or_else(|| bad(format!("offset {off}: no size header")))?;
                    let n = size_of(h);
                    let d = rest
                        .get(hb..hb.saturating_add(n))
                        .ok_or_else(|| bad(format!("offset {off}: {n} bytes claimed, the file ends first")))?;
                    return Ok(d.to_vec());
                }
                let hchars = hb.div_ceil(3) * 4;
                let head = rest
                    .get(..hchars)
                    .and_then(|t| base64_decode(t, hb))
                    .ok_or_else(|| bad(format!("offset {off}: no base64 size header")))?;
                let n = size_of(&head[..hb.min(head.len())]);
                let together = (hb + n).div_ceil(3) * 4;
                if let Some(v) = rest.get(..together).and_then(|t| base64_decode(t, hb)) {
                    if v.len() >= hb + n {
                        return split(v);
                    }
                }
                let data = rest
                    .get(hchars..hchars + n.div_ceil(3) * 4)
                    .and_then(|t| base64_decode(t, 0))
                    .ok_or_else(|| bad(format!("offset {off}: {n} bytes of base64 claimed, not found")))?;
                Ok(data[..n.min(data.len())].to_vec())
            }
        }
    }

    /// A binary array's values as f64 (integers converted exactly where they fit).
    pub fn floats(&self, a: &Array) -> Result<Vec<f64>, Error> {
        self.decode(a, |x: Num| match x {
            Num::F(v) => Some(v),
            Num::I(v) => Some(v as f64),
        })
    }

    /// A binary array's values as integers (floats only when integral).
    pub fn ints(&self, a: &Array) -> Result<Vec<i64>, Error> {
        self.decode(a, |x: Num| match x {
            Num::I(v) => Some(v),
            Num::F(v) => (v.fract() == 0.0 && v.abs() < 9.0e15).then_some(v as i64),
        })
    }

    fn decode<T>(&self, a: &Array, conv: impl Fn(Num) -> Option<T>) -> Result<Vec<T>, Error> {
        let (w, float) = type_width(&a.vtk_type)
            .ok_or_else(|| perr(self.path, a.line, format!("DataArray type {:?} is not supported", a.vtk_type)))?;
        let raw = self.raw(a)?;
        if raw.len() % w != 0 {
            return Err(perr(
                self.path,
                a.line,
                format!("{} bytes is not a whole number of {}", raw.len(), a.vtk_type),
            ));
        }
        let signed = a.vtk_type.starts_with("Int");
        let mut out = Vec::with_capacity(raw.len() / w);
        for (i, c) in raw.chunks_exact(w).enumerate() {
            let mut b = [0u8; 8];
            if self.big_endian {
                b[..w].copy_from_slice(c);
                b[..w].reverse();
            } else {
                b[..w].copy_from_slice(c);
            }
            let x = if float {
                let v = if w == 8 {
                    f64::from_le_bytes(b)
                } else {
                    f32::from_le_bytes(b[..4].try_into().expect("4")) as f64
                };
                Num::F(v)
            } else if signed && b[w - 1] & 0x80 != 0 {
                for byte in b.iter_mut().skip(w) {
                    *byte = 0xff;
                }
                Num::I(i64::from_le_bytes(b))
            } else {
                let u = u64::from_le_bytes(b);
                match i64::try_from(u) {
                    Ok(v) => Num::I(v),
                    Err(_) => Num::F(f64::INFINITY),
                }
            };
            let bad_value = matches!(x, Num::F(v) if !v.is_finite());
            match (bad_value, conv(x)) {
                (false, Some(v)) => out.push(v),
                _ => {
                    return Err(perr(
                        self.path,
                        a.line,
                        format!("DataArray {:?}: value {i} is not a valid {}", a.name, a.vtk_type),
                    ))
                }
            }
        }
        Ok(out)
    }
}

/// A decoded scalar.
#[derive(Clone, Copy)]
pub(super) enum Num {
    F(f64),
    I(i64),
}

pub(super) fn find_bytes(hay: &[u8], needle: &[u8], from: usize) -> Option<usize> {
    hay.get(from..)?.windows(needle.len()).position(|w| w == needle).map(|i| i + from)
}

/// Cuts the appended block out of the file (raw data is not XML) and returns the XML with an
/// empty `<AppendedData/>` in its place.
pub(super) fn split_appended<'a>(bytes: &'a [u8], path: &str) -> Result<(String, Option<Appended<'a>>), Error> {
    let text = |b: &[u8]| {
        String::from_utf8(b.to_vec()).map_err(|e| {
            let line = 1 + b[..e.utf8_error().valid_up_to()].iter().filter(|&&c| c == b'\n').count();
            perr(path, line, "the XML part of the file is not UTF-8 text")
        })
    };
    let Some(start) = find_bytes(bytes, b"<AppendedData", 0) else {
        return Ok((text(bytes)?, None));
    };
    let line = 1 + bytes[..start].iter().filter(|&&c| c == b'\n').count();
    let close = find_bytes(bytes, b">", start).ok_or_else(|| perr(path, line, "unterminated <AppendedData> tag"))?;
    let tag = String::from_utf8_lossy(&bytes[start..close]).into_owned();
    let base64 = match tag.split("encoding=").nth(1).map(|v| v.trim_start_matches(['"', '\'']).to_string()) {
        Some(v) if v.starts_with("raw") => false,
        Some(v) if v.starts_with("base64") => true,
        Some(v) => return Err(perr(path, line, format!("AppendedData encoding {v:?} is not raw or base64"))),
        None => false,
    };
    let mark = find_bytes(bytes, b"_", close).ok_or_else(|| perr(path, line, "AppendedData without its '_' mark"))?;
    let end_tag = b"</AppendedData>";
    let end = bytes
        .windows(end_tag.len())
        .rposition(|w| w == end_tag)
        .filter(|&e| e > mark)
        .ok_or_else(|| perr(path, line, "AppendedData is not closed (truncated file?)"))?;
    let mut data = &bytes[mark + 1..end];
    if base64 {
        while let [rest @ .., last] = data {
            if !last.is_ascii_whitespace() {
                break;
            }
            data = rest;
        }
    }
    let mut xml = text(&bytes[..start])?;
    xml.push_str("<AppendedData/>");
    xml.push_str(&text(&bytes[end + end_tag.len()..])?);
    Ok((xml, Some(Appended { data, base64 })))
}
