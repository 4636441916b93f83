//! `trussmesh mesh`: flags or a TOML scene in, mesh files and pictures out.

use super::auto_size::{is_auto, Auto, AutoSizeArgs};
use super::budget::{self, Budget};
use super::fields::{self, Field, Field2, Field3, Placement};
pub use super::scene::{constant, parse_expr, scene_spec, split_top, whole_number};
use super::{kinds, output, Failure};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Deserialize;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use trussmesh::expr::{Expr, ExprImplicit2};
use trussmesh::geometry::project::Projection;
use trussmesh::geometry::{Declared, Implicit2, Implicit3};
use trussmesh::io::{CellType, MeshData};
use trussmesh::mesher::{estimated_elements, mesh_2d, mesh_3d, Metric2, Options2, Options3, Report, Survey};

/// Projection of boundary nodes onto d = 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProjectionArg {
    /// Exact for distances, first order otherwise.
    Auto,
    /// One step p - d grad d (signed distances).
    Exact,
    /// First-order steps (seed eq. 3.9).
    First,
    /// Second-order steps (seed eq. 3.10-3.16).
    Second,
    /// True closest point by Newton's method (seed eq. 2.10-2.12).
    Newton,
}

impl From<ProjectionArg> for Projection {
    fn from(p: ProjectionArg) -> Self {
        match p {
            ProjectionArg::Auto => Projection::Auto,
            ProjectionArg::Exact => Projection::Exact,
            ProjectionArg::First => Projection::FirstOrder,
            ProjectionArg::Second => Projection::SecondOrder,
            ProjectionArg::Newton => Projection::Newton,
        }
    }
}

const FLAGS: [&str; 20] = [
    "origin",
    "spacing",
    "per_radian",
    "across",
    "gradient",
    "hmax",
    "dim",
    "domain",
    "size",
    "h0",
    "bbox",
    "fix",
    "max_iter",
    "seed",
    "projection",
    "implicit",
    "internal",
    "metric",
    "no_sharp",
    "feature_angle",
];

