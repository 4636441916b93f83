//! The truss iteration on the surface: repulsive bar forces toward L0 = Fscale h(x) (seed eq.
//! 2.6), forward Euler moves in the tangent plane, projection onto phi = 0, quality flips, and
//! density control with hysteresis; it keeps the best mesh seen by a quality score.

use super::density::density_control;
use super::features;
use super::geom::{self, normal, SizeField};
use super::improve::{flip_pass, move_if_no_fold_g, try_flip, FlipGoal};
use super::options::SurfaceOptions;
use crate::geometry::Implicit3;
use crate::mesher::report::OpCounts;
use crate::mesher::truss::{self, backtrack, bar_force, RestScale};
use crate::topology::{FaceId, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec3;
use rayon::prelude::*;
use slotmap::SecondaryMap;

/// Density control runs every this many force iterations, and not in the last stretch.
const DENSITY_EVERY: usize = 20;
/// The force loop stops when its score has not beaten the best for PATIENCE iterations (on
/// large meshes the largest node move never falls below the tolerance).
const PATIENCE: usize = 60;
/// Without subdivision the coarsest level is the final mesh: its loop gets more patience (the
/// score of a start from the fine marching dips before it rises).
const PATIENCE_ALONE: usize = 250;
/// On the finest level of a subdivided start (only local relaxation is left there) the loop
/// stops when the score has not risen by SCORE_STEP for FINE_PATIENCE iterations.
const FINE_PATIENCE: usize = 5;
/// See FINE_PATIENCE.
const SCORE_STEP: f64 = 1e-3;
/// Triangles below this quality have their edges tried for flips after every force step.
const WATCH_Q: f64 = 0.8;
/// A force loop whose mesh grows past this many times its vertices at the start (plus
/// GROWTH_SLACK) has run away: density control at the loop's own sizes keeps the count
/// near the start's, so such growth means nodes jumping between sheets closer than the edges
/// (a shell one edge thick grew from 30,000 to 71,000 vertices in 60 iterations and went on).
const GROWTH_CAP: usize = 2;
/// See GROWTH_CAP: small meshes may grow more before it counts.
const GROWTH_SLACK: usize = 1000;

/// The patience of a force loop (see PATIENCE): the iterations without progress it allows, and
/// the rise of the score that counts as progress. `coarsest` is the level the start mesh was
/// made at, `levels` the number of subdivisions that follow it.
pub(super) fn patience(coarsest: bool, levels: u32) -> (usize, f64) {
    match (coarsest, levels) {
        (true, 0) => (PATIENCE_ALONE, 0.0),
        (true, _) => (PATIENCE, 0.0),
        _ => (FINE_PATIENCE, SCORE_STEP),
    }
}

/// What a force loop did.
pub(super) struct ForceRun {
    /// The kept mesh: the last one when converged, else the best seen.
    pub(super) mesh: TriMesh<DVec3>,
    /// Iterations run.
    pub(super) iterations: usize,
    /// The iteration whose mesh was kept.
    pub(super) kept: usize,
    /// The largest move fell below dptol h.
    pub(super) converged: bool,
    /// The score stopped rising.
    pub(super) plateau: bool,
    /// Moves undone because they would fold a triangle.
    pub(super) undone: usize,
    /// The loop stopped because the mesh ran away (GROWTH_CAP): the vertex counts at its start
    /// and when it stopped. The mesh kept is then meaningless.
    pub(super) runaway: Option<(usize, usize)>,
}

/// The truss iteration at the sizes `size`: force steps, flips when nodes may have moved TTOL h
/// since the last sweep (the seed's retriangulation rule, section 2.2) and on the worst
/// triangles after every step, density control every DENSITY_EVERY steps. Stops when no node
/// moves more than dptol h, at the cap, or when the score has not risen by `step` for
/// `patience` iterations; keeps the best mesh seen unless converged.
pub(super) fn force_loop(
    mut m: TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    opts: &SurfaceOptions,
    tol: f64,
    (patience, step): (usize, f64),
    counts: &mut OpCounts,
) -> Result<ForceRun, Error> {
    let mut best = (score(&m, size), m.clone(), 0usize);
    // Progress is a score `step` above the last one that was.
    let mut plateau = truss::Plateau::since_mark(step, patience, best.0);
    // Largest possible movement of any node since the last flip sweep, relative to h.
    let mut since_flips = 0.0;
    let mut run = ForceRun {
        mesh: TriMesh::new(),
        iterations: 0,
        kept: 0,
        converged: false,
        plateau: false,
        undone: 0,
        runaway: None,
    };
    let start_vertices = m.num_vertices();
    let mut grads = GradCache::new();
    for it in 1..=opts.max_iter {
        run.iterations = it;
        let moved = force_step(&mut m, phi, size, opts, tol, &mut run.undone, &mut grads)?;
        since_flips += moved;
        if since_flips > truss::TTOL {
            counts.flips += flip_pass(&mut m, phi, FlipGoal::Quality, 5);
            since_flips = 0.0;
        }
        let late = it + 3 * DENSITY_EVERY > opts.max_iter;
        if it % DENSITY_EVERY == 0 && !late && density_control(&mut m, phi, size, tol, counts)? > 0 {
            since_flips = 0.0;
            if m.num_vertices() > GROWTH_CAP * start_vertices + GROWTH_SLACK {
                run.runaway = Some((start_vertices, m.num_vertices()));
                break;
            }
        }
        let (sc, worst) = score_and_worst(&m, size, WATCH_Q);
        if std::env::var_os("TRUSSMESH_TRACE").is_some() && it % 20 == 0 {
            eprintln!(
                "surface iter {it}: {} vertices (start {start_vertices}), score {sc:.4}, moved {moved:.2e}",
                m.num_vertices()
            );
        }
        // Between the sweeps, the edges of the worst triangles are tried after every step.
        let mut no_valences = SecondaryMap::new();
        for f in worst {
            if m.contains_face(f) {
                for h in m.face_half_edges(f) {
                    if m.contains_half_edge(h) && try_flip(&mut m, phi, h, FlipGoal::Quality, &mut no_valences) {
                        counts.flips += 1;
                        break;
                    }
                }
            }
        }
        if sc > best.0 {
            best = (sc, m.clone(), it);
        }
        let flat = plateau.reached(sc);
        if truss::stop::at_rest(moved, opts.dptol, it, DENSITY_EVERY) {
            run.converged = true;
            break;
        }
        if flat {
            run.plateau = true;
            break;
        }
    }
    if run.converged || run.runaway.is_some() {
        run.kept = run.iterations;
        run.mesh = m;
    } else {
        run.kept = best.2;
        run.mesh = best.1;
    }
    Ok(run)
}

/// The figure that picks the kept mesh: mean plus worst quality, minus the size deviation
/// (std / mean of edge length over h).
fn score(m: &TriMesh<DVec3>, size: &SizeField) -> f64 {
    score_and_worst(m, size, 0.0).0
}

/// [`score`], and the faces of quality below `watch`.
fn score_and_worst(m: &TriMesh<DVec3>, size: &SizeField, watch: f64) -> (f64, Vec<FaceId>) {
    let (mut min_q, mut sum) = (1.0f64, 0.0);
    let mut worst = Vec::new();
    for f in m.face_ids() {
        let q = m.face_quality(f);
        min_q = min_q.min(q);
        sum += q;
        if q < watch {
            worst.push(f);
        }
    }
    let (mut n, mut s1, mut s2) = (0.0, 0.0, 0.0);
    for e in m.edge_ids() {
        let (p, q) = (m.pos(m.origin(e)), m.pos(m.dest(e)));
        let r = p.distance(q) / size.at(0.5 * (p + q));
        n += 1.0;
        s1 += r;
        s2 += r * r;
    }
    let mean = s1 / n;
    let dev = ((s2 / n - mean * mean).max(0.0)).sqrt() / mean;
    (min_q + sum / m.num_faces().max(1) as f64 - dev, worst)
}

/// grad phi at each vertex where the last step left it (the projection onto phi = 0 returns
/// it): the next step's tangent plane there costs no evaluation. An entry counts only while
/// the vertex is exactly at the position stored with it (splits, collapses and smoothing move
/// vertices without passing here).
type GradCache = SecondaryMap<VertexId, (DVec3, DVec3)>;

/// One truss step (seed eq. 2.6 forces, forward Euler in the tangent plane, projection).
/// Returns the largest node movement relative to h.
fn force_step(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    opts: &SurfaceOptions,
    tol: f64,
    undone: &mut usize,
    grads: &mut GradCache,
) -> Result<f64, Error> {
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    let mut index: SecondaryMap<VertexId, u32> = SecondaryMap::with_capacity(ids.len());
    for (i, &v) in ids.iter().enumerate() {
        index.insert(v, i as u32);
    }
    let pos: Vec<DVec3> = ids.iter().map(|&v| m.pos(v)).collect();
    let bars: Vec<[u32; 2]> = m.edge_ids().map(|h| [index[m.origin(h)], index[m.dest(h)]]).collect();
    let mut len = Vec::with_capacity(bars.len());
    let mut hb = Vec::with_capacity(bars.len());
    let mut rest = RestScale::new(2);
    for &[a, b] in &bars {
        let (pa, pb) = (pos[a as usize], pos[b as usize]);
        let l = pa.distance(pb);
        let h = size.at(0.5 * (pa + pb));
        rest.add(l * l, h);
        len.push(l);
        hb.push(h);
    }
    let scale = rest.scale(opts.fscale);
    let mut force = vec![DVec3::ZERO; ids.len()];
    for (k, &[a, b]) in bars.iter().enumerate() {
        let f = bar_force(pos[a as usize] - pos[b as usize], len[k], hb[k] * scale);
        force[a as usize] += f;
        force[b as usize] -= f;
    }
    // Normals and projections depend on the positions before the step only: in parallel.
    let mesh = &*m;
    let moves: Vec<Option<(DVec3, DVec3)>> = pos
        .par_iter()
        .zip(&force)
        .zip(&ids)
        .map(|((&p, &fi), &v)| {
            if mesh.tag(v) != VertexTag::Interior {
                // Along the feature curve only; corners stay.
                return features::held_target(mesh, phi, v, opts.deltat * fi, size.at(p), tol);
            }
            let n = match grads.get(v) {
                Some(&(at, g)) if at == p => g.normalize_or_zero(),
                _ => normal(phi, p),
            };
            let f = fi - fi.dot(n) * n;
            geom::project_grad(phi, p + opts.deltat * f, tol).map(Some)
        })
        .collect::<Result<_, Error>>()?;
    let mut moved = 0.0f64;
    for (i, &v) in ids.iter().enumerate() {
        let p = pos[i];
        let Some((q, g)) = moves[i] else { continue };
        if m.tag(v) != VertexTag::Interior {
            // A step along a curved feature is not a straight segment: taken whole or not.
            if move_if_no_fold_g(m, v, q, g) {
                moved = moved.max(q.distance(p) / size.at(p));
            } else {
                *undone += 1;
            }
            continue;
        }
        match backtrack(p, q, 0, |y| Ok::<bool, Error>(move_if_no_fold_g(m, v, y, g)))? {
            Some(y) => {
                moved = moved.max(y.distance(p) / size.at(p));
                grads.insert(v, (q, g));
            }
            None => *undone += 1,
        }
    }
    Ok(moved)
}
