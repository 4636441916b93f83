use super::*;
use crate::quality::triangle_q;

/// Step control: a vertex of a triangle a step would invert steps back halfway at most this
/// many times, then stays where it was.
const MAX_HALVINGS: u8 = 2;
/// A step may not bring a triangle below this quality (see [`Snapshot::guard_inversions`]).
const FLAT_Q: f64 = 1e-3;

/// Rings around a boundary vertex whose boundary edges its own are tested against after a
/// suspicious step (see [`Snapshot::boundary_clear`]).
const BOUNDARY_RINGS: usize = 2;
/// Loop edges on either side of a moved boundary vertex that its own are tested against (see
/// [`Snapshot::loop_clear`]).
const LOOP_REACH: usize = 4;
/// Rounds of the mesh-wide boundary-crossing guard (see [`Snapshot::guard_boundary_crossings`]).
const GLOBAL_ROUNDS: usize = 16;

/// Between two subdomains (an internal boundary).
pub(super) const EDGE_INTERFACE: u8 = 2;

/// Compact arrays of the mesh for the force loop, rebuilt when the topology changes.
#[derive(Default)]
pub(super) struct Snapshot {
    /// The vertices from this index on are held core vertices next to the band (see
    /// [`Snapshot::build_band`]); `ids.len()` when the arrays hold the whole mesh.
    pub(super) n_band: usize,
    pub(super) ids: Vec<VertexId>,
    pub(super) kind: Vec<NodeKind>,
    pub(super) adj_start: Vec<u32>,
    pub(super) adj: Vec<u32>,
    pub(super) tris: Vec<[u32; 3]>,
    pub(super) tri_faces: Vec<crate::topology::FaceId>,
    /// The triangles (indices into `tris`) of each vertex.
    pub(super) vt: Incidence,
    /// Every edge: endpoints, one half-edge, and its kind (EDGE_*).
    pub(super) edges: Vec<(u32, u32, HalfEdgeId, u8)>,
    /// Flippable edges (interior, same label both sides): a, b, and the opposite c, d.
    pub(super) quads: Vec<[u32; 4]>,
    pub(super) quad_edges: Vec<HalfEdgeId>,
    /// Boundary neighbours (previous, next along the loop) of boundary vertices.
    pub(super) loop_nbrs: Vec<(u32, u32)>,
    /// The vertices with loop neighbours (boundary vertices), in index order.
    loop_ids: Vec<u32>,
    /// The boundary edges (v, next along the loop) of `loop_nbrs`, for the mesh-wide guard.
    pub(super) loop_edges: Vec<[u32; 2]>,
    /// Triangles over a boundary edge a -> b with an interior apex v: (v, a, b).
    pub(super) apexes: Vec<(u32, u32, u32)>,
    /// The apexes of `apexes`, sorted, for [`Snapshot::is_apex`].
    apex_ids: Vec<u32>,
    /// Neighbours along internal-boundary edges (up to two per vertex, u32::MAX if none).
    pub(super) iface_nbrs: Vec<[u32; 2]>,
}

impl Snapshot {
    pub(super) fn build(m: &TriMesh<DVec2>) -> Snapshot {
        let n = m.num_vertices();
        let mut ids = Vec::with_capacity(n);
        let mut index = SecondaryMap::with_capacity(n);
        let mut kind = Vec::with_capacity(n);
        for (v, vx) in m.vertices() {
            index.insert(v, ids.len() as u32);
            ids.push(v);
            kind.push(NodeKind::of(vx.tag));
        }
        let hs: Vec<HalfEdgeId> = m.edge_ids().collect();
        let faces: Vec<crate::topology::FaceId> = m.face_ids().collect();
        Self::assemble(m, ids, kind, index, n, hs, faces)
    }

