//! Sliver removal by topology (swaps, boundary tet removal, cap collapses) and by vertex
//! perturbation, and the mean-quality swaps.

use super::boundary::ring_patch;
use super::smoothing::{coloured_smoothing, mean_smooth_target, smooth_target, star_min, star_of, star_rr};
use super::{Ctx, CHUNK, GEPS, RR_SLACK, RR_TQ_FLOOR};
use crate::predicates::{orient3d, Sign};
use crate::quality::{dihedral_quality_cos_bounds, tet_dihedral_quality, tet_dihedral_quality_below};
use crate::topology::{EdgeShell, Level, Objective, TVertexId, TetId, TetMesh, TetPatch, VertexTag, EDGE_VERTICES};
use crate::Error;
use glam::DVec3;
use rayon::prelude::*;
use slotmap::SecondaryMap;
use smallvec::SmallVec;

/// Tets below this dihedral quality ([`tet_dihedral_quality`]) are attacked by the sliver removal.
const TQ_TARGET: f64 = 0.6;
/// Boundary tets below this dihedral quality that no swap improves get an edge collapsed,
/// when every new tet keeps a radius ratio above CAP_COLLAPSE_RR.
const CAP_TQ: f64 = 0.2;
const CAP_COLLAPSE_RR: f64 = 0.2;
/// Least gain in the worst tq of the tets it replaces for a collapse of a stuck tet's edge.
const CROWD_GAIN: f64 = 0.01;
/// A polish round that starts with the worst tq less than this above the last round's start
/// is not made (such rounds gain hundredths of a degree at large cost).
const POLISH_STALL: f64 = 1e-3;
/// The mean-quality swaps look at the edges and faces of tets this far below the mean radius
/// ratio (all of them would cost seconds and change almost nothing).
const RR_SWAP_MARGIN: f64 = 0.1;
/// Least gain in summed radius ratio for a mean-quality swap.
const RR_GAIN: f64 = 1e-4;

/// One round of sliver removal over the tets below TQ_TARGET, worst first: swaps, then
/// smoothing of their vertices, then (from the second round) random perturbations. Returns
/// how many changes were accepted.
pub(super) fn improve(ctx: &mut Ctx, m: &mut TetMesh, round: usize) -> Result<usize, Error> {
    let ids: Vec<TetId> = m.tet_ids().collect();
    let mut bad: Vec<(f64, TetId)> = {
        let mesh = &*m;
        let (cl, ch) = dihedral_quality_cos_bounds(TQ_TARGET);
        ids.par_iter()
            .with_min_len(CHUNK)
            .filter_map(|&t| {
                let p = mesh.tet_points(t);
                tet_dihedral_quality_below(p, cl, ch).then(|| (tet_dihedral_quality(p), t))
            })
            .filter(|&(q, _)| q < TQ_TARGET)
            .collect()
    };
    bad.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    // The mean-quality pass after the polish lets any tet down to RR_TQ_FLOOR: polishing the
    // worst tet above that is undone, and so are rounds that no longer raise the worst tet.
    // Rounds 0 and 1 are always made: perturbations start in round 1, and a worst tet that
    // swaps and smoothing leave stuck often moves only then.
    let worst = bad.first().map_or(1.0, |b| b.0);
    if worst >= RR_TQ_FLOOR || (round >= 2 && worst < ctx.polish_worst + POLISH_STALL) {
        return Ok(0);
    }
    ctx.polish_worst = worst;
    let mut changes = 0;
    let ts: Vec<TetId> = bad.iter().map(|b| b.1).collect();
    let promising = swap_candidates(ctx, m, &ts)?;
    // Swaps first, worst tet first; then the vertices of the tets still bad are smoothed by
    // independent classes (in parallel); then, after the first round, perturbed.
    let mut left: Vec<TetId> = Vec::new();
    for (t, hope) in ts.into_iter().zip(promising) {
        if !m.contains_tet(t) || tet_dihedral_quality(m.tet_points(t)) >= TQ_TARGET {
            continue;
        }
        if hope && try_swaps(ctx, m, t)? {
            changes += 1;
            continue;
        }
        left.push(t);
    }
    let mut seen: SecondaryMap<TVertexId, ()> = SecondaryMap::new();
    let mut verts: Vec<TVertexId> = Vec::new();
    for &t in &left {
        if m.contains_tet(t) {
            for v in m.tet(t).v {
                if seen.insert(v, ()).is_none() {
                    verts.push(v);
                }
            }
        }
    }
    changes += coloured_smoothing(ctx, m, Some(&verts), smooth_target)?;
    if round > 0 {
        for &t in &left {
            if m.contains_tet(t) && tet_dihedral_quality(m.tet_points(t)) < TQ_TARGET {
                for v in m.tet(t).v {
                    if perturb_vertex(ctx, m, v)? {
                        changes += 1;
                    }
                }
            }
        }
        // What smoothing and perturbation left stuck may be a crowded spot.
        for t in left {
            if try_crowd_collapse(ctx, m, t) {
                changes += 1;
            }
        }
    }
    Ok(changes)
}

