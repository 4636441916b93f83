//! The force loop's compact arrays of the mesh (patched after local changes instead of rebuilt),
//! the step control that keeps every tet positive, and the wall-time clock per phase.

use crate::mesher::truss::{self, det_sum, Backoff, NodeKind};

/// Step control: a vertex of a tet a step would invert steps back halfway at most this many
/// times, then stays where it was.
const MAX_HALVINGS: u8 = 6;
/// Step control: rounds of the boundary fold check before the whole step is taken back.
const MAX_FOLD_ROUNDS: usize = 8;
use crate::predicates::{orient3d, Sign};
use crate::topology::{faces_meet, ring_winds_once};
use crate::topology::{EdgeShell, Journal, TVertexId, TetId, TetMesh, VertexTag, EDGE_VERTICES, FACE_VERTICES};
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
    /// Every boundary edge with its open ring, as flat records (a, b, r_0, ..., r_k) starting
    /// at `ring_start[e]`: what the fold check of a step reads.
    rings: Vec<u32>,
    ring_start: Vec<u32>,
    /// Pairs of boundary faces near each other where the boundary is thin (two sheets facing
    /// within two rings of a vertex): a step must not make them cross.
    face_pairs: Vec<[[u32; 3]; 2]>,
}

/// An open shell as a ring record (a, b, r_0, ..., r_k) in snapshot indices; empty for a
/// closed one.
fn open_ring_record(shell: &EdgeShell, index: &SecondaryMap<TVertexId, u32>) -> SmallVec<[u32; 12]> {
    let mut r = SmallVec::new();
    if !shell.closed {
        r.extend([index[shell.a], index[shell.b]]);
        r.extend(shell.ring.iter().map(|&w| index[w]));
    }
    r
}

/// Whether the open ring of record `r` already turns within NEAR_WRAP of a full turn at `p`:
/// the boundary there is folded nearly flat onto itself, and the step control lets such a ring
/// through (freezing its nodes would keep the fold; the flat boundary tets leave later). Where
/// one does not leave, the finished mesh fails its check and the run starts again strict
/// (see `mesher::volume::run`).
fn nearly_wrapped(p: &[DVec3], r: &[u32]) -> bool {
    let (a, b) = (p[r[0] as usize], p[r[1] as usize]);
    let turn: f64 =
        r[2..].windows(2).map(|w| crate::quality::dihedral_angle_at(a, b, p[w[0] as usize], p[w[1] as usize])).sum();
    turn > std::f64::consts::TAU - NEAR_WRAP
}

/// See [`nearly_wrapped`] (radians).
const NEAR_WRAP: f64 = 0.5;

