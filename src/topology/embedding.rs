//! The embedding invariant, decided by exact predicates in linear expected time.
//!
//! Positive elements are not enough: a planar mesh whose triangles are all counter-clockwise
//! can still wind twice around a vertex (a fold), and then it covers part of the plane twice.
//!
//! - **Planar triangles.** Around an interior vertex v the angles of its triangles must sum to
//!   exactly 2 pi, around a boundary vertex to less. Each triangle (v, b, c) turns from b to c
//!   counter-clockwise by less than pi (it is positive), so the sum is 2 pi times the number of
//!   times the fan crosses a reference ray from v. A sector crosses the ray exactly when b lies
//!   in the lower half-plane [pi, 2 pi) and c in the upper [0, pi), which is decided by exact
//!   coordinate comparisons (ray +x, interior vertices) or by orient2d against the first
//!   triangle's leading edge (boundary vertices, whose fan must not cross it at all). Boundary
//!   edges that do not share a vertex must not meet (a spatial-hash pass, exact segment tests).
//! - **Tetrahedra.** The same count around every edge: the tets (a, b, r_k, r_k+1) turn about
//!   ab by less than pi each; an interior edge's ring must cross the reference half-plane
//!   (a, b, r_0) exactly once, a boundary edge's not at all. Every vertex link is then a
//!   degree-one cover of the sphere of directions, i.e. embedded. The boundary surface must not
//!   intersect itself (the surface test below).
//! - **Surfaces.** No two triangles meet other than in their shared vertices or edge (exact
//!   triangle-triangle tests on the pairs a spatial hash proposes).

use super::intersect::{first_hit, segments_meet, triangles_meet, Box3};
use super::tetmesh::{TVertexId, TetId, TetMesh};
use super::tri_validate::{Invariant, InvariantViolation};
use super::trimesh::{FaceId, TriMesh, VertexId};
use crate::predicates::{orient2d, orient3d, Sign};
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use slotmap::Key;
use smallvec::SmallVec;

fn violation<K: Key>(invariant: Invariant, k: K) -> InvariantViolation {
    InvariantViolation { invariant, at: format!("{:?}", k.data()) }
}

/// Upper half-plane about v for the ray +x: angle in [0, pi). Exact (comparisons only).
#[inline]
fn upper_x(v: DVec2, p: DVec2) -> bool {
    p.y > v.y || (p.y == v.y && p.x > v.x)
}

/// Upper half-plane about v for the ray towards r: angle in [0, pi) measured from r - v.
#[inline]
fn upper_ref(v: DVec2, r: DVec2, p: DVec2) -> bool {
    match orient2d(v, r, p) {
        Sign::Positive => true,
        Sign::Negative => false,
        // On the line through v and r: upper when on r's side of v (exact sign comparisons).
        Sign::Zero => (p.x - v.x).signum() == (r.x - v.x).signum() && (p.y - v.y).signum() == (r.y - v.y).signum(),
    }
}

/// Whether the fan of sectors (b, c) around v (each triangle (v, b, c) positive) turns exactly
/// once around v (`boundary_start` none: an interior vertex) or by less than 2 pi starting
/// from the ray towards `boundary_start` (a boundary vertex). Exact (see the module notes);
/// shared by `validate` and the 2-D step control.
pub(crate) fn fan_winds_once(
    v: DVec2,
    sectors: impl Iterator<Item = (DVec2, DVec2)>,
    boundary_start: Option<DVec2>,
) -> bool {
    let mut crossings = 0u32;
    for (b, c) in sectors {
        let (ub, uc) = match boundary_start {
            Some(r) => (upper_ref(v, r, b), upper_ref(v, r, c)),
            None => (upper_x(v, b), upper_x(v, c)),
        };
        if !ub && uc {
            crossings += 1;
        }
    }
    if boundary_start.is_some() {
        crossings == 0
    } else {
        crossings == 1
    }
}

