//! Delaunay tetrahedralization by incremental insertion and flips: points in BRIO + Hilbert
//! order, a visibility walk to locate (exact orient3d), a 1-4 split, then flips of the faces
//! opposite the new vertex that fail exact insphere, from a stack, as in Joe (1991) and
//! Shewchuk's notes: 2-3 when the two tets form a convex pair, 3-2 around the one reflex edge
//! when three tets hold it, 4-4 when the new vertex, the apex and an edge are coplanar and four
//! tets hold that edge; other faces wait for a later flip. Points falling exactly on a face or
//! an edge are inserted by a cavity (Bowyer-Watson) instead; duplicates are merged.
//!
//! The triangulation starts from one enclosing tetrahedron whose four vertices lie far away
//! (10^4 times the bounding box). Deleting the tets that hold them does not always recover the
//! convex hull: a far vertex can beat a nearly flat hull-side tet (2 tets of 672 k at 10^5
//! random points). `fill_hull` then adds the tet on each reflex boundary edge and restores
//! Delaunay by checked flips. That this yields the hull is checked, not proven: the oracle test
//! verifies every boundary face against every point (exact orient3d), every interior face by
//! exact insphere, and the volume, on random sets of 10^2 to 10^5 points and degenerate grids.

use super::tet_ops::TetPatch;
use super::tetmesh::{face_key, TVertex, TVertexId, Tet, TetId, TetMesh, EDGE_VERTICES, FACE_VERTICES};
use super::VertexTag;
use crate::predicates::{insphere, orient3d, Sign};
use glam::DVec3;
use slotmap::Key;
use smallvec::SmallVec;
use std::collections::{HashMap, HashSet};

/// Indices of `points` in a biased randomized insertion order (BRIO): rounds of doubling size
/// drawn at random, each sorted along a 3-D Hilbert curve over the bounding box.
pub fn hilbert_order_3d(points: &[DVec3]) -> Vec<usize> {
    let n = points.len();
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let span = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    const BITS: u32 = 21;
    let scale = ((1u64 << BITS) - 1) as f64 / span;
    let key = |i: usize| {
        let q = (points[i] - lo) * scale;
        hilbert_index_3d([q.x as u32, q.y as u32, q.z as u32], BITS)
    };
    // A fixed shuffle, so the order is deterministic.
    let mut idx: Vec<usize> = (0..n).collect();
    // SplitMix64 with a fixed seed.
    let mut state: u64 = 0x6272_696f;
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    for i in (1..n).rev() {
        let j = (next() % (i as u64 + 1)) as usize;
        idx.swap(i, j);
    }
    let mut ends = vec![n];
    let mut m = n;
    while m > 256 {
        m /= 2;
        ends.push(m);
    }
    ends.push(0);
    ends.reverse();
    for w in ends.windows(2) {
        let seg = &mut idx[w[0]..w[1]];
        let mut keyed: Vec<(u64, usize)> = seg.iter().map(|&i| (key(i), i)).collect();
        keyed.sort_unstable();
        for (s, (_, i)) in seg.iter_mut().zip(keyed) {
            *s = i;
        }
    }
    idx
}

/// Position along the 3-D Hilbert curve (Skilling's transpose, then bit interleaving).
fn hilbert_index_3d(mut x: [u32; 3], bits: u32) -> u64 {
    let m = 1u32 << (bits - 1);
    let mut q = m;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    for i in 1..3 {
        x[i] ^= x[i - 1];
    }
    let mut t = 0;
    let mut q = m;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for v in x.iter_mut() {
        *v ^= t;
    }
    let mut key = 0u64;
    for b in (0..bits).rev() {
        for v in x {
            key = (key << 1) | ((v >> b) & 1) as u64;
        }
    }
    key
}

enum Loc {
    Inside(TetId),
    OnFace(TetId),
    Vertex(TVertexId),
    Outside,
}

