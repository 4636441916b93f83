//! The 3-D mesher on the tetrahedral engine (seed chapters 2 and 3, and the seed's own list of
//! future work: swaps inside the iteration instead of a global retriangulation).
//!
//! 1. Start: a body-centred cubic lattice over the box (well-shaped Delaunay tets), thinned by
//!    the size function as in the seed (keep with probability (h_min / h)^3), points with d < 0
//!    (moved off the lattice by 1e-6 of its side, see [`jitter`]) and points projected onto
//!    d = 0, Delaunay through the engine, tets with centroid outside carved away, pinched
//!    vertices and edges repaired.
//! 2. Force equilibrium: repulsive bars f = max(L0 - L, 0) (seed eq. 2.6 with the cube root),
//!    forward Euler, boundary nodes projected onto d = 0 every step, step control so that no tet
//!    inverts (exact orient3d), Lawson flips (exact insphere) around nodes that moved, surface
//!    edge flips, density control (splits and collapses), tets squashed against the boundary
//!    removed (one at a time, or carved together when they are stuck).
//! 3. Sliver removal: the worst tets (by dihedral angles) are attacked by swaps (edge removal
//!    with an optimal ring triangulation, Shewchuk 2002; 2-3 flips; boundary edge flips), by
//!    optimisation-based smoothing of their vertices (maximise the worst quality in the star,
//!    Freitag and Ollivier-Gooch 1997), then by small random perturbations (Tournois et al.
//!    2009), each accepted only when the local worst quality improves.
//! 4. Mean quality: edge removals and 2-3 flips around the tets well below the mean that raise
//!    the mean radius ratio, and every vertex moved uphill on its star's summed radius ratio
//!    (by independent classes, in parallel), each keeping the local worst dihedral quality at
//!    least min(old, RR_TQ_FLOOR). (A smart Laplacian round before it gained nothing the
//!    uphill moves did not: the same rr mean to 2e-4 on the quality examples, and at
//!    10^6 tets 1.3 s.)
//!
//! Set `TRUSSMESH_TRACE=1` to print the state every ten iterations.

use super::options3::Options3;
use super::report3::{QualityStats3, Report3};
use super::sharp;
use super::MeshOutput3;
use crate::geometry::project::{project3, ProjectError, Projection};
use crate::geometry::Implicit3;
use crate::predicates::{orient3d, Sign};
use crate::topology::{Journal, Level, TVertexId, TetId, TetMesh, TetPatch, VertexTag, EDGE_VERTICES};
use crate::Error;
use glam::DVec3;
use rayon::prelude::*;
use slotmap::SecondaryMap;
use smallvec::SmallVec;
use std::collections::HashMap;
use std::time::Instant;

/// Lattice side over target edge length: the BCC Delaunay edges are a and a sqrt(3)/2 long.
const LATTICE: f64 = 1.1;
/// Face-connected pieces with fewer tets than this (and under 1e-3 of the volume) are dropped
/// at the end ([`drop_specks`]).
const SPECK_TETS: usize = 10;
/// The interior lattice points' offset, in lattice sides (see [`jitter`]).
const LATTICE_JITTER: f64 = 1e-6;
/// Surface start points are at least this many lattice sides (times h) apart.
const SURFACE_GAP: f64 = 0.9;
/// Lattice points deeper than this many lattice sides (times h) are interior start points.
const INTERIOR_DEPTH: f64 = 0.45;
/// Tets below this dihedral quality get quality-driven swaps every iteration.
const SWAP_TQ: f64 = 0.5;
/// A tet no swap could improve is tried again only this many iterations later.
const SWAP_RETRY: usize = 10;
/// Tets whose centroid is within GEPS h0 h of d = 0 are dropped from the boundary (seed: 0.1).
const GEPS: f64 = 0.1;
/// Nodes moved farther than this many local sizes since their last check get their faces
/// re-checked for the Delaunay property (the seed's ttol, per node).
const TTOL: f64 = 0.1;
/// Density control runs every this many iterations.
const DENSITY_EVERY: usize = 10;
/// Split edges longer than this many current target lengths, collapse shorter than this.
const SPLIT_ABOVE: f64 = 1.6;
const COLLAPSE_BELOW: f64 = 0.5;
/// The force loop stops on a plateau: the best mean radius ratio, sampled every DENSITY_EVERY
/// iterations, rose by less than this per sample over the last PLATEAU_WINDOWS samples. At
/// 1e-5 the ball at h0 = 0.05 ran into the 300-step cap for a final mean radius ratio of
/// 0.9397; at 1e-4 it stops after 180 steps with 0.9393 and a wider dihedral range (38.8 to
/// 119.8 degrees against 35.6 to 123.4), in 16.5 s instead of 22. The gain is taken over the
/// whole span rather than asked of each sample: on large meshes single samples still wobble
/// above the threshold long after the trend is flat.
const QUALITY_PLATEAU: f64 = 1e-4;
const PLATEAU_WINDOWS: usize = 4;
/// Tets below this dihedral quality ([`tq`]) are attacked by the sliver removal.
const TQ_TARGET: f64 = 0.6;
/// Boundary tets below this dihedral quality that no swap improves get an edge collapsed,
/// when every new tet keeps a radius ratio above CAP_COLLAPSE_RR.
const CAP_TQ: f64 = 0.2;
const CAP_COLLAPSE_RR: f64 = 0.2;
/// Lawson flips and sliver swaps in the force loop come at the end of windows of this many
/// steps, with one snapshot rebuild: at every step they cost more than the forces (the ball at
/// h0 = 0.1: swaps 4 ms and the rebuild 5 ms a step, the forces 1.2 ms). Flat boundary tets
/// still go at every step: removed only at window ends, the ball at h0 = 0.15 lost 1.01% of its
/// volume instead of 0.96%.
const TOPO_EVERY: usize = 5;
/// A polish round that starts with the worst tq less than this above the last round's start
/// is not made (on the ball at h0 = 0.033, rounds 3 to 7 raised the smallest dihedral from
/// 35.70 to 35.74 degrees in 4.7 s).
const POLISH_STALL: f64 = 1e-3;
/// Smoothing and perturbation may lower the star's mean radius ratio by at most this.
const RR_SLACK: f64 = 0.01;
/// Rounds of the final mean-quality pass (swaps and smoothing aimed at the mean radius ratio).
const RR_ROUNDS: usize = 4;
/// The mean-quality pass stops after a round that raised the mean radius ratio by less than
/// this. A second round gains about a tenth of the first: on the unit ball at h0 = 0.15,
/// 8e-3 then 8e-4; at h0 = 0.033 (10^6 tets) 3.0e-3 then 3e-4, at 2.9 s each.
const RR_ROUND_GAIN: f64 = 5e-3;
/// The mean-quality pass keeps every local worst dihedral quality at least min(old, this).
const RR_TQ_FLOOR: f64 = 0.55;
/// The mean-quality swaps look at the edges and faces of tets this far below the mean radius
/// ratio. Over all edges and faces, at 10^6 tets, they took 2.8 s a round and changed almost
/// nothing; with 0.1 the quality examples keep their rr mean to 3e-4.
const RR_SWAP_MARGIN: f64 = 0.1;
/// Least gain in summed radius ratio for a mean-quality swap.
const RR_GAIN: f64 = 1e-4;
/// Gradient steps per vertex in the mean-quality smoothing. Four: ten gave the same mean
/// radius ratio to 1e-4 on both quality examples and at h0 = 0.05, at 1.5x the cost.
const RR_SMOOTH_STEPS: usize = 4;
/// Whether boundary vertices take part in the mean-quality smoothing.
const RR_SMOOTH_BOUNDARY: bool = true;
/// Boundary faces turning more than this (degrees) from the surface normal mark a sharp edge.
const RR_SHARP: f64 = 30.0;
/// Dihedral angle of the regular tetrahedron, degrees.
const REGULAR_DIHEDRAL: f64 = 70.528_779_365_509_3;
/// Chunk size of the deterministic parallel loops.
const CHUNK: usize = 4096;

const INTERIOR: u8 = 0;
const BOUNDARY: u8 = 1;
const FIXED: u8 = 2;
/// A vertex removed since the snapshot was built (see [`Snapshot::refresh`]).
const DEAD: u8 = 3;

/// Dihedral quality: 1 for the regular tet, 0 when a dihedral angle reaches 0 or 180 degrees;
/// min(theta_min / 70.5, (180 - theta_max) / 109.5). Negative for inverted tets. This is the
/// measure the targets are stated in (minimum and maximum dihedral angle).
pub(crate) fn tq(p: [DVec3; 4]) -> f64 {
    match cos_extremes(p) {
        None => -1.0,
        Some((cmax, cmin)) => tq_of_cosines(cmax, cmin),
    }
}

/// The largest and the smallest dihedral cosine of a positive tet; `None` when it is not
/// positive (or not finite).
#[inline]
fn cos_extremes(p: [DVec3; 4]) -> Option<(f64, f64)> {
    let v = crate::quality::tet_volume(p);
    if v <= 0.0 || !v.is_finite() {
        return None;
    }
    // Outward face normals; the dihedral at the edge shared by faces i and j has cosine
    // -n_i . n_j. Only the extreme cosines need an acos (this runs on every tet every step).
    let n = |a: usize, b: usize, c: usize| (p[b] - p[a]).cross(p[c] - p[a]).normalize_or_zero();
    let f = [n(1, 2, 3), n(0, 3, 2), n(0, 1, 3), n(0, 2, 1)];
    let (mut cmax, mut cmin) = (-1.0f64, 1.0f64);
    for i in 0..4 {
        for j in i + 1..4 {
            let c = -f[i].dot(f[j]);
            cmax = cmax.max(c);
            cmin = cmin.min(c);
        }
    }
    Some((cmax, cmin))
}

/// [`tq`] from the extreme cosines: the smallest angle (largest cosine) and the largest angle
/// (smallest cosine) against the regular tet's.
#[inline]
fn tq_of_cosines(cmax: f64, cmin: f64) -> f64 {
    let lo = cmax.clamp(-1.0, 1.0).acos().to_degrees();
    let hi = cmin.clamp(-1.0, 1.0).acos().to_degrees();
    (lo / REGULAR_DIHEDRAL).min((180.0 - hi) / (180.0 - REGULAR_DIHEDRAL))
}

/// Whether [`tq`] is below `thr`, without an acos: theta_min < thr 70.53 degrees or theta_max
/// > 180 - thr 109.47 degrees, compared as cosines (the scan over every tet every step).
fn tq_below(p: [DVec3; 4], cos_lo: f64, cos_hi: f64) -> bool {
    if crate::quality::tet_volume(p) <= 0.0 {
        return true;
    }
    let n = |a: usize, b: usize, c: usize| (p[b] - p[a]).cross(p[c] - p[a]).normalize_or_zero();
    let f = [n(1, 2, 3), n(0, 3, 2), n(0, 1, 3), n(0, 2, 1)];
    for i in 0..4 {
        for j in i + 1..4 {
            let c = -f[i].dot(f[j]);
            if c > cos_lo || c < cos_hi {
                return true;
            }
        }
    }
    false
}

/// The cosine bounds of [`tq_below`] for a threshold.
fn tq_cos_bounds(thr: f64) -> (f64, f64) {
    ((thr * REGULAR_DIHEDRAL).to_radians().cos(), (180.0 - thr * (180.0 - REGULAR_DIHEDRAL)).to_radians().cos())
}

struct Ctx<'a> {
    domain: &'a dyn Implicit3,
    opts: &'a Options3,
    projection: Projection,
    h_floor: f64,
    report: Report3,
    rng: u64,
    trace: bool,
    /// The worst tq at the start of the last polish round.
    polish_worst: f64,
    /// The fixed points: the user's, then the points the start put on sharp edges.
    fixed: Vec<DVec3>,
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
            Err(ProjectError::NonFinite { value }) => {
                Err(Error::NonFinite { what: "the distance function", value, at: [p.x, p.y, p.z] })
            }
            Err(_) => Ok(None),
        }
    }
    /// Approximate distance: d itself for distances, d / |grad d| otherwise.
    fn approx_dist(&self, p: DVec3) -> Result<f64, Error> {
        let d = self.d(p)?;
        if self.domain.is_distance() {
            Ok(d)
        } else {
            let g = self.domain.gradient(p).length();
            Ok(if g > 0.0 && g.is_finite() { d / g } else { d })
        }
    }
    /// SplitMix64 on the options' seed: the only randomness, so runs repeat bit for bit.
    fn next_f64(&mut self) -> f64 {
        self.rng = self.rng.wrapping_add(0x9E37_79B9_7F4A_7C15);
        splitmix_unit(self.rng)
    }
}

