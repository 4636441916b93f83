//! Local operations on [`TetMesh`]: 2-3 and 3-2 flips, edge removal, edge split, edge
//! collapse, insertion in a tet and relocation. Each `check_*` only reads and returns a plan or
//! a [`Refusal`]; each `apply_*` only writes and cannot fail.
//!
//! Every operation is a *patch*: a set of old tets is replaced by new tets over the same
//! region. The apply step glues the new tets to each other and to the tets outside by face
//! keys, so one routine keeps neighbours, face indices and vertex pointers right for all ops.

use super::tetmesh::{face_key, EdgeShell, TVertex, TVertexId, Tet, TetId, TetMesh, EDGE_VERTICES, FACE_VERTICES};
use super::{Refusal, VertexTag};
use crate::predicates::{orient3d, Sign};
use glam::DVec3;
use slotmap::Key;
use smallvec::SmallVec;

/// Maps an exact orientation to a refusal: only `Positive` passes.
#[inline]
pub(crate) fn positive(s: Sign) -> Result<(), Refusal> {
    match s {
        Sign::Positive => Ok(()),
        Sign::Zero => Err(Refusal::WouldDegenerate),
        Sign::Negative => Err(Refusal::WouldInvert),
    }
}

pub(crate) type NewTets = SmallVec<[([TVertexId; 4], u32); 16]>;
/// Outside faces of a patch: key, what lies across, matched yet.
type OuterFaces = SmallVec<[([TVertexId; 3], Option<(TetId, u8)>, bool); 24]>;

/// A checked replacement of `old` tets by `new` ones (with labels). `subst` renames a vertex in
/// the faces outside (a collapse); `remove` is a vertex that disappears; `add` a vertex that
/// appears and is written into the new tets wherever they hold `TVertexId::null()`.
#[derive(Clone, Debug)]
pub struct TetPatch {
    old: SmallVec<[TetId; 16]>,
    new: NewTets,
    subst: Option<(TVertexId, TVertexId)>,
    remove: Option<TVertexId>,
    add: Option<(DVec3, VertexTag)>,
    moved: Option<(TVertexId, DVec3)>,
    /// Worst radius ratio among the new tets.
    pub min_quality: f64,
    /// The mesh revision the plan was checked against (none for crate-private fast paths).
    revision: Option<u64>,
}

impl TetPatch {
    /// A patch whose new tets the caller has already checked (crate-private fast paths).
    pub(crate) fn raw(old: SmallVec<[TetId; 16]>, new: NewTets, add: Option<(DVec3, VertexTag)>) -> Self {
        TetPatch { old, new, subst: None, remove: None, add, moved: None, min_quality: 0.0, revision: None }
    }
    /// Number of tets the patch removes.
    pub fn removed(&self) -> usize {
        self.old.len()
    }
    /// Number of tets the patch creates.
    pub fn created(&self) -> usize {
        self.new.len()
    }
}

/// The plan of a 2-3 flip.
///
/// ```text
///        d                    d
///       /|\                  /|\
///      / | \                / | \        the face (p, q, r) between t = (d, p, q, r)
///     p--|--r     ==>      p--d-e-r      and u = (p, q, r, e) is replaced by the edge d-e
///      \ | /     (3 tets around d-e:  (p,q,d,e), (q,r,d,e), (r,p,d,e))
///       \|/                   |
///        e                    e
/// ```
pub type Flip23Plan = TetPatch;
/// The plan of a 3-2 flip (the inverse of the 2-3 flip).
pub type Flip32Plan = TetPatch;

impl TetMesh {
    // ===================== patch machinery =====================

