//! The 2-D mesher on the local engine (seed chapters 2 and 3): initial mesh by refining one
//! enclosing triangle, then force equilibrium in the truss with boundary projection, Delaunay
//! flips where the exact in-circle test fails, boundary membership by ear filling and
//! boundary-triangle removal, and density control by splits and collapses.
//!
//! Set `TRUSSMESH_TRACE=1` to print the state every ten iterations (a development aid).

mod best;
mod boundary;
mod carve;
mod coverage;
mod density;
mod equilibrium;
mod features;
mod gaps;
mod held;
mod improve;
pub(crate) mod options;
pub(crate) mod report;
mod smoothing;
mod snapshot;
mod start;
#[cfg(test)]
mod tests;

use boundary::*;
use carve::*;
use density::*;
use equilibrium::*;
use snapshot::*;
use start::*;

pub(crate) use carve::{drop_small_fans, pinched_vertices};

use crate::geometry::project::{project2, project_many2, ProjectError, Projection};
use crate::geometry::{decide2, Declared, Implicit2};
use crate::mesher::input::{eval_d, eval_h_floor, survey};
use crate::mesher::internal::{self, Internal};
use crate::mesher::metric::{self, eval_metric, metric_triangle_q, Metric2, MetricFn2};
use crate::mesher::truss::{self, bar_force, det_sum, Backoff, DensityBand, Flags, NodeKind, RestScale, CHUNK};
use crate::mesher::MeshOutput2;
use crate::mesher::Report;
use crate::predicates::{orient2d, Sign};
use crate::topology::{HalfEdgeId, Incidence, Level, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec2;
use options::Options2;
use rayon::prelude::*;
use report::QualityStats;
use slotmap::SecondaryMap;
use std::time::Instant;

/// Initial refinement splits edges longer than this many target lengths: edges end between
/// 1/sqrt(2) and sqrt(2) targets, so the start has the node count the sizes ask for.
const INIT_SPLIT: f64 = std::f64::consts::SQRT_2;
/// [`INIT_SPLIT`] with a metric, whose density control (METRIC_BAND) sets the edge lengths
/// itself; this start leaves boundary layers as thin as the metric asks.
const INIT_SPLIT_METRIC: f64 = 1.5;
/// Density control of a fresh mesh splits edges longer than 2 and collapses edges shorter
/// than 0.4 target lengths (a wide hysteresis band: the forces set the lengths in between).
const FRESH_BAND: DensityBand = DensityBand::new(2.0, 0.4);
/// Initial meshes with more vertices than this are laid out along a Hilbert curve, and their
/// force loop skips settled nodes.
const RELAYOUT_ABOVE: usize = 20_000;
/// A boundary node leaves the boundary only once the ear it leaves behind has this quality.
const EAR_Q: f64 = 0.2;
/// Starting from a previous mesh, its boundary vertices up to this many local sizes outside
/// the new domain are kept (and projected) rather than dropped.
const CARRY_BOUNDARY: f64 = 0.5;
/// Remeshing for a new size field first splits and collapses edges outside this band of
/// target lengths, for at most ADAPT_ROUNDS rounds.
const ADAPT_BAND: DensityBand = DensityBand::new(1.4, 0.7);
const ADAPT_ROUNDS: usize = 8;
/// With a metric, an edge flips only when the worse of its two triangles gains this share of
/// metric quality.
const METRIC_FLIP_GAIN: f64 = 0.02;

/// Edge kinds in the snapshot.
const EDGE_INTERIOR: u8 = 0;
const EDGE_BOUNDARY: u8 = 1;
struct Ctx<'a> {
    domain: &'a dyn Implicit2,
    opts: &'a Options2,
    projection: Projection,
    geps: f64,
    h_floor: f64,
    report: Report<QualityStats>,
    left: usize,
    joined: usize,
    /// The run starts from a previous mesh (moving meshes, remeshing).
    from_previous: bool,
    /// Far nodes are held for this moving-mesh step (their tags are temporarily `Fixed`).
    freezing: bool,
    /// Internal boundaries, if any.
    internal: Option<Internal<'a>>,
    /// The metric of the anisotropic mode, if any (replaces h).
    metric: Option<&'a MetricFn2>,
    /// Whether the mesh is in one piece, as the force loop found it on its last arrays (splits,
    /// collapses, flips and moves keep a mesh in one piece or in several).
    connected: Option<bool>,
}

