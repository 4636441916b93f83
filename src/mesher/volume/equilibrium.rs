//! The force loop: bar forces, boundary projection, step control, Lawson flips, sliver swaps,
//! removal of flat boundary tets, density control and the stop tests; and the rounds of the
//! passes after it.

use super::boundary::{clear_the_way, surface_flips};
use super::carve::{carve, stuck_tets};
use super::density::density_control;
use super::improve::try_swaps;
use super::report::QualityStats3;
use super::snapshot::{mean_rr, write_back, PhaseClock, Snapshot};
use super::{Ctx, CHUNK, GEPS};
use crate::mesher::truss::NodeKind;
use crate::mesher::truss::{self, bar_force, det_sum, RestScale};
use crate::mesher::StopReason;
use crate::quality::{dihedral_quality_cos_bounds, tet_dihedral_quality, tet_dihedral_quality_below};
use crate::topology::{TetId, TetMesh, VertexTag};
use crate::Error;
use glam::DVec3;
use rayon::prelude::*;
use slotmap::SecondaryMap;
use std::time::Instant;

/// Tets below this dihedral quality get quality-driven swaps every iteration.
const SWAP_TQ: f64 = 0.5;
/// A tet no swap could improve is tried again only this many iterations later.
const SWAP_RETRY: usize = 10;
/// Density control runs every this many iterations.
const DENSITY_EVERY: usize = 10;
/// The force loop stops on a plateau: the best mean radius ratio, sampled every DENSITY_EVERY
/// iterations, rose by less than this per sample over the last PLATEAU_WINDOWS samples (taken
/// over the span: on large meshes single samples wobble long after the trend is flat).
const QUALITY_PLATEAU: f64 = 1e-4;
const PLATEAU_WINDOWS: usize = 4;
/// Lawson flips and sliver swaps come at the end of windows of this many steps, with one
/// snapshot rebuild (at every step they would cost more than the forces).
const TOPO_EVERY: usize = 5;

/// Runs `step` for up to `rounds` rounds, stopping after a round that changed nothing (or, with
/// `min_gain`, raised the mean radius ratio by less than that); with tracing on, prints the
/// dihedral range and the mean radius ratio after each.
pub(super) fn repeat_rounds(
    ctx: &mut Ctx,
    mesh: &mut TetMesh,
    rounds: usize,
    name: &str,
    min_gain: Option<f64>,
    mut step: impl FnMut(&mut Ctx, &mut TetMesh, usize) -> Result<usize, Error>,
) -> Result<(), Error> {
    let mut last_rr = min_gain.map(|_| QualityStats3::of(mesh).rr_mean);
    for round in 0..rounds {
        let t = Instant::now();
        let changed = step(ctx, mesh, round)?;
        if ctx.trace {
            let q = QualityStats3::of(mesh);
            eprintln!(
                "{name} {round}: {changed} changes, dihedral {:.2} .. {:.2}, rr mean {:.4}, {:.2} s",
                q.dihedral_min,
                q.dihedral_max,
                q.rr_mean,
                t.elapsed().as_secs_f64()
            );
        }
        if changed == 0 {
            break;
        }
        if let (Some(gain), Some(last)) = (min_gain, last_rr) {
            let now = QualityStats3::of(mesh).rr_mean;
            if now - last < gain {
                break;
            }
            last_rr = Some(now);
        }
    }
    Ok(())
}

