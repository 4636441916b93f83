//! The 3-D mesher on the tetrahedral engine (seed chapters 2 and 3, and the seed's own list of
//! future work: swaps inside the iteration instead of a global retriangulation).
//!
//! 1. Start ([`start`]): a body-centred cubic lattice over the box (well-shaped Delaunay tets),
//!    thinned by the size function as in the seed (keep with probability (h_min / h)^3), points
//!    with d < 0 (moved off the lattice by 1e-6 of its side, see `start::jitter`), points
//!    projected onto d = 0 and points on sharp edges and corners ([`features`]), Delaunay through
//!    the engine, tets with centroid outside carved away, pinched vertices and edges repaired.
//! 2. Force equilibrium ([`equilibrium`](mod@equilibrium)): repulsive bars f = max(L0 - L, 0)
//!    (seed eq. 2.6 with the cube root), forward Euler on compact arrays ([`snapshot`]),
//!    boundary nodes projected onto d = 0 every step, step control so that no tet inverts (exact
//!    orient3d), Lawson flips (exact insphere) around nodes that moved, surface edge flips
//!    ([`boundary`]), density control (splits and collapses, [`density`]), tets squashed
//!    against the boundary removed (one at a time, or carved together when they are stuck,
//!    [`carve`]).
//! 3. Sliver removal ([`improve`](mod@improve)): the worst tets (by dihedral angles) are attacked
//!    by swaps (edge removal with an optimal ring triangulation, Shewchuk 2002; 2-3 flips;
//!    boundary edge flips), by optimisation-based smoothing of their vertices (maximise the
//!    worst quality in the star, Freitag and Ollivier-Gooch 1997, [`smoothing`]), then by small
//!    random perturbations (Tournois et al. 2009), each accepted only when the local worst
//!    quality improves.
//! 4. Mean quality: edge removals and 2-3 flips around the tets well below the mean that raise
//!    the mean radius ratio, and every vertex moved uphill on its star's summed radius ratio
//!    (by independent classes, in parallel), each keeping the local worst dihedral quality at
//!    least min(old, RR_TQ_FLOOR).
//!
//! "tq" in these files is the dihedral quality, [`tet_dihedral_quality`]: 1 for the regular
//! tet, 0 when a dihedral angle reaches 0 or 180 degrees.
//!
//! Set `TRUSSMESH_TRACE=1` to print the state every ten iterations.

mod boundary;
mod carve;
mod density;
mod equilibrium;
mod features;
mod improve;
pub(super) mod options;
pub(super) mod report;
mod smoothing;
mod snapshot;
pub(crate) mod start;
#[cfg(test)]
mod tests;

use crate::geometry::project::{project3, Projection};
use crate::geometry::{decide3, Declared, Implicit3};
use crate::mesher::MeshOutput3;
use crate::mesher::Report;
use crate::quality::tet_dihedral_quality;
use crate::topology::{Invariant, Level, TetId};
use crate::Error;
use boundary::{count_off, settle_boundary};
use carve::drop_specks;
use equilibrium::{equilibrium, repeat_rounds};
use glam::DVec3;
use improve::{clear_flat_boundary_tets, improve, mean_quality_round, reseat_lonely_fixed_points};
use options::Options3;
use rayon::prelude::*;
use report::QualityStats3;
use start::{eval_d, eval_h_floor, initial_mesh, splitmix_unit, survey};
use std::time::Instant;

/// Tets whose centroid is within GEPS h0 h of d = 0 are dropped from the boundary (seed: 0.1).
const GEPS: f64 = 0.1;
/// Smoothing and perturbation may lower the star's mean radius ratio by at most this.
const RR_SLACK: f64 = 0.01;
/// Rounds of the final mean-quality pass (swaps and smoothing aimed at the mean radius ratio).
const RR_ROUNDS: usize = 4;
/// The mean-quality pass stops after a round that raised the mean radius ratio by less than
/// this (a second round gains about a tenth of the first).
const RR_ROUND_GAIN: f64 = 5e-3;
/// The mean-quality pass keeps every local worst dihedral quality at least min(old, this).
const RR_TQ_FLOOR: f64 = 0.55;
use crate::mesher::truss::CHUNK;

struct Ctx<'a> {
    domain: &'a dyn Implicit3,
    opts: &'a Options3,
    projection: Projection,
    h_floor: f64,
    report: Report<QualityStats3>,
    rng: u64,
    trace: bool,
    /// The worst tq at the start of the last polish round.
    polish_worst: f64,
    /// The fixed points: the user's, then the points the start put on sharp edges.
    fixed: Vec<DVec3>,
    /// The step control lets no boundary fold through, not even one nearly flat already (the
    /// second run, after a first one ended folded).
    strict_folds: bool,
    /// The start lattice's origin moves back by this many lattice sides on every axis.
    start_shift: f64,
}

