//! The last phase of the 2-D local mesher, after force equilibrium. The truss equalises bar
//! lengths, not shapes: near valence defects, corners and along the boundary its equilibrium
//! leaves shape quality on the table, and a topology reached by the density control may be
//! a poor one (the unit circle at h0 = 0.4 settles with 15 boundary nodes where 12 give q mean
//! 0.97). Two steps, each keeping a change only when its merit rises, the size deviation (seed
//! section 2.7's measure) stays at most what the equilibrium left and the minimum quality does
//! not fall (earlier polishes that ignored size traded it for size deviation):
//! - [`search`]: local topological changes (collapse, split, flip) on the edges of poor
//!   triangles, each followed by a short re-equilibration of the truss around it and a few
//!   polish sweeps there, so that a change is judged by the mesh the polish makes of it;
//! - [`polish`]: interior nodes, and boundary nodes along the boundary, take gradient steps one
//!   at a time on a merit of shape and size (see [`SIZE_PULL`]).

use super::improve::*;
use crate::topology::{FaceId, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec2;
use rayon::prelude::*;
use slotmap::{SecondaryMap, SparseSecondaryMap};

/// Faces per piece of the polish's parallel passes over the whole mesh.
const PAR_FACES: usize = 4096;

/// Sweeps over the interior nodes at most.
pub(super) const SWEEPS: usize = 30;
/// Meshes with more triangles are polished only around their worst triangles (see
/// [`WORST_QUEUE`]): they are mostly the near-equilateral lattice interior, where whole sweeps
/// cost more than the force loop and gain nothing.
pub(super) const POLISH_MAX_FACES: usize = 20_000;
/// Above POLISH_MAX_FACES, the polish moves the nodes of at most this many of the worst
/// triangles (those below WORST_Q) and their neighbours: the work is bounded by the queue,
/// not by the mesh size, and the worst triangles get the same treatment at every size.
pub(super) const WORST_QUEUE: usize = 4096;
/// Triangles below this quality enter the worst-triangle queue of large meshes.
pub(super) const WORST_Q: f64 = 0.9;
/// A node that gains less merit than this in a try rests until a neighbour gains more.
pub(super) const MOVE_GAIN: f64 = 1e-5;
/// A sweep that gains less than this in summed quality per node ends the polish.
pub(super) const SWEEP_GAIN: f64 = 1e-7;

/// A value per face: indexed by the face's slot for a whole mesh or a small one; hashed for a
/// few faces of a large mesh, where a slot-indexed map would be laid out (and its memory
/// touched) up to the largest face index at every measure of the polish.
pub(super) enum FaceValues {
    Dense(SecondaryMap<FaceId, f64>),
    Sparse(SparseSecondaryMap<FaceId, f64>),
}

impl FaceValues {
    fn for_faces(m: &TriMesh<DVec2>, few: bool) -> FaceValues {
        if few && m.num_faces() > POLISH_MAX_FACES {
            FaceValues::Sparse(SparseSecondaryMap::new())
        } else {
            FaceValues::Dense(SecondaryMap::new())
        }
    }
    fn insert(&mut self, f: FaceId, x: f64) {
        match self {
            FaceValues::Dense(d) => d.insert(f, x),
            FaceValues::Sparse(s) => s.insert(f, x),
        };
    }
    fn contains_key(&self, f: FaceId) -> bool {
        match self {
            FaceValues::Dense(d) => d.contains_key(f),
            FaceValues::Sparse(s) => s.contains_key(f),
        }
    }
    /// The smallest value.
    pub(super) fn min(&self) -> f64 {
        match self {
            FaceValues::Dense(d) => d.values().copied().fold(f64::INFINITY, f64::min),
            FaceValues::Sparse(s) => s.values().copied().fold(f64::INFINITY, f64::min),
        }
    }
}

impl std::ops::Index<FaceId> for FaceValues {
    type Output = f64;
    fn index(&self, f: FaceId) -> &f64 {
        match self {
            FaceValues::Dense(d) => &d[f],
            FaceValues::Sparse(s) => &s[f],
        }
    }
}

impl std::ops::IndexMut<FaceId> for FaceValues {
    fn index_mut(&mut self, f: FaceId) -> &mut f64 {
        match self {
            FaceValues::Dense(d) => &mut d[f],
            FaceValues::Sparse(s) => &mut s[f],
        }
    }
}

/// Quality and relative circumradius of each triangle, and their sums.
pub(super) struct Stats {
    pub(super) q: FaceValues,
    pub(super) s: FaceValues,
    pub(super) sq: f64,
    pub(super) s1: f64,
    pub(super) s2: f64,
    pub(super) n: f64,
}

impl Stats {
    pub(super) fn of(m: &TriMesh<DVec2>, h: &dyn Fn(DVec2) -> Result<f64, Error>) -> Result<Stats, Error> {
        let mut st = Stats {
            q: FaceValues::for_faces(m, false),
            s: FaceValues::for_faces(m, false),
            sq: 0.0,
            s1: 0.0,
            s2: 0.0,
            n: m.num_faces() as f64,
        };
        for f in m.face_ids() {
            let t = m.face_points(f);
            let (q, s) = (crate::quality::triangle_q(t), rel_radius(t, h)?);
            st.q.insert(f, q);
            st.s.insert(f, s);
            st.sq += q;
            st.s1 += s;
            st.s2 += s * s;
        }
        Ok(st)
    }
    /// Quality and relative circumradius of the triangles at `verts` only, with the sums of
    /// the whole mesh given (a trial of the search polishes a few nodes of a large mesh).
    pub(super) fn around(
        m: &TriMesh<DVec2>,
        verts: &[VertexId],
        h: &dyn Fn(DVec2) -> Result<f64, Error>,
        whole: &Sums,
    ) -> Result<Stats, Error> {
        let mut st = Stats {
            q: FaceValues::for_faces(m, true),
            s: FaceValues::for_faces(m, true),
            sq: whole.sq,
            s1: whole.s1,
            s2: whole.s2,
            n: whole.n,
        };
        for &v in verts {
            for f in m.vertex_faces(v) {
                if !st.q.contains_key(f) {
                    let t = m.face_points(f);
                    st.q.insert(f, crate::quality::triangle_q(t));
                    st.s.insert(f, rel_radius(t, h)?);
                }
            }
        }
        Ok(st)
    }
    /// std / mean of the relative circumradii with the sums changed by (d1, d2).
    pub(super) fn dev_with(&self, d1: f64, d2: f64) -> f64 {
        let mean = (self.s1 + d1) / self.n;
        let var = ((self.s2 + d2) / self.n - mean * mean).max(0.0);
        var.sqrt() / mean
    }
}

/// Circumradius over the local size at the centroid (the size deviation's sample).
pub(super) fn rel_radius(t: [DVec2; 3], h: &dyn Fn(DVec2) -> Result<f64, Error>) -> Result<f64, Error> {
    let r = crate::quality::circumradius_from_lengths(t[1].distance(t[2]), t[2].distance(t[0]), t[0].distance(t[1]));
    Ok(r / h((t[0] + t[1] + t[2]) / 3.0)?)
}

/// Weight of the size term in the polish's merit, per triangle q - SIZE_PULL (rho / rho_mean -
/// 1)^2 (rho the relative circumradius): shape is not bought with size deviation.
pub(super) const SIZE_PULL: f64 = 4.0;
/// The first step of a node, as a fraction of the mean length of its edges, before it has a
/// step of its own (each node starts from twice its last accepted step).
pub(super) const FIRST_STEP: f64 = 0.05;
/// Steps tried per node and sweep, each half the one before.
pub(super) const HALVINGS: usize = 6;

/// Polishes the free nodes of `m` in place (see the module notes): interior nodes, and boundary
/// nodes sliding along the boundary. Returns the number of sweeps made.
pub(super) fn polish(m: &mut TriMesh<DVec2>, g: &Geometry) -> Result<usize, Error> {
    if m.num_faces() > POLISH_MAX_FACES {
        return polish_worst(m, g);
    }
    let verts: Vec<VertexId> = m.vertex_ids().filter(|&v| movable(m, v)).collect();
    polish_nodes(m, g, &verts, SWEEPS, None)
}

/// The polish of a large mesh: the nodes of the worst triangles (at most WORST_QUEUE of them,
/// below WORST_Q, worst first) and their neighbours, measured on the triangles there with the
/// sums of the whole mesh. Returns the number of sweeps made.
pub(super) fn polish_worst(m: &mut TriMesh<DVec2>, g: &Geometry) -> Result<usize, Error> {
    // Each face measured in parallel, the results taken in face order (the same sums and
    // queue for any thread count).
    let faces: Vec<FaceId> = m.face_ids().collect();
    let mut worst: Vec<(f64, FaceId)> = faces
        .par_iter()
        .with_min_len(PAR_FACES)
        .map(|&f| (m.face_quality(f), f))
        .filter(|&(q, _)| q < WORST_Q)
        .collect();
    // Stable: equal qualities keep the mesh's face order (deterministic).
    worst.sort_by(|x, y| x.0.total_cmp(&y.0));
    worst.truncate(WORST_QUEUE);
    if worst.is_empty() {
        return Ok(0);
    }
    let mut seen: SecondaryMap<VertexId, ()> = SecondaryMap::new();
    let mut verts = Vec::new();
    for &(_, f) in &worst {
        for v in m.face_vertices(f) {
            for w in std::iter::once(v).chain(m.neighbours(v)) {
                if seen.insert(w, ()).is_none() && movable(m, w) {
                    verts.push(w);
                }
            }
        }
    }
    // The sums of the whole mesh in one pass, without per-triangle maps (memory).
    let mut whole = Sums { qmin: f64::INFINITY, ..Sums::default() };
    let terms: Vec<Result<(f64, f64), Error>> = faces
        .par_iter()
        .with_min_len(PAR_FACES)
        .map(|&f| {
            let t = m.face_points(f);
            Ok((crate::quality::triangle_q(t), rel_radius(t, g.h)?))
        })
        .collect();
    for term in terms {
        let (q, r) = term?;
        whole.n += 1.0;
        whole.sq += q;
        whole.s1 += r;
        whole.s2 += r * r;
        whole.qmin = whole.qmin.min(q);
    }
    polish_nodes(m, g, &verts, SWEEPS, Some(&whole))
}

/// Whether the polish moves `v`: an interior node, or a boundary node (along the boundary).
pub(super) fn movable(m: &TriMesh<DVec2>, v: VertexId) -> bool {
    match m.tag(v) {
        VertexTag::Interior => !m.is_boundary_vertex(v),
        VertexTag::Boundary => m.is_boundary_vertex(v),
        _ => false,
    }
}

/// At most `sweeps` sweeps of [`move_node`] over `verts`; returns the number made. With the
/// sums of the whole mesh in `whole`, only the triangles at `verts` are measured and the size
/// deviation is not bounded (the search bounds it on the whole trial).
pub(super) fn polish_nodes(
    m: &mut TriMesh<DVec2>,
    g: &Geometry,
    verts: &[VertexId],
    sweeps: usize,
    whole: Option<&Sums>,
) -> Result<usize, Error> {
    let measure = |m: &TriMesh<DVec2>, st: Option<&Stats>| match whole {
        None => Stats::of(m, g.h),
        Some(w) => {
            let sums = st.map_or(*w, |s| Sums { n: s.n, sq: s.sq, s1: s.s1, s2: s.s2, qmin: w.qmin });
            Stats::around(m, verts, g.h, &sums)
        }
    };
    let mut st = measure(m, None)?;
    if st.n == 0.0 {
        return Ok(0);
    }
    let budget = if whole.is_some() { f64::INFINITY } else { st.dev_with(0.0, 0.0) };
    let q_floor = whole.map_or_else(|| st.q.min(), |w| w.qmin);
    let mut steps: SecondaryMap<VertexId, f64> = SecondaryMap::new();
    let walls = super::improve::walls(m, g);
    // Nodes whose last try failed or gained less than MOVE_GAIN, and whose neighbours have not
    // gained more since: a new try would do about as little.
    let mut idle: SecondaryMap<VertexId, ()> = SecondaryMap::new();
    let mut kept = 0;
    for _ in 0..sweeps {
        let mut gain = 0.0;
        for &v in verts {
            if idle.contains_key(v) {
                continue;
            }
            let d = move_node(m, &mut st, v, (budget, q_floor), g, (&mut steps, &walls))?;
            gain += d;
            if d > MOVE_GAIN {
                for w in m.neighbours(v) {
                    idle.remove(w);
                }
            } else {
                idle.insert(v, ());
            }
        }
        kept += 1;
        if gain < SWEEP_GAIN * verts.len() as f64 {
            break;
        }
        // Fresh sums: the running updates drift.
        st = measure(m, Some(&st))?;
    }
    Ok(kept)
}

/// The merit of one triangle (see [`SIZE_PULL`]): `rho` its relative circumradius.
pub(super) fn merit(q: f64, rho: f64, rho_mean: f64) -> f64 {
    let e = rho / rho_mean - 1.0;
    q - SIZE_PULL * e * e
}

/// The merit of `v`'s star with `v` at `x`, the sizes held at `hs` (one per face).
pub(super) fn star_merit(
    m: &mut TriMesh<DVec2>,
    v: VertexId,
    x: DVec2,
    faces: &[FaceId],
    hs: &[f64],
    rho_mean: f64,
) -> f64 {
    let old = m.pos(v);
    m.set_pos_unchecked(v, x);
    let mut sum = 0.0;
    for (&f, &h) in faces.iter().zip(hs) {
        let t = m.face_points(f);
        let (a, b, c) = (t[1].distance(t[2]), t[2].distance(t[0]), t[0].distance(t[1]));
        let q = crate::quality::triangle_q_from_lengths(a, b, c);
        sum += merit(q, crate::quality::circumradius_from_lengths(a, b, c) / h, rho_mean);
    }
    m.set_pos_unchecked(v, old);
    sum
}

/// One gradient step of `v` on its star's merit: the gradient by central differences with the
/// sizes held where they are (a step moves a node a fraction of an edge), steps halving from
/// twice the node's last one; a boundary node moves along the chord of its two boundary
/// neighbours and is projected back. A step is kept when the merit with the true sizes rises,
/// no triangle of the star falls below the smallest quality of the star or the mesh and the
/// size deviation stays within `budget`; a boundary node's new edges must clear `walls` (see
/// [`relocate_clear`]). Returns the gain in summed merit.
pub(super) fn move_node(
    m: &mut TriMesh<DVec2>,
    st: &mut Stats,
    v: VertexId,
    (budget, q_floor): (f64, f64),
    g: &Geometry,
    (steps, walls): (&mut SecondaryMap<VertexId, f64>, &[[VertexId; 2]]),
) -> Result<f64, Error> {
    let faces = m.vertex_faces(v);
    let old = m.pos(v);
    let rho_mean = st.s1 / st.n;
    let hs: smallvec::SmallVec<[f64; 8]> = faces
        .iter()
        .map(|&f| {
            let t = m.face_points(f);
            crate::quality::circumradius_from_lengths(t[1].distance(t[2]), t[2].distance(t[0]), t[0].distance(t[1]))
                / st.s[f]
        })
        .collect();
    if hs.iter().any(|h| !h.is_finite() || *h <= 0.0) {
        return Ok(0.0);
    }
    let nbrs = m.neighbours(v);
    let len = nbrs.iter().map(|&w| m.pos(w).distance(old)).sum::<f64>() / nbrs.len().max(1) as f64;
    let before = faces.iter().map(|&f| merit(st.q[f], st.s[f], rho_mean)).sum::<f64>();
    let e = 1e-7 * len;
    let mut grad = DVec2::ZERO;
    for (k, d) in [DVec2::X, DVec2::Y].into_iter().enumerate() {
        let up = star_merit(m, v, old + d * e, &faces, &hs, rho_mean);
        let down = star_merit(m, v, old - d * e, &faces, &hs, rho_mean);
        grad[k] = (up - down) / (2.0 * e);
    }
    let on_boundary = m.tag(v) == VertexTag::Boundary;
    if on_boundary {
        let ends: smallvec::SmallVec<[DVec2; 2]> =
            m.outgoing(v).into_iter().filter(|&x| m.is_boundary_edge(x)).map(|x| m.pos(m.dest(x))).collect();
        if ends.len() != 2 {
            return Ok(0.0);
        }
        let t = (ends[1] - ends[0]).normalize_or_zero();
        grad = t * grad.dot(t);
    }
    let Some(dir) = grad.try_normalize() else { return Ok(0.0) };
    let old_min = faces.iter().map(|&f| st.q[f]).fold(f64::INFINITY, f64::min);
    let floor = old_min.min(q_floor.max(0.0));
    let mut step = steps.get(v).map_or(FIRST_STEP, |s| 2.0 * s).min(0.25);
    for _ in 0..HALVINGS {
        let try_step = step;
        step *= 0.5;
        let mut x = old + dir * (try_step * len);
        if on_boundary {
            match (g.project)(x)? {
                // A projection that lands far from the step has jumped to another part of the
                // boundary.
                Some(p) if p.distance(old) <= 2.0 * try_step * len => x = p,
                _ => continue,
            }
        }
        if star_merit(m, v, x, &faces, &hs, rho_mean) <= before || !relocate_clear(m, v, x, walls) {
            continue;
        }
        let (mut after, mut d1, mut d2, mut qmin) = (0.0, 0.0, 0.0, f64::INFINITY);
        let mut new: smallvec::SmallVec<[(FaceId, f64, f64); 8]> = smallvec::SmallVec::new();
        for &f in &faces {
            let tp = m.face_points(f);
            let (q, s) = (crate::quality::triangle_q(tp), rel_radius(tp, g.h)?);
            after += merit(q, s, rho_mean);
            d1 += s - st.s[f];
            d2 += s * s - st.s[f] * st.s[f];
            qmin = qmin.min(q);
            new.push((f, q, s));
        }
        if after > before && qmin >= floor && st.dev_with(d1, d2) <= budget {
            for (f, q, s) in new {
                st.sq += q - st.q[f];
                st.q[f] = q;
                st.s[f] = s;
            }
            st.s1 += d1;
            st.s2 += d2;
            steps.insert(v, try_step);
            return Ok(after - before);
        }
        m.set_pos_unchecked(v, old);
    }
    steps.insert(v, step);
    Ok(0.0)
}