    /// The arrays of the band of a large mesh whose `core` is held (see [`super::held`]):
    /// every vertex outside the core, then the core vertices next to them as fixed nodes (the
    /// halo, `n_band` onwards), the edges and triangles with a vertex in the band. The
    /// triangles of a band vertex have their vertices in the band or the halo, so every array
    /// is closed under the force loop's use of it. Work proportional to the band, but for one
    /// pass over the vertex keys.
    pub(super) fn build_band(m: &TriMesh<DVec2>, core: &SecondaryMap<VertexId, ()>) -> Snapshot {
        let mut ids = Vec::new();
        let mut index = SecondaryMap::with_capacity(m.num_vertices());
        let mut kind = Vec::new();
        for (v, vx) in m.vertices() {
            if !core.contains_key(v) {
                index.insert(v, ids.len() as u32);
                ids.push(v);
                kind.push(NodeKind::of(vx.tag));
            }
        }
        let n_band = ids.len();
        let mut hs = Vec::with_capacity(3 * n_band);
        let mut faces = Vec::with_capacity(2 * n_band);
        for k in 0..n_band {
            let v = ids[k];
            for h in m.outgoing(v) {
                let w = m.dest(h);
                let j = match index.get(w) {
                    Some(&j) => j as usize,
                    None => {
                        // A core vertex next to the band: held.
                        index.insert(w, ids.len() as u32);
                        ids.push(w);
                        kind.push(NodeKind::Fixed);
                        ids.len() - 1
                    }
                };
                // Each edge once: from its first band end.
                if j >= n_band || k < j {
                    hs.push(h);
                }
                // Each triangle once: from its first band corner (its corners are v, w and the
                // third, u).
                if let Some(f) = m.face_of(h) {
                    let later = |i: usize| i >= n_band || i >= k;
                    let u = m.dest(m.next(h));
                    if later(j) && index.get(u).is_none_or(|&i| later(i as usize)) {
                        faces.push(f);
                    }
                }
            }
        }
        let n = ids.len();
        let mut snap = Self::assemble(m, ids, kind, index, n, hs, faces);
        snap.n_band = n_band;
        snap
    }

    /// The arrays of vertices `ids` (of kinds `kind`, indexed by `index`), edges `hs` (one
    /// half-edge each) and triangles `faces`.
    fn assemble(
        m: &TriMesh<DVec2>,
        ids: Vec<VertexId>,
        kind: Vec<NodeKind>,
        index: SecondaryMap<VertexId, u32>,
        n: usize,
        hs: Vec<HalfEdgeId>,
        tri_faces: Vec<crate::topology::FaceId>,
    ) -> Snapshot {
        // Edges in one pass over the half-edges; the adjacency (CSR) is filled from them.
        let mut edges = Vec::with_capacity(hs.len());
        let mut quads = Vec::with_capacity(hs.len());
        let mut quad_edges = Vec::with_capacity(hs.len());
        let mut deg = vec![0u32; n + 1];
        // One subdomain (the usual case): no face record needs reading per edge.
        let first_label = tri_faces.first().map(|&f| m.face(f).label);
        let one_label = tri_faces.iter().all(|&f| Some(m.face(f).label) == first_label);
        // The records of each edge's two sides are read in parallel: this pass waits on memory
        // (a twin lies wherever its face was created).
        let rows: Vec<(u32, u32, u8, [u32; 2])> = hs
            .par_iter()
            .with_min_len(CHUNK)
            .map(|&h| {
                let t = m.twin(h);
                let (a, b) = (index[m.origin(h)], index[m.origin(t)]);
                match (m.face_of(h), m.face_of(t)) {
                    (Some(f1), Some(f2)) if one_label || m.face(f1).label == m.face(f2).label => {
                        (a, b, EDGE_INTERIOR, [index[m.origin(m.prev(h))], index[m.origin(m.prev(t))]])
                    }
                    (Some(_), Some(_)) => (a, b, EDGE_INTERFACE, [0, 0]),
                    _ => (a, b, EDGE_BOUNDARY, [0, 0]),
                }
            })
            .collect();
        for (&(a, b, kind, [c, d]), &h) in rows.iter().zip(&hs) {
            deg[a as usize] += 1;
            deg[b as usize] += 1;
            edges.push((a, b, h, kind));
            if kind == EDGE_INTERIOR {
                quads.push([a, b, c, d]);
                quad_edges.push(h);
            }
        }
        let mut adj_start = Vec::with_capacity(n + 1);
        let mut acc = 0u32;
        for &d in &deg[..n] {
            adj_start.push(acc);
            acc += d;
        }
        adj_start.push(acc);
        let mut cursor: Vec<u32> = adj_start[..n].to_vec();
        let mut adj = vec![0u32; acc as usize];
        for &(a, b, _, _) in &edges {
            adj[cursor[a as usize] as usize] = b;
            cursor[a as usize] += 1;
            adj[cursor[b as usize] as usize] = a;
            cursor[b as usize] += 1;
        }
        let tris: Vec<[u32; 3]> =
            tri_faces.par_iter().with_min_len(CHUNK).map(|&f| m.face_vertices(f).map(|v| index[v])).collect();
        let vt = Incidence::new(n, &tris);
        let mut loop_nbrs = vec![(u32::MAX, u32::MAX); ids.len()];
        let mut apexes = Vec::new();
        for &(_, _, h, kind) in &edges {
            if kind != EDGE_BOUNDARY {
                continue;
            }
            // g: the boundary half-edge of this edge, v -> c along the loop.
            let g = if m.face_of(h).is_none() { h } else { m.twin(h) };
            let v = index[m.origin(g)] as usize;
            if m.vertex(m.origin(g)).out == g {
                loop_nbrs[v] = (index[m.origin(m.prev(g))], index[m.dest(g)]);
            }
            let inner = m.twin(g); // c -> v, has the face
            let apex = m.origin(m.prev(inner));
            if !m.is_boundary_vertex(apex) {
                apexes.push((index[apex], index[m.origin(inner)], v as u32));
            }
        }
        let mut iface_nbrs = Vec::new();
        if edges.iter().any(|e| e.3 == EDGE_INTERFACE) {
            iface_nbrs = vec![[u32::MAX; 2]; ids.len()];
            for &(a, b, _, kind) in &edges {
                if kind == EDGE_INTERFACE {
                    for (x, y) in [(a, b), (b, a)] {
                        let slot = &mut iface_nbrs[x as usize];
                        if slot[0] == u32::MAX {
                            slot[0] = y;
                        } else {
                            slot[1] = y;
                        }
                    }
                }
            }
        }
        Snapshot {
            n_band: ids.len(),
            ids,
            kind,
            adj_start,
            adj,
            tris,
            tri_faces,
            vt,
            edges,
            quads,
            quad_edges,
            loop_ids: (0..n as u32).filter(|&i| loop_nbrs[i as usize].0 != u32::MAX).collect(),
            loop_edges: (0..n as u32)
                .filter(|&i| loop_nbrs[i as usize].1 != u32::MAX)
                .map(|i| [i, loop_nbrs[i as usize].1])
                .collect(),
            loop_nbrs,
            apex_ids: {
                let mut ids: Vec<u32> = apexes.iter().map(|a| a.0).collect();
                ids.sort_unstable();
                ids.dedup();
                ids
            },
            apexes,
            iface_nbrs,
        }
    }

