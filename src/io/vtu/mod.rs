//! VTK XML unstructured grid (.vtu): ASCII data arrays (readable by people), or raw binary
//! arrays appended after the XML (exact and fast); ParaView and meshio read both. The reader
//! also takes VTK's inline base64 arrays and base64 appended data.

mod decode;
mod write;

use super::text::{perr, settle_dim, Tokens};
use super::{CellType, MeshData};
use crate::Error;
use decode::{split_appended, Array, Layout, Stored};
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;
pub(crate) use write::write;

/// Counts newlines incrementally so byte offsets turn into line numbers in linear time.
struct LineCounter<'a> {
    s: &'a [u8],
    pos: usize,
    line: usize,
}

impl LineCounter<'_> {
    fn at(&mut self, pos: usize) -> usize {
        let pos = pos.min(self.s.len());
        if pos > self.pos {
            self.line += self.s[self.pos..pos].iter().filter(|&&b| b == b'\n').count();
            self.pos = pos;
        }
        self.line
    }
}

fn attr(e: &BytesStart, key: &str) -> Option<String> {
    e.attributes()
        .flatten()
        .find(|a| a.key.local_name().as_ref() == key.as_bytes())
        .and_then(|a| a.unescape_value().ok().map(|v| v.into_owned()))
}

fn local(e: &BytesStart) -> String {
    String::from_utf8_lossy(e.local_name().as_ref()).into_owned()
}

pub(crate) fn read(bytes: &[u8], path: &str) -> Result<MeshData, Error> {
    let (xml, appended) = split_appended(bytes, path)?;
    let s = xml.as_str();
    let mut layout = Layout { header_bytes: 4, big_endian: false, appended, path };
    let mut r = Reader::from_str(s);
    let mut lc = LineCounter { s: s.as_bytes(), pos: 0, line: 1 };
    let mut stack: Vec<String> = Vec::new();
    let mut arrays: Vec<Array> = Vec::new();
    let mut current: Option<Array> = None;
    let mut pieces = 0usize;
    let mut header: Option<(usize, usize, usize)> = None; // points, cells, line
    let mut saw_vtkfile = false;
    loop {
        let ev = r.read_event();
        let line = lc.at(r.buffer_position() as usize);
        let ev = ev.map_err(|e| perr(path, line, format!("malformed or truncated XML: {e}")))?;
        let (start, empty) = match &ev {
            Event::Start(e) => (Some(e.clone()), false),
            Event::Empty(e) => (Some(e.clone()), true),
            _ => (None, false),
        };
        if let Some(e) = start {
            let name = local(&e);
            match name.as_str() {
                "VTKFile" => {
                    saw_vtkfile = true;
                    let t = attr(&e, "type").unwrap_or_default();
                    if t != "UnstructuredGrid" {
                        return Err(perr(path, line, format!("VTKFile type {t:?} is not UnstructuredGrid")));
                    }
                    if attr(&e, "compressor").is_some() {
                        return Err(perr(path, line, "compressed vtu data not supported"));
                    }
                    layout.header_bytes = match attr(&e, "header_type").as_deref() {
                        None | Some("UInt32") => 4,
                        Some("UInt64") => 8,
                        Some(h) => return Err(perr(path, line, format!("header_type {h:?} is not UInt32 or UInt64"))),
                    };
                    layout.big_endian = match attr(&e, "byte_order").as_deref() {
                        None | Some("LittleEndian") => false,
                        Some("BigEndian") => true,
                        Some(b) => return Err(perr(path, line, format!("byte_order {b:?} is not known"))),
                    };
                }
                "Piece" => {
                    pieces += 1;
                    if pieces > 1 {
                        return Err(perr(path, line, "vtu files with several pieces are not supported"));
                    }
                    let num = |k: &str| -> Result<usize, Error> {
                        attr(&e, k)
                            .and_then(|v| v.trim().parse::<usize>().ok())
                            .ok_or_else(|| perr(path, line, format!("Piece needs a valid {k} attribute")))
                    };
                    header = Some((num("NumberOfPoints")?, num("NumberOfCells")?, line));
                }
                "DataArray" => {
                    if current.is_some() {
                        return Err(perr(path, line, "DataArray nested inside DataArray"));
                    }
                    let format = attr(&e, "format").unwrap_or_else(|| "ascii".into());
                    let stored = match format.as_str() {
                        "ascii" => Stored::Ascii,
                        "binary" => Stored::Base64,
                        "appended" => Stored::Appended(
                            attr(&e, "offset")
                                .and_then(|v| v.trim().parse::<usize>().ok())
                                .ok_or_else(|| perr(path, line, "an appended DataArray needs a valid offset"))?,
                        ),
                        f => return Err(perr(path, line, format!("DataArray format {f:?} is not known"))),
                    };
                    let components = match attr(&e, "NumberOfComponents") {
                        None => 1,
                        Some(v) => v
                            .trim()
                            .parse::<usize>()
                            .ok()
                            .filter(|&c| (1..=64).contains(&c))
                            .ok_or_else(|| perr(path, line, format!("bad NumberOfComponents {v:?}")))?,
                    };
                    let a = Array {
                        parent: stack.last().cloned().unwrap_or_default(),
                        name: attr(&e, "Name").unwrap_or_default(),
                        components,
                        text: String::new(),
                        line,
                        stored,
                        vtk_type: attr(&e, "type").unwrap_or_default(),
                    };
                    if empty {
                        arrays.push(a);
                    } else {
                        current = Some(a);
                    }
                }
                _ => {}
            }
            if !empty {
                stack.push(name);
            }
            continue;
        }
        match ev {
            Event::End(e) => {
                let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                if stack.pop().as_deref() != Some(name.as_str()) {
                    return Err(perr(path, line, format!("unexpected closing tag </{name}>")));
                }
                if name == "DataArray" {
                    if let Some(a) = current.take() {
                        arrays.push(a);
                    }
                }
            }
            Event::Text(t) => {
                if let Some(a) = current.as_mut() {
                    let txt = t.unescape().map_err(|e| perr(path, line, format!("bad text in DataArray: {e}")))?;
                    if a.text.is_empty() {
                        // The array's text starts where its start tag ended.
                        a.line = lc.line - txt.matches('\n').count();
                    }
                    a.text.push_str(&txt);
                }
            }
            Event::CData(_) if current.is_some() => {
                return Err(perr(path, line, "CDATA in a DataArray is not supported"));
            }
            Event::Eof => break,
            _ => {}
        }
    }
    let last_line = lc.line;
    if !saw_vtkfile {
        return Err(perr(path, 1, "not a VTK XML file (no VTKFile element)"));
    }
    if !stack.is_empty() {
        return Err(perr(path, last_line, format!("file ends inside <{}> (truncated)", stack.join("><"))));
    }
    let (npts, ncells, hline) = header.ok_or_else(|| perr(path, last_line, "no Piece element in the vtu file"))?;
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
