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
    let mut out = r?;
    out.report.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
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
