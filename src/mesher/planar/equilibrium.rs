use super::best::{state_q_min, state_worst, BestState};
use super::held::{HeldCore, CORE_RINGS, RIM_DRIFT};
use super::*;
use crate::mesher::StopReason;

/// Density control runs every this many iterations (a window).
pub(super) const DENSITY_EVERY: usize = 10;
/// The window of large meshes (over RELAYOUT_ABOVE vertices): one topology update and one
/// full sweep per window, which at 10^6 triangles cost more than the partial steps between.
pub(super) const LARGE_WINDOW: usize = 20;
/// Between full sweeps, a node that moved less than this many local sizes in a step, with
/// neighbours that did too, is settled and skipped (a tenth of the default dptol).
pub(super) const SETTLE: f64 = 5e-4;
/// The run stops on a quality plateau: the mean quality, sampled at the end of every window,
/// rose less than this above the best before it in PLATEAU_WINDOWS windows in a row.
pub(super) const QUALITY_PLATEAU: f64 = 1e-6;
pub(super) const PLATEAU_WINDOWS: usize = 30;
/// The run also stops when the mean quality's deficit 1 - q mean fell by less than STALL_GAIN
/// of itself over STALL_WINDOWS windows: a slow mode of the truss (a lattice creeping to fit a
/// straight side, a flip travelling along it) that the forces would take hundreds of
/// iterations more to settle, for a gain the final search and polish give anyway. The seed's
/// rest test "is sometimes too tight, and a high-quality mesh is often achieved long before
/// termination" (seed section 2.3, step 8), and it ends such runs on element qualities.
pub(super) const STALL_GAIN: f64 = 0.1;
pub(super) const STALL_WINDOWS: usize = 20;
/// The stall rule stops a run only while its largest step is below STALL_MOVE times dptol, or
/// its nodes are at rest on the whole: no node got farther than dptol per iteration over the
/// window (its net move over the window's iterations). The slow modes creep just above dptol,
/// while a graded run still relaxing takes larger steps (stopped early, it leaves the search
/// more to do, and the whole run is no faster); a node swinging back and forth by a fixed step
/// (a boundary node stepping inside and projected back, every other step) gets nowhere, and
/// no longer holds the run to the iteration cap.
pub(super) const STALL_MOVE: f64 = 3.0;
/// With a metric, density control splits above and collapses below these metric lengths
/// (wider bands leave the truss too coarse inside and too crowded in a boundary layer).
pub(super) const METRIC_BAND: DensityBand = DensityBand::new(1.45, 0.65);
/// Density control from a previous mesh (moving meshes, remeshing): a narrower band, as areas
/// change and a fresh start's wide band would let a growing region coarsen twofold.
pub(super) const MOVING_BAND: DensityBand = DensityBand::new(1.5, 0.6);
/// Density control of a moving-mesh step with freezing: collapses from 0.82 target lengths,
/// before the distortion a moving boundary leaves behind is frozen into its wake.
pub(super) const FREEZING_BAND: DensityBand = DensityBand::new(1.5, 0.82);
/// The force loop (seed section 2.3): forward Euler steps of the truss with boundary
/// projection and step control, connectivity by exact in-circle flips, boundary membership
/// and density control every window, until the nodes rest or the quality stops rising.
pub(super) fn equilibrium(ctx: &mut Ctx, m: &mut TriMesh<DVec2>) -> Result<(), Error> {
    let opts = ctx.opts;
    let h0 = opts.h0;
    let metric = ctx.metric;
    let uniform = opts.size.is_none() && metric.is_none();
    // A large uniform fresh mesh holds its core (see `held`): the arrays cover the band near
    // the boundary only.
    let mut core = if uniform
        && m.num_vertices() > RELAYOUT_ABOVE
        && ctx.internal.is_none()
        && !ctx.from_previous
        && !ctx.freezing
    {
        HeldCore::find(m, CORE_RINGS)
    } else {
        None
    };
    let build = |m: &TriMesh<DVec2>, core: &Option<HeldCore>| match core {
        Some(c) => Snapshot::build_band(m, &c.held),
        None => Snapshot::build(m),
    };
    let mut snap = build(m, &core);
    let mut p: Vec<DVec2> = snap.ids.iter().map(|&v| m.pos(v)).collect();
    if let Some(c) = &mut core {
        c.measure(ctx, m, &snap, &p);
    }
    // Positions at the last connectivity check (the seed's pold).
    let mut pold: Vec<DVec2> = p.clone();
    let mut hv: Vec<f64> = vec![1.0; p.len()];
    // With a metric: M at each vertex, and the mean metric edge length (sqrt of the mean
    // square) for the boundary spacing rule.
    let mut mv: Vec<Metric2> = Vec::new();
    let mut munit = 1.0;
    let mut slots: Vec<u32> = Vec::new();
    let mut plateau = truss::Plateau::every_window(QUALITY_PLATEAU, PLATEAU_WINDOWS);
    // The deficit 1 - q mean on a log scale: a gain of STALL_GAIN is a fall of that fraction.
    let mut stall = truss::Plateau::since_mark(-(1.0 - STALL_GAIN).ln(), STALL_WINDOWS, f64::NEG_INFINITY);
    // Not with a metric or from a previous mesh (short runs, whose density bands keep edges
    // moving that a fresh isotropic truss would have settled), nor with internal curves (no
    // search or polish follows the loop there).
    let stall_applies = metric.is_none() && ctx.internal.is_none() && !ctx.from_previous;
    let mut drift_start: Vec<DVec2> = if stall_applies { p.clone() } else { Vec::new() };
    let mut drift_from = 0usize;
    let mut rebuilds = 0usize;
    let mut stop = StopReason::IterationCap { max_iter: opts.max_iter };
    let mut iter = 0;
    let mut unit = h0;
    // The active set: between full sweeps only nodes that moved more than SETTLE local sizes
    // in the last step, and their neighbours, get forces. A settled region keeps its forces
    // (nothing in it moved), so skipping it changes nothing but the cost: the lattice interior
    // of the start is in equilibrium from the first step, and most of the run is spent near
    // the boundary. Full sweeps: the first step after a topology change, the first step of
    // every window (the size scale of eq. 2.6 is summed on full sweeps only), and every step
    // with a metric or from a previous mesh (short runs of a few steps that must undo a distortion
    // everywhere) or of a small mesh (a sweep costs microseconds there).
    let large = p.len() > RELAYOUT_ABOVE;
    let window = if large { LARGE_WINDOW } else { DENSITY_EVERY };
    let mut newp = p.clone();
    // Nodes that moved more than SETTLE in the last step.
    let mut moved: Vec<u32> = Vec::new();
    let mut need_full = true;
    let mut scale_sums = (0.0, 0.0);
    let mut flags = Flags::default();
    let mut swept = 0usize;
    let mut build_s = 0.0;
    let (mut full_s, mut part_s, mut full_n, mut end_s) = (0.0, 0.0, 0usize, 0.0);
    // The best state met, for the iteration cap (not in a moving-mesh step with frozen nodes,
    // whose vertex keys must survive the loop).
    let mut best = BestState::default();
    let t_loop = Instant::now();
    if std::env::var_os("TRUSSMESH_TRACE").is_some() {
        eprintln!("equilibrium entered, peak {}", peak_memory());
        let mut val = [0usize; 12];
        for i in 0..p.len() {
            if snap.kind[i] == NodeKind::Interior {
                val[((snap.adj_start[i + 1] - snap.adj_start[i]) as usize).min(11)] += 1;
            }
        }
        eprintln!(
            "start: q mean {:.5}, {} vertices ({} fixed, {} held), interior valences {:?}, peak {}",
            whole_mean_quality(ctx, &core, &snap, &p),
            p.len(),
            snap.kind[..snap.n_band].iter().filter(|&&k| k == NodeKind::Fixed).count(),
            core.as_ref().map_or(0, |c| c.held.len()),
            val,
            peak_memory()
        );
    }
    while iter < opts.max_iter {
        iter += 1;
        if let Some(cb) = &opts.progress {
            cb(iter, opts.max_iter);
        }
        let ti = Instant::now();
        let full = need_full || !large || metric.is_some() || ctx.from_previous || iter % window == 1;
        need_full = false;
        let active: Vec<u32> =
            if full { (0..p.len() as u32).collect() } else { snap.with_neighbours(&moved, &mut flags) };
        swept += active.len();
        if metric.is_some() {
            mv = p.par_iter().map(|&x| ctx.metric_at(x)).collect::<Result<Vec<Metric2>, Error>>()?;
            hv = mv.par_iter().map(|m| m.smallest_size() / h0).collect();
        } else if !uniform {
            let hs = active.par_iter().map(|&i| ctx.h(p[i as usize])).collect::<Result<Vec<f64>, Error>>()?;
            for (&i, h) in active.iter().zip(hs) {
                hv[i as usize] = h;
            }
        }
        // With a metric: every edge's metric length, integrated along it (Simpson's rule
        // with M at the endpoints and the midpoint), indexed by adjacency slot.
        let el: Vec<f64> = if metric.is_some() {
            if slots.len() != snap.adj.len() {
                slots = adjacency_edges(&snap);
            }
            let lens = snap
                .edges
                .par_iter()
                .with_min_len(CHUNK)
                .map(|&(a, b, _, _)| {
                    let (a, b) = (a as usize, b as usize);
                    let mm = ctx.metric_at((p[a] + p[b]) * 0.5)?;
                    Ok(metric::simpson_length(&mv[a], &mm, &mv[b], p[b] - p[a]))
                })
                .collect::<Result<Vec<f64>, Error>>()?;
            slots.iter().map(|&e| lens[e as usize]).collect()
        } else {
            Vec::new()
        };
        // Seed eq. 2.6: L0 = h_bar Fscale sqrt(sum L^2 / sum h_bar^2); with a metric every
        // desired length is one, so L0 = Fscale sqrt(mean of the squared metric lengths).
        let node_sums = |i: usize| {
            if metric.is_some() {
                let mut s = (0.0, 0.0);
                for k in snap.adj_start[i]..snap.adj_start[i + 1] {
                    let l = el[k as usize];
                    s.0 += l * l;
                    s.1 += 1.0;
                }
                return s;
            }
            let mut s = (0.0, 0.0);
            for k in snap.adj_start[i]..snap.adj_start[i + 1] {
                let j = snap.adj[k as usize] as usize;
                let (l, h) = RestScale::terms(2, p[i].distance_squared(p[j]), 0.5 * (hv[i] + hv[j]));
                s.0 += l;
                s.1 += h;
            }
            s
        };
        // Summed on full sweeps only and kept in between: the premise of the active set is that
        // a settled node's forces stand, and they would not if the scale moved under them.
        // (Partial steps run only on large meshes, whose scale sums hundreds of thousands of
        // bars, most of them settled.)
        if full {
            scale_sums = det_sum(p.len(), node_sums);
            if let Some(c) = &core {
                scale_sums = c.scale_sums(scale_sums);
            }
        }
        let rest = RestScale::from_sums(2, scale_sums);
        let scale = rest.scale(opts.fscale);
        // With a metric: the boundary pushes back on interior nodes through a bar to their
        // mirror image across d = 0, of rest length twice an equilateral height (sqrt 3 L0):
        // a boundary chord alone barely resists a node approaching it along the normal, and
        // in a boundary layer the chord's sagitta is a large part of the first row's height.
        let wall: Vec<DVec2> = if metric.is_some() {
            (0..p.len())
                .into_par_iter()
                .with_min_len(CHUNK)
                .map(|i| {
                    if snap.kind[i] != NodeKind::Interior {
                        return Ok(DVec2::ZERO);
                    }
                    let d = ctx.approx_dist(p[i])?;
                    let g = ctx.domain.gradient(p[i]);
                    let n = g.normalize_or_zero();
                    if d >= 0.0 || n == DVec2::ZERO {
                        return Ok(DVec2::ZERO);
                    }
                    let v = n * (2.0 * d); // from the mirror image to p (inward)
                    let l = mv[i].length(v);
                    let rest = 3f64.sqrt() * scale;
                    Ok(if l > 0.0 && l < rest { v * ((rest - l) / l) } else { DVec2::ZERO })
                })
                .collect::<Result<Vec<DVec2>, Error>>()?
        } else {
            Vec::new()
        };
        // Forces gathered per vertex (deterministic in parallel), forward Euler step.
        let dt = opts.deltat;
        let stepped: Vec<DVec2> = active
            .par_iter()
            .with_min_len(CHUNK)
            .map(|&i| {
                let i = i as usize;
                if snap.kind[i] == NodeKind::Fixed {
                    return p[i];
                }
                let mut f = DVec2::ZERO;
                if metric.is_some() {
                    for k in snap.adj_start[i]..snap.adj_start[i + 1] {
                        let j = snap.adj[k as usize] as usize;
                        f += bar_force(p[i] - p[j], el[k as usize], scale);
                    }
                    return p[i] + dt * (f + wall[i]);
                }
                for k in snap.adj_start[i]..snap.adj_start[i + 1] {
                    let j = snap.adj[k as usize] as usize;
                    let d = p[i] - p[j];
                    f += bar_force(d, d.length(), 0.5 * (hv[i] + hv[j]) * scale);
                }
                p[i] + dt * f
            })
            .collect();
        for (&i, q) in active.iter().zip(stepped) {
            newp[i as usize] = q;
        }
        // Interior movement before projection: the seed's stop criterion.
        let step = |i: usize, q: &[DVec2]| {
            if metric.is_some() {
                mv[i].length(q[i] - p[i])
            } else {
                q[i].distance(p[i]) / (h0 * hv[i])
            }
        };
        let interior_move = active
            .par_iter()
            .with_min_len(CHUNK)
            .map(|&i| i as usize)
            .filter(|&i| snap.kind[i] == NodeKind::Interior)
            .map(|i| step(i, &newp))
            .reduce(|| 0.0, f64::max);
        // Boundary membership follows the forces, as the seed's retriangulation lets it: a
        // boundary node whose raw step ends inside the chord of its boundary neighbours leaves
        // the boundary; an interior node whose raw step crosses the boundary edge below it joins.
        let mut leaving: Vec<(usize, DVec2)> = Vec::new();
        for &i in &active {
            let i = i as usize;
            if snap.kind[i] == NodeKind::Boundary && snap.loop_nbrs[i].0 != u32::MAX {
                let (a, c) = snap.loop_nbrs[i];
                if orient2d(p[a as usize], newp[i], p[c as usize]) == Sign::Positive {
                    leaving.push((i, newp[i]));
                }
            }
        }
        // Topology follows in index order, whatever the order of the active list.
        leaving.sort_unstable_by_key(|l| l.0);
        let mut joining: Vec<usize> = snap
            .apexes
            .iter()
            .filter(|&&(v, a, b)| {
                // Not with a metric: the mirror bar keeps nodes off the boundary there, and
                // nodes joining a chord deep inside a thin layer only get collapsed again.
                if metric.is_some() {
                    return false;
                }
                let (pa, pb, pv) = (p[a as usize], p[b as usize], newp[v as usize]);
                // Crossing the boundary edge; when starting from a previous mesh, also squashed
                // flat onto it (the carried boundary rows leave such slivers behind).
                orient2d(pa, pb, pv) != Sign::Positive || (ctx.from_previous && ctx.tri_q([pa, pb, pv]) < EAR_Q)
            })
            .map(|&(v, _, _)| v as usize)
            .collect();
        // Boundary nodes back onto d = 0; interior nodes must stay inside. d is evaluated in
        // batches over the active nodes (one call of a batch geometry per set, see
        // `Implicit2::values`), and so are the projections.
        let probed: Vec<usize> = active
            .iter()
            .map(|&i| i as usize)
            .filter(|&i| matches!(snap.kind[i], NodeKind::Boundary | NodeKind::Interior))
            .collect();
        let dnew = ctx.approx_dists(&probed.iter().map(|&i| newp[i]).collect::<Vec<_>>())?;
        // Free inside only where a boundary node could leave the boundary: over a concave
        // stretch (the chord of its neighbours outside) it is held on d = 0.
        let chords: Vec<usize> = probed
            .iter()
            .copied()
            .filter(|&i| snap.kind[i] == NodeKind::Boundary && snap.loop_nbrs[i].0 != u32::MAX)
            .collect();
        let mids: Vec<DVec2> = chords
            .iter()
            .map(|&i| {
                let (a, c) = snap.loop_nbrs[i];
                (p[a as usize] + p[c as usize]) * 0.5
            })
            .collect();
        let dmid = ctx.approx_dists(&mids)?;
        let mut concave = vec![false; p.len()];
        for (&i, &dc) in chords.iter().zip(&dmid) {
            concave[i] = dc > -ctx.geps;
        }
        // Boundary nodes inside move freely (the carved start's outer row) and are projected
        // once outside (seed step 7), as the pressure keeps them there.
        let to_project: Vec<usize> = probed
            .iter()
            .zip(&dnew)
            .filter(|&(&i, &d)| snap.kind[i] == NodeKind::Boundary && (d > 0.0 || concave[i]))
            .map(|(&i, _)| i)
            .collect();
        let projected = ctx.project_many(&to_project.iter().map(|&i| newp[i]).collect::<Vec<_>>())?;
        let mut fixes: Vec<(usize, DVec2)> = Vec::new();
        for (&i, q) in to_project.iter().zip(projected) {
            fixes.push((i, q.unwrap_or(p[i])));
        }
        // Interior nodes: held where the step leaves the domain, or crosses an internal
        // boundary (marked NaN to join it).
        for (&i, &d) in probed.iter().zip(&dnew) {
            if snap.kind[i] != NodeKind::Interior {
                continue;
            }
            if d > -ctx.geps {
                fixes.push((i, p[i]));
                // An apex over a boundary edge that the forces push out of the domain without
                // crossing the edge (over a concave stretch the chord lies outside) joins the
                // boundary, as the seed's projection of every outside node would make it; held
                // instead, it would press against d = 0 at every step and the run never rest.
                if metric.is_none() && snap.is_apex(i) {
                    joining.push(i);
                }
            } else if ctx.crosses_internal(p[i], newp[i])? {
                fixes.push((i, DVec2::NAN));
            }
        }
        // Internal-boundary nodes back onto d_I = 0 every step: they slide along it, but never
        // past a neighbour along it (near a corner of the curve the projection could jump to
        // the far side of the corner).
        for &i in &active {
            let i = i as usize;
            if snap.kind[i] == NodeKind::Internal {
                let q = match ctx.project_internal(newp[i])? {
                    Some(q) if snap.keeps_curve_order(i, &p, q) => q,
                    _ => p[i],
                };
                fixes.push((i, q));
            }
        }
        joining.sort_unstable();
        joining.dedup();
        fixes.sort_unstable_by_key(|f| f.0);
        let mut joining_internal = Vec::new();
        for (i, q) in fixes {
            if q.is_nan() {
                joining_internal.push(i);
                newp[i] = p[i];
            } else {
                newp[i] = q;
            }
        }
        joining_internal.sort_unstable();
        // Step control: no triangle may invert; vertices of offending triangles step back.
        let tris = if full {
            None
        } else {
            let t = snap.triangles_of(&active, &flags);
            flags.clear(&active);
            Some(t)
        };
        snap.guard_inversions(&p, &mut newp, tris.as_deref(), metric.map(|_| &mv[..]));
        // Without a metric, screened: only steps that could fold are checked exactly.
        if metric.is_some() {
            snap.guard_folds(&p, &mut newp);
        } else {
            snap.guard_folds_screened(&p, &mut newp, tris.as_deref());
        }
        // Boundary nodes count too once the step is taken: a node still travelling to d = 0
        // (a start cut from a previous mesh) is not settled.
        let boundary_move = active
            .par_iter()
            .with_min_len(CHUNK)
            .map(|&i| i as usize)
            .filter(|&i| snap.kind[i] == NodeKind::Boundary || snap.kind[i] == NodeKind::Internal)
            .map(|i| step(i, &newp))
            .reduce(|| 0.0, f64::max);
        let max_move = interior_move.max(boundary_move);
        moved = active.iter().copied().filter(|&i| step(i as usize, &newp) > SETTLE).collect();
        for &i in &active {
            p[i as usize] = newp[i as usize];
        }
        // Connectivity: when some node is far from where it was at the last check (the seed's
        // ttol), every edge gets the exact in-circle test (in parallel) and bad ones flip.
        // Large meshes look only at the end of a window, with density control: a topology
        // change costs a snapshot rebuild and a full sweep, and so they come together, once
        // per window, right before the window's scheduled full sweep. Every node is looked at
        // then (one that moved far early in the window may have settled since).
        let mut topo_changed = false;
        let far_from_last = |i: usize| p[i].distance(pold[i]) > truss::TTOL * h0 * hv[i];
        let far = if !large {
            active.par_iter().with_min_len(CHUNK).any(|&i| far_from_last(i as usize))
        } else {
            iter % window == 0 && (0..p.len()).into_par_iter().with_min_len(CHUNK).any(far_from_last)
        };
        if far {
            let bad = snap.non_delaunay(&p, &pold, metric.map(|_| &*ctx));
            pold.copy_from_slice(&p);
            if !bad.is_empty() {
                write_back(m, &snap, &p);
                let flips = ctx.legalize(m, bad);
                ctx.report.ops.flips += flips;
                topo_changed |= flips > 0;
            }
        }
        // Boundary membership follows the forces, as in the seed's global retriangulation.
        if !leaving.is_empty() || !joining.is_empty() {
            write_back(m, &snap, &p);
            topo_changed |= change_membership(ctx, m, &snap, &leaving, &joining)?;
        }
        if !joining_internal.is_empty() {
            write_back(m, &snap, &p);
            topo_changed |= join_internal(ctx, m, &snap, &joining_internal)?;
        }
        // Density control and repair of bad triangles.
        if iter % window == 0 {
            let mu = metric.map(|_| rest.unit());
            let band = if metric.is_some() {
                METRIC_BAND
            } else if ctx.freezing {
                FREEZING_BAND
            } else if ctx.from_previous {
                MOVING_BAND
            } else {
                FRESH_BAND
            };
            let cands = density_candidates(ctx, &snap, &p, rest.unit(), mu, band)?;
            if !cands.is_empty() {
                write_back(m, &snap, &p);
                let loops = snap.boundary_loops(m);
                topo_changed |= density_control(ctx, m, cands, !large, loops)?;
            }
            if ctx.metric.is_none() {
                // Every topology change so far wrote the positions back before it.
                if !topo_changed {
                    write_back(m, &snap, &p);
                }
                let loops: Vec<VertexId> =
                    snap.loop_edges.iter().map(|e| snap.ids[e[0] as usize]).filter(|&v| m.contains_vertex(v)).collect();
                topo_changed |= close_slits(ctx, m, &loops)?;
            }
            unit = rest.unit();
            munit = unit;
        }
        let el_s = ti.elapsed().as_secs_f64();
        if full {
            full_s += el_s;
            full_n += 1;
        } else {
            part_s += el_s;
            if iter % window == 0 {
                end_s += el_s;
            }
        }
        // The stall rule's net motion, at the end of a window: the largest move since the window
        // began (or the snapshot was rebuilt), per iteration. A node swinging between two places
        // takes steps of a fixed size forever and gets nowhere.
        let drift = if stall_applies && iter % window == 0 {
            let span = (iter - drift_from) as f64;
            let far = (0..p.len())
                .into_par_iter()
                .with_min_len(CHUNK)
                .map(|i| p[i].distance(drift_start[i]) / (h0 * hv[i]))
                .reduce(|| 0.0, f64::max);
            drift_start.copy_from_slice(&p);
            drift_from = iter;
            far / span.max(1.0)
        } else {
            f64::INFINITY
        };
        // The relaxation reached the held core's rim: a wider band (or the whole mesh).
        let widen = iter % window == 0 && core.as_ref().is_some_and(|c| c.reached(&p, RIM_DRIFT * h0));
        if widen {
            write_back(m, &snap, &p);
            let rings = core.as_ref().map_or(0, |c| 2 * c.rings);
            core = HeldCore::find(m, rings);
        }
        if topo_changed || widen {
            rebuilds += 1;
            let tb = Instant::now();
            if let Some(c) = &mut core {
                c.fold_rim(&p);
            }
            // The old arrays go before the new ones come (peak memory).
            drop(std::mem::take(&mut snap));
            snap = build(m, &core);
            build_s += tb.elapsed().as_secs_f64();
            slots.clear();
            p = snap.ids.iter().map(|&v| m.pos(v)).collect();
            if let Some(c) = &mut core {
                if widen {
                    c.measure(ctx, m, &snap, &p);
                } else {
                    c.track_rim(&snap, &p);
                }
            }
            pold = p.clone();
            newp = p.clone();
            if stall_applies {
                drift_start = p.clone();
                drift_from = iter;
            }
            need_full = true;
            hv = vec![1.0; p.len()];
            if metric.is_some() {
                mv = p.par_iter().map(|&x| ctx.metric_at(x)).collect::<Result<Vec<Metric2>, Error>>()?;
                hv = mv.par_iter().map(|m| m.smallest_size() / h0).collect();
            } else if !uniform {
                hv = p.par_iter().map(|&x| ctx.h(x)).collect::<Result<Vec<f64>, Error>>()?;
            }
        }
        // Only a full sweep sees every node's step: a settled node's force may have grown since.
        if full && truss::stop::at_rest(max_move, opts.dptol, iter, window) {
            stop = StopReason::AtRest { dptol: opts.dptol };
            break;
        }
        if iter % window == 0 {
            let q = whole_mean_quality(ctx, &core, &snap, &p);
            let trace = std::env::var_os("TRUSSMESH_TRACE").is_some();
            // Runs with frozen nodes keep no best state: the pass is for the trace only there.
            let (q_min, worst) =
                if !ctx.freezing || trace { state_worst(ctx, &snap, &p) } else { (f64::NAN, usize::MAX) };
            if !ctx.freezing {
                #[cfg(test)]
                super::best::OFFERED.with(|o| o.borrow_mut().push((iter, q_min)));
                if core.is_some() {
                    if best.iteration == 0 || q_min > best.q_min {
                        write_back(m, &snap, &p);
                        best.offer_mesh(m, q_min, iter);
                    }
                } else {
                    best.offer(m, &snap, &p, q_min, iter);
                }
            }
            if trace {
                // Where the worst triangle is, and what its corners are.
                if let Some(&t) = snap.tris.get(worst) {
                    let c = t.iter().map(|&v| p[v as usize]).sum::<DVec2>() / 3.0;
                    let kinds =
                        t.map(|v| (snap.kind[v as usize], snap.adj_start[v as usize + 1] - snap.adj_start[v as usize]));
                    eprintln!("  worst triangle at ({:.4}, {:.4}): corners (kind, valence) {kinds:?}", c.x, c.y);
                }
                eprintln!(
                    "iter {iter} ({:.3} s): q mean {q:.5}, q min {q_min:.4}, max move {max_move:.2e}, {} vertices, flips {} splits {} collapses {} left {} joined {}",
                    t_loop.elapsed().as_secs_f64(),
                    p.len(),
                    ctx.report.ops.flips,
                    ctx.report.ops.splits,
                    ctx.report.ops.collapses,
                    ctx.left,
                    ctx.joined
                );
            }
            if plateau.reached(q) {
                stop = StopReason::QualityPlateau;
                break;
            }
            if stall_applies
                && stall.reached(-(1.0 - q).max(f64::MIN_POSITIVE).ln())
                && (max_move < STALL_MOVE * opts.dptol || drift < opts.dptol)
            {
                stop = StopReason::QualityPlateau;
                break;
            }
        }
    }
    if std::env::var_os("TRUSSMESH_TRACE").is_some() {
        eprintln!(
            "{rebuilds} snapshot rebuilds ({build_s:.3} s) in {iter} iterations, {:.1} full sweeps of force work; {full_n} full steps {full_s:.3} s, {} partial {part_s:.3} s (mean active {:.0}; window ends {end_s:.3} s)",
            swept as f64 / p.len().max(1) as f64,
            iter - full_n,
            swept.saturating_sub(full_n * p.len()) as f64 / (iter - full_n).max(1) as f64
        );
    }
    if std::env::var_os("TRUSSMESH_TRACE").is_some() {
        eprintln!("loop done at {:.3} s of the loop, peak {}", t_loop.elapsed().as_secs_f64(), peak_memory());
    }
    // The iteration cap: the run finishes from the best state met when it beats the last.
    if matches!(stop, StopReason::IterationCap { .. })
        && best.iteration != 0
        && best.q_min > state_q_min(ctx, &snap, &p)
    {
        *m = best.rebuild()?;
        core = None;
        snap = Snapshot::build(m);
        p = snap.ids.iter().map(|&v| m.pos(v)).collect();
        ctx.report.kept_iteration = Some(best.iteration);
    }
    drop(best);
    // The clean-up below works on the whole mesh.
    if core.is_some() {
        write_back(m, &snap, &p);
        snap = Snapshot::build(m);
        p = snap.ids.iter().map(|&v| m.pos(v)).collect();
    }
    ctx.connected = Some(snap.is_connected());
    // The loop's working arrays go before the final clean-up allocates (peak memory).
    drop((pold, newp, hv, moved, mv, slots, flags));
    // Every boundary node ends on d = 0.
    project_boundary(ctx, &snap, &mut p, m)?;
    write_back(m, &snap, &p);
    // Final cleanup: repair bad triangles, restore Delaunay. The snapshot is current: it is
    // rebuilt after every topology change, and only positions changed since.
    let mu = metric.map(|_| munit);
    let band = if metric.is_some() { METRIC_BAND } else { FRESH_BAND };
    let cands = density_candidates(ctx, &snap, &p, unit, mu, band)?;
    // The global pass follows. No force step follows it either, so a split or collapse
    // here is final as made: the pass is kept only if it leaves the worst triangle no worse
    // (a run stopped by the iteration cap, far from rest, can have long edges whose split
    // would leave a sliver behind). With internal boundaries it is always kept: on the seed's
    // figure 3-5 meshed from the Python package's sampled callable, whose curves are sealed
    // after this, the guard gave q min 0.638 where keeping the pass gives 0.682.
    if ctx.internal.is_some() {
        density_control(ctx, m, cands, false, BoundaryLoops::default())?;
        ctx.report.ops.flips += ctx.make_delaunay(m);
    } else if !cands.is_empty() {
        let q_before = state_q_min(ctx, &snap, &p);
        let (kept, ops) = (m.clone(), ctx.report.ops);
        density_control(ctx, m, cands, false, BoundaryLoops::default())?;
        ctx.report.ops.flips += ctx.make_delaunay(m);
        if mesh_q_min(ctx, m) < q_before {
            *m = kept;
            ctx.report.ops = ops;
        }
    }
    settle_boundary(ctx, m)?;
    ctx.report.stopped(iter, stop);
    Ok(())
}

/// The mean triangle quality of the whole mesh, from the arrays `snap` and the held core.
fn whole_mean_quality(ctx: &Ctx, core: &Option<HeldCore>, snap: &Snapshot, p: &[DVec2]) -> f64 {
    let q = mean_quality(ctx, snap, p);
    core.as_ref().map_or(q, |c| c.mean_quality(q, snap.tris.len()))
}

/// The smallest triangle quality of `m` (in the metric, if any).
fn mesh_q_min(ctx: &Ctx, m: &TriMesh<DVec2>) -> f64 {
    m.face_ids().map(|f| ctx.tri_q(m.face_points(f))).fold(f64::INFINITY, f64::min)
}
