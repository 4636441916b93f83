//! Closed polylines from files, the format from the extension:
//!
//! - `.obj`: `v x y [z]` records and `l i j k ...` records (1-based vertex numbers, negative
//!   ones counted back from the last vertex, `i/t` forms allowed); the segments of all `l`
//!   records are joined where they share a point into closed loops, so one loop may be one
//!   record (`l 1 2 3 4 1`) or many. An OBJ without `l` records but with faces gives the
//!   boundary of its triangles, as a mesh file does.
//! - `.txt` `.xy` `.dat` `.csv`: one point a line, `x y` (separated by spaces, tabs or a comma);
//!   a blank line ends a loop; `#` starts a comment. Each loop closes by itself (the last point
//!   joins the first; repeating the first point at the end is allowed).
//! - `.msh` `.vtu` `.mesh` `.json`: a planar triangle mesh (every z = 0); its boundary edges,
//!   those of one triangle only, are the loops.
//!
//! Points with equal coordinates are one point, so loops joined from records or from a mesh
//! close where their coordinates meet.

use super::check::PolygonError;
use crate::io::{read_mesh_bytes, CellType, Format, MeshData};
use crate::Error;
use std::path::Path;

/// Loops as plain arrays.
pub type Loops = Vec<Vec<[f64; 2]>>;

/// The extensions of the text format.
pub const TEXT_EXTENSIONS: [&str; 4] = ["txt", "xy", "dat", "csv"];

/// Every extension [`read_loops`] takes.
pub const EXTENSIONS: [&str; 8] = ["obj", "txt", "xy", "dat", "csv", "msh", "vtu", "mesh"];

fn perr(name: &str, line: usize, message: impl Into<String>) -> Error {
    Error::Parse { path: name.to_string(), line, message: message.into() }
}

fn extension(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default()
}

/// Reads the loops of a polyline file (see the module text for the formats).
pub fn read_loops(path: &Path) -> Result<Loops, Error> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::Io { path: name.clone(), message: e.to_string() })?;
    loops_from_bytes(&bytes, &extension(path), &name)
}

/// [`read_loops`] from memory: `ext` is the extension that names the format (without the dot),
/// `name` names the source in errors.
pub fn loops_from_bytes(bytes: &[u8], ext: &str, name: &str) -> Result<Loops, Error> {
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(perr(name, 0, "the file is empty"));
    }
    let text = || std::str::from_utf8(bytes).map_err(|_| perr(name, 0, "the file is not UTF-8 text"));
    match ext {
        "obj" => {
            let s = text()?;
            if has_lines(s) {
                obj_lines(s, name)
            } else {
                mesh_boundary(bytes, Format::Obj, name)
            }
        }
        e if TEXT_EXTENSIONS.contains(&e) => text_loops(text()?, name),
        "msh" => mesh_boundary(bytes, Format::Msh, name),
        "vtu" => mesh_boundary(bytes, Format::Vtu, name),
        "mesh" => mesh_boundary(bytes, Format::Medit, name),
        "json" => mesh_boundary(bytes, Format::Json, name),
        e => Err(Error::Invalid(format!(
            "unknown polyline file extension {e:?} in {name} (expected .obj .txt .xy .dat .csv .msh .vtu .mesh .json)"
        ))),
    }
}

/// Whether a file holds planar loops rather than a surface: an OBJ with `l` records, a text
/// file, or a mesh of triangles whose z coordinates are all zero.
pub fn is_planar(path: &Path) -> Result<bool, Error> {
    let ext = extension(path);
    if TEXT_EXTENSIONS.contains(&ext.as_str()) {
        return Ok(true);
    }
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::Io { path: name.clone(), message: e.to_string() })?;
    if ext == "obj" {
        if let Ok(s) = std::str::from_utf8(&bytes) {
            if has_lines(s) {
                return Ok(true);
            }
        }
    }
    let Ok(format) = Format::from_path(path) else { return Ok(false) };
    // Binary STL and PLY are surfaces; a mesh file that does not parse is left to the surface
    // reader, which names the problem.
    if matches!(format, Format::Stl | Format::Ply) {
        return Ok(false);
    }
    Ok(read_mesh_bytes(&bytes, format)
        .is_ok_and(|m| m.cell_type == CellType::Triangle && (m.dim == 2 || m.points.iter().all(|p| p[2] == 0.0))))
}

fn has_lines(s: &str) -> bool {
    s.lines().any(|l| l.trim_start().strip_prefix('l').is_some_and(|r| r.starts_with([' ', '\t'])))
}

/// The text format: x y per line, blank lines between loops.
fn text_loops(s: &str, name: &str) -> Result<Loops, Error> {
    let mut loops: Loops = Vec::new();
    let mut cur: Vec<[f64; 2]> = Vec::new();
    for (i, line) in s.lines().enumerate() {
        let body = line.split('#').next().unwrap_or("").trim();
        if body.is_empty() {
            // A comment line does not end a loop; a blank one does.
            if line.trim().is_empty() && !cur.is_empty() {
                loops.push(std::mem::take(&mut cur));
            }
            continue;
        }
        let w: Vec<&str> = body.split(|c: char| c.is_whitespace() || c == ',').filter(|w| !w.is_empty()).collect();
        if w.len() != 2 {
            return Err(perr(name, i + 1, format!("expected two numbers x y, found {} fields in {body:?}", w.len())));
        }
        let num = |t: &str| t.parse::<f64>().map_err(|_| perr(name, i + 1, format!("{t:?} is not a number")));
        cur.push([num(w[0])?, num(w[1])?]);
    }
    if !cur.is_empty() {
        loops.push(cur);
    }
    if loops.is_empty() {
        return Err(perr(name, 0, "the file holds no points"));
    }
    Ok(loops)
}