impl TetMesh {
    /// The Delaunay tetrahedralization of `points` (see the module notes for the hull). Returns
    /// the mesh and the vertex of each input point; duplicates share one vertex, and a point
    /// that ends in no tet maps to a key that is not live. Needs four non-coplanar points.
    pub fn delaunay(points: &[DVec3]) -> Result<(TetMesh, Vec<TVertexId>), crate::Error> {
        use crate::Error::InvalidMesh;
        if let Some(i) = points.iter().position(|p| !p.is_finite()) {
            return Err(InvalidMesh(format!("point {i} is not finite")));
        }
        if points.len() < 4 {
            return Err(InvalidMesh("Delaunay needs at least four points".into()));
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let c = (lo + hi) * 0.5;
        let s = (hi - lo).max_element().max(1e-300);
        let far = 1e4 * s;
        let dirs = [
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(-1.0, -1.0, 1.0),
        ];
        let mut m = TetMesh::with_capacity(points.len() + 4);
        let fv: Vec<TVertexId> = dirs
            .iter()
            .map(|d| m.vertices.insert(TVertex { pos: c + *d * far, tet: TetId::null(), tag: VertexTag::Interior }))
            .collect();
        let mut v = [fv[0], fv[1], fv[2], fv[3]];
        if orient3d(m.pos(v[0]), m.pos(v[1]), m.pos(v[2]), m.pos(v[3])) != Sign::Positive {
            v.swap(2, 3);
        }
        let t0 = m.tets.insert(Tet { v, adj: [None; 4], label: 0 });
        for &x in &v {
            m.vertices[x].tet = t0;
        }
        let mut ids = vec![TVertexId::null(); points.len()];
        let mut hint = t0;
        let mut stack: Vec<TetId> = Vec::with_capacity(64);
        for i in hilbert_order_3d(points) {
            let p = points[i];
            match m.locate(p, hint) {
                Loc::Vertex(w) => ids[i] = w,
                Loc::Outside => return Err(InvalidMesh("a point fell outside the enclosing tetrahedron".into())),
                Loc::Inside(t) => {
                    let nv = m.vertices.insert(TVertex { pos: p, tet: t, tag: VertexTag::Interior });
                    ids[i] = nv;
                    stack.clear();
                    m.split14_raw(t, nv, &mut stack);
                    hint = m.restore_delaunay(nv, &mut stack);
                }
                Loc::OnFace(t) => {
                    if let Some((nv, h)) = m.insert_cavity(p, t) {
                        ids[i] = nv;
                        hint = h;
                    }
                }
            }
            if !m.tets.contains_key(hint) {
                hint = m.tets.keys().next().expect("tets");
            }
        }
        // Remove the enclosing vertices and their tets.
        let dead: Vec<TetId> =
            m.tets.iter().filter(|(_, tx)| tx.v.iter().any(|w| fv.contains(w))).map(|(t, _)| t).collect();
        let removed: Vec<Tet> = dead.iter().map(|&t| m.tets.remove(t).expect("live")).collect();
        for tx in &removed {
            for k in 0..4 {
                if let Some((u, j)) = tx.adj[k] {
                    if let Some(ux) = m.tets.get_mut(u) {
                        ux.adj[j as usize] = None;
                        let uv = ux.v;
                        for w in uv {
                            m.vertices[w].tet = u;
                        }
                    }
                }
            }
        }
        for &w in &fv {
            m.vertices.remove(w);
        }
        m.fill_hull();
        let lost: Vec<TVertexId> =
            m.vertices.iter().filter(|(_, vx)| !m.tets.contains_key(vx.tet)).map(|(w, _)| w).collect();
        for w in lost {
            m.vertices.remove(w);
        }
        if m.tets.is_empty() {
            return Err(InvalidMesh("the points are coplanar".into()));
        }
        Ok((m, ids))
    }

    /// Fills the dents left where an enclosing vertex beat a hull face: while two boundary faces
    /// (a, b, c) and (b, a, w) meet at a reflex edge (w strictly outside (a, b, c), exact), adds
    /// the positive tet (a, b, c, w), then restores Delaunay around it by flips. Returns the
    /// number of tets added.
    fn fill_hull(&mut self) -> usize {
        let mut total = 0;
        loop {
            let bf = self.boundary_faces();
            let mut by_key: HashMap<[TVertexId; 3], (TetId, u8)> = HashMap::with_capacity(bf.len());
            let mut by_edge: HashMap<(TVertexId, TVertexId), TVertexId> = HashMap::with_capacity(3 * bf.len());
            for &(t, i) in &bf {
                let f = self.face_vertices(t, i);
                by_key.insert(face_key(f), (t, i as u8));
                for k in 0..3 {
                    by_edge.insert((f[k], f[(k + 1) % 3]), f[(k + 2) % 3]);
                }
            }
            let mut touched: HashSet<TVertexId> = HashSet::new();
            let mut added: Vec<TetId> = Vec::new();
            for &(t, i) in &bf {
                if self.tets[t].adj[i].is_some() {
                    continue;
                }
                let f = self.face_vertices(t, i);
                if f.iter().any(|v| touched.contains(v)) {
                    continue;
                }
                let pf = [self.pos(f[0]), self.pos(f[1]), self.pos(f[2])];
                for k in 0..3 {
                    let (x, y) = (f[k], f[(k + 1) % 3]);
                    let Some(&w) = by_edge.get(&(y, x)) else {
                        continue;
                    };
                    if touched.contains(&w) || f.contains(&w) {
                        continue;
                    }
                    // Reflex edge: w strictly outside the face.
                    if orient3d(pf[0], pf[1], pf[2], self.pos(w)) != Sign::Positive {
                        continue;
                    }
                    let v = [f[0], f[1], f[2], w];
                    // Each face of the new tet is new, or a boundary face to glue to.
                    let mut glue: [Option<(TetId, u8)>; 4] = [None; 4];
                    let mut ok = true;
                    for (j, g) in glue.iter_mut().enumerate() {
                        let fv = FACE_VERTICES[j].map(|m| v[m]);
                        match by_key.get(&face_key(fv)) {
                            Some(&(u, l)) if self.tets[u].adj[l as usize].is_none() => *g = Some((u, l)),
                            Some(_) => ok = false,
                            None => ok &= !self.has_face(fv[0], fv[1], fv[2]),
                        }
                    }
                    if !ok {
                        continue;
                    }
                    let id = self.tets.insert(Tet { v, adj: glue, label: 0 });
                    for (j, g) in glue.iter().enumerate() {
                        if let Some((u, l)) = g {
                            self.tets[*u].adj[*l as usize] = Some((id, j as u8));
                        }
                    }
                    for &x in &v {
                        self.vertices[x].tet = id;
                        touched.insert(x);
                    }
                    added.push(id);
                    break;
                }
            }
            if added.is_empty() {
                break;
            }
            total += added.len();
            let mut stack = Vec::new();
            for &t in &added {
                for i in 0..4 {
                    stack.push((t, i));
                }
            }
            self.lawson(stack);
        }
        total
    }

    /// Lawson flips from a stack of faces: each face that fails exact insphere is removed by a
    /// 2-3 flip, or by a 3-2 flip of one of its edges; faces neither can remove are left.
    /// Returns the number of flips.
    pub(crate) fn lawson(&mut self, mut stack: Vec<(TetId, usize)>) -> usize {
        let mut flips = 0;
        while let Some((t, i)) = stack.pop() {
            if !self.tets.contains_key(t) {
                continue;
            }
            let Some((u, _)) = self.tets[t].adj[i] else {
                continue;
            };
            if self.tets[u].label != self.tets[t].label || self.is_locally_delaunay(t, i) {
                continue;
            }
            let made = match self.check_flip23(t, i) {
                Ok(plan) => self.apply_patch(plan).0,
                Err(_) => {
                    let f = FACE_VERTICES[i];
                    let mut done = None;
                    for k in 0..3 {
                        let (x, y) = (f[k].min(f[(k + 1) % 3]), f[k].max(f[(k + 1) % 3]));
                        let e = EDGE_VERTICES.iter().position(|&[p, q]| p == x && q == y).expect("edge");
                        if let Ok(plan) = self.check_flip32(t, e) {
                            done = Some(self.apply_patch(plan).0);
                            break;
                        }
                    }
                    match done {
                        Some(m) => m,
                        None => continue,
                    }
                }
            };
            flips += 1;
            for &n in &made {
                for j in 0..4 {
                    stack.push((n, j));
                }
            }
        }
        flips
    }

    /// Visibility walk from `start` with a rotating first face (exact orientations).
    fn locate(&self, p: DVec3, start: TetId) -> Loc {
        let mut t = start;
        let mut rot: u32 = 0x9e37_79b9;
        let mut prev: Option<TetId> = None;
        'walk: loop {
            let tx = &self.tets[t];
            let q = [self.pos(tx.v[0]), self.pos(tx.v[1]), self.pos(tx.v[2]), self.pos(tx.v[3])];
            rot ^= rot << 13;
            rot ^= rot >> 17;
            rot ^= rot << 5;
            let r = (rot >> 8) as usize;
            let mut zero = false;
            for k in 0..4 {
                let i = (k + r) & 3;
                let nb = tx.adj[i];
                // No need to test the face we came through.
                if nb.is_some() && nb.map(|x| x.0) == prev {
                    continue;
                }
                let f = FACE_VERTICES[i];
                match orient3d(q[f[0]], q[f[1]], q[f[2]], p) {
                    Sign::Positive => match nb {
                        Some((u, _)) => {
                            prev = Some(t);
                            t = u;
                            continue 'walk;
                        }
                        None => return Loc::Outside,
                    },
                    Sign::Zero => zero = true,
                    Sign::Negative => {}
                }
            }
            if !zero {
                return Loc::Inside(t);
            }
            if let Some(k) = (0..4).find(|&k| q[k] == p) {
                return Loc::Vertex(tx.v[k]);
            }
            return Loc::OnFace(t);
        }
    }

