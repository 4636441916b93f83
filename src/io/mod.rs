//! Mesh files and pictures. Every format reads and writes [`MeshData`], the plain-array form.

/// The kind of cell a [`MeshData`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellType {
    /// Three nodes per cell (planar or surface triangles).
    Triangle,
    /// Four nodes per cell, positively oriented.
    Tetra,
}

impl CellType {
    /// Nodes per cell.
    pub fn nodes(self) -> usize {
        match self {
            CellType::Triangle => 3,
            CellType::Tetra => 4,
        }
    }
}

/// A mesh as plain arrays with compact 0-based indices: what files hold.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshData {
    /// Embedding dimension: 2 for planar meshes (z is 0), 3 otherwise.
    pub dim: usize,
    /// The cell kind.
    pub cell_type: CellType,
    /// Node coordinates; z = 0 when `dim == 2`.
    pub points: Vec<[f64; 3]>,
    /// Cells, `cell_type.nodes()` indices each, flattened.
    pub cells: Vec<usize>,
    /// Optional subdomain label per cell.
    pub subdomain: Option<Vec<i32>>,
}

impl MeshData {
    /// Number of cells.
    pub fn num_cells(&self) -> usize {
        self.cells.len() / self.cell_type.nodes()
    }
    /// The nodes of cell `i`.
    pub fn cell(&self, i: usize) -> &[usize] {
        let k = self.cell_type.nodes();
        &self.cells[i * k..(i + 1) * k]
    }
}

mod binary;
pub mod check;
mod glyphs;
pub mod grid_file;
mod json;
pub mod measure;
mod medit;
mod msh;
mod msh_binary;
pub mod picture;
mod surface;
mod text;
mod vtu;

pub use binary::Encoding;
pub use check::{check_mesh, MeshCheck, Problem, ProblemKind};
pub use grid_file::{is_grid_file, read_grid_file, GridFile};
pub use measure::Measure;
pub use picture::{png_bytes, png_bytes_by, svg_bytes, svg_bytes_by, write_png, write_svg};

use crate::Error;
use std::path::Path;

/// A mesh file format, chosen from the file extension by [`read_mesh`] and [`write_mesh`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// Our own JSON layout (`.json`).
    Json,
    /// VTK XML unstructured grid (`.vtu`), ASCII or appended raw binary arrays.
    Vtu,
    /// Gmsh 4.1 (`.msh`), ASCII or binary.
    Msh,
    /// Medit / mmg (`.mesh`).
    Medit,
    /// Wavefront OBJ, triangles only (`.obj`).
    Obj,
    /// ASCII STL, triangles only (`.stl`).
    Stl,
    /// ASCII PLY, triangles only (`.ply`).
    Ply,
}

impl Format {
    /// Every format, in the order the fuzz body tries them.
    pub const ALL: [Format; 7] =
        [Format::Json, Format::Vtu, Format::Msh, Format::Medit, Format::Obj, Format::Stl, Format::Ply];

    /// The usual file extension (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            Format::Json => "json",
            Format::Vtu => "vtu",
            Format::Msh => "msh",
            Format::Medit => "mesh",
            Format::Obj => "obj",
            Format::Stl => "stl",
            Format::Ply => "ply",
        }
    }

    /// Whether the format has a binary form ([`Encoding::Binary`] applies).
    pub fn has_binary(self) -> bool {
        matches!(self, Format::Vtu | Format::Msh)
    }

    /// The format a path's extension names (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Format, Error> {
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default();
        Format::ALL.into_iter().find(|f| f.extension() == ext).ok_or_else(|| {
            Error::Invalid(format!(
                "unknown mesh file extension {:?} in {} (expected .json .vtu .msh .mesh .obj .stl .ply)",
                ext,
                path.display()
            ))
        })
    }
}