/// Mesh {d < 0} given by expressions in x, y (z), or by a scene file.
#[derive(Args, Debug, Default)]
pub struct MeshArgs {
    /// A TOML scene file with the same fields as the flags (dim, domain, size, h0, bbox, fix,
    /// max_iter, seed, projection, implicit, internal, metric, output; `sharp = false` for
    /// --no-sharp).
    #[arg(value_name = "SCENE.toml", conflicts_with_all = FLAGS)]
    pub scene: Option<PathBuf>,
    /// Dimension [default: 2].
    #[arg(long, value_name = "2|3")]
    pub dim: Option<usize>,
    /// The domain d(x, y) < 0 (a signed distance unless --implicit), a grid of its values (.npy
    /// placed by --origin and --spacing, or .vti), a file of closed polylines whose inside is
    /// meshed in 2-D (.txt .xy .dat .csv of x y lines, .obj with l records, or a planar triangle
    /// mesh .msh .vtu .mesh whose boundary is taken), or with --dim 3 a closed surface file (.stl
    /// .obj .ply .mesh .msh .vtu) whose inside is meshed.
    #[arg(long, value_name = "EXPR", allow_hyphen_values = true, required_unless_present = "scene")]
    pub domain: Option<String>,
    /// Relative size h(x, y) (only ratios matter; default uniform), a grid of its values (.npy or
    /// .vti, as for --domain), or `auto`: sizes from curvature and feature size, gradient
    /// limited, from --h0 up to --hmax.
    #[arg(long, value_name = "EXPR|auto", allow_hyphen_values = true)]
    pub size: Option<String>,
    #[command(flatten)]
    pub auto: AutoSizeArgs,
    /// Initial edge length (a constant expression such as 0.05/3).
    #[arg(long, value_name = "H", allow_hyphen_values = true, required_unless_present = "scene")]
    pub h0: Option<String>,
    /// Bounding box: the minimum corner, then the maximum corner (required, but for a surface
    /// or polyline file's inside, whose box is the file's own, and for a grid --domain, whose
    /// box is the grid's extent).
    #[arg(long, value_name = "X0,Y0[,Z0],X1,Y1[,Z1]", allow_hyphen_values = true)]
    pub bbox: Option<String>,
    /// With a .npy grid as --domain or --size: the position of its first sample, a[0, 0] or
    /// a[0, 0, 0] (the array's axes are (y, x) or (z, y, x)) [default: 0,0 or 0,0,0].
    #[arg(long, value_name = "X,Y[,Z]", allow_hyphen_values = true)]
    pub origin: Option<String>,
    /// With a .npy grid as --domain or --size: the distance between neighbouring samples, the
    /// same along every axis (required for .npy; a .vti image carries its own).
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub spacing: Option<String>,
    /// Fixed points, separated by ';'.
    #[arg(long, value_name = "x,y[,z];...", allow_hyphen_values = true)]
    pub fix: Option<String>,
    /// Iteration cap of the force loop [default: 1000 in 2-D, 300 in 3-D].
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = whole_number::<usize>)]
    pub max_iter: Option<usize>,
    /// Seed of every random choice (same input and seed: same mesh) [default: 0].
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = whole_number::<u64>)]
    pub seed: Option<u64>,
    /// Boundary projection [default: auto].
    #[arg(long, value_enum)]
    pub projection: Option<ProjectionArg>,
    /// The domain is a level set, not a signed distance.
    #[arg(long)]
    pub implicit: bool,
    /// Internal boundaries: curves EXPR = 0 that no triangle crosses (seed section 3.4);
    /// triangles are labelled by subdomain (.msh physical groups, .vtu cell data).
    #[arg(long, value_name = "EXPR", allow_hyphen_values = true)]
    pub internal: Option<String>,
    /// Anisotropic metric "A;B;C": M = [[A, B], [B, C]] (seed eq. 3.19), three expressions in
    /// x, y; replaces --size, and --h0 then only sets tolerances (about the smallest size).
    #[arg(long, value_name = "A;B;C", allow_hyphen_values = true)]
    pub metric: Option<String>,
    /// Do not look for sharp corners (and in 3-D sharp edges) to hold fixed: they are rounded
    /// off unless given with --fix.
    #[arg(long)]
    pub no_sharp: bool,
    /// With a surface file as --domain: edges whose triangles' normals differ by more than DEG
    /// degrees are sharp features, held by the mesh (default 40); with a polyline file, points
    /// where the polyline turns by more than DEG degrees are corners, held fixed.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub feature_angle: Option<f64>,
    /// Output file; the extension picks the format (.json .vtu .msh .mesh .obj .stl .ply .svg .png).
    #[arg(short = 'o', long = "output", value_name = "FILE", required_unless_present = "scene")]
    pub output: Vec<PathBuf>,
    /// Memory budget (such as 2G or 500M; default a quarter of the machine's memory): a run
    /// whose estimate passes it is refused before meshing.
    #[arg(long, value_name = "BYTES")]
    pub max_memory: Option<String>,
    /// No progress bar and no report.
    #[arg(short, long)]
    pub quiet: bool,
}

/// The run as text, from flags or a scene file, before checking.
#[derive(Debug, Clone, Default)]
pub struct Spec {
    pub dim: usize,
    pub domain: String,
    pub size: Option<String>,
    pub auto: AutoSizeArgs,
    pub h0: String,
    pub bbox: Vec<String>,
    /// Where .npy grids sit (--origin, --spacing).
    pub place: Placement,
    pub fix: Vec<Vec<String>>,
    pub max_iter: Option<usize>,
    pub seed: Option<u64>,
    pub projection: Option<ProjectionArg>,
    pub implicit: bool,
    pub internal: Option<String>,
    pub metric: Option<String>,
    /// Find sharp features and hold them fixed.
    pub sharp: bool,
    pub outputs: Vec<PathBuf>,
    pub max_memory: Option<String>,
}