    /// Flips the faces opposite `p` until each passes exact insphere or cannot be flipped.
    /// Returns a live tet near `p`.
    fn restore_delaunay(&mut self, p: TVertexId, stack: &mut Vec<TetId>) -> TetId {
        let mut last = self.vertices[p].tet;
        while let Some(t) = stack.pop() {
            let Some(tx) = self.tets.get(t) else { continue };
            let tx = *tx;
            let ip = tx.v.iter().position(|&w| w == p).expect("tet holds p");
            let Some((u, j)) = tx.adj[ip] else { continue };
            let e = self.tets[u].v[j as usize];
            let q = [self.pos(tx.v[0]), self.pos(tx.v[1]), self.pos(tx.v[2]), self.pos(tx.v[3])];
            let pe = self.pos(e);
            if insphere(q[0], q[1], q[2], q[3], pe) != Sign::Positive {
                continue;
            }
            let pp = q[ip];
            let f = FACE_VERTICES[ip];
            let abc = [tx.v[f[0]], tx.v[f[1]], tx.v[f[2]]];
            let pabc = [q[f[0]], q[f[1]], q[f[2]]];
            let mut neg = SmallVec::<[usize; 3]>::new();
            let mut zeros = SmallVec::<[usize; 3]>::new();
            for k in 0..3 {
                match orient3d(pabc[k], pabc[(k + 1) % 3], pp, pe) {
                    Sign::Positive => {}
                    Sign::Negative => neg.push(k),
                    Sign::Zero => zeros.push(k),
                }
            }
            let zero = !zeros.is_empty();
            if neg.is_empty() && zeros.len() == 1 {
                // p, x, y, e coplanar: a 4-4 flip of the edge (x, y) when four tets hold it.
                let k = zeros[0];
                let (x, y) = (abc[k], abc[(k + 1) % 3]);
                let ix = tx.v.iter().position(|&w| w == x).expect("x");
                let iy = tx.v.iter().position(|&w| w == y).expect("y");
                let sh = self.edge_shell(t, ix, iy);
                if sh.closed && sh.tets.len() == 4 {
                    if let Some(r0) = sh.ring.iter().position(|&w| w == p) {
                        let r = |m: usize| sh.ring[(r0 + m) % 4];
                        if r(2) == e {
                            let tris = [[r(0), r(1), r(2)], [r(2), r(3), r(0)]];
                            let mut new: SmallVec<[([TVertexId; 4], u32); 16]> = SmallVec::new();
                            for [ci, cj, ck] in tris {
                                new.push(([sh.a, ci, cj, ck], tx.label));
                                new.push(([ci, cj, ck, sh.b], tx.label));
                            }
                            let ok = new.iter().all(|(v, _)| {
                                orient3d(self.pos(v[0]), self.pos(v[1]), self.pos(v[2]), self.pos(v[3]))
                                    == Sign::Positive
                            });
                            if ok {
                                let (made, _) =
                                    self.apply_patch(TetPatch::raw(sh.tets.iter().copied().collect(), new, None));
                                last = made[0];
                                stack.extend(made);
                            }
                        }
                    }
                }
                continue;
            }
            if neg.is_empty() && !zero {
                // 2-3: (a, b, p, e), (b, c, p, e), (c, a, p, e).
                last = t;
                self.flip23_raw(t, ip, u, j as usize, stack);
            } else if neg.len() == 1 && !zero {
                // 3-2 around the reflex edge (x, y) when exactly three tets hold it.
                let k = neg[0];
                let (x, y, z) = (abc[k], abc[(k + 1) % 3], abc[(k + 2) % 3]);
                let iz = tx.v.iter().position(|&w| w == z).expect("z");
                let Some((w, _)) = tx.adj[iz] else { continue };
                let ux = &self.tets[u];
                let uz = ux.v.iter().position(|&w| w == z).expect("z");
                if ux.adj[uz].map(|a| a.0) != Some(w) || !self.tets[w].v.contains(&e) {
                    continue;
                }
                // The two new tets: (x, p, z, e)-side and (y, p, z, e)-side, oriented by
                // substitution into t and checked exactly.
                let mut t1 = tx.v;
                let mut t2 = tx.v;
                for s in t1.iter_mut() {
                    if *s == y {
                        *s = e;
                    }
                }
                for s in t2.iter_mut() {
                    if *s == x {
                        *s = e;
                    }
                }
                let ok = |v: [TVertexId; 4]| {
                    orient3d(self.pos(v[0]), self.pos(v[1]), self.pos(v[2]), self.pos(v[3])) == Sign::Positive
                };
                if !ok(t1) || !ok(t2) {
                    continue;
                }
                last = t;
                self.flip32_raw(t, u, w, x, y, e, stack);
            }
        }
        if self.tets.contains_key(last) {
            last
        } else {
            self.vertices[p].tet
        }
    }

