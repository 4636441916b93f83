//! VTK XML unstructured grid (.vtu) with ASCII data arrays: readable by people, ParaView and meshio.

use super::measure::{tet_min_dihedral_values, tet_radius_ratio_values, triangle_q_values};
use super::text::{fmt_f64, perr, settle_dim, Tokens};
use super::{CellType, MeshData, NodeKind};
use crate::Error;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

/// One ASCII data array as found in the file.
struct Array {
    parent: String,
    name: String,
    components: usize,
    text: String,
    line: usize,
}

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

pub(crate) fn read(s: &str, path: &str) -> Result<MeshData, Error> {
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
                "AppendedData" => {
                    return Err(perr(path, line, "binary/appended vtu data not supported"));
                }
                "DataArray" => {
                    if current.is_some() {
                        return Err(perr(path, line, "DataArray nested inside DataArray"));
                    }
                    let format = attr(&e, "format").unwrap_or_else(|| "ascii".into());
                    if format != "ascii" {
                        return Err(perr(
                            path,
                            line,
                            format!("binary/appended vtu data not supported (DataArray format={format:?})"),
                        ));
                    }
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
                return Err(perr(path, line, "binary/appended vtu data not supported (CDATA)"));
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
    let mut t = Tokens::new(&pa.text, path, None, pa.line);
    if t.remaining() != 3 * npts.min(usize::MAX / 3) {
        return Err(perr(
            path,
            pa.line,
            format!(
                "Points holds {} numbers but NumberOfPoints={npts} needs {}",
                t.remaining(),
                npts.saturating_mul(3)
            ),
        ));
    }
    let mut points = Vec::with_capacity(npts);
    for _ in 0..npts {
        points.push([t.f64("point x")?, t.f64("point y")?, t.f64("point z")?]);
    }

    // Cells.
    let ints = |a: &Array, what: &str| -> Result<Vec<(i64, usize)>, Error> {
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

/// Writes the mesh with its cell data (quality: `q` for triangles, `radius_ratio` and
/// `min_dihedral` in degrees for tetrahedra; `subdomain` when labelled) and its point data
/// (`node_kind`: the given kinds, or for planar and tetrahedral meshes interior 0 / boundary 1
/// from the boundary facets).
pub(crate) fn write(m: &MeshData, kinds: Option<&[NodeKind]>) -> String {
    let n = m.num_cells();
    let k = m.cell_type.nodes();
    let mut s = String::with_capacity(64 * (m.points.len() + n) + 1024);
    s.push_str("<?xml version=\"1.0\"?>\n");
    s.push_str(
        "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n",
    );
    s.push_str("  <UnstructuredGrid>\n");
    s.push_str(&format!("    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{n}\">\n", m.points.len()));
    let derived;
    let kinds = match kinds {
        Some(k) if k.len() == m.points.len() => Some(k),
        _ if m.dim == 2 || m.cell_type == CellType::Tetra => {
            let mut d = vec![NodeKind::Interior; m.points.len()];
            for v in m.boundary_facets().into_iter().flatten() {
                d[v] = NodeKind::Boundary;
            }
            derived = d;
            Some(derived.as_slice())
        }
        _ => None,
    };
    if let Some(kinds) = kinds {
        s.push_str("      <PointData Scalars=\"node_kind\">\n        <DataArray type=\"UInt8\" Name=\"node_kind\" format=\"ascii\">\n");
        push_wrapped(&mut s, kinds.iter().map(|&k| (k as u8).to_string()));
        s.push_str("        </DataArray>\n      </PointData>\n");
    }
    s.push_str("      <Points>\n        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"ascii\">\n");
    for p in &m.points {
        s.push_str(&format!("          {} {} {}\n", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2])));
    }
    s.push_str("        </DataArray>\n      </Points>\n      <Cells>\n");
    s.push_str("        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
    for i in 0..n {
        let c: Vec<String> = m.cell(i).iter().map(|v| v.to_string()).collect();
        s.push_str(&format!("          {}\n", c.join(" ")));
    }
    s.push_str("        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
    push_wrapped(&mut s, (1..=n).map(|i| (i * k).to_string()));
    s.push_str("        </DataArray>\n        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
    let ty = if m.cell_type == CellType::Tetra { "10" } else { "5" };
    push_wrapped(&mut s, (0..n).map(|_| ty.to_string()));
    s.push_str("        </DataArray>\n      </Cells>\n");
    let quality: Vec<(&str, Vec<f64>)> = match m.cell_type {
        CellType::Triangle => vec![("q", triangle_q_values(m))],
        CellType::Tetra => {
            vec![("radius_ratio", tet_radius_ratio_values(m)), ("min_dihedral", tet_min_dihedral_values(m))]
        }
    };
    s.push_str(&format!("      <CellData Scalars=\"{}\">\n", quality[0].0));
    for (name, values) in &quality {
        s.push_str(&format!("        <DataArray type=\"Float64\" Name=\"{name}\" format=\"ascii\">\n"));
        push_wrapped(&mut s, values.iter().map(|&v| fmt_f64(if v.is_finite() { v } else { 0.0 })));
        s.push_str("        </DataArray>\n");
    }
    if let Some(sd) = &m.subdomain {
        s.push_str("        <DataArray type=\"Int32\" Name=\"subdomain\" format=\"ascii\">\n");
        push_wrapped(&mut s, sd.iter().map(|v| v.to_string()));
        s.push_str("        </DataArray>\n");
    }
    s.push_str("      </CellData>\n");
    s.push_str("    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
    s
}

/// Twenty numbers a line keeps long arrays readable.
fn push_wrapped(s: &mut String, items: impl Iterator<Item = String>) {
    let items: Vec<String> = items.collect();
    for chunk in items.chunks(20) {
        s.push_str("          ");
        s.push_str(&chunk.join(" "));
        s.push('\n');
    }
}
