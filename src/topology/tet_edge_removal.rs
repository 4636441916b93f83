//! Edge removal (Shewchuk 2002): the tets around an edge are replaced by two tets on each
//! triangle of a triangulation of the edge's ring polygon, the triangulation chosen by dynamic
//! programming over the polygon (Klincsek 1980).

use super::tet_ops::{NewTets, TetPatch};
use super::tetmesh::{EdgeShell, TVertexId, TetId, TetMesh, EDGE_VERTICES};
use super::Refusal;
use crate::predicates::{orient3d, Sign};
use glam::DVec3;
use smallvec::SmallVec;

impl TetMesh {
    /// Checks removing the interior edge of the shell: the n tets around it become 2n - 4 tets
    /// over a triangulation of the ring polygon, chosen by dynamic programming to maximise the
    /// worst radius ratio among the triangulations whose tets are all positive (exact).
    ///
    /// ```text
    ///      ring c0 .. c(n-1) around a-b           each ring triangle (ci, cj, ck) gives
    ///        c1-----c2                            (a, ci, cj, ck) and (ci, cj, ck, b)
    ///       /  \ a  /  \
    ///     c0 ---(a-b)--- c3    ==>  the edge a-b is gone
    ///       \  /    \  /
    ///        c5-----c4
    /// ```
    #[allow(clippy::needless_range_loop)]
    pub fn check_remove_edge_shell(&self, s: &EdgeShell) -> Result<TetPatch, Refusal> {
        if !s.closed {
            return Err(Refusal::BoundaryEdge);
        }
        let n = s.ring.len();
        if n < 3 {
            return Err(Refusal::TooSmall);
        }
        if n > 12 {
            return Err(Refusal::NotConvex);
        }
        let label = self.tets[s.tets[0]].label;
        // An edge inside one subdomain only.
        if s.tets.iter().any(|&t| self.tets[t].label != label) {
            return Err(Refusal::Constrained);
        }
        let (pa, pb) = (self.pos(s.a), self.pos(s.b));
        let pc: SmallVec<[DVec3; 12]> = s.ring.iter().map(|&c| self.pos(c)).collect();
        // Quality of the pair of tets on ring triangle (i, j, k); negative when invalid.
        let tri_q = |i: usize, j: usize, k: usize| -> f64 {
            let (ci, cj, ck) = (pc[i], pc[j], pc[k]);
            if orient3d(pa, ci, cj, ck) != Sign::Positive || orient3d(ci, cj, ck, pb) != Sign::Positive {
                return -1.0;
            }
            crate::quality::tet_radius_ratio([pa, ci, cj, ck]).min(crate::quality::tet_radius_ratio([ci, cj, ck, pb]))
        };
        let (worst, choice) = best_ring_triangulation(n, tri_q);
        // No valid triangulation of the ring.
        if worst < 0.0 {
            return Err(Refusal::NotConvex);
        }
        let (new, diagonals) = ring_tets(s.a, s.b, &s.ring, &choice, label);
        // The new diagonals must not exist already; for n = 3 the new face must not.
        for &(i, j) in &diagonals {
            if (j + 1) % n != i && (i + 1) % n != j && self.find_edge(s.ring[i], s.ring[j]).is_some() {
                return Err(Refusal::DuplicateEdge);
            }
        }
        if n == 3 && self.has_face(s.ring[0], s.ring[1], s.ring[2]) {
            return Err(Refusal::DuplicateEdge);
        }
        let mut plan = self.patch(s.tets.iter().copied().collect(), new);
        plan.min_quality = worst;
        Ok(plan)
    }

    /// Checks removing edge `e` (0..6, [`EDGE_VERTICES`]) of tet `t`; see
    /// [`TetMesh::check_remove_edge_shell`].
    pub fn check_remove_edge(&self, t: TetId, e: usize) -> Result<TetPatch, Refusal> {
        self.live_tet(t)?;
        let [i, j] = *EDGE_VERTICES.get(e).ok_or(Refusal::StaleKey)?;
        let s = self.edge_shell(t, i, j);
        self.check_remove_edge_shell(&s)
    }

    /// Removes edge `e` of `t` if allowed; returns the new tets.
    pub fn remove_edge(&mut self, t: TetId, e: usize) -> Result<SmallVec<[TetId; 16]>, Refusal> {
        let plan = self.check_remove_edge(t, e)?;
        Ok(self.apply_patch(plan).0)
    }
}

/// The triangulation of a ring of n <= 12 vertices (edge removal, Shewchuk 2002; the
/// polygon triangulation by dynamic programming of Klincsek 1980) that maximises the worst
/// `tri_q(i, k, j)` over its triangles (negative: not allowed). Returns that worst value
/// (negative when no triangulation is allowed) and `choice[i][j]`, the apex k over the
/// sub-polygon i..j.
pub(crate) fn best_ring_triangulation(
    n: usize,
    tri_q: impl Fn(usize, usize, usize) -> f64,
) -> (f64, [[usize; 12]; 12]) {
    let mut best = [[f64::INFINITY; 12]; 12];
    let mut choice = [[0usize; 12]; 12];
    for len in 2..n {
        for i in 0..n - len {
            let j = i + len;
            let mut b = -1.0;
            for k in i + 1..j {
                let q = tri_q(i, k, j);
                if q < 0.0 {
                    continue;
                }
                let left = if k > i + 1 { best[i][k] } else { f64::INFINITY };
                let right = if j > k + 1 { best[k][j] } else { f64::INFINITY };
                let v = q.min(left).min(right);
                if v > b {
                    b = v;
                    choice[i][j] = k;
                }
            }
            best[i][j] = b;
        }
    }
    (best[0][n - 1], choice)
}

/// The tets of a ring triangulation chosen by [`best_ring_triangulation`]: two per ring
/// triangle (a on one side, b on the other), and the diagonals of the ring it uses.
pub(crate) fn ring_tets(
    a: TVertexId,
    b: TVertexId,
    ring: &[TVertexId],
    choice: &[[usize; 12]; 12],
    label: u32,
) -> (NewTets, SmallVec<[(usize, usize); 12]>) {
    let n = ring.len();
    let mut new: NewTets = SmallVec::new();
    let mut stack: SmallVec<[(usize, usize); 12]> = SmallVec::new();
    stack.push((0, n - 1));
    let mut diagonals: SmallVec<[(usize, usize); 12]> = SmallVec::new();
    while let Some((i, j)) = stack.pop() {
        if j < i + 2 {
            continue;
        }
        let k = choice[i][j];
        let (ci, ck, cj) = (ring[i], ring[k], ring[j]);
        new.push(([a, ci, ck, cj], label));
        new.push(([ci, ck, cj, b], label));
        stack.push((i, k));
        stack.push((k, j));
        if k > i + 1 {
            diagonals.push((i, k));
        }
        if j > k + 1 {
            diagonals.push((k, j));
        }
    }
    (new, diagonals)
}