    /// Whether node `i` is the interior apex of a triangle over a boundary edge.
    pub(super) fn is_apex(&self, i: usize) -> bool {
        self.apex_ids.binary_search(&(i as u32)).is_ok()
    }

    /// Step control from `old` to `newp` (only the triangles in `subset` when given): a vertex
    /// of a triangle the step would invert steps back halfway, at most MAX_HALVINGS times.
    /// Also no triangle may turn flat (q below FLAT_Q) in a step: boundary nodes projected onto a
    /// straight stretch would otherwise lay triangles of three boundary nodes flat on it, which
    /// no force opens again. With a metric (`metrics`, M at each node), q is measured in M at
    /// the triangle's first node: an element thin as the metric asks is not flat.
    pub(super) fn guard_inversions(
        &self,
        old: &[DVec2],
        newp: &mut [DVec2],
        subset: Option<&[u32]>,
        metrics: Option<&[Metric2]>,
    ) {
        let q_of = |x: &[DVec2], [a, b, c]: [usize; 3]| match metrics {
            Some(mv) => metric_triangle_q(&mv[a], [x[a], x[b], x[c]]),
            None => triangle_q([x[a], x[b], x[c]]),
        };
        // q >= FLAT_Q without a square root for the usual fair triangle: q = 16 A^2 / (a b c
        // (a + b + c)) >= 4 cross^2 / (3 lmax^4), asked with a margin of two for rounding.
        let surely_not_flat = |x: &[DVec2], [a, b, c]: [usize; 3]| {
            if metrics.is_some() {
                return false;
            }
            let (e1, e2, e3) = (x[b] - x[a], x[c] - x[a], x[c] - x[b]);
            let l2 = e1.length_squared().max(e2.length_squared()).max(e3.length_squared());
            let cross = e1.perp_dot(e2);
            4.0 * cross * cross >= 6.0 * FLAT_Q * l2 * l2
        };
        truss::guard_inversions(&self.tris, subset, old, newp, MAX_HALVINGS, Backoff::PerElement, |q, t| {
            let t = [t[0] as usize, t[1] as usize, t[2] as usize];
            orient2d(q[t[0]], q[t[1]], q[t[2]]) == Sign::Positive
                && (surely_not_flat(q, t) || q_of(q, t) >= FLAT_Q || q_of(old, t) < FLAT_Q)
        });
    }

