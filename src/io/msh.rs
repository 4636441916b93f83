//! Gmsh 4.1 ASCII (.msh): one physical group per subdomain and a "boundary" group of facets, so
//! solvers reading the file find both the regions and the boundary to put conditions on.

use super::text::{fmt_f64, settle_dim, Tokens};
use super::{CellType, MeshData};
use crate::Error;
use std::collections::{BTreeMap, HashMap};

/// Nodes per element for the Gmsh element types we may meet (so unknown blocks can be skipped).
pub(super) fn nodes_of_type(t: i64) -> Option<usize> {
    Some(match t {
        15 => 1,
        1 => 2,
        2 | 8 => 3,
        3 | 4 | 26 => 4,
        7 | 27 => 5,
        6 | 9 | 28 => 6,
        5 | 16 => 8,
        10 | 20 => 9,
        11 | 21 => 10,
        22 => 12,
        19 => 13,
        14 => 14,
        18 | 23 | 24 => 15,
        13 => 18,
        17 | 29 => 20,
        25 => 21,
        12 => 27,
        30 => 35,
        31 => 56,
        _ => return None,
    })
}

/// Name of the physical group written when a mesh has no subdomain labels, so that reading the
/// file back gives `subdomain: None` again.
const PLAIN: &str = "domain";