// ============================ input checks ============================

fn eval_d(domain: &dyn Implicit3, p: DVec3) -> Result<f64, Error> {
    let d = domain.value(p);
    if d.is_finite() {
        Ok(d)
    } else {
        Err(Error::NonFinite { what: "the distance function", value: d, at: [p.x, p.y, p.z] })
    }
}

/// The relative size, raised to `floor` where it is not positive (outside the domain, where
/// size functions need not make sense); non-finite values are errors.
fn eval_h_floor(opts: &Options3, p: DVec3, floor: f64) -> Result<f64, Error> {
    match &opts.size {
        None => Ok(1.0),
        Some(h) => {
            let v = h(p);
            if !v.is_finite() {
                Err(Error::NonFinite { what: "the size function", value: v, at: [p.x, p.y, p.z] })
            } else {
                Ok(v.max(floor))
            }
        }
    }
}

struct Survey {
    estimated_tets: f64,
    h_floor: f64,
}

/// Checks h0, the box, the fixed points, d and h on a sample grid, and the element estimate,
/// before anything large is allocated.
fn survey(domain: &dyn Implicit3, opts: &Options3) -> Result<Survey, Error> {
    let h0 = opts.h0;
    if !h0.is_finite() || h0 <= 0.0 {
        return Err(Error::BadSize(format!("h0 must be positive and finite, got {h0}")));
    }
    let [lo, hi] = opts.bbox;
    if !lo.is_finite() || !hi.is_finite() {
        return Err(Error::BadBox(format!("the box {lo:?} - {hi:?} is not finite")));
    }
    if !(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z) {
        return Err(Error::BadBox(format!(
            "the box {lo:?} - {hi:?} is empty or inverted: each max must exceed its min"
        )));
    }
    for p in &opts.fixed {
        if !p.is_finite() {
            let bad = p.to_array().into_iter().find(|x| !x.is_finite()).unwrap_or(f64::NAN);
            return Err(Error::BadCoordinate { what: "fixed point", value: bad });
        }
        if p.cmplt(lo).any() || p.cmpgt(hi).any() {
            return Err(Error::Invalid(format!("fixed point {p:?} lies outside the box")));
        }
    }
    if !opts.fscale.is_finite() || opts.fscale <= 0.0 || !opts.deltat.is_finite() || opts.deltat <= 0.0 {
        return Err(Error::Invalid(format!(
            "fscale and deltat must be positive and finite, got {} and {}",
            opts.fscale, opts.deltat
        )));
    }
    let ext = hi - lo;
    let n = |e: f64| ((e / h0).ceil() as usize + 1).clamp(8, 96);
    let (nx, ny, nz) = (n(ext.x), n(ext.y), n(ext.z));
    let step = ext / DVec3::new((nx - 1) as f64, (ny - 1) as f64, (nz - 1) as f64);
    let mut inside = 0usize;
    let mut density = 0.0;
    let mut h_floor = f64::INFINITY;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = lo + DVec3::new(i as f64, j as f64, k as f64) * step;
                if eval_d(domain, p)? < 0.0 {
                    let h = eval_h_floor(opts, p, f64::NEG_INFINITY)?;
                    if h <= 0.0 {
                        return Err(Error::BadSize(format!(
                            "the size function is {h} at {p:?} inside the domain; it must be positive"
                        )));
                    }
                    inside += 1;
                    density += 1.0 / (h * h * h);
                    h_floor = h_floor.min(h);
                } else {
                    eval_h_floor(opts, p, 0.0)?;
                }
            }
        }
    }
    if inside == 0 {
        // Cell centres once more before giving up (thin domains).
        let mut found = false;
        'outer: for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    let p = lo + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * step;
                    if eval_d(domain, p)? < 0.0 {
                        found = true;
                        break 'outer;
                    }
                }
            }
        }
        if !found {
            return Err(Error::EmptyDomain(format!(
                "the distance function is non-negative at every sample of the box {lo:?} - {hi:?}"
            )));
        }
        inside = 1;
        density = 1.0;
        h_floor = 1.0;
    }
    let _ = inside;
    let cell = step.x * step.y * step.z;
    // About 6.4 tets per node in a good mesh; the BCC start has 2 nodes per (LATTICE h)^3.
    let nodes = density * h_floor.powi(3) * cell * 2.0 / (LATTICE * h0).powi(3);
    let estimated_tets = 6.4 * nodes;
    if estimated_tets > opts.max_elements as f64 {
        return Err(Error::TooManyElements { estimated: estimated_tets as u64, limit: opts.max_elements });
    }
    Ok(Survey { estimated_tets, h_floor })
}

// ============================ the run ============================

pub(crate) fn run(domain: &dyn Implicit3, opts: &Options3) -> Result<MeshOutput3, Error> {
    let t0 = Instant::now();
    let survey = survey(domain, opts)?;
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
        report: Report3::default(),
        rng: opts.seed ^ 0x7472_7573_736d_6533,
        trace: std::env::var_os("TRUSSMESH_TRACE").is_some(),
        polish_worst: f64::NEG_INFINITY,
        fixed: opts.fixed.clone(),
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
    repeat_rounds(&mut ctx, &mut mesh, RR_ROUNDS, "mean quality", Some(RR_ROUND_GAIN), |c, m, _| {
        mean_quality_round(c, m)
    })?;
    if ctx.trace {
        let mut w: Vec<(f64, TetId)> = mesh.tet_ids().map(|t| (tq(mesh.tet_points(t)), t)).collect();
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
    if let Err(e) = mesh.validate(Level::Geometry) {
        return Err(Error::Internal(format!("the finished mesh is invalid: {e}")));
    }
    let mut report = ctx.report;
    report.seconds = t0.elapsed().as_secs_f64();
    report.quality = QualityStats3::of(&mesh);
    Ok(MeshOutput3 { mesh, report })
}

// ============================ initial mesh ============================

/// The SplitMix64 output for state `z` (Steele, Lea and Flood 2014), as a number in [0, 1).
fn splitmix_unit(z: u64) -> f64 {
    let mut z = z;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// A deterministic pseudo-random vector in [-1, 1]^3 for index i.
fn jitter(i: u64) -> DVec3 {
    let unit =
        |k: u64| 2.0 * splitmix_unit(i.wrapping_mul(3).wrapping_add(k).wrapping_add(0x9E37_79B9_7F4A_7C15)) - 1.0;
    DVec3::new(unit(0), unit(1), unit(2))
}

/// BCC lattice points inside, thinned by the size function; Delaunay; carve; repair pinches.
fn initial_mesh(ctx: &mut Ctx, estimate: f64) -> Result<TetMesh, Error> {
    let opts = ctx.opts;
    let [lo, hi] = opts.bbox;
    let a = LATTICE * opts.h0;
    let n = ((hi - lo) / a).ceil().as_uvec3() + 1;
    let uniform = opts.size.is_none();
    let mut pts: Vec<DVec3> = Vec::with_capacity((estimate / 6.0) as usize + 16);
    // Surface points: lattice points near d = 0 projected onto it, thinned greedily (in lattice
    // order, so deterministically) to SURFACE_GAP lattice sides times h apart. The carved
    // mesh's boundary then starts on the surface instead of a lattice row inside it.
    let gap = SURFACE_GAP * a;
    let mut grid: HashMap<[i64; 3], SmallVec<[DVec3; 4]>> = HashMap::new();
    let cell = |p: DVec3| (p / gap).floor().as_i64vec3().to_array();
    for k in 0..n.z {
        for j in 0..n.y {
            for i in 0..n.x {
                for off in [0.0, 0.5] {
                    let p = lo + (DVec3::new(i as f64, j as f64, k as f64) + off) * a;
                    if p.cmpgt(hi).any() {
                        continue;
                    }
                    let d = ctx.approx_dist(p)?;
                    let h = if uniform { 1.0 } else { ctx.h(p)? };
                    if d < -INTERIOR_DEPTH * a * h {
                        // Seed 2.3: rejection with probability 1 - (h_min / h)^3.
                        if !uniform && ctx.next_f64() > 1.0 / (h * h * h) {
                            continue;
                        }
                        if opts.fixed.iter().any(|f| f.distance(p) < 0.5 * a * h) {
                            continue;
                        }
                        // Moved by a tiny deterministic offset: during the insertion the
                        // lattice forms many cospherical sets, whose insphere tests leave the
                        // floating-point filter for exact arithmetic. Off the lattice by 1e-6
                        // of its side, the start's Delaunay at 10^6 tets takes 0.56 s instead
                        // of 2.0 s. Where the lattice is degenerate the offset picks another
                        // triangulation (a few near-flat tets among them, which the force
                        // loop's swaps remove); the surface and fixed points are not moved.
                        pts.push(p + LATTICE_JITTER * a * jitter(pts.len() as u64));
                    } else if d.abs() < a * h {
                        let Some(q) = ctx.project(p)? else { continue };
                        let hq = if uniform { 1.0 } else { ctx.h(q)? };
                        let r = gap * hq;
                        let c = cell(q);
                        let reach = (r / gap).ceil() as i64;
                        let mut near = false;
                        'scan: for dz in -reach..=reach {
                            for dy in -reach..=reach {
                                for dx in -reach..=reach {
                                    if let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                                        if list.iter().any(|&x| x.distance(q) < r) {
                                            near = true;
                                            break 'scan;
                                        }
                                    }
                                }
                            }
                        }
                        if near || opts.fixed.iter().any(|f| f.distance(q) < 0.5 * a * hq) {
                            continue;
                        }
                        grid.entry(c).or_default().push(q);
                        pts.push(q);
                    }
                }
            }
        }
    }
    let t_crease = Instant::now();
    let creases = if opts.sharp_edges { crease_points(ctx, &grid, gap)? } else { Vec::new() };
    if ctx.trace {
        eprintln!(
            "start: {} points on sharp edges, held fixed ({:.3} s)",
            creases.len(),
            t_crease.elapsed().as_secs_f64()
        );
    }
    if !creases.is_empty() {
        // Start points near a crease point give way to it, as to a fixed point.
        let near = |p: DVec3| -> Result<bool, Error> {
            let h = if uniform { 1.0 } else { ctx.h(p)? };
            Ok(creases.iter().any(|c| c.distance(p) < 0.5 * a * h))
        };
        let mut kept = Vec::with_capacity(pts.len());
        for p in pts {
            if !near(p)? {
                kept.push(p);
            }
        }
        pts = kept;
        ctx.report.sharp_edge_points = creases.len();
        ctx.fixed.extend(creases);
    }
    pts.extend(ctx.fixed.iter().copied());
    if pts.len() < 4 {
        return Err(Error::EmptyDomain(format!(
            "only {} lattice points fall inside the domain at h0 = {}: h0 is too large for it",
            pts.len(),
            opts.h0
        )));
    }
    let (del, _) = TetMesh::delaunay(&pts)?;
    if del.num_tets() as u64 > opts.max_elements {
        return Err(Error::TooManyElements { estimated: del.num_tets() as u64, limit: opts.max_elements });
    }
    let (points, tets, _, _) = del.to_arrays();
    drop(del);
    // Seed: keep tets whose centroid is inside by more than geps = 0.1 h0.
    let geps = 0.1 * opts.h0;
    let keep: Vec<bool> = tets
        .par_iter()
        .with_min_len(CHUNK)
        .map(|t| {
            let c = (points[t[0]] + points[t[1]] + points[t[2]] + points[t[3]]) / 4.0;
            ctx.approx_dist(c).map(|d| d < -geps)
        })
        .collect::<Result<_, Error>>()?;
    let mut tets: Vec<[usize; 4]> = tets.into_iter().zip(keep).filter(|x| x.1).map(|x| x.0).collect();
    tets.par_sort_unstable_by_key(|t| (*t.iter().min().expect("four"), *t));
    let mut mesh = repair_pinches(&points, &mut tets)?;
    tag_built_mesh(&mut mesh, &ctx.fixed);
    Ok(mesh)
}