    /// Sets the neighbour across face `i` of `t` to `n`, and the back pointer.
    #[inline]
    fn glue(&mut self, t: TetId, i: usize, n: Option<(TetId, u8)>) {
        self.tets[t].adj[i] = n;
        if let Some((u, j)) = n {
            self.tets[u].adj[j as usize] = Some((t, i as u8));
        }
    }

    /// 1-4 split of `t` by the new vertex `p` (already stored), which the caller located
    /// strictly inside: tet k is t with vertex k replaced by p; it reuses t's slot for k = 0.
    /// Pushes the four tets.
    fn split14_raw(&mut self, t: TetId, p: TVertexId, out: &mut Vec<TetId>) {
        self.revision = self.revision.wrapping_add(1);
        let tx = self.tets[t];
        let mut n = [t; 4];
        for k in 1..4 {
            let mut v = tx.v;
            v[k] = p;
            n[k] = self.tets.insert(Tet { v, adj: [None; 4], label: tx.label });
        }
        self.tets[t].v[0] = p;
        for k in 0..4 {
            // Face k (opposite p) is t's face k; face j != k is shared with tet j's face k.
            self.glue(n[k], k, tx.adj[k]);
            for j in 0..4 {
                if j != k {
                    self.tets[n[k]].adj[j] = Some((n[j], k as u8));
                }
            }
        }
        self.vertices[tx.v[0]].tet = n[1];
        self.vertices[p].tet = t;
        out.extend_from_slice(&n);
    }

