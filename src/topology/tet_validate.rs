//! `validate()` for [`TetMesh`]: every invariant, returned as a value naming what broke where.

use super::tetmesh::{face_key, TetId, TetMesh};
use super::tri_validate::{Invariant, InvariantViolation, Level};
use crate::predicates::{insphere, Sign};
use slotmap::Key;

fn fail<K: Key>(invariant: Invariant, k: K) -> Result<(), InvariantViolation> {
    Err(InvariantViolation { invariant, at: format!("{:?}", k.data()) })
}

impl TetMesh {
    /// Checks the invariants up to `level`: `Topology` (live keys, distinct vertices, mutual
    /// neighbours with matching face indices and shared face vertices, vertex pointers, each
    /// boundary edge on exactly two boundary faces), `Geometry` (plus exact positive
    /// orientation and the embedding: one winding of the tets around every interior edge, less
    /// than one around boundary edges, a boundary surface that does not intersect itself) and `Delaunay` (plus exact in-sphere on interior faces of equal label).
    pub fn validate(&self, level: Level) -> Result<(), InvariantViolation> {
        use Invariant::*;
        for (t, tx) in self.tets.iter() {
            if tx.v.iter().any(|&v| !self.vertices.contains_key(v)) {
                return fail(DanglingKey, t);
            }
            if (0..4).any(|i| (i + 1..4).any(|j| tx.v[i] == tx.v[j])) {
                return fail(TetRepeatsVertex, t);
            }
            for i in 0..4 {
                let Some((u, j)) = tx.adj[i] else { continue };
                if j > 3 || !self.tets.contains_key(u) {
                    return fail(DanglingKey, t);
                }
                if u == t {
                    return fail(NeighbourNotMutual, t);
                }
                match self.tets[u].adj[j as usize] {
                    Some((back, k)) if back == t => {
                        if k as usize != i {
                            return fail(FaceIndexMismatch, t);
                        }
                    }
                    _ => return fail(NeighbourNotMutual, t),
                }
                if face_key(self.face_vertices(t, i)) != face_key(self.face_vertices(u, j as usize)) {
                    return fail(SharedFaceMismatch, t);
                }
            }
        }
        for (v, vx) in self.vertices.iter() {
            if !self.tets.contains_key(vx.tet) {
                return fail(DanglingKey, v);
            }
            if !self.tets[vx.tet].v.contains(&v) {
                return fail(VertexTetWrong, v);
            }
        }
        // Each boundary edge on exactly two boundary faces.
        let mut edges = Vec::new();
        for (t, i) in self.boundary_faces() {
            let f = self.face_vertices(t, i);
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                edges.push(if a < b { (a, b) } else { (b, a) });
            }
        }
        edges.sort_unstable();
        let mut k = 0;
        while k < edges.len() {
            let mut m = k;
            while m < edges.len() && edges[m] == edges[k] {
                m += 1;
            }
            if m - k != 2 {
                return fail(NonManifoldBoundary, edges[k].0);
            }
            k = m;
        }
        if level >= Level::Geometry {
            for t in self.tets.keys() {
                if self.tet_orientation(t) != Sign::Positive {
                    return fail(InvertedTet, t);
                }
            }
            super::embedding::tetrahedral(self)?;
        }
        if level >= Level::Delaunay {
            for (t, tx) in self.tets.iter() {
                for i in 0..4 {
                    let Some((u, j)) = tx.adj[i] else { continue };
                    if self.tets[u].label != tx.label {
                        continue;
                    }
                    if !self.is_locally_delaunay(t, i) {
                        let _ = (u, j);
                        return fail(NotDelaunay, t);
                    }
                }
            }
        }
        Ok(())
    }

    /// True when the apex across face `i` of `t` is not strictly inside t's circumsphere
    /// (boundary faces are Delaunay).
    pub fn is_locally_delaunay(&self, t: TetId, i: usize) -> bool {
        match self.tets[t].adj[i] {
            None => true,
            Some((u, j)) => {
                let [a, b, c, d] = self.tet_points(t);
                let e = self.pos(self.tets[u].v[j as usize]);
                insphere(a, b, c, d, e) != Sign::Positive
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{edge_shell, tet_pair};
    use glam::DVec3;

    fn expect(m: &TetMesh, level: Level, inv: Invariant) {
        match m.validate(level) {
            Err(e) => assert_eq!(e.invariant, inv, "got {e}"),
            Ok(()) => panic!("corruption for {inv:?} not detected"),
        }
    }

    // Break the checker on purpose: each corruption must trigger exactly its invariant.
    #[test]
    fn each_invariant_is_detected() {
        let base = tet_pair();
        base.validate(Level::Delaunay).unwrap();
        let t: Vec<TetId> = base.tet_ids().collect();
        let (t0, t1) = (t[0], t[1]);
        let i = (0..4).find(|&i| base.tets[t0].adj[i].is_some()).unwrap();
        let (_, j) = base.tets[t0].adj[i].unwrap();

        let mut m = base.clone();
        let dead = m.tets.insert(m.tets[t0]);
        m.tets.remove(dead);
        m.tets[t0].adj[i] = Some((dead, j));
        expect(&m, Level::Topology, Invariant::DanglingKey);

        let mut m = base.clone();
        m.tets[t0].v[1] = m.tets[t0].v[0];
        expect(&m, Level::Topology, Invariant::TetRepeatsVertex);

        let mut m = base.clone();
        m.tets[t1].adj[j as usize] = None;
        expect(&m, Level::Topology, Invariant::NeighbourNotMutual);

        let mut m = base.clone();
        m.tets[t1].adj[j as usize] = Some((t0, ((i + 1) % 4) as u8));
        expect(&m, Level::Topology, Invariant::FaceIndexMismatch);

        let mut m = base.clone();
        let jj = j as usize;
        m.tets[t1].v.swap(jj, (jj + 1) % 4);
        expect(&m, Level::Topology, Invariant::SharedFaceMismatch);

        let mut m = base.clone();
        let apex = m.tets[t0].v[i];
        m.vertices[apex].tet = t1;
        expect(&m, Level::Topology, Invariant::VertexTetWrong);

        let mut m = base.clone();
        let apex = m.tets[t0].v[i];
        let f = m.face_vertices(t0, i);
        let c = (m.pos(f[0]) + m.pos(f[1]) + m.pos(f[2])) / 3.0;
        let p = m.pos(apex);
        m.set_pos_unchecked(apex, c + (c - p) * 0.1);
        expect(&m, Level::Geometry, Invariant::InvertedTet);

        // Two tets sharing only an edge: four boundary faces at that edge.
        let p = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(-1.0, -1.0, 0.0),
        ];
        let (m, _) = TetMesh::from_arrays(&p, &[[0, 1, 2, 3], [0, 1, 4, 5]]).unwrap();
        expect(&m, Level::Topology, Invariant::NonManifoldBoundary);

        // Pull the apex of one tet inside the other's circumsphere.
        let mut m = base.clone();
        let e = m.tets[t1].v[jj];
        let f = m.face_vertices(t0, i);
        let c = (m.pos(f[0]) + m.pos(f[1]) + m.pos(f[2])) / 3.0;
        let q = m.pos(e);
        m.set_pos_unchecked(e, c + (q - c) * 0.05);
        m.validate(Level::Geometry).unwrap();
        expect(&m, Level::Delaunay, Invariant::NotDelaunay);

        edge_shell(5).validate(Level::Geometry).unwrap();
    }
}