/// The boundary face pairs of `Snapshot::face_pairs`: around every boundary vertex with a
/// boundary vertex of opposite normal (area-weighted, at the build's positions) within two
/// rings, its boundary faces against those of the two rings. Empty away from thin parts.
fn thin_face_pairs(m: &TetMesh, snap: &Snapshot) -> Vec<[[u32; 3]; 2]> {
    let n = snap.ids.len();
    let faces: Vec<[u32; 3]> =
        m.boundary_faces().into_iter().map(|(t, i)| m.face_vertices(t, i).map(|v| snap.index[v])).collect();
    let inc = crate::topology::Incidence::new(n, &faces);
    let pos = |i: u32| m.pos(snap.ids[i as usize]);
    let normals: Vec<DVec3> = (0..n)
        .into_par_iter()
        .with_min_len(1024)
        .map(|i| {
            inc.of(i)
                .iter()
                .map(|&f| {
                    let [a, b, c] = faces[f as usize].map(pos);
                    (b - a).cross(c - a)
                })
                .sum::<DVec3>()
                .normalize_or_zero()
        })
        .collect();
    // Thin at i: a boundary vertex within two rings faces the other way (repeats allowed:
    // about 200 dot products, no set).
    let thin = |i: usize| {
        let ni = normals[i];
        snap.row(i).iter().any(|&k| {
            let k = k as usize;
            ni.dot(normals[k]) < 0.0 || snap.row(k).iter().any(|&j| ni.dot(normals[j as usize]) < 0.0)
        })
    };
    let mut pairs: Vec<[[u32; 3]; 2]> = (0..n)
        .into_par_iter()
        .with_min_len(256)
        .filter(|&i| snap.kind[i] != NodeKind::Dead && !inc.of(i).is_empty() && thin(i))
        .flat_map_iter(|i| {
            let mut near: SmallVec<[u32; 64]> = SmallVec::new();
            near.push(i as u32);
            let mut from = 0;
            for _ in 0..2 {
                let to = near.len();
                for k in from..to {
                    let v = near[k] as usize;
                    for &w in snap.row(v) {
                        if w as usize != v && !near.contains(&w) {
                            near.push(w);
                        }
                    }
                }
                from = to;
            }
            let mut others: SmallVec<[u32; 128]> =
                near.iter().flat_map(|&j| inc.of(j as usize).iter().copied()).collect();
            others.sort_unstable();
            others.dedup();
            let mut out: Vec<[[u32; 3]; 2]> = Vec::new();
            for &f in inc.of(i) {
                for &g in &others {
                    if g != f {
                        let (x, y) = (f.min(g), f.max(g));
                        out.push([faces[x as usize], faces[y as usize]]);
                    }
                }
            }
            out
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// The boundary edges of `m` and their rings, in snapshot indices (see `Snapshot::rings`):
/// each edge of a boundary face once, its shell walked from that face.
fn boundary_rings(m: &TetMesh, index: &SecondaryMap<TVertexId, u32>) -> (Vec<u32>, Vec<u32>) {
    let mut edges: Vec<((u32, u32), TetId, usize, usize)> = Vec::new();
    for (t, f) in m.boundary_faces() {
        let v = m.tet(t).v;
        let face = FACE_VERTICES[f];
        for (i, j) in [(face[0], face[1]), (face[1], face[2]), (face[2], face[0])] {
            let (x, y) = (index[v[i]], index[v[j]]);
            edges.push(((x.min(y), x.max(y)), t, i, j));
        }
    }
    edges.sort_unstable_by_key(|e| e.0);
    edges.dedup_by_key(|e| e.0);
    let records: Vec<SmallVec<[u32; 12]>> = edges
        .par_iter()
        .with_min_len(256)
        .map(|&(_, t, i, j)| open_ring_record(&m.edge_shell(t, i, j), index))
        .collect();
    let mut rings = Vec::with_capacity(records.iter().map(|r| r.len()).sum());
    let mut start = Vec::with_capacity(records.len() + 1);
    for r in records.iter().filter(|r| !r.is_empty()) {
        start.push(rings.len() as u32);
        rings.extend_from_slice(r);
    }
    start.push(rings.len() as u32);
    (rings, start)
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

    /// Step control against folds at the boundary: a step that leaves every tet positive can
    /// still wrap the ring of a boundary edge more than once around it (a boundary node
    /// projected across a thin part onto the far side), or push two facing sheets of the
    /// boundary through each other (`face_pairs`). The vertices of such a ring or pair go
    /// halfway back to `old` (all the way in the last three rounds), the orientation check runs
    /// again on the mixed positions, and the rings are checked again (at most MAX_FOLD_ROUNDS
    /// rounds, then every node goes back). Unless `strict`, a ring already within NEAR_WRAP of
    /// a full turn is let through ([`nearly_wrapped`]). Rings whose vertices
    /// all kept their place are not checked: `old` is an embedding. Returns how many nodes
    /// went back.
    pub(super) fn guard_boundary_folds(&self, old: &[DVec3], newp: &mut [DVec3], strict: bool) -> usize {
        let mut reverted = 0;
        for round in 0..MAX_FOLD_ROUNDS {
            let q: &[DVec3] = newp;
            let bad: Vec<usize> = (0..self.ring_start.len() - 1)
                .into_par_iter()
                .with_min_len(256)
                .filter(|&e| {
                    let r = self.ring_record(e);
                    if r.iter().all(|&k| q[k as usize] == old[k as usize]) {
                        return false;
                    }
                    let (a, b) = (q[r[0] as usize], q[r[1] as usize]);
                    !ring_winds_once(a, b, false, r[2..].iter().map(|&k| q[k as usize]))
                        && (strict || !nearly_wrapped(old, r))
                })
                .collect();
            let crossing: Vec<usize> = (0..self.face_pairs.len())
                .into_par_iter()
                .with_min_len(256)
                .filter(|&k| {
                    let [f, g] = self.face_pairs[k];
                    f.iter().chain(&g).any(|&i| q[i as usize] != old[i as usize])
                        && faces_meet(|i: u32| q[i as usize], f, g)
                })
                .collect();
            if bad.is_empty() && crossing.is_empty() {
                return reverted;
            }
            // Halfway back first (the node still approaches d = 0 or its equilibrium), all
            // the way in the last rounds.
            let half = round + 3 < MAX_FOLD_ROUNDS;
            let mut back = |k: u32| {
                let k = k as usize;
                if newp[k] != old[k] {
                    newp[k] = if half { old[k].lerp(newp[k], 0.5) } else { old[k] };
                    reverted += 1;
                }
            };
            for e in bad {
                for &k in self.ring_record(e) {
                    back(k);
                }
            }
            for k in crossing {
                let [f, g] = self.face_pairs[k];
                for i in f.into_iter().chain(g) {
                    back(i);
                }
            }
            self.guard_inversions(old, newp);
        }
        for (x, &o) in newp.iter_mut().zip(old) {
            if *x != o {
                *x = o;
                reverted += 1;
            }
        }
        reverted
    }

    /// The boundary edges' rings and the thin parts' face pairs read again from `m`, after
    /// any change of the boundary (a refresh, or boundary tets removed in place).
    pub(super) fn refresh_boundary(&mut self, m: &TetMesh) {
        (self.rings, self.ring_start) = boundary_rings(m, &self.index);
        self.face_pairs = thin_face_pairs(m, self);
    }

    /// The rings after boundary tets were removed in place (`removed`: their vertices, in
    /// snapshot indices): only the six edges of each removed tet have another ring, so their
    /// records are dropped and read again from `m`. The face pairs stay until the next refresh
    /// (the faces a removal uncovers were interior and join them then).
    pub(super) fn patch_rings(&mut self, m: &TetMesh, removed: &[[u32; 4]]) {
        let mut keys: Vec<(u32, u32)> = removed
            .iter()
            .flat_map(|t| EDGE_VERTICES.iter().map(move |&[i, j]| (t[i].min(t[j]), t[i].max(t[j]))))
            .collect();
        keys.sort_unstable();
        keys.dedup();
        let (mut rings, mut start) = (Vec::with_capacity(self.rings.len()), Vec::with_capacity(self.ring_start.len()));
        for e in 0..self.ring_start.len() - 1 {
            let r = self.ring_record(e);
            if keys.binary_search(&(r[0].min(r[1]), r[0].max(r[1]))).is_err() {
                start.push(rings.len() as u32);
                rings.extend_from_slice(r);
            }
        }
        for (a, b) in keys {
            let Some(shell) = m.edge_shell_of(self.ids[a as usize], self.ids[b as usize]) else { continue };
            let r = open_ring_record(&shell, &self.index);
            if !r.is_empty() {
                start.push(rings.len() as u32);
                rings.extend_from_slice(&r);
            }
        }
        start.push(rings.len() as u32);
        (self.rings, self.ring_start) = (rings, start);
    }

    /// Boundary edge e's record: its two ends, then its ring.
    fn ring_record(&self, e: usize) -> &[u32] {
        &self.rings[self.ring_start[e] as usize..self.ring_start[e + 1] as usize]
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
        let mut snap = Snapshot {
            ids,
            index,
            kind,
            tets,
            tet_ids,
            rows,
            adj,
            spent: 0,
            rings: Vec::new(),
            ring_start: vec![0],
            face_pairs: Vec::new(),
        };
        snap.refresh_boundary(m);
        snap
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
        self.refresh_boundary(m);
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