pub(crate) fn read(s: &str, path: &str) -> Result<MeshData, Error> {
    let mut t = Tokens::new(s, path, None, 1);
    let mut names: HashMap<(i64, i64), String> = HashMap::new();
    let mut entity_phys: HashMap<(i64, i64), i64> = HashMap::new();
    let mut node_index: HashMap<i64, usize> = HashMap::new();
    let mut points: Vec<[f64; 3]> = Vec::new();
    // (element tag, type, nodes, entity dim, entity tag)
    let mut elems: Vec<(i64, i64, Vec<usize>, i64, i64)> = Vec::new();
    let mut saw_format = false;
    let mut saw_nodes = false;
    while let Some(sec) = t.peek() {
        let sline = t.line();
        t.next("section")?;
        if !sec.starts_with('$') {
            return Err(t.err_at(sline, format!("expected a $Section, found {sec:?}")));
        }
        let name = &sec[1..];
        if !saw_format && name != "MeshFormat" {
            return Err(t.err_at(sline, "the file does not start with $MeshFormat"));
        }
        match name {
            "MeshFormat" => {
                let v = t.next("version")?;
                if v != "4.1" {
                    return Err(t.err_at(t.prev_line(), format!("msh version {v} not supported (only 4.1 ASCII)")));
                }
                if t.i64("file type")? != 0 {
                    return Err(t.err_at(t.prev_line(), "binary msh not supported (file type must be 0)"));
                }
                t.i64("data size")?;
                saw_format = true;
            }
            "PhysicalNames" => {
                let n = t.count("number of physical names", 3)?;
                for _ in 0..n {
                    let line = t.line();
                    let toks = t.rest_of_line();
                    if toks.len() < 3 {
                        return Err(t.err_at(line, "a physical name needs: dimension tag \"name\""));
                    }
                    let num = |x: &str| {
                        x.parse::<i64>().map_err(|_| t.err_at(line, format!("physical name: {x:?} is not an integer")))
                    };
                    let (d, tag) = (num(toks[0])?, num(toks[1])?);
                    let nm = toks[2..].join(" ");
                    names.insert((d, tag), nm.trim_matches('"').to_string());
                }
            }
            "Entities" => {
                let mut counts = [0usize; 4];
                for c in counts.iter_mut() {
                    *c = t.count("number of entities", 5)?;
                }
                for (d, &c) in counts.iter().enumerate() {
                    for _ in 0..c {
                        let tag = t.i64("entity tag")?;
                        let ncoords = if d == 0 { 3 } else { 6 };
                        for _ in 0..ncoords {
                            t.f64("entity bounding box")?;
                        }
                        let np = t.count("number of physical tags", 1)?;
                        for k in 0..np {
                            let p = t.i64("physical tag")?;
                            if k == 0 {
                                entity_phys.insert((d as i64, tag), p);
                            }
                        }
                        if d > 0 {
                            let nb = t.count("number of bounding entities", 1)?;
                            for _ in 0..nb {
                                t.i64("bounding entity tag")?;
                            }
                        }
                    }
                }
            }
            "Nodes" => {
                if saw_nodes {
                    return Err(t.err_at(sline, "a second $Nodes section"));
                }
                saw_nodes = true;
                let nblocks = t.count("number of node blocks", 4)?;
                let total = t.count("number of nodes", 4)?;
                t.i64("minimum node tag")?;
                t.i64("maximum node tag")?;
                points.reserve(total);
                for _ in 0..nblocks {
                    let edim = t.i64("entity dimension")?;
                    t.i64("entity tag")?;
                    let param = t.i64("parametric flag")?;
                    let extra = match (param, edim) {
                        (0, _) => 0,
                        (1, 0..=3) => edim as usize,
                        _ => return Err(t.err_at(t.prev_line(), "bad parametric flag or entity dimension")),
                    };
                    let n = t.count("number of nodes in block", 4 + extra)?;
                    let first = points.len();
                    let mut tags = Vec::with_capacity(n);
                    for _ in 0..n {
                        tags.push(t.i64("node tag")?);
                    }
                    for (k, &tag) in tags.iter().enumerate() {
                        let p = [t.f64("node x")?, t.f64("node y")?, t.f64("node z")?];
                        for _ in 0..extra {
                            t.f64("parametric coordinate")?;
                        }
                        if node_index.insert(tag, first + k).is_some() {
                            return Err(t.err_at(t.prev_line(), format!("node tag {tag} appears twice")));
                        }
                        points.push(p);
                    }
                }
                if points.len() != total {
                    return Err(t.err(format!("$Nodes header says {total} nodes but the blocks hold {}", points.len())));
                }
            }
            "Elements" => {
                let nblocks = t.count("number of element blocks", 4)?;
                let total = t.count("number of elements", 2)?;
                t.i64("minimum element tag")?;
                t.i64("maximum element tag")?;
                let mut seen = 0usize;
                for _ in 0..nblocks {
                    let edim = t.i64("entity dimension")?;
                    let etag = t.i64("entity tag")?;
                    let ty = t.i64("element type")?;
                    let k = nodes_of_type(ty)
                        .ok_or_else(|| t.err_at(t.prev_line(), format!("unknown element type {ty}")))?;
                    let n = t.count("number of elements in block", k + 1)?;
                    seen += n;
                    for _ in 0..n {
                        let tag = t.i64("element tag")?;
                        let mut nodes = Vec::with_capacity(k);
                        for _ in 0..k {
                            let nt = t.i64("element node tag")?;
                            if ty == 2 || ty == 4 {
                                let &i = node_index.get(&nt).ok_or_else(|| {
                                    t.err_at(
                                        t.prev_line(),
                                        format!("element {tag} uses node tag {nt}, which $Nodes does not define"),
                                    )
                                })?;
                                nodes.push(i);
                            }
                        }
                        if ty == 2 || ty == 4 {
                            elems.push((tag, ty, nodes, edim, etag));
                        }
                    }
                }
                if seen != total {
                    return Err(t.err(format!("$Elements header says {total} elements but the blocks hold {seen}")));
                }
            }
            _ => {
                // An unknown section: skip to its end marker.
                let end = format!("$End{name}");
                loop {
                    let x = t.next(&format!("section {sec} (no {end})"))?;
                    if x == end {
                        break;
                    }
                }
                continue;
            }
        }
        let end = format!("$End{name}");
        let x = t.next(&end)?;
        if x != end {
            return Err(t.err_at(t.prev_line(), format!("expected {end}, found {x:?}")));
        }
    }
    let last = t.line();
    if !saw_format {
        return Err(t.err_at(last, "empty file: no $MeshFormat"));
    }
    assemble(Parsed { names, entity_phys, points, elems }, |m| t.err_at(last, m))
}

