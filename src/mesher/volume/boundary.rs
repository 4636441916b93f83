//! The boundary: surface edge flips, edge removal by ring triangulation, and boundary nodes
//! brought onto d = 0.

use super::density::edge_index;
use super::improve::try_swaps;
use super::smoothing::smooth_vertex;
use super::Ctx;
use crate::predicates::{orient3d, Sign};
use crate::quality::tet_dihedral_quality;
use crate::topology::{EdgeShell, Objective, TVertexId, TetId, TetMesh, TetPatch, VertexTag, EDGE_VERTICES};
use crate::Error;
use glam::DVec3;
use std::collections::HashMap;

/// A boundary edge whose midpoint is farther than this times its length from d = 0 cuts across
/// a sharp edge of the domain (a smooth surface's chord sags by about len / (8 R) times len).
const CUT: f64 = 0.1;
/// The flip of such an edge is tried when the other diagonal's midpoint is this much nearer.
const CUT_GAIN: f64 = 0.5;
/// The four nodes must lie within this times the edge's length of d = 0.
const CUT_ON: f64 = 1e-3;
/// Priority of those flips over the Delaunay ones (angle sums are below 2 pi).
const CUT_FIRST: f64 = 10.0;

/// Boundary edges whose two boundary triangles fail the planar Delaunay test (opposite angles
/// summing past 180 degrees), and boundary edges that cut across a sharp edge of the domain
/// while the other diagonal of their two triangles follows it, are flipped when the tets allow
/// it; returns the count.
pub(super) fn surface_flips(ctx: &mut Ctx, m: &mut TetMesh) -> Result<usize, Error> {
    let mut faces: HashMap<(TVertexId, TVertexId), TVertexId> = HashMap::new();
    let bfaces = m.boundary_faces();
    for &(t, f) in &bfaces {
        let v = m.face_vertices(t, f);
        for k in 0..3 {
            faces.insert((v[k], v[(k + 1) % 3]), v[(k + 2) % 3]);
        }
    }
    let mut cands: Vec<(f64, TVertexId, TVertexId)> = Vec::new();
    for (&(a, b), &c) in &faces {
        if a > b {
            continue;
        }
        let Some(&d) = faces.get(&(b, a)) else { continue };
        let (pa, pb, pc, pd) = (m.pos(a), m.pos(b), m.pos(c), m.pos(d));
        let ang = |x: DVec3, y: DVec3, z: DVec3| (y - x).angle_between(z - x);
        let s = ang(pc, pa, pb) + ang(pd, pa, pb);
        if s > std::f64::consts::PI + 1e-3 {
            cands.push((s, a, b));
            continue;
        }
        // An edge that cuts across a sharp edge of the domain (its midpoint far from d = 0)
        // where the other diagonal lies on d = 0: the flip restores the edge of the domain.
        let dab = ctx.approx_dist((pa + pb) * 0.5)?.abs();
        let len = pa.distance(pb);
        if dab > CUT * len {
            // Only between nodes that lie on d = 0 (not on their way there, early on).
            let mut on = true;
            for q in [pa, pb, pc, pd] {
                on &= ctx.approx_dist(q)?.abs() < CUT_ON * len;
            }
            let dcd = ctx.approx_dist((pc + pd) * 0.5)?.abs();
            if on && dcd < CUT_GAIN * dab {
                cands.push((CUT_FIRST + dab / pa.distance(pb), a, b));
            }
        }
    }
    cands.sort_by(|x, y| y.0.total_cmp(&x.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    let mut n = 0;
    for (_, a, b) in cands {
        let Some(s) = m.edge_shell_of(a, b) else { continue };
        if s.closed {
            continue;
        }
        if let Some((plan, _)) = ring_patch(ctx, m, &s, true, |q| q > 0.05)? {
            m.apply_patch(plan);
            n += 1;
        }
    }
    ctx.report.ops.flips += n;
    Ok(n)
}

/// Removal of the edge of shell `s` (interior or, with `allow_boundary`, boundary) by the
/// engine's ring retriangulation maximising the worst [`tet_dihedral_quality`] (Shewchuk's
/// edge removal), taken when `accept` takes that worst value. For a boundary edge the ring is
/// open, its two ends become the new boundary edge, which must stay near d = 0 (the flip may
/// not cut across a sharp edge of the domain). Returns the patch and its worst tq.
pub(super) fn ring_patch(
    ctx: &Ctx,
    m: &TetMesh,
    s: &EdgeShell,
    allow_boundary: bool,
    accept: impl Fn(f64) -> bool,
) -> Result<Option<(TetPatch, f64)>, Error> {
    let n = s.ring.len();
    if !(3..=12).contains(&n) || (!s.closed && !allow_boundary) {
        return Ok(None);
    }
    // The engine refuses an internal boundary too; checked first to spare the distances.
    let label = m.tet(s.tets[0]).label;
    if s.tets.iter().any(|&t| m.tet(t).label != label) {
        return Ok(None);
    }
    if !s.closed {
        let (p0, pn) = (m.pos(s.ring[0]), m.pos(s.ring[n - 1]));
        let dn = ctx.approx_dist((p0 + pn) * 0.5)?.abs();
        let dold = ctx.approx_dist((m.pos(s.a) + m.pos(s.b)) * 0.5)?.abs();
        if dn > 2.0 * dold + 0.02 * p0.distance(pn) {
            return Ok(None);
        }
    }
    Ok(m.ring_retriangulation(s, tet_dihedral_quality, Objective::Worst, accept).ok())
}

/// Every boundary node onto d = 0 where the tets allow it (checked moves).
pub(super) fn settle_boundary(ctx: &mut Ctx, m: &mut TetMesh) -> Result<(), Error> {
    let vs: Vec<TVertexId> = m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Boundary).collect();
    for v in vs {
        if !m.contains_vertex(v) {
            continue;
        }
        let p = m.pos(v);
        if ctx.trace && ctx.approx_dist(p)?.abs() > 1e-3 * ctx.opts.h0 {
            let q = ctx.project(p)?;
            eprintln!(
                "settle: off vertex at {p:?}, d {:.4}, projection {q:?}, relocate ok {:?}",
                ctx.approx_dist(p)?,
                q.map(|q| m.check_relocate(v, q))
            );
        }
        if let Some(q) = ctx.project(p)? {
            if q != p
                && m.relocate(v, q).is_err()
                && !clear_the_way(ctx, m, v, q)?
                && !merge_into_boundary_neighbour(ctx, m, v)?
            {
                // Part of the way at least.
                for f in [0.5, 0.75, 0.9] {
                    if m.relocate(v, p.lerp(q, f)).is_ok() {
                        break;
                    }
                }
            }
        }
    }
    Ok(())
}

/// The tets that would invert with `v` at `q` are swapped away or their other vertices
/// smoothed, a few rounds, until `v` can move to `q`.
pub(super) fn clear_the_way(ctx: &mut Ctx, m: &mut TetMesh, v: TVertexId, q: DVec3) -> Result<bool, Error> {
    for _ in 0..4 {
        let blocking: Vec<TetId> = m
            .vertex_tets(v)
            .into_iter()
            .filter(|&t| {
                let p = m.tet(t).v.map(|w| if w == v { q } else { m.pos(w) });
                orient3d(p[0], p[1], p[2], p[3]) != Sign::Positive
            })
            .collect();
        if blocking.is_empty() {
            break;
        }
        for t in blocking {
            if !m.contains_tet(t) {
                continue;
            }
            let nb = m.tet(t).adj.iter().filter(|a| a.is_none()).count();
            if nb >= 2 && m.remove_boundary_tet(t).is_ok() {
                ctx.report.ops.removed += 1;
                continue;
            }
            if try_swaps(ctx, m, t)? {
                continue;
            }
            for w in m.tet(t).v {
                if w != v {
                    smooth_vertex(ctx, m, w)?;
                }
            }
        }
        if !m.contains_vertex(v) {
            return Ok(true);
        }
        if m.relocate(v, q).is_ok() {
            return Ok(true);
        }
    }
    Ok(m.contains_vertex(v) && m.relocate(v, q).is_ok())
}

/// A boundary node that cannot reach d = 0 is collapsed along a boundary edge into the
/// neighbour that leaves the best worst radius ratio (seed: such nodes are crowded ones).
fn merge_into_boundary_neighbour(ctx: &mut Ctx, m: &mut TetMesh, v: TVertexId) -> Result<bool, Error> {
    let mut best: Option<(f64, TetPatch)> = None;
    for w in m.vertex_neighbours(v) {
        if !matches!(m.tag(w), VertexTag::Boundary | VertexTag::Fixed) {
            continue;
        }
        let Some(t) = m.find_edge(v, w) else { continue };
        let e = edge_index(m, t, v, w);
        let reverse = m.tet(t).v[EDGE_VERTICES[e][0]] != v;
        if let Ok(plan) = m.check_collapse(t, e, reverse, m.pos(w)) {
            if plan.min_quality > 0.0 && best.as_ref().is_none_or(|b| plan.min_quality > b.0) {
                best = Some((plan.min_quality, plan));
            }
        }
    }
    if let Some((_, plan)) = best {
        m.apply_patch(plan);
        ctx.report.ops.collapses += 1;
        return Ok(true);
    }
    Ok(false)
}

pub(super) fn count_off(ctx: &Ctx, m: &TetMesh) -> Result<usize, Error> {
    let tol = 1e-3 * ctx.opts.h0;
    let mut n = 0;
    for v in m.vertex_ids() {
        if matches!(m.tag(v), VertexTag::Boundary) && ctx.approx_dist(m.pos(v))?.abs() > tol {
            n += 1;
        }
    }
    Ok(n)
}
