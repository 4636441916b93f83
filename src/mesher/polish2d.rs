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

use crate::topology::{FaceId, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec2;
use slotmap::SecondaryMap;

/// Sweeps over the interior nodes at most.
const SWEEPS: usize = 30;
/// Meshes with more triangles are not polished: they are mostly the lattice interior the
/// truss leaves near equilateral, and the sweeps cost more than the whole force loop (2x10^5
/// triangles: 2.9 s, q mean 0.9993 before and after).
const POLISH_MAX_FACES: usize = 20_000;
/// A node that gains less merit than this in a try rests until a neighbour gains more.
const MOVE_GAIN: f64 = 1e-5;
/// A sweep that gains less than this in summed quality per node ends the polish.
const SWEEP_GAIN: f64 = 1e-7;

/// Quality and relative circumradius of each triangle, and their sums.
struct Stats {
    q: SecondaryMap<FaceId, f64>,
    s: SecondaryMap<FaceId, f64>,
    sq: f64,
    s1: f64,
    s2: f64,
    n: f64,
}

impl Stats {
    fn of(m: &TriMesh<DVec2>, h: &dyn Fn(DVec2) -> Result<f64, Error>) -> Result<Stats, Error> {
        let mut st = Stats {
            q: SecondaryMap::new(),
            s: SecondaryMap::new(),
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
    fn around(
        m: &TriMesh<DVec2>,
        verts: &[VertexId],
        h: &dyn Fn(DVec2) -> Result<f64, Error>,
        whole: &Sums,
    ) -> Result<Stats, Error> {
        let mut st = Stats {
            q: SecondaryMap::new(),
            s: SecondaryMap::new(),
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
    fn dev_with(&self, d1: f64, d2: f64) -> f64 {
        let mean = (self.s1 + d1) / self.n;
        let var = ((self.s2 + d2) / self.n - mean * mean).max(0.0);
        var.sqrt() / mean
    }
}

/// Circumradius over the local size at the centroid (the size deviation's sample).
fn rel_radius(t: [DVec2; 3], h: &dyn Fn(DVec2) -> Result<f64, Error>) -> Result<f64, Error> {
    let r = crate::quality::circumradius_from_lengths(t[1].distance(t[2]), t[2].distance(t[0]), t[0].distance(t[1]));
    Ok(r / h((t[0] + t[1] + t[2]) / 3.0)?)
}

/// Weight of the size term in the polish's merit: per triangle q - SIZE_PULL (rho / rho_mean - 1)^2,
/// rho the relative circumradius. Measured on example 3b (447 triangles), gradient steps alone
/// run to convergence on every interior node and the hole's boundary nodes: 0 gives q mean
/// 0.9753 at size deviation 8.0% (shape bought with size), 3 gives 0.9710 / 4.3%, 5 gives
/// 0.9689 / 3.6% (the size deviation the equilibrium left), 10 gives 0.9658 / 2.9%. With the
/// search in the loop (before the start's fill toward the estimate): 3 gives 0.9723 / 4.4%, 4 gives 0.9723 / 3.7%, 5
/// gives 0.9692 / 3.1%.
const SIZE_PULL: f64 = 4.0;
/// The first step of a node, as a fraction of the mean length of its edges, before it has a
/// step of its own (each node starts from twice its last accepted step).
const FIRST_STEP: f64 = 0.05;
/// Steps tried per node and sweep, each half the one before.
const HALVINGS: usize = 6;

/// Polishes the free nodes of `m` in place (see the module notes): interior nodes, and boundary
/// nodes sliding along the boundary. Returns the number of sweeps made.
pub(crate) fn polish(m: &mut TriMesh<DVec2>, g: &Geometry) -> Result<usize, Error> {
    if m.num_faces() > POLISH_MAX_FACES {
        return Ok(0);
    }
    let verts: Vec<VertexId> = m.vertex_ids().filter(|&v| movable(m, v)).collect();
    polish_nodes(m, g, &verts, SWEEPS, None)
}

/// Whether the polish moves `v`: an interior node, or a boundary node (along the boundary).
fn movable(m: &TriMesh<DVec2>, v: VertexId) -> bool {
    match m.tag(v) {
        VertexTag::Interior => !m.is_boundary_vertex(v),
        VertexTag::Boundary => m.is_boundary_vertex(v),
        _ => false,
    }
}

/// At most `sweeps` sweeps of [`move_node`] over `verts`; returns the number made. With the
/// sums of the whole mesh in `whole`, only the triangles at `verts` are measured and the size
/// deviation is not bounded (the search bounds it on the whole trial).
fn polish_nodes(
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
    let q_floor = whole.map_or_else(|| st.q.values().copied().fold(f64::INFINITY, f64::min), |w| w.qmin);
    let mut steps: SecondaryMap<VertexId, f64> = SecondaryMap::new();
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
            let d = move_node(m, &mut st, v, (budget, q_floor), g, &mut steps)?;
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
fn merit(q: f64, rho: f64, rho_mean: f64) -> f64 {
    let e = rho / rho_mean - 1.0;
    q - SIZE_PULL * e * e
}

/// The merit of `v`'s star with `v` at `x`, the sizes held at `hs` (one per face).
fn star_merit(m: &mut TriMesh<DVec2>, v: VertexId, x: DVec2, faces: &[FaceId], hs: &[f64], rho_mean: f64) -> f64 {
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
/// size deviation stays within `budget`. Returns the gain in summed merit.
fn move_node(
    m: &mut TriMesh<DVec2>,
    st: &mut Stats,
    v: VertexId,
    (budget, q_floor): (f64, f64),
    g: &Geometry,
    steps: &mut SecondaryMap<VertexId, f64>,
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
        if star_merit(m, v, x, &faces, &hs, rho_mean) <= before || m.relocate(v, x).is_err() {
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

// ============================ local topological search ============================

/// What the topological search needs of the geometry: the relative size, the projection onto
/// the boundary, and the truss's force law (seed eq. 2.6 with these Fscale and time step).
pub(crate) struct Geometry<'a> {
    pub h: &'a dyn Fn(DVec2) -> Result<f64, Error>,
    pub project: &'a dyn Fn(DVec2) -> Result<Option<DVec2>, Error>,
    pub fscale: f64,
    pub dt: f64,
}

/// Triangles below this quality have their edges tried by the search.
const Q_TRY: f64 = 0.95;
/// Rings of nodes around a change that the re-equilibration moves.
const RELAX_RINGS: usize = 3;
/// Force iterations of the re-equilibration at most.
const RELAX_ITERS: usize = 40;
/// The re-equilibration stops once no node moves more than this many rest lengths in a step.
const RELAX_TOL: f64 = 1e-3;
/// The search ranks states by q mean - SIZE_WEIGHT * size deviation: a change may give up a
/// little mean quality for twice as much less size deviation. Measured against 0 (mean quality
/// alone) on the seed's 2-D examples: size deviation ex8 2.7% -> 2.3%, ex5 3.0 -> 2.8, ex3b
/// 4.3 -> 4.1; q mean ex5 0.9717 -> 0.9746, ex8 0.9806 -> 0.9823, ex3a 0.9810 -> 0.9750, ex3b
/// 0.9663 -> 0.9628. With 1: ex3a 0.9730, ex3b 0.9617 / 3.8%.
const SIZE_WEIGHT: f64 = 0.5;
/// Meshes with more triangles are not searched: every trial copies and measures the whole
/// mesh, so the search grows faster than the mesh (9 865 triangles: 0.8 s, six times the
/// force loop), and on fine meshes the poor triangles along the boundary weigh little in the
/// mean.
const SEARCH_MAX_FACES: usize = 5_000;
/// Polish sweeps over the relaxed nodes of a trial: a change is judged by the mesh the polish
/// would make of it.
const TRIAL_SWEEPS: usize = 2;
/// Rounds of the search (each tries every candidate once).
const SEARCH_ROUNDS: usize = 8;

/// Sums over some triangles: count, quality, relative circumradius and its square, and the
/// smallest quality.
#[derive(Clone, Copy, Default)]
struct Sums {
    n: f64,
    sq: f64,
    s1: f64,
    s2: f64,
    qmin: f64,
}

impl Sums {
    /// Over the triangles with a corner in `verts` (each once).
    fn around(m: &TriMesh<DVec2>, verts: &[VertexId], h: &dyn Fn(DVec2) -> Result<f64, Error>) -> Result<Sums, Error> {
        let mut seen: SecondaryMap<FaceId, ()> = SecondaryMap::new();
        let mut out = Sums { qmin: f64::INFINITY, ..Sums::default() };
        for &v in verts {
            if !m.contains_vertex(v) {
                continue;
            }
            for f in m.vertex_faces(v) {
                if seen.insert(f, ()).is_none() {
                    let t = m.face_points(f);
                    let (q, r) = (crate::quality::triangle_q(t), rel_radius(t, h)?);
                    out.n += 1.0;
                    out.sq += q;
                    out.s1 += r;
                    out.s2 += r * r;
                    out.qmin = out.qmin.min(q);
                }
            }
        }
        Ok(out)
    }
    /// Over the whole mesh.
    fn of(m: &TriMesh<DVec2>, h: &dyn Fn(DVec2) -> Result<f64, Error>) -> Result<Sums, Error> {
        let st = Stats::of(m, h)?;
        let qmin = st.q.values().copied().fold(f64::INFINITY, f64::min);
        Ok(Sums { n: st.n, sq: st.sq, s1: st.s1, s2: st.s2, qmin })
    }
    fn q_mean(&self) -> f64 {
        self.sq / self.n
    }
    fn dev(&self) -> f64 {
        let mean = self.s1 / self.n;
        ((self.s2 / self.n - mean * mean).max(0.0)).sqrt() / mean
    }
    /// These sums with the triangles of `old` replaced by those of `new`.
    fn replace(&self, old: &Sums, new: &Sums) -> Sums {
        Sums {
            n: self.n - old.n + new.n,
            sq: self.sq - old.sq + new.sq,
            s1: self.s1 - old.s1 + new.s1,
            s2: self.s2 - old.s2 + new.s2,
            qmin: new.qmin,
        }
    }
}

/// Local changes (collapse, split, flip of the edges of poor triangles), each followed by a
/// short re-equilibration of the truss around it, kept only when q mean - SIZE_WEIGHT * size
/// deviation rises while the size deviation stays at most what it was and the minimum quality
/// does not fall; the mean quality at the end is at least what it was.
/// A trial is measured on the triangles near it (those farther away are untouched); the
/// result is measured whole, and the search undone if it broke a condition after all.
/// Returns the number of changes kept.
pub(crate) fn search(m: &mut TriMesh<DVec2>, g: &Geometry) -> Result<usize, Error> {
    if m.num_faces() > SEARCH_MAX_FACES || m.num_faces() == 0 {
        return Ok(0);
    }
    let start = Sums::of(m, g.h)?;
    let (budget, floor) = (start.dev(), start.qmin);
    let original = m.clone();
    let mut kept = 0;
    // Vertices near a kept change: later rounds try only edges there (None: every edge).
    let mut dirty: Option<SecondaryMap<VertexId, ()>> = None;
    for _ in 0..SEARCH_ROUNDS {
        let scale = bar_scale(m, g)?;
        let mut cur = Sums::of(m, g.h)?;
        let mut round = 0;
        let edges = candidate_edges(m, dirty.as_ref());
        let mut touched: SecondaryMap<VertexId, ()> = SecondaryMap::new();
        for (a, b) in edges {
            // The best of the three changes of this edge that passes.
            let mut best: Option<(Sums, TriMesh<DVec2>, Vec<VertexId>)> = None;
            for op in [Op::Collapse, Op::Split, Op::Flip] {
                let Some(x) = (if m.contains_vertex(a) { m.find_half_edge(a, b) } else { None }) else { break };
                let region = rings_around(m, &[a, b], RELAX_RINGS + 3);
                let before = Sums::around(m, &region, g.h)?;
                let mut trial = m.clone();
                let Some(seeds) = apply(&mut trial, g, x, op)? else { continue };
                relax(&mut trial, g, &seeds, scale)?;
                let mut near: Vec<VertexId> = region.iter().copied().filter(|&v| trial.contains_vertex(v)).collect();
                near.extend(seeds.iter().copied().filter(|&v| trial.contains_vertex(v)));
                let free: Vec<VertexId> =
                    rings_around(&trial, &seeds, RELAX_RINGS).into_iter().filter(|&v| movable(&trial, v)).collect();
                polish_nodes(&mut trial, g, &free, TRIAL_SWEEPS, Some(&cur))?;
                let after = Sums::around(&trial, &near, g.h)?;
                // Triangles outside the region must be the same in number, or the measure is whole.
                let next = if m.num_faces() as f64 - before.n == trial.num_faces() as f64 - after.n {
                    cur.replace(&before, &after)
                } else {
                    Sums::of(&trial, g.h)?
                };
                let merit = |x: &Sums| x.q_mean() - SIZE_WEIGHT * x.dev();
                let bar = best.as_ref().map_or(merit(&cur) + 1e-7, |b| merit(&b.0));
                if merit(&next) > bar && next.dev() <= budget && next.qmin >= floor {
                    best = Some((next, trial, near));
                }
            }
            if let Some((next, trial, near)) = best {
                *m = trial;
                cur = next;
                round += 1;
                for v in near {
                    touched.insert(v, ());
                }
            }
        }
        kept += round;
        if round == 0 {
            break;
        }
        dirty = Some(touched);
    }
    let end = Sums::of(m, g.h)?;
    if end.q_mean() < start.q_mean() || end.dev() > budget || end.qmin < floor {
        *m = original;
        return Ok(0);
    }
    Ok(kept)
}

/// The edges of triangles below Q_TRY, worst triangle first, and only those with an end in
/// `dirty` when given.
fn candidate_edges(m: &TriMesh<DVec2>, dirty: Option<&SecondaryMap<VertexId, ()>>) -> Vec<(VertexId, VertexId)> {
    let mut edges: Vec<(f64, VertexId, VertexId)> = Vec::new();
    for f in m.face_ids() {
        let q = m.face_quality(f);
        if q < Q_TRY {
            for x in m.face_half_edges(f) {
                let (a, b) = (m.origin(x), m.dest(x));
                if dirty.map_or(true, |d| d.contains_key(a) || d.contains_key(b)) {
                    edges.push((q, a, b));
                }
            }
        }
    }
    // Stable sort: equal qualities keep the mesh's face order (deterministic). An edge of two
    // poor triangles comes twice: the first try may have changed its neighbourhood.
    edges.sort_by(|x, y| x.0.total_cmp(&y.0));
    edges.into_iter().map(|(_, a, b)| (a, b)).collect()
}

#[derive(Clone, Copy)]
enum Op {
    Collapse,
    Split,
    Flip,
}

/// Applies `op` to the edge of `x`; returns the vertices to relax around, or `None` when the
/// change is not allowed.
fn apply(
    m: &mut TriMesh<DVec2>,
    g: &Geometry,
    x: crate::topology::HalfEdgeId,
    op: Op,
) -> Result<Option<Vec<VertexId>>, Error> {
    let (a, b) = (m.origin(x), m.dest(x));
    let (pa, pb) = (m.pos(a), m.pos(b));
    let boundary = m.is_boundary_edge(x);
    match op {
        Op::Flip => {
            let c = m.origin(m.prev(x));
            let d = m.origin(m.prev(m.twin(x)));
            Ok(m.flip(x).is_ok().then(|| vec![a, b, c, d]))
        }
        Op::Split => {
            let mut mid = (pa + pb) * 0.5;
            if boundary {
                match (g.project)(mid)? {
                    Some(q) => mid = q,
                    None => return Ok(None),
                }
            }
            match m.split_edge(x, mid) {
                Ok(v) => {
                    legalize_around(m, v);
                    Ok(Some(vec![v]))
                }
                Err(_) => Ok(None),
            }
        }
        Op::Collapse => {
            use VertexTag::{Boundary, Fixed, Interior};
            let (ta, tb) = (m.tag(a), m.tag(b));
            let try_ = match (ta, tb) {
                (Interior, Interior) => Some((x, (pa + pb) * 0.5)),
                (Interior, _) => Some((x, pb)),
                (_, Interior) => Some((m.twin(x), pa)),
                (Boundary, Boundary) if boundary => (g.project)((pa + pb) * 0.5)?.map(|q| (x, q)),
                (Boundary, Fixed) if boundary => Some((x, pb)),
                (Fixed, Boundary) if boundary => Some((m.twin(x), pa)),
                _ => None,
            };
            let Some((e, pos)) = try_ else { return Ok(None) };
            match m.collapse(e, pos) {
                Ok(v) => {
                    legalize_around(m, v);
                    Ok(Some(vec![v]))
                }
                Err(_) => Ok(None),
            }
        }
    }
}

/// Delaunay flips from the edges around `v` and opposite it.
fn legalize_around(m: &mut TriMesh<DVec2>, v: VertexId) {
    let mut stack = Vec::new();
    for h in m.outgoing(v) {
        stack.push(h);
        if m.face_of(h).is_some() {
            stack.push(m.next(h));
        }
    }
    m.legalize(stack);
}

/// Fscale sqrt(sum L^2 / sum h_bar^2) over the edges of `m` (seed eq. 2.6): the rest length
/// of a bar is this times its mean relative size.
fn bar_scale(m: &TriMesh<DVec2>, g: &Geometry) -> Result<f64, Error> {
    let (mut sl, mut sh) = (0.0, 0.0);
    for e in m.edge_ids() {
        let (a, b) = (m.pos(m.origin(e)), m.pos(m.dest(e)));
        let hb = 0.5 * ((g.h)(a)? + (g.h)(b)?);
        sl += a.distance_squared(b);
        sh += hb * hb;
    }
    Ok(g.fscale * (sl / sh).sqrt())
}

/// The vertices within `rings` edges of `seeds`, in a deterministic order.
fn rings_around(m: &TriMesh<DVec2>, seeds: &[VertexId], rings: usize) -> Vec<VertexId> {
    let mut seen: SecondaryMap<VertexId, ()> = SecondaryMap::new();
    let mut out: Vec<VertexId> = Vec::new();
    for &s in seeds {
        if m.contains_vertex(s) && seen.insert(s, ()).is_none() {
            out.push(s);
        }
    }
    let mut start = 0;
    for _ in 0..rings {
        let end = out.len();
        for i in start..end {
            for w in m.neighbours(out[i]) {
                if seen.insert(w, ()).is_none() {
                    out.push(w);
                }
            }
        }
        start = end;
    }
    out
}

/// Force iterations of the truss on the nodes near `seeds` (the rest held): bars push with
/// (L0 - L) / L where shorter than L0 = Fscale h_bar sqrt(sum L^2 / sum h_bar^2) (seed eq. 2.6,
/// the sums over the whole mesh), boundary nodes projected back onto d = 0 after each step, and
/// every step checked exactly against inverting a triangle. Ends with Delaunay flips there.
/// `scale` is Fscale sqrt(sum L^2 / sum h_bar^2) of the mesh (see [`bar_scale`]).
fn relax(m: &mut TriMesh<DVec2>, g: &Geometry, seeds: &[VertexId], scale: f64) -> Result<(), Error> {
    let nodes: Vec<VertexId> = rings_around(m, seeds, RELAX_RINGS)
        .into_iter()
        .filter(|&v| matches!(m.tag(v), VertexTag::Interior | VertexTag::Boundary))
        .collect();
    // The topology holds during the iterations: neighbours and boundary flags once.
    let nbrs: Vec<smallvec::SmallVec<[VertexId; 8]>> = nodes.iter().map(|&v| m.neighbours(v)).collect();
    let on_boundary: Vec<bool> =
        nodes.iter().map(|&v| m.tag(v) == VertexTag::Boundary && m.is_boundary_vertex(v)).collect();
    // The relative size at each node and its neighbours where they start: the nodes move a
    // fraction of a bar.
    let mut hs: SecondaryMap<VertexId, f64> = SecondaryMap::new();
    for (k, &v) in nodes.iter().enumerate() {
        for &w in std::iter::once(&v).chain(nbrs[k].iter()) {
            if !hs.contains_key(w) {
                hs.insert(w, (g.h)(m.pos(w))?);
            }
        }
    }
    let mut steps = Vec::with_capacity(nodes.len());
    for _ in 0..RELAX_ITERS {
        steps.clear();
        for (k, &v) in nodes.iter().enumerate() {
            let pv = m.pos(v);
            let hv = hs[v];
            let mut f = DVec2::ZERO;
            for &w in &nbrs[k] {
                let d = pv - m.pos(w);
                let l = d.length();
                let l0 = 0.5 * (hv + hs[w]) * scale;
                if l > 0.0 && l0 > l {
                    f += d * ((l0 - l) / l);
                }
            }
            steps.push(pv + g.dt * f);
        }
        let mut moved = 0.0f64;
        for (k, &v) in nodes.iter().enumerate() {
            let old = m.pos(v);
            let mut x = steps[k];
            if x == old {
                continue;
            }
            if on_boundary[k] {
                match (g.project)(x)? {
                    Some(q) => x = q,
                    None => continue,
                }
            }
            for t in [1.0, 0.5, 0.25] {
                let y = old + (x - old) * t;
                if m.relocate(v, y).is_ok() {
                    moved = moved.max(y.distance(old) / (scale * hs[v]));
                    break;
                }
            }
        }
        if moved < RELAX_TOL {
            break;
        }
    }
    let mut stack = Vec::new();
    for &v in &nodes {
        stack.extend(m.outgoing(v));
    }
    m.legalize(stack);
    Ok(())
}