/// Checks the planar embedding of a mesh whose faces are all positive (see the module notes).
pub(crate) fn planar(m: &TriMesh<DVec2>) -> Result<(), InvariantViolation> {
    let verts: Vec<_> = m.vertex_ids().collect();
    let bad = verts.par_iter().find_map_first(|&v| {
        let out = m.outgoing(v);
        // The first ring vertex of a boundary fan: its edge has a face on the left and none
        // on the right.
        let reference = if m.is_boundary_vertex(v) {
            match out.iter().find(|&&h| m.face_of(h).is_some() && m.face_of(m.twin(h)).is_none()) {
                Some(&h) => Some(m.pos(m.dest(h))),
                None => return Some(violation(Invariant::FoldedVertex, v)),
            }
        } else {
            None
        };
        let sectors =
            out.iter().filter(|&&h| m.face_of(h).is_some()).map(|&h| (m.pos(m.dest(h)), m.pos(m.dest(m.next(h)))));
        (!fan_winds_once(m.pos(v), sectors, reference)).then(|| violation(Invariant::FoldedVertex, v))
    });
    if let Some(e) = bad {
        return Err(e);
    }
    // Boundary edges that share no vertex must not meet.
    let edges: Vec<_> = m.half_edge_ids().filter(|&h| m.face_of(h).is_none()).collect();
    let ends: Vec<[_; 2]> = edges.iter().map(|&h| [m.origin(h), m.dest(h)]).collect();
    let boxes: Vec<Box3> = ends
        .iter()
        .map(|&[a, b]| {
            let (p, q) = (m.pos(a), m.pos(b));
            (p.min(q).extend(0.0), p.max(q).extend(0.0))
        })
        .collect();
    let hit = first_hit(&boxes, 2, |i, j| {
        let (e, f) = (ends[i], ends[j]);
        if e.iter().any(|v| f.contains(v)) {
            return false;
        }
        segments_meet(m.pos(e[0]), m.pos(e[1]), m.pos(f[0]), m.pos(f[1]))
    });
    match hit {
        Some((i, j)) => {
            let seg = |e: [VertexId; 2]| {
                format!("({}, {})-({}, {})", m.pos(e[0]).x, m.pos(e[0]).y, m.pos(e[1]).x, m.pos(e[1]).y)
            };
            Err(InvariantViolation {
                invariant: Invariant::BoundaryCrossing,
                at: format!("{:?} and {:?}: {} meets {}", edges[i].data(), edges[j].data(), seg(ends[i]), seg(ends[j])),
            })
        }
        None => Ok(()),
    }
}

/// The boundary edges a moved vertex of a planar mesh in several pieces must be tested against
/// besides its own loop (see [`boundary_clear`]): every boundary edge, as its two vertices, or
/// none when the mesh is connected. In a connected mesh the relocation's own-loop test is exact
/// (the grown part lies in the complement component that loop borders, see `fan`); a mesh in
/// pieces (a start that a narrow gap cut apart) can lay one piece over another.
pub(crate) fn boundary_edges_if_split(m: &TriMesh<DVec2>) -> Vec<[VertexId; 2]> {
    let Some(first) = m.vertex_ids().next() else { return Vec::new() };
    let mut seen: slotmap::SecondaryMap<VertexId, ()> = slotmap::SecondaryMap::new();
    seen.insert(first, ());
    let mut stack = vec![first];
    while let Some(v) = stack.pop() {
        for h in m.outgoing(v) {
            let w = m.dest(h);
            if seen.insert(w, ()).is_none() {
                stack.push(w);
            }
        }
    }
    if seen.len() == m.num_vertices() {
        return Vec::new();
    }
    m.half_edge_ids().filter(|&h| m.face_of(h).is_none()).map(|h| [m.origin(h), m.dest(h)]).collect()
}

/// Whether the boundary edges at `v` meet none of `edges` (from [`boundary_edges_if_split`]) that they
/// share no vertex with. A relocation checks the moved fans and `v`'s own boundary loop; a
/// mesh in several pieces (or with a hole a node can reach) needs this too for the embedding.
/// Exact; a box test spares the predicates on almost every edge.
pub(crate) fn boundary_clear(m: &TriMesh<DVec2>, v: VertexId, edges: &[[VertexId; 2]]) -> bool {
    if edges.is_empty() || !m.is_boundary_vertex(v) {
        return true;
    }
    let pv = m.pos(v);
    let ends: SmallVec<[VertexId; 2]> =
        m.outgoing(v).into_iter().filter(|&h| m.is_boundary_edge(h)).map(|h| m.dest(h)).collect();
    for &[a, b] in edges {
        let (pa, pb) = (m.pos(a), m.pos(b));
        for &w in &ends {
            if a == v || b == v || a == w || b == w {
                continue;
            }
            let pw = m.pos(w);
            let apart = pa.x.max(pb.x) < pv.x.min(pw.x)
                || pa.x.min(pb.x) > pv.x.max(pw.x)
                || pa.y.max(pb.y) < pv.y.min(pw.y)
                || pa.y.min(pb.y) > pv.y.max(pw.y);
            if !apart && segments_meet(pv, pw, pa, pb) {
                return false;
            }
        }
    }
    true
}