    /// Whether the triangles of vertex i at positions q are positive and wind exactly once
    /// around it (less than once from the first edge of an open fan): the embedding, locally.
    fn winds_once(&self, q: &[DVec2], i: usize) -> bool {
        let fan = self.vt.of(i);
        let sector = |t: u32| {
            let tr = self.tris[t as usize];
            let k = tr.iter().position(|&x| x as usize == i).unwrap_or(0);
            (tr[(k + 1) % 3], tr[(k + 2) % 3])
        };
        // Reverting a neighbour can invert a triangle that the step had kept positive.
        if fan.iter().any(|&t| {
            let (b, c) = sector(t);
            orient2d(q[i], q[b as usize], q[c as usize]) != Sign::Positive
        }) {
            return false;
        }
        // An open fan starts at a b that is no sector's c.
        let start = fan.iter().map(|&t| sector(t).0).find(|&b| !fan.iter().any(|&t| sector(t).1 == b));
        let sectors = fan.iter().map(|&t| {
            let (b, c) = sector(t);
            (q[b as usize], q[c as usize])
        });
        crate::topology::fan_winds_once(q[i], sectors, start.map(|b| q[b as usize]))
    }

    /// Step control against folds (with a metric, whose steps are long across the thin
    /// direction): a step can keep every triangle positive and still jump a node over its
    /// neighbours' fans, so that the mesh winds twice around a vertex, or lay one stretch of
    /// boundary over another. Every vertex next to a moved one is checked exactly (its fan,
    /// and at the boundary its two boundary edges against the loop near it, as in
    /// [`Snapshot::guard_folds_screened`]); the nodes around a vertex that fails go
    /// back to `old` (which is embedded), until none is left (at most 8 rounds, then every
    /// moved node goes back). Then boundary edges far apart in the mesh, as there.
    pub(super) fn guard_folds(&self, old: &[DVec2], newp: &mut [DVec2]) -> usize {
        let mut reverted = self.guard_folds_rings(old, newp);
        for _ in 0..GLOBAL_ROUNDS {
            let back = self.guard_boundary_crossings(old, newp);
            if back == 0 {
                break;
            }
            reverted += back + self.guard_folds_rings(old, newp);
        }
        reverted
    }

    /// [`Snapshot::guard_folds`] within the fans and boundary rings of the moved nodes.
    fn guard_folds_rings(&self, old: &[DVec2], newp: &mut [DVec2]) -> usize {
        let mut reverted = 0;
        for round in 0..9 {
            let moved: Vec<usize> = (0..old.len()).into_par_iter().filter(|&i| newp[i] != old[i]).collect();
            if moved.is_empty() {
                break;
            }
            if round == 8 {
                for i in moved {
                    newp[i] = old[i];
                    reverted += 1;
                }
                break;
            }
            let mut check: Vec<u32> = Vec::with_capacity(4 * moved.len());
            for &i in &moved {
                check.push(i as u32);
                check.extend_from_slice(&self.adj[self.adj_start[i] as usize..self.adj_start[i + 1] as usize]);
            }
            check.sort_unstable();
            check.dedup();
            let q: &[DVec2] = newp;
            let bad: Vec<u32> = check
                .par_iter()
                .copied()
                .filter(|&i| {
                    let i = i as usize;
                    !self.winds_once(q, i) || !self.loop_clear(q, i) || !self.boundary_clear(q, i)
                })
                .collect();
            if bad.is_empty() {
                break;
            }
            for &i in &bad {
                self.revert_star(i as usize, old, newp, |_| reverted += 1);
            }
        }
        reverted
    }

    /// The neighbours of vertex i.
    fn ring(&self, i: usize) -> &[u32] {
        &self.adj[self.adj_start[i] as usize..self.adj_start[i + 1] as usize]
    }