impl Ctx<'_> {
    /// Relative size normalised so that the smallest size inside is 1 (edge length h0).
    fn h(&self, p: DVec3) -> Result<f64, Error> {
        Ok(eval_h_floor(self.opts, p, self.h_floor)? / self.h_floor)
    }
    fn d(&self, p: DVec3) -> Result<f64, Error> {
        eval_d(self.domain, p)
    }
    /// Projects onto d = 0; `Ok(None)` when the projection does not converge.
    fn project(&self, p: DVec3) -> Result<Option<DVec3>, Error> {
        match project3(self.domain, p, self.projection, 1e-9 * self.opts.h0, 20) {
            Ok(q) => Ok(Some(q)),
            Err(e) => match crate::mesher::truss::domain::projection_non_finite(
                &e,
                crate::mesher::truss::domain::Function::Domain,
            ) {
                Some(err) => Err(err),
                None => Ok(None),
            },
        }
    }
    /// Approximate distance: d itself for distances, d / |grad d| otherwise.
    fn approx_dist(&self, p: DVec3) -> Result<f64, Error> {
        let d = self.d(p)?;
        let g = if self.domain.is_distance() { 1.0 } else { self.domain.gradient(p).length() };
        Ok(crate::mesher::truss::domain::approx_distance(d, g, self.domain.is_distance()))
    }
    /// [`Ctx::approx_dist`] where d = 0 may pass within `r` of `p`; `None` where the geometry
    /// knows it is farther (see `Implicit3::value_near`; only signed distances can say so).
    fn approx_dist_near(&self, p: DVec3, r: f64) -> Result<Option<f64>, Error> {
        if !self.domain.is_distance() {
            return self.approx_dist(p).map(Some);
        }
        self.domain.value_near(p, r).map(|d| crate::mesher::truss::domain::checked_d(d, p)).transpose()
    }
    /// SplitMix64 on the options' seed: the only randomness, so runs repeat bit for bit.
    fn next_f64(&mut self) -> f64 {
        self.rng = self.rng.wrapping_add(0x9E37_79B9_7F4A_7C15);
        splitmix_unit(self.rng)
    }
}

