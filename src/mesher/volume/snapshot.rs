//! The force loop's compact arrays of the mesh (patched after local changes instead of rebuilt),
//! the step control that keeps every tet positive, and the wall-time clock per phase.

use crate::mesher::truss::{self, det_sum, Backoff, NodeKind};

/// Step control: a vertex of a tet a step would invert steps back halfway at most this many
/// times, then stays where it was.
const MAX_HALVINGS: u8 = 6;
use crate::predicates::{orient3d, Sign};
use crate::topology::{Journal, TVertexId, TetId, TetMesh, VertexTag};
use glam::DVec3;
use rayon::prelude::*;
use slotmap::SecondaryMap;
use smallvec::SmallVec;
use std::time::Instant;

/// Free entries at the end of each neighbour row of the snapshot, so that a refresh after
/// local flips rewrites the touched rows in place.
const ROW_SLACK: usize = 4;

/// Compact arrays of the mesh for the force loop, refreshed when the topology changes.
pub(super) struct Snapshot {
    pub(super) ids: Vec<TVertexId>,
    /// Position of each vertex in `ids`.
    index: SecondaryMap<TVertexId, u32>,
    pub(super) kind: Vec<NodeKind>,
    pub(super) tets: Vec<[u32; 4]>,
    pub(super) tet_ids: Vec<TetId>,
    /// Each vertex's row in `adj` (start, end): rows are contiguous after a build; a refresh
    /// moves a row that outgrew its slack to the end.
    rows: Vec<(u32, u32)>,
    /// Neighbours of each vertex (CSR), in increasing order; an entry equal to its own vertex
    /// (ROW_SLACK of them at the end of each row, and edges removed since the build) is
    /// skipped by every loop.
    adj: Vec<u32>,
    /// Entries dead or added and rows moved since the build.
    spent: usize,
}

fn kind_of(tag: VertexTag) -> NodeKind {
    match NodeKind::of(tag) {
        // No internal boundaries in 3-D.
        NodeKind::Internal => NodeKind::Interior,
        k => k,
    }
}

impl Snapshot {
    /// Step control from `old` to `newp`: a vertex of a tet the step would not leave positive
    /// (exact orient3d) steps back halfway, at most MAX_HALVINGS times.
    pub(super) fn guard_inversions(&self, old: &[DVec3], newp: &mut [DVec3]) {
        truss::guard_inversions(&self.tets, None, old, newp, MAX_HALVINGS, Backoff::PerRound, |q, t| {
            orient3d(q[t[0] as usize], q[t[1] as usize], q[t[2] as usize], q[t[3] as usize]) == Sign::Positive
        });
    }