/// A checked run.
pub struct Job {
    pub dim: usize,
    pub domain: Field,
    pub size: Option<Field>,
    /// `--size auto`.
    pub auto: Option<Auto>,
    pub h0: f64,
    pub bbox: Vec<f64>,
    pub fix: Vec<Vec<f64>>,
    pub max_iter: Option<usize>,
    pub seed: Option<u64>,
    pub projection: Option<ProjectionArg>,
    pub implicit: bool,
    pub internal: Option<Expr>,
    pub metric: Option<[Expr; 3]>,
    pub sharp: bool,
    pub outputs: Vec<PathBuf>,
    pub budget: Budget,
}

/// A finished run. `report` is the run's report without its quality summary (the mesh is
/// measured on its own); `summary` is the report as printed.
pub struct Meshed {
    pub mesh: MeshData,
    /// The kind of every node of `mesh`.
    pub node_kind: Vec<trussmesh::io::NodeKind>,
    pub report: Report<()>,
    pub summary: String,
}

impl MeshArgs {
    /// The run these arguments describe (reading the scene file if one is given).
    pub fn spec(&self) -> Result<Spec, Failure> {
        if let Some(path) = &self.scene {
            let text = std::fs::read_to_string(path)
                .map_err(|e| Failure::bad(format!("cannot read {}: {e}", path.display())))?;
            let mut spec = scene_spec(&text, &path.display().to_string())?;
            spec.outputs.extend(self.output.iter().cloned());
            spec.max_memory = self.max_memory.clone().or(spec.max_memory);
            return Ok(spec);
        }
        let need = |v: &Option<String>, flag: &str| {
            v.clone().ok_or_else(|| {
                Failure::bad(format!("missing --{flag} (or give a SCENE.toml file); see trussmesh mesh --help"))
            })
        };
        let fix = match &self.fix {
            Some(f) if !f.trim().is_empty() => {
                split_top(f, ';').iter().filter(|p| !p.trim().is_empty()).map(|p| split_top(p, ',')).collect()
            }
            _ => Vec::new(),
        };
        Ok(Spec {
            dim: self.dim.unwrap_or(2),
            domain: need(&self.domain, "domain")?,
            size: self.size.clone(),
            auto: self.auto.clone(),
            h0: need(&self.h0, "h0")?,
            bbox: match (&self.bbox, &self.domain) {
                (None, Some(d)) if fields::is_grid(d) => Vec::new(),
                _ => split_top(&need(&self.bbox, "bbox")?, ','),
            },
            place: Placement { origin: self.origin.clone(), spacing: self.spacing.clone() },
            fix,
            max_iter: self.max_iter,
            seed: self.seed,
            projection: self.projection,
            implicit: self.implicit,
            internal: self.internal.clone(),
            metric: self.metric.clone(),
            sharp: !self.no_sharp,
            outputs: self.output.clone(),
            max_memory: self.max_memory.clone(),
        })
    }
}

impl Spec {
    /// Checks everything and compiles the expressions.
    pub fn resolve(&self) -> Result<Job, Failure> {
        self.resolve_with(true)
    }

