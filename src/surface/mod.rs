//! Surface meshes of implicit surfaces phi(x) = 0 (seed section 3.6.1); rational Bézier
//! patches meshed in space (section 3.6.2) are in [`bezier`].
//!
//! The seed's recipe: the force iteration of the 2-D mesher with nodes moving in space and every
//! node projected back onto phi = 0 after every step, connectivity kept good by local flips in
//! space instead of a Delaunay triangulation. Here:
//!
//! 1. marching tetrahedra on a background grid gives a closed, outward-oriented start mesh
//!    ([`march`]), welded into the half-edge engine;
//! 2. a few remeshing passes (split long, collapse short, valence flips, tangential smoothing,
//!    projection; the isotropic remeshing loop of Botsch and Kobbelt, 2004) bring the node
//!    density to h(x);
//! 3. the truss iteration: repulsive bar forces toward L0 = Fscale h(x) (seed eq. 2.6, Fscale
//!    1.2), moves in the tangent plane, projection, quality flips, and density control with
//!    hysteresis; it stops when the nodes stop moving or at the cap, keeping the best mesh seen.
//!
//! Sizes are uniform or follow the maximum principal curvature with gradient limiting (seed
//! chapter 4).

pub mod bezier;
pub mod geom;
pub mod march;
pub mod ops;
pub mod report;

pub use geom::SizeField;
pub use report::{SurfaceQuality, SurfaceReport};

use crate::geometry::Implicit3;
use crate::mesher::ProgressFn;
use crate::size::{auto_size_3d, SizeParams};
use crate::topology::{FaceId, TriMesh, VertexId};
use crate::Error;
use geom::{normal, project};
use glam::DVec3;
use ops::{collapse_short, flip_pass, smooth_tangential, split_long, FlipGoal, OpCounts};
use rayon::prelude::*;
use slotmap::SecondaryMap;

/// How the target edge length varies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SurfaceSize {
    /// h0 everywhere.
    Uniform,
    /// h = 1 / (k |kappa_max|) clamped to [h0, hmax], then gradient limited to |grad h| <= g
    /// (seed eq. 4.4 and Algorithm 4-2).
    Curvature {
        /// Elements per radian.
        k: f64,
        /// Gradient limit.
        g: f64,
        /// Largest size.
        hmax: f64,
    },
}

/// Options of [`mesh_implicit_surface`]. Defaults: uniform size, 1000 iterations, Fscale 1.2,
/// time step 0.3, movement tolerance 1e-3 h.
#[derive(Clone)]
#[non_exhaustive]
pub struct SurfaceOptions {
    /// Target edge length (the smallest one with curvature sizes).
    pub h0: f64,
    /// A box that contains the whole surface.
    pub bbox: [DVec3; 2],
    /// Size rule.
    pub size: SurfaceSize,
    /// Iteration cap of each force loop (one per level of the coarse-to-fine start).
    pub max_iterations: usize,
    /// Bar lengths are pushed toward Fscale h (seed eq. 2.6).
    pub fscale: f64,
    /// Time step of the forward Euler move.
    pub dt: f64,
    /// Stop when no node moves more than dptol h in an iteration.
    pub dptol: f64,
    /// Progress callback, called as (stages done, stages): the start, each level of the
    /// coarse-to-fine start (remeshing, force loop, subdivision), the length equalisation.
    pub progress: Option<ProgressFn>,
}

impl std::fmt::Debug for SurfaceOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceOptions")
            .field("h0", &self.h0)
            .field("bbox", &self.bbox)
            .field("size", &self.size)
            .field("max_iterations", &self.max_iterations)
            .field("fscale", &self.fscale)
            .field("dt", &self.dt)
            .field("dptol", &self.dptol)
            .field("progress", &self.progress.as_ref().map(|_| "fn"))
            .finish()
    }
}

impl SurfaceOptions {
    /// Default iteration cap.
    pub const DEFAULT_MAX_ITERATIONS: usize = 1000;
    /// Default Fscale.
    pub const DEFAULT_FSCALE: f64 = 1.2;
    /// Default time step.
    pub const DEFAULT_DT: f64 = 0.3;
    /// Default movement tolerance.
    pub const DEFAULT_DPTOL: f64 = 1e-3;