    /// The entries of vertex i's row.
    #[inline]
    fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.rows[i].0 as usize..self.rows[i].1 as usize
    }

    /// Vertex i's neighbours, with self-entries to skip.
    #[inline]
    pub(super) fn row(&self, i: usize) -> &[u32] {
        &self.adj[self.range(i)]
    }

    /// Drops the edge a-b from the neighbour lists: each entry becomes its own vertex's index,
    /// which every loop over neighbours skips (a zero-length bar exerts no force).
    pub(super) fn remove_edge(&mut self, a: usize, b: usize) {
        for (x, y) in [(a, b), (b, a)] {
            let range = self.range(x);
            let list = &mut self.adj[range];
            if let Some(e) = list.iter_mut().find(|e| **e as usize == y) {
                *e = x as u32;
            }
        }
    }

    /// Drops the tets at the given positions, keeping the others in order (as a rebuild
    /// would list them).
    pub(super) fn remove_tets(&mut self, positions: &[usize]) {
        let mut gone = positions.to_vec();
        gone.sort_unstable();
        let mut next = gone.iter().peekable();
        let mut w = 0;
        for r in 0..self.tets.len() {
            if next.peek() == Some(&&r) {
                next.next();
                continue;
            }
            self.tets[w] = self.tets[r];
            self.tet_ids[w] = self.tet_ids[r];
            w += 1;
        }
        self.tets.truncate(w);
        self.tet_ids.truncate(w);
    }

    pub(super) fn build(m: &TetMesh) -> Snapshot {
        let mut index: SecondaryMap<TVertexId, u32> = SecondaryMap::with_capacity(m.num_vertices());
        let mut ids = Vec::with_capacity(m.num_vertices());
        let mut kind = Vec::with_capacity(m.num_vertices());
        for v in m.vertex_ids() {
            index.insert(v, ids.len() as u32);
            ids.push(v);
            kind.push(kind_of(m.tag(v)));
        }
        let mut tets = Vec::with_capacity(m.num_tets());
        let mut tet_ids = Vec::with_capacity(m.num_tets());
        for t in m.tet_ids() {
            tets.push(m.tet(t).v.map(|x| index[x]));
            tet_ids.push(t);
        }
        // Vertex -> tets by counting, then each vertex's neighbours, sorted, in parallel blocks
        // of vertices (deterministic): no global sort of the 12 T directed edges. A vertex's
        // tets name each neighbour several times (about 70 names for 14 neighbours): a stamp per
        // vertex drops the repeats before the sort, and each block fills one flat list (one
        // allocation per block, not per vertex).
        let n = ids.len();
        let inc = crate::topology::Incidence::new(n, &tets);
        const BLOCK: usize = 1024;
        // Jobs of at least 16 blocks: each job clears a stamp array of n entries.
        let blocks: Vec<(Vec<u32>, Vec<u32>)> = (0..n.div_ceil(BLOCK))
            .into_par_iter()
            .with_min_len(16)
            .map_init(
                || vec![u32::MAX; n],
                |seen, b| {
                    let (mut flat, mut counts) =
                        (Vec::with_capacity((16 + ROW_SLACK) * BLOCK), Vec::with_capacity(BLOCK));
                    for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                        let first = flat.len();
                        for &k in inc.of(i) {
                            for &j in &tets[k as usize] {
                                if j as usize != i && seen[j as usize] != i as u32 {
                                    seen[j as usize] = i as u32;
                                    flat.push(j);
                                }
                            }
                        }
                        flat[first..].sort_unstable();
                        flat.extend([i as u32; ROW_SLACK]);
                        counts.push((flat.len() - first) as u32);
                    }
                    (flat, counts)
                },
            )
            .collect();
        let mut rows = Vec::with_capacity(n);
        let mut adj = Vec::with_capacity(blocks.iter().map(|b| b.0.len()).sum());
        for (flat, counts) in &blocks {
            for &c in counts {
                let start = rows.last().map_or(0, |r: &(u32, u32)| r.1);
                rows.push((start, start + c));
            }
            adj.extend_from_slice(flat);
        }
        Snapshot { ids, index, kind, tets, tet_ids, rows, adj, spent: 0 }
    }

    /// Brings the snapshot up to date after local topology changes: the kinds and the tets are
    /// read again, and only the rows of the vertices the journal names are recomputed. A vertex
    /// removed stays as a NodeKind::Dead entry with an empty row; a vertex added is appended with a row
    /// of its own. The loops skip the self-entries and the dead, so the forces are a rebuild's.
    /// False when the dead and added entries and the moved rows pass 1/8 of the vertices:
    /// rebuild then.
    pub(super) fn refresh(&mut self, m: &TetMesh, journal: &Journal) -> bool {
        let mut keys: Vec<TVertexId> = journal.touched.clone();
        keys.sort_unstable();
        keys.dedup();
        // The dead first: a new vertex may reuse a dead one's slot with a newer version.
        for &v in &keys {
            if !m.contains_vertex(v) {
                if let Some(i) = self.index.remove(v) {
                    let i = i as usize;
                    self.kind[i] = NodeKind::Dead;
                    let row = self.range(i);
                    self.adj[row].fill(i as u32);
                    self.spent += 1;
                }
            }
        }
        for &v in &keys {
            if m.contains_vertex(v) && !self.index.contains_key(v) {
                self.index.insert(v, self.ids.len() as u32);
                self.ids.push(v);
                self.kind.push(NodeKind::Interior);
                self.spent += 1;
            }
        }
        let alive = self.ids.len() - self.kind.iter().filter(|&&k| k == NodeKind::Dead).count();
        if alive != m.num_vertices() || 8 * self.spent > self.ids.len() {
            return false;
        }
        for (k, &v) in self.ids.iter().enumerate() {
            if self.kind[k] != NodeKind::Dead {
                self.kind[k] = kind_of(m.tag(v));
            }
        }
        self.tets.clear();
        self.tet_ids.clear();
        for t in m.tet_ids() {
            self.tets.push(m.tet(t).v.map(|x| self.index[x]));
            self.tet_ids.push(t);
        }
        let mut touched: Vec<u32> = keys.iter().filter_map(|&v| self.index.get(v).copied()).collect();
        touched.sort_unstable();
        let rows: Vec<SmallVec<[u32; 32]>> = touched
            .par_iter()
            .with_min_len(64)
            .map(|&i| {
                let mut r: SmallVec<[u32; 32]> =
                    m.vertex_neighbours(self.ids[i as usize]).iter().map(|&w| self.index[w]).collect();
                r.sort_unstable();
                r
            })
            .collect();
        // Rows in place where they fit; at the end (with fresh slack) where they do not, and
        // for the added vertices.
        let old_n = self.rows.len();
        self.rows.resize(self.ids.len(), (0, 0));
        for (&i, r) in touched.iter().zip(&rows) {
            let i = i as usize;
            let range = self.range(i);
            if i < old_n && r.len() <= range.len() {
                let row = &mut self.adj[range];
                row[..r.len()].copy_from_slice(r);
                row[r.len()..].fill(i as u32);
            } else {
                if i < old_n {
                    self.adj[range].fill(i as u32);
                    self.spent += 1;
                }
                let start = self.adj.len() as u32;
                self.adj.extend_from_slice(r);
                self.adj.extend([i as u32; ROW_SLACK]);
                self.rows[i] = (start, self.adj.len() as u32);
            }
        }
        true
    }
}

