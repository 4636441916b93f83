//! Medit / mmg (.mesh) ASCII: the format mmg2d/mmg3d read for remeshing, so refs carry the
//! subdomain of each cell and boundary facets carry ref 1.

use super::text::{fmt_f64, Tokens};
use super::{CellType, MeshData};
use crate::Error;

/// Reads one entity section: count, then `k` 1-based indices and a ref per entity.
fn read_entities(t: &mut Tokens, what: &str, k: usize, npts: usize) -> Result<(Vec<usize>, Vec<i32>), Error> {
    let n = t.count(&format!("number of {what}"), k + 1)?;
    let mut idx = Vec::with_capacity(n * k);
    let mut refs = Vec::with_capacity(n);
    for i in 0..n {
        for _ in 0..k {
            let v = t.usize(&format!("{what} vertex index"))?;
            if v == 0 || v > npts {
                return Err(t.err_at(
                    t.prev_line(),
                    format!("{what} {} uses vertex {v}, but vertices are numbered 1..={npts}", i + 1),
                ));
            }
            idx.push(v - 1);
        }
        refs.push(t.i32(&format!("{what} reference"))?);
    }
    Ok((idx, refs))
}

fn is_keyword(s: &str) -> bool {
    s.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
}

pub(crate) fn read(s: &str, path: &str) -> Result<MeshData, Error> {
    let mut t = Tokens::new(s, path, Some('#'), 1);
    let mut dim = None;
    let mut points: Option<Vec<[f64; 3]>> = None;
    let mut tris: Option<(Vec<usize>, Vec<i32>)> = None;
    let mut tets: Option<(Vec<usize>, Vec<i32>)> = None;
    let mut saw_version = false;
    let mut ended = false;
    while let Some(kw) = t.peek() {
        let line = t.line();
        t.next("keyword")?;
        if !is_keyword(kw) {
            return Err(t.err_at(line, format!("expected a keyword, found {kw:?}")));
        }
        let lower = kw.to_ascii_lowercase();
        let npts = points.as_ref().map_or(0, Vec::len);
        match lower.as_str() {
            "meshversionformatted" => {
                let v = t.i64("MeshVersionFormatted")?;
                if !(1..=2).contains(&v) {
                    return Err(t.err_at(line, format!("MeshVersionFormatted {v} not supported (1 or 2)")));
                }
                saw_version = true;
            }
            "dimension" => {
                let d = t.usize("Dimension")?;
                if d != 2 && d != 3 {
                    return Err(t.err_at(line, format!("Dimension {d} must be 2 or 3")));
                }
                dim = Some(d);
            }
            "vertices" => {
                let d = dim.ok_or_else(|| t.err_at(line, "Vertices before Dimension"))?;
                if points.is_some() {
                    return Err(t.err_at(line, "a second Vertices section"));
                }
                let n = t.count("number of vertices", d + 1)?;
                let mut pts = Vec::with_capacity(n);
                for _ in 0..n {
                    let mut p = [0.0; 3];
                    for c in p.iter_mut().take(d) {
                        *c = t.f64("vertex coordinate")?;
                    }
                    t.i32("vertex reference")?;
                    pts.push(p);
                }
                points = Some(pts);
            }
            "triangles" | "tetrahedra" | "edges" => {
                if points.is_none() {
                    return Err(t.err_at(line, format!("{kw} before Vertices")));
                }
                let k = match lower.as_str() {
                    "edges" => 2,
                    "triangles" => 3,
                    _ => 4,
                };
                let e = read_entities(&mut t, kw, k, npts)?;
                let slot = match k {
                    3 => &mut tris,
                    4 => &mut tets,
                    _ => continue,
                };
                if slot.is_some() {
                    return Err(t.err_at(line, format!("a second {kw} section")));
                }
                *slot = Some(e);
            }
            "end" => {
                ended = true;
                break;
            }
            _ => {
                // Sections we do not use (Corners, Ridges, Normals, ...): skip their numbers.
                while t.peek().is_some_and(|x| !is_keyword(x)) {
                    t.next("section data")?;
                }
            }
        }
    }
    let last = t.line();
    if !saw_version {
        return Err(t.err_at(1, "missing MeshVersionFormatted"));
    }
    if !ended {
        return Err(t.err_at(last, "missing End (truncated file?)"));
    }
    let dim = dim.ok_or_else(|| t.err_at(last, "missing Dimension"))?;
    let points = points.ok_or_else(|| t.err_at(last, "missing Vertices"))?;
    let (cell_type, (cells, refs)) = match (tets, tris) {
        (Some(c), _) if !c.0.is_empty() => (CellType::Tetra, c),
        (_, Some(c)) if !c.0.is_empty() => (CellType::Triangle, c),
        _ => return Err(t.err_at(last, "no Triangles or Tetrahedra")),
    };
    if cell_type == CellType::Tetra && dim != 3 {
        return Err(t.err_at(last, "Tetrahedra in a Dimension 2 file"));
    }
    // Ref 0 everywhere means "no labels".
    let subdomain = if refs.iter().all(|&r| r == 0) { None } else { Some(refs) };
    Ok(MeshData { dim, cell_type, points, cells, subdomain })
}

pub(crate) fn write(m: &MeshData) -> String {
    let n = m.num_cells();
    let bnd = m.boundary_facets();
    let mut s = String::with_capacity(64 * (m.points.len() + n + bnd.len()) + 256);
    s.push_str(&format!("MeshVersionFormatted 2\n\nDimension {}\n\n", m.dim));
    s.push_str(&format!("Vertices\n{}\n", m.points.len()));
    for p in &m.points {
        let c: Vec<String> = p[..m.dim].iter().map(|&x| fmt_f64(x)).collect();
        s.push_str(&format!("{} 0\n", c.join(" ")));
    }
    let cells_kw = if m.cell_type == CellType::Tetra { "Tetrahedra" } else { "Triangles" };
    s.push_str(&format!("\n{cells_kw}\n{n}\n"));
    for i in 0..n {
        let c: Vec<String> = m.cell(i).iter().map(|v| (v + 1).to_string()).collect();
        let r = m.subdomain.as_ref().map_or(0, |sd| sd[i]);
        s.push_str(&format!("{} {r}\n", c.join(" ")));
    }
    if !bnd.is_empty() {
        let kw = if m.cell_type == CellType::Tetra { "Triangles" } else { "Edges" };
        s.push_str(&format!("\n{kw}\n{}\n", bnd.len()));
        for f in &bnd {
            let c: Vec<String> = f.iter().map(|v| (v + 1).to_string()).collect();
            s.push_str(&format!("{} 1\n", c.join(" ")));
        }
    }
    s.push_str("\nEnd\n");
    s
}
