//! `trussmesh surface`: the closed surface phi(x, y, z) = 0 (seed section 3.6.1), or rational
//! Bézier patches from a JSON file (section 3.6.2), meshed in space.

use super::budget::{self, Budget};
use super::mesh::{constant, parse_expr, round_sig, show_point, sig, split_top, whole_number};
use super::{output, Failure};
use clap::Args;
use glam::DVec3;
use std::path::PathBuf;
use std::sync::Arc;
use trussmesh::expr::{Expr, ExprImplicit3};
use trussmesh::io::{CellType, MeshData};
use trussmesh::surface::bezier::{mesh_patches, BezierOptions, BezierQuality, RationalBezierPatch};
use trussmesh::surface::{mesh_surface, SurfaceOptions};

/// Mesh the closed surface phi(x, y, z) = 0 (phi < 0 inside).
#[derive(Args, Debug)]
pub struct SurfaceArgs {
    /// The surface phi(x, y, z) = 0, any smooth level-set function, negative inside.
    #[arg(
        long,
        value_name = "EXPR",
        allow_hyphen_values = true,
        required_unless_present_any = ["bezier", "input"],
        conflicts_with_all = ["bezier", "input"]
    )]
    pub phi: Option<String>,
    /// A closed triangulated surface to remesh instead of phi (.stl .obj .ply .mesh .msh .vtu;
    /// the box from the file unless --bbox is given).
    #[arg(long, value_name = "FILE", conflicts_with = "bezier")]
    pub input: Option<PathBuf>,
    /// Rational Bézier patches instead of phi: a JSON file {"patches": [{"degree": [m, n],
    /// "control": [[x, y, z], ...], "weights": [...], "trim": "EXPR in u, v"}]} (control points
    /// u fastest; the patch keeps trim <= 0).
    #[arg(long, value_name = "PATCHES.json")]
    pub bezier: Option<PathBuf>,
    /// A box containing the whole surface: the minimum corner, then the maximum corner.
    #[arg(
        long,
        value_name = "X0,Y0,Z0,X1,Y1,Z1",
        allow_hyphen_values = true,
        required_unless_present_any = ["bezier", "input"],
        conflicts_with = "bezier"
    )]
    pub bbox: Option<String>,
    /// Target edge length (the smallest one with --size auto).
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub h0: String,
    /// `auto`: sizes from curvature, h = 1/(K |kappa|) clamped to [h0, hmax], gradient limited;
    /// or a relative size h(x, y, z) (with --phi or --input; only ratios matter: the smallest
    /// near the surface becomes h0) [default: uniform h0].
    #[arg(long, value_name = "auto|EXPR", allow_hyphen_values = true, conflicts_with = "bezier")]
    pub size: Option<String>,
    /// With --size auto: elements per radian of curvature [default: 2].
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    pub per_radian: Option<f64>,
    /// The old spelling of --size auto --per-radian K.
    #[arg(long, value_name = "K", hide = true, conflicts_with_all = ["bezier", "size", "per_radian"], allow_hyphen_values = true)]
    pub curvature: Option<f64>,
    /// With --size auto: gradient limit G, neighbouring sizes within a factor 1 + G
    /// [default: 0.3].
    #[arg(long, value_name = "G", allow_hyphen_values = true)]
    pub gradient: Option<f64>,
    /// With --size auto: the largest size [default: 8 h0].
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub hmax: Option<f64>,
    /// Iteration cap of each force loop (one per level of the coarse-to-fine start).
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = whole_number::<usize>)]
    pub max_iter: Option<usize>,
    /// With --input: edges whose triangles' normals differ by more than DEG degrees are sharp
    /// features, held by the remeshed surface: its vertices on them slide along the input's
    /// own edges, and corners stay (default 40).
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub feature_angle: Option<f64>,
    /// With --input: hold no sharp feature of the input (they are rounded off).
    #[arg(long)]
    pub no_sharp: bool,
    /// Memory budget (such as 2G or 500M; default a quarter of the machine's memory): a run
    /// whose estimate passes it is refused before meshing.
    #[arg(long, value_name = "BYTES")]
    pub max_memory: Option<String>,
    /// Output file; the extension picks the format (.json .vtu .msh .mesh .obj .stl .ply, or a
    /// shaded picture .svg .png).
    #[arg(short = 'o', long = "output", value_name = "FILE", required = true)]
    pub output: Vec<PathBuf>,
    /// No report.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `trussmesh surface`.