/// Points on the domain's sharp edges, at about one target length apart, which the start
/// holds fixed: the seed keeps sharp features with fixed points, and a polyhedron meshed
/// without them folds its boundary where nodes near an edge are projected onto one face or the
/// other (the cube at h0 = 0.17 kept 0-degree tets). Two surface start points (`grid`, cells
/// of side `gap`) closer than sharp::REACH gaps whose normals differ by more than sharp::SHARP_DEG
/// degrees straddle an edge: the point of the line where their tangent planes meet nearest to
/// their midpoint, projected onto d = 0, is on it (exactly for planar faces). A surface point
/// whose normals differ on either side of it lies on an edge itself. The corners where three
/// faces meet ([`corner_points`]) and then these points are thinned greedily, in the start's
/// lattice order, to sharp::SPACING target lengths apart and kept clear of the user's fixed
/// points.
fn crease_points(ctx: &Ctx, grid: &HashMap<[i64; 3], SmallVec<[DVec3; 4]>>, gap: f64) -> Result<Vec<DVec3>, Error> {
    let opts = ctx.opts;
    let uniform = opts.size.is_none();
    let cos_max = sharp::SHARP_DEG.to_radians().cos();
    let mut cells: Vec<&[i64; 3]> = grid.keys().collect();
    cells.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
    // Each surface point with its unit normal, computed once.
    let mut normals: HashMap<[i64; 3], SmallVec<[(DVec3, DVec3); 4]>> = HashMap::with_capacity(cells.len());
    for &c in &cells {
        let list = grid[c].iter().map(|&q| (q, ctx.domain.gradient(q).normalize_or_zero())).collect();
        normals.insert(*c, list);
    }
    // Points on edges with the normals of their two faces.
    let mut found: Vec<(DVec3, DVec3, DVec3)> = Vec::new();
    for c in cells {
        for &(q1, n1) in &normals[c] {
            if n1.length_squared() < 0.5 {
                continue;
            }
            let h1 = if uniform { 1.0 } else { ctx.h(q1)? };
            // A surface point on the edge itself (the projection of a lattice point as far from
            // both faces ends there): the normals a hair's breadth away on either side differ.
            let eps = sharp::PROBE * gap * h1;
            // Probes a little inside (a distance built from unsigned distances has a kink on
            // d = 0, where its gradient can be anything), on every side of the point.
            let probes = [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z]
                .map(|e| ctx.domain.gradient(q1 + (e - n1) * eps).normalize_or_zero());
            // A probe without a normal says nothing.
            let probes: SmallVec<[DVec3; 6]> = probes.into_iter().filter(|n| n.length_squared() > 0.5).collect();
            let split = probes
                .iter()
                .flat_map(|&a| probes.iter().map(move |&b| (a.dot(b), a, b)))
                .min_by(|x, y| x.0.total_cmp(&y.0));
            if let Some((cos, a, b)) = split {
                if cos < cos_max {
                    found.push((q1, a, b));
                }
            }
            let reach = sharp::REACH * gap * h1;
            let span = (reach / gap).ceil() as i64;
            for dz in -span..=span {
                for dy in -span..=span {
                    for dx in -span..=span {
                        let Some(list) = normals.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else { continue };
                        for &(q2, n2) in list {
                            // Each pair once, in a fixed order.
                            if q2.to_array() <= q1.to_array() || q2.distance(q1) > reach || n2.length_squared() < 0.5 {
                                continue;
                            }
                            let cos = n1.dot(n2);
                            if cos > cos_max || cos < -cos_max {
                                continue;
                            }
                            // x = m + alpha n1 + beta n2 on both tangent planes.
                            let m = (q1 + q2) * 0.5;
                            let (r1, r2) = (n1.dot(q1 - m), n2.dot(q2 - m));
                            let det = 1.0 - cos * cos;
                            let x = m + n1 * ((r1 - cos * r2) / det) + n2 * ((r2 - cos * r1) / det);
                            if x.distance(m) > reach {
                                continue;
                            }
                            let Some(p) = ctx.project(x)? else { continue };
                            if p.distance(x) <= sharp::TOL * gap * h1 {
                                found.push((p, n1, n2));
                            }
                        }
                    }
                }
            }
        }
    }
    let corners = corner_points(ctx, &found, gap, cos_max)?;
    let n_corners = corners.len();
    let mut kept: Vec<DVec3> = Vec::new();
    let candidates = corners.into_iter().map(|p| (p, None)).chain(found.into_iter().map(|f| (f.0, Some((f.1, f.2)))));
    for (k, (p, faces)) in candidates.enumerate() {
        let h = if uniform { 1.0 } else { ctx.h(p)? };
        let s = sharp::SPACING * opts.h0 * h;
        if kept.iter().any(|k| k.distance(p) < s) || opts.fixed.iter().any(|f| f.distance(p) < s) {
            continue;
        }
        if p.cmplt(opts.bbox[0]).any() || p.cmpgt(opts.bbox[1]).any() {
            continue;
        }
        let p = match faces {
            Some((n1, n2)) if k >= n_corners => refine_edge_point(ctx, p, n1, n2, gap * h)?,
            _ => p,
        };
        kept.push(p);
    }
    Ok(kept)
}

/// Moves the edge point `p` (faces of normals `n1`, `n2`) to the point nearest it on the line
/// where the faces' tangent planes meet, the planes taken at points of each face ever closer to
/// it (from a tenth of `s` down by ten each, sharp::REFINE_STEPS steps): exact already for planar
/// faces; on a curved edge (a cylinder's rim) the error falls with the square of the distance.
fn refine_edge_point(ctx: &Ctx, p: DVec3, n1: DVec3, n2: DVec3, s: f64) -> Result<DVec3, Error> {
    let (mut x, mut a, mut b) = (p, n1, n2);
    let mut delta = 0.1 * s;
    for _ in 0..sharp::REFINE_STEPS {
        // A point of each face, delta from the edge across it: of the two ways, the one whose
        // normal (taken a little inside) stays with the face.
        let face = |n: DVec3, other: DVec3| -> Result<Option<(DVec3, DVec3)>, Error> {
            let Some(across) = (other - n * n.dot(other)).try_normalize() else { return Ok(None) };
            let mut best: Option<(f64, DVec3, DVec3)> = None;
            for dir in [across, -across] {
                if let Some(q) = ctx.project(x + dir * delta)? {
                    let m = ctx.domain.gradient(q - n * (1e-3 * delta)).normalize_or_zero();
                    if m.length_squared() > 0.5 && best.map_or(true, |(c, _, _)| m.dot(n) > c) {
                        best = Some((m.dot(n), q, m));
                    }
                }
            }
            Ok(best.map(|(_, q, m)| (q, m)))
        };
        let (Some((q1, m1)), Some((q2, m2))) = (face(a, b)?, face(b, a)?) else { break };
        let cos = m1.dot(m2);
        let det = 1.0 - cos * cos;
        if det < 1e-6 {
            break;
        }
        // The point of both planes nearest x: x + alpha m1 + beta m2.
        let (r1, r2) = (m1.dot(q1 - x), m2.dot(q2 - x));
        let y = x + m1 * ((r1 - cos * r2) / det) + m2 * ((r2 - cos * r1) / det);
        let Some(y) = ctx.project(y)? else { break };
        if y.distance(x) > 2.0 * delta {
            break;
        }
        (x, a, b) = (y, m1, m2);
        delta *= 0.1;
    }
    Ok(x)
}

/// Corners where three faces meet, from the points on edges (`found`, each with the normals of
/// its two faces): two such points within reach whose faces bring a third normal (more than
/// sharp::SHARP_DEG from both of the first point's) meet at the point of all three tangent planes,
/// kept when its projection onto d = 0 hardly moves it. They go first into the thinning.
fn corner_points(ctx: &Ctx, found: &[(DVec3, DVec3, DVec3)], gap: f64, cos_max: f64) -> Result<Vec<DVec3>, Error> {
    let uniform = ctx.opts.size.is_none();
    let cell = |p: DVec3| (p / gap).floor().as_i64vec3().to_array();
    let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (k, f) in found.iter().enumerate() {
        cells.entry(cell(f.0)).or_default().push(k);
    }
    let distinct = |n: DVec3, m: DVec3| {
        let c = n.dot(m);
        c < cos_max && c > -cos_max
    };
    let mut corners = Vec::new();
    for (k, &(pa, a1, a2)) in found.iter().enumerate() {
        let h = if uniform { 1.0 } else { ctx.h(pa)? };
        let reach = sharp::REACH * gap * h;
        let span = (reach / gap).ceil() as i64;
        let c = cell(pa);
        for dz in -span..=span {
            for dy in -span..=span {
                for dx in -span..=span {
                    let Some(list) = cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else { continue };
                    for &j in list {
                        let (pb, b1, b2) = found[j];
                        if j <= k || pb.distance(pa) > reach {
                            continue;
                        }
                        for nb in [b1, b2] {
                            if !distinct(nb, a1) || !distinct(nb, a2) {
                                continue;
                            }
                            let m = glam::DMat3::from_cols(a1, a2, nb).transpose();
                            if m.determinant().abs() < 0.1 {
                                continue;
                            }
                            let x = m.inverse() * DVec3::new(a1.dot(pa), a2.dot(pa), nb.dot(pb));
                            if !x.is_finite() || x.distance(pa) > reach {
                                continue;
                            }
                            let Some(p) = ctx.project(x)? else { continue };
                            if p.distance(x) <= sharp::TOL * gap * h {
                                corners.push(p);
                            }
                        }
                    }
                }
            }
        }
    }
    Ok(corners)
}

/// Tags a mesh built from arrays: vertices on boundary faces `Boundary`, the fixed points
/// `Fixed`. Returns how many fixed points it holds.
fn tag_built_mesh(m: &mut TetMesh, fixed: &[DVec3]) -> usize {
    m.tag_boundary_vertices();
    let mut found = 0;
    for v in m.vertex_ids().collect::<Vec<_>>() {
        if fixed.contains(&m.pos(v)) {
            m.set_tag(v, VertexTag::Fixed);
            found += 1;
        }
    }
    found
}

/// Builds the mesh from the kept tets, dropping the smaller side wherever tets meet only at a
/// vertex or only along an edge, so that the boundary is a 2-manifold.
fn repair_pinches(points: &[DVec3], tets: &mut Vec<[usize; 4]>) -> Result<TetMesh, Error> {
    for _round in 0..64 {
        if tets.is_empty() {
            return Err(Error::EmptyDomain("no tetrahedron has its centroid inside the domain".into()));
        }
        // Compact the used points.
        let mut map = vec![usize::MAX; points.len()];
        let mut used = Vec::new();
        for t in tets.iter() {
            for &i in t {
                if map[i] == usize::MAX {
                    map[i] = used.len();
                    used.push(points[i]);
                }
            }
        }
        let local: Vec<[usize; 4]> = tets.iter().map(|t| t.map(|i| map[i])).collect();
        let (m, ids) = TetMesh::from_arrays(&used, &local)?;
        let tet_ids: Vec<TetId> = m.tet_ids().collect();
        let mut index: SecondaryMap<TetId, usize> = SecondaryMap::with_capacity(tet_ids.len());
        for (k, &t) in tet_ids.iter().enumerate() {
            index.insert(t, k);
        }
        let mut count = vec![0u32; used.len()];
        for t in &local {
            for &i in t {
                count[i] += 1;
            }
        }
        let mut drop = vec![false; local.len()];
        let mut any = false;
        // Star sizes in parallel; the few pinched vertices are handled in order.
        let short: Vec<usize> = {
            let mesh = &m;
            (0..ids.len())
                .into_par_iter()
                .with_min_len(1024)
                .filter(|&i| mesh.vertex_tets(ids[i]).len() < count[i] as usize)
                .collect()
        };
        for i in short {
            any = true;
            let star = m.vertex_tets(ids[i]);
            let small_is_walked = 2 * star.len() <= count[i] as usize;
            for (k, t) in local.iter().enumerate() {
                if t.contains(&i) && (star.iter().any(|&s| index[s] == k) == small_is_walked) {
                    drop[k] = true;
                }
            }
        }
        if !any {
            // Edges with more than two boundary faces: tets meeting only along the edge.
            let mut bcount: HashMap<(TVertexId, TVertexId), (u32, TetId, usize)> = HashMap::new();
            for (t, f) in m.boundary_faces() {
                let fv = m.face_vertices(t, f);
                for k in 0..3 {
                    let (x, y) = (fv[k], fv[(k + 1) % 3]);
                    let e = bcount.entry((x.min(y), x.max(y))).or_insert((0, t, f));
                    e.0 += 1;
                }
            }
            let mut bad: Vec<((TVertexId, TVertexId), TetId)> =
                bcount.into_iter().filter(|(_, c)| c.0 > 2).map(|(e, c)| (e, c.1)).collect();
            bad.sort();
            for ((x, y), t) in bad {
                any = true;
                let (i, j) = (m.local_index(t, x).expect("edge"), m.local_index(t, y).expect("edge"));
                let shell = m.edge_shell(t, i, j);
                let all: Vec<usize> = (0..local.len())
                    .filter(|&k| {
                        let tv = tet_ids[k];
                        m.tet(tv).v.contains(&x) && m.tet(tv).v.contains(&y)
                    })
                    .collect();
                let small_is_walked = 2 * shell.tets.len() <= all.len();
                for k in all {
                    if shell.tets.iter().any(|&s| index[s] == k) == small_is_walked {
                        drop[k] = true;
                    }
                }
            }
        }
        if !any {
            return Ok(m);
        }
        let mut k = 0;
        tets.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
    }
    Err(Error::Internal("the carved start mesh keeps pinched vertices".into()))
}

