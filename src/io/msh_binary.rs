//! Gmsh 4.1 binary (.msh, file type 1, data size 8): the text format's sections with their
//! numbers stored little-endian (`int` as i32, `size_t` as u64, `double` as f64). The same
//! groups and boundary entity as the text writer, so either reads back the same mesh.

use super::binary::Cursor;
use super::msh::{assemble, nodes_of_type, Parsed, Plan};
use super::MeshData;
use crate::Error;
use std::collections::HashMap;

/// Whether `bytes` is a binary .msh file (its $MeshFormat line says file type 1).
pub(crate) fn is_binary(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(64)];
    let text = String::from_utf8_lossy(head);
    let mut lines = text.lines();
    lines.next().map(str::trim) == Some("$MeshFormat")
        && lines.next().and_then(|l| l.split_whitespace().nth(1)) == Some("1")
}

pub(crate) fn write(m: &MeshData) -> Vec<u8> {
    let n = m.num_cells();
    let plan = Plan::new(m);
    let np = m.points.len();
    let mut out = Vec::with_capacity(32 * np + (8 + 8 * 4) * n + 4096);
    let put_i32 = |o: &mut Vec<u8>, v: i32| o.extend_from_slice(&v.to_le_bytes());
    let put_u64 = |o: &mut Vec<u8>, v: usize| o.extend_from_slice(&(v as u64).to_le_bytes());
    out.extend_from_slice(b"$MeshFormat\n4.1 1 8\n");
    put_i32(&mut out, 1);
    out.extend_from_slice(b"\n$EndMeshFormat\n");
    out.extend_from_slice(plan.physical_names(m).as_bytes());
    out.extend_from_slice(b"$Entities\n");
    let entities = plan.entities(m);
    let mut counts = [0usize; 4];
    for e in &entities {
        counts[e.0] += 1;
    }
    counts.iter().for_each(|&c| put_u64(&mut out, c));
    for (_, tag, bb, phys) in &entities {
        put_i32(&mut out, *tag);
        bb.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        put_u64(&mut out, 1);
        put_i32(&mut out, *phys);
        put_u64(&mut out, 0);
    }
    out.extend_from_slice(b"\n$EndEntities\n$Nodes\n");
    let blocks = usize::from(np > 0);
    for v in [blocks, np, usize::from(np > 0), np] {
        put_u64(&mut out, v);
    }
    if np > 0 {
        put_i32(&mut out, plan.cdim as i32);
        put_i32(&mut out, 1);
        put_i32(&mut out, 0);
        put_u64(&mut out, np);
        (1..=np).for_each(|i| put_u64(&mut out, i));
        m.points.iter().flatten().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
    }
    out.extend_from_slice(b"\n$EndNodes\n$Elements\n");
    let total = n + plan.bnd.len();
    for v in [plan.groups.len() + usize::from(!plan.bnd.is_empty()), total, usize::from(total > 0), total] {
        put_u64(&mut out, v);
    }
    // Cells keep tags 1..=n in their original order so a reader can restore it.
    for (e, cs) in plan.groups.values().enumerate() {
        put_i32(&mut out, plan.cdim as i32);
        put_i32(&mut out, e as i32 + 1);
        put_i32(&mut out, plan.cty);
        put_u64(&mut out, cs.len());
        for &c in cs {
            put_u64(&mut out, c + 1);
            m.cell(c).iter().for_each(|&v| put_u64(&mut out, v + 1));
        }
    }
    if !plan.bnd.is_empty() {
        put_i32(&mut out, plan.cdim as i32 - 1);
        put_i32(&mut out, 1);
        put_i32(&mut out, plan.fty);
        put_u64(&mut out, plan.bnd.len());
        for (j, f) in plan.bnd.iter().enumerate() {
            put_u64(&mut out, n + j + 1);
            f.iter().for_each(|&v| put_u64(&mut out, v + 1));
        }
    }
    out.extend_from_slice(b"\n$EndElements\n");
    out
}