/// What a reader (text or binary) collects before the cells are put in order.
pub(super) struct Parsed {
    /// Physical names by (dimension, tag).
    pub names: HashMap<(i64, i64), String>,
    /// The first physical tag of each (dimension, entity tag).
    pub entity_phys: HashMap<(i64, i64), i64>,
    pub points: Vec<[f64; 3]>,
    /// (element tag, type, nodes, entity dim, entity tag) of the triangles and tetrahedra.
    pub elems: Vec<(i64, i64, Vec<usize>, i64, i64)>,
}

/// Keeps the highest-dimensional cells in element-tag order with their subdomain labels.
pub(super) fn assemble(p: Parsed, err: impl Fn(String) -> Error) -> Result<MeshData, Error> {
    let Parsed { names, entity_phys, mut points, elems } = p;
    let want = if elems.iter().any(|e| e.1 == 4) { 4 } else { 2 };
    let cell_type = if want == 4 { CellType::Tetra } else { CellType::Triangle };
    let mut kept: Vec<_> = elems.into_iter().filter(|e| e.1 == want).collect();
    if kept.is_empty() {
        return Err(err("no triangles (type 2) or tetrahedra (type 4) in the file".into()));
    }
    // Element tags give the cell order (our writer groups cells by subdomain).
    kept.sort_by_key(|e| e.0);
    let mut cells = Vec::with_capacity(kept.len() * cell_type.nodes());
    let mut labels = Vec::with_capacity(kept.len());
    let mut plain = true;
    for (_, _, nodes, edim, etag) in &kept {
        cells.extend_from_slice(nodes);
        let label = match entity_phys.get(&(*edim, *etag)) {
            Some(&p) => {
                plain &= names.get(&(*edim, p)).map(String::as_str) == Some(PLAIN);
                p
            }
            None => {
                plain = false;
                *etag
            }
        };
        let label = i32::try_from(label).map_err(|_| err(format!("subdomain tag {label} does not fit in 32 bits")))?;
        labels.push(label);
    }
    let plain = plain && labels.iter().all(|&l| l == labels[0]);
    let dim = settle_dim(&mut points, cell_type);
    Ok(MeshData { dim, cell_type, points, cells, subdomain: if plain { None } else { Some(labels) } })
}

fn bbox<'a>(pts: impl Iterator<Item = &'a [f64; 3]>) -> [f64; 6] {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pts {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if lo[0] > hi[0] {
        lo = [0.0; 3];
        hi = [0.0; 3];
    }
    [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]]
}

/// What both writers emit: cells grouped by label (entity tags 1.. in label order) and the
/// boundary facets as one more entity.
pub(super) struct Plan {
    /// Dimension of the cells (2 or 3).
    pub cdim: usize,
    /// Gmsh element types of the cells and of the boundary facets.
    pub cty: i32,
    pub fty: i32,
    pub groups: BTreeMap<i32, Vec<usize>>,
    pub bnd: Vec<Vec<usize>>,
}

impl Plan {
    pub fn new(m: &MeshData) -> Plan {
        let cdim = if m.cell_type == CellType::Tetra { 3 } else { 2 };
        let (cty, fty) = if cdim == 3 { (4, 2) } else { (2, 1) };
        let mut groups: BTreeMap<i32, Vec<usize>> = BTreeMap::new();
        for i in 0..m.num_cells() {
            let l = m.subdomain.as_ref().map_or(1, |s| s[i]);
            groups.entry(l).or_default().push(i);
        }
        Plan { cdim, cty, fty, groups, bnd: m.boundary_facets() }
    }