    /// [`Spec::resolve`]; with `files` false the outputs' extensions are checked but not the
    /// file system, and the budget is the fixed fallback (for the fuzz body).
    pub fn resolve_with(&self, files: bool) -> Result<Job, Failure> {
        let dim = self.dim;
        if dim != 2 && dim != 3 {
            return Err(Failure::bad(format!("--dim must be 2 or 3, not {dim}")));
        }
        let domain = fields::load("--domain", &self.domain, dim, &self.place)?;
        let auto_size = is_auto(self.size.as_deref());
        let size = match &self.size {
            // Sizes are relative: a positive constant is the uniform size, which the meshers
            // have fast paths for (the 2-D force loop holds a large lattice's core).
            Some(s) if !auto_size => match fields::load("--size", s, dim, &self.place)? {
                fields::Field::Expr(e)
                    if e.is_constant() && e.eval(0.0, 0.0, 0.0).is_finite() && e.eval(0.0, 0.0, 0.0) > 0.0 =>
                {
                    None
                }
                f => Some(f),
            },
            _ => None,
        };
        if !(fields::is_grid(&self.domain) || self.size.as_deref().is_some_and(fields::is_grid))
            && (self.place.origin.is_some() || self.place.spacing.is_some())
        {
            return Err(Failure::bad("--origin and --spacing go with a .npy grid as --domain or --size"));
        }
        let internal = match &self.internal {
            Some(s) => Some(parse_expr("--internal", s)?),
            None => None,
        };
        let metric = match &self.metric {
            Some(s) => {
                let parts = split_top(s, ';');
                if parts.len() != 3 {
                    return Err(Failure::bad(format!(
                        "--metric needs three expressions \"A;B;C\" for M = [[A, B], [B, C]], got {}",
                        parts.len()
                    )));
                }
                if self.size.is_some() {
                    return Err(Failure::bad(
                        "give either --size or --metric, not both (the metric replaces the size)",
                    ));
                }
                Some([
                    parse_expr("--metric A", &parts[0])?,
                    parse_expr("--metric B", &parts[1])?,
                    parse_expr("--metric C", &parts[2])?,
                ])
            }
            None => None,
        };
        if dim == 3 && (internal.is_some() || metric.is_some()) {
            return Err(Failure::bad("--internal and --metric are 2-D options (--dim 2)"));
        }
        if dim == 2 {
            let fields = [&domain].into_iter().chain(size.as_ref()).map(|f| (f.source(), f.uses_z()));
            let exprs = internal.iter().chain(metric.iter().flatten()).map(|e| (e.source(), e.uses_z()));
            for (source, uses_z) in fields.chain(exprs) {
                if uses_z {
                    return Err(Failure::bad(format!("{source:?} uses z but --dim is 2")));
                }
            }
        }
        let h0 = constant("h0", &self.h0)?;
        if h0 <= 0.0 {
            return Err(Failure::bad(format!("h0 must be positive, got {h0} ({})", self.h0.trim())));
        }
        let auto = self.auto.resolve(auto_size, h0)?;
        let axes = if dim == 2 { "X0,Y0,X1,Y1" } else { "X0,Y0,Z0,X1,Y1,Z1" };
        let grid_box = domain.grid_box().filter(|_| self.bbox.is_empty());
        if grid_box.is_none() && self.bbox.len() != 2 * dim {
            return Err(Failure::bad(format!(
                "--bbox needs {} values for --dim {dim} ({axes}), got {}",
                2 * dim,
                self.bbox.len()
            )));
        }
        let bbox = match grid_box {
            Some(b) => b,
            None => self.bbox.iter().map(|s| constant("a --bbox value", s)).collect::<Result<Vec<_>, _>>()?,
        };
        for k in 0..dim {
            let axis = ["x", "y", "z"][k];
            if bbox[k] >= bbox[k + dim] {
                return Err(Failure::bad(format!(
                    "--bbox is empty along axis {axis}: min {} >= max {} (order: {axes})",
                    bbox[k],
                    bbox[k + dim]
                )));
            }
            let width = bbox[k + dim] - bbox[k];
            if !width.is_finite() {
                return Err(Failure::bad(format!(
                    "--bbox is too wide along axis {axis}: from {} to {} is more than the largest number (about \
                     1.8e308); give a box that holds the domain with a margin",
                    sig(bbox[k]),
                    sig(bbox[k + dim])
                )));
            }
            if width / h0 > 1e15 {
                return Err(Failure::bad(format!(
                    "--bbox is {} wide along axis {axis}, {} times h0 = {h0:e}: no mesh has that many elements \
                     across; give a larger --h0 or a smaller box",
                    sig(width),
                    sig(width / h0)
                )));
            }
        }
        let mut fix = Vec::new();
        for (i, p) in self.fix.iter().enumerate() {
            if p.len() != dim {
                return Err(Failure::bad(format!(
                    "fixed point {} has {} coordinates, expected {dim} for --dim {dim}",
                    i + 1,
                    p.len()
                )));
            }
            let q = p.iter().map(|s| constant("a --fix coordinate", s)).collect::<Result<Vec<_>, _>>()?;
            if (0..dim).any(|k| q[k] < bbox[k] || q[k] > bbox[k + dim]) {
                return Err(Failure::bad(format!(
                    "the fixed point {} lies outside the box {} - {} (--bbox)",
                    show_point(&q),
                    show_point(&bbox[..dim]),
                    show_point(&bbox[dim..])
                )));
            }
            fix.push(q);
        }
        if dim == 3 {
            for p in &self.outputs {
                if matches!(output::extension(p).as_str(), "obj" | "stl" | "ply") {
                    return Err(Failure::bad(format!(
                        "{} cannot hold tetrahedra; use .vtu, .msh, .mesh or .json with --dim 3 (or .svg, .png \
                         for a cut-away picture)",
                        p.display()
                    )));
                }
            }
        }
        let budget = if files {
            output::check_all(&self.outputs)?;
            Budget::new(self.max_memory.as_deref())?
        } else {
            self.outputs.iter().try_for_each(|p| output::check_extension(p))?;
            Budget { limit: budget::FALLBACK_BYTES, source: "the fuzz body's".into() }
        };
        Ok(Job {
            dim,
            domain,
            size,
            auto,
            h0,
            bbox,
            fix,
            max_iter: self.max_iter,
            seed: self.seed,
            projection: self.projection,
            implicit: self.implicit,
            internal,
            metric,
            sharp: self.sharp,
            outputs: self.outputs.clone(),
            budget,
        })
    }
}