    /// Applies a checked patch and returns the new tets (and the new vertex, if any).
    pub fn apply_patch(&mut self, plan: TetPatch) -> (SmallVec<[TetId; 16]>, Option<TVertexId>) {
        if let Some(r) = plan.revision {
            debug_assert_eq!(r, self.revision, "apply_patch: the plan is stale");
        }
        self.revision = self.revision.wrapping_add(1);
        let sub = |v: TVertexId| match plan.subst {
            Some((a, b)) if v == a => b,
            _ => v,
        };
        // Faces of the region's boundary, with what lies across them.
        let mut ext: OuterFaces = SmallVec::new();
        for &t in &plan.old {
            let tx = self.tets[t];
            for i in 0..4 {
                if let Some((u, _)) = tx.adj[i] {
                    if plan.old.contains(&u) {
                        continue;
                    }
                }
                let f = self.face_vertices(t, i);
                ext.push((face_key([sub(f[0]), sub(f[1]), sub(f[2])]), tx.adj[i], false));
            }
        }
        for &t in &plan.old {
            if let Some(tx) = self.tets.remove(t) {
                self.note_tet(tx.v);
            }
        }
        if plan.add.is_some() || plan.remove.is_some() {
            self.note_vertex_set();
        }
        let newv = plan.add.map(|(pos, tag)| self.vertices.insert(TVertex { pos, tet: TetId::null(), tag }));
        if let Some((v, p)) = plan.moved {
            self.vertices[v].pos = p;
        }
        let mut made: SmallVec<[TetId; 16]> = SmallVec::new();
        let mut pending: SmallVec<[([TVertexId; 3], TetId, u8); 24]> = SmallVec::new();
        for &(mut v, label) in &plan.new {
            for x in v.iter_mut() {
                if x.is_null() {
                    *x = newv.expect("patch with a new vertex");
                }
            }
            let id = self.tets.insert(Tet { v, adj: [None; 4], label });
            self.note_tet(v);
            made.push(id);
            for &x in &v {
                self.vertices[x].tet = id;
            }
            for i in 0..4 {
                let key = face_key(self.face_vertices(id, i));
                if let Some(e) = ext.iter_mut().find(|e| !e.2 && e.0 == key) {
                    e.2 = true;
                    if let Some((u, j)) = e.1 {
                        self.tets[u].adj[j as usize] = Some((id, i as u8));
                        self.tets[id].adj[i] = Some((u, j));
                    }
                } else if let Some(k) = pending.iter().position(|p| p.0 == key) {
                    let (_, u, j) = pending.swap_remove(k);
                    self.tets[u].adj[j as usize] = Some((id, i as u8));
                    self.tets[id].adj[i] = Some((u, j));
                } else {
                    pending.push((key, id, i as u8));
                }
            }
        }
        // Faces still pending are new boundary faces (a split of a boundary edge makes two).
        // Outside faces that met no new tet pair up with each other (a collapse squeezes a
        // removed tet's two outer faces together).
        for k in 0..ext.len() {
            if ext[k].2 {
                continue;
            }
            ext[k].2 = true;
            let key = ext[k].0;
            let other = (k + 1..ext.len()).find(|&m| !ext[m].2 && ext[m].0 == key);
            debug_assert!(other.is_some() || ext[k].1.is_none(), "patch left an outside neighbour unmatched");
            if let Some(m) = other {
                ext[m].2 = true;
                let (x, y) = (ext[k].1, ext[m].1);
                if let Some((u, j)) = x {
                    self.tets[u].adj[j as usize] = y;
                    for w in self.tets[u].v {
                        self.vertices[w].tet = u;
                    }
                }
                if let Some((u, j)) = y {
                    self.tets[u].adj[j as usize] = x;
                    for w in self.tets[u].v {
                        self.vertices[w].tet = u;
                    }
                }
            }
        }
        if let Some(v) = plan.remove {
            self.vertices.remove(v);
        }
        #[cfg(debug_assertions)]
        self.check_around(&made);
        (made, newv)
    }

    /// Debug builds: the invariants around freshly written tets (mutual neighbours, matching
    /// face indices and vertices, vertex pointers, exact positive orientation).
    #[cfg(debug_assertions)]
    pub(crate) fn check_around(&self, tets: &[TetId]) {
        for &t in tets {
            let tx = &self.tets[t];
            assert_eq!(self.tet_orientation(t), Sign::Positive, "check_around: tet not positive");
            for i in 0..4 {
                assert!(self.tets.contains_key(self.vertices[tx.v[i]].tet), "check_around: dead vertex pointer");
                if let Some((u, j)) = tx.adj[i] {
                    assert_eq!(self.tets[u].adj[j as usize], Some((t, i as u8)), "check_around: neighbours");
                    assert_eq!(face_key(self.face_vertices(t, i)), face_key(self.face_vertices(u, j as usize)));
                }
            }
        }
    }

    /// Orientation checks of would-be tets; `p` is the position of the null (new) vertex and
    /// `moved` overrides one vertex's position. Returns the worst radius ratio.
    fn check_new(&self, new: &NewTets, p: DVec3, moved: Option<(TVertexId, DVec3)>) -> Result<f64, Refusal> {
        let at = |v: TVertexId| {
            if v.is_null() {
                p
            } else {
                match moved {
                    Some((m, q)) if m == v => q,
                    _ => self.pos(v),
                }
            }
        };
        let mut worst = 1.0f64;
        for (v, _) in new {
            let q = [at(v[0]), at(v[1]), at(v[2]), at(v[3])];
            positive(orient3d(q[0], q[1], q[2], q[3]))?;
            worst = worst.min(crate::quality::tet_radius_ratio(q));
        }
        Ok(worst)
    }

