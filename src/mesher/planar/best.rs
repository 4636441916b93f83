//! The best state of the force loop, by the report's quality measure (the smallest triangle
//! quality): when the iteration cap ends the loop, the best state met is what the run
//! finishes from (`Options2::max_iter` promises the best mesh so far), not the last one.
//!
//! A state is kept in compact arrays (positions, triangles, tags, labels: about 40 bytes per
//! triangle, copied in a few milliseconds at 10^6 triangles) whenever the smallest quality at
//! the end of a window rises above the best before it; the mesh is rebuilt from them only when
//! the cap is reached and the kept state beats the last one.

use super::*;

/// A kept state of the force loop.
#[derive(Default)]
pub(super) struct BestState {
    /// The iteration of the kept state (0: none kept).
    pub(super) iteration: usize,
    /// Its smallest triangle quality.
    pub(super) q_min: f64,
    p: Vec<DVec2>,
    tris: Vec<[u32; 3]>,
    tags: Vec<VertexTag>,
    /// One label per triangle, or empty when every triangle has label 0.
    labels: Vec<u32>,
}

/// The smallest triangle quality of the state (`ctx`'s measure: q, or with a metric q in M).
pub(super) fn state_q_min(ctx: &Ctx, snap: &Snapshot, p: &[DVec2]) -> f64 {
    state_worst(ctx, snap, p).0
}

/// The smallest triangle quality of the state and the index of its triangle in `snap.tris`
/// (the first of equals, so the same for any thread count; `usize::MAX` with no triangle).
pub(super) fn state_worst(ctx: &Ctx, snap: &Snapshot, p: &[DVec2]) -> (f64, usize) {
    snap.tris
        .par_iter()
        .enumerate()
        .with_min_len(CHUNK)
        .map(|(k, &[a, b, c])| (ctx.tri_q([p[a as usize], p[b as usize], p[c as usize]]), k))
        .reduce(|| (f64::INFINITY, usize::MAX), |x, y| if y.0 < x.0 || (y.0 == x.0 && y.1 < x.1) { y } else { x })
}

impl BestState {
    /// Offers the state at `iteration` (mesh `m` with positions `p`, arrays `snap`): kept
    /// when its smallest quality `q_min` is above the best so far.
    pub(super) fn offer(&mut self, m: &TriMesh<DVec2>, snap: &Snapshot, p: &[DVec2], q_min: f64, iteration: usize) {
        if self.iteration != 0 && q_min <= self.q_min {
            return;
        }
        self.iteration = iteration;
        self.q_min = q_min;
        self.p.clear();
        self.p.extend_from_slice(p);
        self.tris.clear();
        self.tris.extend_from_slice(&snap.tris);
        self.tags.clear();
        self.tags.extend(snap.ids.iter().map(|&v| m.tag(v)));
        self.labels.clear();
        if snap.tri_faces.iter().any(|&f| m.face(f).label != 0) {
            self.labels.extend(snap.tri_faces.iter().map(|&f| m.face(f).label));
        }
    }

    /// [`BestState::offer`] for a mesh whose force loop holds a core (see `held`): the
    /// arrays hold only the band, so the state is read from the mesh itself, whose positions
    /// must be current.
    pub(super) fn offer_mesh(&mut self, m: &TriMesh<DVec2>, q_min: f64, iteration: usize) {
        if self.iteration != 0 && q_min <= self.q_min {
            return;
        }
        self.iteration = iteration;
        self.q_min = q_min;
        let mut index: SecondaryMap<VertexId, u32> = SecondaryMap::with_capacity(m.num_vertices());
        self.p.clear();
        self.tags.clear();
        for (v, vx) in m.vertices() {
            index.insert(v, self.p.len() as u32);
            self.p.push(vx.pos);
            self.tags.push(vx.tag);
        }
        self.tris.clear();
        self.tris.extend(m.face_ids().map(|f| m.face_vertices(f).map(|v| index[v])));
        self.labels.clear();
        if m.face_ids().any(|f| m.face(f).label != 0) {
            self.labels.extend(m.face_ids().map(|f| m.face(f).label));
        }
    }

    /// The mesh of the kept state.
    pub(super) fn rebuild(&self) -> Result<TriMesh<DVec2>, Error> {
        let tris: Vec<[usize; 3]> = self.tris.iter().map(|t| t.map(|i| i as usize)).collect();
        let (mut m, ids) = TriMesh::from_arrays(&self.p, &tris)?;
        for (&v, &tag) in ids.iter().zip(&self.tags) {
            m.set_tag(v, tag);
        }
        if !self.labels.is_empty() {
            let faces: Vec<crate::topology::FaceId> = m.face_ids().collect();
            let index: std::collections::HashMap<[VertexId; 3], u32> =
                self.tris.iter().zip(&self.labels).map(|(t, &l)| (canonical(t.map(|i| ids[i as usize])), l)).collect();
            for f in faces {
                if let Some(&l) = index.get(&canonical(m.face_vertices(f))) {
                    m.set_label(f, l);
                }
            }
        }
        Ok(m)
    }
}

/// The triangle's vertices rotated to start at the smallest key (orientation kept).
fn canonical(t: [VertexId; 3]) -> [VertexId; 3] {
    let k = (0..3).min_by_key(|&i| t[i]).unwrap_or(0);
    [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
}

#[cfg(test)]
thread_local! {
    /// Every offered state's (iteration, smallest quality), for the tests.
    pub(super) static OFFERED: std::cell::RefCell<Vec<(usize, f64)>> = const { std::cell::RefCell::new(Vec::new()) };
}
