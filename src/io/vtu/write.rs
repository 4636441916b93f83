//! The .vtu writer: one list of typed arrays, written as ASCII text or appended raw binary.

use super::super::measure::{tet_min_dihedral_values, tet_radius_ratio_values, triangle_q_values};
use super::super::text::fmt_f64;
use super::super::{CellType, MeshData, NodeKind};

/// The numbers of one output array.
enum Values<'a> {
    F64(&'a [[f64; 3]]),
    F64s(Vec<f64>),
    I64(Vec<i64>),
    I32(&'a [i32]),
    I32Owned(Vec<i32>),
    U8(Vec<u8>),
}

impl Values<'_> {
    fn vtk_type(&self) -> &'static str {
        match self {
            Values::F64(_) | Values::F64s(_) => "Float64",
            Values::I64(_) => "Int64",
            Values::I32(_) | Values::I32Owned(_) => "Int32",
            Values::U8(_) => "UInt8",
        }
    }
    fn byte_len(&self) -> usize {
        match self {
            Values::F64(v) => 24 * v.len(),
            Values::F64s(v) => 8 * v.len(),
            Values::I64(v) => 8 * v.len(),
            Values::I32(v) => 4 * v.len(),
            Values::I32Owned(v) => 4 * v.len(),
            Values::U8(v) => v.len(),
        }
    }
    /// Appends the values as little-endian bytes: on little-endian machines the arrays are
    /// their own bytes (one copy at memory speed), elsewhere each number is swapped.
    fn push_le(&self, out: &mut Vec<u8>) {
        out.reserve(self.byte_len());
        #[cfg(target_endian = "little")]
        match self {
            Values::F64(v) => out.extend_from_slice(bytemuck::cast_slice(v)),
            Values::F64s(v) => out.extend_from_slice(bytemuck::cast_slice(v)),
            Values::I64(v) => out.extend_from_slice(bytemuck::cast_slice(v)),
            Values::I32(v) => out.extend_from_slice(bytemuck::cast_slice(v)),
            Values::I32Owned(v) => out.extend_from_slice(bytemuck::cast_slice(v)),
            Values::U8(v) => out.extend_from_slice(v),
        }
        #[cfg(not(target_endian = "little"))]
        match self {
            Values::F64(v) => v.iter().flatten().for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Values::F64s(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Values::I64(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Values::I32(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Values::I32Owned(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Values::U8(v) => out.extend_from_slice(v),
        }
    }
    fn push_ascii(&self, s: &mut String, per_line: usize) {
        use std::fmt::Write;
        match self {
            Values::F64(v) => v.iter().for_each(|p| {
                let _ = writeln!(s, "          {} {} {}", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2]));
            }),
            Values::F64s(v) => push_wrapped(s, v.iter().map(|&x| fmt_f64(x)), per_line),
            Values::I64(v) => push_wrapped(s, v.iter().map(|x| x.to_string()), per_line),
            Values::I32(v) => push_wrapped(s, v.iter().map(|x| x.to_string()), per_line),
            Values::I32Owned(v) => push_wrapped(s, v.iter().map(|x| x.to_string()), per_line),
            Values::U8(v) => push_wrapped(s, v.iter().map(|x| x.to_string()), per_line),
        }
    }
}

/// One output array: the section it belongs to, its name and components.
struct OutArray<'a> {
    section: &'static str,
    name: &'static str,
    components: usize,
    values: Values<'a>,
}