/// The first pair of triangles (by index) of a soup that meet other than in shared corners.
pub(crate) fn soup_intersection(points: &[DVec3], tris: &[[usize; 3]]) -> Option<(usize, usize)> {
    let boxes: Vec<Box3> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| points[i]);
            (a.min(b).min(c), a.max(b).max(c))
        })
        .collect();
    first_hit(&boxes, 3, |i, j| faces_meet(|k| points[k], tris[i], tris[j]))
}

/// Whether two triangles given by vertex indices meet other than in the corners they share
/// (exact; see [`triangles_meet`]).
pub(crate) fn faces_meet<T: Copy + PartialEq>(points: impl Fn(T) -> DVec3, t: [T; 3], u: [T; 3]) -> bool {
    // Boxes strictly apart first (faces sharing a corner have touching boxes).
    let (pt, pu) = (t.map(&points), u.map(&points));
    let (lo_t, hi_t) = (pt[0].min(pt[1]).min(pt[2]), pt[0].max(pt[1]).max(pt[2]));
    let (lo_u, hi_u) = (pu[0].min(pu[1]).min(pu[2]), pu[0].max(pu[1]).max(pu[2]));
    if hi_t.cmplt(lo_u).any() || hi_u.cmplt(lo_t).any() {
        return false;
    }
    // Shared corners first, in matching order.
    let mut ts = [0usize; 3];
    let mut us = [0usize; 3];
    let mut shared = 0;
    for (x, &a) in t.iter().enumerate() {
        if let Some(y) = u.iter().position(|&b| b == a) {
            ts[shared] = x;
            us[shared] = y;
            shared += 1;
        }
    }
    let (mut nt, mut nu) = (shared, shared);
    for x in 0..3 {
        if !ts[..shared].contains(&x) {
            ts[nt] = x;
            nt += 1;
        }
        if !us[..shared].contains(&x) {
            us[nu] = x;
            nu += 1;
        }
    }
    triangles_meet(ts.map(|x| pt[x]), us.map(|y| pu[y]), shared)
}

/// Whether a face around `v` meets a face within two rings of it other than in
/// shared corners (exact, as [`surface`]; faces sharing a corner with the star are not
/// tested, see [`star_meets`]): the local form of the surface test, for checking a move where
/// the surface folds sharply. Two rings reach the faces across a feature curve from a vertex
/// beside it, where a fold-free star can still pass through the other side's faces.
pub(crate) fn surface_star_meets(m: &TriMesh<DVec3>, v: VertexId) -> bool {
    let faces = m.vertex_faces(v);
    let star: SmallVec<[[VertexId; 3]; 8]> = faces.iter().map(|&f| m.face_vertices(f)).collect();
    let near = faces_near(m, v, |f| !faces.contains(&f));
    star_meets(|w| m.pos(w), &star, &near)
}

/// The faces (as corner triples) with a corner within two rings of `v` that `keep` accepts.
fn faces_near(m: &TriMesh<DVec3>, v: VertexId, keep: impl Fn(FaceId) -> bool) -> Vec<[VertexId; 3]> {
    let mut ring: Vec<VertexId> = vec![v];
    for _ in 0..2 {
        let n = ring.len();
        for i in 0..n {
            ring.extend(m.neighbours(ring[i]));
        }
        ring.sort_unstable();
        ring.dedup();
    }
    let mut faces: Vec<FaceId> = ring.iter().flat_map(|&w| m.vertex_faces(w)).filter(|&f| keep(f)).collect();
    faces.sort_unstable();
    faces.dedup();
    faces.into_iter().map(|f| m.face_vertices(f)).collect()
}

