//! Delaunay tetrahedralization by incremental insertion: points in BRIO + Hilbert order, a
//! visibility walk to locate (exact orient3d), and a Bowyer-Watson cavity per point (exact
//! insphere) in a flat-array kernel (`tet_delaunay_kernel`, which says why a cavity and not a
//! flip sequence); the result is copied into the arena mesh once. Duplicates are merged.
//!
//! The triangulation starts from one enclosing tetrahedron whose four vertices lie far away
//! (10^4 times the bounding box). Deleting the tets that hold them does not always recover the
//! convex hull: a far vertex can beat a nearly flat hull-side tet (2 tets of 672 k at 10^5
//! random points). `fill_hull` then adds the tet on each reflex boundary edge and restores
//! Delaunay by checked flips (Lawson's 2-3 / 3-2 flips, Joe 1991). That this yields the hull is
//! checked, not proven: the oracle test verifies every boundary face against every point (exact
//! orient3d), every interior face by exact insphere, and the volume, on random sets of 10^2 to
//! 10^5 points and degenerate grids.

use super::tet_delaunay_kernel::{Inserted, Kernel, MAX_POINTS, NONE};
use super::tetmesh::{face_key, TVertex, TVertexId, Tet, TetId, TetMesh, EDGE_VERTICES, FACE_VERTICES};
use super::VertexTag;
use crate::predicates::{orient3d, Sign};
use glam::DVec3;
use slotmap::{Key, KeyData};
use std::collections::{HashMap, HashSet};

/// The key that the `i`-th insertion into a fresh slot map returns: slotmap 1.x reserves slot
/// 0 and gives slot i + 1 version 1, in the layout of `KeyData::as_ffi` (index in the low 32
/// bits, version in the high ones). slotmap does not promise that layout, so every insertion
/// that relies on it is checked, and a mismatch is an internal error, not a wrong mesh.
#[inline]
fn fresh_key<K: From<KeyData>>(i: u32) -> K {
    KeyData::from_ffi((1u64 << 32) | (i as u64 + 1)).into()
}

fn keys_out_of_order() -> crate::Error {
    crate::Error::internal("the slot map did not hand out keys in insertion order (its key layout changed)")
}

/// Indices of `points` in a biased randomized insertion order (BRIO, Amenta, Choi and Rote
/// 2003): rounds growing eightfold drawn at random, each sorted along a 3-D Hilbert curve over
/// the bounding box. Larger last rounds keep consecutive points closer (shorter walks, warmer
/// caches) than doubling rounds, and the randomized rounds keep the expected cost bound.
pub fn hilbert_order_3d(points: &[DVec3]) -> Vec<usize> {
    let n = points.len();
    let key = hilbert_keys(points);
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
        m /= 8;
        ends.push(m);
    }
    ends.push(0);
    ends.reverse();
    // Sorted as (key, index) pairs side by side: a sort that looks keys up through the indices
    // waits for a cache miss at almost every comparison.
    let mut pairs: Vec<(u64, usize)> = Vec::with_capacity(n - n / 8);
    for w in ends.windows(2) {
        pairs.clear();
        pairs.extend(idx[w[0]..w[1]].iter().map(|&i| (key[i], i)));
        pairs.sort_unstable();
        for (slot, &(_, i)) in idx[w[0]..w[1]].iter_mut().zip(&pairs) {
            *slot = i;
        }
    }
    idx
}

/// Indices of `points` sorted along a 3-D Hilbert curve over their bounding box (ties by
/// index): a memory order in which neighbours in space are mostly neighbours in memory.
pub fn hilbert_sort_3d(points: &[DVec3]) -> Vec<usize> {
    let key = hilbert_keys(points);
    let mut pairs: Vec<(u64, usize)> = key.into_iter().zip(0..).collect();
    pairs.sort_unstable();
    pairs.into_iter().map(|(_, i)| i).collect()
}