/// A change [`find_swap`] chose for a tet.
enum Swap {
    /// The tet leaves the boundary.
    Remove,
    /// An edge removal or a 2-3 flip.
    Flip(TetPatch),
    /// An edge collapse of a flat boundary cap.
    Collapse(TetPatch),
}

/// The best of: removing one of the six edges of `t` (interior or boundary), or a 2-3 flip of
/// one of its faces, if it raises the worst tq of the tets it replaces; before that a boundary
/// tent that can go, after it a flat cap's collapse. Read-only, so candidates can be screened
/// in parallel.
fn find_swap(ctx: &Ctx, m: &TetMesh, t: TetId) -> Result<Option<Swap>, Error> {
    // A tent or cap on the boundary (two or three boundary faces, centroid near d = 0) goes.
    let nb = m.tet(t).adj.iter().filter(|a| a.is_none()).count();
    if nb >= 2 {
        let p = m.tet_points(t);
        let c = (p[0] + p[1] + p[2] + p[3]) / 4.0;
        if ctx.approx_dist(c)? > -GEPS * ctx.opts.h0 * ctx.h(c)? && m.check_remove_boundary_tet(t).is_ok() {
            return Ok(Some(Swap::Remove));
        }
    }
    let mut best: Option<(f64, TetPatch)> = None;
    for [i, j] in EDGE_VERTICES {
        let s = m.edge_shell(t, i, j);
        let old = s.tets.iter().map(|&u| tet_dihedral_quality(m.tet_points(u))).fold(f64::INFINITY, f64::min);
        let better = |q: f64| q > old + 1e-6 && best.as_ref().is_none_or(|b| q - old > b.0);
        if let Some((plan, q)) = ring_patch(ctx, m, &s, true, better)? {
            best = Some((q - old, plan));
        }
    }
    let tx = *m.tet(t);
    for f in 0..4 {
        let Some((u, j)) = tx.adj[f] else { continue };
        let d = m.pos(tx.v[f]);
        let e = m.pos(m.tet(u).v[j as usize]);
        let [p, q, r] = m.face_vertices(t, f).map(|v| m.pos(v));
        let newq = tet_dihedral_quality([p, q, d, e])
            .min(tet_dihedral_quality([q, r, d, e]))
            .min(tet_dihedral_quality([r, p, d, e]));
        let old = tet_dihedral_quality(m.tet_points(t)).min(tet_dihedral_quality(m.tet_points(u)));
        if newq > old + 1e-6 && best.as_ref().is_none_or(|b| newq - old > b.0) {
            if let Ok(plan) = m.check_flip23(t, f) {
                best = Some((newq - old, plan));
            }
        }
    }
    if let Some((_, plan)) = best {
        return Ok(Some(Swap::Flip(plan)));
    }
    // A flat cap on the boundary that neither leaves nor swaps: collapse its shortest edge
    // whose collapse leaves every new tet above CAP_COLLAPSE_RR (the forces respace later).
    if nb >= 1 && tet_dihedral_quality(m.tet_points(t)) < CAP_TQ {
        let mut edges: SmallVec<[(f64, usize); 6]> = (0..6)
            .map(|e| {
                let [i, j] = EDGE_VERTICES[e];
                (m.pos(tx.v[i]).distance(m.pos(tx.v[j])), e)
            })
            .collect();
        edges.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (_, e) in edges {
            for reverse in [false, true] {
                let [i, j] = EDGE_VERTICES[e];
                let stay = if reverse { tx.v[i] } else { tx.v[j] };
                if let Ok(plan) = m.check_collapse(t, e, reverse, m.pos(stay)) {
                    if plan.min_quality > CAP_COLLAPSE_RR {
                        return Ok(Some(Swap::Collapse(plan)));
                    }
                }
            }
        }
    }
    Ok(None)
}