pub(super) fn equilibrium(ctx: &mut Ctx, m: &mut TetMesh) -> Result<(), Error> {
    let opts = ctx.opts;
    let h0 = opts.h0;
    let mut snap = Snapshot::build(m);
    m.open_journal();
    let mut p: Vec<DVec3> = snap.ids.iter().map(|&v| m.pos(v)).collect();
    let mut pold = p.clone();
    let uniform = opts.size.is_none();
    let sizes = |ctx: &Ctx, p: &[DVec3]| -> Result<Vec<f64>, Error> {
        if uniform {
            Ok(vec![1.0; p.len()])
        } else {
            p.par_iter().with_min_len(256).map(|&x| ctx.h(x)).collect()
        }
    };
    let mut hv = sizes(ctx, &p)?;
    let mut plateau = truss::Plateau::over_span(QUALITY_PLATEAU, PLATEAU_WINDOWS);
    let mut stop = StopReason::IterationCap { max_iter: opts.max_iter };
    let mut iter = 0;
    let mut tried: SecondaryMap<TetId, usize> = SecondaryMap::new();
    let mut clock = PhaseClock::new();
    let mut stuck: Vec<TetId> = Vec::new();
    while iter < opts.max_iter {
        clock.lap("stop tests and trace");
        iter += 1;
        if let Some(cb) = &opts.progress {
            cb(iter, opts.max_iter);
        }
        // Seed eq. 2.6 in 3-D: L0 = h_bar Fscale (sum L^3 / sum h_bar^3)^(1/3).
        let sums = det_sum(p.len(), |i| {
            let mut s = (0.0, 0.0);
            for &j in snap.row(i) {
                let j = j as usize;
                if j == i {
                    continue;
                }
                let (l, h) = RestScale::terms(3, p[i].distance_squared(p[j]), 0.5 * (hv[i] + hv[j]));
                s.0 += l;
                s.1 += h;
            }
            s
        });
        let rest = RestScale::from_sums(3, sums);
        let unit = rest.unit();
        let scale = rest.scale(opts.fscale);
        let dt = opts.deltat;
        let mut newp: Vec<DVec3> = (0..p.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|i| {
                if snap.kind[i] == NodeKind::Fixed {
                    return p[i];
                }
                let mut f = DVec3::ZERO;
                for &j in snap.row(i) {
                    let j = j as usize;
                    let d = p[i] - p[j];
                    f += bar_force(d, d.length(), 0.5 * (hv[i] + hv[j]) * scale);
                }
                p[i] + dt * f
            })
            .collect();
        clock.lap("forces");
        // Boundary nodes back onto d = 0 (seed step 7, applied to every boundary node: the
        // boundary is the carved mesh's, not the set of nodes outside).
        let fixes: Vec<(usize, DVec3)> = (0..p.len())
            .into_par_iter()
            .with_min_len(256)
            .filter(|&i| snap.kind[i] == NodeKind::Boundary)
            .map(|i| Ok((i, ctx.project(newp[i])?.unwrap_or(p[i]))))
            .collect::<Result<_, Error>>()?;
        for (i, q) in fixes {
            newp[i] = q;
        }
        clock.lap("projection");
        snap.guard_inversions(&p, &mut newp);
        snap.guard_boundary_folds(&p, &mut newp, ctx.strict_folds);
        clock.lap("step control");
        let max_move = (0..p.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .filter(|&i| snap.kind[i] == NodeKind::Interior)
            .map(|i| newp[i].distance(p[i]) / (h0 * hv[i]))
            .reduce(|| 0.0, f64::max);
        p = newp;

        // Connectivity: faces around nodes that moved farther than TTOL since their last check
        // get the exact insphere test, and Lawson flips repair them.
        let mut topo_changed = false;
        let window_end = iter % TOPO_EVERY == 0;
        let far: Vec<bool> = if window_end {
            (0..p.len())
                .into_par_iter()
                .with_min_len(CHUNK)
                .map(|i| p[i].distance(pold[i]) > truss::TTOL * h0 * hv[i])
                .collect()
        } else {
            Vec::new()
        };
        if far.iter().any(|&x| x) {
            let mut stack: Vec<(TetId, usize)> = Vec::new();
            for (k, t) in snap.tets.iter().enumerate() {
                if t.iter().any(|&i| far[i as usize]) {
                    for f in 0..4 {
                        stack.push((snap.tet_ids[k], f));
                    }
                }
            }
            for i in 0..p.len() {
                if far[i] {
                    pold[i] = p[i];
                }
            }
            write_back(m, &snap, &p);
            let flips = m.lawson(stack);
            ctx.report.ops.flips += flips;
            topo_changed |= flips > 0;
        }
        clock.lap("delaunay flips");
        // Quality-driven swaps: the tets below SWAP_TQ, worst first, get the best edge removal
        // or 2-3 flip that raises the local worst quality (Lawson alone stalls in 3-D).
        if window_end {
            let (cl, ch) = dihedral_quality_cos_bounds(SWAP_TQ);
            let mut bad: Vec<(f64, usize)> = (0..snap.tets.len())
                .into_par_iter()
                .with_min_len(CHUNK)
                .filter_map(|k| {
                    let q = snap.tets[k].map(|i| p[i as usize]);
                    tet_dihedral_quality_below(q, cl, ch).then(|| (tet_dihedral_quality(q), k))
                })
                .collect();
            if !bad.is_empty() {
                bad.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                write_back(m, &snap, &p);
                for (_, k) in bad {
                    let t = snap.tet_ids[k];
                    // A tet no swap could improve waits SWAP_RETRY iterations before the next try.
                    // (Screening these in parallel, as the polish does, changed which swaps the
                    // loop makes and cost the unit ball at h0 = 0.15 0.04 points of volume.)
                    if tried.get(t).is_some_and(|&at| iter < at + SWAP_RETRY) {
                        continue;
                    }
                    if m.contains_tet(t) {
                        if try_swaps(ctx, m, t)? {
                            topo_changed = true;
                        } else {
                            tried.insert(t, iter);
                        }
                    }
                }
            }
        }
        clock.lap("sliver swaps");
        // Tets squashed against the boundary (centroid within geps of d = 0) leave the mesh, as
        // the seed's retriangulation drops them: their interior apex joins the boundary.
        let flat: Vec<usize> = (0..snap.tets.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .filter(|&k| snap.tets[k].iter().filter(|&&i| snap.kind[i as usize] != NodeKind::Interior).count() >= 3)
            .map(|k| {
                let t = snap.tets[k];
                let c = (p[t[0] as usize] + p[t[1] as usize] + p[t[2] as usize] + p[t[3] as usize]) / 4.0;
                let hc = t.iter().map(|&i| hv[i as usize]).sum::<f64>() / 4.0;
                Ok((k, ctx.approx_dist(c)? > -GEPS * h0 * hc))
            })
            .collect::<Result<Vec<_>, Error>>()?
            .into_iter()
            .filter(|x| x.1)
            .map(|x| x.0)
            .collect();
        // Removals happen at most steps, and a snapshot rebuild at every step cost more than
        // the forces: the snapshot is patched instead. A tet with one boundary face keeps every
        // vertex and edge (its apex joins the boundary); with two, the edge both boundary faces
        // share goes from the neighbour lists. Three take a vertex with them: that rebuilds.
        let mut joined: Vec<usize> = Vec::new();
        let mut lost: Vec<(usize, usize)> = Vec::new();
        let mut gone: Vec<usize> = Vec::new();
        if !flat.is_empty() {
            write_back(m, &snap, &p);
            for k in flat {
                let t = snap.tet_ids[k];
                if !m.contains_tet(t) {
                    continue;
                }
                let Ok(faces) = m.check_remove_boundary_tet(t) else { continue };
                // With two boundary faces, the edge they share lies in this tet only.
                let local = m.tet(t).adj.map(|a| a.is_some());
                if m.remove_boundary_tet(t).is_ok() {
                    ctx.report.ops.removed += 1;
                    if faces <= 2 {
                        joined.extend(snap.tets[k].iter().map(|&i| i as usize));
                        gone.push(k);
                    }
                    if faces == 2 {
                        let mut e = snap.tets[k].iter().zip(local).filter(|x| x.1).map(|x| *x.0 as usize);
                        lost.push((e.next().expect("edge"), e.next().expect("edge")));
                    }
                    if faces > 2 {
                        topo_changed = true;
                    }
                }
            }
        }
        clock.lap("boundary tets");
        if iter % DENSITY_EVERY == 0 {
            write_back(m, &snap, &p);
            topo_changed |= surface_flips(ctx, m)? > 0;
            topo_changed |= density_control(ctx, m, &snap, &p, &hv, unit)?;
            // Boundary nodes the step control kept off d = 0: the tets in the way are swapped
            // away or their vertices smoothed, then the node moves.
            let off: Vec<usize> = (0..p.len())
                .into_par_iter()
                .with_min_len(CHUNK)
                .filter(|&i| snap.kind[i] == NodeKind::Boundary)
                .map(|i| Ok((i, ctx.approx_dist(p[i])?.abs() > 1e-3 * h0)))
                .collect::<Result<Vec<_>, Error>>()?
                .into_iter()
                .filter(|x| x.1)
                .map(|x| x.0)
                .collect();
            for i in off {
                let v = snap.ids[i];
                if !m.contains_vertex(v) {
                    continue;
                }
                if let Some(q) = ctx.project(m.pos(v))? {
                    clear_the_way(ctx, m, v, q)?;
                    topo_changed = true;
                }
            }
        }
        // Squashed tets the local removal refused at two checks in a row go together (rare:
        // most are squashed for a step or two and then leave one by one).
        let mut carved = false;
        if iter % DENSITY_EVERY == 0 {
            // (The positions were written back at the start of the density block.)
            let now = stuck_tets(ctx, m)?;
            let again: Vec<TetId> = now.iter().copied().filter(|t| stuck.binary_search(t).is_ok()).collect();
            carved = carve(ctx, m, &again)?;
            if carved {
                if ctx.trace {
                    eprintln!("iter {iter}: {} stuck squashed tets carved, the mesh rebuilt", again.len());
                }
                topo_changed = true;
                tried.clear();
                stuck.clear();
            } else {
                stuck = now;
                stuck.sort_unstable();
            }
        }
        clock.lap("density");
        if topo_changed {
            // Density control may grow the mesh past what the survey estimated.
            if m.num_tets() as u64 > opts.max_elements {
                return Err(Error::TooManyElements { estimated: m.num_tets() as u64, limit: opts.max_elements });
            }
            // Only the rows of the vertices the changes touched are recomputed.
            let journal = m.take_journal().unwrap_or_default();
            if carved || !snap.refresh(m, &journal) {
                snap = Snapshot::build(m);
            }
            m.open_journal();
            // A dead entry keeps its last position (nothing reads it).
            let old = std::mem::take(&mut p);
            p = snap
                .ids
                .iter()
                .enumerate()
                .map(|(k, &v)| if m.contains_vertex(v) { m.pos(v) } else { old[k] })
                .collect();
            pold = p.clone();
            hv = sizes(ctx, &p)?;
        } else if !joined.is_empty() {
            // The state a rebuild would give: the apexes' new kind, the tets in arena order
            // without the removed ones, the movement references reset.
            for i in joined {
                if snap.kind[i] == NodeKind::Interior && m.tag(snap.ids[i]) == VertexTag::Boundary {
                    snap.kind[i] = NodeKind::Boundary;
                }
            }
            for (a, b) in lost {
                snap.remove_edge(a, b);
            }
            let removed: Vec<[u32; 4]> = gone.iter().map(|&k| snap.tets[k]).collect();
            snap.remove_tets(&gone);
            snap.patch_rings(m, &removed);
            pold.copy_from_slice(&p);
            hv = sizes(ctx, &p)?;
        } else if !uniform && iter % DENSITY_EVERY == 0 {
            hv = sizes(ctx, &p)?;
        }
        clock.lap("snapshot");
        if truss::stop::at_rest(max_move, opts.dptol, iter, DENSITY_EVERY) {
            stop = StopReason::AtRest { dptol: opts.dptol };
            break;
        }
        if iter % DENSITY_EVERY == 0 {
            let q = mean_rr(&snap, &p);
            if ctx.trace {
                write_back(m, &snap, &p);
                let mut nd = 0;
                let (mut si, mut ni, mut sb, mut nb) = (0.0, 0, 0.0, 0);
                let mut bins = [0usize; 6];
                for (k, t) in snap.tets.iter().enumerate() {
                    let tt = snap.tet_ids[k];
                    for f in 0..4 {
                        if !m.is_locally_delaunay(tt, f) {
                            nd += 1;
                        }
                    }
                    let q = crate::quality::tet_radius_ratio(t.map(|i| p[i as usize]));
                    let qq = tet_dihedral_quality(t.map(|i| p[i as usize]));
                    bins[((qq.max(0.0) * 10.0) as usize).min(5)] += 1;
                    if t.iter().all(|&i| snap.kind[i as usize] == NodeKind::Interior) {
                        si += q;
                        ni += 1;
                    } else {
                        sb += q;
                        nb += 1;
                    }
                }
                eprintln!(
                    "   non-delaunay faces {nd}, interior rr {:.4} ({ni}), boundary rr {:.4} ({nb}), tq bins {bins:?}",
                    si / ni as f64,
                    sb / nb as f64
                );
                eprintln!(
                    "iter {iter}: rr mean {q:.5}, max move {max_move:.2e}, {} vertices, {} tets, flips {} splits {} collapses {} removed {}",
                    p.len(),
                    snap.tets.len(),
                    ctx.report.ops.flips,
                    ctx.report.ops.splits,
                    ctx.report.ops.collapses,
                    ctx.report.ops.removed
                );
            }
            if plateau.reached(q) {
                stop = StopReason::QualityPlateau;
                break;
            }
        }
    }
    clock.lap("stop tests and trace");
    if ctx.trace {
        eprintln!("force loop: {}", clock.summary());
    }
    write_back(m, &snap, &p);
    m.take_journal();
    ctx.report.stopped(iter, stop);
    Ok(())
}