/// What a node of a mesh is, as the .vtu point data `node_kind` records it (the number is the
/// value written).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum NodeKind {
    /// Free: moved by the bar forces alone.
    Interior = 0,
    /// On the boundary d = 0.
    Boundary = 1,
    /// Held where it is: a point given to be fixed.
    Fixed = 2,
    /// Held where it is: a sharp corner or a point on a sharp edge, found by the mesher.
    Feature = 3,
    /// On an internal boundary d_I = 0 (2-D).
    Internal = 4,
}

impl MeshData {
    /// Checks the invariants every writer relies on, so a bad mesh fails before a file is half written.
    pub fn validate(&self) -> Result<(), Error> {
        let bad = |m: String| Err(Error::InvalidMesh(m));
        if self.dim != 2 && self.dim != 3 {
            return bad(format!("dim must be 2 or 3, not {}", self.dim));
        }
        if self.cell_type == CellType::Tetra && self.dim != 3 {
            return bad("tetrahedra need dim 3".into());
        }
        let k = self.cell_type.nodes();
        if self.cells.len() % k != 0 {
            return bad(format!("cells has {} entries, not a multiple of {k}", self.cells.len()));
        }
        for (i, p) in self.points.iter().enumerate() {
            if !p.iter().all(|c| c.is_finite()) {
                return bad(format!("point {i} has a non-finite coordinate {p:?}"));
            }
            if self.dim == 2 && p[2] != 0.0 {
                return bad(format!("point {i} of a 2-D mesh has z = {} (must be 0)", p[2]));
            }
        }
        let n = self.points.len();
        if let Some(j) = self.cells.iter().position(|&v| v >= n) {
            return bad(format!("cell {} uses node {} but there are {n} points", j / k, self.cells[j]));
        }
        if let Some(s) = &self.subdomain {
            if s.len() != self.num_cells() {
                return bad(format!("{} subdomain labels for {} cells", s.len(), self.num_cells()));
            }
        }
        Ok(())
    }

    /// Facets (edges of triangles, faces of tets) that belong to one cell only, oriented
    /// outward from that cell, in order of first appearance: the boundary files record.
    pub fn boundary_facets(&self) -> Vec<Vec<usize>> {
        self.boundary_facet_positions()
            .into_iter()
            .map(|at| {
                let k = self.cell_type.nodes();
                cell_facets(self.cell_type, self.cell(at / k)).swap_remove(at % k)
            })
            .collect()
    }

    /// The boundary facets as positions `cell * k + local` (k facets a cell, in the order of
    /// [`cell_facets`]), ascending. Facets are bucketed by their smallest node (a counting
    /// sort), and a facet is on the boundary when no other in its bucket has the same nodes:
    /// linear time, no hashing, and the same result however the buckets are filled (the
    /// buckets are checked in parallel). Indices are 32-bit where they fit (a third of the
    /// memory traffic of a 10^6-triangle mesh's 3x10^6 facets).
    fn boundary_facet_positions(&self) -> Vec<usize> {
        let total = self.num_cells() * self.cell_type.nodes();
        if total <= u32::MAX as usize && self.points.len() <= u32::MAX as usize {
            self.boundary_flags::<u32>()
        } else {
            self.boundary_flags::<usize>()
        }
    }