/// A tet that swaps, smoothing and perturbation left below RR_TQ_FLOOR where too many nodes
/// crowd a spot (a node squeezed between the boundary and the next layer): the collapse of
/// one of its edges (at the midpoint of two interior ends, or into an end) that raises the
/// worst tq of the tets it replaces the most, by at least CROWD_GAIN. Returns whether it
/// collapsed one.
fn try_crowd_collapse(ctx: &mut Ctx, m: &mut TetMesh, t: TetId) -> bool {
    if !m.contains_tet(t) || tet_dihedral_quality(m.tet_points(t)) >= RR_TQ_FLOOR {
        return false;
    }
    let tx = *m.tet(t);
    let mut best: Option<(f64, TetPatch)> = None;
    for (e, [i, j]) in EDGE_VERTICES.into_iter().enumerate() {
        let (pi, pj) = (m.pos(tx.v[i]), m.pos(tx.v[j]));
        // A boundary survivor stays where it is (on d = 0); two interior ends may also meet
        // halfway.
        let both_inside = m.tag(tx.v[i]) == VertexTag::Interior && m.tag(tx.v[j]) == VertexTag::Interior;
        for reverse in [false, true] {
            let stay = if reverse { pi } else { pj };
            let places: SmallVec<[DVec3; 2]> =
                if both_inside { smallvec::smallvec![(pi + pj) * 0.5, stay] } else { smallvec::smallvec![stay] };
            for pos in places {
                let Ok(plan) = m.check_collapse(t, e, reverse, pos) else { continue };
                let (old, new) = m.patch_quality(&plan, tet_dihedral_quality);
                if new > old + CROWD_GAIN && best.as_ref().is_none_or(|b| new - old > b.0) {
                    best = Some((new - old, plan));
                }
            }
        }
    }
    let Some((_, plan)) = best else { return false };
    m.apply_patch(plan);
    ctx.report.ops.collapses += 1;
    true
}

/// A tet below this tq at the end, with a boundary face, is flat on the boundary (see
/// [`clear_flat_boundary_tets`]).
const FLAT_TQ: f64 = 1e-3;
/// Rounds of [`clear_flat_boundary_tets`]: each removal can free a neighbour's.
const FLAT_ROUNDS: usize = 8;

/// Removes the tets left flat on the boundary (tq below FLAT_TQ, a face on it): a cluster of
/// them can lie in one plane of the boundary, each wedged by the others (its free edge already
/// on the boundary) and one of them capping a fixed point that only it holds, so that neither
/// the swaps nor the removals of the polish apply. Such a cap's fixed point lies in the plane
/// of the face under it and goes with it (the face keeps the feature's place on the surface);
/// the rest leave one after the other as their neighbours go, or by [`try_swaps`]. Returns
/// the number of changes.
pub(super) fn clear_flat_boundary_tets(ctx: &mut Ctx, m: &mut TetMesh) -> Result<usize, Error> {
    let mut changes = 0;
    for _ in 0..FLAT_ROUNDS {
        let flat: Vec<TetId> = m
            .tet_ids()
            .filter(|&t| m.tet(t).adj.iter().any(|a| a.is_none()) && tet_dihedral_quality(m.tet_points(t)) < FLAT_TQ)
            .collect();
        let mut changed = 0;
        for t in flat {
            if !m.contains_tet(t) {
                continue;
            }
            let tx = *m.tet(t);
            if tx.adj.iter().filter(|a| a.is_none()).count() == 3 {
                // The cap's apex: the vertex opposite its one interior face.
                if let Some(i) = tx.adj.iter().position(|a| a.is_some()) {
                    let v = tx.v[i];
                    if m.tag(v) == VertexTag::Fixed && m.vertex_tets(v).len() == 1 {
                        m.set_tag(v, VertexTag::Boundary);
                        if m.remove_boundary_tet(t).is_ok() {
                            ctx.report.ops.removed += 1;
                            changed += 1;
                            continue;
                        }
                        m.set_tag(v, VertexTag::Fixed);
                    }
                }
            }
            if m.remove_boundary_tet(t).is_ok() {
                ctx.report.ops.removed += 1;
                changed += 1;
            } else if try_swaps(ctx, m, t)? {
                changed += 1;
            }
        }
        changes += changed;
        if changed == 0 {
            break;
        }
    }
    Ok(changes)
}