pub(crate) fn run(domain: &dyn Implicit3, opts: &Options3) -> Result<MeshOutput3, Error> {
    let t0 = Instant::now();
    let folded = |r: &Result<MeshOutput3, Error>| {
        matches!(r, Err(Error::Internal { violation: Some(v), .. })
            if matches!(v.invariant, Invariant::FoldedEdge | Invariant::SelfIntersection))
    };
    // A boundary fold the step control let through while nearly flat, and that stayed (a
    // folded edge, or boundary faces laid over each other): the run again, with every fold
    // held back; then, if the boundary still folds, from a start lattice shifted by a third of
    // its side (where the boundary folds depends on how the lattice meets the domain's edges).
    let mut r = run_once(domain, opts, false, 0.0);
    let mut shifted = false;
    for (strict, shift) in [(true, 0.0), (true, START_SHIFT)] {
        if !folded(&r) {
            break;
        }
        r = run_once(domain, opts, strict, shift);
        shifted = shift != 0.0;
    }
    // A mesh with tets flatter than the report's floor: how the start lattice met the domain's
    // sharp edges decides that too (a flat tet held between points fixed on two edges), so the
    // shifted start is tried as well and the better of the two kept.
    let dihedral = |r: &Result<MeshOutput3, Error>| match r {
        Ok(out) if out.report.quality.dihedral_min.is_finite() => out.report.quality.dihedral_min,
        _ => f64::NEG_INFINITY,
    };
    if !shifted && r.is_ok() && dihedral(&r) < crate::mesher::report::DIHEDRAL_FLOOR {
        let other = run_once(domain, opts, true, START_SHIFT);
        if dihedral(&other) > dihedral(&r) {
            r = other;
        }
    }
    // Every attempt laid the boundary over itself: where the domain has walls far thinner than
    // the elements, that is the cause, and the user can act on it (a smaller h0, a thicker
    // wall); an internal error would only say that something broke.
    if folded(&r) {
        if let Some(wall) = thin_wall(domain, opts)? {
            return Err(Error::BadSize(format!(
                "the domain has walls thinner than h0 / 2 = {:.3e} ({} samples of a grid of spacing {:.3e}; the \
                 thinnest about {:.3e} across near ({:.4}, {:.4}, {:.4})), and the boundary's two sides met across \
                 them in every attempt: lower h0 (a wall takes about two elements across), or thicken or remove the \
                 walls",
                0.5 * opts.h0,
                wall.samples,
                wall.spacing,
                wall.thickness,
                wall.at.x,
                wall.at.y,
                wall.at.z
            )));
        }
    }
    let mut out = r?;
    // A mean radius ratio this low (meshes of sound domains reach 0.88 and more) where walls
    // are thinner than the elements: the report says why.
    if out.report.quality.rr_mean < THIN_RR_MEAN {
        if let Some(wall) = thin_wall(domain, opts)? {
            out.report.notes.push(format!(
                "poor tets (mean radius ratio {:.3}): the domain has walls thinner than h0 / 2 = {:.3e} (the thinnest \
                 about {:.3e} across near ({:.4}, {:.4}, {:.4})), which no good tet fits across; lower h0 to about \
                 half their thickness, or thicken them",
                out.report.quality.rr_mean,
                0.5 * opts.h0,
                wall.thickness,
                wall.at.x,
                wall.at.y,
                wall.at.z
            ));
        }
    }
    out.report.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// A finished mesh whose mean radius ratio is below this is checked for walls thinner than its
/// elements (see [`thin_wall`]).
const THIN_RR_MEAN: f64 = 0.8;

/// Where the domain is thinnest, as [`thin_wall`] finds it.
struct ThinWall {
    /// Grid samples inside whose neighbourhood is all thin.
    samples: usize,
    spacing: f64,
    /// Twice the largest distance to the boundary near the thinnest sample.
    thickness: f64,
    at: DVec3,
}

/// Samples of the box at most this many (the grid coarsens beyond).
const THIN_SAMPLES: f64 = 2e6;

/// The domain's walls thinner than h0 / 2, if any: on a grid of spacing h0 / 4 over the box
/// (coarser past [`THIN_SAMPLES`]), an inside sample is in such a wall when no sample within
/// h0 / 2 of it (a cube) lies more than h0 / 4 from the boundary (distance |d|, or |d| / |grad
/// d| for a level set). The tip of a sharp wedge is such a place too, so this only names a
/// likely cause of a failure, after the fact.
fn thin_wall(domain: &dyn Implicit3, opts: &Options3) -> Result<Option<ThinWall>, Error> {
    let [lo, hi] = opts.bbox;
    let ext = hi - lo;
    let spacing = (0.25 * opts.h0).max((ext.x * ext.y * ext.z / THIN_SAMPLES).cbrt());
    let n = (ext / spacing).ceil().as_uvec3() + glam::UVec3::ONE;
    let (nx, ny, nz) = (n.x as usize, n.y as usize, n.z as usize);
    let idx = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
    let distance = domain.is_distance();
    // The distance inside (0 outside), per sample.
    let depth: Vec<f64> = (0..nx * ny * nz)
        .into_par_iter()
        .map(|c| {
            let (i, j, k) = (c % nx, (c / nx) % ny, c / (nx * ny));
            let p = lo + DVec3::new(i as f64, j as f64, k as f64) * spacing;
            let d = eval_d(domain, p)?;
            if d >= 0.0 {
                return Ok(0.0);
            }
            let g = if distance { 1.0 } else { domain.gradient(p).length() };
            Ok(-crate::mesher::truss::domain::approx_distance(d, g, distance))
        })
        .collect::<Result<_, Error>>()?;
    // The largest depth within `reach` samples along each axis in turn (a cube's maximum).
    let reach = ((0.5 * opts.h0) / spacing).ceil() as usize;
    let mut near = depth.clone();
    for axis in 0..3 {
        let len = [nx, ny, nz][axis];
        let src = near.clone();
        for (c, out) in near.iter_mut().enumerate() {
            let (i, j, k) = (c % nx, (c / nx) % ny, c / (nx * ny));
            let at = [i, j, k][axis];
            let mut m = 0.0f64;
            for t in at.saturating_sub(reach)..(at + reach + 1).min(len) {
                let mut q = [i, j, k];
                q[axis] = t;
                m = m.max(src[idx(q[0], q[1], q[2])]);
            }
            *out = m;
        }
    }
    let mut found: Option<ThinWall> = None;
    for c in 0..depth.len() {
        if depth[c] > 0.0 && near[c] < 0.25 * opts.h0 {
            let (i, j, k) = (c % nx, (c / nx) % ny, c / (nx * ny));
            let p = lo + DVec3::new(i as f64, j as f64, k as f64) * spacing;
            let f = found.get_or_insert(ThinWall { samples: 0, spacing, thickness: f64::INFINITY, at: p });
            f.samples += 1;
            if 2.0 * near[c] < f.thickness {
                f.thickness = 2.0 * near[c];
                f.at = p;
            }
        }
    }
    Ok(found)
}

/// The start lattice's shift, in lattice sides, of a run's last attempt (see [`run`]).
const START_SHIFT: f64 = 1.0 / 3.0;

fn run_once(domain: &dyn Implicit3, opts: &Options3, strict_folds: bool, shift: f64) -> Result<MeshOutput3, Error> {
    let t0 = Instant::now();
    let survey = survey(domain, opts)?;
    let (distance, gradient_survey) = decide3(domain, opts.bbox[0], opts.bbox[1]);
    let decided = Declared { inner: domain, distance };
    let domain: &dyn Implicit3 = &decided;
    let projection = match opts.projection {
        Projection::Auto if domain.is_distance() => Projection::Exact,
        Projection::Auto => Projection::FirstOrder,
        p => p,
    };
    let mut ctx = Ctx {
        domain,
        opts,
        projection,
        h_floor: survey.h_floor,
        report: Report { gradient_survey, level_set: !distance, ..Report::default() },
        rng: opts.seed ^ 0x7472_7573_736d_6533,
        trace: std::env::var_os("TRUSSMESH_TRACE").is_some(),
        polish_worst: f64::NEG_INFINITY,
        fixed: opts.fixed.clone(),
        strict_folds,
        start_shift: shift,
    };
    let mut mesh = initial_mesh(&mut ctx, survey.estimated_tets)?;
    if ctx.trace {
        eprintln!(
            "start: {} vertices, {} tets, {:.2} s",
            mesh.num_vertices(),
            mesh.num_tets(),
            t0.elapsed().as_secs_f64()
        );
    }
    equilibrium(&mut ctx, &mut mesh)?;
    settle_boundary(&mut ctx, &mut mesh)?;
    if ctx.trace {
        eprintln!("equilibrium done at {:.2} s", t0.elapsed().as_secs_f64());
    }
    repeat_rounds(&mut ctx, &mut mesh, opts.polish_rounds, "polish", None, improve)?;
    // Tets the polish left flat on the boundary go, and so do poor caps that alone hold a
    // fixed point; the polish runs again around where they were.
    let flat = clear_flat_boundary_tets(&mut ctx, &mut mesh)? + reseat_lonely_fixed_points(&mut ctx, &mut mesh)?;
    if flat > 0 {
        if ctx.trace {
            eprintln!("flat boundary tets: {flat} changes, dihedral from {:.2}", QualityStats3::of(&mesh).dihedral_min);
        }
        repeat_rounds(&mut ctx, &mut mesh, opts.polish_rounds, "polish", None, improve)?;
    }
    repeat_rounds(&mut ctx, &mut mesh, RR_ROUNDS, "mean quality", Some(RR_ROUND_GAIN), |c, m, _| {
        mean_quality_round(c, m)
    })?;
    if ctx.trace {
        let mut w: Vec<(f64, TetId)> = mesh.tet_ids().map(|t| (tet_dihedral_quality(mesh.tet_points(t)), t)).collect();
        w.sort_by(|a, b| a.0.total_cmp(&b.0));
        for &(q, t) in w.iter().take(6) {
            let tx = mesh.tet(t);
            let nb = tx.adj.iter().filter(|a| a.is_none()).count();
            let tags: Vec<String> =
                tx.v.iter()
                    .map(|&v| format!("{:?}@{:.3}", mesh.tag(v), ctx.approx_dist(mesh.pos(v)).unwrap_or(0.0)))
                    .collect();
            eprintln!("worst tq {q:.3}: {nb} boundary faces, {:?} {:?}", tags, mesh.tet_points(t)[0]);
        }
    }
    if drop_specks(&ctx, &mut mesh)? && ctx.trace {
        eprintln!("specks dropped");
    }
    ctx.report.boundary_nodes_off = count_off(&ctx, &mesh)?;
    let pinched = report::pinched_boundary_vertices(&mesh);
    if let Some(&v) = pinched.first() {
        let p = mesh.pos(v);
        ctx.report.notes.push(format!(
            "the boundary is pinched at {} vertices (two parts of it meet at a vertex alone, first at ({:.4}, {:.4}, {:.4})): \
             the boundary is no manifold surface there",
            pinched.len(),
            p.x,
            p.y,
            p.z
        ));
    }
    if let Err(e) = mesh.validate(Level::Geometry) {
        return Err(Error::broken("the finished mesh is invalid", e));
    }
    let mut report = ctx.report;
    report.seconds = t0.elapsed().as_secs_f64();
    report.quality = QualityStats3::of(&mesh);
    Ok(MeshOutput3 { mesh, report })
}