    /// Sends vertex i's neighbours and then i itself back to `old` where they moved, calling
    /// `reverted` with each one sent back (the step control's answer to a fan that folds).
    fn revert_star(&self, i: usize, old: &[DVec2], newp: &mut [DVec2], mut reverted: impl FnMut(usize)) {
        for &j in self.ring(i).iter().chain(std::iter::once(&(i as u32))) {
            let j = j as usize;
            if newp[j] != old[j] {
                newp[j] = old[j];
                reverted(j);
            }
        }
    }

    /// Whether the two boundary edges of boundary vertex i at positions q stay clear of the
    /// other boundary edges within BOUNDARY_RINGS rings of it (exact segment tests): fans that
    /// wind once can still lay one stretch of boundary over a close one (a step across a thin
    /// notch, or two boundary nodes far closer than the size). True for interior vertices.
    fn boundary_clear(&self, q: &[DVec2], i: usize) -> bool {
        let (a, c) = self.loop_nbrs[i];
        if a == u32::MAX {
            return true;
        }
        let mut near: smallvec::SmallVec<[u32; 32]> = smallvec::SmallVec::new();
        near.push(i as u32);
        let mut from = 0;
        for _ in 0..BOUNDARY_RINGS {
            let to = near.len();
            for k in from..to {
                let v = near[k] as usize;
                for &w in &self.adj[self.adj_start[v] as usize..self.adj_start[v + 1] as usize] {
                    if !near.contains(&w) {
                        near.push(w);
                    }
                }
            }
            from = to;
        }
        let i = i as u32;
        for &j in &near {
            let k = self.loop_nbrs[j as usize].1;
            if k == u32::MAX {
                continue;
            }
            for (x, y) in [(a, i), (i, c)] {
                if j == x || j == y || k == x || k == y {
                    continue;
                }
                let (px, py, pj, pk) = (q[x as usize], q[y as usize], q[j as usize], q[k as usize]);
                if crate::topology::segments_meet(px, py, pj, pk) {
                    return false;
                }
            }
        }
        true
    }

    /// Whether the two boundary edges of boundary vertex i at positions q stay clear of the
    /// next LOOP_REACH edges along its loop on either side (exact segment tests): boundary
    /// nodes projected back onto d = 0 can pass each other along the curve, and the loop then
    /// zigzags over itself with every triangle positive and every fan winding once.
    fn loop_clear(&self, q: &[DVec2], i: usize) -> bool {
        let (a, c) = self.loop_nbrs[i];
        if a == u32::MAX {
            return true;
        }
        let i = i as u32;
        let meets = |j: u32, k: u32| {
            [(a, i), (i, c)].iter().any(|&(x, y)| {
                j != x
                    && j != y
                    && k != x
                    && k != y
                    && crate::topology::segments_meet(q[x as usize], q[y as usize], q[j as usize], q[k as usize])
            })
        };
        let (mut fwd, mut back) = (c, a);
        for _ in 0..LOOP_REACH {
            let next = self.loop_nbrs[fwd as usize].1;
            let prev = self.loop_nbrs[back as usize].0;
            if next == u32::MAX || prev == u32::MAX {
                return true;
            }
            if meets(fwd, next) || meets(prev, back) {
                return false;
            }
            fwd = next;
            back = prev;
        }
        true
    }

    /// Step control against folds without a metric, screened: a step that keeps every
    /// triangle positive along the whole straight path from `old` to `newp` cannot change the
    /// winding of a closed fan (each angle at the centre stays in (0, pi) and varies
    /// continuously, so their sum stays the same multiple of 2 pi). The path of a triangle
    /// with old edges e1, e2 (longest edge L) whose corners move by at most delta keeps
    /// cross(e1, e2) - 4 delta L - 4 delta^2 > 0, which the screen asks with a margin for
    /// rounding; the corners of the triangles that fail it, and the open fans of the boundary
    /// vertices next to a moved node, are checked exactly ([`Snapshot::winds_once`]). Nodes
    /// around a fan that does not wind once go back to `old`, then their fans are checked in
    /// turn (at most 8 rounds, then every moved node goes back). Then boundary edges far
    /// apart in the mesh ([`Snapshot::guard_boundary_crossings`]). `tris` lists the triangles
    /// (indices into `tris`) that may have a moved corner (None: all). Returns how many nodes
    /// went back.
    pub(super) fn guard_folds_screened(&self, old: &[DVec2], newp: &mut [DVec2], tris: Option<&[u32]>) -> usize {
        let mut reverted = self.guard_folds_local(old, newp, tris);
        for _ in 0..GLOBAL_ROUNDS {
            let back = self.guard_boundary_crossings(old, newp);
            if back == 0 {
                break;
            }
            reverted += back + self.guard_folds_local(old, newp, tris);
        }
        reverted
    }

