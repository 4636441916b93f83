//! Edge removal (Shewchuk 2002): the tets around an edge are replaced by two tets on each
//! triangle of a triangulation of the edge's ring polygon, the triangulation chosen by dynamic
//! programming over the polygon (Klincsek 1980). The 3-2 and 4-4 flips are its cases n = 3, 4.

use super::tet_ops::{NewTets, TetPatch};
use super::tetmesh::{EdgeShell, TVertexId, TetId, TetMesh, EDGE_VERTICES};
use super::Refusal;
use crate::predicates::{orient3d, Sign};
use crate::quality::tet_radius_ratio;
use glam::DVec3;
use smallvec::SmallVec;

/// Largest ring an edge removal triangulates (the tables of the dynamic programming).
const MAX_RING: usize = 12;

/// What a ring retriangulation maximises over the tets it makes (see
/// [`TetMesh::ring_retriangulation`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Objective {
    /// The worst quality of a new tet (Shewchuk 2002's edge removal).
    Worst,
    /// The summed quality of the new tets (what a mesh's mean quality gains).
    Sum,
}

impl TetMesh {
    /// The optimal retriangulation of the ring of shell `s`: the tets around the edge a-b are
    /// replaced by the two tets (a, ci, cj, ck) and (ci, cj, ck, b) on each triangle of a
    /// triangulation of the ring polygon c0 .. c(n-1), n <= 12.
    ///
    /// ```text
    ///      ring c0 .. c(n-1) around a-b           each ring triangle (ci, cj, ck) gives
    ///        c1-----c2                            (a, ci, cj, ck) and (ci, cj, ck, b)
    ///       /  \ a  /  \
    ///     c0 ---(a-b)--- c3    ==>  the edge a-b is gone
    ///       \  /    \  /
    ///        c5-----c4
    /// ```
    ///
    /// Among the triangulations whose tets are all positive (exact orient3d) and allowed by
    /// `quality` (a negative quality forbids a tet), the one with the largest `objective` of
    /// `quality` over its tets is taken, by dynamic programming over the polygon (Klincsek
    /// 1980). `accept` sees that optimal value before the patch is built: `false` refuses with
    /// [`Refusal::NotBetter`]. An open shell (a boundary edge) is triangulated as the polygon
    /// closed by c0-c(n-1), which becomes a boundary edge in place of a-b.
    ///
    /// Refused when the ring is too small or too large, the tets of the shell hold different
    /// labels (an internal boundary), no allowed triangulation exists, or a new edge (or for
    /// n = 3 the new face) exists already. Returns the checked patch, whose
    /// [`TetPatch::min_quality`] is the worst radius ratio of its tets, and the optimal value.
    pub fn ring_retriangulation(
        &self,
        s: &EdgeShell,
        quality: impl Fn([DVec3; 4]) -> f64,
        objective: Objective,
        accept: impl Fn(f64) -> bool,
    ) -> Result<(TetPatch, f64), Refusal> {
        let (mut plan, value) = self.ring_patch(s, quality, objective, accept)?;
        let p = |v: TVertexId| self.pos(v);
        plan.min_quality = plan.new.iter().map(|(v, _)| tet_radius_ratio(v.map(p))).fold(f64::INFINITY, f64::min);
        Ok((plan, value))
    }

