//! Edge collapse (with the link condition) and removal of a tet from the boundary.

use super::tet_ops::{NewTets, TetPatch};
use super::tetmesh::{face_key, EdgeShell, TVertexId, TetId, TetMesh, EDGE_VERTICES, FACE_VERTICES};
use super::{Refusal, VertexTag};
use glam::DVec3;
use slotmap::Key;
use smallvec::SmallVec;

impl TetMesh {
    // ===================== collapse =====================

    /// Checks collapsing edge `e` of `t` with its first vertex a = `v[i]` merging into the second
    /// b = `v[j]` (swapped when `reverse`), which ends at `pos`. Refused when it fails the link
    /// condition Lk(a) ∩ Lk(b) = Lk(ab) (the boundary counted as a vertex at infinity), would
    /// make a non-positive tet, would leave a vertex with no tet, or a tag protects a vertex:
    /// fixed vertices never go nor move; boundary vertices go only along boundary edges into
    /// boundary or fixed vertices; internal-boundary vertices only along internal-boundary
    /// edges into the same curve.
    pub fn check_collapse(&self, t: TetId, e: usize, reverse: bool, pos: DVec3) -> Result<TetPatch, Refusal> {
        self.live_tet(t)?;
        if !pos.is_finite() {
            return Err(Refusal::NonFinite);
        }
        let [mut i, mut j] = *EDGE_VERTICES.get(e).ok_or(Refusal::StaleKey)?;
        if reverse {
            std::mem::swap(&mut i, &mut j);
        }
        let s = self.edge_shell(t, i, j);
        let (a, b) = (s.a, s.b);
        let (tag_a, tag_b) = (self.tag(a), self.tag(b));
        let label0 = self.tets[s.tets[0]].label;
        let constrained = s.tets.iter().any(|&u| self.tets[u].label != label0);
        match tag_a {
            VertexTag::Fixed => return Err(Refusal::Protected(tag_a)),
            VertexTag::Boundary => {
                if s.closed || !matches!(tag_b, VertexTag::Boundary | VertexTag::Fixed) {
                    return Err(Refusal::Protected(tag_a));
                }
            }
            VertexTag::InternalBoundary { curve } => {
                let same = matches!(tag_b, VertexTag::InternalBoundary { curve: cb } if cb == curve)
                    || tag_b == VertexTag::Fixed;
                if !constrained || !same {
                    return Err(Refusal::Protected(tag_a));
                }
            }
            VertexTag::Interior => {}
        }
        if tag_b == VertexTag::Fixed && pos != self.pos(b) {
            return Err(Refusal::Protected(tag_b));
        }
        let star_a = self.vertex_tets(a);
        let star_b = self.vertex_tets(b);
        self.link_condition(a, b, &s, &star_a, &star_b)?;
        // New tets: star(a) minus the shell with a -> b, and star(b) minus the shell, b at pos.
        let mut new: NewTets = SmallVec::new();
        let mut old: SmallVec<[TetId; 16]> = SmallVec::new();
        for &u in star_a.iter() {
            old.push(u);
            if s.tets.contains(&u) {
                continue;
            }
            let tx = self.tets[u];
            let mut v = tx.v;
            for x in v.iter_mut() {
                if *x == a {
                    *x = b;
                }
            }
            new.push((v, tx.label));
        }
        for &u in star_b.iter() {
            if s.tets.contains(&u) {
                continue;
            }
            old.push(u);
            new.push((self.tets[u].v, self.tets[u].label));
        }
        let worst = self.check_new(&new, DVec3::ZERO, Some((b, pos)))?;
        // Every ring vertex must keep a tet (its other tets all touch a or b, so are new).
        if new.is_empty() || s.ring.iter().any(|&c| !new.iter().any(|(v, _)| v.contains(&c))) {
            return Err(Refusal::TooSmall);
        }
        let mut plan = self.patch(old, new);
        plan.subst = Some((a, b));
        plan.remove = Some(a);
        plan.moved = Some((b, pos));
        plan.min_quality = worst;
        if !self.patch_unfolded(&plan) {
            return Err(Refusal::WouldFold);
        }
        Ok(plan)
    }