    /// See [`MeshData::boundary_facet_positions`]; `I` holds node and facet indices.
    fn boundary_flags<I: FacetIndex>(&self) -> Vec<usize> {
        use rayon::prelude::*;
        const TET: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];
        let k = self.cell_type.nodes();
        let total = self.num_cells() * k;
        // The facet's nodes, sorted (a triangle's edge repeats its larger node).
        let nodes = |c: &[usize], j: usize| -> [usize; 3] {
            match self.cell_type {
                CellType::Triangle => {
                    let (a, b) = (c[j], c[(j + 1) % 3]);
                    [a.min(b), a.max(b), a.max(b)]
                }
                CellType::Tetra => {
                    let mut f = TET[j].map(|l| c[l]);
                    f.sort_unstable();
                    f
                }
            }
        };
        let n = self.points.len();
        let mut start = vec![0usize; n + 1];
        for c in self.cells.chunks_exact(k) {
            for j in 0..k {
                start[nodes(c, j)[0] + 1] += 1;
            }
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut bucket = vec![(I::from(0), I::from(0), I::from(0)); total];
        for (i, c) in self.cells.chunks_exact(k).enumerate() {
            for j in 0..k {
                let at = i * k + j;
                let f = nodes(c, j);
                bucket[fill[f[0]]] = (I::from(f[1]), I::from(f[2]), I::from(at));
                fill[f[0]] += 1;
            }
        }
        drop(fill);
        // A flag per bucket entry: no other facet in its bucket has the same nodes. The
        // buckets are split into blocks of whole buckets, checked in parallel.
        let mut lone = vec![false; total];
        let blocks = n.div_ceil(8192).max(1);
        let mut parts: Vec<(usize, &mut [bool])> = Vec::with_capacity(blocks);
        let mut rest: &mut [bool] = &mut lone;
        for b in 0..blocks {
            let (v0, v1) = (b * n / blocks, (b + 1) * n / blocks);
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(start[v1] - start[v0]);
            parts.push((v0, head));
            rest = tail;
        }
        parts.into_par_iter().enumerate().for_each(|(b, (v0, flags))| {
            let v1 = (b + 1) * n / blocks;
            for v in v0..v1 {
                let (lo, hi) = (start[v], start[v + 1]);
                let bk = &bucket[lo..hi];
                for (i, x) in bk.iter().enumerate() {
                    flags[lo - start[v0] + i] = !bk.iter().enumerate().any(|(j, y)| j != i && (y.0, y.1) == (x.0, x.1));
                }
            }
        });
        let mut boundary = vec![false; total];
        for (x, _) in bucket.iter().zip(&lone).filter(|(_, &l)| l) {
            boundary[x.2.get()] = true;
        }
        (0..total).filter(|&at| boundary[at]).collect()
    }

    /// Whether each node lies on a boundary facet.
    pub fn boundary_nodes(&self) -> Vec<bool> {
        let k = self.cell_type.nodes();
        let mut on = vec![false; self.points.len()];
        for at in self.boundary_facet_positions() {
            let c = self.cell(at / k);
            match self.cell_type {
                CellType::Triangle => [at % k, (at % k + 1) % 3].iter().for_each(|&l| on[c[l]] = true),
                CellType::Tetra => (0..4).filter(|&l| l != at % k).for_each(|l| on[c[l]] = true),
            }
        }
        on
    }
}

/// An index type for the boundary-facet buckets: u32 where the mesh allows, usize beyond.
trait FacetIndex: Copy + PartialEq + Send + Sync {
    fn from(x: usize) -> Self;
    fn get(self) -> usize;
}

impl FacetIndex for u32 {
    #[inline]
    fn from(x: usize) -> Self {
        x as u32
    }
    #[inline]
    fn get(self) -> usize {
        self as usize
    }
}

impl FacetIndex for usize {
    #[inline]
    fn from(x: usize) -> Self {
        x
    }
    #[inline]
    fn get(self) -> usize {
        self
    }
}

/// The facets of one cell, oriented outward for counter-clockwise triangles and positive tets.
pub(crate) fn cell_facets(ct: CellType, c: &[usize]) -> Vec<Vec<usize>> {
    match ct {
        CellType::Triangle => vec![vec![c[0], c[1]], vec![c[1], c[2]], vec![c[2], c[0]]],
        CellType::Tetra => {
            vec![vec![c[1], c[2], c[3]], vec![c[0], c[3], c[2]], vec![c[0], c[1], c[3]], vec![c[0], c[2], c[1]]]
        }
    }
}

pub(crate) fn sorted(f: &[usize]) -> Vec<usize> {
    let mut s = f.to_vec();
    s.sort_unstable();
    s
}

/// Reads a mesh file, choosing the format from the extension.
pub fn read_mesh(path: &Path) -> Result<MeshData, Error> {
    let format = Format::from_path(path)?;
    let bytes =
        std::fs::read(path).map_err(|e| Error::Io { path: path.display().to_string(), message: e.to_string() })?;
    read_named(&bytes, format, &path.display().to_string())
}