    /// 2-3 flip of face `ip` of `t` (opposite p) with `u` (face `j`, apex e), already checked
    /// convex: (x, y, p, e) for the face's edges (x, y); reuses t's and u's slots.
    fn flip23_raw(&mut self, t: TetId, ip: usize, u: TetId, j: usize, out: &mut Vec<TetId>) {
        self.revision = self.revision.wrapping_add(1);
        let (tx, ux) = (self.tets[t], self.tets[u]);
        let p = tx.v[ip];
        let e = ux.v[j];
        let f = FACE_VERTICES[ip];
        let abc = [tx.v[f[0]], tx.v[f[1]], tx.v[f[2]]];
        // Outer neighbours: across (x, y, p) from t and (x, y, e) from u, z the third vertex.
        let mut from_t = [None; 3];
        let mut from_u = [None; 3];
        for k in 0..3 {
            let z = abc[(k + 2) % 3];
            from_t[k] = tx.adj[tx.v.iter().position(|&w| w == z).expect("z in t")];
            from_u[k] = ux.adj[ux.v.iter().position(|&w| w == z).expect("z in u")];
        }
        let n2 = self.tets.insert(Tet { v: [abc[2], abc[0], p, e], adj: [None; 4], label: tx.label });
        let n = [t, u, n2];
        for k in 0..3 {
            self.tets[n[k]].v = [abc[k], abc[(k + 1) % 3], p, e];
        }
        for k in 0..3 {
            self.tets[n[k]].adj[0] = Some((n[(k + 1) % 3], 1));
            self.tets[n[k]].adj[1] = Some((n[(k + 2) % 3], 0));
            self.glue(n[k], 2, from_u[k]);
            self.glue(n[k], 3, from_t[k]);
        }
        self.vertices[abc[0]].tet = t;
        self.vertices[abc[1]].tet = t;
        self.vertices[abc[2]].tet = u;
        out.extend_from_slice(&n);
    }