impl Ctx<'_> {
    /// The local size relative to h0 (with a metric: its smallest size, which sets the
    /// tolerances of movement and projection).
    fn h(&self, p: DVec2) -> Result<f64, Error> {
        if self.metric.is_some() {
            return Ok(self.metric_at(p)?.smallest_size() / self.opts.h0);
        }
        // Relative size normalised so that the smallest size inside is 1 (edge length h0).
        Ok(eval_h_floor(self.opts, p, self.h_floor)? / self.h_floor)
    }
    /// The length of the edge a-b in target lengths: |b - a| / (h0 h(midpoint)), or with a
    /// metric its length in M (seed eq. 3.18) integrated along the edge.
    fn ratio(&self, a: DVec2, b: DVec2) -> Result<f64, Error> {
        match self.metric {
            Some(_) => Ok(metric::simpson_length(
                &self.metric_at(a)?,
                &self.metric_at((a + b) * 0.5)?,
                &self.metric_at(b)?,
                b - a,
            )),
            None => Ok(a.distance(b) / (self.opts.h0 * self.h((a + b) * 0.5)?)),
        }
    }
    /// See [`INIT_SPLIT`].
    fn init_split(&self) -> f64 {
        if self.metric.is_some() {
            INIT_SPLIT_METRIC
        } else {
            INIT_SPLIT
        }
    }
    /// The metric length of the offset from the midpoint of a-b to the boundary.
    fn metric_sagitta(&self, a: DVec2, b: DVec2) -> Result<f64, Error> {
        let mid = (a + b) * 0.5;
        match self.project(mid)? {
            Some(q) => Ok(self.metric_at(q)?.length(q - mid)),
            None => Ok(0.0),
        }
    }
    /// The metric at `p`, taken at the nearest boundary point when `p` is outside: like the
    /// seed's size functions, a metric need only make sense inside the domain (figure 3-6's
    /// radial size is negative a little outside the circle).
    fn metric_at(&self, p: DVec2) -> Result<Metric2, Error> {
        let f = self.metric.expect("metric mode");
        if self.approx_dist(p)? > 0.0 {
            if let Some(q) = self.project(p)? {
                return eval_metric(f, q);
            }
        }
        eval_metric(f, p)
    }
    /// Triangle quality: q, or with a metric q measured in M at the centroid.
    fn tri_q(&self, t: [DVec2; 3]) -> f64 {
        match self.metric {
            Some(_) => match self.metric_at((t[0] + t[1] + t[2]) / 3.0) {
                Ok(m) => metric_triangle_q(&m, t),
                Err(_) => crate::quality::triangle_q(t),
            },
            None => crate::quality::triangle_q(t),
        }
    }
    /// Lawson flips from `stack`: exact in-circle, or in the metric space of each quad.
    fn legalize(&self, m: &mut TriMesh<DVec2>, stack: Vec<HalfEdgeId>) -> usize {
        match self.metric {
            None => m.legalize(stack),
            Some(_) => {
                let cap = 10 * m.num_edges() + 1000;
                m.legalize_with(stack, cap, |a, b, c, d| self.metric_flip(a, b, c, d))
            }
        }
    }
    /// With a metric: whether the edge a-b (c on its left, d on its right) should flip, by
    /// the metric quality of the two triangles with M at the quad's centroid (seed 3.5: "a
    /// length based quality test with M averaged over the element nodes"), with hysteresis:
    /// in a layer of metric rectangles both diagonals are equally Delaunay, and flipping back
    /// and forth would shake the truss.
    fn metric_flip(&self, a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
        let Ok(m) = self.metric_at((a + b + c + d) * 0.25) else { return false };
        let before = metric_triangle_q(&m, [a, b, c]).min(metric_triangle_q(&m, [b, a, d]));
        let after = metric_triangle_q(&m, [c, a, d]).min(metric_triangle_q(&m, [d, b, c]));
        after > before * (1.0 + METRIC_FLIP_GAIN)
    }
    /// Every edge by [`Ctx::legalize`].
    fn make_delaunay(&self, m: &mut TriMesh<DVec2>) -> usize {
        let stack: Vec<HalfEdgeId> = m.edge_ids().collect();
        match self.metric {
            None => m.make_delaunay(),
            Some(_) => self.legalize(m, stack),
        }
    }
    fn d(&self, p: DVec2) -> Result<f64, Error> {
        eval_d(self.domain, p)
    }
    /// Projects onto d = 0; `Ok(None)` when the projection does not converge (keep the point).
    fn project(&self, p: DVec2) -> Result<Option<DVec2>, Error> {
        project_point(self.domain, self.projection, self.opts.h0, p)
    }
    /// True when an interior node's step from `a` to `b` would cross (or land on) an internal
    /// boundary: it is held back, so that no triangle straddles d_I = 0.
    fn crosses_internal(&self, a: DVec2, b: DVec2) -> Result<bool, Error> {
        let Some(di) = &self.internal else { return Ok(false) };
        let (da, db) = (di.value(a)?, di.value(b)?);
        Ok((da < 0.0) != (db < 0.0) || di.approx_dist(b)?.abs() < self.geps)
    }
    /// Projects onto d_I = 0 (`Ok(None)` without internal boundaries or without convergence).
    fn project_internal(&self, p: DVec2) -> Result<Option<DVec2>, Error> {
        match &self.internal {
            Some(di) => di.project(p),
            None => Ok(None),
        }
    }
    /// [`Ctx::approx_dist`] at every point of `ps`, evaluated in batches (one call of
    /// `Implicit2::values`, and of `gradients` for a level set): bit for bit the same numbers.
    fn approx_dists(&self, ps: &[DVec2]) -> Result<Vec<f64>, Error> {
        let mut d = vec![0.0; ps.len()];
        self.domain.values(ps, &mut d);
        for (&v, &p) in d.iter().zip(ps) {
            truss::domain::checked_d(v, p)?;
        }
        if self.domain.is_distance() {
            return Ok(d);
        }
        let mut g = vec![DVec2::ZERO; ps.len()];
        self.domain.gradients(ps, &mut g);
        Ok(d.iter().zip(&g).map(|(&v, g)| truss::domain::approx_distance(v, g.length(), false)).collect())
    }
    /// [`Ctx::project`] of every point of `ps`, in batches.
    fn project_many(&self, ps: &[DVec2]) -> Result<Vec<Option<DVec2>>, Error> {
        project_many2(self.domain, ps, self.projection, 1e-9 * self.opts.h0, PROJECT_ITER)
            .into_iter()
            .map(projected)
            .collect()
    }
    /// The approximate distance from the centroid of the triangle `t` to d = 0, for the tests
    /// that drop triangles as certainly outside: d itself for a distance; for a level set d
    /// divided by the largest |grad d| at the centroid and the corners. d / |grad d| at the
    /// centroid alone is far too large near a critical point of d (the centre of a round hole,
    /// where a difference quotient of the gradient is round-off): the enclosing triangle
    /// of a domain with a hole at the box's centre was then dropped whole.
    fn distance_bound(&self, t: [DVec2; 3]) -> Result<f64, Error> {
        let c = (t[0] + t[1] + t[2]) / 3.0;
        let d = self.d(c)?;
        if self.domain.is_distance() {
            return Ok(d);
        }
        let g = [c, t[0], t[1], t[2]].iter().map(|&p| self.domain.gradient(p).length()).fold(0.0, f64::max);
        Ok(truss::domain::approx_distance(d, g, false))
    }
    /// Approximate distance: d itself for distances, d / |grad d| otherwise.
    fn approx_dist(&self, p: DVec2) -> Result<f64, Error> {
        let d = self.d(p)?;
        let g = if self.domain.is_distance() { 1.0 } else { self.domain.gradient(p).length() };
        Ok(truss::domain::approx_distance(d, g, self.domain.is_distance()))
    }
}

