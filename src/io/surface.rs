//! Surface formats (OBJ, ASCII STL, ASCII PLY) for viewers and CAD tools. They hold triangles
//! only: a tet mesh is written as its boundary surface. Subdomains survive as OBJ groups, STL
//! solids and a PLY face property named `subdomain`.

use super::text::{fmt_f64, parse_f64, perr, settle_dim, Tokens};
use super::{CellType, MeshData};
use crate::Error;
use std::collections::HashMap;

/// The triangles to write and their labels (a tet mesh gives its unlabelled boundary).
fn triangles(m: &MeshData) -> (Vec<[usize; 3]>, Option<Vec<i32>>) {
    match m.cell_type {
        CellType::Triangle => (
            (0..m.num_cells())
                .map(|i| {
                    let c = m.cell(i);
                    [c[0], c[1], c[2]]
                })
                .collect(),
            m.subdomain.clone(),
        ),
        CellType::Tetra => (m.boundary_facets().into_iter().map(|f| [f[0], f[1], f[2]]).collect(), None),
    }
}

fn group_label(name: &str) -> Option<i32> {
    name.strip_prefix("subdomain_")?.parse().ok()
}

fn finish(
    mut points: Vec<[f64; 3]>,
    cells: Vec<usize>,
    labels: Vec<i32>,
    labelled: bool,
    path: &str,
    line: usize,
) -> Result<MeshData, Error> {
    if cells.is_empty() {
        return Err(perr(path, line, "the file holds no triangles"));
    }
    let dim = settle_dim(&mut points, CellType::Triangle);
    Ok(MeshData { dim, cell_type: CellType::Triangle, points, cells, subdomain: labelled.then_some(labels) })
}

pub(crate) fn write_obj(m: &MeshData) -> String {
    let (tris, labels) = triangles(m);
    let mut s = String::with_capacity(48 * (m.points.len() + tris.len()) + 64);
    s.push_str("# written by trussmesh\n");
    for p in &m.points {
        s.push_str(&format!("v {} {} {}\n", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2])));
    }
    let mut current = None;
    for (i, t) in tris.iter().enumerate() {
        if let Some(l) = labels.as_ref().map(|l| l[i]) {
            if current != Some(l) {
                s.push_str(&format!("g subdomain_{l}\n"));
                current = Some(l);
            }
        }
        s.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    s
}

pub(crate) fn read_obj(s: &str, path: &str) -> Result<MeshData, Error> {
    let mut points: Vec<[f64; 3]> = Vec::new();
    let mut cells = Vec::new();
    let mut labels = Vec::new();
    let mut label = 0;
    let mut labelled = false;
    let mut last = 1;
    for (i, raw) in s.lines().enumerate() {
        let line = i + 1;
        last = line;
        let raw = raw.split('#').next().unwrap_or("");
        let mut it = raw.split_whitespace();
        let Some(kw) = it.next() else { continue };
        match kw {
            "v" => {
                let mut p = [0.0; 3];
                for c in &mut p {
                    let tok = it.next().ok_or_else(|| perr(path, line, "a vertex needs x y z"))?;
                    *c = parse_f64(tok)
                        .ok_or_else(|| perr(path, line, format!("vertex coordinate {tok:?} is not a finite number")))?;
                }
                points.push(p);
            }
            "f" => {
                let mut idx = Vec::new();
                for tok in it {
                    let v = tok.split('/').next().unwrap_or("");
                    let v: i64 =
                        v.parse().map_err(|_| perr(path, line, format!("face index {tok:?} is not an integer")))?;
                    let n = points.len() as i64;
                    // Negative indices count back from the latest vertex.
                    let j = if v > 0 { v - 1 } else { n + v };
                    if v == 0 || j < 0 || j >= n {
                        return Err(perr(path, line, format!("face index {v} is out of range ({n} vertices so far)")));
                    }
                    idx.push(j as usize);
                }
                if idx.len() < 3 {
                    return Err(perr(path, line, "a face needs at least 3 vertices"));
                }
                // Polygons become fans.
                for k in 1..idx.len() - 1 {
                    cells.extend_from_slice(&[idx[0], idx[k], idx[k + 1]]);
                    labels.push(label);
                }
            }
            "g" | "o" => {
                let name: Vec<&str> = it.collect();
                match group_label(&name.join(" ")) {
                    Some(l) => {
                        label = l;
                        labelled = true;
                    }
                    None => label = 0,
                }
            }
            _ => {}
        }
    }
    finish(points, cells, labels, labelled, path, last)
}

fn normal(m: &MeshData, t: &[usize; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|i| glam::DVec3::from_array(m.points[i]));
    let n = (b - a).cross(c - a).normalize_or_zero();
    n.to_array()
}

