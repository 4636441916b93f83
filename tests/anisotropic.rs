//! Anisotropic meshes (seed section 3.5, figure 3-6): the unit circle with a boundary layer
//! of thickness about 0.01, sizes h1 = min(hmin + g (1 - r), hmax) across the boundary and
//! h2 = hmax along it. Prints the table kept in docs/quality.md.

use glam::DVec2;
use trussmesh::geometry::Circle;
use trussmesh::mesher::{area, mesh_2d, Metric2, MetricStats, Options2};
use trussmesh::topology::Level;

const HMIN: f64 = 0.01;
const HMAX: f64 = 0.2;
const G: f64 = 0.3;

/// Seed eq. 3.20 to 3.23: radial size h1, tangential size h2.
fn figure_3_6_metric(p: DVec2) -> Metric2 {
    let r = p.length();
    let h1 = (HMIN + G * (1.0 - r)).min(HMAX);
    let dir = if r > 1e-12 { p / r } else { DVec2::X };
    Metric2::from_sizes(dir, h1, HMAX)
}

#[test]
fn figure_3_6_boundary_layer() {
    let opts = Options2::uniform(HMIN, [-1.0, -1.0], [1.0, 1.0]).with_metric(figure_3_6_metric);
    let out = mesh_2d(&Circle::new([0.0, 0.0], 1.0), &opts).expect("meshing succeeds");
    let m = &out.mesh;
    m.validate(Level::Geometry).expect("valid, every triangle positive (exact)");
    let stats = MetricStats::of(m, &figure_3_6_metric);
    // Thickness of the boundary triangles in the radial direction.
    let mut thick: f64 = 0.0;
    for f in m.face_ids() {
        if m.face_half_edges(f).iter().any(|&h| m.is_boundary_edge(h)) {
            let t = m.face_points(f).iter().map(|p| 1.0 - p.length()).fold(0.0, f64::max);
            thick = thick.max(t);
        }
    }
    println!(
        "| figure 3-6 | nodes | triangles | edges in [0.707, 1.414] | metric length min / mean / max | metric q min / mean | boundary layer thickness | iterations |"
    );
    println!(
        "| anisotropic circle | {} | {} | {:.1}% | {:.2} / {:.3} / {:.2} | {:.3} / {:.3} | {:.4} | {} |",
        m.num_vertices(),
        m.num_faces(),
        100.0 * stats.in_band,
        stats.len_min,
        stats.len_mean,
        stats.len_max,
        stats.q_min,
        stats.q_mean,
        thick,
        out.report.iterations
    );
    println!("{}", out.report);
    println!("{stats}");
    if let Some(dir) = std::env::var_os("TRUSSMESH_TEST_PICTURES") {
        let data = trussmesh::io::MeshData::from_trimesh2(m);
        let path = std::path::Path::new(&dir).join("figure_3_6.png");
        // Coloured by the metric quality, the quality the mesh is made for.
        let by = trussmesh::io::Measure::metric_q(&data, &figure_3_6_metric);
        let png = trussmesh::io::png_bytes_by(&data, "figure 3-6", &by, 1600).expect("picture drawn");
        trussmesh::io::write_file(&path, &png).expect("picture written");
        // A close-up of the boundary layer, stretched across the boundary (polar coordinates:
        // angle along, 20 (1 - r) across) so that its rows can be seen.
        let mut zoom = data.clone();
        for p in &mut zoom.points {
            let (r, a) = ((p[0] * p[0] + p[1] * p[1]).sqrt(), p[1].atan2(p[0]));
            *p = [a, 20.0 * (1.0 - r), 0.0];
        }
        let keep: Vec<usize> = (0..zoom.num_cells())
            .filter(|&c| {
                zoom.cell(c)
                    .iter()
                    .all(|&i| zoom.points[i][0] > 0.2 && zoom.points[i][0] < 1.2 && zoom.points[i][1] < 3.0)
            })
            .collect();
        zoom.cells = keep.iter().flat_map(|&c| data.cell(c).iter().rev().copied().collect::<Vec<_>>()).collect();
        zoom.subdomain = None;
        let path = std::path::Path::new(&dir).join("figure_3_6_layer.png");
        trussmesh::io::picture::write_png(&path, &zoom, "figure 3-6 boundary layer", 1600).expect("picture written");
    }
    assert!((300..=800).contains(&m.num_vertices()), "about 500 nodes, got {}", m.num_vertices());
    assert!(stats.in_band >= 0.95, "{:.1}% of edges in [1/sqrt 2, sqrt 2]", 100.0 * stats.in_band);
    assert!(thick <= 0.015, "boundary triangles {thick} thick radially");
}