/// Whether tet t is squashed against the boundary: three or four of its vertices on it and its
/// centroid within GEPS h of d = 0 (or outside). The seed's retriangulation drops such tets.
fn squashed(ctx: &Ctx, m: &TetMesh, t: TetId) -> Result<bool, Error> {
    let tx = m.tet(t);
    if tx.v.iter().filter(|&&v| m.tag(v) != VertexTag::Interior).count() < 3 {
        return Ok(false);
    }
    let p = m.tet_points(t);
    let c = (p[0] + p[1] + p[2] + p[3]) / 4.0;
    Ok(ctx.approx_dist(c)? > -GEPS * ctx.opts.h0 * ctx.h(c)?)
}

/// The squashed tets ([`squashed`]) that the local removal refuses, in arena order.
fn stuck_tets(ctx: &Ctx, m: &TetMesh) -> Result<Vec<TetId>, Error> {
    let ids: Vec<TetId> = m.tet_ids().collect();
    ids.par_iter()
        .with_min_len(CHUNK)
        .map(|&t| Ok((squashed(ctx, m, t)? && m.check_remove_boundary_tet(t).is_err()).then_some(t)))
        .collect::<Result<Vec<Option<TetId>>, Error>>()
        .map(|v| v.into_iter().flatten().collect())
}

/// Drops the given tets at once and rebuilds the mesh from arrays with its pinches repaired,
/// as the start does. The force loop removes squashed tets one at a time where that keeps the
/// boundary a 2-manifold; a cluster of them bridging a concave part of the boundary (or
/// folded at a sharp edge) only goes together, and left alone it ends as slivers no swap can
/// reach. Returns whether the mesh changed; a carve that would lose a fixed point or split the
/// mesh into more pieces is not made.
fn carve(ctx: &Ctx, m: &mut TetMesh, gone: &[TetId]) -> Result<bool, Error> {
    if gone.is_empty() {
        return Ok(false);
    }
    let drop: SecondaryMap<TetId, ()> = gone.iter().map(|&t| (t, ())).collect();
    let keep: Vec<bool> = m.tet_ids().map(|t| !drop.contains_key(t)).collect();
    let (points, tets, _, _) = m.to_arrays();
    let mut kept: Vec<[usize; 4]> = tets.into_iter().zip(keep).filter(|x| x.1).map(|x| x.0).collect();
    // A carve whose pinches do not resolve is not made (the mesh as it is stays valid).
    let Ok(mut carved) = repair_pinches(&points, &mut kept) else { return Ok(false) };
    let found = tag_built_mesh(&mut carved, &ctx.fixed);
    if found < m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed).count() {
        return Ok(false);
    }
    // Nor one that splits the mesh: along a sharp edge the stuck tets can be all that holds a
    // corner on (the cube's corners broke off that way).
    if count_pieces(&carved) > count_pieces(m) {
        return Ok(false);
    }
    *m = carved;
    Ok(true)
}

/// The face-connected piece of each tet (a representative tet index per piece), in arena order.
fn pieces(m: &TetMesh) -> (Vec<TetId>, Vec<usize>) {
    let ids: Vec<TetId> = m.tet_ids().collect();
    let mut index: SecondaryMap<TetId, usize> = SecondaryMap::with_capacity(ids.len());
    for (k, &t) in ids.iter().enumerate() {
        index.insert(t, k);
    }
    let mut sets = crate::topology::DisjointSets::new(ids.len());
    for (k, &t) in ids.iter().enumerate() {
        for (u, _) in m.tet(t).adj.iter().flatten() {
            sets.join(k, index[*u]);
        }
    }
    let roots = (0..ids.len()).map(|k| sets.root(k)).collect();
    (ids, roots)
}

/// How many face-connected pieces the mesh has.
fn count_pieces(m: &TetMesh) -> usize {
    let (_, mut roots) = pieces(m);
    roots.sort_unstable();
    roots.dedup();
    roots.len()
}

/// Drops face-connected pieces of fewer than SPECK_TETS tets holding less than 1e-3 of the
/// volume, unless they alone hold a fixed point: a tet whose neighbours all left one by one
/// (each removal keeps its own boundary manifold, not a neighbour's) is cut off, and at a sharp
/// edge it may be flat. Returns whether the mesh changed.
fn drop_specks(ctx: &Ctx, m: &mut TetMesh) -> Result<bool, Error> {
    let (ids, roots) = pieces(m);
    let vols: Vec<f64> = ids.iter().map(|&t| crate::quality::tet_volume(m.tet_points(t))).collect();
    let total: f64 = vols.iter().sum();
    let mut piece: HashMap<usize, (usize, f64)> = HashMap::new();
    for (&root, &vol) in roots.iter().zip(&vols) {
        let e = piece.entry(root).or_insert((0, 0.0));
        e.0 += 1;
        e.1 += vol;
    }
    let speck = |k: usize| {
        let (n, v) = piece[&roots[k]];
        n < SPECK_TETS && v < 1e-3 * total
    };
    // A fixed point that only specks hold keeps them.
    let mut kept_fixed: SecondaryMap<TVertexId, bool> = SecondaryMap::new();
    for (k, &t) in ids.iter().enumerate() {
        let is_speck = speck(k);
        for &v in &m.tet(t).v {
            if m.tag(v) == VertexTag::Fixed {
                let e = kept_fixed.entry(v).expect("live vertex").or_insert(false);
                *e |= !is_speck;
            }
        }
    }
    let gone: Vec<TetId> = (0..ids.len())
        .filter(|&k| speck(k) && m.tet(ids[k]).v.iter().all(|&v| m.tag(v) != VertexTag::Fixed || kept_fixed[v]))
        .map(|k| ids[k])
        .collect();
    carve(ctx, m, &gone)
}

// ============================ snapshot ============================

/// Free entries at the end of each neighbour row of the snapshot, so that a refresh after
/// local flips rewrites the touched rows in place.
const ROW_SLACK: usize = 4;

/// Compact arrays of the mesh for the force loop, refreshed when the topology changes.
struct Snapshot {
    ids: Vec<TVertexId>,
    /// Position of each vertex in `ids`.
    index: SecondaryMap<TVertexId, u32>,
    kind: Vec<u8>,
    tets: Vec<[u32; 4]>,
    tet_ids: Vec<TetId>,
    /// Each vertex's row in `adj` (start, end): rows are contiguous after a build; a refresh
    /// moves a row that outgrew its slack to the end.
    rows: Vec<(u32, u32)>,
    /// Neighbours of each vertex (CSR), in increasing order; an entry equal to its own vertex
    /// (ROW_SLACK of them at the end of each row, and edges removed since the build) is
    /// skipped by every loop.
    adj: Vec<u32>,
    /// Entries dead or added and rows moved since the build.
    spent: usize,
}

fn kind_of(tag: VertexTag) -> u8 {
    match tag {
        VertexTag::Fixed => FIXED,
        VertexTag::Boundary => BOUNDARY,
        _ => INTERIOR,
    }
}

impl Snapshot {
    /// The entries of vertex i's row.
    #[inline]
    fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.rows[i].0 as usize..self.rows[i].1 as usize
    }

    /// Vertex i's neighbours, with self-entries to skip.
    #[inline]
    fn row(&self, i: usize) -> &[u32] {
        &self.adj[self.range(i)]
    }

    /// Drops the edge a-b from the neighbour lists: each entry becomes its own vertex's index,
    /// which every loop over neighbours skips (a zero-length bar exerts no force).
    fn remove_edge(&mut self, a: usize, b: usize) {
        for (x, y) in [(a, b), (b, a)] {
            let range = self.range(x);
            let list = &mut self.adj[range];
            if let Some(e) = list.iter_mut().find(|e| **e as usize == y) {
                *e = x as u32;
            }
        }
    }

    /// Drops the tets at the given positions, keeping the others in order (as a rebuild
    /// would list them).
    fn remove_tets(&mut self, positions: &[usize]) {
        let mut gone = positions.to_vec();
        gone.sort_unstable();
        let mut next = gone.iter().peekable();
        let mut w = 0;
        for r in 0..self.tets.len() {
            if next.peek() == Some(&&r) {
                next.next();
                continue;
            }
            self.tets[w] = self.tets[r];
            self.tet_ids[w] = self.tet_ids[r];
            w += 1;
        }
        self.tets.truncate(w);
        self.tet_ids.truncate(w);
    }

    fn build(m: &TetMesh) -> Snapshot {
        let mut index: SecondaryMap<TVertexId, u32> = SecondaryMap::with_capacity(m.num_vertices());
        let mut ids = Vec::with_capacity(m.num_vertices());
        let mut kind = Vec::with_capacity(m.num_vertices());
        for v in m.vertex_ids() {
            index.insert(v, ids.len() as u32);
            ids.push(v);
            kind.push(kind_of(m.tag(v)));
        }
        let mut tets = Vec::with_capacity(m.num_tets());
        let mut tet_ids = Vec::with_capacity(m.num_tets());
        for t in m.tet_ids() {
            tets.push(m.tet(t).v.map(|x| index[x]));
            tet_ids.push(t);
        }
        // Vertex -> tets by counting, then each vertex's neighbours, sorted, in parallel blocks
        // of vertices (deterministic): no global sort of the 12 T directed edges. A vertex's
        // tets name each neighbour several times (about 70 names for 14 neighbours): a stamp per
        // vertex drops the repeats before the sort, and each block fills one flat list (one
        // allocation per block, not per vertex).
        let n = ids.len();
        let inc = crate::topology::Incidence::new(n, &tets);
        const BLOCK: usize = 1024;
        // Jobs of at least 16 blocks: each job clears a stamp array of n entries.
        let blocks: Vec<(Vec<u32>, Vec<u32>)> = (0..n.div_ceil(BLOCK))
            .into_par_iter()
            .with_min_len(16)
            .map_init(
                || vec![u32::MAX; n],
                |seen, b| {
                    let (mut flat, mut counts) =
                        (Vec::with_capacity((16 + ROW_SLACK) * BLOCK), Vec::with_capacity(BLOCK));
                    for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                        let first = flat.len();
                        for &k in inc.of(i) {
                            for &j in &tets[k as usize] {
                                if j as usize != i && seen[j as usize] != i as u32 {
                                    seen[j as usize] = i as u32;
                                    flat.push(j);
                                }
                            }
                        }
                        flat[first..].sort_unstable();
                        flat.extend([i as u32; ROW_SLACK]);
                        counts.push((flat.len() - first) as u32);
                    }
                    (flat, counts)
                },
            )
            .collect();
        let mut rows = Vec::with_capacity(n);
        let mut adj = Vec::with_capacity(blocks.iter().map(|b| b.0.len()).sum());
        for (flat, counts) in &blocks {
            for &c in counts {
                let start = rows.last().map_or(0, |r: &(u32, u32)| r.1);
                rows.push((start, start + c));
            }
            adj.extend_from_slice(flat);
        }
        Snapshot { ids, index, kind, tets, tet_ids, rows, adj, spent: 0 }
    }

    /// Brings the snapshot up to date after local topology changes: the kinds and the tets are
    /// read again, and only the rows of the vertices the journal names are recomputed. A vertex
    /// removed stays as a DEAD entry with an empty row; a vertex added is appended with a row
    /// of its own. The loops skip the self-entries and the dead, so the forces are a rebuild's.
    /// False when the dead and added entries and the moved rows pass 1/8 of the vertices:
    /// rebuild then.
    fn refresh(&mut self, m: &TetMesh, journal: &Journal) -> bool {
        let mut keys: Vec<TVertexId> = journal.touched.clone();
        keys.sort_unstable();
        keys.dedup();
        // The dead first: a new vertex may reuse a dead one's slot with a newer version.
        for &v in &keys {
            if !m.contains_vertex(v) {
                if let Some(i) = self.index.remove(v) {
                    let i = i as usize;
                    self.kind[i] = DEAD;
                    let row = self.range(i);
                    self.adj[row].fill(i as u32);
                    self.spent += 1;
                }
            }
        }
        for &v in &keys {
            if m.contains_vertex(v) && !self.index.contains_key(v) {
                self.index.insert(v, self.ids.len() as u32);
                self.ids.push(v);
                self.kind.push(INTERIOR);
                self.spent += 1;
            }
        }
        let alive = self.ids.len() - self.kind.iter().filter(|&&k| k == DEAD).count();
        if alive != m.num_vertices() || 8 * self.spent > self.ids.len() {
            return false;
        }
        for (k, &v) in self.ids.iter().enumerate() {
            if self.kind[k] != DEAD {
                self.kind[k] = kind_of(m.tag(v));
            }
        }
        self.tets.clear();
        self.tet_ids.clear();
        for t in m.tet_ids() {
            self.tets.push(m.tet(t).v.map(|x| self.index[x]));
            self.tet_ids.push(t);
        }
        let mut touched: Vec<u32> = keys.iter().filter_map(|&v| self.index.get(v).copied()).collect();
        touched.sort_unstable();
        let rows: Vec<SmallVec<[u32; 32]>> = touched
            .par_iter()
            .with_min_len(64)
            .map(|&i| {
                let mut r: SmallVec<[u32; 32]> =
                    m.vertex_neighbours(self.ids[i as usize]).iter().map(|&w| self.index[w]).collect();
                r.sort_unstable();
                r
            })
            .collect();
        // Rows in place where they fit; at the end (with fresh slack) where they do not, and
        // for the added vertices.
        let old_n = self.rows.len();
        self.rows.resize(self.ids.len(), (0, 0));
        for (&i, r) in touched.iter().zip(&rows) {
            let i = i as usize;
            let range = self.range(i);
            if i < old_n && r.len() <= range.len() {
                let row = &mut self.adj[range];
                row[..r.len()].copy_from_slice(r);
                row[r.len()..].fill(i as u32);
            } else {
                if i < old_n {
                    self.adj[range].fill(i as u32);
                    self.spent += 1;
                }
                let start = self.adj.len() as u32;
                self.adj.extend_from_slice(r);
                self.adj.extend([i as u32; ROW_SLACK]);
                self.rows[i] = (start, self.adj.len() as u32);
            }
        }
        true
    }
}

