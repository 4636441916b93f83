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