/// Whether a face of `star` meets another of `star` or one of `near` that shares no corner with
/// it. Faces sharing a corner are left out (a crossing there is a fold, for the callers' fold
/// tests or the final check of the whole surface): touching in their shared corners, they
/// would need the exact test every time.
fn star_meets(point: impl Fn(VertexId) -> DVec3 + Copy, star: &[[VertexId; 3]], near: &[[VertexId; 3]]) -> bool {
    let bounds = |t: &[VertexId; 3]| {
        let [a, b, c] = t.map(point);
        (a.min(b).min(c), a.max(b).max(c))
    };
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for t in star {
        let (l, h) = bounds(t);
        lo = lo.min(l);
        hi = hi.max(h);
    }
    let apart = |t: &[VertexId; 3], u: &[VertexId; 3]| t.iter().all(|v| !u.contains(v));
    star.iter().enumerate().any(|(i, t)| {
        star[i + 1..]
            .iter()
            .chain(near.iter().filter(|u| {
                let (l, h) = bounds(u);
                !(h.cmplt(lo).any() || hi.cmplt(l).any())
            }))
            .any(|u| apart(t, u) && faces_meet(point, *t, *u))
    })
}

/// Checks that a triangle mesh in space does not intersect itself.
pub(crate) fn surface(m: &TriMesh<DVec3>) -> Result<(), InvariantViolation> {
    let a = m.to_arrays();
    let faces: Vec<_> = m.face_ids().collect();
    match soup_intersection(&a.points, &a.cells) {
        // to_arrays lists the faces in face_ids order.
        Some((i, _)) => Err(violation(Invariant::SelfIntersection, faces[i])),
        None => Ok(()),
    }
}

/// Same half-plane as r within the plane of (a, b, r): exact through a projection that keeps
/// the triangle (a, b, r) non-degenerate.
fn same_side_in_plane(a: DVec3, b: DVec3, r: DVec3, p: DVec3) -> bool {
    let drops: [fn(DVec3) -> DVec2; 3] = [|p| DVec2::new(p.y, p.z), |p| DVec2::new(p.z, p.x), |p| DVec2::new(p.x, p.y)];
    for f in drops {
        let s = orient2d(f(a), f(b), f(r));
        if s != Sign::Zero {
            return orient2d(f(a), f(b), f(p)) == s;
        }
    }
    false
}

/// The ring of the edge (local vertices i, j of t) when t is the smallest tet around it (each
/// edge is then checked once), walking face neighbours and giving up at the first smaller tet:
/// ring vertices with the tets (a, b, r_k, r_k+1) positive, and whether the ring closes.
fn owned_ring(m: &TetMesh, t: TetId, i: usize, j: usize) -> Option<(SmallVec<[TVertexId; 12]>, bool)> {
    let tx = m.tet(t);
    let (a, b) = (tx.v[i], tx.v[j]);
    let e = super::EDGE_VERTICES.iter().position(|&x| x == [i, j]).expect("edge table");
    let [k, l] = super::EDGE_OPPOSITE[e];
    let mut ring: SmallVec<[TVertexId; 12]> = SmallVec::new();
    let (x0, y0) = (tx.v[k], tx.v[l]);
    ring.push(x0);
    ring.push(y0);
    // Forward: from (a, b, x, y) across the face opposite x to (a, b, y, z).
    let (mut cur, mut x, mut y) = (t, x0, y0);
    let limit = m.num_tets();
    loop {
        let cx = m.tet(cur);
        let ix = cx.v.iter().position(|&w| w == x).expect("ring walk");
        match cx.adj[ix] {
            None => break,
            Some((u, _)) if u == t => {
                ring.pop();
                return Some((ring, true));
            }
            Some((u, _)) if u < t => return None,
            Some((u, _)) => {
                let z = m.tet(u).v.iter().copied().find(|&w| w != a && w != b && w != y).expect("ring walk");
                cur = u;
                x = y;
                y = z;
                ring.push(z);
            }
        }
        if ring.len() > limit + 2 {
            return None;
        }
    }
    // Open: backward from t across the face opposite y of (a, b, x, y) to (a, b, w, x).
    let mut back: SmallVec<[TVertexId; 12]> = SmallVec::new();
    let (mut cur, mut x, mut y) = (t, x0, y0);
    loop {
        let cx = m.tet(cur);
        let iy = cx.v.iter().position(|&w| w == y).expect("ring walk");
        match cx.adj[iy] {
            None => break,
            Some((u, _)) if u < t => return None,
            Some((u, _)) => {
                let w = m.tet(u).v.iter().copied().find(|&w| w != a && w != b && w != x).expect("ring walk");
                cur = u;
                y = x;
                x = w;
                back.push(w);
            }
        }
        if back.len() > limit {
            return None;
        }
    }
    back.reverse();
    back.extend(ring);
    Some((back, false))
}