/// Writes a mesh file, choosing the format from the extension and the encoding by size
/// ([`Encoding::Auto`]).
pub fn write_mesh(path: &Path, mesh: &MeshData) -> Result<(), Error> {
    write_mesh_with(path, mesh, Encoding::Auto)
}

/// Writes a mesh file in the format the extension names, with the given [`WriteOptions`] (or
/// just an [`Encoding`]).
pub fn write_mesh_with<'a>(path: &Path, mesh: &MeshData, opts: impl Into<WriteOptions<'a>>) -> Result<(), Error> {
    let format = Format::from_path(path)?;
    let bytes = write_mesh_bytes_with(mesh, format, opts)?;
    write_file(path, &bytes)
}

/// Writes `bytes` to `path` whole or not at all: a regular file (or a new one) is written to a
/// temporary file beside it, flushed and renamed over it, so that a full disk or a killed run
/// leaves the old file (or none) instead of half a file; anything else that exists already (a
/// device such as /dev/null, a pipe) is written directly.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    use std::io::Write;
    let err = |e: std::io::Error| Error::Io { path: path.display().to_string(), message: e.to_string() };
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => {
            return Err(Error::Io { path: path.display().to_string(), message: "is a directory".into() })
        }
        Ok(m) if !m.is_file() => return std::fs::write(path, bytes).map_err(err),
        _ => {}
    }
    // A link to a file: the file it names is replaced, the link kept.
    let target;
    let path = if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        target = std::fs::canonicalize(path).map_err(err)?;
        target.as_path()
    } else {
        path
    };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.{}.partial", std::process::id()));
    // The rename makes the new file appear whole or not at all, to readers and if this process
    // stops. No sync to the disk before it: that is the file system's business, as for any
    // ordinary write, and it cost 0.07 to 0.18 s for a 62 MB mesh here.
    let written = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(e));
    }
    Ok(())
}

/// Reads a mesh from memory (errors name the source `<memory>`).
pub fn read_mesh_bytes(bytes: &[u8], format: Format) -> Result<MeshData, Error> {
    read_named(bytes, format, "<memory>")
}

/// Writes a mesh to memory in the given format, the encoding chosen by size
/// ([`Encoding::Auto`]).
pub fn write_mesh_bytes(mesh: &MeshData, format: Format) -> Result<Vec<u8>, Error> {
    write_mesh_bytes_with(mesh, format, WriteOptions::default())
}

/// How a mesh file is written: the encoding, and what the file records beyond the mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WriteOptions<'a> {
    /// Text or binary (formats without a binary form refuse [`Encoding::Binary`]).
    pub encoding: Encoding,
    /// The kind of every node (one per point), which .vtu files record as point data
    /// `node_kind` (the other formats have no place for it).
    pub node_kind: Option<&'a [NodeKind]>,
}

impl From<Encoding> for WriteOptions<'_> {
    fn from(encoding: Encoding) -> Self {
        WriteOptions { encoding, node_kind: None }
    }
}

impl<'a> From<Option<&'a [NodeKind]>> for WriteOptions<'a> {
    fn from(node_kind: Option<&'a [NodeKind]>) -> Self {
        WriteOptions { encoding: Encoding::Auto, node_kind }
    }
}

/// Writes a mesh to memory in the given format with the given [`WriteOptions`] (or just an
/// [`Encoding`]). [`Encoding::Binary`] for a format without a binary form is an error;
/// [`Encoding::Auto`] then writes text.
pub fn write_mesh_bytes_with<'a>(
    mesh: &MeshData,
    format: Format,
    opts: impl Into<WriteOptions<'a>>,
) -> Result<Vec<u8>, Error> {
    let WriteOptions { encoding, node_kind: kinds } = opts.into();
    mesh.validate()?;
    if let Some(k) = kinds {
        if k.len() != mesh.points.len() {
            return Err(Error::Invalid(format!("{} node kinds for {} points", k.len(), mesh.points.len())));
        }
    }
    if encoding == Encoding::Binary && !format.has_binary() {
        return Err(Error::Invalid(format!(
            "the .{} format has no binary form (binary output: .vtu or .msh)",
            format.extension()
        )));
    }
    let binary = format.has_binary() && encoding.is_binary(mesh.num_cells());
    let s = match format {
        Format::Json => json::write(mesh),
        Format::Vtu => return Ok(vtu::write(mesh, kinds, binary)),
        Format::Msh if binary => return Ok(msh_binary::write(mesh)),
        Format::Msh => msh::write(mesh),
        Format::Medit => medit::write(mesh),
        Format::Obj => surface::write_obj(mesh),
        Format::Stl => surface::write_stl(mesh),
        Format::Ply => surface::write_ply(mesh),
    };
    Ok(s.into_bytes())
}