    /// [`TetMesh::ring_retriangulation`] with the patch's `min_quality` left unset.
    fn ring_patch(
        &self,
        s: &EdgeShell,
        quality: impl Fn([DVec3; 4]) -> f64,
        objective: Objective,
        accept: impl Fn(f64) -> bool,
    ) -> Result<(TetPatch, f64), Refusal> {
        let n = s.ring.len();
        if n < 3 {
            return Err(Refusal::TooSmall);
        }
        if n > MAX_RING {
            return Err(Refusal::NotConvex);
        }
        let label = self.tets[s.tets[0]].label;
        // An edge inside one subdomain only.
        if s.tets.iter().any(|&t| self.tets[t].label != label) {
            return Err(Refusal::Constrained);
        }
        let (pa, pb) = (self.pos(s.a), self.pos(s.b));
        let pc: SmallVec<[DVec3; MAX_RING]> = s.ring.iter().map(|&c| self.pos(c)).collect();
        // The qualities of the two tets on ring triangle (i, j, k); none when one is not
        // positive or is forbidden.
        let pair = |i: usize, j: usize, k: usize| -> Option<(f64, f64)> {
            let (ci, cj, ck) = (pc[i], pc[j], pc[k]);
            if orient3d(pa, ci, cj, ck) != Sign::Positive || orient3d(ci, cj, ck, pb) != Sign::Positive {
                return None;
            }
            Some((quality([pa, ci, cj, ck]), quality([ci, cj, ck, pb])))
        };
        let (value, choice) = best_ring_triangulation(n, objective, |i, j, k| {
            let (x, y) = pair(i, j, k)?;
            let q = match objective {
                Objective::Worst => x.min(y),
                Objective::Sum if x < 0.0 || y < 0.0 => return None,
                Objective::Sum => x + y,
            };
            if q < 0.0 {
                None
            } else {
                Some(q)
            }
        });
        // No allowed triangulation of the ring.
        let allowed = match objective {
            Objective::Worst => value >= 0.0,
            Objective::Sum => value.is_finite(),
        };
        if !allowed {
            return Err(Refusal::NotConvex);
        }
        if !accept(value) {
            return Err(Refusal::NotBetter);
        }
        let (new, diagonals) = ring_tets(s.a, s.b, &s.ring, &choice, label);
        // The new edges must not exist already: the diagonals, and for an open ring the edge
        // that closes it; for n = 3 around an interior edge, the new face must not.
        for &(i, j) in &diagonals {
            if self.find_edge(s.ring[i], s.ring[j]).is_some() {
                return Err(Refusal::DuplicateEdge);
            }
        }
        if !s.closed && self.find_edge(s.ring[0], s.ring[n - 1]).is_some() {
            return Err(Refusal::DuplicateEdge);
        }
        if n == 3 && s.closed && self.has_face(s.ring[0], s.ring[1], s.ring[2]) {
            return Err(Refusal::DuplicateEdge);
        }
        let plan = self.patch(s.tets.iter().copied().collect(), new);
        // Around a boundary edge the boundary surface changes: it must not fold.
        if !s.closed && !self.patch_unfolded(&plan) {
            return Err(Refusal::WouldFold);
        }
        Ok((plan, value))
    }

