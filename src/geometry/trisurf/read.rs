//! Triangle meshes from files: binary STL and binary PLY here, the text formats (ASCII STL,
//! OBJ, ASCII PLY, Medit .mesh, Gmsh .msh, VTU, JSON) through [`crate::io`]; a tetrahedral mesh
//! gives its boundary triangles.

use crate::io::{read_mesh_bytes, CellType, Format, MeshData};
use crate::Error;
use std::path::Path;

/// Plain arrays: vertex coordinates and triangles.
pub type Arrays = (Vec<[f64; 3]>, Vec<[usize; 3]>);

fn perr(name: &str, message: impl Into<String>) -> Error {
    Error::Parse { path: name.to_string(), line: 0, message: message.into() }
}

/// Reads the triangles of a file, the format from its extension (.stl .obj .ply .mesh .msh .vtu .json).
pub fn read_triangles(path: &Path) -> Result<Arrays, Error> {
    let name = path.display().to_string();
    let format = Format::from_path(path)?;
    let bytes = std::fs::read(path).map_err(|e| Error::Io { path: name.clone(), message: e.to_string() })?;
    triangles_from_bytes(&bytes, format, &name)
}

/// [`read_triangles`] from memory; `name` names the source in errors.
pub fn triangles_from_bytes(bytes: &[u8], format: Format, name: &str) -> Result<Arrays, Error> {
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(perr(name, "the file is empty"));
    }
    match format {
        Format::Stl if !bytes.starts_with(b"solid") || binary_stl_size_matches(bytes) => binary_stl(bytes, name),
        Format::Ply if ply_is_binary(bytes) => binary_ply(bytes, name),
        _ => {
            let m = read_mesh_bytes(bytes, format).map_err(|e| match e {
                Error::Parse { line, message, .. } => Error::Parse { path: name.to_string(), line, message },
                e => e,
            })?;
            Ok(from_mesh_data(&m))
        }
    }
}

/// The triangles of a mesh: its cells, or a tet mesh's boundary faces (oriented outward).
pub fn from_mesh_data(m: &MeshData) -> Arrays {
    let tris = match m.cell_type {
        CellType::Triangle => (0..m.num_cells()).map(|i| m.cell(i)).map(|c| [c[0], c[1], c[2]]).collect(),
        CellType::Tetra => m.boundary_facets().into_iter().map(|f| [f[0], f[1], f[2]]).collect(),
    };
    (m.points.clone(), tris)
}

fn binary_stl_size_matches(bytes: &[u8]) -> bool {
    bytes.len() >= 84
        && 84 + 50 * u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64 == bytes.len() as u64
}

/// Binary STL: an 80-byte header, a little-endian u32 count, then per triangle a normal and
/// three corners (f32) and two attribute bytes. The count must match the size exactly.
fn binary_stl(bytes: &[u8], name: &str) -> Result<Arrays, Error> {
    if bytes.len() < 84 {
        return Err(perr(
            name,
            format!("a binary STL file needs at least 84 bytes (header and count), this one has {}", bytes.len()),
        ));
    }
    let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
    let want = 84 + 50 * count;
    if want != bytes.len() as u64 {
        return Err(perr(
            name,
            format!(
                "the binary STL header claims {count} triangles, which need {want} bytes, but the file has {} bytes \
                 (truncated or not an STL file)",
                bytes.len()
            ),
        ));
    }
    if count == 0 {
        return Err(perr(name, "the binary STL file holds no triangles"));
    }
    let f = |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]) as f64;
    let mut points = Vec::with_capacity(3 * count as usize);
    let mut tris = Vec::with_capacity(count as usize);
    for t in 0..count as usize {
        let o = 84 + 50 * t + 12;
        for k in 0..3 {
            let q = o + 12 * k;
            points.push([f(q), f(q + 4), f(q + 8)]);
        }
        tris.push([3 * t, 3 * t + 1, 3 * t + 2]);
    }
    Ok((points, tris))
}

fn ply_header(bytes: &[u8]) -> Option<(&str, usize)> {
    let end = bytes.windows(10).position(|w| w == b"end_header")?;
    let mut stop = end + 10;
    // The header ends with the newline after end_header (\n or \r\n).
    while stop < bytes.len() && bytes[stop] != b'\n' {
        stop += 1;
    }
    let text = std::str::from_utf8(&bytes[..end]).ok()?;
    Some((text, (stop + 1).min(bytes.len())))
}