/// How far from a lonely fixed point (see [`reseat_lonely_fixed_points`]) a boundary node may
/// be to take its place, in local target lengths h0 h.
const RESEAT_REACH: f64 = 0.3;

/// Gives a fixed point held by one poor tet alone a better holder. Such a point (on a sharp
/// edge, most often in a concave crease) has lost its other tets to removals at the boundary,
/// while a free boundary node beside it took over its part of the surface; the tet left is a
/// cap with three boundary faces over a nearly flat patch (a 13-degree one where a ball leaves
/// a box's top face), which no swap or smoothing can mend, since its apex may not move. The
/// cap goes, and the nearest free boundary node within [`RESEAT_REACH`] of the point (among
/// the neighbours of the cap's other corners) moves onto it and is fixed there instead, when
/// the move is a checked relocation and every tet around the node then has a higher dihedral
/// quality than the cap had; otherwise nothing changes. Returns the number of points reseated.
pub(super) fn reseat_lonely_fixed_points(ctx: &mut Ctx, m: &mut TetMesh) -> Result<usize, Error> {
    let lonely: Vec<TVertexId> =
        m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed && m.vertex_tets(v).len() == 1).collect();
    let mut done = 0;
    for v in lonely {
        let star = m.vertex_tets(v);
        let [t] = star[..] else { continue };
        let cap_q = tet_dihedral_quality(m.tet_points(t));
        if cap_q >= CAP_TQ || m.tet(t).adj.iter().filter(|a| a.is_none()).count() != 3 {
            continue;
        }
        let at = m.pos(v);
        let reach = RESEAT_REACH * ctx.opts.h0 * ctx.h(at)?;
        let corners = m.tet(t).v;
        let mut best: Option<(f64, TVertexId)> = None;
        for &c in corners.iter().filter(|&&c| c != v) {
            for w in m.vertex_neighbours(c) {
                if corners.contains(&w) || m.tag(w) != VertexTag::Boundary {
                    continue;
                }
                let d = m.pos(w).distance(at);
                if d <= reach && best.is_none_or(|(bd, bw)| d < bd || (d == bd && w < bw)) {
                    best = Some((d, w));
                }
            }
        }
        let Some((_, w)) = best else { continue };
        let saved = m.clone();
        m.set_tag(v, VertexTag::Boundary);
        let moved = m.remove_boundary_tet(t).is_ok() && m.relocate(w, at).is_ok();
        // The relocation's checks are local (positive tets, unwrapped boundary rings); a node
        // moved onto a point the cap held could still meet the boundary elsewhere, so the whole
        // mesh is validated (rare: a few points per mesh at most).
        let better = moved
            && m.vertex_tets(w).iter().all(|&u| tet_dihedral_quality(m.tet_points(u)) > cap_q)
            && m.validate(Level::Geometry).is_ok();
        if !better {
            *m = saved;
            continue;
        }
        m.set_tag(w, VertexTag::Fixed);
        ctx.report.ops.removed += 1;
        done += 1;
    }
    Ok(done)
}