    /// 3-2 flip of the edge (x, y) held by exactly t = (x, y, z, p), u = (x, y, z, e) and
    /// w = (x, y, p, e), already checked: t becomes t with y -> e, u becomes t with x -> e, w
    /// goes.
    #[allow(clippy::too_many_arguments)]
    fn flip32_raw(
        &mut self,
        t: TetId,
        u: TetId,
        w: TetId,
        x: TVertexId,
        y: TVertexId,
        e: TVertexId,
        out: &mut Vec<TetId>,
    ) {
        self.revision = self.revision.wrapping_add(1);
        let (tx, ux, wx) = (self.tets[t], self.tets[u], self.tets[w]);
        let at = |v: &[TVertexId; 4], q: TVertexId| v.iter().position(|&s| s == q).expect("vertex in tet");
        let (ix, iy) = (at(&tx.v, x), at(&tx.v, y));
        let iz = (0..4).find(|&k| k != ix && k != iy && tx.v[k] != e && ux.v.contains(&tx.v[k])).expect("z");
        let ip = 6 - ix - iy - iz;
        let mut v1 = tx.v;
        v1[iy] = e;
        let mut v2 = tx.v;
        v2[ix] = e;
        // Outer neighbours, read before any write.
        let t1 = [(iy, tx.adj[iy]), (iz, wx.adj[at(&wx.v, y)]), (ip, ux.adj[at(&ux.v, y)])];
        let t2 = [(ix, tx.adj[ix]), (iz, wx.adj[at(&wx.v, x)]), (ip, ux.adj[at(&ux.v, x)])];
        self.tets.remove(w);
        self.tets[t].v = v1;
        self.tets[u].v = v2;
        self.tets[t].adj[ix] = Some((u, iy as u8));
        self.tets[u].adj[iy] = Some((t, ix as u8));
        for (k, n) in t1 {
            self.glue(t, k, n);
        }
        for (k, n) in t2 {
            self.glue(u, k, n);
        }
        for q in v1 {
            self.vertices[q].tet = t;
        }
        self.vertices[y].tet = u;
        out.push(t);
        out.push(u);
    }