/// The projection of `p` onto d = 0 to within 1e-9 h0 (`None` when it does not converge).
fn project_point(domain: &dyn Implicit2, projection: Projection, h0: f64, p: DVec2) -> Result<Option<DVec2>, Error> {
    projected(project2(domain, p, projection, 1e-9 * h0, PROJECT_ITER))
}

/// Steps of a boundary projection at most.
const PROJECT_ITER: usize = 20;

/// A projection's result as the mesher takes it: the point, `None` when it did not converge
/// (the node is kept where it was), or the error naming a non-finite value.
fn projected(r: Result<DVec2, ProjectError>) -> Result<Option<DVec2>, Error> {
    match r {
        Ok(q) => Ok(Some(q)),
        Err(e) => match truss::domain::projection_non_finite(&e, truss::domain::Function::Domain) {
            Some(err) => Err(err),
            None => Ok(None),
        },
    }
}

/// Runs the local strategy.
pub(crate) fn run(domain: &dyn Implicit2, opts: &Options2) -> Result<MeshOutput2, Error> {
    let out = run_from(domain, opts, None)?;
    if out.report.dropped_by_size.is_empty() || opts.metric.is_some() {
        return Ok(out);
    }
    // Parts narrower than the requested size were left out: meshed again with the size capped
    // by the local feature size, the run that leaves out less is kept (both times counted).
    // When the capped run cannot be made (too many elements, say) the first mesh stands with
    // its warnings.
    let again =
        gaps::capped_options(domain, opts, &out.report.dropped_by_size).and_then(|c| run_from(domain, &c, None));
    let Ok(mut again) = again else { return Ok(out) };
    let left = |o: &MeshOutput2| o.report.notes.iter().filter(|n| n.contains("is not meshed")).count();
    if std::env::var_os("TRUSSMESH_TRACE").is_some() {
        eprintln!(
            "parts left out by the size: {}; meshed again with the size capped by the feature size: {}",
            left(&out),
            left(&again)
        );
    }
    if left(&again) < left(&out) {
        again.report.seconds += out.report.seconds;
        again.report.notes.push(format!(
            "the size was capped by the local feature size (two elements across) where it was wider than the domain \
             ({} part{} had been left out)",
            out.report.dropped_by_size.len(),
            if out.report.dropped_by_size.len() == 1 { "" } else { "s" }
        ));
        Ok(again)
    } else {
        let mut out = out;
        out.report.seconds += again.report.seconds;
        Ok(out)
    }
}