    fn patch(&self, old: SmallVec<[TetId; 16]>, new: NewTets) -> TetPatch {
        TetPatch {
            old,
            new,
            subst: None,
            remove: None,
            add: None,
            moved: None,
            min_quality: 0.0,
            revision: Some(self.revision),
        }
    }

    // ===================== 2-3 flip =====================

    /// Checks the 2-3 flip of face `i` of tet `t`: both tets share a label, the new edge d-e
    /// does not exist, and the three new tets are positive (exact), i.e. the pair is convex.
    pub fn check_flip23(&self, t: TetId, i: usize) -> Result<Flip23Plan, Refusal> {
        let tx = self.live_tet(t)?;
        if i > 3 {
            return Err(Refusal::StaleKey);
        }
        let (u, j) = tx.adj[i].ok_or(Refusal::BoundaryFace)?;
        // A face between subdomains is an internal boundary.
        if self.tets[u].label != tx.label {
            return Err(Refusal::Constrained);
        }
        let d = tx.v[i];
        let e = self.tets[u].v[j as usize];
        let [p, q, r] = self.face_vertices(t, i);
        let new: NewTets =
            SmallVec::from_slice(&[([p, q, d, e], tx.label), ([q, r, d, e], tx.label), ([r, p, d, e], tx.label)]);
        let worst = self.check_new(&new, DVec3::ZERO, None)?;
        // The new edge must not exist already.
        if self.find_edge(d, e).is_some() {
            return Err(Refusal::DuplicateEdge);
        }
        let mut plan = self.patch(SmallVec::from_slice(&[t, u]), new);
        plan.min_quality = worst;
        Ok(plan)
    }

    /// Flips face `i` of `t` (two tets become three) if allowed; returns the new tets.
    pub fn flip23(&mut self, t: TetId, i: usize) -> Result<SmallVec<[TetId; 16]>, Refusal> {
        let plan = self.check_flip23(t, i)?;
        Ok(self.apply_patch(plan).0)
    }

    // ===================== 3-2 flip and edge removal =====================

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

    /// Checks the 3-2 flip of edge `e` of `t`: the edge must have exactly three tets around it.
    pub fn check_flip32(&self, t: TetId, e: usize) -> Result<Flip32Plan, Refusal> {
        self.live_tet(t)?;
        let [i, j] = *EDGE_VERTICES.get(e).ok_or(Refusal::StaleKey)?;
        let s = self.edge_shell(t, i, j);
        if !s.closed {
            return Err(Refusal::BoundaryEdge);
        }
        // Only an edge of degree three.
        if s.tets.len() != 3 {
            return Err(Refusal::NotConvex);
        }
        self.check_remove_edge_shell(&s)
    }

    /// Checks the 4-4 flip of edge `e` of `t`: an interior edge with exactly four tets around
    /// it is replaced by the better of the two diagonals of its ring quad.
    ///
    /// ```text
    ///     c1 ------ c2            c1 ------ c2
    ///     |  \ a-b /  |    ==>    |       /  |     4 tets around a-b become 4 tets
    ///     |  / (x) \  |           |     /    |     around c0-c2 or c1-c3
    ///     c0 ------ c3            c0 ------ c3
    /// ```
    pub fn check_flip44(&self, t: TetId, e: usize) -> Result<TetPatch, Refusal> {
        self.live_tet(t)?;
        let [i, j] = *EDGE_VERTICES.get(e).ok_or(Refusal::StaleKey)?;
        let s = self.edge_shell(t, i, j);
        if !s.closed {
            return Err(Refusal::BoundaryEdge);
        }
        // Only an edge of degree four.
        if s.tets.len() != 4 {
            return Err(Refusal::NotConvex);
        }
        self.check_remove_edge_shell(&s)
    }

    /// 4-4 flip of edge `e` of `t` if allowed; returns the four new tets.
    pub fn flip44(&mut self, t: TetId, e: usize) -> Result<SmallVec<[TetId; 16]>, Refusal> {
        let plan = self.check_flip44(t, e)?;
        Ok(self.apply_patch(plan).0)
    }

    /// 3-2 flip of edge `e` of `t` if allowed; returns the two new tets.
    pub fn flip32(&mut self, t: TetId, e: usize) -> Result<SmallVec<[TetId; 16]>, Refusal> {
        let plan = self.check_flip32(t, e)?;
        Ok(self.apply_patch(plan).0)
    }

    // ===================== edge split =====================