    /// The link condition for collapsing a-b, with the boundary as a vertex at infinity (the
    /// null key): common link vertices must be ring vertices, common link edges ring edges,
    /// and there is no common link triangle.
    #[allow(clippy::needless_range_loop)]
    fn link_condition(
        &self,
        a: TVertexId,
        b: TVertexId,
        s: &EdgeShell,
        star_a: &[TetId],
        star_b: &[TetId],
    ) -> Result<(), Refusal> {
        let inf = TVertexId::null();
        // The link of x without simplices that hold y: vertices, edges, triangles.
        let link = |x: TVertexId, y: TVertexId, star: &[TetId]| {
            let mut vs: Vec<TVertexId> = Vec::new();
            let mut es: Vec<(TVertexId, TVertexId)> = Vec::new();
            let mut ts: Vec<[TVertexId; 3]> = Vec::new();
            let add_tri = |f: [TVertexId; 3],
                           vs: &mut Vec<TVertexId>,
                           es: &mut Vec<(TVertexId, TVertexId)>,
                           ts: &mut Vec<[TVertexId; 3]>| {
                for k in 0..3 {
                    if f[k] != y {
                        vs.push(f[k]);
                    }
                    let (p, q) = (f[k], f[(k + 1) % 3]);
                    if p != y && q != y {
                        es.push(if p < q { (p, q) } else { (q, p) });
                    }
                }
                if !f.contains(&y) {
                    ts.push(face_key(f));
                }
            };
            for &u in star {
                let tx = &self.tets[u];
                let ix = tx.v.iter().position(|&w| w == x).expect("star");
                let f = FACE_VERTICES[ix].map(|k| tx.v[k]);
                add_tri(f, &mut vs, &mut es, &mut ts);
                // Boundary faces through x cone to infinity.
                for k in 0..4 {
                    if k != ix && tx.adj[k].is_none() {
                        let g: SmallVec<[TVertexId; 3]> =
                            FACE_VERTICES[k].iter().map(|&m| tx.v[m]).filter(|&w| w != x).collect();
                        add_tri([g[0], g[1], inf], &mut vs, &mut es, &mut ts);
                    }
                }
            }
            vs.sort_unstable();
            vs.dedup();
            es.sort_unstable();
            es.dedup();
            ts.sort_unstable();
            ts.dedup();
            (vs, es, ts)
        };
        let (va, ea, ta) = link(a, b, star_a);
        let (vb, eb, tb) = link(b, a, star_b);
        let mut ring: SmallVec<[TVertexId; 9]> = s.ring.iter().copied().collect();
        if !s.closed {
            ring.push(inf);
        }
        for v in &va {
            if vb.binary_search(v).is_ok() && !ring.contains(v) {
                return Err(Refusal::LinkCondition);
            }
        }
        let n = s.ring.len();
        let is_ring_edge = |p: TVertexId, q: TVertexId| {
            let m = if s.closed { n } else { n - 1 };
            let ring_edge = (0..m).any(|k| {
                let (x, y) = (s.ring[k], s.ring[(k + 1) % n]);
                (x == p && y == q) || (x == q && y == p)
            });
            let end =
                !s.closed && ((p == inf || q == inf) && [p, q].iter().any(|&w| w == s.ring[0] || w == s.ring[n - 1]));
            ring_edge || end
        };
        for &(p, q) in &ea {
            if eb.binary_search(&(p, q)).is_ok() && !is_ring_edge(p, q) {
                return Err(Refusal::LinkCondition);
            }
        }
        if ta.iter().any(|f| tb.binary_search(f).is_ok()) {
            return Err(Refusal::LinkCondition);
        }
        Ok(())
    }

    /// Collapses edge `e` of `t` (see [`TetMesh::check_collapse`]); returns the survivor.
    pub fn collapse(&mut self, t: TetId, e: usize, reverse: bool, pos: DVec3) -> Result<TVertexId, Refusal> {
        let plan = self.check_collapse(t, e, reverse, pos)?;
        let b = plan.subst.expect("collapse").1;
        self.apply_patch(plan);
        Ok(b)
    }

    // ===================== boundary tet removal =====================