    /// Inserts `p` by emptying the tets whose circumsphere strictly holds it, grown from `t`
    /// (which holds `p` on its closure). None when a new tet would not be positive.
    fn insert_cavity(&mut self, p: DVec3, t: TetId) -> Option<(TVertexId, TetId)> {
        let mut cav: SmallVec<[TetId; 16]> = SmallVec::new();
        cav.push(t);
        let mut k = 0;
        while k < cav.len() {
            let tx = self.tets[cav[k]];
            k += 1;
            for i in 0..4 {
                if let Some((u, _)) = tx.adj[i] {
                    if cav.contains(&u) {
                        continue;
                    }
                    let q = self.tet_points(u);
                    if insphere(q[0], q[1], q[2], q[3], p) == Sign::Positive {
                        cav.push(u);
                    }
                }
            }
        }
        let null = TVertexId::null();
        let mut new: SmallVec<[([TVertexId; 4], u32); 16]> = SmallVec::new();
        for &c in &cav {
            let tx = self.tets[c];
            for i in 0..4 {
                if let Some((u, _)) = tx.adj[i] {
                    if cav.contains(&u) {
                        continue;
                    }
                }
                let mut v = tx.v;
                v[i] = null;
                let q = v.map(|w| if w.is_null() { p } else { self.pos(w) });
                if orient3d(q[0], q[1], q[2], q[3]) != Sign::Positive {
                    return None;
                }
                new.push((v, tx.label));
            }
        }
        let (made, nv) = self.apply_patch(TetPatch::raw(cav, new, Some((p, VertexTag::Interior))));
        Some((nv.expect("new vertex"), made[0]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Level;

    #[test]
    fn hilbert_keys_are_a_permutation_of_the_curve() {
        let mut keys: Vec<u64> = (0..8u32).map(|i| hilbert_index_3d([i & 1, (i >> 1) & 1, i >> 2], 1)).collect();
        keys.sort();
        assert_eq!(keys, (0..8).collect::<Vec<u64>>());
        // Consecutive cells of an order-2 curve are face neighbours.
        let mut cells: Vec<(u64, [u32; 3])> = Vec::new();
        for x in 0..4 {
            for y in 0..4 {
                for z in 0..4 {
                    cells.push((hilbert_index_3d([x, y, z], 2), [x, y, z]));
                }
            }
        }
        cells.sort();
        for w in cells.windows(2) {
            let d: u32 = (0..3).map(|k| w[0].1[k].abs_diff(w[1].1[k])).sum();
            assert_eq!(d, 1, "{:?}", w);
        }
    }

    #[test]
    fn small_delaunay_is_valid() {
        let mut r = crate::testing::Rng::new(crate::testing::SEED);
        let pts: Vec<DVec3> = (0..200).map(|_| DVec3::new(r.f64(), r.f64(), r.f64())).collect();
        let (m, ids) = TetMesh::delaunay(&pts).unwrap();
        m.validate(Level::Delaunay).unwrap();
        assert!(ids.iter().all(|&v| m.contains_vertex(v)));
    }

    #[test]
    fn grid_points_with_degeneracies() {
        let mut pts = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..4 {
                    pts.push(DVec3::new(i as f64, j as f64, k as f64));
                }
            }
        }
        pts.push(DVec3::new(1.0, 1.0, 1.0)); // a duplicate
        let (m, ids) = TetMesh::delaunay(&pts).unwrap();
        m.validate(Level::Geometry).unwrap();
        assert_eq!(ids[pts.len() - 1], ids[21]);
        assert!((m.volume() - 27.0).abs() < 1e-9, "volume {}", m.volume());
    }
}