    /// Checks splitting edge `e` of `t` at `p`: each tet (a, b, x, y) of the shell becomes
    /// (a, m, x, y) and (m, b, x, y), all positive (exact).
    ///
    /// ```text
    ///     a ------------- b    ==>    a ------ m ------ b
    /// ```
    /// The new vertex is `Boundary` on a boundary edge, `InternalBoundary` on an edge between
    /// subdomains, else `Interior`.
    pub fn check_split_edge(&self, t: TetId, e: usize, p: DVec3) -> Result<TetPatch, Refusal> {
        self.live_tet(t)?;
        if !p.is_finite() {
            return Err(Refusal::NonFinite);
        }
        let [i, j] = *EDGE_VERTICES.get(e).ok_or(Refusal::StaleKey)?;
        let s = self.edge_shell(t, i, j);
        let null = TVertexId::null();
        let mut new: NewTets = SmallVec::new();
        for (k, &u) in s.tets.iter().enumerate() {
            let (x, y) = (s.ring_at(k), s.ring_at(k + 1));
            let label = self.tets[u].label;
            new.push(([s.a, null, x, y], label));
            new.push(([null, s.b, x, y], label));
        }
        let worst = self.check_new(&new, p, None)?;
        let label0 = self.tets[s.tets[0]].label;
        let tag = if !s.closed {
            VertexTag::Boundary
        } else if s.tets.iter().any(|&u| self.tets[u].label != label0) {
            let curve = match (self.tag(s.a), self.tag(s.b)) {
                (VertexTag::InternalBoundary { curve }, _) | (_, VertexTag::InternalBoundary { curve }) => curve,
                _ => 0,
            };
            VertexTag::InternalBoundary { curve }
        } else {
            VertexTag::Interior
        };
        let mut plan = self.patch(s.tets.iter().copied().collect(), new);
        plan.add = Some((p, tag));
        plan.min_quality = worst;
        Ok(plan)
    }

    /// Splits edge `e` of `t` at `p` if allowed; returns the new vertex.
    pub fn split_edge(&mut self, t: TetId, e: usize, p: DVec3) -> Result<TVertexId, Refusal> {
        let plan = self.check_split_edge(t, e, p)?;
        Ok(self.apply_patch(plan).1.expect("split adds a vertex"))
    }

    // ===================== insertion in a tet (1-4) =====================

    /// Checks inserting `p` inside `t`: the four tets (t with vertex i replaced by p) must be
    /// positive, i.e. `p` strictly inside.
    ///
    /// ```text
    ///   (v0, v1, v2, v3)  ==>  (p, v1, v2, v3), (v0, p, v2, v3), (v0, v1, p, v3), (v0, v1, v2, p)
    /// ```
    pub fn check_insert_in_tet(&self, t: TetId, p: DVec3) -> Result<TetPatch, Refusal> {
        let tx = self.live_tet(t)?;
        if !p.is_finite() {
            return Err(Refusal::NonFinite);
        }
        let mut new: NewTets = SmallVec::new();
        for i in 0..4 {
            let mut v = tx.v;
            v[i] = TVertexId::null();
            new.push((v, tx.label));
        }
        let worst = self.check_new(&new, p, None)?;
        let mut plan = self.patch(SmallVec::from_slice(&[t]), new);
        plan.add = Some((p, VertexTag::Interior));
        plan.min_quality = worst;
        Ok(plan)
    }

    /// Inserts `p` inside `t` if allowed; returns the new vertex.
    pub fn insert_in_tet(&mut self, t: TetId, p: DVec3) -> Result<TVertexId, Refusal> {
        let plan = self.check_insert_in_tet(t, p)?;
        Ok(self.apply_patch(plan).1.expect("insertion adds a vertex"))
    }

    // ===================== collapse =====================

    /// Checks collapsing edge `e` of `t` with its first vertex a = v[i] merging into the second
    /// b = v[j] (swapped when `reverse`), which ends at `pos`. Refused when it fails the link
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

    // ===================== relocation =====================

    /// Checks moving `v` to `p`: fixed vertices never move; every tet around `v` stays positive.
    pub fn check_relocate(&self, v: TVertexId, p: DVec3) -> Result<(), Refusal> {
        let vx = self.vertices.get(v).ok_or(Refusal::StaleKey)?;
        if vx.tag == VertexTag::Fixed {
            return Err(Refusal::Protected(VertexTag::Fixed));
        }
        if !p.is_finite() {
            return Err(Refusal::NonFinite);
        }
        for t in self.vertex_tets(v) {
            let q = self.tets[t].v.map(|w| if w == v { p } else { self.pos(w) });
            positive(orient3d(q[0], q[1], q[2], q[3]))?;
        }
        Ok(())
    }

    /// Moves `v` to `p` if allowed.
    pub fn relocate(&mut self, v: TVertexId, p: DVec3) -> Result<(), Refusal> {
        self.check_relocate(v, p)?;
        self.vertices[v].pos = p;
        self.revision = self.revision.wrapping_add(1);
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