/// Applies [`find_swap`]'s choice for `t`, if any.
pub(super) fn try_swaps(ctx: &mut Ctx, m: &mut TetMesh, t: TetId) -> Result<bool, Error> {
    match find_swap(ctx, m, t)? {
        Some(Swap::Remove) => {
            if m.remove_boundary_tet(t).is_err() {
                return Ok(false);
            }
            ctx.report.ops.removed += 1;
        }
        Some(Swap::Flip(plan)) => {
            m.apply_patch(plan);
            ctx.report.ops.flips += 1;
        }
        Some(Swap::Collapse(plan)) => {
            m.apply_patch(plan);
            ctx.report.ops.collapses += 1;
        }
        None => return Ok(false),
    }
    Ok(true)
}

/// Whether [`find_swap`] finds something for each tet of `cands` on the mesh as it is, in
/// parallel. The polish then tries in order only the tets marked true; at 10^6 tets most
/// candidates are not.
fn swap_candidates(ctx: &Ctx, m: &TetMesh, cands: &[TetId]) -> Result<Vec<bool>, Error> {
    cands.par_iter().with_min_len(64).map(|&t| Ok(m.contains_tet(t) && find_swap(ctx, m, t)?.is_some())).collect()
}

/// Random moves of `v` within a tenth of its edge length (tangential on the boundary), the
/// best of a few kept if it raises the star's worst tq: slivers that are a local optimum of
/// the smoothing often are not one of a small jump.
fn perturb_vertex(ctx: &mut Ctx, m: &mut TetMesh, v: TVertexId) -> Result<bool, Error> {
    if !m.contains_vertex(v) || m.tag(v) == VertexTag::Fixed {
        return Ok(false);
    }
    let boundary = m.tag(v) == VertexTag::Boundary;
    let star = star_of(m, v);
    let x0 = m.pos(v);
    let nb = m.vertex_neighbours(v);
    let len = nb.iter().map(|&w| m.pos(w).distance(x0)).sum::<f64>() / nb.len().max(1) as f64;
    let (f0, _) = star_min(&star, x0);
    let mut best = (f0, x0);
    for _ in 0..12 {
        let r = DVec3::new(ctx.next_f64() - 0.5, ctx.next_f64() - 0.5, ctx.next_f64() - 0.5) * (0.2 * len);
        let mut y = x0 + r;
        if boundary {
            match ctx.project(y)? {
                Some(q) => y = q,
                None => continue,
            }
        }
        let (fy, _) = star_min(&star, y);
        if fy > best.0 + 1e-9 {
            best = (fy, y);
        }
    }
    if best.0 > f0 + 1e-9 && star_rr(&star, best.1) > star_rr(&star, x0) - RR_SLACK && m.relocate(v, best.1).is_ok() {
        ctx.report.ops.smoothings += 1;
        return Ok(true);
    }
    Ok(false)
}