/// Whether the ring of the edge (a, b) turns once around it (closed) or less than once (open,
/// the ring of a boundary edge): every tet (a, b, r_k, r_k+1) positive, and the ring crossing
/// the half-plane of (a, b, r_0) once, or never when open (exact orient3d).
pub(crate) fn ring_winds_once(
    a: DVec3,
    b: DVec3,
    closed: bool,
    ring: impl ExactSizeIterator<Item = DVec3> + Clone,
) -> bool {
    let n = ring.len();
    let mut pts = ring.clone();
    let Some(r0) = pts.next() else { return true };
    let upper = |p: DVec3| match orient3d(a, b, r0, p) {
        Sign::Positive => true,
        Sign::Negative => false,
        Sign::Zero => same_side_in_plane(a, b, r0, p),
    };
    let steps = if closed { n } else { n - 1 };
    let mut crossings = 0u32;
    let mut up = true;
    let mut x = r0;
    let mut next = ring.cycle().skip(1);
    for _ in 0..steps {
        let y = next.next().expect("cycle");
        // Every step turns the same way (the tet (a, b, x, y) is positive).
        if orient3d(a, b, x, y) != Sign::Positive {
            return false;
        }
        let uy = upper(y);
        if !up && uy {
            crossings += 1;
        }
        up = uy;
        x = y;
    }
    if closed {
        crossings == 1
    } else {
        crossings == 0
    }
}

/// Every edge whose ring winds other than once (see [`ring_winds_once`]), as (tet, local
/// vertices), each once, in tet order: what a repair must take apart.
pub(crate) fn folded_edges(m: &TetMesh) -> Vec<(TetId, usize, usize)> {
    let tets: Vec<_> = m.tet_ids().collect();
    tets.par_iter()
        .with_min_len(1024)
        .flat_map_iter(|&t| {
            let tx = m.tet(t);
            super::EDGE_VERTICES.iter().filter_map(move |&[i, j]| {
                let (ring, closed) = owned_ring(m, t, i, j)?;
                (!ring_winds_once(m.pos(tx.v[i]), m.pos(tx.v[j]), closed, ring.iter().map(|&w| m.pos(w))))
                    .then_some((t, i, j))
            })
        })
        .collect()
}