pub(crate) fn write_stl(m: &MeshData) -> String {
    let (tris, labels) = triangles(m);
    let mut s = String::with_capacity(200 * tris.len() + 64);
    let mut open: Option<String> = None;
    for (i, t) in tris.iter().enumerate() {
        let name = match &labels {
            Some(l) => format!("subdomain_{}", l[i]),
            None => "trussmesh".to_string(),
        };
        if open.as_ref() != Some(&name) {
            if let Some(o) = open.take() {
                s.push_str(&format!("endsolid {o}\n"));
            }
            s.push_str(&format!("solid {name}\n"));
            open = Some(name);
        }
        let n = normal(m, t);
        s.push_str(&format!("  facet normal {} {} {}\n    outer loop\n", fmt_f64(n[0]), fmt_f64(n[1]), fmt_f64(n[2])));
        for &v in t {
            let p = m.points[v];
            s.push_str(&format!("      vertex {} {} {}\n", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2])));
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    match open {
        Some(o) => s.push_str(&format!("endsolid {o}\n")),
        None => s.push_str("solid trussmesh\nendsolid trussmesh\n"),
    }
    s
}

/// The words left on the line of the token just read (a solid's name).
fn same_line_rest<'a>(t: &mut Tokens<'a>) -> Vec<&'a str> {
    if t.peek().is_some() && t.line() == t.prev_line() {
        t.rest_of_line()
    } else {
        Vec::new()
    }
}

pub(crate) fn read_stl(s: &str, path: &str) -> Result<MeshData, Error> {
    let mut t = Tokens::new(s, path, None, 1);
    if t.peek() != Some("solid") {
        return Err(t.err("not an ASCII STL file: it must start with 'solid' (binary STL is not supported)"));
    }
    let mut index: HashMap<[u64; 3], usize> = HashMap::new();
    let mut points = Vec::new();
    let mut cells = Vec::new();
    let mut labels = Vec::new();
    let mut labelled = false;
    while t.peek().is_some() {
        t.expect("solid")?;
        let name = same_line_rest(&mut t).join(" ");
        let label = group_label(&name);
        labelled |= label.is_some();
        let label = label.unwrap_or(0);
        loop {
            match t.next("facet or endsolid")? {
                "endsolid" => {
                    same_line_rest(&mut t);
                    break;
                }
                "facet" => {}
                x => return Err(t.err_at(t.prev_line(), format!("expected 'facet' or 'endsolid', found {x:?}"))),
            }
            t.expect("normal")?;
            for _ in 0..3 {
                t.f64("facet normal")?;
            }
            t.expect("outer")?;
            t.expect("loop")?;
            for _ in 0..3 {
                t.expect("vertex")?;
                let p = [t.f64("vertex x")?, t.f64("vertex y")?, t.f64("vertex z")?];
                let key = p.map(f64::to_bits);
                let i = *index.entry(key).or_insert_with(|| {
                    points.push(p);
                    points.len() - 1
                });
                cells.push(i);
            }
            t.expect("endloop")?;
            t.expect("endfacet")?;
            labels.push(label);
        }
    }
    let line = t.line();
    finish(points, cells, labels, labelled, path, line)
}

pub(crate) fn write_ply(m: &MeshData) -> String {
    let (tris, labels) = triangles(m);
    let mut s = String::with_capacity(48 * (m.points.len() + tris.len()) + 256);
    s.push_str("ply\nformat ascii 1.0\ncomment written by trussmesh\n");
    s.push_str(&format!(
        "element vertex {}\nproperty double x\nproperty double y\nproperty double z\n",
        m.points.len()
    ));
    s.push_str(&format!("element face {}\nproperty list uchar int vertex_indices\n", tris.len()));
    if labels.is_some() {
        s.push_str("property int subdomain\n");
    }
    s.push_str("end_header\n");
    for p in &m.points {
        s.push_str(&format!("{} {} {}\n", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2])));
    }
    for (i, t) in tris.iter().enumerate() {
        s.push_str(&format!("3 {} {} {}", t[0], t[1], t[2]));
        if let Some(l) = &labels {
            s.push_str(&format!(" {}", l[i]));
        }
        s.push('\n');
    }
    s
}

struct PlyElement {
    name: String,
    count: usize,
    /// (property name, is a list)
    props: Vec<(String, bool)>,
    line: usize,
}