/// A progress bar on stderr that appears once a run has taken a second; `unit` names what it
/// counts.
fn progress_bar(quiet: bool, unit: &str) -> Option<ProgressBar> {
    if quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let pb = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
    if let Ok(style) = ProgressStyle::with_template(&format!("{{elapsed_precise}} [{{bar:40}}] {{pos}}/{{len}} {unit}"))
    {
        pb.set_style(style.progress_chars("=> "));
    }
    Some(pb)
}

/// Runs `job` with a progress bar (see [`progress_bar`]) handed to it, cleared afterwards
/// whatever the outcome.
pub(crate) fn with_progress_bar<T>(quiet: bool, unit: &str, job: impl FnOnce(Option<ProgressBar>) -> T) -> T {
    let pb = progress_bar(quiet, unit);
    let out = job(pb.clone());
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    out
}

/// The progress callback both meshers take: the bar appears once a run has taken a second.
pub(crate) fn progress_callback(pb: ProgressBar) -> impl Fn(usize, usize) + Send + Sync + 'static {
    let start = Instant::now();
    let shown = AtomicBool::new(false);
    move |it, cap| {
        if !shown.load(Ordering::Relaxed) {
            if start.elapsed() < Duration::from_secs(1) {
                return;
            }
            shown.store(true, Ordering::Relaxed);
            pb.set_draw_target(ProgressDrawTarget::stderr());
        }
        pb.set_length(cap as u64);
        pb.set_position(it as u64);
    }
}

impl Job {
    /// The 2-D mesher's options.
    pub fn options2(&self, progress: Option<ProgressBar>) -> Options2 {
        let b = &self.bbox;
        let mut o = Options2::uniform(self.h0, [b[0], b[1]], [b[2], b[3]]);
        if let Some(h) = &self.size {
            let h = h.clone();
            o = o.with_size(move |p| h.eval(p.x, p.y, 0.0));
        }
        if let Some(g) = self.auto.as_ref().and_then(Auto::ready2) {
            o = o.with_size(move |p| trussmesh::geometry::Implicit2::value(&*g, p));
        }
        o = o.with_fixed(self.fix.iter().map(|p| [p[0], p[1]]));
        if let Some(e) = &self.internal {
            o = o.with_internal(ExprImplicit2 { expr: e.clone(), distance: !self.implicit });
        }
        if let Some([a, b, c]) = &self.metric {
            let (a, b, c) = (a.clone(), b.clone(), c.clone());
            o = o.with_metric(move |p| {
                Metric2::new(a.eval(p.x, p.y, 0.0), b.eval(p.x, p.y, 0.0), c.eval(p.x, p.y, 0.0))
            });
        }
        if let Some(n) = self.max_iter {
            o = o.with_max_iter(n);
        }
        if let Some(s) = self.seed {
            o = o.with_seed(s);
        }
        if let Some(p) = self.projection {
            o = o.with_projection(p.into());
        }
        if let Some(pb) = progress {
            o = o.with_progress(progress_callback(pb));
        }
        o.with_sharp_corners(self.sharp)
    }