/// Checks the tetrahedral embedding of a mesh whose tets are all positive (see the module
/// notes): the winding of every edge ring, then the boundary surface.
pub(crate) fn tetrahedral(m: &TetMesh) -> Result<(), InvariantViolation> {
    let tets: Vec<_> = m.tet_ids().collect();
    let bad = tets.par_iter().with_min_len(1024).find_map_first(|&t| {
        let tx = m.tet(t);
        for [i, j] in super::EDGE_VERTICES {
            let Some((ring, closed)) = owned_ring(m, t, i, j) else { continue };
            if !ring_winds_once(m.pos(tx.v[i]), m.pos(tx.v[j]), closed, ring.iter().map(|&w| m.pos(w))) {
                return Some(violation(Invariant::FoldedEdge, t));
            }
        }
        None
    });
    if let Some(e) = bad {
        return Err(e);
    }
    let faces = m.boundary_faces();
    let mut index = slotmap::SecondaryMap::new();
    let mut points = Vec::new();
    let tris: Vec<[usize; 3]> = faces
        .iter()
        .map(|&(t, i)| {
            m.face_vertices(t, i).map(|v| {
                *index.entry(v).unwrap().or_insert_with(|| {
                    points.push(m.pos(v));
                    points.len() - 1
                })
            })
        })
        .collect();
    match soup_intersection(&points, &tris) {
        Some((i, _)) => Err(violation(Invariant::SelfIntersection, faces[i].0)),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::super::Level;
    use super::*;
    use crate::testing::{grid, tet_grid};
    use std::f64::consts::TAU;

    #[track_caller]
    fn broken(r: Result<(), InvariantViolation>) -> Invariant {
        r.expect_err("the fold must be detected").invariant
    }

    /// Two separate triangles: moving a corner of one into the other keeps every fan and its
    /// own loop clear (the relocation allows it), but lays the pieces over each other. The
    /// boundary test against the other piece refuses it; a connected mesh needs no list.
    #[test]
    fn a_piece_moved_over_another_is_caught() {
        let p = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(3.0, 0.0),
            DVec2::new(2.0, 1.0),
        ];
        let (mut m, ids) = TriMesh::from_arrays(&p, &[[0, 1, 2], [3, 4, 5]]).unwrap();
        let walls = boundary_edges_if_split(&m);
        assert_eq!(walls.len(), 6);
        let over = DVec2::new(2.5, 0.2);
        assert!(m.check_relocate(ids[1], over).is_ok(), "the relocation sees only its own loop");
        m.set_pos_unchecked(ids[1], over);
        assert!(!boundary_clear(&m, ids[1], &walls));
        assert!(m.validate(Level::Geometry).is_err());
        m.set_pos_unchecked(ids[1], DVec2::new(1.2, 0.1));
        assert!(boundary_clear(&m, ids[1], &walls));
        assert!(m.validate(Level::Geometry).is_ok());
        let (one, _) = TriMesh::from_arrays(&p[..4], &[[0, 1, 2], [1, 3, 2]]).unwrap();
        assert!(boundary_edges_if_split(&one).is_empty());
    }

    /// A vertex at the origin with a ring of 7 vertices that goes around it twice: each
    /// triangle turns by 4 pi / 7 < pi, so all 7 are positive, yet the angles sum to 4 pi.
    #[test]
    fn planar_fold_is_detected() {
        let mut p = vec![DVec2::ZERO];
        let mut t = Vec::new();
        for k in 0..7 {
            let a = 2.0 * TAU * k as f64 / 7.0;
            p.push(DVec2::new(a.cos(), a.sin()));
            t.push([0, 1 + k, 1 + (k + 1) % 7]);
        }
        let (m, _) = TriMesh::from_arrays(&p, &t).unwrap();
        assert!(m.face_ids().all(|f| m.face_orientation(f) == Sign::Positive));
        assert_eq!(broken(m.validate(Level::Geometry)), Invariant::FoldedVertex);

        // A boundary fan that turns by 400 degrees (five positive sectors of 80 degrees).
        let mut p = vec![DVec2::ZERO];
        let mut t = Vec::new();
        for k in 0..6 {
            let a = (80.0 * k as f64).to_radians();
            let r = 1.0 + 0.1 * k as f64;
            p.push(DVec2::new(r * a.cos(), r * a.sin()));
            if k > 0 {
                t.push([0, k, k + 1]);
            }
        }
        let (m, _) = TriMesh::from_arrays(&p, &t).unwrap();
        assert!(m.face_ids().all(|f| m.face_orientation(f) == Sign::Positive));
        assert_eq!(broken(m.validate(Level::Geometry)), Invariant::FoldedVertex);
        // The same fan stopped at 320 degrees is an embedding.
        let (m, _) = TriMesh::from_arrays(&p[..5], &t[..3]).unwrap();
        m.validate(Level::Geometry).unwrap();

        // Two squares whose boundaries cross, every vertex fine on its own.
        let sq = |x: f64, y: f64| {
            [DVec2::new(x, y), DVec2::new(x + 1.0, y), DVec2::new(x + 1.0, y + 1.0), DVec2::new(x, y + 1.0)]
        };
        let p: Vec<DVec2> = sq(0.0, 0.0).into_iter().chain(sq(0.5, 0.5)).collect();
        let (m, _) = TriMesh::from_arrays(&p, &[[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]).unwrap();
        assert_eq!(broken(m.validate(Level::Geometry)), Invariant::BoundaryCrossing);

        // Good meshes pass: a jittered grid.
        grid(20, 20, 0.3, 7).validate(Level::Geometry).unwrap();
    }

    /// An edge along z whose ring of 7 vertices goes around it twice: 7 positive tets whose
    /// dihedral angles at the edge sum to 4 pi.
    #[test]
    fn tetrahedral_fold_is_detected() {
        let mut p = vec![DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, 1.0)];
        let mut t = Vec::new();
        for k in 0..7 {
            let a = 2.0 * TAU * k as f64 / 7.0;
            p.push(DVec3::new(a.cos(), a.sin(), 0.0));
            t.push([0, 1, 2 + k, 2 + (k + 1) % 7]);
        }
        for c in &t {
            let [a, b, x, y] = c.map(|i| p[i]);
            assert_eq!(orient3d(a, b, x, y), Sign::Positive);
        }
        let (m, _) = TetMesh::from_arrays(&p, &t).unwrap();
        assert!(m.validate(Level::Topology).is_ok());
        assert!(m.tet_ids().all(|t| m.tet_orientation(t) == Sign::Positive));
        assert_eq!(broken(m.validate(Level::Geometry)), Invariant::FoldedEdge);

        // Two cubes of tets overlapping: every edge fine, the boundary crosses itself.
        let a = tet_grid(2);
        a.validate(Level::Geometry).unwrap();
        let arr = a.to_arrays();
        let n = arr.points.len();
        let mut pts = arr.points.clone();
        pts.extend(arr.points.iter().map(|&q| q + DVec3::splat(0.3)));
        let mut cells = arr.cells.clone();
        cells.extend(arr.cells.iter().map(|c| c.map(|i| i + n)));
        let (m, _) = TetMesh::from_arrays(&pts, &cells).unwrap();
        assert_eq!(broken(m.validate(Level::Geometry)), Invariant::SelfIntersection);
    }

    fn octahedron(shift: DVec3) -> (Vec<DVec3>, Vec<[usize; 3]>) {
        let p = vec![DVec3::X, DVec3::Y, DVec3::NEG_X, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z];
        let t = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [1, 0, 5], [2, 1, 5], [3, 2, 5], [0, 3, 5]];
        (p.into_iter().map(|q| q + shift).collect(), t)
    }

    #[test]
    fn surface_self_intersection_and_openness_are_detected() {
        let (p, t) = octahedron(DVec3::ZERO);
        let (m, _) = TriMesh::from_arrays(&p, &t).unwrap();
        m.validate_closed_surface().unwrap();
        // Two octahedra through each other: each closed and manifold, together intersecting.
        let (q, u) = octahedron(DVec3::new(0.5, 0.2, 0.1));
        let mut pts = p.clone();
        pts.extend(q);
        let mut tris = t.clone();
        tris.extend(u.iter().map(|c| c.map(|i| i + 6)));
        let (m, _) = TriMesh::from_arrays(&pts, &tris).unwrap();
        assert_eq!(broken(m.validate(Level::Geometry)), Invariant::SelfIntersection);
        // Apart, or touching nowhere, they pass.
        let (q, u) = octahedron(DVec3::new(2.5, 0.0, 0.0));
        let mut pts = p.clone();
        pts.extend(q);
        let (m, _) = TriMesh::from_arrays(&pts, &tris).unwrap();
        m.validate_closed_surface().unwrap();
        let _ = u;
        // One octahedron with its top apex pulled down through the equator and out of the
        // bottom half beside it: the edge from (-1, 0, 0) runs inside the bottom pyramid
        // and leaves it through a bottom face.
        let mut p2 = p.clone();
        p2[4] = DVec3::new(0.9, 0.0, -0.5);
        let (m, _) = TriMesh::from_arrays(&p2, &t).unwrap();
        let r = m.validate(Level::Geometry);
        assert_eq!(broken(r), Invariant::SelfIntersection);
        // A face removed: manifold, not closed.
        let (m, _) = TriMesh::from_arrays(&p, &t[1..]).unwrap();
        m.validate(Level::Geometry).unwrap();
        assert_eq!(broken(m.validate_closed_surface()), Invariant::OpenSurface);
        // Non-manifold: a third face on an edge is refused when the mesh is built.
        let mut t3 = t.clone();
        t3.push([0, 1, 2]);
        assert!(TriMesh::from_arrays(&p, &t3).is_err());
    }

    /// The local surface test: a star moved through the faces beside it is caught, a star
    /// moved back is clear.
    #[test]
    fn local_surface_crossings_are_caught() {
        let (p, t) = octahedron(DVec3::ZERO);
        let (mut m, ids) = TriMesh::from_arrays(&p, &t).unwrap();
        assert!(!surface_star_meets(&m, ids[4]));
        // The top apex pulled down through the bottom half (see the test above).
        m.set_pos_unchecked(ids[4], DVec3::new(0.9, 0.0, -0.5));
        assert!(surface_star_meets(&m, ids[4]));
        // Pulled down only to the equator's plane, flat but crossing nothing.
        m.set_pos_unchecked(ids[4], DVec3::new(0.0, 0.0, 0.0));
        assert!(!surface_star_meets(&m, ids[4]));
    }
}