pub fn run(args: SurfaceArgs) -> Result<(), Failure> {
    output::check_all(&args.output)?;
    let budget = Budget::new(args.max_memory.as_deref())?;
    let h0 = constant("h0", &args.h0)?;
    if h0 <= 0.0 {
        return Err(Failure::bad(format!("h0 = {h0} must be positive (--h0 {})", args.h0.trim())));
    }
    if args.input.is_none() && (args.feature_angle.is_some() || args.no_sharp) {
        return Err(Failure::bad("--feature-angle and --no-sharp go with --input (a surface file)"));
    }
    if let Some(path) = &args.bezier {
        return run_bezier(path, h0, &args, &budget);
    }
    if let Some(path) = &args.input {
        return super::trisurf::run_surface(&args, path, h0);
    }
    let (Some(phi_src), Some(bbox_src)) = (&args.phi, &args.bbox) else {
        return Err(Failure::bad("--phi and --bbox are needed without --bezier"));
    };
    let phi = ExprImplicit3::new(parse_expr("phi", phi_src)?);
    let corners: Vec<f64> = split_top(bbox_src, ',').iter().map(|c| constant("bbox", c)).collect::<Result<_, _>>()?;
    if corners.len() != 6 {
        return Err(Failure::bad(format!("--bbox needs 6 numbers X0,Y0,Z0,X1,Y1,Z1, not {}", corners.len())));
    }
    let (lo, hi) = (DVec3::new(corners[0], corners[1], corners[2]), DVec3::new(corners[3], corners[4], corners[5]));
    for k in 0..3 {
        let axis = ["x", "y", "z"][k];
        if lo[k].is_nan() || hi[k].is_nan() || lo[k] >= hi[k] {
            return Err(Failure::bad(format!(
                "--bbox is empty along axis {axis}: min {} >= max {} (order: X0,Y0,Z0,X1,Y1,Z1)",
                lo[k], hi[k]
            )));
        }
        if !(hi[k] - lo[k]).is_finite() {
            return Err(Failure::bad(format!(
                "--bbox is too wide along axis {axis}: from {} to {} is more than the largest number (about 1.8e308)",
                sig(lo[k]),
                sig(hi[k])
            )));
        }
    }
    let sample = SurfaceSample::new(&phi, lo, hi);
    sample.check(h0, phi_src)?;
    let triangles = sample.area / (3f64.sqrt() / 4.0 * h0 * h0);
    budget.check(
        "the surface mesh",
        budget::BASE_BYTES + triangles * budget::BYTES_PER_SURFACE_TRIANGLE,
        &format!(
            "about {} triangles for a surface of area about {} at about {} bytes each",
            budget::count(triangles),
            sig(sample.area),
            budget::BYTES_PER_SURFACE_TRIANGLE
        ),
        "use a larger --h0",
    )?;
    let mut opts = SurfaceOptions::uniform(h0, lo, hi);
    match size_rule(&args)? {
        SizeRule::Uniform => {}
        SizeRule::Curvature(k) => {
            opts = opts.with_curvature(k, args.gradient.unwrap_or(0.3), args.hmax.unwrap_or(8.0 * h0));
        }
        SizeRule::Relative(e) => opts = opts.with_size(move |p| e.eval(p.x, p.y, p.z)),
    }
    if let Some(n) = args.max_iter {
        opts = opts.with_max_iter(n);
    }
    let out = super::mesh::with_progress_bar(args.quiet, "stages", |pb| {
        if let Some(pb) = pb {
            opts = opts.with_progress(super::mesh::progress_callback(pb));
        }
        mesh_surface(&phi, &opts)
    })
    .map_err(|e| sample.diagnose(h0, e.into()))?;
    let data = MeshData::from_trimesh3(&out.mesh);
    output::write_all(&args.output, &data, phi_src)?;
    if !args.quiet {
        println!("{}", out.report);
        for p in &args.output {
            println!("wrote {}", output::describe(p));
        }
    }
    Ok(())
}

/// The size rule of `surface --phi`.
pub(super) enum SizeRule {
    /// h0 everywhere.
    Uniform,
    /// Sizes from curvature with K elements per radian (`--size auto`, or the old
    /// `--curvature K`).
    Curvature(f64),
    /// A relative size expression in x, y, z (`--size EXPR`).
    Relative(Expr),
}