    /// Step control against boundary crossings anywhere in the mesh: the local checks see the
    /// loop and the rings near a moved boundary vertex, but two stretches of boundary far
    /// apart in the mesh (the two sides of a gap narrower than the size, closing as their
    /// rows are pushed onto d = 0) can also come to cross. Every boundary edge with a moved
    /// end is tested against all boundary edges ([`first_crossing`]); the
    /// stars of the ends of a crossing pair go back to `old`, until none is left (at most
    /// GLOBAL_ROUNDS pairs, then every moved node goes back). Returns how many nodes went back.
    fn guard_boundary_crossings(&self, old: &[DVec2], newp: &mut [DVec2]) -> usize {
        let edges: &[[u32; 2]] = &self.loop_edges;
        let mut reverted = 0;
        for _ in 0..GLOBAL_ROUNDS {
            let moved = |e: [u32; 2]| e.iter().any(|&v| newp[v as usize] != old[v as usize]);
            if !edges.iter().any(|&e| moved(e)) {
                return reverted;
            }
            let q: &[DVec2] = newp;
            let hit = first_crossing(edges, q, &moved);
            let Some((i, j)) = hit else { return reverted };
            for v in edges[i].into_iter().chain(edges[j]) {
                self.revert_star(v as usize, old, newp, |_| reverted += 1);
            }
        }
        for i in 0..old.len() {
            if newp[i] != old[i] {
                newp[i] = old[i];
                reverted += 1;
            }
        }
        reverted
    }

    /// [`Snapshot::guard_folds_screened`] within the fans and boundary rings of the moved nodes.
    fn guard_folds_local(&self, old: &[DVec2], newp: &mut [DVec2], tris: Option<&[u32]>) -> usize {
        // Squared lengths and one square root per triangle: this runs on every triangle of
        // every moved node at every step.
        let path_positive = |t: u32| {
            let [a, b, c] = self.tris[t as usize].map(|x| x as usize);
            let delta2 = [a, b, c].iter().map(|&k| newp[k].distance_squared(old[k])).fold(0.0, f64::max);
            if delta2 == 0.0 {
                return true;
            }
            let (e1, e2) = (old[b] - old[a], old[c] - old[a]);
            let l2 = e1.length_squared().max(e2.length_squared()).max((old[c] - old[b]).length_squared());
            e1.perp_dot(e2) > 4.0 * (delta2 * l2).sqrt() * (1.0 + 1e-9) + 4.0 * delta2 + 1e-12 * l2
        };
        // The suspects: the corners of triangles whose path the screen cannot clear get both
        // exact checks (the fan and the boundary edges, tagged with the high bit), the boundary
        // vertices that moved or are next to a moved node the fan check (an open fan's turn
        // varies continuously and is not a multiple of 2 pi). Each triangle is screened once.
        const FULL: u32 = 1 << 31;
        let moved_at = |i: usize| newp[i] != old[i];
        let mut check: Vec<u32> = self
            .loop_ids
            .par_iter()
            .with_min_len(CHUNK)
            .copied()
            .filter(|&b| moved_at(b as usize) || self.ring(b as usize).iter().any(|&j| moved_at(j as usize)))
            .collect();
        let failing: Vec<u32> = match tris {
            Some(ts) => ts.par_iter().with_min_len(CHUNK).copied().filter(|&t| !path_positive(t)).collect(),
            None => {
                (0..self.tris.len() as u32).into_par_iter().with_min_len(CHUNK).filter(|&t| !path_positive(t)).collect()
            }
        };
        check.extend(failing.iter().flat_map(|&t| self.tris[t as usize].map(|v| v | FULL)));
        if check.is_empty() {
            return 0;
        }
        // A node listed both ways keeps the full check only.
        check.sort_unstable_by_key(|&x| (x & !FULL, std::cmp::Reverse(x & FULL)));
        check.dedup_by_key(|x| *x & !FULL);
        let mut reverted = 0;
        for round in 0..8 {
            if round > 0 {
                check.sort_unstable();
                check.dedup();
            }
            let q: &[DVec2] = newp;
            let bad: Vec<u32> = check
                .par_iter()
                .copied()
                .filter(|&x| {
                    let i = (x & !FULL) as usize;
                    !self.winds_once(q, i) || !self.loop_clear(q, i) || (x & FULL != 0 && !self.boundary_clear(q, i))
                })
                .map(|x| x & !FULL)
                .collect();
            if bad.is_empty() {
                return reverted;
            }
            check.clear();
            for &i in &bad {
                self.revert_star(i as usize, old, newp, |j| {
                    reverted += 1;
                    check.push(j as u32 | FULL);
                    check.extend(self.ring(j).iter().map(|&w| w | FULL));
                });
            }
            if check.is_empty() {
                // Every node around the bad fans is back where it was (embedded): impossible,
                // but never loop.
                break;
            }
        }
        for i in 0..old.len() {
            if newp[i] != old[i] {
                newp[i] = old[i];
                reverted += 1;
            }
        }
        reverted
    }