    /// The $PhysicalNames section (text in both forms).
    pub fn physical_names(&self, m: &MeshData) -> String {
        let mut s = String::from("$PhysicalNames\n");
        s.push_str(&format!("{}\n", self.groups.len() + usize::from(!self.bnd.is_empty())));
        if !self.bnd.is_empty() {
            s.push_str(&format!("{} 1 \"boundary\"\n", self.cdim - 1));
        }
        for &l in self.groups.keys() {
            if m.subdomain.is_some() {
                s.push_str(&format!("{} {l} \"subdomain_{l}\"\n", self.cdim));
            } else {
                s.push_str(&format!("{} {l} \"{PLAIN}\"\n", self.cdim));
            }
        }
        s.push_str("$EndPhysicalNames\n");
        s
    }

    /// The entities: (dimension, tag, bounding box, physical tag), boundary first.
    pub fn entities(&self, m: &MeshData) -> Vec<(usize, i32, [f64; 6], i32)> {
        let mut v = Vec::new();
        if !self.bnd.is_empty() {
            v.push((self.cdim - 1, 1, bbox(self.bnd.iter().flatten().map(|&i| &m.points[i])), 1));
        }
        for (e, (&l, cs)) in self.groups.iter().enumerate() {
            let bb = bbox(cs.iter().flat_map(|&c| m.cell(c)).map(|&i| &m.points[i]));
            v.push((self.cdim, e as i32 + 1, bb, l));
        }
        v
    }
}

pub(crate) fn write(m: &MeshData) -> String {
    let n = m.num_cells();
    let plan = Plan::new(m);
    let Plan { cdim, cty, fty, ref groups, ref bnd } = plan;
    let mut s = String::with_capacity(64 * (m.points.len() + n + bnd.len()) + 1024);
    s.push_str("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
    s.push_str(&plan.physical_names(m));
    s.push_str("$Entities\n");
    let entities = plan.entities(m);
    let mut counts = [0usize; 4];
    for e in &entities {
        counts[e.0] += 1;
    }
    s.push_str(&format!("{} {} {} {}\n", counts[0], counts[1], counts[2], counts[3]));
    for (_, tag, bb, phys) in &entities {
        let bb: Vec<String> = bb.iter().map(|&x| fmt_f64(x)).collect();
        s.push_str(&format!("{tag} {} 1 {phys} 0\n", bb.join(" ")));
    }
    s.push_str("$EndEntities\n$Nodes\n");
    let np = m.points.len();
    if np == 0 {
        s.push_str("0 0 0 0\n");
    } else {
        s.push_str(&format!("1 {np} 1 {np}\n{cdim} 1 0 {np}\n"));
        for i in 1..=np {
            s.push_str(&format!("{i}\n"));
        }
        for p in &m.points {
            s.push_str(&format!("{} {} {}\n", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2])));
        }
    }
    s.push_str("$EndNodes\n$Elements\n");
    let nblocks = groups.len() + usize::from(!bnd.is_empty());
    let total = n + bnd.len();
    s.push_str(&format!("{nblocks} {total} {} {total}\n", if total == 0 { 0 } else { 1 }));
    // Cells keep tags 1..=n in their original order so a reader can restore it.
    for (e, cs) in groups.values().enumerate() {
        s.push_str(&format!("{cdim} {} {cty} {}\n", e + 1, cs.len()));
        for &c in cs {
            let nodes: Vec<String> = m.cell(c).iter().map(|v| (v + 1).to_string()).collect();
            s.push_str(&format!("{} {}\n", c + 1, nodes.join(" ")));
        }
    }
    if !bnd.is_empty() {
        s.push_str(&format!("{} 1 {fty} {}\n", cdim - 1, bnd.len()));
        for (j, f) in bnd.iter().enumerate() {
            let nodes: Vec<String> = f.iter().map(|v| (v + 1).to_string()).collect();
            s.push_str(&format!("{} {}\n", n + j + 1, nodes.join(" ")));
        }
    }
    s.push_str("$EndElements\n");
    s
}