/// The size rule the flags give; the flags of `--size auto` without it are refused.
pub(super) fn size_rule(args: &SurfaceArgs) -> Result<SizeRule, Failure> {
    let auto_flags = args.per_radian.is_some() || args.gradient.is_some() || args.hmax.is_some();
    let refuse = || Failure::bad("--per-radian, --gradient and --hmax go with --size auto (or the old --curvature K)");
    match (args.size.as_deref().map(str::trim), args.curvature) {
        (Some(s), _) if s.eq_ignore_ascii_case("auto") => Ok(SizeRule::Curvature(args.per_radian.unwrap_or(2.0))),
        (Some(_), _) if auto_flags => Err(refuse()),
        (Some(s), _) => {
            let e = parse_expr("--size", s)?;
            Ok(SizeRule::Relative(e))
        }
        (None, Some(k)) => Ok(SizeRule::Curvature(k)),
        (None, None) if auto_flags => Err(refuse()),
        (None, None) => Ok(SizeRule::Uniform),
    }
}

/// One patch as the JSON file gives it.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PatchJson {
    degree: [usize; 2],
    control: Vec<[f64; 3]>,
    weights: Vec<f64>,
    #[serde(default)]
    trim: Option<String>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PatchesJson {
    patches: Vec<PatchJson>,
}

/// The trim expression is written in u and v; the expression language knows x and y, so the
/// identifiers u and v are renamed (and x, y refused, to keep one meaning).
fn trim_expr(src: &str) -> Result<Expr, Failure> {
    let mut out = String::with_capacity(src.len());
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| -> Result<(), Failure> {
        match word.as_str() {
            "u" => out.push('x'),
            "v" => out.push('y'),
            "x" | "y" | "z" => return Err(Failure::bad(format!("the trim expression uses u and v, not {word}"))),
            w => out.push_str(w),
        }
        word.clear();
        Ok(())
    };
    for c in src.chars() {
        if c.is_ascii_alphanumeric()
            || c == '_'
            || (c == '.' && word.chars().all(|d| d.is_ascii_digit())) && !word.is_empty()
        {
            word.push(c);
        } else {
            flush(&mut word, &mut out)?;
            out.push(c);
        }
    }
    flush(&mut word, &mut out)?;
    parse_expr("trim", &out).map_err(|f| Failure::bad(format!("{} (in the trim expression {src:?})", f.message)))
}

/// The area of an untrimmed patch, from the triangles of a 32 x 32 grid of its points.
fn patch_area(p: &RationalBezierPatch) -> f64 {
    let n = 32;
    let at = |i: usize, j: usize| p.point(glam::DVec2::new(i as f64 / n as f64, j as f64 / n as f64));
    let mut a = 0.0;
    for j in 0..n {
        for i in 0..n {
            let (p00, p10, p01, p11) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
            a += 0.5 * ((p10 - p00).cross(p11 - p00).length() + (p11 - p00).cross(p01 - p00).length());
        }
    }
    if a.is_finite() {
        a
    } else {
        0.0
    }
}

/// `trussmesh surface --bezier PATCHES.json`.
fn run_bezier(path: &std::path::Path, h0: f64, args: &SurfaceArgs, budget: &Budget) -> Result<(), Failure> {
    let text =
        std::fs::read_to_string(path).map_err(|e| Failure::bad(format!("cannot read {}: {e}", path.display())))?;
    let json: PatchesJson = serde_json::from_str(&text)
        .map_err(|e| Failure::bad(format!("bad Bézier patch file {}: {e}", path.display())))?;
    let mut patches = Vec::with_capacity(json.patches.len());
    for (k, p) in json.patches.into_iter().enumerate() {
        let control = p.control.iter().map(|c| DVec3::from_array(*c)).collect();
        let mut patch = RationalBezierPatch::new((p.degree[0], p.degree[1]), control, p.weights)
            .map_err(|e| Failure::bad(format!("patch {k}: {e}")))?;
        if let Some(t) = &p.trim {
            let e = trim_expr(t)?;
            patch = patch.with_trim(Arc::new(move |u, v| e.eval(u, v, 0.0)));
        }
        patches.push(patch);
    }
    let mut opts = BezierOptions::new(h0);
    if let Some(n) = args.max_iter {
        opts.max_iter = n;
    }
    // The patches' area, from a 32 x 32 grid of points on each (untrimmed: an upper bound).
    let area: f64 = patches.iter().map(patch_area).sum();
    let triangles = area / (3f64.sqrt() / 4.0 * h0 * h0);
    budget.check(
        "the patches' mesh",
        budget::BASE_BYTES + triangles * budget::BYTES_PER_SURFACE_TRIANGLE,
        &format!(
            "about {} triangles for control nets of area {} at about {} bytes each",
            budget::count(triangles),
            sig(area),
            budget::BYTES_PER_SURFACE_TRIANGLE
        ),
        "use a larger --h0",
    )?;
    let start = std::time::Instant::now();
    let out = mesh_patches(&patches, &opts)?;
    let q = BezierQuality::measure(&out.points, &out.triangles, h0);
    let data = MeshData {
        dim: 3,
        cell_type: CellType::Triangle,
        points: out.points.iter().map(|p| p.to_array()).collect(),
        cells: out.triangles.iter().flatten().copied().collect(),
        subdomain: None,
    };
    output::write_all(&args.output, &data, "Bézier patches")?;
    if !args.quiet {
        println!(
            "bezier: {} patches, {} vertices, {} triangles; min angle {:.1}, min q {:.3}, mean q {:.4}, size deviation {:.1}% (mean length/h {:.3}); {:.2} s",
            patches.len(),
            q.vertices,
            q.triangles,
            q.min_angle,
            q.min_q,
            q.mean_q,
            100.0 * q.size_deviation,
            q.mean_size_ratio,
            start.elapsed().as_secs_f64()
        );
        for p in &args.output {
            println!("wrote {}", output::describe(p));
        }
    }
    Ok(())
}