/// Each point's position along the Hilbert curve of an octree over the bounding box.
fn hilbert_keys(points: &[DVec3]) -> Vec<u64> {
    let n = points.len();
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let span = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    // Three bits per level of an octree with about one point per cell, plus three to spare:
    // a finer curve orders nothing better and costs a loop per bit.
    let levels = (usize::BITS - n.leading_zeros()).div_ceil(3);
    let bits = (levels + 3).clamp(4, 21);
    let scale = ((1u64 << bits) - 1) as f64 / span;
    points
        .iter()
        .map(|p| {
            let q = (*p - lo) * scale;
            hilbert_index_3d([q.x as u32, q.y as u32, q.z as u32], bits)
        })
        .collect()
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
        if points.len() > MAX_POINTS {
            return Err(crate::Error::TooManyElements {
                estimated: 7 * points.len() as u64,
                limit: 7 * MAX_POINTS as u64,
            });
        }
        let order = hilbert_order_3d(points);
        let c = (lo + hi) * 0.5;
        let s = (hi - lo).max_element().max(1e-300);
        let mut k = Kernel::new(c, 1e4 * s, points.len());
        // Kernel vertex of each input point.
        let mut kid = vec![NONE; points.len()];
        let mut hint = 0;
        // Gathered first: independent loads overlap, where a load inside the insertion loop
        // would stall it once per point on large inputs.
        let ordered: Vec<DVec3> = order.iter().map(|&i| points[i]).collect();
        for (&i, &p) in order.iter().zip(&ordered) {
            match k.insert(p, hint) {
                Some(Inserted::New(t)) => {
                    kid[i] = (k.pts.len() - 1) as u32;
                    hint = t;
                }
                Some(Inserted::Duplicate(v)) => kid[i] = v,
                None => return Err(InvalidMesh("a point fell outside the enclosing tetrahedron".into())),
            }
        }
        // To the arena mesh, without the enclosing vertices and their tets, in one pass over the
        // tets: a fresh slot map hands out keys (index i + 1, version 1) in insertion order, so
        // every key is known before its record is written (each insertion checks it).
        let mut m = TetMesh::with_capacity(k.pts.len());
        // The kept kernel tets as a bit set with the count of kept tets before each word: the new
        // index of a neighbour is then read from 1/32 of the memory a table of indices would take
        // (in cache, where such a table is not). And a kept tet of each kernel vertex.
        let mut keep = vec![0u64; k.tets.len().div_ceil(64)];
        let mut rank = vec![0u32; keep.len()];
        let mut vtet = vec![NONE; k.pts.len()];
        let mut kept = 0u32;
        for (t, kt) in k.tets.iter().enumerate() {
            if t & 63 == 0 {
                rank[t >> 6] = kept;
            }
            let w = kt.v;
            if w[0] == NONE || w[0] < 4 || w[1] < 4 || w[2] < 4 || w[3] < 4 {
                continue;
            }
            keep[t >> 6] |= 1 << (t & 63);
            for x in w {
                vtet[x as usize] = kept;
            }
            kept += 1;
        }
        let newidx = |u: usize| -> u32 {
            let (word, bit) = (keep[u >> 6], 1u64 << (u & 63));
            if word & bit == 0 {
                NONE
            } else {
                rank[u >> 6] + (word & (bit - 1)).count_ones()
            }
        };
        for (w, &pos) in k.pts.iter().enumerate().skip(4) {
            let tet = if vtet[w] == NONE { TetId::null() } else { fresh_key(vtet[w]) };
            let id = m.vertices.insert(TVertex { pos, tet, tag: VertexTag::Interior });
            if id != fresh_key::<TVertexId>(w as u32 - 4) {
                return Err(keys_out_of_order());
            }
        }
        // Loops written out (no `array::map`): this copies millions of tets.
        let mut hull = Vec::new();
        let mut nt = 0u32;
        for (t, kt) in k.tets.iter().enumerate() {
            if keep[t >> 6] & (1 << (t & 63)) == 0 {
                continue;
            }
            let w = kt.v;
            let v = [fresh_key(w[0] - 4), fresh_key(w[1] - 4), fresh_key(w[2] - 4), fresh_key(w[3] - 4)];
            let me: TetId = fresh_key(nt);
            let mut adj = [None; 4];
            for (j, (a, &nb)) in adj.iter_mut().zip(kt.n.iter()).enumerate() {
                let u = if nb == NONE { NONE } else { newidx((nb >> 2) as usize) };
                if u == NONE {
                    hull.push((me, j));
                } else {
                    *a = Some((fresh_key(u), (nb & 3) as u8));
                }
            }
            let id = m.tets.insert(Tet { v, adj, label: 0 });
            if id != me {
                return Err(keys_out_of_order());
            }
            nt += 1;
        }
        let ids: Vec<TVertexId> = kid.iter().map(|&w| fresh_key(w - 4)).collect();
        // Vertices of enclosing tets only; the hull filling below adds tets on hull vertices alone.
        let lost: Vec<TVertexId> =
            (4..k.pts.len()).filter(|&w| vtet[w] == NONE).map(|w| fresh_key(w as u32 - 4)).collect();
        drop(k);
        m.fill_hull(hull);
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
    /// number of tets added. `hull` holds the boundary faces; later rounds look for boundary
    /// faces only around their vertices (filling and flips add no boundary vertex), not in the
    /// whole mesh.
    fn fill_hull(&mut self, hull: Vec<(TetId, usize)>) -> usize {
        let mut total = 0;
        let mut bverts: Vec<TVertexId> = hull.iter().flat_map(|&(t, i)| self.face_vertices(t, i)).collect();
        bverts.sort_unstable();
        bverts.dedup();
        let mut first = Some(hull);
        loop {
            let bf = first.take().unwrap_or_else(|| {
                let mut seen = HashSet::new();
                for &v in &bverts {
                    for t in self.vertex_tets(v) {
                        for i in 0..4 {
                            if self.tets[t].adj[i].is_none() {
                                seen.insert((t, i));
                            }
                        }
                    }
                }
                let mut bf: Vec<(TetId, usize)> = seen.into_iter().collect();
                bf.sort_unstable();
                bf
            });
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
                    self.note_tet(v);
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

    /// Lawson flips (exact insphere) from the four faces of each tet around `v`, tet by tet in
    /// the order of [`TetMesh::vertex_tets`]: what a split, a collapse or a move at `v` needs
    /// to restore the Delaunay property around it. Returns the flip count.
    pub fn lawson_star(&mut self, v: TVertexId) -> usize {
        let stack: Vec<(TetId, usize)> =
            self.vertex_tets(v).iter().flat_map(|&t| (0..4).map(move |f| (t, f))).collect();
        self.lawson(stack)
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
    fn cospherical_points_and_a_centre() {
        // Every integer point on the sphere of radius 5, then the centre, whose cavity is the
        // whole ball: large cavities, many cospherical sets, exact ties everywhere.
        let mut pts = Vec::new();
        for x in -5i32..=5 {
            for y in -5i32..=5 {
                for z in -5i32..=5 {
                    if x * x + y * y + z * z == 25 {
                        pts.push(DVec3::new(x as f64, y as f64, z as f64));
                    }
                }
            }
        }
        let n = pts.len();
        pts.push(DVec3::ZERO);
        let (m, ids) = TetMesh::delaunay(&pts).unwrap();
        m.validate(Level::Delaunay).unwrap();
        assert_eq!(m.num_vertices(), n + 1);
        assert!(m.contains_vertex(ids[n]));
        assert!(m.vertex_tets(ids[n]).len() >= 4);
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