#[test]
fn figure_3_6_is_deterministic() {
    let opts = Options2::uniform(HMIN, [-1.0, -1.0], [1.0, 1.0]).with_metric(figure_3_6_metric);
    let a = mesh_2d(&Circle::new([0.0, 0.0], 1.0), &opts).expect("meshing succeeds");
    let b = mesh_2d(&Circle::new([0.0, 0.0], 1.0), &opts).expect("meshing succeeds");
    assert_eq!(a.mesh.to_arrays(), b.mesh.to_arrays());
}

/// An isotropic metric I / h^2 is the size h: the metric mode must then give a mesh of the
/// quality of the isotropic one, with edges of about length h.
#[test]
fn an_isotropic_metric_meshes_like_a_size() {
    let h = |p: DVec2| 0.05 + 0.1 * p.length();
    let opts = Options2::uniform(0.05, [-1.0, -1.0], [1.0, 1.0]).with_metric(move |p| Metric2::isotropic(h(p)));
    let out = mesh_2d(&Circle::new([0.0, 0.0], 1.0), &opts).expect("meshing succeeds");
    out.mesh.validate(Level::Geometry).expect("valid");
    let stats = MetricStats::of(&out.mesh, &move |p| Metric2::isotropic(h(p)));
    println!("isotropic metric: {} nodes; {stats}; {}", out.mesh.num_vertices(), out.report);
    assert!(stats.in_band >= 0.95, "{stats}");
    assert!(out.report.quality.q_mean >= 0.95, "q mean {}", out.report.quality.q_mean);
    assert!(out.report.quality.q_min >= 0.5, "q min {}", out.report.quality.q_min);
}

/// The shock metric of issue 22 on the square [-1, 1]^2: size `hmin + 0.3 |d|` (capped at 0.1)
/// across the curve y = `amp` sin(`freq` pi x), 0.1 along it.
fn shock(hmin: f64, amp: f64, freq: f64) -> impl Fn(DVec2) -> Metric2 + Clone + Send + Sync + 'static {
    move |p: DVec2| {
        let w = freq * std::f64::consts::PI;
        let g = amp * w * (w * p.x).cos();
        let d = (p.y - amp * (w * p.x).sin()).abs() / (1.0 + g * g).sqrt();
        let hn = (hmin + 0.3 * d).min(0.1);
        Metric2::from_sizes(DVec2::new(-g, 1.0), hn, 0.1)
    }
}

/// 4 / sqrt(3) times the integral of sqrt(det M) over the square (midpoint rule, 400^2).
fn estimate(m: &dyn Fn(DVec2) -> Metric2) -> f64 {
    let n = 400;
    let h = 2.0 / n as f64;
    let mut s = 0.0;
    for i in 0..n {
        for j in 0..n {
            let x = m(DVec2::new(-1.0 + (i as f64 + 0.5) * h, -1.0 + (j as f64 + 0.5) * h));
            s += (x.a * x.c - x.b * x.b).sqrt() * h * h;
        }
    }
    4.0 / 3f64.sqrt() * s
}

/// Strong anisotropy does not fold (issue 22): ratios 4:1 to 20:1 and three curve shapes; the
/// mesher's own validation (the embedding) runs on every output, and every edge count,
/// unit-length share and area is checked here.
#[test]
fn shock_metrics_do_not_fold() {
    shock_family(&[(0.005, 0.3, 1.0), (0.01, 0.3, 1.0), (0.025, 0.3, 1.0), (0.005, 0.5, 0.5)]);
}

/// The shorter wave (two periods across the square) folded: density control split boundary
/// edges at the projection checking orientation only, and with a metric the force step's
/// fold check looked at fans only, not at boundary edges laid over each other.
#[test]
fn shock_metric_with_two_periods_does_not_fold() {
    shock_family(&[(0.01, 0.2, 2.0)]);
}