fn read_named(bytes: &[u8], format: Format, name: &str) -> Result<MeshData, Error> {
    let m = match format {
        Format::Vtu => vtu::read(bytes, name)?,
        Format::Msh if msh_binary::is_binary(bytes) => msh_binary::read(bytes, name)?,
        _ => {
            let s = std::str::from_utf8(bytes).map_err(|e| {
                let line = 1 + bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count();
                Error::Parse {
                    path: name.to_string(),
                    line,
                    message: format!("the file is not UTF-8 text (the .{} reader takes text)", format.extension()),
                }
            })?;
            match format {
                Format::Json => json::read(s, name)?,
                Format::Vtu => vtu::read(bytes, name)?,
                Format::Msh => msh::read(s, name)?,
                Format::Medit => medit::read(s, name)?,
                Format::Obj => surface::read_obj(s, name)?,
                Format::Stl => surface::read_stl(s, name)?,
                Format::Ply => surface::read_ply(s, name)?,
            }
        }
    };
    // Readers check as they go; this catches anything they missed, still as a parse error.
    m.validate().map_err(|e| Error::Parse { path: name.to_string(), line: 0, message: e.to_string() })?;
    Ok(m)
}

/// Fuzz body: every reader must return instead of panicking, and whatever one accepts must
/// survive its own writer and reader unchanged.
pub fn fuzz_read_all(data: &[u8]) {
    for format in Format::ALL {
        if let Ok(m) = read_mesh_bytes(data, format) {
            let bytes = write_mesh_bytes(&m, format)
                .unwrap_or_else(|e| panic!("{format:?}: writing what was read failed: {e}"));
            let back = read_mesh_bytes(&bytes, format).unwrap_or_else(|e| {
                panic!("{format:?}: reading our own output failed: {e}\n{}", String::from_utf8_lossy(&bytes))
            });
            assert_eq!(m, back, "{format:?}: round trip changed the mesh");
        }
    }
}

impl MeshData {
    /// The plain-array form of a planar triangle mesh (face labels become subdomains when any
    /// is non-zero).
    pub fn from_trimesh2(m: &crate::topology::TriMesh<glam::DVec2>) -> MeshData {
        let crate::topology::MeshArrays { points: pts, cells: tris, labels, .. } = m.to_arrays();
        MeshData {
            dim: 2,
            cell_type: CellType::Triangle,
            points: pts.iter().map(|p| [p.x, p.y, 0.0]).collect(),
            cells: tris.iter().flatten().copied().collect(),
            subdomain: labels.iter().any(|&l| l != 0).then(|| labels.iter().map(|&l| l as i32).collect()),
        }
    }
    /// The plain-array form of a surface triangle mesh.
    pub fn from_trimesh3(m: &crate::topology::TriMesh<glam::DVec3>) -> MeshData {
        let crate::topology::MeshArrays { points: pts, cells: tris, labels, .. } = m.to_arrays();
        MeshData {
            dim: 3,
            cell_type: CellType::Triangle,
            points: pts.iter().map(|p| [p.x, p.y, p.z]).collect(),
            cells: tris.iter().flatten().copied().collect(),
            subdomain: labels.iter().any(|&l| l != 0).then(|| labels.iter().map(|&l| l as i32).collect()),
        }
    }
}