pub(super) fn write_back(m: &mut TetMesh, snap: &Snapshot, p: &[DVec3]) {
    // Vertices removed since the snapshot (a tent dropped from the boundary) are skipped.
    for (k, &v) in snap.ids.iter().enumerate() {
        if m.contains_vertex(v) {
            m.set_pos_unchecked(v, p[k]);
        }
    }
}

pub(super) fn mean_rr(snap: &Snapshot, p: &[DVec3]) -> f64 {
    let (s, n) = det_sum(snap.tets.len(), |k| {
        let t = snap.tets[k];
        (crate::quality::tet_radius_ratio(t.map(|i| p[i as usize])), 1.0)
    });
    s / n.max(1.0)
}

/// Wall time per phase of the force loop, printed with TRUSSMESH_TRACE: where a large run
/// spends its time, measured rather than guessed.
pub(super) struct PhaseClock {
    last: Instant,
    totals: Vec<(&'static str, f64)>,
}

impl PhaseClock {
    pub(super) fn new() -> Self {
        PhaseClock { last: Instant::now(), totals: Vec::new() }
    }

    /// Adds the time since the previous lap to `phase`.
    pub(super) fn lap(&mut self, phase: &'static str) {
        let now = Instant::now();
        let dt = (now - self.last).as_secs_f64();
        self.last = now;
        match self.totals.iter_mut().find(|e| e.0 == phase) {
            Some(e) => e.1 += dt,
            None => self.totals.push((phase, dt)),
        }
    }

    pub(super) fn summary(&self) -> String {
        self.totals.iter().map(|(p, t)| format!("{p} {t:.2} s")).collect::<Vec<_>>().join(", ")
    }
}