fn shock_family(cases: &[(f64, f64, f64)]) {
    use trussmesh::geometry::Rectangle;
    eprintln!("| hmin | ratio | curve | triangles | estimate | count/estimate | unit edges | area | seconds |");
    for &(hmin, amp, freq) in cases {
        let m = shock(hmin, amp, freq);
        let fixed = vec![[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
        let opts = Options2::uniform(0.1, [-1.0, -1.0], [1.0, 1.0]).with_fixed(fixed).with_metric(m.clone());
        let out = mesh_2d(&Rectangle::new([-1.0, -1.0], [1.0, 1.0]), &opts).expect("no fold: the output validates");
        out.mesh.validate(Level::Geometry).expect("embedded");
        let stats = MetricStats::of(&out.mesh, &m);
        let est = estimate(&m);
        let n = out.mesh.num_faces() as f64;
        let area = area(&out.mesh);
        eprintln!(
            "| {hmin} | {:.0}:1 | {amp} sin({freq} pi x) | {n} | {est:.0} | {:.2} | {:.1}% | {area:.6} | {:.2} |",
            0.1 / hmin,
            n / est,
            100.0 * stats.in_band,
            out.report.seconds
        );
        assert!((area - 4.0).abs() < 1e-9, "area {area}");
        assert!(stats.in_band >= 0.95, "{:.1}% unit edges", 100.0 * stats.in_band);
        assert!(n <= 1.5 * est && n >= est / 1.5, "{n} triangles for an estimate of {est:.0}");
    }
}

/// A metric stretched 1000:1 over the square: the start, refined evenly in every direction,
/// would need some ten times the nodes the metric asks for. A typed error names the stretch
/// and where (it was an internal error, and before that a run past 400 s).
#[test]
fn a_metric_stretched_beyond_the_start_is_a_named_error() {
    use trussmesh::geometry::Rectangle;
    let m = |_: DVec2| Metric2::from_sizes(DVec2::X, 0.001, 1.0);
    let opts = Options2::uniform(0.1, [-1.0, -1.0], [1.0, 1.0]).with_metric(m);
    let t = std::time::Instant::now();
    let err = mesh_2d(&Rectangle::new([-1.0, -1.0], [1.0, 1.0]), &opts).expect_err("too stretched for the start");
    let text = err.to_string();
    println!("{text} ({:.2} s)", t.elapsed().as_secs_f64());
    assert!(matches!(err, trussmesh::Error::BadSize(_)), "{err:?}");
    assert!(text.contains("stretched 1000:1"), "{text}");
}

/// Constant anisotropic metrics on the square [-1, 1]^2, corners not fixed (issue 22): ratios
/// 2:1 to 20:1, turned by a drawn angle, long sizes 0.1 to 0.8 (meshes of about 100 to 6,500
/// triangles; the coarsest starts come out of the carving in several pieces, and the 10:1
/// one ended with crossing boundary edges). Each output must be an embedding: the mesher's
/// own validation, and again here.
#[test]
fn constant_anisotropic_metrics_give_embedded_meshes() {
    constant_metric_family(false);
}

/// [`constant_anisotropic_metrics_give_embedded_meshes`] held to quality: the square covered to
/// 2% and 90% of the edges of unit metric length.
#[test]
#[ignore = "not reached: the square's corners are held now, but coarse stretched metrics (long size 0.64 to 1.0, 10:1 to 19:1) start from a lattice whose cells are about as long as the square is wide; carving keeps only triangles with three vertices inside, the start comes out in pieces, and the gaps between them stay as slits (area 3.875 to 3.991 of 4, 72% to 85% unit edges, 94.7% for 10:1 at 1.0); finer ones reach 90% to 100% with the full area. Splitting boundary-crossing edges of the start, or keeping triangles by their centroid, closed the slits but cost unit edges elsewhere (46% to 89%) and folded a shock metric"]
fn constant_anisotropic_metrics_reach_unit_edges() {
    constant_metric_family(true);
}

fn constant_metric_family(quality: bool) {
    use trussmesh::geometry::Rectangle;
    use trussmesh::testing::Rng;
    let mut rng = Rng::new(trussmesh::testing::SEED ^ 0xa115);
    eprintln!("| ratio | turn (deg) | long size | triangles | unit edges | area | q min (metric) |");
    let mut bad = Vec::new();
    for k in 0..16 {
        let ratio = if k == 0 { 10.0 } else { rng.range(2.0, 20.0) };
        let turn = if k == 0 { 0.0 } else { rng.range(0.0, std::f64::consts::PI) };
        let long = if k == 0 { 1.0 } else { rng.range(0.1, 0.8) };
        let dir = DVec2::new(turn.cos(), turn.sin());
        let m = move |_: DVec2| Metric2::from_sizes(dir, long / ratio, long);
        let opts = Options2::uniform(long / ratio, [-1.0, -1.0], [1.0, 1.0]).with_metric(m);
        let label = format!("{ratio:.1}:1, {:.0} deg, {long:.2}", turn.to_degrees());
        let out = match mesh_2d(&Rectangle::new([-1.0, -1.0], [1.0, 1.0]), &opts) {
            Ok(o) => o,
            Err(e) => {
                eprintln!("| {label} | error: {e} |");
                bad.push(format!("{label}: {e}"));
                continue;
            }
        };
        if let Err(e) = out.mesh.validate(Level::Geometry) {
            bad.push(format!("{label}: not embedded: {e}"));
            continue;
        }
        let stats = MetricStats::of(&out.mesh, &m);
        let area = area(&out.mesh);
        eprintln!(
            "| {ratio:.1}:1 | {:.0} | {long:.2} | {} | {:.1}% | {area:.4} | {:.3} |",
            turn.to_degrees(),
            out.mesh.num_faces(),
            100.0 * stats.in_band,
            stats.q_min
        );
        if area > 4.0 + 1e-9 {
            bad.push(format!("{label}: area {area:.6} above the square's 4"));
        }
        if quality && ((area - 4.0).abs() > 0.08 || stats.in_band < 0.9) {
            bad.push(format!("{label}: area {area:.4}, {:.1}% unit edges", 100.0 * stats.in_band));
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

/// Constant metrics stretched 5:1 to 40:1, turned by a drawn angle, long sizes 0.3 to 1.0 on
/// the square: every run ends in an embedded mesh. Before the start's fixed corners were held
/// clear of the other pieces of a start cut apart by the carving, 10 of 120 such runs (6 of
/// these 24) ended in an internal error, their boundary laid over itself at a corner.
#[test]
fn stretched_metrics_to_40_to_1_give_embedded_meshes() {
    use trussmesh::geometry::Rectangle;
    use trussmesh::testing::Rng;
    let mut rng = Rng::new(trussmesh::testing::SEED ^ 0xbeef);
    eprintln!("| ratio | turn (deg) | long size | triangles | unit edges | area |");
    let mut bad = Vec::new();
    for _ in 0..24 {
        let ratio = rng.range(5.0, 40.0);
        let turn = rng.range(0.0, std::f64::consts::PI);
        let long = rng.range(0.3, 1.0);
        let dir = DVec2::new(turn.cos(), turn.sin());
        let m = move |_: DVec2| Metric2::from_sizes(dir, long / ratio, long);
        let opts = Options2::uniform(long / ratio, [-1.0, -1.0], [1.0, 1.0]).with_metric(m);
        let label = format!("{ratio:.1}:1, {:.0} deg, {long:.2}", turn.to_degrees());
        match mesh_2d(&Rectangle::new([-1.0, -1.0], [1.0, 1.0]), &opts) {
            Ok(out) => {
                if let Err(e) = out.mesh.validate(Level::Geometry) {
                    bad.push(format!("{label}: not embedded: {e}"));
                }
                let stats = MetricStats::of(&out.mesh, &m);
                eprintln!(
                    "| {ratio:.1}:1 | {:.0} | {long:.2} | {} | {:.1}% | {:.4} |",
                    turn.to_degrees(),
                    out.mesh.num_faces(),
                    100.0 * stats.in_band,
                    area(&out.mesh)
                );
            }
            Err(e) => bad.push(format!("{label}: {e}")),
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}
