//! VTK XML unstructured grid (.vtu): ASCII data arrays (readable by people), or raw binary
//! arrays appended after the XML (exact and fast); ParaView and meshio read both. The reader
//! also takes VTK's inline base64 arrays and base64 appended data.

mod decode;
mod image;
mod scan;
mod write;

use super::text::{perr, settle_dim, Tokens};
use super::{CellType, MeshData};
use crate::Error;
use decode::{Array, Stored};
pub(crate) use image::read_image;
use scan::{scan, Scanned};
pub(crate) use write::write;

pub(crate) fn read(bytes: &[u8], path: &str) -> Result<MeshData, Error> {
    let Scanned { layout, arrays, tags, last_line } = scan(bytes, path, "UnstructuredGrid")?;
    let piece = tags
        .iter()
        .find(|t| t.name == "Piece")
        .ok_or_else(|| perr(path, last_line, "no Piece element in the vtu file"))?;
    let num = |k: &str| -> Result<usize, Error> {
        piece
            .get(k)
            .and_then(|v| v.trim().parse::<usize>().ok())
            .ok_or_else(|| perr(path, piece.line, format!("Piece needs a valid {k} attribute")))
    };
    let (npts, ncells, hline) = (num("NumberOfPoints")?, num("NumberOfCells")?, piece.line);
    let find = |parent: &str, name: Option<&str>| {
        arrays.iter().find(|a| a.parent == parent && name.is_none_or(|n| a.name == n))
    };

    // Points.
    let pa = find("Points", None).ok_or_else(|| perr(path, hline, "no Points DataArray"))?;
    if pa.components != 3 {
        return Err(perr(path, pa.line, "Points must have NumberOfComponents=\"3\""));
    }
    let coords = if pa.stored == Stored::Ascii {
        let mut t = Tokens::new(&pa.text, path, None, pa.line);
        let mut v = Vec::with_capacity(t.remaining());
        while t.peek().is_some() {
            v.push(t.f64("point coordinate")?);
        }
        v
    } else {
        layout.floats(pa)?
    };
    if coords.len() != 3 * npts.min(usize::MAX / 3) {
        return Err(perr(
            path,
            pa.line,
            format!("Points holds {} numbers but NumberOfPoints={npts} needs {}", coords.len(), npts.saturating_mul(3)),
        ));
    }
    let mut points: Vec<[f64; 3]> = coords.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();

    // Cells.
    let ints = |a: &Array, what: &str| -> Result<Vec<(i64, usize)>, Error> {
        if a.stored != Stored::Ascii {
            return Ok(layout.ints(a)?.into_iter().map(|v| (v, a.line)).collect());
        }
        let mut t = Tokens::new(&a.text, path, None, a.line);
        let mut v = Vec::with_capacity(t.remaining());
        while t.peek().is_some() {
            let line = t.line();
            v.push((t.i64(what)?, line));
        }
        Ok(v)
    };
    let get = |name: &str| {
        find("Cells", Some(name)).ok_or_else(|| perr(path, hline, format!("no Cells DataArray named {name:?}")))
    };
    let conn = ints(get("connectivity")?, "connectivity")?;
    let offa = get("offsets")?;
    let offs = ints(offa, "offsets")?;
    let typa = get("types")?;
    let types = ints(typa, "types")?;
    if offs.len() != ncells || types.len() != ncells {
        return Err(perr(
            path,
            offa.line,
            format!("NumberOfCells={ncells} but there are {} offsets and {} types", offs.len(), types.len()),
        ));
    }
    let has_tets = types.iter().any(|t| t.0 == 10);
    let cell_type = if has_tets { CellType::Tetra } else { CellType::Triangle };
    let want = if has_tets { 10 } else { 5 };
    let mut cells = Vec::new();
    let mut kept = Vec::new();
    let mut prev = 0usize;
    for (i, (&(off, oline), &(ty, tline))) in offs.iter().zip(&types).enumerate() {
        let off = usize::try_from(off).ok().filter(|&o| o >= prev && o <= conn.len()).ok_or_else(|| {
            perr(path, oline, format!("offset {off} of cell {i} is out of order or past the connectivity"))
        })?;
        let size = off - prev;
        let nodes = &conn[prev..off];
        prev = off;
        let need = match ty {
            5 => 3,
            10 => 4,
            1..=4 => continue,
            _ => {
                return Err(perr(path, tline, format!("unsupported VTK cell type {ty} (only 5 triangle and 10 tetra)")))
            }
        };
        if size != need {
            return Err(perr(path, oline, format!("cell {i} of type {ty} has {size} nodes, expected {need}")));
        }
        if ty != want {
            continue;
        }
        for &(v, vline) in nodes {
            let v = usize::try_from(v)
                .ok()
                .filter(|&v| v < npts)
                .ok_or_else(|| perr(path, vline, format!("cell {i} uses node {v} but there are {npts} points")))?;
            cells.push(v);
        }
        kept.push(i);
    }
    if prev != conn.len() {
        return Err(perr(path, offa.line, "the last offset does not match the connectivity length"));
    }
    if cells.is_empty() {
        return Err(perr(path, hline, "the file holds no triangles or tetrahedra"));
    }

    // Subdomain labels, if any.
    let sa = ["subdomain", "gmsh:physical", "medit:ref"].iter().find_map(|n| find("CellData", Some(n)));
    let subdomain = match sa {
        None => None,
        Some(a) if a.stored != Stored::Ascii => {
            let all = layout.ints(a)?;
            if a.components != 1 || all.len() != ncells {
                return Err(perr(
                    path,
                    a.line,
                    format!("CellData {:?} holds {} values for {ncells} cells", a.name, all.len()),
                ));
            }
            let label = |i: usize| {
                i32::try_from(all[i])
                    .map_err(|_| perr(path, a.line, format!("subdomain label {} is not a 32-bit integer", all[i])))
            };
            Some(kept.iter().map(|&i| label(i)).collect::<Result<Vec<i32>, Error>>()?)
        }
        Some(a) => {
            let mut t = Tokens::new(&a.text, path, None, a.line);
            if a.components != 1 || t.remaining() != ncells {
                return Err(perr(
                    path,
                    a.line,
                    format!("CellData {:?} holds {} values for {ncells} cells", a.name, t.remaining()),
                ));
            }
            let mut all = Vec::with_capacity(ncells);
            for _ in 0..ncells {
                let line = t.line();
                let tok = t.next("subdomain label")?;
                let v = tok
                    .parse::<i32>()
                    .ok()
                    .or_else(|| {
                        tok.parse::<f64>().ok().filter(|f| f.fract() == 0.0 && f.abs() < 2.0e9).map(|f| f as i32)
                    })
                    .ok_or_else(|| perr(path, line, format!("subdomain label {tok:?} is not a 32-bit integer")))?;
                all.push(v);
            }
            Some(kept.iter().map(|&i| all[i]).collect())
        }
    };
    let dim = settle_dim(&mut points, cell_type);
    Ok(MeshData { dim, cell_type, points, cells, subdomain })
}