    /// The 3-D mesher's options.
    pub fn options3(&self, progress: Option<ProgressBar>) -> Options3 {
        let b = &self.bbox;
        let mut o = Options3::uniform(self.h0, [b[0], b[1], b[2]], [b[3], b[4], b[5]]);
        if let Some(h) = &self.size {
            let h = h.clone();
            o = o.with_size(move |p| h.eval(p.x, p.y, p.z));
        }
        if let Some(g) = self.auto.as_ref().and_then(Auto::ready3) {
            o = o.with_size(move |p| trussmesh::geometry::Implicit3::value(&*g, p));
        }
        o = o.with_fixed(self.fix.iter().map(|p| [p[0], p[1], p[2]]));
        if let Some(n) = self.max_iter {
            o = o.with_max_iter(n);
        }
        if let Some(s) = self.seed {
            o = o.with_seed(s);
        }
        if let Some(p) = self.projection {
            o = o.with_projection(p.into());
        }
        if let Some(pb) = progress {
            o = o.with_progress(progress_callback(pb));
        }
        o.with_sharp_edges(self.sharp)
    }

    /// Meshes in 2-D or 3-D, after the checks that need the domain: fixed points inside it,
    /// internal boundaries that cut it, and the memory estimate against the budget.
    pub fn mesh(&self, quiet: bool) -> Result<Meshed, Failure> {
        self.warn_slow_expressions(quiet);
        self.check_before_meshing()?;
        let result = if self.dim == 3 { mesh3(self, quiet) } else { mesh2(self, quiet) };
        result.map_err(|f| self.diagnose(f))
    }

    /// Computes the `--size auto` grid (once) before the options use it.
    fn prepare_auto(&self) -> Result<(), Failure> {
        let (Some(a), b, d) = (&self.auto, &self.bbox, self.dim) else { return Ok(()) };
        if d == 3 {
            a.grid3(&self.geom3(), [b[0], b[1], b[2]], [b[3], b[4], b[5]]).map(|_| ())
        } else {
            a.grid2(&self.geom2(), [b[0], b[1]], [b[2], b[3]]).map(|_| ())
        }
    }

    /// The domain as the meshers see it.
    /// The domain, declared neither a distance nor a level set: the mesher decides from its
    /// gradient unless `--implicit` declares it a level set.
    fn geom2(&self) -> Field2 {
        Field2(self.domain.clone())
    }

    fn geom3(&self) -> Field3 {
        Field3(self.domain.clone())
    }

    /// The estimated element count of the mesher's survey (bad input fails here, before any
    /// meshing, as it would in the mesher).
    pub fn estimated_elements(&self) -> Result<f64, Failure> {
        self.prepare_auto()?;
        let r = if self.dim == 3 {
            estimated_elements(Survey::Volume(&self.geom3(), &self.options3(None)))
        } else {
            estimated_elements(Survey::Planar(&self.geom2(), &self.options2(None)))
        };
        r.map_err(|e| self.diagnose(e.into()))
    }