/// Deterministic parallel sum of pairs: fixed chunks, partial sums added in order.
fn det_sum(n: usize, f: impl Fn(usize) -> (f64, f64) + Sync) -> (f64, f64) {
    let parts: Vec<(f64, f64)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut s = (0.0, 0.0);
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let x = f(i);
                s.0 += x.0;
                s.1 += x.1;
            }
            s
        })
        .collect();
    parts.into_iter().fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1))
}

fn write_back(m: &mut TetMesh, snap: &Snapshot, p: &[DVec3]) {
    // Vertices removed since the snapshot (a tent dropped from the boundary) are skipped.
    for (k, &v) in snap.ids.iter().enumerate() {
        if m.contains_vertex(v) {
            m.set_pos_unchecked(v, p[k]);
        }
    }
}

fn mean_rr(snap: &Snapshot, p: &[DVec3]) -> f64 {
    let (s, n) = det_sum(snap.tets.len(), |k| {
        let t = snap.tets[k];
        (crate::quality::tet_radius_ratio(t.map(|i| p[i as usize])), 1.0)
    });
    s / n.max(1.0)
}

/// Halves the step of every vertex of a tet that would not be positive (exact), up to six
/// times, then puts those vertices back; repeats until every tet is positive. The old
/// positions are valid, so this ends.
fn guard_inversions(snap: &Snapshot, old: &[DVec3], newp: &mut [DVec3]) {
    let positive = |newp: &[DVec3], t: [u32; 4]| {
        orient3d(newp[t[0] as usize], newp[t[1] as usize], newp[t[2] as usize], newp[t[3] as usize]) == Sign::Positive
    };
    let mut bad: Vec<usize> =
        (0..snap.tets.len()).into_par_iter().with_min_len(CHUNK).filter(|&k| !positive(newp, snap.tets[k])).collect();
    let mut halvings = vec![0u8; old.len()];
    let mut moved = vec![false; old.len()];
    while !bad.is_empty() {
        let mut hit: Vec<u32> = bad.iter().flat_map(|&k| snap.tets[k]).collect();
        hit.sort_unstable();
        hit.dedup();
        for i in hit {
            let i = i as usize;
            if newp[i] == old[i] {
                continue;
            }
            halvings[i] += 1;
            newp[i] = if halvings[i] > 6 { old[i] } else { (old[i] + newp[i]) * 0.5 };
            moved[i] = true;
        }
        // Only the tets of vertices just moved back can have changed sign: the rescan looks
        // at them alone (a flag test per tet instead of an orientation).
        let newp_ro: &[DVec3] = newp;
        bad = (0..snap.tets.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .filter(|&k| {
                let t = snap.tets[k];
                t.iter().any(|&i| moved[i as usize]) && !positive(newp_ro, t)
            })
            .collect();
        moved.iter_mut().for_each(|x| *x = false);
    }
}

// ============================ force equilibrium ============================

/// Wall time per phase of the force loop, printed with TRUSSMESH_TRACE: where a large run
/// spends its time, measured rather than guessed.
struct PhaseClock {
    last: Instant,
    totals: Vec<(&'static str, f64)>,
}

impl PhaseClock {
    fn new() -> Self {
        PhaseClock { last: Instant::now(), totals: Vec::new() }
    }

    /// Adds the time since the previous lap to `phase`.
    fn lap(&mut self, phase: &'static str) {
        let now = Instant::now();
        let dt = (now - self.last).as_secs_f64();
        self.last = now;
        match self.totals.iter_mut().find(|e| e.0 == phase) {
            Some(e) => e.1 += dt,
            None => self.totals.push((phase, dt)),
        }
    }

    fn summary(&self) -> String {
        self.totals.iter().map(|(p, t)| format!("{p} {t:.2} s")).collect::<Vec<_>>().join(", ")
    }
}

/// Runs `step` for up to `rounds` rounds, stopping after a round that changed nothing (or, with
/// `min_gain`, raised the mean radius ratio by less than that); with tracing on, prints the
/// dihedral range and the mean radius ratio after each.
fn repeat_rounds(
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

fn equilibrium(ctx: &mut Ctx, m: &mut TetMesh) -> Result<(), Error> {
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
    let (mut best_q, mut converged, mut iter) = (Vec::new(), false, 0);
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
        let (sl, sh) = det_sum(p.len(), |i| {
            let mut s = (0.0, 0.0);
            for &j in snap.row(i) {
                let j = j as usize;
                if j == i {
                    continue;
                }
                let hb = 0.5 * (hv[i] + hv[j]);
                s.0 += p[i].distance(p[j]).powi(3);
                s.1 += hb * hb * hb;
            }
            s
        });
        let unit = (sl / sh).cbrt();
        let scale = opts.fscale * unit;
        let dt = opts.deltat;
        let mut newp: Vec<DVec3> = (0..p.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|i| {
                if snap.kind[i] == FIXED {
                    return p[i];
                }
                let mut f = DVec3::ZERO;
                for &j in snap.row(i) {
                    let j = j as usize;
                    let d = p[i] - p[j];
                    let l = d.length();
                    let l0 = 0.5 * (hv[i] + hv[j]) * scale;
                    if l > 0.0 && l0 > l {
                        f += d * ((l0 - l) / l);
                    }
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
            .filter(|&i| snap.kind[i] == BOUNDARY)
            .map(|i| Ok((i, ctx.project(newp[i])?.unwrap_or(p[i]))))
            .collect::<Result<_, Error>>()?;
        for (i, q) in fixes {
            newp[i] = q;
        }
        clock.lap("projection");
        guard_inversions(&snap, &p, &mut newp);
        clock.lap("step control");
        let max_move = (0..p.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .filter(|&i| snap.kind[i] == INTERIOR)
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
                .map(|i| p[i].distance(pold[i]) > TTOL * h0 * hv[i])
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
            ctx.report.flips += flips;
            topo_changed |= flips > 0;
        }
        clock.lap("delaunay flips");
        // Quality-driven swaps: the tets below SWAP_TQ, worst first, get the best edge removal
        // or 2-3 flip that raises the local worst quality (Lawson alone stalls in 3-D).
        if window_end {
            let (cl, ch) = tq_cos_bounds(SWAP_TQ);
            let mut bad: Vec<(f64, usize)> = (0..snap.tets.len())
                .into_par_iter()
                .with_min_len(CHUNK)
                .filter_map(|k| {
                    let q = snap.tets[k].map(|i| p[i as usize]);
                    tq_below(q, cl, ch).then(|| (tq(q), k))
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
            .filter(|&k| snap.tets[k].iter().filter(|&&i| snap.kind[i as usize] != INTERIOR).count() >= 3)
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
                    ctx.report.removed += 1;
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
                .filter(|&i| snap.kind[i] == BOUNDARY)
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
                if snap.kind[i] == INTERIOR && m.tag(snap.ids[i]) == VertexTag::Boundary {
                    snap.kind[i] = BOUNDARY;
                }
            }
            for (a, b) in lost {
                snap.remove_edge(a, b);
            }
            snap.remove_tets(&gone);
            pold.copy_from_slice(&p);
            hv = sizes(ctx, &p)?;
        } else if !uniform && iter % DENSITY_EVERY == 0 {
            hv = sizes(ctx, &p)?;
        }
        clock.lap("snapshot");
        if max_move < opts.dptol && iter > DENSITY_EVERY {
            converged = true;
            ctx.report.stop_reason = format!("nodes moved less than dptol = {} (relative to h)", opts.dptol);
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
                    let qq = tq(t.map(|i| p[i as usize]));
                    bins[((qq.max(0.0) * 10.0) as usize).min(5)] += 1;
                    if t.iter().all(|&i| snap.kind[i as usize] == INTERIOR) {
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
                    ctx.report.flips,
                    ctx.report.splits,
                    ctx.report.collapses,
                    ctx.report.removed
                );
            }
            best_q.push(best_q.last().map_or(q, |&b: &f64| b.max(q)));
            let n = best_q.len();
            if n > PLATEAU_WINDOWS
                && best_q[n - 1] - best_q[n - 1 - PLATEAU_WINDOWS] < PLATEAU_WINDOWS as f64 * QUALITY_PLATEAU
            {
                converged = true;
                ctx.report.stop_reason = "mean quality stopped improving".into();
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
    ctx.report.iterations = iter;
    ctx.report.converged = converged;
    if !converged {
        ctx.report.stop_reason =
            format!("iteration cap of {} reached; the mesh is the last valid state", opts.max_iter);
    }
    Ok(())
}

// ============================ density control ============================

/// Splits edges longer than SPLIT_ABOVE and collapses edges shorter than COLLAPSE_BELOW times
/// the current target (the mesh's own scale `unit` times h), one change per neighbourhood.
fn density_control(
    ctx: &mut Ctx,
    m: &mut TetMesh,
    snap: &Snapshot,
    p: &[DVec3],
    hv: &[f64],
    unit: f64,
) -> Result<bool, Error> {
    let mut long: Vec<(f64, u32, u32)> = Vec::new();
    let mut short: Vec<(f64, u32, u32)> = Vec::new();
    for i in 0..p.len() {
        for &j in snap.row(i) {
            let j = j as usize;
            if j <= i {
                continue;
            }
            let r = p[i].distance(p[j]) / (unit * 0.5 * (hv[i] + hv[j]));
            if r > SPLIT_ABOVE {
                long.push((r, i as u32, j as u32));
            } else if r < COLLAPSE_BELOW {
                short.push((r, i as u32, j as u32));
            }
        }
    }
    let mut changed = false;
    let mut touched = vec![false; p.len()];
    long.sort_by(|x, y| y.0.total_cmp(&x.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    for (_, i, j) in long {
        let (a, b) = (snap.ids[i as usize], snap.ids[j as usize]);
        if touched[i as usize] || touched[j as usize] {
            continue;
        }
        let Some(t) = m.find_edge(a, b) else { continue };
        let e = edge_index(m, t, a, b);
        let mid = (m.pos(a) + m.pos(b)) * 0.5;
        let boundary = !m.edge_shell(t, EDGE_VERTICES[e][0], EDGE_VERTICES[e][1]).closed;
        let mut at = mid;
        if boundary {
            if let Some(q) = ctx.project(mid)? {
                at = q;
            }
        }
        let split = m.split_edge(t, e, at).or_else(|_| m.split_edge(t, e, mid));
        if let Ok(v) = split {
            ctx.report.splits += 1;
            changed = true;
            touched[i as usize] = true;
            touched[j as usize] = true;
            ctx.report.flips += lawson_around(m, v);
        }
    }
    short.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    for (_, i, j) in short {
        if touched[i as usize] || touched[j as usize] {
            continue;
        }
        let (a, b) = (snap.ids[i as usize], snap.ids[j as usize]);
        if !m.contains_vertex(a) || !m.contains_vertex(b) {
            continue;
        }
        let Some(t) = m.find_edge(a, b) else { continue };
        let e = edge_index(m, t, a, b);
        // Interior vertices merge into the other end; two interior ends meet at the midpoint.
        let (pa, pb) = (m.pos(a), m.pos(b));
        let both_interior = m.tag(a) == VertexTag::Interior && m.tag(b) == VertexTag::Interior;
        let [li, _] = EDGE_VERTICES[e];
        let a_first = m.tet(t).v[li] == a;
        let mut done = None;
        for reverse in [false, true] {
            // `reverse == false` merges the edge's first local vertex into the second.
            let (gone, stay) = if a_first != reverse { (a, b) } else { (b, a) };
            let _ = gone;
            let pos = if both_interior { (pa + pb) * 0.5 } else { m.pos(stay) };
            if let Ok(plan) = m.check_collapse(t, e, reverse, pos) {
                if plan.min_quality > 0.05 {
                    let (made, _) = m.apply_patch(plan);
                    done = made.first().copied();
                    break;
                }
            }
        }
        if let Some(t) = done {
            ctx.report.collapses += 1;
            changed = true;
            touched[i as usize] = true;
            touched[j as usize] = true;
            let v = m.tet(t).v[0];
            ctx.report.flips += lawson_around(m, v);
        }
    }
    Ok(changed)
}

/// Local index (0..6) of edge a-b in tet t.
fn edge_index(m: &TetMesh, t: TetId, a: TVertexId, b: TVertexId) -> usize {
    let (i, j) = (m.local_index(t, a).expect("edge"), m.local_index(t, b).expect("edge"));
    let (i, j) = (i.min(j), i.max(j));
    EDGE_VERTICES.iter().position(|&[x, y]| x == i && y == j).expect("edge")
}

/// Lawson flips on the faces of the star of `v`.
fn lawson_around(m: &mut TetMesh, v: TVertexId) -> usize {
    let stack: Vec<(TetId, usize)> = m.vertex_tets(v).iter().flat_map(|&t| (0..4).map(move |f| (t, f))).collect();
    m.lawson(stack)
}

// ============================ surface flips ============================

/// Boundary edges whose two boundary triangles fail the planar Delaunay test (opposite angles
/// summing past 180 degrees) are flipped when the tets allow it; returns the count.
fn surface_flips(ctx: &mut Ctx, m: &mut TetMesh) -> Result<usize, Error> {
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
        }
    }
    cands.sort_by(|x, y| y.0.total_cmp(&x.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    let mut n = 0;
    for (_, a, b) in cands {
        let Some(s) = m.edge_shell_of(a, b) else { continue };
        if s.closed {
            continue;
        }
        if let Some((plan, q)) = ring_patch(ctx, m, &s, true)? {
            if q > 0.05 {
                m.apply_patch(plan);
                n += 1;
            }
        }
    }
    ctx.report.flips += n;
    Ok(n)
}

/// Removal of the edge of shell `s` (interior or, with `allow_boundary`, boundary): the ring
/// polygon is triangulated by dynamic programming maximising the worst [`tq`] (Shewchuk's
/// edge removal); each ring triangle makes one tet with each end. For a boundary edge the ring
/// is open, its two ends become the new boundary edge, which must stay near d = 0 (the
/// flip may not cut across a sharp edge of the domain). Returns the patch and its worst tq.
#[allow(clippy::needless_range_loop)]
fn ring_patch(
    ctx: &Ctx,
    m: &TetMesh,
    s: &crate::topology::EdgeShell,
    allow_boundary: bool,
) -> Result<Option<(TetPatch, f64)>, Error> {
    let n = s.ring.len();
    if !(3..=12).contains(&n) || (!s.closed && !allow_boundary) {
        return Ok(None);
    }
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
    let (pa, pb) = (m.pos(s.a), m.pos(s.b));
    let pc: SmallVec<[DVec3; 12]> = s.ring.iter().map(|&c| m.pos(c)).collect();
    let tri_q = |i: usize, j: usize, k: usize| -> f64 {
        let (ci, cj, ck) = (pc[i], pc[j], pc[k]);
        if orient3d(pa, ci, cj, ck) != Sign::Positive || orient3d(ci, cj, ck, pb) != Sign::Positive {
            return -1.0;
        }
        tq([pa, ci, cj, ck]).min(tq([ci, cj, ck, pb]))
    };
    let (worst, choice) = crate::topology::tet_ops::best_ring_triangulation(n, tri_q);
    if worst < 0.0 {
        return Ok(None);
    }
    let (new, mut diagonals) = crate::topology::tet_ops::ring_tets(s.a, s.b, &s.ring, &choice, label);
    if !s.closed {
        diagonals.push((0, n - 1));
    }
    for &(i, j) in &diagonals {
        let ring_edge = s.closed && ((j + 1) % n == i || (i + 1) % n == j);
        if !ring_edge && m.find_edge(s.ring[i], s.ring[j]).is_some() {
            return Ok(None);
        }
    }
    if n == 3 && s.closed && m.has_face(s.ring[0], s.ring[1], s.ring[2]) {
        return Ok(None);
    }
    Ok(Some((TetPatch::raw(s.tets.iter().copied().collect(), new, None), worst)))
}

// ============================ boundary ============================

/// Every boundary node onto d = 0 where the tets allow it (checked moves).
fn settle_boundary(ctx: &mut Ctx, m: &mut TetMesh) -> Result<(), Error> {
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
fn clear_the_way(ctx: &mut Ctx, m: &mut TetMesh, v: TVertexId, q: DVec3) -> Result<bool, Error> {
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
                ctx.report.removed += 1;
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
            if plan.min_quality > 0.0 && best.as_ref().map_or(true, |b| plan.min_quality > b.0) {
                best = Some((plan.min_quality, plan));
            }
        }
    }
    if let Some((_, plan)) = best {
        m.apply_patch(plan);
        ctx.report.collapses += 1;
        return Ok(true);
    }
    Ok(false)
}

fn count_off(ctx: &Ctx, m: &TetMesh) -> Result<usize, Error> {
    let tol = 1e-3 * ctx.opts.h0;
    let mut n = 0;
    for v in m.vertex_ids() {
        if matches!(m.tag(v), VertexTag::Boundary) && ctx.approx_dist(m.pos(v))?.abs() > tol {
            n += 1;
        }
    }
    Ok(n)
}

// ============================ sliver removal ============================

/// One round of sliver removal over the tets below TQ_TARGET, worst first: swaps, then
/// smoothing of their vertices, then (from the second round) random perturbations. Returns
/// how many changes were accepted.
fn improve(ctx: &mut Ctx, m: &mut TetMesh, round: usize) -> Result<usize, Error> {
    let ids: Vec<TetId> = m.tet_ids().collect();
    let mut bad: Vec<(f64, TetId)> = {
        let mesh = &*m;
        let (cl, ch) = tq_cos_bounds(TQ_TARGET);
        ids.par_iter()
            .with_min_len(CHUNK)
            .filter_map(|&t| {
                let p = mesh.tet_points(t);
                tq_below(p, cl, ch).then(|| (tq(p), t))
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
        if !m.contains_tet(t) || tq(m.tet_points(t)) >= TQ_TARGET {
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
        for t in left {
            if m.contains_tet(t) && tq(m.tet_points(t)) < TQ_TARGET {
                for v in m.tet(t).v {
                    if perturb_vertex(ctx, m, v)? {
                        changes += 1;
                    }
                }
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
        let old = s.tets.iter().map(|&u| tq(m.tet_points(u))).fold(f64::INFINITY, f64::min);
        if let Some((plan, q)) = ring_patch(ctx, m, &s, true)? {
            if q > old + 1e-6 && best.as_ref().map_or(true, |b| q - old > b.0) {
                best = Some((q - old, plan));
            }
        }
    }
    let tx = *m.tet(t);
    for f in 0..4 {
        let Some((u, j)) = tx.adj[f] else { continue };
        let d = m.pos(tx.v[f]);
        let e = m.pos(m.tet(u).v[j as usize]);
        let [p, q, r] = m.face_vertices(t, f).map(|v| m.pos(v));
        let newq = tq([p, q, d, e]).min(tq([q, r, d, e])).min(tq([r, p, d, e]));
        let old = tq(m.tet_points(t)).min(tq(m.tet_points(u)));
        if newq > old + 1e-6 && best.as_ref().map_or(true, |b| newq - old > b.0) {
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
    if nb >= 1 && tq(m.tet_points(t)) < CAP_TQ {
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

/// Applies [`find_swap`]'s choice for `t`, if any.
fn try_swaps(ctx: &mut Ctx, m: &mut TetMesh, t: TetId) -> Result<bool, Error> {
    match find_swap(ctx, m, t)? {
        Some(Swap::Remove) => {
            if m.remove_boundary_tet(t).is_err() {
                return Ok(false);
            }
            ctx.report.removed += 1;
        }
        Some(Swap::Flip(plan)) => {
            m.apply_patch(plan);
            ctx.report.flips += 1;
        }
        Some(Swap::Collapse(plan)) => {
            m.apply_patch(plan);
            ctx.report.collapses += 1;
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

/// The star of `v` as point quadruples with `v`'s slot marked, for moving `v` around.
fn star_of(m: &TetMesh, v: TVertexId) -> Vec<([DVec3; 4], usize)> {
    m.vertex_tets(v)
        .iter()
        .map(|&t| {
            let k = m.local_index(t, v).expect("star");
            (m.tet_points(t), k)
        })
        .collect()
}

/// The worst [`tq`] of the star with its vertex at `x`, and that tet's place in the star.
/// Both terms of tq are monotone in one extreme cosine, so the star's worst is tq of the
/// star's extreme cosines: two acos per call instead of two per tet.
fn star_min(star: &[([DVec3; 4], usize)], x: DVec3) -> (f64, usize) {
    let (mut cmax, mut imax, mut cmin, mut imin) = (f64::NEG_INFINITY, 0, f64::INFINITY, 0);
    for (n, (p, k)) in star.iter().enumerate() {
        let mut p = *p;
        p[*k] = x;
        let Some((a, b)) = cos_extremes(p) else { return (-1.0, n) };
        if a > cmax {
            (cmax, imax) = (a, n);
        }
        if b < cmin {
            (cmin, imin) = (b, n);
        }
    }
    if star.is_empty() {
        return (f64::INFINITY, 0);
    }
    let lo = cmax.clamp(-1.0, 1.0).acos().to_degrees() / REGULAR_DIHEDRAL;
    let hi = (180.0 - cmin.clamp(-1.0, 1.0).acos().to_degrees()) / (180.0 - REGULAR_DIHEDRAL);
    match lo.total_cmp(&hi) {
        std::cmp::Ordering::Less => (lo, imax),
        std::cmp::Ordering::Greater => (hi, imin),
        std::cmp::Ordering::Equal => (lo, imax.min(imin)),
    }
}

/// Optimisation-based smoothing: moves `v` uphill on the quality of the worst tet of its star
/// (finite-difference gradient, halving line search) while the star's worst tq improves.
/// Boundary vertices move in the tangent plane and are projected back onto d = 0.
fn smooth_vertex(ctx: &mut Ctx, m: &mut TetMesh, v: TVertexId) -> Result<bool, Error> {
    if let Some(x) = smooth_target(ctx, m, v)? {
        if m.relocate(v, x).is_ok() {
            ctx.report.smoothings += 1;
            return Ok(true);
        }
    }
    Ok(false)
}

/// Where [`smooth_vertex`] would move `v`, if anywhere (read-only).
fn smooth_target(ctx: &Ctx, m: &TetMesh, v: TVertexId) -> Result<Option<DVec3>, Error> {
    if !m.contains_vertex(v) || m.tag(v) == VertexTag::Fixed {
        return Ok(None);
    }
    let boundary = m.tag(v) == VertexTag::Boundary;
    let star = star_of(m, v);
    let x0 = m.pos(v);
    let nb = m.vertex_neighbours(v);
    let len = nb.iter().map(|&w| m.pos(w).distance(x0)).sum::<f64>() / nb.len().max(1) as f64;
    let (f0, _) = star_min(&star, x0);
    let (mut x, mut fx) = (x0, f0);
    for _ in 0..20 {
        let (_, w) = star_min(&star, x);
        let (p, k) = star[w];
        let eps = 1e-6 * len;
        let mut g = DVec3::ZERO;
        for axis in 0..3 {
            let mut e = DVec3::ZERO;
            e[axis] = eps;
            let (mut pp, mut pm) = (p, p);
            pp[k] = x + e;
            pm[k] = x - e;
            g[axis] = (tq(pp) - tq(pm)) / (2.0 * eps);
        }
        let mut step = 0.1 * len;
        let better = |y: DVec3| Some(star_min(&star, y).0).filter(|&fy| fy > fx + 1e-9);
        match ascend(ctx, x, g, boundary, &mut step, 8, better)? {
            Some((y, fy)) => (x, fx) = (y, fy),
            None => break,
        }
    }
    Ok((fx > f0 + 1e-9 && star_rr(&star, x) > star_rr(&star, x0) - RR_SLACK).then_some(x))
}

/// Mean radius ratio of the star with `v` at `x`: a move for the worst tet may not cost the
/// others more than RR_SLACK of it.
fn star_rr(star: &[([DVec3; 4], usize)], x: DVec3) -> f64 {
    star_rr_sum(star, x) / star.len().max(1) as f64
}

/// Summed radius ratio of the star with its vertex at `x`.
fn star_rr_sum(star: &[([DVec3; 4], usize)], x: DVec3) -> f64 {
    star.iter()
        .map(|(p, k)| {
            let mut p = *p;
            p[*k] = x;
            crate::quality::tet_radius_ratio(p)
        })
        .sum()
}

/// The summed radius ratio of a star as a function of its vertex x, with what does not depend
/// on x computed once: the mean-quality smoothing evaluates it about 25 times per vertex.
/// Per tet (x, q0, q1, q2), with a = q1 - q0, b = q2 - q0, c = x - q0 and n = a x b:
/// 6V = |n . c|, twice the area is |n| + |b x c| + |c x a| + |b x c + n + c x a|, the
/// circumcentre is q0 + (|a|^2 b x c + |b|^2 c x a + |c|^2 n) / (12 V), and
/// 3 r_in / r_out = 6 (6V)^2 / (2 area |12 V (circumcentre - q0)|).
struct StarRr {
    parts: SmallVec<[RrTerm; 32]>,
}

/// One tet of a [`StarRr`]: q0, a, b, n = a x b, |a|^2, |b|^2 and |n|.
#[derive(Clone, Copy)]
struct RrTerm {
    q0: DVec3,
    a: DVec3,
    b: DVec3,
    n: DVec3,
    aa: f64,
    bb: f64,
    nn: f64,
}

impl StarRr {
    fn new(star: &[([DVec3; 4], usize)]) -> Self {
        let parts = star
            .iter()
            .map(|(p, k)| {
                let [q0, q1, q2] = [(k + 1) % 4, (k + 2) % 4, (k + 3) % 4].map(|i| p[i]);
                let (a, b) = (q1 - q0, q2 - q0);
                let n = a.cross(b);
                RrTerm { q0, a, b, n, aa: a.length_squared(), bb: b.length_squared(), nn: n.length() }
            })
            .collect();
        StarRr { parts }
    }

    fn sum(&self, x: DVec3) -> f64 {
        self.parts
            .iter()
            .map(|t| {
                let c = x - t.q0;
                let v6 = t.n.dot(c).abs();
                if v6 == 0.0 {
                    return 0.0;
                }
                let (bc, ca) = (t.b.cross(c), c.cross(t.a));
                let area2 = t.nn + bc.length() + ca.length() + (bc + t.n + ca).length();
                let num = t.aa * bc + t.bb * ca + c.length_squared() * t.n;
                (6.0 * v6 * v6 / (area2 * num.length())).clamp(0.0, 1.0)
            })
            .sum()
    }
}

/// One line search of the smoothing ascents: from `x` along the gradient `g` (in the tangent
/// plane of d = 0 for boundary vertices, which are projected back), halving `step` up to
/// `tries` times until `better` returns the new objective value. `None`: no better point.
fn ascend(
    ctx: &Ctx,
    x: DVec3,
    mut g: DVec3,
    boundary: bool,
    step: &mut f64,
    tries: usize,
    better: impl Fn(DVec3) -> Option<f64>,
) -> Result<Option<(DVec3, f64)>, Error> {
    if boundary {
        let nrm = ctx.domain.gradient(x).normalize_or_zero();
        g -= nrm * g.dot(nrm);
    }
    if g.length() <= 0.0 || !g.is_finite() {
        return Ok(None);
    }
    let dir = g.normalize();
    for _ in 0..tries {
        let mut y = x + dir * *step;
        if boundary {
            match ctx.project(y)? {
                Some(q) => y = q,
                None => {
                    *step *= 0.5;
                    continue;
                }
            }
        }
        if let Some(fy) = better(y) {
            return Ok(Some((y, fy)));
        }
        *step *= 0.5;
    }
    Ok(None)
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
        ctx.report.smoothings += 1;
        return Ok(true);
    }
    Ok(false)
}

// ============================ mean quality ============================

/// One round of the final mean-quality pass (Klingner and Shewchuk 2007 aim their swaps and
/// smoothing at the mean as well as the worst): interior edge removals and 2-3 flips that raise
/// the mesh's mean radius ratio, then each free vertex moved uphill on its star's summed radius
/// ratio. Every change keeps the local worst dihedral quality at least min(its old value,
/// RR_TQ_FLOOR). Returns how many changes were accepted.
fn mean_quality_round(ctx: &mut Ctx, m: &mut TetMesh) -> Result<usize, Error> {
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
            ctx.report.flips += 1;
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
            let old_min = tq(pt).min(tq(pu));
            let new_min = new.iter().map(|&x| tq(x)).fold(f64::INFINITY, f64::min);
            if new_min < old_min.min(RR_TQ_FLOOR) {
                continue;
            }
            let rr = crate::quality::tet_radius_ratio;
            let gain = new.iter().map(|&x| rr(x)).sum::<f64>() - rr(pt) - rr(pu) - mean;
            if gain > RR_GAIN {
                if let Ok(plan) = m.check_flip23(t, f) {
                    m.apply_patch(plan);
                    ctx.report.flips += 1;
                    changes += 1;
                    break;
                }
            }
        }
    }
    // The smoothing.
    Ok(changes + coloured_smoothing(ctx, m, None, mean_smooth_target)?)
}

/// The removal of an interior edge whose ring triangulation (dynamic programming on the summed
/// radius ratio, every tet above the dihedral floor) raises the mean radius ratio.
#[allow(clippy::needless_range_loop)]
fn mean_ring_patch(m: &TetMesh, s: &crate::topology::EdgeShell, mean: f64) -> Option<TetPatch> {
    let n = s.ring.len();
    if !s.closed || !(3..=7).contains(&n) {
        return None;
    }
    let label = m.tet(s.tets[0]).label;
    if s.tets.iter().any(|&t| m.tet(t).label != label) {
        return None;
    }
    let rr = crate::quality::tet_radius_ratio;
    let mut old_sum = 0.0;
    let mut old_min = f64::INFINITY;
    for &t in &s.tets {
        let p = m.tet_points(t);
        old_sum += rr(p);
        old_min = old_min.min(tq(p));
    }
    let floor = old_min.min(RR_TQ_FLOOR);
    let (pa, pb) = (m.pos(s.a), m.pos(s.b));
    let pc: SmallVec<[DVec3; 12]> = s.ring.iter().map(|&c| m.pos(c)).collect();
    let tri = |i: usize, j: usize, k: usize| -> f64 {
        let (ci, cj, ck) = (pc[i], pc[j], pc[k]);
        if orient3d(pa, ci, cj, ck) != Sign::Positive || orient3d(ci, cj, ck, pb) != Sign::Positive {
            return f64::NEG_INFINITY;
        }
        let (x, y) = ([pa, ci, cj, ck], [ci, cj, ck, pb]);
        if tq(x).min(tq(y)) < floor {
            return f64::NEG_INFINITY;
        }
        rr(x) + rr(y)
    };
    let mut best = [[0.0f64; 12]; 12];
    let mut choice = [[0usize; 12]; 12];
    for len in 2..n {
        for i in 0..n - len {
            let j = i + len;
            let mut b = f64::NEG_INFINITY;
            for k in i + 1..j {
                let v = tri(i, k, j) + best[i][k] + best[k][j];
                if v > b {
                    b = v;
                    choice[i][j] = k;
                }
            }
            best[i][j] = b;
        }
    }
    let new_sum = best[0][n - 1];
    if !new_sum.is_finite() {
        return None;
    }
    let gain = new_sum - old_sum - mean * (2.0 * n as f64 - 4.0 - n as f64);
    if gain <= RR_GAIN {
        return None;
    }
    let (new, diagonals) = crate::topology::tet_ops::ring_tets(s.a, s.b, &s.ring, &choice, label);
    for &(i, j) in &diagonals {
        if (j + 1) % n != i && (i + 1) % n != j && m.find_edge(s.ring[i], s.ring[j]).is_some() {
            return None;
        }
    }
    if n == 3 && m.has_face(s.ring[0], s.ring[1], s.ring[2]) {
        return None;
    }
    Some(TetPatch::raw(s.tets.iter().copied().collect(), new, None))
}

/// Whether a boundary face around `v` turns more than RR_SHARP degrees from the surface
/// normal at `v`: a node on a sharp edge or corner of the domain, whose tangential moves would
/// round it off.
fn on_sharp_feature(ctx: &Ctx, m: &TetMesh, v: TVertexId) -> bool {
    let nrm = ctx.domain.gradient(m.pos(v)).normalize_or_zero();
    let cos = RR_SHARP.to_radians().cos();
    for t in m.vertex_tets(v) {
        let tx = m.tet(t);
        for f in 0..4 {
            if tx.adj[f].is_some() || tx.v[f] == v {
                continue;
            }
            let [a, b, c] = m.face_vertices(t, f).map(|w| m.pos(w));
            let n = (b - a).cross(c - a).normalize_or_zero();
            if n.dot(nrm).abs() < cos {
                return true;
            }
        }
    }
    false
}

/// Moves `v` uphill on the summed radius ratio of its star (finite-difference gradient,
/// halving line search), keeping the star's worst tq at least min(old, RR_TQ_FLOOR); boundary
/// vertices move in the tangent plane and are projected back onto d = 0.
fn mean_smooth_target(ctx: &Ctx, m: &TetMesh, v: TVertexId) -> Result<Option<DVec3>, Error> {
    if !m.contains_vertex(v) || m.tag(v) == VertexTag::Fixed {
        return Ok(None);
    }
    let boundary = m.tag(v) == VertexTag::Boundary;
    if boundary && !RR_SMOOTH_BOUNDARY {
        return Ok(None);
    }
    if boundary && on_sharp_feature(ctx, m, v) {
        return Ok(None);
    }
    let star = star_of(m, v);
    let x0 = m.pos(v);
    let nb = m.vertex_neighbours(v);
    let len = nb.iter().map(|&w| m.pos(w).distance(x0)).sum::<f64>() / nb.len().max(1) as f64;
    let rr = StarRr::new(&star);
    let sum_at = |x: DVec3| rr.sum(x);
    let (t0, _) = star_min(&star, x0);
    // The floor as cosine bounds: no acos per tet per trial point.
    let (cos_lo, cos_hi) = tq_cos_bounds(t0.min(RR_TQ_FLOOR));
    let above_floor = |y: DVec3| {
        star.iter().all(|(p, k)| {
            let mut p = *p;
            p[*k] = y;
            !tq_below(p, cos_lo, cos_hi)
        })
    };
    let f0 = sum_at(x0);
    let (mut x, mut fx) = (x0, f0);
    let mut step = 0.05 * len;
    for _ in 0..RR_SMOOTH_STEPS {
        // Forward differences: only an uphill direction is needed, and the line search
        // checks every step.
        let eps = 1e-6 * len;
        let mut g = DVec3::ZERO;
        for axis in 0..3 {
            let mut e = DVec3::ZERO;
            e[axis] = eps;
            g[axis] = (sum_at(x + e) - fx) / eps;
        }
        let better = |y: DVec3| Some(sum_at(y)).filter(|&fy| fy > fx + 1e-9 && above_floor(y));
        match ascend(ctx, x, g, boundary, &mut step, 6, better)? {
            Some((y, fy)) => {
                (x, fx) = (y, fy);
                step *= 1.5;
            }
            None => break,
        }
    }
    Ok((fx > f0 + 1e-7).then_some(x))
}

/// Classes of vertices (all, or those of `subset`) no two of which share an edge (greedy
/// colouring in arena or subset order), so that no vertex of a class lies in the star of
/// another: their moves are independent.
fn independent_classes(m: &TetMesh, subset: Option<&[TVertexId]>) -> Vec<Vec<TVertexId>> {
    if let Some(verts) = subset {
        // Colours within the subset only; neighbours found in parallel.
        let nbs: Vec<SmallVec<[TVertexId; 32]>> = verts.par_iter().map(|&v| m.vertex_neighbours(v)).collect();
        let mut colour: SecondaryMap<TVertexId, u16> = SecondaryMap::with_capacity(verts.len());
        let mut classes: Vec<Vec<TVertexId>> = Vec::new();
        let mut used: SmallVec<[u16; 64]> = SmallVec::new();
        for (&v, nb) in verts.iter().zip(&nbs) {
            if colour.contains_key(v) {
                continue;
            }
            used.clear();
            used.extend(nb.iter().filter_map(|&w| colour.get(w).copied()));
            let c = (0..).find(|c| !used.contains(c)).expect("a free colour");
            colour.insert(v, c);
            if c as usize == classes.len() {
                classes.push(Vec::new());
            }
            classes[c as usize].push(v);
        }
        return classes;
    }
    let snap = Snapshot::build(m);
    let mut colour = vec![u16::MAX; snap.ids.len()];
    let mut classes: Vec<Vec<TVertexId>> = Vec::new();
    let mut used: SmallVec<[u16; 64]> = SmallVec::new();
    for i in 0..snap.ids.len() {
        used.clear();
        used.extend(snap.row(i).iter().map(|&j| colour[j as usize]).filter(|&c| c != u16::MAX));
        let c = (0..).find(|c| !used.contains(c)).expect("a free colour");
        colour[i] = c;
        if c as usize == classes.len() {
            classes.push(Vec::new());
        }
        classes[c as usize].push(snap.ids[i]);
    }
    classes
}

/// Moves every vertex to `target`'s point, class by class ([`independent_classes`]): a
/// class's targets are computed in parallel on the unchanged mesh, then applied in order
/// with the exact validity check. Deterministic; returns the moves made.
fn coloured_smoothing(
    ctx: &mut Ctx,
    m: &mut TetMesh,
    subset: Option<&[TVertexId]>,
    target: impl Fn(&Ctx, &TetMesh, TVertexId) -> Result<Option<DVec3>, Error> + Sync,
) -> Result<usize, Error> {
    let mut moved = 0;
    for class in independent_classes(m, subset) {
        let targets: Vec<Option<DVec3>> = {
            let (c, mesh) = (&*ctx, &*m);
            class.par_iter().with_min_len(64).map(|&v| target(c, mesh, v)).collect::<Result<_, Error>>()?
        };
        for (&v, y) in class.iter().zip(targets) {
            if let Some(y) = y {
                if m.relocate(v, y).is_ok() {
                    moved += 1;
                }
            }
        }
    }
    ctx.report.smoothings += moved;
    Ok(moved)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_tet_has_dihedral_quality_one() {
        let s = 1.0 / 2f64.sqrt();
        let p =
            [DVec3::new(1.0, 0.0, -s), DVec3::new(-1.0, 0.0, -s), DVec3::new(0.0, 1.0, s), DVec3::new(0.0, -1.0, s)];
        let p = if crate::quality::tet_volume(p) > 0.0 { p } else { [p[1], p[0], p[2], p[3]] };
        assert!((tq(p) - 1.0).abs() < 1e-9, "{}", tq(p));
        let flat = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)];
        assert!(tq(flat) < 0.0);
    }

    #[test]
    fn tq_below_agrees_with_tq() {
        let (cl, ch) = tq_cos_bounds(0.5);
        let mut rng = crate::testing::Rng::new(crate::testing::SEED);
        let mut seen = [0usize; 2];
        for _ in 0..2000 {
            let p = [0; 4].map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64()));
            let q = tq(p);
            if (q - 0.5).abs() > 1e-9 {
                assert_eq!(tq_below(p, cl, ch), q < 0.5, "tq {q}");
                seen[(q < 0.5) as usize] += 1;
            }
        }
        assert!(seen[0] > 0 && seen[1] > 0, "both sides sampled: {seen:?}");
    }

    #[test]
    fn star_rr_sums_the_radius_ratios() {
        let mut rng = crate::testing::Rng::new(crate::testing::SEED);
        for _ in 0..200 {
            let star: Vec<([DVec3; 4], usize)> =
                (0..5).map(|k| ([0; 4].map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64())), k % 4)).collect();
            let x = DVec3::new(rng.f64(), rng.f64(), rng.f64());
            let (fast, slow) = (StarRr::new(&star).sum(x), star_rr_sum(&star, x));
            assert!((fast - slow).abs() < 1e-9, "{fast} against {slow}");
        }
    }

    /// A snapshot in vertex keys: (vertex, kind, sorted neighbours) and (tet, corners).
    type Keyed = (Vec<(TVertexId, u8, Vec<TVertexId>)>, Vec<(TetId, [TVertexId; 4])>);

    /// The snapshot in vertex keys, for comparing snapshots whose indices differ.
    fn by_key(s: &Snapshot) -> Keyed {
        let mut verts: Vec<(TVertexId, u8, Vec<TVertexId>)> = (0..s.ids.len())
            .filter(|&i| s.kind[i] != DEAD)
            .map(|i| {
                let mut nb: Vec<TVertexId> =
                    s.row(i).iter().filter(|&&j| j as usize != i).map(|&j| s.ids[j as usize]).collect();
                nb.sort_unstable();
                (s.ids[i], s.kind[i], nb)
            })
            .collect();
        verts.sort_unstable_by_key(|x| x.0);
        let tets = s.tet_ids.iter().zip(&s.tets).map(|(&t, v)| (t, v.map(|i| s.ids[i as usize]))).collect();
        (verts, tets)
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config {
            cases: 64,
            rng_seed: proptest::test_runner::RngSeed::Fixed(crate::testing::SEED),
            ..proptest::test_runner::Config::default()
        })]

        /// Random operation sequences (flips, edge removals, splits, collapses, insertions,
        /// moves), the snapshot refreshed after every few: it always says what a rebuild says.
        #[test]
        fn refreshes_after_random_operations_equal_rebuilds(
            n in 8usize..40,
            seed in proptest::prelude::any::<u64>(),
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..400),
            every in 1usize..6,
        ) {
            let (mut m, _) = TetMesh::delaunay(&crate::testing::random_points_3d(n, seed)).expect("delaunay");
            m.tag_boundary_vertices();
            let mut snap = Snapshot::build(&m);
            m.open_journal();
            let mut u = arbitrary::Unstructured::new(&bytes);
            let mut k = 0;
            // (An exhausted input still yields default operations: stop on it.)
            while !u.is_empty() && k < 64 {
                let Ok(op) = u.arbitrary::<crate::testing::TetOp>() else { break };
                let _ = crate::testing::apply_tet_op(&mut m, op);
                k += 1;
                if k % every == 0 {
                    let journal = m.take_journal().expect("open journal");
                    if !snap.refresh(&m, &journal) {
                        snap = Snapshot::build(&m);
                    }
                    proptest::prop_assert_eq!(by_key(&snap), by_key(&Snapshot::build(&m)));
                    m.open_journal();
                }
            }
        }
    }

    #[test]
    fn a_cut_off_speck_is_dropped_and_the_rest_kept() {
        let mut rng = crate::testing::Rng::new(crate::testing::SEED);
        let mut pts: Vec<DVec3> = (0..200).map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64())).collect();
        let (del, _) = TetMesh::delaunay(&pts).expect("delaunay");
        let (points, mut tets, _, _) = del.to_arrays();
        pts = points;
        // A flat tet away from the rest, cut off from it.
        let n = pts.len();
        pts.extend([[3.0, 0.0, 0.0], [4.0, 0.0, 0.0], [3.0, 1.0, 0.0], [3.2, 0.2, 1e-3]].map(DVec3::from));
        tets.push([n, n + 1, n + 2, n + 3]);
        let (mut m, _) = TetMesh::from_arrays(&pts, &tets).expect("valid");
        m.tag_boundary_vertices();
        let domain = crate::geometry::Ball::new([0.0, 0.0, 0.0], 10.0);
        let opts = Options3::uniform(0.1, [-1.0; 3], [5.0; 3]);
        let ctx = Ctx {
            domain: &domain,
            opts: &opts,
            projection: Projection::Exact,
            h_floor: 1.0,
            report: Report3::default(),
            rng: 1,
            trace: false,
            polish_worst: 0.0,
            fixed: Vec::new(),
        };
        let before = m.num_tets();
        assert_eq!(count_pieces(&m), 2);
        assert!(drop_specks(&ctx, &mut m).expect("no error"));
        assert_eq!((count_pieces(&m), m.num_tets(), m.num_vertices()), (1, before - 1, n));
        m.validate(Level::Geometry).expect("valid");
        // Nothing left to drop.
        assert!(!drop_specks(&ctx, &mut m).expect("no error"));
    }

    #[test]
    fn a_refreshed_snapshot_equals_a_rebuilt_one() {
        let mut rng = crate::testing::Rng::new(crate::testing::SEED);
        let pts: Vec<DVec3> = (0..400).map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64())).collect();
        let (mut m, _) = TetMesh::delaunay(&pts).expect("delaunay");
        m.tag_boundary_vertices();
        let mut snap = Snapshot::build(&m);
        m.open_journal();
        // Tets taken off the boundary (which retag vertices) and 2-3 flips (each adds an edge).
        let (mut flips, mut removed) = (0, 0);
        let ids: Vec<TetId> = m.tet_ids().collect();
        for &t in &ids {
            if removed < 5 && m.check_remove_boundary_tet(t).is_ok_and(|f| f <= 2) {
                removed += usize::from(m.remove_boundary_tet(t).is_ok());
            }
        }
        for &t in &ids {
            if m.contains_tet(t) && (0..4).any(|i| m.flip23(t, i).is_ok()) {
                flips += 1;
            }
            if flips >= 40 {
                break;
            }
        }
        assert!(flips >= 40 && removed > 0, "{flips} flips, {removed} removals");
        let journal = m.take_journal().expect("open journal");
        assert!(!journal.vertices_changed);
        assert!(snap.refresh(&m, &journal));
        let fresh = Snapshot::build(&m);
        // Without a vertex added or removed, the indices are the rebuild's too.
        assert_eq!(snap.ids, fresh.ids);
        assert_eq!(snap.tets, fresh.tets);
        assert_eq!(by_key(&snap), by_key(&fresh));
        // Splits add vertices and collapses remove them: the journal says so, the refresh
        // appends and buries entries, and the snapshot still says what a rebuild says.
        m.open_journal();
        let (mut splits, mut collapses) = (0, 0);
        let ids: Vec<TetId> = m.tet_ids().collect();
        for (k, &t) in ids.iter().enumerate() {
            if !m.contains_tet(t) {
                continue;
            }
            let [a, b] = EDGE_VERTICES[k % 6].map(|i| m.pos(m.tet(t).v[i]));
            if k % 3 == 0 && splits < 10 {
                splits += usize::from(m.split_edge(t, k % 6, (a + b) * 0.5).is_ok());
            } else if k % 3 == 1 && collapses < 10 {
                collapses += usize::from(m.collapse(t, k % 6, false, b).is_ok());
            }
        }
        assert!(splits == 10 && collapses > 0, "{splits} splits, {collapses} collapses");
        let journal = m.take_journal().expect("open journal");
        assert!(journal.vertices_changed);
        assert!(snap.refresh(&m, &journal));
        m.validate(Level::Geometry).expect("valid");
        assert_eq!(by_key(&snap), by_key(&Snapshot::build(&m)));
    }
}