    /// Checks deleting tet `t` from the boundary so that the boundary stays a 2-manifold: with
    /// one boundary face its opposite vertex must be interior (it joins the boundary); with two
    /// boundary faces the edge they do not share must not touch the boundary; with three, the
    /// vertex they share must lie in `t` only and not be fixed (it goes with `t`). Returns the
    /// number of boundary faces.
    pub fn check_remove_boundary_tet(&self, t: TetId) -> Result<usize, Refusal> {
        let tx = self.live_tet(t)?;
        let nb = tx.adj.iter().filter(|a| a.is_none()).count();
        match nb {
            1 => {
                let i = tx.adj.iter().position(|a| a.is_none()).expect("one boundary face");
                if self.is_boundary_vertex(tx.v[i]) {
                    return Err(Refusal::Protected(VertexTag::Boundary));
                }
            }
            2 => {
                // Faces opposite c and d are boundary: the edge c-d must be interior.
                let mut cd = [0usize; 2];
                let mut k = 0;
                for i in 0..4 {
                    if tx.adj[i].is_none() {
                        cd[k] = i;
                        k += 1;
                    }
                }
                if !self.edge_shell(t, cd[0], cd[1]).closed {
                    return Err(Refusal::BoundaryEdge);
                }
            }
            3 => {
                let i = tx.adj.iter().position(|a| a.is_some()).expect("one interior face");
                let v = tx.v[i];
                if self.vertices[v].tag == VertexTag::Fixed {
                    return Err(Refusal::Protected(VertexTag::Fixed));
                }
                if self.vertex_tets(v).len() != 1 {
                    return Err(Refusal::LinkCondition);
                }
            }
            _ => return Err(Refusal::TooSmall),
        }
        if tx.adj.iter().any(|a| a.is_some_and(|(u, _)| self.tets[u].label != tx.label)) {
            return Err(Refusal::Constrained);
        }
        Ok(nb)
    }

    /// Deletes tet `t` from the boundary (see [`TetMesh::check_remove_boundary_tet`]); a vertex
    /// that joins the boundary is tagged `Boundary` unless it is `Fixed`.
    pub fn remove_boundary_tet(&mut self, t: TetId) -> Result<(), Refusal> {
        let nb = self.check_remove_boundary_tet(t)?;
        let tx = self.tets[t];
        if nb == 3 {
            let i = tx.adj.iter().position(|a| a.is_some()).expect("one interior face");
            let (u, j) = tx.adj[i].expect("interior face");
            self.revision = self.revision.wrapping_add(1);
            self.tets[u].adj[j as usize] = None;
            for w in self.tets[u].v {
                self.vertices[w].tet = u;
            }
            self.tets.remove(t);
            self.vertices.remove(tx.v[i]);
            self.note_tet(tx.v);
            self.note_vertex_set();
            return Ok(());
        }
        self.revision = self.revision.wrapping_add(1);
        for i in 0..4 {
            if let Some((u, j)) = tx.adj[i] {
                self.tets[u].adj[j as usize] = None;
                for w in self.tets[u].v {
                    if tx.v.contains(&w) {
                        self.vertices[w].tet = u;
                    }
                }
            }
        }
        self.tets.remove(t);
        self.note_tet(tx.v);
        for w in tx.v {
            if self.vertices[w].tag == VertexTag::Interior {
                self.vertices[w].tag = VertexTag::Boundary;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::testing::{edge_shell, tet_grid, tet_pair};
    use crate::topology::{Level, Refusal};

    #[test]
    fn boundary_tet_removal_keeps_a_valid_manifold() {
        // Three boundary faces: the tet and its free apex go.
        let mut m = tet_pair();
        let t = m.tet_ids().next().unwrap();
        m.remove_boundary_tet(t).expect("a tent comes off");
        assert_eq!((m.num_tets(), m.num_vertices()), (1, 4));
        m.validate(Level::Geometry).expect("valid");
        // Two boundary faces and an interior opposite edge: the edge joins the boundary.
        let mut m = edge_shell(5);
        let t = m.tet_ids().next().unwrap();
        m.remove_boundary_tet(t).expect("a cap comes off");
        assert_eq!(m.num_tets(), 4);
        m.validate(Level::Geometry).expect("valid");
        // The shell is open now: an end tet has three boundary faces and its ring vertex is in
        // no other tet, so it comes off with that vertex.
        let u = m.tet_ids().find(|&u| m.tet(u).adj.iter().filter(|a| a.is_none()).count() == 3).expect("an end tet");
        assert_eq!(m.check_remove_boundary_tet(u), Ok(3));
        m.remove_boundary_tet(u).expect("comes off");
        assert_eq!((m.num_tets(), m.num_vertices()), (3, 6));
        m.validate(Level::Geometry).expect("valid");
        // An interior tet is refused and the mesh is untouched.
        let g = tet_grid(4);
        let inner = g.tet_ids().find(|&t| g.tet(t).adj.iter().all(|a| a.is_some())).expect("an interior tet");
        let mut h = g.clone();
        assert_eq!(h.remove_boundary_tet(inner), Err(Refusal::TooSmall));
        assert!(h == g);
    }
}