    /// Checks removing the interior edge of the shell: the n tets around it become 2n - 4 tets
    /// over the triangulation of the ring polygon that maximises the worst radius ratio (see
    /// [`TetMesh::ring_retriangulation`]).
    pub fn check_remove_edge_shell(&self, s: &EdgeShell) -> Result<TetPatch, Refusal> {
        if !s.closed {
            return Err(Refusal::BoundaryEdge);
        }
        let (mut plan, worst) = self.ring_patch(s, tet_radius_ratio, Objective::Worst, |_| true)?;
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

/// Apex choices of a ring triangulation: `choice[i][j]` is the apex k over the sub-polygon
/// i..j.
type Choice = [[usize; MAX_RING]; MAX_RING];

/// The triangulation of a ring of n <= 12 vertices that maximises `objective` of
/// `tri_q(i, k, j)` over its triangles (none: the triangle is not allowed), by dynamic
/// programming over the sub-polygons i..j (Klincsek 1980). Returns the optimal value (below
/// zero for the worst, not finite for the sum, when no triangulation is allowed) and the apex
/// choices.
#[allow(clippy::needless_range_loop)]
fn best_ring_triangulation(
    n: usize,
    objective: Objective,
    tri_q: impl Fn(usize, usize, usize) -> Option<f64>,
) -> (f64, Choice) {
    // The value of an empty sub-polygon (a ring edge), and the start of the search.
    let (empty, nothing) = match objective {
        Objective::Worst => (f64::INFINITY, -1.0),
        Objective::Sum => (0.0, f64::NEG_INFINITY),
    };
    let join = |x: f64, y: f64| match objective {
        Objective::Worst => x.min(y),
        Objective::Sum => x + y,
    };
    let mut best = [[empty; MAX_RING]; MAX_RING];
    let mut choice = [[0usize; MAX_RING]; MAX_RING];
    for len in 2..n {
        for i in 0..n - len {
            let j = i + len;
            let mut b = nothing;
            for k in i + 1..j {
                let Some(q) = tri_q(i, k, j) else { continue };
                let v = join(join(q, best[i][k]), best[k][j]);
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

/// The tets of a ring triangulation by its apex choices: two per ring triangle (a on one
/// side, b on the other), and the diagonals of the ring it uses.
fn ring_tets(
    a: TVertexId,
    b: TVertexId,
    ring: &[TVertexId],
    choice: &Choice,
    label: u32,
) -> (NewTets, SmallVec<[(usize, usize); MAX_RING]>) {
    let n = ring.len();
    let mut new: NewTets = SmallVec::new();
    let mut stack: SmallVec<[(usize, usize); MAX_RING]> = SmallVec::new();
    stack.push((0, n - 1));
    let mut diagonals: SmallVec<[(usize, usize); MAX_RING]> = SmallVec::new();
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quality::tet_dihedral_quality;
    use crate::testing::edge_shell;
    use crate::topology::Level;

    /// The n - 1 tets around the boundary edge from (0, 0, -1) to (0, 0, 1), the ring on a
    /// half circle: the boundary is flat at the edge (the plane y = 0).
    fn open_shell(n: usize) -> TetMesh {
        let mut p = vec![DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, 1.0)];
        for k in 0..n {
            let a = std::f64::consts::PI * k as f64 / (n - 1) as f64;
            p.push(DVec3::new(a.cos(), a.sin(), 0.0));
        }
        let t: Vec<[usize; 4]> = (0..n - 1).map(|k| [0, 1, 2 + k, 3 + k]).collect();
        TetMesh::from_arrays(&p, &t).expect("valid").0
    }

    fn axis(m: &TetMesh) -> EdgeShell {
        let v: Vec<TVertexId> = m.vertex_ids().collect();
        m.edge_shell_of(v[0], v[1]).expect("the axis")
    }

    #[test]
    fn worst_radius_ratio_is_the_edge_removal() {
        for n in 3..=10 {
            let m = edge_shell(n);
            let s = axis(&m);
            let plan = m.check_remove_edge_shell(&s).expect("removable");
            let (ring, worst) = m.ring_retriangulation(&s, tet_radius_ratio, Objective::Worst, |_| true).unwrap();
            assert_eq!(ring.new, plan.new, "n = {n}");
            assert_eq!((ring.min_quality, worst), (plan.min_quality, plan.min_quality));
        }
    }

    #[test]
    fn sum_objective_adds_the_new_tets() {
        for n in 3..=10 {
            let mut m = edge_shell(n);
            let (vol, s) = (m.volume(), axis(&m));
            let (plan, sum) = m.ring_retriangulation(&s, tet_dihedral_quality, Objective::Sum, |_| true).unwrap();
            let p = |v: TVertexId| m.pos(v);
            let total: f64 = plan.new.iter().map(|(v, _)| tet_dihedral_quality(v.map(p))).sum();
            assert!((total - sum).abs() < 1e-12, "n = {n}: {total} vs {sum}");
            // No triangulation of the ring sums more: the fans are among them.
            let pc: Vec<DVec3> = s.ring.iter().map(|&c| m.pos(c)).collect();
            let (pa, pb) = (m.pos(s.a), m.pos(s.b));
            for apex in 0..n {
                let fan: f64 = (1..n - 1)
                    .map(|k| {
                        let (ci, cj, ck) = (pc[apex], pc[(apex + k) % n], pc[(apex + k + 1) % n]);
                        tet_dihedral_quality([pa, ci, cj, ck]) + tet_dihedral_quality([ci, cj, ck, pb])
                    })
                    .sum();
                assert!(fan <= sum + 1e-12, "n = {n}, fan {apex}: {fan} > {sum}");
            }
            m.apply_patch(plan);
            m.validate(Level::Geometry).expect("valid");
            assert_eq!(m.num_tets(), 2 * n - 4);
            assert!((m.volume() - vol).abs() < 1e-12);
        }
    }

    #[test]
    fn refusals_leave_the_mesh_alone() {
        let m = edge_shell(6);
        let s = axis(&m);
        let r = m.ring_retriangulation(&s, tet_radius_ratio, Objective::Worst, |_| false);
        assert_eq!(r.err(), Some(Refusal::NotBetter));
        // A quality that forbids every tet leaves no triangulation.
        for objective in [Objective::Worst, Objective::Sum] {
            let r = m.ring_retriangulation(&s, |_| -1.0, objective, |_| true);
            assert_eq!(r.err(), Some(Refusal::NotConvex));
        }
        // An internal boundary through the edge.
        let mut c = m.clone();
        c.set_label(s.tets[0], 7);
        let r = c.ring_retriangulation(&s, tet_radius_ratio, Objective::Worst, |_| true);
        assert_eq!(r.err(), Some(Refusal::Constrained));
    }

    #[test]
    fn open_rings_close_on_a_new_boundary_edge() {
        for n in 3..=9 {
            let mut m = open_shell(n);
            let (vol, s) = (m.volume(), axis(&m));
            assert!(!s.closed);
            assert_eq!(m.check_remove_edge_shell(&s).err(), Some(Refusal::BoundaryEdge));
            for objective in [Objective::Worst, Objective::Sum] {
                let (plan, _) = m.ring_retriangulation(&s, tet_radius_ratio, objective, |_| true).unwrap();
                assert!(plan.min_quality > 0.0);
                assert_eq!(plan.created(), 2 * (n - 2));
            }
            let (plan, _) = m.ring_retriangulation(&s, tet_radius_ratio, Objective::Worst, |_| true).unwrap();
            m.apply_patch(plan);
            m.validate(Level::Geometry).expect("valid");
            assert!(m.find_edge(s.a, s.b).is_none());
            assert!(m.find_edge(s.ring[0], s.ring[n - 1]).is_some());
            assert!((m.volume() - vol).abs() < 1e-12);
            assert!(!m.edge_shell_of(s.ring[0], s.ring[n - 1]).expect("the new edge").closed);
        }
    }
}