/// Runs the local strategy from `start` (a previous mesh: moving meshes and remeshing, seed
/// chapter 5) or, when `None`, from the refined enclosing triangle.
pub(crate) fn run_from(
    domain: &dyn Implicit2,
    opts: &Options2,
    start: Option<&TriMesh<DVec2>>,
) -> Result<MeshOutput2, Error> {
    run_moving(domain, opts, start, None, false)
}

/// Nodes to hold still during a moving-mesh step: those more than `rings` edges away from
/// every node where the old and the new geometry disagree (seed section 5.1: stiffness grows
/// with the distance from the moving boundary; here it becomes infinite past a few rings).
pub(crate) struct Freeze<'a> {
    pub old_domain: &'a dyn Implicit2,
    pub rings: usize,
}

pub(crate) fn run_moving(
    domain: &dyn Implicit2,
    opts: &Options2,
    start: Option<&TriMesh<DVec2>>,
    freeze: Option<Freeze>,
    adapt: bool,
) -> Result<MeshOutput2, Error> {
    let t0 = Instant::now();
    let survey = survey(domain, opts)?;
    let (distance, gradient_survey) = decide2(domain, opts.bbox[0], opts.bbox[1]);
    let decided = Declared { inner: domain, distance };
    let domain: &dyn Implicit2 = &decided;
    let projection = match opts.projection {
        Projection::Auto if domain.is_distance() => Projection::Exact,
        Projection::Auto => Projection::FirstOrder,
        p => p,
    };
    // A fresh mesh holds the domain's sharp corners fixed (with a metric too: left free, the
    // projection rounds them off and the square loses area at each). A corner the start
    // cannot reach is left free with a note (see `carve::corners_left_free`).
    let corners = if start.is_none() && opts.sharp_corners {
        features::find(domain, opts, survey.h_floor, &|p| project_point(domain, projection, opts.h0, p))?
    } else {
        Vec::new()
    };
    let with_corners;
    let opts = if corners.is_empty() {
        opts
    } else {
        let mut o = opts.clone();
        o.fixed.extend(corners.iter().copied());
        with_corners = o;
        &with_corners
    };
    let mut ctx = Ctx {
        domain,
        opts,
        projection,
        geps: 1e-3 * opts.h0,
        h_floor: survey.h_floor,
        report: Report { feature_points: corners.len(), gradient_survey, level_set: !distance, ..Report::default() },
        left: 0,
        connected: None,
        joined: 0,
        from_previous: start.is_some(),
        freezing: freeze.is_some(),
        internal: opts.internal.as_deref().map(|d| Internal::new(d, opts.h0)),
        metric: opts.metric.as_ref(),
    };
    let mut mesh = match start {
        None => initial_mesh(&mut ctx, survey.estimated_triangles)?,
        Some(prev) => {
            if let Err(e) = prev.validate(Level::Geometry) {
                return Err(Error::InvalidMesh(format!(
                    "the mesh to start from is invalid ({e}): inverted or broken elements"
                )));
            }
            let mut fixed_prev = prev.clone();
            for v in prev.vertex_ids() {
                let tag = if opts.fixed.contains(&prev.pos(v)) { VertexTag::Fixed } else { VertexTag::Interior };
                fixed_prev.set_tag(v, tag);
            }
            carve(&ctx, fixed_prev, CARRY_BOUNDARY)?
        }
    };
    if adapt {
        // Seed 5.2: density control first, without regard to quality, with a tight band.
        for _ in 0..ADAPT_ROUNDS {
            let snap = Snapshot::build(&mesh);
            let p: Vec<DVec2> = snap.ids.iter().map(|&v| mesh.pos(v)).collect();
            let cands = density_candidates(&ctx, &snap, &p, opts.h0, None, ADAPT_BAND)?;
            if cands.is_empty() || !density_control(&mut ctx, &mut mesh, cands, true, BoundaryLoops::default())? {
                break;
            }
        }
    }
    let frozen = match &freeze {
        Some(fz) => freeze_far_nodes(&ctx, &mut mesh, fz)?,
        None => Vec::new(),
    };
    let trace = std::env::var_os("TRUSSMESH_TRACE").is_some();
    if trace {
        eprintln!("start ready at {:.3} s, peak {}", t0.elapsed().as_secs_f64(), peak_memory());
    }
    equilibrium(&mut ctx, &mut mesh)?;
    if trace {
        eprintln!("equilibrium done at {:.3} s, peak {}", t0.elapsed().as_secs_f64(), peak_memory());
    }
    if ctx.metric.is_none() && ctx.internal.is_none() {
        let geo = improve::Geometry {
            h: &|p| ctx.h(p),
            project: &|p| ctx.project(p),
            fscale: opts.fscale,
            dt: opts.deltat,
            connected: ctx.connected.unwrap_or_else(|| crate::topology::boundary_edges_if_split(&mesh).is_empty()),
        };
        let changes = if start.is_none() { improve::search(&mut mesh, &geo)? } else { 0 };
        if trace {
            eprintln!("search: {changes} local changes, done at {:.3} s", t0.elapsed().as_secs_f64());
        }
        let kept = smoothing::polish(&mut mesh, &geo)?;
        if trace {
            eprintln!("polish: {kept} sweeps, done at {:.3} s", t0.elapsed().as_secs_f64());
        }
    }
    for v in frozen {
        if mesh.contains_vertex(v) {
            let tag = if mesh.is_boundary_vertex(v) { VertexTag::Boundary } else { VertexTag::Interior };
            mesh.set_tag(v, tag);
        }
    }
    if let Some(di) = &ctx.internal {
        internal::tag_interface(&mut mesh);
        // No triangle may have vertices strictly on both sides of d_I (the sign of d_I at
        // them): crossing edges get a vertex on the curve, and a crossing left is a bug.
        // On the curve: within 1e-6 h0 (curve nodes are projected to 1e-9 h0; a bisection
        // split next to such a node would only make a sliver).
        let on = 1e-6 * opts.h0;
        internal::seal(&mut mesh, di, on)?;
        let left = internal::crossings(&mesh, di, on)?;
        if left > 0 {
            return Err(Error::internal(format!(
                "{left} triangles cross the internal boundary (vertices strictly on both sides of d_I) after the repair"
            )));
        }
        ctx.report.internal_nodes_off = internal::nodes_off(&mesh, di, ctx.geps)?;
    }
    if ctx.internal.is_some() || start.is_some() {
        internal::label_subdomains(&mut mesh);
    }
    if let Err(e) = mesh.validate(Level::Geometry) {
        return Err(Error::broken("the finished mesh is invalid", e));
    }
    if trace {
        eprintln!("validated at {:.3} s", t0.elapsed().as_secs_f64());
    }
    if start.is_none() && freeze.is_none() {
        let (notes, by_size) = coverage::uncovered(&ctx, &mesh)?;
        ctx.report.notes.extend(notes);
        ctx.report.dropped_by_size = by_size;
        if trace {
            eprintln!("coverage checked at {:.3} s", t0.elapsed().as_secs_f64());
        }
    }
    let mut report = ctx.report;
    report.seconds = t0.elapsed().as_secs_f64();
    report.quality = QualityStats::of(&mesh);
    if let Some(f) = &opts.metric {
        report.metric = Some(crate::mesher::metric::MetricStats::of(&mesh, &|p| f(p)));
    }
    Ok(MeshOutput2 { mesh, report })
}

/// The process's peak resident memory so far, for the trace (Linux; "?" elsewhere).
fn peak_memory() -> String {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("VmHWM:")).map(|l| l[6..].trim().to_string()))
        .unwrap_or_else(|| "?".into())
}

// ============================ initial mesh ============================

/// Marks the vertices within `rings` edges of the marked vertices `front` (already in `ring`,
/// at ring 0) with their ring, breadth first.
fn within_rings(m: &TriMesh<DVec2>, ring: &mut SecondaryMap<VertexId, u32>, mut front: Vec<VertexId>, rings: usize) {
    for k in 1..=rings as u32 {
        let mut next = Vec::new();
        for &v in &front {
            for w in m.neighbours(v) {
                if !ring.contains_key(w) {
                    ring.insert(w, k);
                    next.push(w);
                }
            }
        }
        front = next;
    }
}