/// One round of the final mean-quality pass (Klingner and Shewchuk 2007 aim their swaps and
/// smoothing at the mean as well as the worst): interior edge removals and 2-3 flips that raise
/// the mesh's mean radius ratio, then each free vertex moved uphill on its star's summed radius
/// ratio. Every change keeps the local worst dihedral quality at least min(its old value,
/// RR_TQ_FLOOR). Returns how many changes were accepted.
pub(super) fn mean_quality_round(ctx: &mut Ctx, m: &mut TetMesh) -> Result<usize, Error> {
    let mut changes = 0;
    // The swaps: a change replacing old tets by new ones raises the mean when
    // new_sum - old_sum > mean (new_count - old_count). Only swaps that replace a tet well
    // below the mean pay: the candidates are the edges and faces of those tets.
    let ids: Vec<TetId> = m.tet_ids().collect();
    let rrs: Vec<f64> = {
        let mesh = &*m;
        ids.par_iter().with_min_len(CHUNK).map(|&t| crate::quality::tet_radius_ratio(mesh.tet_points(t))).collect()
    };
    let mean = rrs.iter().sum::<f64>() / rrs.len().max(1) as f64;
    let poor: Vec<TetId> = ids.iter().zip(&rrs).filter(|x| *x.1 < mean - RR_SWAP_MARGIN).map(|x| *x.0).collect();
    // The edges worth a look are found in parallel on the unchanged mesh, then taken in order
    // (each recomputed, since an earlier change may have touched it).
    let edges: Vec<(TVertexId, TVertexId)> = {
        let mut all: Vec<(TVertexId, TVertexId)> = poor
            .iter()
            .flat_map(|&t| {
                let v = m.tet(t).v;
                EDGE_VERTICES.map(|[i, j]| (v[i].min(v[j]), v[i].max(v[j])))
            })
            .collect();
        all.sort_unstable();
        all.dedup();
        let mesh = &*m;
        let pays: Vec<bool> = all
            .par_iter()
            .with_min_len(256)
            .map(|&(a, b)| mesh.edge_shell_of(a, b).is_some_and(|s| mean_ring_patch(mesh, &s, mean).is_some()))
            .collect();
        all.into_iter().zip(pays).filter(|x| x.1).map(|x| x.0).collect()
    };
    for (a, b) in edges {
        if !m.contains_vertex(a) || !m.contains_vertex(b) {
            continue;
        }
        let Some(s) = m.edge_shell_of(a, b) else { continue };
        if let Some(plan) = mean_ring_patch(m, &s, mean) {
            m.apply_patch(plan);
            ctx.report.ops.flips += 1;
            changes += 1;
        }
    }
    for t in poor {
        for f in 0..4 {
            if !m.contains_tet(t) {
                break;
            }
            let tx = *m.tet(t);
            let Some((u, j)) = tx.adj[f] else { continue };
            if m.tet(u).label != tx.label {
                continue;
            }
            let d = m.pos(tx.v[f]);
            let e = m.pos(m.tet(u).v[j as usize]);
            let [p, q, r] = m.face_vertices(t, f).map(|v| m.pos(v));
            let new = [[p, q, d, e], [q, r, d, e], [r, p, d, e]];
            if new.iter().any(|x| orient3d(x[0], x[1], x[2], x[3]) != Sign::Positive) {
                continue;
            }
            let (pt, pu) = (m.tet_points(t), m.tet_points(u));
            let old_min = tet_dihedral_quality(pt).min(tet_dihedral_quality(pu));
            let new_min = new.iter().map(|&x| tet_dihedral_quality(x)).fold(f64::INFINITY, f64::min);
            if new_min < old_min.min(RR_TQ_FLOOR) {
                continue;
            }
            let rr = crate::quality::tet_radius_ratio;
            let gain = new.iter().map(|&x| rr(x)).sum::<f64>() - rr(pt) - rr(pu) - mean;
            if gain > RR_GAIN {
                if let Ok(plan) = m.check_flip23(t, f) {
                    m.apply_patch(plan);
                    ctx.report.ops.flips += 1;
                    changes += 1;
                    break;
                }
            }
        }
    }
    // The smoothing.
    Ok(changes + coloured_smoothing(ctx, m, None, mean_smooth_target)?)
}

/// The removal of an interior edge whose ring triangulation (the engine's, on the summed
/// radius ratio, every tet above the dihedral floor) raises the mean radius ratio.
fn mean_ring_patch(m: &TetMesh, s: &EdgeShell, mean: f64) -> Option<TetPatch> {
    let n = s.ring.len();
    if !s.closed || !(3..=7).contains(&n) {
        return None;
    }
    let rr = crate::quality::tet_radius_ratio;
    let mut old_sum = 0.0;
    let mut old_min = f64::INFINITY;
    for &t in &s.tets {
        let p = m.tet_points(t);
        old_sum += rr(p);
        old_min = old_min.min(tet_dihedral_quality(p));
    }
    let floor = old_min.min(RR_TQ_FLOOR);
    let quality = |p: [DVec3; 4]| if tet_dihedral_quality(p) < floor { -1.0 } else { rr(p) };
    // 2n - 4 tets replace n.
    let more = 2.0 * n as f64 - 4.0 - n as f64;
    let pays = |new_sum: f64| new_sum - old_sum - mean * more > RR_GAIN;
    m.ring_retriangulation(s, quality, Objective::Sum, pays).ok().map(|(plan, _)| plan)
}