/// The arrays a mesh is written as, in file order: point data (`node_kind`: the given kinds,
/// or for planar and tetrahedral meshes interior 0 / boundary 1 from the boundary facets),
/// points, cells, and cell data (quality: `q` for triangles, `radius_ratio` and
/// `min_dihedral` in degrees for tetrahedra; `subdomain` when labelled).
fn arrays<'a>(m: &'a MeshData, kinds: Option<&[NodeKind]>) -> Vec<OutArray<'a>> {
    let n = m.num_cells();
    let k = m.cell_type.nodes();
    let ty = if m.cell_type == CellType::Tetra { 10 } else { 5 };
    // 32-bit indices wherever they fit (every mesh below two billion nodes): half the bytes.
    let narrow = m.cells.len() < i32::MAX as usize && m.points.len() < i32::MAX as usize;
    let ints = |v: &mut dyn Iterator<Item = usize>| {
        if narrow {
            Values::I32Owned(v.map(|c| c as i32).collect())
        } else {
            Values::I64(v.map(|c| c as i64).collect())
        }
    };
    let mut v = Vec::new();
    let kinds: Option<Vec<u8>> = match kinds {
        Some(k) if k.len() == m.points.len() => Some(k.iter().map(|&k| k as u8).collect()),
        _ if m.dim == 2 || m.cell_type == CellType::Tetra => {
            let kind = |b: bool| if b { NodeKind::Boundary } else { NodeKind::Interior } as u8;
            Some(m.boundary_nodes().into_iter().map(kind).collect())
        }
        _ => None,
    };
    if let Some(k) = kinds {
        v.push(OutArray { section: "PointData", name: "node_kind", components: 1, values: Values::U8(k) });
    }
    v.extend([
        OutArray { section: "Points", name: "Points", components: 3, values: Values::F64(&m.points) },
        OutArray { section: "Cells", name: "connectivity", components: k, values: ints(&mut m.cells.iter().copied()) },
        OutArray { section: "Cells", name: "offsets", components: 1, values: ints(&mut (1..=n).map(|i| i * k)) },
        OutArray { section: "Cells", name: "types", components: 1, values: Values::U8(vec![ty; n]) },
    ]);
    let finite = |q: Vec<f64>| Values::F64s(q.into_iter().map(|x| if x.is_finite() { x } else { 0.0 }).collect());
    match m.cell_type {
        CellType::Triangle => {
            v.push(OutArray { section: "CellData", name: "q", components: 1, values: finite(triangle_q_values(m)) })
        }
        CellType::Tetra => {
            for (name, q) in
                [("radius_ratio", tet_radius_ratio_values(m)), ("min_dihedral", tet_min_dihedral_values(m))]
            {
                v.push(OutArray { section: "CellData", name, components: 1, values: finite(q) });
            }
        }
    }
    if let Some(sd) = &m.subdomain {
        v.push(OutArray { section: "CellData", name: "subdomain", components: 1, values: Values::I32(sd) });
    }
    v
}

/// Writes the mesh as ASCII arrays, or with `binary` as raw little-endian arrays appended
/// after the XML (each block led by its UInt64 byte count): exact, about a third of the size,
/// and written at memory speed.
pub(crate) fn write(m: &MeshData, kinds: Option<&[NodeKind]>, binary: bool) -> Vec<u8> {
    use std::fmt::Write;
    let n = m.num_cells();
    let arrays = arrays(m, kinds);
    let mut s = String::with_capacity(if binary { 4096 } else { 64 * (m.points.len() + n) + 1024 });
    s.push_str("<?xml version=\"1.0\"?>\n");
    s.push_str(
        "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n",
    );
    s.push_str("  <UnstructuredGrid>\n");
    let _ = writeln!(s, "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{n}\">", m.points.len());
    let mut offset = 0usize;
    let mut open: Option<&str> = None;
    for a in &arrays {
        if open != Some(a.section) {
            if let Some(o) = open {
                let _ = writeln!(s, "      </{o}>");
            }
            if a.section.ends_with("Data") {
                let _ = writeln!(s, "      <{} Scalars=\"{}\">", a.section, a.name);
            } else {
                let _ = writeln!(s, "      <{}>", a.section);
            }
            open = Some(a.section);
        }
        let comps = if a.components > 1 && a.name != "connectivity" {
            format!(" NumberOfComponents=\"{}\"", a.components)
        } else {
            String::new()
        };
        let _ = write!(s, "        <DataArray type=\"{}\" Name=\"{}\"{comps}", a.values.vtk_type(), a.name);
        if binary {
            let _ = writeln!(s, " format=\"appended\" offset=\"{offset}\"/>");
            offset += 8 + a.values.byte_len();
        } else {
            s.push_str(" format=\"ascii\">\n");
            a.values.push_ascii(&mut s, if a.name == "connectivity" { a.components } else { 20 });
            s.push_str("        </DataArray>\n");
        }
    }
    if let Some(o) = open {
        let _ = writeln!(s, "      </{o}>");
    }
    s.push_str("    </Piece>\n  </UnstructuredGrid>\n");
    if !binary {
        s.push_str("</VTKFile>\n");
        return s.into_bytes();
    }
    s.push_str("  <AppendedData encoding=\"raw\">\n   _");
    let mut out = s.into_bytes();
    out.reserve(offset + 64);
    for a in &arrays {
        out.extend_from_slice(&(a.values.byte_len() as u64).to_le_bytes());
        a.values.push_le(&mut out);
    }
    out.extend_from_slice(b"\n  </AppendedData>\n</VTKFile>\n");
    out
}

/// `per_line` numbers a line keeps long arrays readable.
fn push_wrapped(s: &mut String, items: impl Iterator<Item = String>, per_line: usize) {
    let mut k = 0;
    for item in items {
        s.push_str(if k == 0 { "          " } else { " " });
        s.push_str(&item);
        k += 1;
        if k == per_line {
            s.push('\n');
            k = 0;
        }
    }
    if k > 0 {
        s.push('\n');
    }
}