/// OBJ `v` and `l` records joined into loops.
fn obj_lines(s: &str, name: &str) -> Result<Loops, Error> {
    let mut points: Vec<[f64; 2]> = Vec::new();
    // Each segment with the line of its record.
    let mut edges: Vec<([usize; 2], usize)> = Vec::new();
    for (i, line) in s.lines().enumerate() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let c: Vec<&str> = w.collect();
                if c.len() < 2 {
                    return Err(perr(name, i + 1, "a v record needs at least x and y"));
                }
                let num = |t: &str| t.parse::<f64>().map_err(|_| perr(name, i + 1, format!("{t:?} is not a number")));
                let z = if c.len() > 2 { num(c[2])? } else { 0.0 };
                if z != 0.0 {
                    return Err(perr(
                        name,
                        i + 1,
                        format!("vertex {} has z = {z}; polylines must lie in z = 0", points.len() + 1),
                    ));
                }
                points.push([num(c[0])?, num(c[1])?]);
            }
            Some("l") => {
                let mut ids = Vec::new();
                for t in w {
                    let v = t.split('/').next().unwrap_or("");
                    let k: i64 = v.parse().map_err(|_| perr(name, i + 1, format!("{t:?} is not a vertex number")))?;
                    let n = points.len() as i64;
                    let idx = if k < 0 { n + k } else { k - 1 };
                    if !(0..n).contains(&idx) {
                        return Err(perr(
                            name,
                            i + 1,
                            format!("vertex {k} does not exist ({n} vertices defined before this line)"),
                        ));
                    }
                    ids.push(idx as usize);
                }
                if ids.len() < 2 {
                    return Err(perr(name, i + 1, "an l record needs at least two vertices"));
                }
                edges.extend(ids.windows(2).map(|p| ([p[0], p[1]], i + 1)));
            }
            _ => {}
        }
    }
    chain(&points, &edges, |line| format!("the polyline of the l record on line {line}"))
}

/// The boundary edges of a planar triangle mesh.
fn mesh_boundary(bytes: &[u8], format: Format, name: &str) -> Result<Loops, Error> {
    let m: MeshData = read_mesh_bytes(bytes, format).map_err(|e| match e {
        Error::Parse { line, message, .. } => perr(name, line, message),
        e => e,
    })?;
    if m.cell_type != CellType::Triangle {
        return Err(perr(name, 0, "the mesh holds tetrahedra; a planar domain needs a triangle mesh's boundary"));
    }
    if let Some(p) = m.points.iter().find(|p| p[2] != 0.0) {
        return Err(perr(
            name,
            0,
            format!(
                "the mesh is not planar: a node has z = {} (at ({}, {})); a planar domain needs z = 0",
                p[2], p[0], p[1]
            ),
        ));
    }
    if m.num_cells() == 0 {
        return Err(perr(name, 0, "the mesh has no triangles"));
    }
    let points: Vec<[f64; 2]> = m.points.iter().map(|p| [p[0], p[1]]).collect();
    let edges: Vec<([usize; 2], usize)> = m.boundary_facets().into_iter().map(|f| ([f[0], f[1]], 0)).collect();
    chain(&points, &edges, |_| "a boundary edge".to_string())
}

/// Joins segments into closed loops, points with equal coordinates merged. A point with one
/// segment is an open end, one with more than two a branch.
fn chain(points: &[[f64; 2]], edges: &[([usize; 2], usize)], what: impl Fn(usize) -> String) -> Result<Loops, Error> {
    // Merge equal coordinates (-0 and 0 alike), numbering points by first use.
    let mut index: crate::FastMap<[u64; 2], usize> = crate::FastMap::default();
    let mut pos: Vec<[f64; 2]> = Vec::new();
    let mut id = |p: [f64; 2]| -> usize {
        let key = p.map(|c| (c + 0.0).to_bits());
        *index.entry(key).or_insert_with(|| {
            pos.push(p);
            pos.len() - 1
        })
    };
    // Segments of zero length (a point repeated in a record) join nothing and are dropped.
    let es: Vec<([usize; 2], usize)> =
        edges.iter().map(|&([a, b], l)| ([id(points[a]), id(points[b])], l)).filter(|([a, b], _)| a != b).collect();
    let mut inc: Vec<Vec<usize>> = vec![Vec::new(); pos.len()];
    for (e, ([a, b], _)) in es.iter().enumerate() {
        inc[*a].push(e);
        inc[*b].push(e);
    }
    for (v, list) in inc.iter().enumerate() {
        match list.len() {
            1 => return Err(PolygonError::Open { what: what(es[list[0]].1), at: pos[v] }.into()),
            n if n > 2 => return Err(PolygonError::Branch { count: n, at: pos[v] }.into()),
            _ => {}
        }
    }
    let mut used = vec![false; es.len()];
    let mut loops = Vec::new();
    for start in 0..es.len() {
        if used[start] {
            continue;
        }
        used[start] = true;
        let [first, mut at] = es[start].0;
        let mut lp = vec![pos[first]];
        while at != first {
            lp.push(pos[at]);
            let Some(&e) = inc[at].iter().find(|&&e| !used[e]) else { break };
            used[e] = true;
            let [a, b] = es[e].0;
            at = if a == at { b } else { a };
        }
        loops.push(lp);
    }
    Ok(loops)
}
