//! The cells around each vertex of a list of cells (triangles or tets given by vertex indices),
//! in compressed rows: one counting pass, one filling pass, no sort and no map.

/// Vertex indices as stored by the callers (`u32` in compact arrays, `usize` in input lists).
pub trait VertexIndex: Copy {
    /// The index as `usize`.
    fn ix(self) -> usize;
}

impl VertexIndex for u32 {
    #[inline]
    fn ix(self) -> usize {
        self as usize
    }
}

impl VertexIndex for usize {
    #[inline]
    fn ix(self) -> usize {
        self
    }
}

/// The cells of each of `n` vertices: vertex v's cells are `cells[start[v]..start[v + 1]]`, in
/// increasing order.
#[derive(Clone, Debug, Default)]
pub struct Incidence {
    /// Row starts, `n + 1` of them.
    pub start: Vec<u32>,
    /// Cell indices, row after row.
    pub cells: Vec<u32>,
}

impl Incidence {
    /// Builds the rows; every vertex index must be below `n`.
    pub fn new<T: VertexIndex, const K: usize>(n: usize, cells: &[[T; K]]) -> Incidence {
        let mut start = vec![0u32; n + 1];
        for c in cells {
            for &v in c {
                start[v.ix() + 1] += 1;
            }
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill: Vec<u32> = start[..n].to_vec();
        let mut list = vec![0u32; K * cells.len()];
        for (k, c) in cells.iter().enumerate() {
            for &v in c {
                list[fill[v.ix()] as usize] = k as u32;
                fill[v.ix()] += 1;
            }
        }
        Incidence { start, cells: list }
    }

    /// The cells around vertex v.
    #[inline]
    pub fn of(&self, v: usize) -> &[u32] {
        &self.cells[self.start[v] as usize..self.start[v + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_list_each_cell_under_each_of_its_vertices() {
        let tris: [[usize; 3]; 2] = [[0, 1, 2], [2, 1, 3]];
        let inc = Incidence::new(5, &tris);
        assert_eq!(inc.of(0), &[0]);
        assert_eq!(inc.of(1), &[0, 1]);
        assert_eq!(inc.of(2), &[0, 1]);
        assert_eq!(inc.of(3), &[1]);
        assert!(inc.of(4).is_empty());
        assert_eq!(inc.start.len(), 6);
    }
}