    /// Uniform size `h0` for a surface inside `bbox`.
    pub fn uniform(h0: f64, bbox: [DVec3; 2]) -> Self {
        SurfaceOptions {
            h0,
            bbox,
            size: SurfaceSize::Uniform,
            max_iterations: Self::DEFAULT_MAX_ITERATIONS,
            fscale: Self::DEFAULT_FSCALE,
            dt: Self::DEFAULT_DT,
            dptol: Self::DEFAULT_DPTOL,
            progress: None,
        }
    }
    /// Sizes from curvature (see [`SurfaceSize::Curvature`]).
    pub fn with_curvature(mut self, k: f64, g: f64, hmax: f64) -> Self {
        self.size = SurfaceSize::Curvature { k, g, hmax };
        self
    }
    /// Sets the progress callback (see [`SurfaceOptions::progress`]).
    pub fn with_progress(mut self, f: impl Fn(usize, usize) + Send + Sync + 'static) -> Self {
        self.progress = Some(std::sync::Arc::new(f));
        self
    }
    /// Sets the iteration cap.
    pub fn with_max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = n;
        self
    }

    fn check(&self) -> Result<(), Error> {
        if !(self.h0 > 0.0 && self.h0.is_finite()) {
            return Err(Error::BadSize(format!("h0 = {} must be positive and finite", self.h0)));
        }
        let [lo, hi] = self.bbox;
        if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
            return Err(Error::BadBox(format!("{lo} .. {hi}")));
        }
        if let SurfaceSize::Curvature { k, g, hmax } = self.size {
            if !(k > 0.0 && k.is_finite() && g > 0.0 && g.is_finite() && hmax >= self.h0) {
                return Err(Error::BadSize(format!(
                    "curvature sizes k = {k}, g = {g}, hmax = {hmax} (need k > 0, g > 0, hmax >= h0)"
                )));
            }
        }
        let ok = |v: f64| v > 0.0 && v.is_finite();
        if !(ok(self.fscale) && ok(self.dt) && ok(self.dptol)) {
            return Err(Error::Invalid(format!(
                "fscale {}, dt {}, dptol {} must be positive and finite",
                self.fscale, self.dt, self.dptol
            )));
        }
        Ok(())
    }
}

/// A surface mesh and its report.
#[derive(Clone, Debug)]
pub struct SurfaceOutput {
    /// The mesh: closed, counter-clockwise seen from outside (normals along grad phi).
    pub mesh: TriMesh<DVec3>,
    /// The size field used.
    pub size: SizeField,
    /// What happened and the quality figures.
    pub report: SurfaceReport,
}

/// Remeshing passes that bring the start mesh to the target density.
const REMESH_PASSES: usize = 12;
/// Coarsest start level: the start mesh is made at up to 2^MAX_LEVELS times the target size.
const MAX_LEVELS: u32 = 3;
/// The largest marching grid for the reference topology (about 250^3 nodes).
const REFERENCE_GRID_NODES: u64 = 16_000_000;
/// Largest turn of the normal along one edge of the coarsest start mesh, radians.
const MAX_TURN: f64 = 0.4;
/// Split above 4/3 h, collapse below 4/5 h (the remeshing hysteresis of Botsch and Kobbelt).
const REMESH_HI: f64 = 4.0 / 3.0;
const REMESH_LO: f64 = 0.8;
/// Density control during the force loop: wider hysteresis so nodes do not go in and out.
const DENSITY_HI: f64 = 1.6;
const DENSITY_LO: f64 = 0.5;
/// Density control runs every this many force iterations, and not in the last stretch.
const DENSITY_EVERY: usize = 20;
/// The force loop stops when its quality score has not beaten the best for PATIENCE
/// iterations. On the finest level of a subdivided start it stops sooner: when the score has
/// not risen by SCORE_STEP for FINE_PATIENCE iterations. On large meshes the largest node move
/// never falls below the tolerance (the slowest modes of a forward-Euler truss relax in a time
/// that grows with the square of the mesh diameter in edges), and after subdividing a relaxed
/// coarse mesh only local relaxation is left.
const PATIENCE: usize = 60;
/// Without subdivision the coarsest level is the final mesh: its loop gets more patience (the
/// score of a start from the fine marching dips before it rises).
const PATIENCE_ALONE: usize = 250;
const FINE_PATIENCE: usize = 5;
const SCORE_STEP: f64 = 1e-3;
/// Flip sweeps in the force loop wait until a node may have moved this far (times h) since
/// the last one (the seed's ttol).
const TTOL: f64 = 0.1;
/// Triangles below this quality have their edges tried for flips after every force step.
const WATCH_Q: f64 = 0.8;
/// Length-equalising sweeps after the force iteration (stopping early when nothing moves).
const EQUALIZE_SWEEPS: usize = 10;
/// Projection tolerance, in units of the smallest size (|phi| / |grad phi|).
const PROJECT_TOL: f64 = 1e-9;