pub(crate) fn read_ply(s: &str, path: &str) -> Result<MeshData, Error> {
    let mut lines = s.split_inclusive('\n');
    let mut consumed = 0usize;
    let mut lineno = 0usize;
    let mut elements: Vec<PlyElement> = Vec::new();
    let mut ended = false;
    for raw in lines.by_ref() {
        consumed += raw.len();
        lineno += 1;
        let w: Vec<&str> = raw.split_whitespace().collect();
        let bad = |m: &str| perr(path, lineno, m.to_string());
        if lineno == 1 {
            if w != ["ply"] {
                return Err(bad("not a PLY file: the first line must be 'ply'"));
            }
            continue;
        }
        match w.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                if w.get(1) != Some(&"ascii") {
                    return Err(bad("only ASCII PLY is supported (format ascii 1.0)"));
                }
            }
            Some("element") => {
                if w.len() != 3 {
                    return Err(bad("an element line needs: element <name> <count>"));
                }
                let count = w[2].parse::<usize>().map_err(|_| bad("element count is not a non-negative integer"))?;
                elements.push(PlyElement { name: w[1].to_string(), count, props: Vec::new(), line: lineno });
            }
            Some("property") => {
                let e = elements.last_mut().ok_or_else(|| bad("property before any element"))?;
                match w.as_slice() {
                    [_, "list", _, _, name] => e.props.push((name.to_string(), true)),
                    [_, ty, name] if *ty != "list" => e.props.push((name.to_string(), false)),
                    _ => return Err(bad("malformed property line")),
                }
            }
            Some("end_header") => {
                ended = true;
                break;
            }
            Some(x) => return Err(bad(&format!("unknown PLY header line starting with {x:?}"))),
        }
    }
    if !ended {
        return Err(perr(path, lineno.max(1), "PLY header has no end_header (truncated?)"));
    }
    let mut t = Tokens::new(&s[consumed..], path, None, lineno + 1);
    let mut points: Vec<[f64; 3]> = Vec::new();
    let mut cells = Vec::new();
    let mut labels = Vec::new();
    let mut labelled = false;
    let mut saw_vertex = false;
    for e in &elements {
        let per = e.props.len().max(1);
        if e.count.saturating_mul(per) > t.remaining() {
            return Err(perr(
                path,
                e.line,
                format!("element {} claims {} entries, more than the file holds", e.name, e.count),
            ));
        }
        match e.name.as_str() {
            "vertex" => {
                saw_vertex = true;
                let pos = |n: &str| e.props.iter().position(|p| p.0 == n && !p.1);
                let (Some(ix), Some(iy), Some(iz)) = (pos("x"), pos("y"), pos("z")) else {
                    return Err(perr(path, e.line, "vertex element needs x, y and z properties"));
                };
                points.reserve(e.count);
                for _ in 0..e.count {
                    let mut p = [0.0; 3];
                    for (k, (_, list)) in e.props.iter().enumerate() {
                        if *list {
                            skip_list(&mut t)?;
                            continue;
                        }
                        let v = t.f64("vertex property")?;
                        for (slot, at) in [(0, ix), (1, iy), (2, iz)] {
                            if k == at {
                                p[slot] = v;
                            }
                        }
                    }
                    points.push(p);
                }
            }
            "face" => {
                if !saw_vertex {
                    return Err(perr(path, e.line, "face element before vertex element"));
                }
                let vi = e
                    .props
                    .iter()
                    .position(|p| p.1 && (p.0 == "vertex_indices" || p.0 == "vertex_index"))
                    .ok_or_else(|| perr(path, e.line, "face element needs a vertex_indices list"))?;
                let si = e.props.iter().position(|p| p.0 == "subdomain" && !p.1);
                labelled |= si.is_some();
                for _ in 0..e.count {
                    let mut idx = Vec::new();
                    let mut label = 0;
                    for (k, (_, list)) in e.props.iter().enumerate() {
                        if k == vi {
                            let n = t.count("face vertex count", 1)?;
                            if n < 3 {
                                return Err(t.err_at(t.prev_line(), "a face needs at least 3 vertices"));
                            }
                            for _ in 0..n {
                                let v = t.usize("face vertex index")?;
                                if v >= points.len() {
                                    return Err(t.err_at(
                                        t.prev_line(),
                                        format!("face uses vertex {v} but there are {} vertices", points.len()),
                                    ));
                                }
                                idx.push(v);
                            }
                        } else if Some(k) == si {
                            label = t.i32("face subdomain")?;
                        } else if *list {
                            skip_list(&mut t)?;
                        } else {
                            t.f64("face property")?;
                        }
                    }
                    for k in 1..idx.len() - 1 {
                        cells.extend_from_slice(&[idx[0], idx[k], idx[k + 1]]);
                        labels.push(label);
                    }
                }
            }
            _ => {
                for _ in 0..e.count {
                    for (_, list) in &e.props {
                        if *list {
                            skip_list(&mut t)?;
                        } else {
                            t.f64("property")?;
                        }
                    }
                }
            }
        }
    }
    if t.peek().is_some() {
        return Err(t.err("data after the last PLY element"));
    }
    let line = t.line();
    finish(points, cells, labels, labelled, path, line)
}

fn skip_list(t: &mut Tokens) -> Result<(), Error> {
    let n = t.count("list length", 1)?;
    for _ in 0..n {
        t.f64("list entry")?;
    }
    Ok(())
}
