use super::smoothing::*;
use crate::mesher::truss::{backtrack, bar_force, RestScale};
use crate::topology::{FaceId, Level, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec2;
use rayon::prelude::*;
use slotmap::SecondaryMap;

// ============================ local topological search ============================

/// What the topological search needs of the geometry: the relative size, the projection onto
/// the boundary, and the truss's force law (seed eq. 2.6 with these Fscale and time step).
pub(super) struct Geometry<'a> {
    pub h: &'a (dyn Fn(DVec2) -> Result<f64, Error> + Sync),
    pub project: &'a (dyn Fn(DVec2) -> Result<Option<DVec2>, Error> + Sync),
    pub fscale: f64,
    pub dt: f64,
    /// Whether the mesh is in one piece. Collapses, splits, flips and moves keep a mesh in one
    /// piece or in several, so this is found once, before the search and the polish, and a
    /// connected mesh's walls (see [`walls`]) need no walk over every vertex per trial.
    pub connected: bool,
}

/// The boundary edges a moved boundary node must clear besides its own loop: none in a mesh in
/// one piece, every boundary edge otherwise (see [`crate::topology::boundary_edges_if_split`]).
pub(super) fn walls(m: &TriMesh<DVec2>, g: &Geometry) -> Vec<[VertexId; 2]> {
    if g.connected {
        Vec::new()
    } else {
        crate::topology::boundary_edges_if_split(m)
    }
}

/// Triangles below this quality have their edges tried by the search.
pub(super) const Q_TRY: f64 = 0.95;
/// Rings of nodes around a change that the re-equilibration moves.
pub(super) const RELAX_RINGS: usize = 3;
/// Force iterations of the re-equilibration at most.
pub(super) const RELAX_ITERS: usize = 40;
/// The re-equilibration stops once no node moves more than this many rest lengths in a step.
pub(super) const RELAX_TOL: f64 = 1e-3;
/// The search ranks states by q mean - SIZE_WEIGHT * size deviation: a change may give up a
/// little mean quality for twice as much less size deviation.
pub(super) const SIZE_WEIGHT: f64 = 0.5;
/// The size deviation the search may reach on its way (or the start's, if higher): below the
/// 4% the quality tests hold meshes to. Bounded by the start's deviation alone, a search from
/// an already even mesh could keep no change at all: nearly every split, collapse or flip first
/// raises the deviation a little, and meshes of the same domain perturbed by 1e-9 came out with
/// q mean 0.984 or 0.974 depending on whether the start happened to be that even.
pub(super) const SIZE_DEV_ALLOWED: f64 = 0.035;
/// Meshes with more triangles are not searched: each trial measures the whole mesh, and on
/// fine meshes the poor boundary triangles weigh little in the mean.
pub(super) const SEARCH_MAX_FACES: usize = 5_000;
/// Polish sweeps over the relaxed nodes of a trial: a change is judged by the mesh the polish
/// would make of it.
pub(super) const TRIAL_SWEEPS: usize = 2;
/// Rounds of the search (each tries every candidate once).
pub(super) const SEARCH_ROUNDS: usize = 8;

/// Sums over some triangles: count, quality, relative circumradius and its square, and the
/// smallest quality.
#[derive(Clone, Copy, Default)]
pub(super) struct Sums {
    pub(super) n: f64,
    pub(super) sq: f64,
    pub(super) s1: f64,
    pub(super) s2: f64,
    pub(super) qmin: f64,
}