    /// Warns (on stderr) when the expressions are so long that the survey of the box alone
    /// would take more than ten seconds: each of its samples evaluates them once.
    fn warn_slow_expressions(&self, quiet: bool) {
        let b = &self.bbox;
        let cap = if self.dim == 3 { 96.0 } else { 512.0 };
        let samples: f64 =
            (0..self.dim).map(|k| ((b[k + self.dim] - b[k]) / self.h0 + 1.0).ceil().clamp(8.0, cap)).product();
        let exprs: Vec<(&str, &Expr)> = std::iter::once(("--domain", &self.domain))
            .chain(self.size.as_ref().map(|e| ("--size", e)))
            .filter_map(|(n, f)| f.expr().map(|e| (n, e)))
            .chain(self.internal.as_ref().map(|e| ("--internal", e)))
            .collect();
        let start = Instant::now();
        let mut reps = 0u32;
        let mut sink = 0.0;
        while reps < 64 && (reps < 2 || start.elapsed() < Duration::from_millis(200)) {
            let t = reps as f64 / 64.0;
            for (_, e) in &exprs {
                sink += e.eval(b[0] + t * (b[self.dim] - b[0]), b[1] + t * (b[self.dim + 1] - b[1]), 0.0);
            }
            reps += 1;
        }
        let per = start.elapsed().as_secs_f64() / reps as f64;
        let survey = per * samples;
        if survey > 10.0 && !quiet {
            std::hint::black_box(sink);
            let ops: usize = exprs.iter().map(|(_, e)| e.ops()).sum();
            let names: Vec<&str> = exprs.iter().map(|(n, _)| *n).collect();
            eprintln!(
                "warning: one evaluation of {} takes about {} ms ({} operations, {} of source); the survey of the box \
                 alone evaluates it {} times (about {} minutes), and meshing many times more; shorten the expression or \
                 use a larger --h0",
                names.join(" and "),
                sig(per * 1e3),
                budget::count(ops as f64),
                budget::human(exprs.iter().map(|(_, e)| e.source().len() as f64).sum()),
                budget::count(samples),
                sig(survey / 60.0)
            );
        }
    }

    fn check_before_meshing(&self) -> Result<(), Failure> {
        // Fixed points must lie in the closed domain (d <= 0 up to rounding).
        for p in &self.fix {
            let d = self.domain.eval(p[0], p[1], p.get(2).copied().unwrap_or(0.0));
            if d.is_nan() || d > 1e-2 * self.h0 {
                return Err(Failure::bad(format!(
                    "the fixed point {} lies outside the domain (d = {d:.4} there); fixed points must be inside it \
                     or on its boundary",
                    show_point(p)
                )));
            }
        }
        if let Some(e) = &self.internal {
            self.check_internal(e)?;
        }
        let n = self.estimated_elements()?;
        let (what, per, unit) = if self.dim == 3 {
            ("the 3-D mesh", budget::BYTES_PER_TET, "tetrahedra")
        } else {
            ("the 2-D mesh", budget::BYTES_PER_TRIANGLE_2D, "triangles")
        };
        self.budget.check(
            what,
            budget::BASE_BYTES + n * per,
            &format!("about {} {unit} at about {per} bytes each", budget::count(n)),
            "use a larger --h0",
        )
    }

    /// An internal boundary must change sign inside the domain, or it separates nothing.
    fn check_internal(&self, e: &Expr) -> Result<(), Failure> {
        let b = &self.bbox;
        let n = 200;
        let (mut neg, mut pos) = (false, false);
        for j in 0..=n {
            for i in 0..=n {
                let x = b[0] + (b[2] - b[0]) * i as f64 / n as f64;
                let y = b[1] + (b[3] - b[1]) * j as f64 / n as f64;
                if self.domain.eval(x, y, 0.0) < 0.0 {
                    let v = e.eval(x, y, 0.0);
                    neg |= v < 0.0;
                    pos |= v > 0.0;
                }
            }
        }
        if neg && pos {
            return Ok(());
        }
        Err(Failure::bad(format!(
            "--internal {:?} is {} everywhere inside the domain: its curves EXPR = 0 do not cross the domain, so it \
             separates nothing (no subdomain labels would be made)",
            e.source(),
            if neg { "negative" } else { "non-negative" }
        )))
    }
}

/// A number to three significant digits: 0.0123, 4.57, 1.23e6.
pub fn sig(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-3..1e5).contains(&x.abs()) {
        return format!("{x:.2e}");
    }
    let digits = if x == 0.0 || !x.is_finite() { 0 } else { (2 - x.abs().log10().floor() as i32).max(0) as usize };
    format!("{x:.digits$}")
}

