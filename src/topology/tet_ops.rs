//! Local operations on [`TetMesh`]: the patch machinery, 2-3, 3-2 and 4-4 flips, edge split,
//! insertion in a tet and relocation. Edge removal lives in `tet_edge_removal`, edge collapse
//! and boundary tet removal in `tet_collapse`. Each `check_*` only reads and returns a plan or
//! a [`Refusal`]; `apply_patch` only writes and cannot fail.
//!
//! Every operation is a *patch*: a set of old tets is replaced by new tets over the same
//! region. The apply step glues the new tets to each other and to the tets outside by face
//! keys, so one routine keeps neighbours, face indices and vertex pointers right for all ops.

use super::tetmesh::{face_key, TVertex, TVertexId, Tet, TetId, TetMesh, EDGE_VERTICES, FACE_VERTICES};
use super::{embedding::faces_meet, embedding::ring_winds_once, Refusal, VertexTag};
use crate::predicates::{orient3d, Sign};
use crate::quality::dihedral_angle_at;
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

pub(super) type NewTets = SmallVec<[([TVertexId; 4], u32); 16]>;
/// Outside faces of a patch: key, what lies across, matched yet.
type OuterFaces = SmallVec<[([TVertexId; 3], Option<(TetId, u8)>, bool); 24]>;

/// A checked replacement of `old` tets by `new` ones (with labels). `subst` renames a vertex in
/// the faces outside (a collapse); `remove` is a vertex that disappears; `add` a vertex that
/// appears and is written into the new tets wherever they hold `TVertexId::null()`.
///
/// Only the engine makes patches (the `check_*` methods and [`TetMesh::ring_retriangulation`]):
/// every patch applied was checked, new tets positive by exact orientation, against the mesh
/// revision it remembers.
#[derive(Clone, Debug)]
pub struct TetPatch {
    pub(super) old: SmallVec<[TetId; 16]>,
    pub(super) new: NewTets,
    pub(super) subst: Option<(TVertexId, TVertexId)>,
    pub(super) remove: Option<TVertexId>,
    pub(super) add: Option<(DVec3, VertexTag)>,
    pub(super) moved: Option<(TVertexId, DVec3)>,
    /// Worst radius ratio among the new tets.
    pub min_quality: f64,
    /// The mesh revision the plan was checked against.
    pub(super) revision: u64,
}

impl TetPatch {
    /// Number of tets the patch removes.
    pub fn removed(&self) -> usize {
        self.old.len()
    }
    /// Number of tets the patch creates.
    pub fn created(&self) -> usize {
        self.new.len()
    }
}