fn ply_is_binary(bytes: &[u8]) -> bool {
    ply_header(bytes).is_some_and(|(h, _)| h.lines().any(|l| l.trim_start().starts_with("format binary")))
}

/// A PLY scalar type's size in bytes.
fn ply_size(ty: &str) -> Option<usize> {
    Some(match ty {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "int32" | "uint32" | "float" | "float32" => 4,
        "double" | "float64" => 8,
        _ => return None,
    })
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    big: bool,
    name: &'a str,
}

impl Reader<'_> {
    fn read(&mut self, ty: &str) -> Result<f64, Error> {
        let n = ply_size(ty).ok_or_else(|| perr(self.name, format!("unknown PLY type {ty:?}")))?;
        if self.pos + n > self.bytes.len() {
            return Err(perr(self.name, "the binary PLY data ends early (truncated file)"));
        }
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(&self.bytes[self.pos..self.pos + n]);
        if self.big {
            b[..n].reverse();
        }
        self.pos += n;
        Ok(match ty {
            "char" | "int8" => b[0] as i8 as f64,
            "uchar" | "uint8" => b[0] as f64,
            "short" | "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
            "ushort" | "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
            "int" | "int32" => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            "uint" | "uint32" => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            "float" | "float32" => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            _ => f64::from_le_bytes(b),
        })
    }
}

/// One property: its name, its type, and for lists the type of the count.
type Prop = (String, String, Option<String>);

/// Binary PLY (little or big endian): vertices with x, y, z, faces with a vertex_indices list
/// (polygons fanned into triangles); other elements and properties skipped.
fn binary_ply(bytes: &[u8], name: &str) -> Result<Arrays, Error> {
    let Some((header, data)) = ply_header(bytes) else {
        return Err(perr(name, "the PLY header has no end_header"));
    };
    let big = header.lines().any(|l| l.trim_start().starts_with("format binary_big_endian"));
    let mut elements: Vec<(String, usize, Vec<Prop>)> = Vec::new();
    for line in header.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["element", n, c] => {
                let count = c.parse().map_err(|_| perr(name, format!("bad PLY element count {c:?}")))?;
                elements.push((n.to_string(), count, Vec::new()));
            }
            ["property", "list", ct, it, n] => match elements.last_mut() {
                Some(e) => e.2.push((n.to_string(), it.to_string(), Some(ct.to_string()))),
                None => return Err(perr(name, "a PLY property before any element")),
            },
            ["property", ty, n] => match elements.last_mut() {
                Some(e) => e.2.push((n.to_string(), ty.to_string(), None)),
                None => return Err(perr(name, "a PLY property before any element")),
            },
            _ => {}
        }
    }
    let mut r = Reader { bytes, pos: data, big, name };
    let (mut points, mut tris) = (Vec::new(), Vec::new());
    for (el, count, props) in &elements {
        // Every entry takes at least one byte: refuse counts the file cannot hold before reserving.
        if *count > bytes.len() {
            return Err(perr(name, format!("PLY element {el} claims {count} entries, more than the file holds")));
        }
        for _ in 0..*count {
            let mut p = [0.0; 3];
            for (pn, ty, list) in props {
                match list {
                    Some(ct) => {
                        let n = r.read(ct)?;
                        if !(0.0..=1e6).contains(&n) {
                            return Err(perr(name, format!("bad PLY list length {n}")));
                        }
                        let vals = (0..n as usize).map(|_| r.read(ty)).collect::<Result<Vec<f64>, Error>>()?;
                        if el == "face" && (pn == "vertex_indices" || pn == "vertex_index") {
                            if vals.len() < 3 || vals.iter().any(|&v| v < 0.0 || v >= points.len() as f64) {
                                return Err(perr(
                                    name,
                                    format!("PLY face {} has bad vertex indices {vals:?}", tris.len()),
                                ));
                            }
                            for k in 1..vals.len() - 1 {
                                tris.push([vals[0] as usize, vals[k] as usize, vals[k + 1] as usize]);
                            }
                        }
                    }
                    None => {
                        let v = r.read(ty)?;
                        if el == "vertex" {
                            match pn.as_str() {
                                "x" => p[0] = v,
                                "y" => p[1] = v,
                                "z" => p[2] = v,
                                _ => {}
                            }
                        }
                    }
                }
            }
            if el == "vertex" {
                points.push(p);
            }
        }
    }
    Ok((points, tris))
}