/// phi sampled on a grid over the box, before meshing: the surface's rough area (cells the
/// surface crosses) and the extent of its inside.
struct SurfaceSample {
    negative: usize,
    positive: usize,
    lo: DVec3,
    hi: DVec3,
    step: DVec3,
    area: f64,
}

impl SurfaceSample {
    const N: usize = 64;

    fn new(phi: &ExprImplicit3, lo: DVec3, hi: DVec3) -> SurfaceSample {
        let n = Self::N;
        let step = (hi - lo) / n as f64;
        let mut v = vec![0.0; (n + 1) * (n + 1) * (n + 1)];
        let at = |i: usize, j: usize, k: usize| i + (n + 1) * (j + (n + 1) * k);
        let mut s =
            SurfaceSample { negative: 0, positive: 0, lo: DVec3::INFINITY, hi: DVec3::NEG_INFINITY, step, area: 0.0 };
        for k in 0..=n {
            for j in 0..=n {
                for i in 0..=n {
                    let p = lo + step * DVec3::new(i as f64, j as f64, k as f64);
                    let f = phi.expr.eval(p.x, p.y, p.z);
                    v[at(i, j, k)] = f;
                    if f < 0.0 {
                        s.negative += 1;
                        s.lo = s.lo.min(p);
                        s.hi = s.hi.max(p);
                    } else if f > 0.0 {
                        s.positive += 1;
                    }
                }
            }
        }
        // A surface of area A crosses about 1.5 A / step^2 cells (the mean of |n_x| + |n_y| +
        // |n_z| over directions); the step is the cube root of the cell volume.
        let mut crossed = 0usize;
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let c = [0, 1].iter().flat_map(|&dk| {
                        [0, 1].iter().flat_map(move |&dj| [0, 1].map(move |di| (i + di, j + dj, k + dk)))
                    });
                    let (mut neg, mut pos) = (false, false);
                    for (a, b, cc) in c {
                        let f = v[at(a, b, cc)];
                        neg |= f < 0.0;
                        pos |= f >= 0.0;
                    }
                    crossed += (neg && pos) as usize;
                }
            }
        }
        let h = (step.x * step.y * step.z).cbrt();
        s.area = crossed as f64 * h * h / 1.5;
        s
    }

    /// Refuses an h0 that is plainly larger than the surface.
    fn check(&self, h0: f64, src: &str) -> Result<(), Failure> {
        if self.negative == 0 || self.positive == 0 {
            return Ok(()); // The mesher names a phi of one sign.
        }
        let span = self.hi - self.lo + self.step;
        if h0 > span.max_element() / 2.0 {
            return Err(self.too_large(h0, src));
        }
        Ok(())
    }

    fn too_large(&self, h0: f64, src: &str) -> Failure {
        let span = self.hi - self.lo + self.step;
        Failure::bad(format!(
            "h0 = {h0} is too large for the surface {src:?}: its inside spans about {} x {} x {} (from {} to {}), \
             and elements of {h0} cannot follow it; give an --h0 below {}",
            sig(span.x),
            sig(span.y),
            sig(span.z),
            show_point(&self.lo.to_array().map(round_sig)),
            show_point(&self.hi.to_array().map(round_sig)),
            sig(span.min_element() / 4.0)
        ))
    }

    /// Rewrites "phi is positive everywhere" when the samples found an inside: the start's
    /// grid of spacing about h0 stepped over the surface.
    fn diagnose(&self, h0: f64, f: Failure) -> Failure {
        if f.code == super::EXIT_BAD_INPUT && f.message.contains("everywhere in the bounding box") && self.negative > 0
        {
            let mut t = self.too_large(h0, "phi");
            t.message = t.message.replacen("\"phi\"", "phi", 1);
            return t;
        }
        f
    }
}