impl TetMesh {
    /// The worst value of `quality` over the tets a checked patch removes, and over those it
    /// creates (at their new positions): how a caller judges a patch by its own measure.
    pub(crate) fn patch_quality(&self, plan: &TetPatch, quality: impl Fn([DVec3; 4]) -> f64) -> (f64, f64) {
        let old = plan.old.iter().map(|&t| quality(self.tet_points(t))).fold(f64::INFINITY, f64::min);
        let at = |v: TVertexId| match (plan.add, plan.moved) {
            (Some((p, _)), _) if v.is_null() => p,
            (_, Some((w, p))) if w == v => p,
            _ => self.pos(v),
        };
        let new = plan.new.iter().map(|(vs, _)| quality(vs.map(at))).fold(f64::INFINITY, f64::min);
        (old, new)
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
        debug_assert_eq!(plan.revision, self.revision, "apply_patch: the plan is stale");
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
    pub(super) fn check_new(&self, new: &NewTets, p: DVec3, moved: Option<(TVertexId, DVec3)>) -> Result<f64, Refusal> {
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

    pub(super) fn patch(&self, old: SmallVec<[TetId; 16]>, new: NewTets) -> TetPatch {
        TetPatch {
            old,
            new,
            subst: None,
            remove: None,
            add: None,
            moved: None,
            min_quality: 0.0,
            revision: self.revision,
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

    // ===================== 3-2 and 4-4 flips =====================

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
        // A boundary edge split off the edge (onto d = 0) changes the boundary surface.
        if !s.closed && !self.patch_unfolded(&plan) {
            return Err(Refusal::WouldFold);
        }
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
        let star = self.vertex_tets(v);
        for &t in &star {
            let q = self.tets[t].v.map(|w| if w == v { p } else { self.pos(w) });
            positive(orient3d(q[0], q[1], q[2], q[3]))?;
        }
        self.check_boundary_rings(v, p, &star)
    }

    /// Whether `plan` would leave the boundary unwrapped: around every edge of its new tets
    /// with both ends on the boundary, the dihedral angles of the tets there after the patch
    /// (the new ones and the untouched ones) add up to at most a full turn. A patch that
    /// changes the boundary surface (a collapse of a boundary node, a boundary edge removal
    /// or flip) can keep every tet positive and still lay the boundary over itself; one that
    /// keeps the boundary faces cannot. Angles in floating point: a sum within 1e-6 of a full
    /// turn counts as a full turn.
    pub fn patch_unfolded(&self, plan: &TetPatch) -> bool {
        let at = |v: TVertexId| {
            if v.is_null() {
                plan.add.expect("patch with a new vertex").0
            } else {
                match plan.moved {
                    Some((w, p)) if w == v => p,
                    _ => self.pos(v),
                }
            }
        };
        let on_boundary = |v: TVertexId| {
            let tag = if v.is_null() { plan.add.expect("patch with a new vertex").1 } else { self.tag(v) };
            matches!(tag, VertexTag::Boundary | VertexTag::Fixed)
        };
        for (k, [i, j]) in boundary_edges(plan.new.iter().map(|x| x.0), on_boundary) {
            let (a, b) = (plan.new[k].0[i], plan.new[k].0[j]);
            let angle_at = |v: [TVertexId; 4]| {
                let mut o = v.iter().copied().filter(|&x| x != a && x != b);
                let (c, d) = (o.next().expect("tet"), o.next().expect("tet"));
                dihedral_angle_at(at(a), at(b), at(c), at(d))
            };
            let mut sum: f64 =
                plan.new.iter().filter(|(v, _)| v.contains(&a) && v.contains(&b)).map(|(v, _)| angle_at(*v)).sum();
            if !a.is_null() && !b.is_null() {
                for t in self.vertex_tets(a) {
                    let v = self.tets[t].v;
                    if v.contains(&b) && !plan.old.contains(&t) {
                        sum += angle_at(v);
                    }
                }
            }
            if sum > std::f64::consts::TAU + 1e-6 {
                return false;
            }
        }
        self.patch_faces_clear(plan, at, on_boundary)
    }

    /// Whether the boundary faces a patch makes stay clear of the boundary around them: each
    /// meets no other boundary face (of the patch, or of a tet outside it around a boundary
    /// vertex of the patch) other than in shared corners. `at` and `on_boundary` read the
    /// patch's vertices (the null key is the added one).
    fn patch_faces_clear(
        &self,
        plan: &TetPatch,
        at: impl Fn(TVertexId) -> DVec3,
        on_boundary: impl Fn(TVertexId) -> bool,
    ) -> bool {
        let sorted = |mut f: [TVertexId; 3]| {
            f.sort_unstable();
            f
        };
        // Faces of the new tets that no other new tet shares, and no tet outside either.
        let mut faces: SmallVec<[[TVertexId; 3]; 32]> = SmallVec::new();
        for (v, _) in &plan.new {
            for fv in FACE_VERTICES {
                faces.push(fv.map(|i| v[i]));
            }
        }
        let keys: SmallVec<[[TVertexId; 3]; 32]> = faces.iter().map(|&f| sorted(f)).collect();
        let outside = |t: TetId| !plan.old.contains(&t);
        let mut mine: SmallVec<[[TVertexId; 3]; 16]> = SmallVec::new();
        for (k, &f) in faces.iter().enumerate() {
            if keys.iter().filter(|&&x| x == keys[k]).count() > 1 {
                continue;
            }
            let shared_outside = !f.iter().any(|w| w.is_null())
                && self.vertex_tets(f[0]).into_iter().any(|t| {
                    let v = self.tets[t].v;
                    outside(t) && v.contains(&f[1]) && v.contains(&f[2])
                });
            if !shared_outside {
                mine.push(f);
            }
        }
        if mine.is_empty() {
            return true;
        }
        // The boundary faces outside the patch around its boundary vertices.
        let mut near: Vec<[TVertexId; 3]> = Vec::new();
        let mut seen: SmallVec<[TVertexId; 32]> = SmallVec::new();
        for f in &mine {
            for &w in f {
                if w.is_null() || !on_boundary(w) || seen.contains(&w) {
                    continue;
                }
                seen.push(w);
                for t in self.vertex_tets(w) {
                    if !outside(t) {
                        continue;
                    }
                    let tx = &self.tets[t];
                    for g in 0..4 {
                        if tx.adj[g].is_none() {
                            near.push(sorted(self.face_vertices(t, g)));
                        }
                    }
                }
            }
        }
        near.sort_unstable();
        near.dedup();
        for (k, &f) in mine.iter().enumerate() {
            let key = sorted(f);
            for &g in mine[k + 1..].iter().chain(near.iter()) {
                if sorted(g) != key && faces_meet(&at, f, g) {
                    return false;
                }
            }
        }
        true
    }

    /// Every tet positive is not enough at the boundary: the ring of a boundary edge in the
    /// star of `v` may wrap past a full turn (the boundary laid over itself). The edges of the
    /// star with both ends on the boundary get the open-ring test with `v` at `p`.
    fn check_boundary_rings(&self, v: TVertexId, p: DVec3, star: &[TetId]) -> Result<(), Refusal> {
        let on_boundary = |w: TVertexId| matches!(self.tag(w), VertexTag::Boundary | VertexTag::Fixed);
        let at = |w: TVertexId| if w == v { p } else { self.pos(w) };
        for (k, [i, j]) in boundary_edges(star.iter().map(|&t| self.tets[t].v), on_boundary) {
            let shell = self.edge_shell(star[k], i, j);
            if !shell.closed && !ring_winds_once(at(shell.a), at(shell.b), false, shell.ring.iter().map(|&w| at(w))) {
                return Err(Refusal::WouldFold);
            }
        }
        if !on_boundary(v) {
            return Ok(());
        }
        // The boundary faces of v against the boundary faces around every boundary vertex of
        // its star (and those of the tets next to the star): a move must not lay v's faces
        // over the surface around them, nor push one sheet of the boundary through another
        // across a thin part.
        let mut mine: SmallVec<[[TVertexId; 3]; 12]> = SmallVec::new();
        let mut near: Vec<[TVertexId; 3]> = Vec::new();
        let mut around: SmallVec<[TVertexId; 32]> = SmallVec::new();
        let push_boundary_faces = |t: TetId, near: &mut Vec<[TVertexId; 3]>| {
            let tx = &self.tets[t];
            for g in 0..4 {
                if tx.adj[g].is_none() {
                    let face = self.face_vertices(t, g);
                    if !face.contains(&v) {
                        near.push(face);
                    }
                }
            }
        };
        for &t in star {
            let tx = self.tets[t];
            for f in 0..4 {
                let w = tx.v[f];
                if w != v && on_boundary(w) && !around.contains(&w) {
                    around.push(w);
                }
                match tx.adj[f] {
                    None => {
                        let face = self.face_vertices(t, f);
                        if face.contains(&v) {
                            mine.push(face);
                        }
                    }
                    Some((u, _)) if !star.contains(&u) => push_boundary_faces(u, &mut near),
                    Some(_) => {}
                }
            }
        }
        for &w in &around {
            for t in self.vertex_tets(w) {
                if !star.contains(&t) {
                    push_boundary_faces(t, &mut near);
                }
            }
        }
        for &t in star {
            push_boundary_faces(t, &mut near);
        }
        near.sort_unstable();
        near.dedup();
        for (k, &f) in mine.iter().enumerate() {
            for &g in mine[k + 1..].iter().chain(near.iter()) {
                if faces_meet(at, f, g) {
                    return Err(Refusal::WouldFold);
                }
            }
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

/// The edges of `tets` with both ends on the boundary, each once: (position in `tets`, the
/// edge's local vertices).
fn boundary_edges(
    tets: impl Iterator<Item = [TVertexId; 4]>,
    on_boundary: impl Fn(TVertexId) -> bool,
) -> SmallVec<[(usize, [usize; 2]); 32]> {
    let mut seen: SmallVec<[(TVertexId, TVertexId); 32]> = SmallVec::new();
    let mut out = SmallVec::new();
    for (k, tv) in tets.enumerate() {
        for [i, j] in EDGE_VERTICES {
            let (a, b) = (tv[i], tv[j]);
            let key = if a < b { (a, b) } else { (b, a) };
            if on_boundary(a) && on_boundary(b) && !seen.contains(&key) {
                seen.push(key);
                out.push((k, [i, j]));
            }
        }
    }
    out
}