impl Sums {
    /// Over the triangles with a corner in `verts` (each once).
    pub(super) fn around(
        m: &TriMesh<DVec2>,
        verts: &[VertexId],
        h: &dyn Fn(DVec2) -> Result<f64, Error>,
    ) -> Result<Sums, Error> {
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
    pub(super) fn of(m: &TriMesh<DVec2>, h: &dyn Fn(DVec2) -> Result<f64, Error>) -> Result<Sums, Error> {
        let st = Stats::of(m, h)?;
        let qmin = st.q.min();
        Ok(Sums { n: st.n, sq: st.sq, s1: st.s1, s2: st.s2, qmin })
    }
    pub(super) fn q_mean(&self) -> f64 {
        self.sq / self.n
    }
    pub(super) fn dev(&self) -> f64 {
        let mean = self.s1 / self.n;
        ((self.s2 / self.n - mean * mean).max(0.0)).sqrt() / mean
    }
    /// These sums with the triangles of `old` replaced by those of `new`.
    pub(super) fn replace(&self, old: &Sums, new: &Sums) -> Sums {
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
/// deviation rises while the size deviation stays within [`SIZE_DEV_ALLOWED`] (or what it
/// was, if more) and the minimum quality does not fall; the mean quality at the end is at least
/// what it was.
/// A trial is measured on the triangles near it (those farther away are untouched); the
/// result is measured whole, and the search undone if it broke a condition after all.
/// Returns the number of changes kept.
pub(super) fn search(m: &mut TriMesh<DVec2>, g: &Geometry) -> Result<usize, Error> {
    if m.num_faces() > SEARCH_MAX_FACES || m.num_faces() == 0 {
        return Ok(0);
    }
    let start = Sums::of(m, g.h)?;
    let (budget, floor) = (start.dev().max(SIZE_DEV_ALLOWED), start.qmin);
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
        // Speculation: the next few edges are tried in parallel on the same mesh. Nearly every
        // trial is refused (84 of 4,521 kept on seed example 3b), and a refused edge leaves
        // the mesh as it was, so each result is what the edges one after the other would give,
        // up to the first kept change; the results after it are dropped and tried again on
        // the changed mesh. The outcome is that of the sequential search for any thread count.
        let batch = rayon::current_num_threads().max(1);
        let limits = Limits { budget, floor, scale };
        let mut i = 0;
        while i < edges.len() {
            let end = (i + batch).min(edges.len());
            let tried: Vec<Result<Option<Trial>, Error>> =
                edges[i..end].par_iter().map(|&(a, b)| best_change(m, g, &cur, &limits, a, b)).collect();
            let mut next_i = end;
            for (k, t) in tried.into_iter().enumerate() {
                if let Some(Trial { sums, mesh, near }) = t? {
                    *m = mesh;
                    cur = sums;
                    round += 1;
                    for v in near {
                        touched.insert(v, ());
                    }
                    next_i = i + k + 1;
                    break;
                }
            }
            i = next_i;
        }
        kept += round;
        if std::env::var_os("TRUSSMESH_TRACE").is_some() {
            eprintln!("search round: {} candidate edges, {round} kept, {} faces", edges.len(), m.num_faces());
        }
        if round == 0 {
            break;
        }
        dirty = Some(touched);
    }
    let end = Sums::of(m, g.h)?;
    if end.q_mean() < start.q_mean() || end.dev() > budget || end.qmin < floor || m.validate(Level::Geometry).is_err() {
        *m = original;
        return Ok(0);
    }
    Ok(kept)
}

/// What bounds a kept change: the size deviation budget, the quality floor, and the bar
/// scale of the round (see [`bar_scale`]).
struct Limits {
    budget: f64,
    floor: f64,
    scale: f64,
}

/// A change that passed: the mesh's sums after it, the mesh, and the vertices near it.
struct Trial {
    sums: Sums,
    mesh: TriMesh<DVec2>,
    near: Vec<VertexId>,
}

/// The best of the three changes (collapse, split, flip) of the edge a-b of `m` that passes,
/// each followed by the re-equilibration and polish around it; `None` when none passes or
/// the edge is gone. Reads `m` only.
fn best_change(
    m: &TriMesh<DVec2>,
    g: &Geometry,
    cur: &Sums,
    lim: &Limits,
    a: VertexId,
    b: VertexId,
) -> Result<Option<Trial>, Error> {
    let Some(x) = (if m.contains_vertex(a) { m.find_half_edge(a, b) } else { None }) else { return Ok(None) };
    // The region and its sums are those of `m`, the same for the three trials.
    let region = rings_around(m, &[a, b], RELAX_RINGS + 3);
    let before = Sums::around(m, &region, g.h)?;
    let merit = |x: &Sums| x.q_mean() - SIZE_WEIGHT * x.dev();
    // A collapse or split at the boundary is checked locally (fans, the new boundary edges
    // against the loop), which a mesh of a few triangles with a deep notch can still defeat
    // (the boundary crossed itself in a 2 x 3.5 h0 quadrilateral): a change there is kept
    // only if the whole trial mesh is an embedding (few are kept, so this costs little).
    let at_boundary = m.is_boundary_vertex(a) || m.is_boundary_vertex(b);
    let mut best: Option<Trial> = None;
    for op in [Op::Collapse, Op::Split, Op::Flip] {
        let mut trial = m.clone();
        let Some(seeds) = apply(&mut trial, g, x, op)? else { continue };
        relax(&mut trial, g, &seeds, lim.scale)?;
        let mut near: Vec<VertexId> = region.iter().copied().filter(|&v| trial.contains_vertex(v)).collect();
        near.extend(seeds.iter().copied().filter(|&v| trial.contains_vertex(v)));
        let free: Vec<VertexId> =
            rings_around(&trial, &seeds, RELAX_RINGS).into_iter().filter(|&v| movable(&trial, v)).collect();
        polish_nodes(&mut trial, g, &free, TRIAL_SWEEPS, Some(cur))?;
        let after = Sums::around(&trial, &near, g.h)?;
        // Triangles outside the region must be the same in number, or the measure is whole.
        let next = if m.num_faces() as f64 - before.n == trial.num_faces() as f64 - after.n {
            cur.replace(&before, &after)
        } else {
            Sums::of(&trial, g.h)?
        };
        let bar = best.as_ref().map_or(merit(cur) + 1e-7, |b| merit(&b.sums));
        if merit(&next) > bar
            && next.dev() <= lim.budget
            && next.qmin >= lim.floor
            && (matches!(op, Op::Flip) || !at_boundary || trial.validate(Level::Geometry).is_ok())
        {
            best = Some(Trial { sums: next, mesh: trial, near });
        }
    }
    Ok(best)
}

/// The edges of triangles below Q_TRY, worst triangle first, and only those with an end in
/// `dirty` when given.
pub(super) fn candidate_edges(
    m: &TriMesh<DVec2>,
    dirty: Option<&SecondaryMap<VertexId, ()>>,
) -> Vec<(VertexId, VertexId)> {
    let mut edges: Vec<(f64, VertexId, VertexId)> = Vec::new();
    for f in m.face_ids() {
        let q = m.face_quality(f);
        if q < Q_TRY {
            for x in m.face_half_edges(f) {
                let (a, b) = (m.origin(x), m.dest(x));
                if dirty.is_none_or(|d| d.contains_key(a) || d.contains_key(b)) {
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
pub(super) enum Op {
    Collapse,
    Split,
    Flip,
}

/// Applies `op` to the edge of `x`; returns the vertices to relax around, or `None` when the
/// change is not allowed.
pub(super) fn apply(
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
            let mid = (pa + pb) * 0.5;
            if boundary {
                let Some(q) = (g.project)(mid)? else { return Ok(None) };
                return Ok(match super::density::split_boundary_at(m, x, q) {
                    Some((v, true)) => {
                        m.legalize_star(v);
                        Some(vec![v])
                    }
                    _ => None,
                });
            }
            match m.split_edge(x, mid) {
                Ok(v) => {
                    m.legalize_star(v);
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
                    m.legalize_star(v);
                    Ok(Some(vec![v]))
                }
                Err(_) => Ok(None),
            }
        }
    }
}

/// Fscale sqrt(sum L^2 / sum h_bar^2) over the edges of `m` (seed eq. 2.6): the rest length
/// of a bar is this times its mean relative size.
pub(super) fn bar_scale(m: &TriMesh<DVec2>, g: &Geometry) -> Result<f64, Error> {
    let mut rest = RestScale::new(2);
    for e in m.edge_ids() {
        let (a, b) = (m.pos(m.origin(e)), m.pos(m.dest(e)));
        rest.add(a.distance_squared(b), 0.5 * ((g.h)(a)? + (g.h)(b)?));
    }
    Ok(rest.scale(g.fscale))
}

/// The vertices within `rings` edges of `seeds`, in a deterministic order.
pub(super) fn rings_around(m: &TriMesh<DVec2>, seeds: &[VertexId], rings: usize) -> Vec<VertexId> {
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
pub(super) fn relax(m: &mut TriMesh<DVec2>, g: &Geometry, seeds: &[VertexId], scale: f64) -> Result<(), Error> {
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
    let walls = walls(m, g);
    let mut steps = Vec::with_capacity(nodes.len());
    for _ in 0..RELAX_ITERS {
        steps.clear();
        for (k, &v) in nodes.iter().enumerate() {
            let pv = m.pos(v);
            let hv = hs[v];
            let mut f = DVec2::ZERO;
            for &w in &nbrs[k] {
                let d = pv - m.pos(w);
                f += bar_force(d, d.length(), 0.5 * (hv + hs[w]) * scale);
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
                    // A projection that lands far from the step has jumped to another part of
                    // the boundary (across a narrow gap, onto a hole).
                    Some(q) if q.distance(old) <= 2.0 * x.distance(old) => x = q,
                    _ => continue,
                }
            }
            let taken = backtrack(old, x, 2, |y| Ok::<bool, Error>(relocate_clear(m, v, y, &walls)))?;
            if let Some(y) = taken {
                moved = moved.max(y.distance(old) / (scale * hs[v]));
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

/// Moves `v` to `p` when the engine's relocation check passes and, for a boundary node, its
/// new boundary edges meet none of `walls` (from [`crate::topology::boundary_edges_if_split`]:
/// empty for a connected mesh, where the relocation's own-loop test is exact; every boundary
/// edge for a mesh in pieces, which a node could lay over one another).
pub(super) fn relocate_clear(m: &mut TriMesh<DVec2>, v: VertexId, p: DVec2, walls: &[[VertexId; 2]]) -> bool {
    let old = m.pos(v);
    if m.relocate(v, p).is_err() {
        return false;
    }
    if !crate::topology::boundary_clear(m, v, walls) {
        m.set_pos_unchecked(v, old);
        return false;
    }
    true
}