/// `x` rounded to three significant digits (0.9950000000000001 becomes 0.995).
pub fn round_sig(x: f64) -> f64 {
    sig(x).parse().unwrap_or(x)
}

/// "(5, 5, 5)": a point as the user wrote it.
pub fn show_point(p: &[f64]) -> String {
    let c: Vec<String> = p.iter().map(|x| format!("{x}")).collect();
    format!("({})", c.join(", "))
}

fn planar_data(out: &trussmesh::mesher::MeshOutput2) -> MeshData {
    MeshData::from_trimesh2(&out.mesh)
}

/// 2-D meshing: triangles.
fn mesh2(job: &Job, quiet: bool) -> Result<Meshed, Failure> {
    let geom = job.geom2();
    let level = Declared { inner: &geom as &dyn Implicit2, distance: false };
    let domain: &dyn Implicit2 = if job.implicit { &level } else { &geom };
    let out = with_progress_bar(quiet, "iterations", |pb| mesh_2d(domain, &job.options2(pb)))?;
    let mesh = planar_data(&out);
    let node_kind = kinds::planar(&out.mesh, &job.fix, job.h0);
    let summary = out.report.to_string();
    Ok(Meshed { mesh, node_kind, report: out.report.map_quality(|_| ()), summary })
}

/// 3-D meshing: tetrahedra, written as 3-D cells (.vtu, .msh, .mesh, .json).
fn mesh3(job: &Job, quiet: bool) -> Result<Meshed, Failure> {
    let geom = job.geom3();
    let level = Declared { inner: &geom as &dyn Implicit3, distance: false };
    let domain: &dyn Implicit3 = if job.implicit { &level } else { &geom };
    let out = with_progress_bar(quiet, "iterations", |pb| mesh_3d(domain, &job.options3(pb)))?;
    let trussmesh::topology::MeshArrays { points, cells: tets, labels, .. } = out.mesh.to_arrays();
    let subdomain =
        if labels.iter().any(|&l| l != 0) { Some(labels.iter().map(|&l| l as i32).collect()) } else { None };
    let mesh = MeshData {
        dim: 3,
        cell_type: CellType::Tetra,
        points: points.iter().map(|p| p.to_array()).collect(),
        cells: tets.iter().flatten().copied().collect(),
        subdomain,
    };
    let node_kind = kinds::volume(&out.mesh, &job.fix, job.h0);
    let summary = out.report.to_string();
    Ok(Meshed { mesh, node_kind, report: out.report.map_quality(|_| ()), summary })
}

/// Writes one output: a mesh file (with the node kinds), or a picture for .svg and .png
/// coloured by the metric quality when the job has a metric (whole or not at all).
pub fn write_output(job: &Job, path: &Path, done: &Meshed, title: &str) -> Result<(), Failure> {
    let measure = job.metric.as_ref().map(|abc| output::metric_measure(&done.mesh, abc));
    let extras = output::Extras { measure: measure.as_ref(), node_kind: Some(&done.node_kind) };
    output::write_one_by(path, &done.mesh, title, extras)
}

/// `trussmesh mesh`.
pub fn run(args: MeshArgs) -> Result<(), Failure> {
    if let Some(file) = args.domain.as_deref().filter(|d| super::polydom::is_polyline_file(d, args.dim)) {
        return super::polydom::run_mesh(&args, file);
    }
    if let Some(file) = args.domain.as_deref().filter(|d| super::trisurf::is_surface_file(d)) {
        return super::trisurf::run_mesh(&args, file);
    }
    let job = args.spec()?.resolve()?;
    let done = job.mesh(args.quiet)?;
    let title = job.domain.source().to_string();
    let measure = job.metric.as_ref().map(|abc| output::metric_measure(&done.mesh, abc));
    let extras = output::Extras { measure: measure.as_ref(), node_kind: Some(&done.node_kind) };
    output::write_all_by(&job.outputs, &done.mesh, &title, extras)?;
    if !args.quiet {
        println!("{}", done.summary);
        for p in &job.outputs {
            println!("wrote {}", output::describe(p));
        }
    }
    Ok(())
}