    /// The boundary half-edges of `m` for [`BoundaryLoops`], from the boundary vertices of
    /// these arrays and their neighbours instead of a scan of the whole arena: since the arrays
    /// were built, a vertex joined the boundary only next to a boundary vertex, and an edge
    /// closing over a vertex that left starts at a boundary vertex.
    pub(super) fn boundary_loops(&self, m: &TriMesh<DVec2>) -> BoundaryLoops {
        let mut seen = vec![false; self.ids.len()];
        let mut nodes = Vec::new();
        for &i in &self.loop_ids {
            let ring = &self.adj[self.adj_start[i as usize] as usize..self.adj_start[i as usize + 1] as usize];
            for &j in std::iter::once(&i).chain(ring) {
                if !std::mem::replace(&mut seen[j as usize], true) {
                    nodes.push(self.ids[j as usize]);
                }
            }
        }
        BoundaryLoops::of_nodes(m, nodes.into_iter())
    }

    /// Whether the mesh of these arrays is in one piece (a walk over the edges; the arrays
    /// cover the whole mesh, not a band).
    pub(super) fn is_connected(&self) -> bool {
        let n = self.ids.len();
        if n == 0 {
            return true;
        }
        let mut seen = vec![false; n];
        let mut stack = vec![0u32];
        seen[0] = true;
        let mut count = 1;
        while let Some(v) = stack.pop() {
            for &w in &self.adj[self.adj_start[v as usize] as usize..self.adj_start[v as usize + 1] as usize] {
                if !seen[w as usize] {
                    seen[w as usize] = true;
                    count += 1;
                    stack.push(w);
                }
            }
        }
        count == n
    }

    /// The given nodes and their neighbours, each once, in increasing order. They stay set in
    /// `flags` for [`Snapshot::triangles_of`]; clear them after.
    pub(super) fn with_neighbours(&self, nodes: &[u32], flags: &mut Flags) -> Vec<u32> {
        flags.fit(self.ids.len());
        for &i in nodes {
            flags.set(i);
            for &j in &self.adj[self.adj_start[i as usize] as usize..self.adj_start[i as usize + 1] as usize] {
                flags.set(j);
            }
        }
        flags.set_indices()
    }

    /// The triangles with a corner in `vertices` (those set in `flags`, in increasing order),
    /// each once: from its lowest corner in the set, so in parallel and in the same order for
    /// any thread count.
    pub(super) fn triangles_of(&self, vertices: &[u32], flags: &Flags) -> Vec<u32> {
        vertices
            .par_iter()
            .with_min_len(CHUNK / 8)
            .flat_map_iter(|&v| {
                self.vt
                    .of(v as usize)
                    .iter()
                    .copied()
                    .filter(move |&t| self.tris[t as usize].iter().all(|&c| c >= v || !flags.get(c)))
            })
            .collect()
    }

    /// Edges that fail the exact in-circle test at positions `p`, found in parallel.
    /// Whether moving internal-boundary vertex i from p[i] to q keeps it on the same side of
    /// each of its neighbours along the curve (seen along the edge to that neighbour).
    pub(super) fn keeps_curve_order(&self, i: usize, p: &[DVec2], q: DVec2) -> bool {
        let Some(nb) = self.iface_nbrs.get(i) else { return true };
        nb.iter().filter(|&&j| j != u32::MAX).all(|&j| {
            let pj = p[j as usize];
            (q - pj).dot(p[i] - pj) > 0.0
        })
    }