/// Meshes the closed surface phi = 0 inside `opts.bbox` (phi < 0 inside, so normals point
/// along grad phi).
pub fn mesh_implicit_surface(phi: &dyn Implicit3, opts: &SurfaceOptions) -> Result<SurfaceOutput, Error> {
    let start = std::time::Instant::now();
    opts.check()?;
    let size = match opts.size {
        SurfaceSize::Uniform => SizeField::Uniform(opts.h0),
        SurfaceSize::Curvature { k, g, hmax } => {
            // The size grid has spacing h0/2 over the padded box: refuse before allocating it.
            let span = opts.bbox[1] - opts.bbox[0] + DVec3::splat(4.0 * opts.h0);
            let nodes = (span / (0.5 * opts.h0)).ceil() + DVec3::ONE;
            let estimated = nodes.x * nodes.y * nodes.z;
            if estimated > march::MAX_GRID_NODES as f64 {
                return Err(Error::TooManyElements { estimated: estimated as u64, limit: march::MAX_GRID_NODES });
            }
            let params = SizeParams { k, r: 0.0, g, hmin: opts.h0, hmax, ..SizeParams::default() };
            let pad = DVec3::splat(2.0 * opts.h0);
            let grid = auto_size_3d(phi, [opts.bbox[0] - pad, opts.bbox[1] + pad], 0.5 * opts.h0, &params)?;
            SizeField::Grid(grid)
        }
    };
    let hmin = size.min();
    let tol = PROJECT_TOL * hmin;
    // The reference marching fixes the topology; the start mesh is made at the coarsest level
    // 2^k h with the same Euler characteristic and component count, then subdivided k times,
    // so that the fine mesh has only the coarse mesh's irregular vertices. The reference is the
    // finest level whose grid stays below REFERENCE_GRID_NODES: marching costs the volume of
    // the box over h^3 while the mesh costs its area over h^2, so at h itself a large mesh
    // would spend most of its time (and memory) on the grid.
    let mut reference = 0;
    while reference < MAX_LEVELS
        && march::grid_nodes(opts.bbox, hmin * (1u32 << reference) as f64) > REFERENCE_GRID_NODES
    {
        reference += 1;
    }
    let fine = march::march(phi, opts.bbox, hmin * (1u32 << reference) as f64)?;
    let signature = |mc: &march::Marched| {
        let mut edges: Vec<(usize, usize)> = mc
            .triangles
            .iter()
            .flat_map(|t| [0, 1, 2].map(|k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let chi = mc.points.len() as i64 - edges.len() as i64 + mc.triangles.len() as i64;
        (chi, ops::components(mc.points.len(), &mc.triangles))
    };
    let want = signature(&fine);
    // The coarse level must still follow the surface: at most MAX_TURN radians per edge.
    let curvatures: Vec<f64> = fine
        .points
        .par_iter()
        .map(|&p| Ok(geom::max_curvature(phi, project(phi, p, tol)?).abs()))
        .collect::<Result<_, Error>>()?;
    let kmax = curvatures.iter().fold(0.0f64, |a, &b| a.max(b));
    let mut levels = reference;
    let mut marched = fine;
    for k in (reference + 1..=MAX_LEVELS).rev() {
        let hk = hmin * (1u32 << k) as f64;
        if hk * kmax > MAX_TURN {
            continue;
        }
        let coarse = march::march(phi, opts.bbox, hk);
        if let Ok(c) = coarse {
            if signature(&c) == want {
                levels = k;
                marched = c;
                break;
            }
        }
    }
    let (mut m, _) = TriMesh::from_arrays(&marched.points, &marched.triangles)
        .map_err(|e| Error::Internal(format!("marching tetrahedra made an invalid mesh: {e}")))?;
    let mut report = SurfaceReport::default();
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    for v in ids {
        let p = project(phi, m.pos(v), tol)?;
        ops::move_if_no_fold(&mut m, phi, v, p);
    }
    let stages = levels as usize + 3;
    let tick = |done: usize| {
        if let Some(cb) = &opts.progress {
            cb(done, stages);
        }
    };
    tick(1);
    report.stage_seconds[0] = start.elapsed().as_secs_f64();
    let mut clock = report.stage_seconds[0];
    let mut lap = |report: &mut SurfaceReport, k: usize| {
        let now = start.elapsed().as_secs_f64();
        report.stage_seconds[k] += now - clock;
        clock = now;
    };
    let mut counts = OpCounts::default();
    let mut kept = 0;
    for level in (0..=levels).rev() {
        let level_size = size.scaled((1u32 << level) as f64);
        // The coarsest level gets the remeshing passes and a force loop run to its plateau; each
        // finer level, made by subdivision, inherits its quality: remeshing passes on the levels
        // above the finest, and a short loop on each to relax what the projected midpoints
        // disturbed. On the finest level passes and long loops would cost the most and add
        // little (measured on the unit sphere, see docs/surface.md).
        let coarsest = level == levels;
        let passes = if level > 0 || coarsest { REMESH_PASSES } else { 0 };
        for _ in 0..passes {
            counts.splits += split_long(&mut m, phi, &level_size, REMESH_HI, tol)?;
            counts.collapses += collapse_short(&mut m, phi, &level_size, REMESH_LO, REMESH_HI, 0.0, tol)?;
            counts.flips += flip_pass(&mut m, phi, FlipGoal::Valence, 3);
            smooth_tangential(&mut m, phi, 0.5, tol)?;
            report.remesh_passes += 1;
        }
        counts.flips += flip_pass(&mut m, phi, FlipGoal::Quality, 10);
        lap(&mut report, 1);
        let patience = match (coarsest, levels) {
            (true, 0) => (PATIENCE_ALONE, 0.0),
            (true, _) => (PATIENCE, 0.0),
            _ => (FINE_PATIENCE, SCORE_STEP),
        };
        let run = force_loop(m, phi, &level_size, opts, tol, patience, &mut counts)?;
        m = run.mesh;
        report.undone_moves += run.undone;
        if level == 0 {
            report.iterations = run.iterations;
            report.converged = run.converged;
            report.plateau = run.plateau;
            kept = run.kept;
        } else {
            report.coarse_iterations += run.iterations;
        }
        lap(&mut report, 2);
        if level > 0 {
            counts.splits += ops::subdivide(&mut m, phi, tol)?;
            m = ops::relayout(&m)?;
        }
        tick(stages - 1 - level as usize);
    }
    // The truss equilibrium balances forces; a few sweeps then even out the lengths themselves
    // (measured on the unit sphere at h = 0.1 on the build of 2026-11-25: size deviation 5.6% ->
    // 5.3%, mean q 0.986 -> 0.990).
    for _ in 0..EQUALIZE_SWEEPS {
        report.equalize_sweeps += 1;
        let scale = mean_ratio(&m, &size);
        if ops::equalize_lengths(&mut m, phi, &size, scale, tol)? < opts.dptol {
            break;
        }
    }
    lap(&mut report, 3);
    tick(stages);
    // Final projection to the tight tolerance (the loop already projects every step).
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    let mesh = &m;
    let finals: Vec<DVec3> =
        ids.par_iter().map(|&v| project(phi, mesh.pos(v), 1e-3 * tol)).collect::<Result<_, Error>>()?;
    for (&v, &p) in ids.iter().zip(&finals) {
        m.set_pos_unchecked(v, p);
    }
    report.kept_iteration = kept;
    report.ops = counts;
    report.quality = SurfaceQuality::measure(&m, phi, &size);
    report.seconds = start.elapsed().as_secs_f64();
    Ok(SurfaceOutput { mesh: m, size, report })
}

/// What a force loop did.
struct ForceRun {
    /// The kept mesh: the last one when converged, else the best seen.
    mesh: TriMesh<DVec3>,
    iterations: usize,
    kept: usize,
    converged: bool,
    plateau: bool,
    undone: usize,
}

/// The truss iteration at the sizes `size`: force steps, flips when nodes may have moved TTOL h
/// since the last sweep (the seed's retriangulation rule, section 2.2) and on the worst
/// triangles after every step, density control every DENSITY_EVERY steps. Stops when no node
/// moves more than dptol h, at the cap, or when the score has not risen by `step` for
/// `patience` iterations; keeps the best mesh seen unless converged.
fn force_loop(
    mut m: TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    opts: &SurfaceOptions,
    tol: f64,
    (patience, step): (usize, f64),
    counts: &mut OpCounts,
) -> Result<ForceRun, Error> {
    let mut best = (score(&m, size), m.clone(), 0usize);
    // The last score that beat the one before it by `step`, and when.
    let mut marked = (best.0, 0usize);
    // Largest possible movement of any node since the last flip sweep, relative to h.
    let mut since_flips = 0.0;
    let mut run =
        ForceRun { mesh: TriMesh::new(), iterations: 0, kept: 0, converged: false, plateau: false, undone: 0 };
    for it in 1..=opts.max_iterations {
        run.iterations = it;
        let moved = force_step(&mut m, phi, size, opts, tol, &mut run.undone)?;
        since_flips += moved;
        if since_flips > TTOL {
            counts.flips += flip_pass(&mut m, phi, FlipGoal::Quality, 5);
            since_flips = 0.0;
        }
        let late = it + 3 * DENSITY_EVERY > opts.max_iterations;
        if it % DENSITY_EVERY == 0 && !late {
            let s = split_long(&mut m, phi, size, DENSITY_HI, tol)?;
            let c = collapse_short(&mut m, phi, size, DENSITY_LO, DENSITY_HI, 0.3, tol)?;
            counts.splits += s;
            counts.collapses += c;
            if s + c > 0 {
                counts.flips += flip_pass(&mut m, phi, FlipGoal::Quality, 10);
                since_flips = 0.0;
            }
        }
        let (sc, worst) = score_and_worst(&m, size, WATCH_Q);
        // Between the sweeps, the edges of the worst triangles are tried after every step.
        let mut no_valences = SecondaryMap::new();
        for f in worst {
            if m.contains_face(f) {
                for h in m.face_half_edges(f) {
                    if m.contains_half_edge(h) && ops::try_flip(&mut m, phi, h, FlipGoal::Quality, &mut no_valences) {
                        counts.flips += 1;
                        break;
                    }
                }
            }
        }
        if sc > best.0 {
            best = (sc, m.clone(), it);
        }
        if sc > marked.0 + step {
            marked = (sc, it);
        }
        if moved < opts.dptol && it > DENSITY_EVERY {
            run.converged = true;
            break;
        }
        if it >= marked.1 + patience {
            run.plateau = true;
            break;
        }
    }
    if run.converged {
        run.kept = run.iterations;
        run.mesh = m;
    } else {
        run.kept = best.2;
        run.mesh = best.1;
    }
    Ok(run)
}

/// sum(L h) / sum(h^2): the scale that best fits the edge lengths L to the sizes h.
fn mean_ratio(m: &TriMesh<DVec3>, size: &SizeField) -> f64 {
    let (mut lh, mut hh) = (0.0, 0.0);
    for e in m.edge_ids() {
        let (p, q) = (m.pos(m.origin(e)), m.pos(m.dest(e)));
        let h = size.at(0.5 * (p + q));
        lh += p.distance(q) * h;
        hh += h * h;
    }
    lh / hh
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

/// One truss step (seed eq. 2.6 forces, forward Euler in the tangent plane, projection).
/// Returns the largest node movement relative to h.
fn force_step(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    opts: &SurfaceOptions,
    tol: f64,
    undone: &mut usize,
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
    let (mut sl, mut sh) = (0.0, 0.0);
    for &[a, b] in &bars {
        let (pa, pb) = (pos[a as usize], pos[b as usize]);
        let l = pa.distance(pb);
        let h = size.at(0.5 * (pa + pb));
        sl += l * l;
        sh += h * h;
        len.push(l);
        hb.push(h);
    }
    let scale = opts.fscale * (sl / sh).sqrt();
    let mut force = vec![DVec3::ZERO; ids.len()];
    for (k, &[a, b]) in bars.iter().enumerate() {
        let l0 = hb[k] * scale;
        let l = len[k];
        if l <= 0.0 || l0 <= l {
            continue;
        }
        let f = (l0 - l) / l * (pos[a as usize] - pos[b as usize]);
        force[a as usize] += f;
        force[b as usize] -= f;
    }
    // Normals and projections depend on the positions before the step only: in parallel.
    let moves: Vec<(DVec3, DVec3)> = pos
        .par_iter()
        .zip(&force)
        .map(|(&p, &fi)| {
            let n = normal(phi, p);
            let f = fi - fi.dot(n) * n;
            geom::project_grad(phi, p + opts.dt * f, tol)
        })
        .collect::<Result<_, Error>>()?;
    let mut moved = 0.0f64;
    for (i, &v) in ids.iter().enumerate() {
        let p = pos[i];
        let (q, g) = moves[i];
        if ops::move_if_no_fold_g(m, v, q, g) {
            moved = moved.max(q.distance(p) / size.at(p));
        } else {
            *undone += 1;
        }
    }
    Ok(moved)
}