/// The next line as text (without its newline), or `None` at the end of the file.
fn line<'a>(c: &mut Cursor<'a>) -> Option<&'a str> {
    if c.pos >= c.bytes.len() {
        return None;
    }
    let rest = &c.bytes[c.pos..];
    let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
    c.pos += (end + 1).min(rest.len());
    std::str::from_utf8(&rest[..end]).ok().map(str::trim)
}

/// Skips the newline after a binary block and checks the section's end marker.
fn end_section(c: &mut Cursor, name: &str) -> Result<(), Error> {
    let want = format!("$End{name}");
    while c.pos < c.bytes.len() && c.bytes[c.pos].is_ascii_whitespace() {
        c.pos += 1;
    }
    let at = c.pos;
    match line(c) {
        Some(l) if l == want => Ok(()),
        _ => {
            c.pos = at;
            Err(c.err(format!("expected {want}")))
        }
    }
}

/// An `int` read as i64, the width the shared assembly keys on.
fn tag(c: &mut Cursor, what: &str) -> Result<i64, Error> {
    Ok(c.i32(what)? as i64)
}

pub(crate) fn read(bytes: &[u8], path: &str) -> Result<MeshData, Error> {
    let mut c = Cursor::new(bytes, 0, path);
    let mut p = Parsed { names: HashMap::new(), entity_phys: HashMap::new(), points: Vec::new(), elems: Vec::new() };
    let mut node_index: HashMap<i64, usize> = HashMap::new();
    if line(&mut c) != Some("$MeshFormat") {
        return Err(c.err("the file does not start with $MeshFormat"));
    }
    let fmt = line(&mut c).unwrap_or_default();
    let f: Vec<&str> = fmt.split_whitespace().collect();
    if f.len() != 3 || f[0] != "4.1" || f[1] != "1" {
        return Err(c.err(format!("expected \"4.1 1 8\" (msh 4.1 binary), found {fmt:?}")));
    }
    if f[2] != "8" {
        return Err(c.err(format!("data size {} is not supported (only 8-byte size_t)", f[2])));
    }
    let one = c.i32("the byte-order check")?;
    if one != 1 {
        return Err(c.err(format!(
            "binary msh: the byte-order check reads {one}, not 1 (a big-endian file, or text marked binary?)"
        )));
    }
    end_section(&mut c, "MeshFormat")?;
    let mut saw_nodes = false;
    while let Some(sec) = line(&mut c) {
        if sec.is_empty() {
            continue;
        }
        let name = sec
            .strip_prefix('$')
            .ok_or_else(|| c.err(format!("expected a $Section, found {:?}", &sec[..sec.len().min(40)])))?
            .to_string();
        match name.as_str() {
            "PhysicalNames" => {
                let n: usize =
                    line(&mut c).and_then(|l| l.parse().ok()).ok_or_else(|| c.err("$PhysicalNames needs a count"))?;
                for _ in 0..n {
                    let l = line(&mut c).ok_or_else(|| c.err("the file ends inside $PhysicalNames"))?;
                    let mut it = l.splitn(3, char::is_whitespace);
                    let num = |x: Option<&str>| x.and_then(|x| x.trim().parse::<i64>().ok());
                    let (Some(d), Some(t), Some(nm)) = (num(it.next()), num(it.next()), it.next()) else {
                        return Err(c.err(format!("a physical name needs: dimension tag \"name\", found {l:?}")));
                    };
                    p.names.insert((d, t), nm.trim().trim_matches('"').to_string());
                }
            }
            "Entities" => {
                let mut counts = [0usize; 4];
                for k in counts.iter_mut() {
                    *k = c.count("number of entities", 4 + 24 + 8)?;
                }
                for (d, &n) in counts.iter().enumerate() {
                    for _ in 0..n {
                        let t = tag(&mut c, "entity tag")?;
                        c.take(if d == 0 { 24 } else { 48 }, "an entity's bounding box")?;
                        let np = c.count("number of physical tags", 4)?;
                        for k in 0..np {
                            let ph = tag(&mut c, "physical tag")?;
                            if k == 0 {
                                p.entity_phys.insert((d as i64, t), ph);
                            }
                        }
                        if d > 0 {
                            let nb = c.count("number of bounding entities", 4)?;
                            c.take(4 * nb, "bounding entity tags")?;
                        }
                    }
                }
            }
            "Nodes" => {
                if saw_nodes {
                    return Err(c.err("a second $Nodes section"));
                }
                saw_nodes = true;
                let nblocks = c.count("number of node blocks", 20)?;
                let total = c.count("number of nodes", 32)?;
                c.u64("minimum node tag")?;
                c.u64("maximum node tag")?;
                p.points.reserve(total);
                for _ in 0..nblocks {
                    let edim = c.i32("entity dimension")?;
                    c.i32("entity tag")?;
                    let extra = match (c.i32("parametric flag")?, edim) {
                        (0, _) => 0,
                        (1, 0..=3) => edim as usize,
                        _ => return Err(c.err("bad parametric flag or entity dimension")),
                    };
                    let n = c.count("number of nodes in block", 32 + 8 * extra)?;
                    let first = p.points.len();
                    let mut tags = Vec::with_capacity(n);
                    for _ in 0..n {
                        tags.push(c.u64("node tag")? as i64);
                    }
                    for (k, &t) in tags.iter().enumerate() {
                        let xyz = [c.f64("node x")?, c.f64("node y")?, c.f64("node z")?];
                        c.take(8 * extra, "parametric coordinates")?;
                        if node_index.insert(t, first + k).is_some() {
                            return Err(c.err(format!("node tag {t} appears twice")));
                        }
                        p.points.push(xyz);
                    }
                }
                if p.points.len() != total {
                    return Err(c.err(format!("$Nodes says {total} nodes but the blocks hold {}", p.points.len())));
                }
            }
            "Elements" => {
                let nblocks = c.count("number of element blocks", 20)?;
                let total = c.count("number of elements", 16)?;
                c.u64("minimum element tag")?;
                c.u64("maximum element tag")?;
                let mut seen = 0usize;
                for _ in 0..nblocks {
                    let edim = c.i32("entity dimension")? as i64;
                    let etag = c.i32("entity tag")? as i64;
                    let ty = c.i32("element type")? as i64;
                    let k = nodes_of_type(ty).ok_or_else(|| c.err(format!("unknown element type {ty}")))?;
                    let n = c.count("number of elements in block", 8 * (k + 1))?;
                    seen += n;
                    for _ in 0..n {
                        let t = c.u64("element tag")? as i64;
                        let mut nodes = Vec::with_capacity(k);
                        for _ in 0..k {
                            let nt = c.u64("element node tag")? as i64;
                            if ty == 2 || ty == 4 {
                                let &i = node_index.get(&nt).ok_or_else(|| {
                                    c.err(format!("element {t} uses node tag {nt}, which $Nodes does not define"))
                                })?;
                                nodes.push(i);
                            }
                        }
                        if ty == 2 || ty == 4 {
                            p.elems.push((t, ty, nodes, edim, etag));
                        }
                    }
                }
                if seen != total {
                    return Err(c.err(format!("$Elements says {total} elements but the blocks hold {seen}")));
                }
            }
            _ => {
                // An unknown section: skip to its end marker.
                let end = format!("\n$End{name}");
                let rest = &c.bytes[c.pos..];
                let at = rest
                    .windows(end.len())
                    .position(|w| w == end.as_bytes())
                    .ok_or_else(|| c.err(format!("section ${name} has no $End{name}")))?;
                c.pos += at;
            }
        }
        end_section(&mut c, &name)?;
    }
    let at = c.pos;
    assemble(p, |m| Cursor::new(bytes, at, path).err(m))
}