    /// Only quads with a vertex away from `pold` (its position at the last check): the others
    /// were checked then. With a metric, `ctx` decides by [`Ctx::metric_flip`] instead.
    pub(super) fn non_delaunay(&self, p: &[DVec2], pold: &[DVec2], ctx: Option<&Ctx>) -> Vec<HalfEdgeId> {
        self.quads
            .par_iter()
            .zip(self.quad_edges.par_iter())
            .with_min_len(CHUNK)
            .filter(|(q, _)| {
                let [a, b, c, d] = **q;
                if q.iter().all(|&v| p[v as usize] == pold[v as usize]) {
                    return false;
                }
                let (pa, pb, pc, pd) = (p[a as usize], p[b as usize], p[c as usize], p[d as usize]);
                match ctx {
                    Some(ctx) => ctx.metric_flip(pa, pb, pc, pd),
                    None => crate::predicates::incircle(pa, pb, pc, pd) == Sign::Positive,
                }
            })
            .map(|(_, h)| *h)
            .collect()
    }
}

/// The edge (index into `snap.edges`) of each adjacency slot, in the order the snapshot
/// filled them.
pub(super) fn adjacency_edges(snap: &Snapshot) -> Vec<u32> {
    let n = snap.ids.len();
    let mut cursor: Vec<u32> = snap.adj_start[..n].to_vec();
    let mut out = vec![0u32; snap.adj.len()];
    for (e, &(a, b, _, _)) in snap.edges.iter().enumerate() {
        out[cursor[a as usize] as usize] = e as u32;
        cursor[a as usize] += 1;
        out[cursor[b as usize] as usize] = e as u32;
        cursor[b as usize] += 1;
    }
    out
}

pub(super) fn write_back(m: &mut TriMesh<DVec2>, snap: &Snapshot, p: &[DVec2]) {
    for (i, &v) in snap.ids.iter().enumerate() {
        m.set_pos_unchecked(v, p[i]);
    }
}

pub(super) fn mean_quality(ctx: &Ctx, snap: &Snapshot, p: &[DVec2]) -> f64 {
    let (s, _) = det_sum(snap.tris.len(), |t| {
        let [a, b, c] = snap.tris[t];
        (ctx.tri_q([p[a as usize], p[b as usize], p[c as usize]]), 0.0)
    });
    s / snap.tris.len().max(1) as f64
}

/// The first pair (in a fixed order) of edges among `edges` at positions q that share no end,
/// have a moved end (`moved`), and meet (exact segment tests). A sequential sweep over the
/// boxes sorted by their low x: a boundary has few edges, and a parallel grid would cost more
/// in waking threads every step than the test itself.
fn first_crossing(edges: &[[u32; 2]], q: &[DVec2], moved: &dyn Fn([u32; 2]) -> bool) -> Option<(usize, usize)> {
    let boxes: Vec<(DVec2, DVec2)> = edges
        .iter()
        .map(|&[a, b]| {
            let (a, b) = (q[a as usize], q[b as usize]);
            (a.min(b), a.max(b))
        })
        .collect();
    let mut order: Vec<u32> = (0..edges.len() as u32).collect();
    order.sort_unstable_by(|&x, &y| boxes[x as usize].0.x.total_cmp(&boxes[y as usize].0.x).then(x.cmp(&y)));
    let is_moved: Vec<bool> = edges.iter().map(|&e| moved(e)).collect();
    for (k, &i) in order.iter().enumerate() {
        let (i, (lo, hi)) = (i as usize, boxes[i as usize]);
        for &j in &order[k + 1..] {
            let (j, (lo2, hi2)) = (j as usize, boxes[j as usize]);
            if lo2.x > hi.x {
                break;
            }
            if (!is_moved[i] && !is_moved[j]) || lo2.y > hi.y || lo.y > hi2.y {
                continue;
            }
            let (e, f) = (edges[i], edges[j]);
            if e.iter().any(|v| f.contains(v)) {
                continue;
            }
            let p = |v: u32| q[v as usize];
            if crate::topology::segments_meet(p(e[0]), p(e[1]), p(f[0]), p(f[1])) {
                return Some((i, j));
            }
        }
    }
    None
}
