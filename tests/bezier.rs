//! Rational Bézier patches meshed in space (seed section 3.6.2, figure 3-8): quality against
//! the mesh of the parameter plane, exact rational quadratic surfaces, trims, shared sides, bad
//! input. Run with `cargo test --release --test bezier -- --nocapture` for the table.

use glam::{DVec2, DVec3};
use std::sync::Arc;
use trussmesh::surface::bezier::{mesh_patches, BezierOptions, BezierQuality, PatchesMesh, RationalBezierPatch};
use trussmesh::topology::{Level, TriMesh};

/// A distorted bi-quadratic rational patch in the style of figure 3-8: uneven control points
/// and weights from 0.4 to 3, so equal steps in (u, v) are very unequal in space.
fn distorted() -> RationalBezierPatch {
    let c = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(0.3, 0.0, 0.2),
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.3),
        DVec3::new(0.4, 0.6, 1.0),
        DVec3::new(2.0, 1.2, 0.4),
        DVec3::new(0.0, 2.0, 0.0),
        DVec3::new(0.8, 2.0, 0.3),
        DVec3::new(2.2, 2.4, 0.2),
    ];
    let w = vec![1.0, 3.0, 1.0, 0.5, 2.0, 1.0, 1.0, 0.4, 2.0];
    RationalBezierPatch::new((2, 2), c, w).unwrap()
}

const S: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// A quarter of the unit cylinder x^2 + y^2 = 1, 0 <= z <= 1, the given quarter:
/// the exact rational quadratic quarter circle in u, a straight line (degree 2) in v.
fn quarter_cylinder(quarter: usize) -> RationalBezierPatch {
    // Exact quarter turns, so shared sides have bit-identical control points.
    let rot = |x: f64, y: f64| match quarter % 4 {
        0 => DVec2::new(x, y),
        1 => DVec2::new(-y, x),
        2 => DVec2::new(-x, -y),
        _ => DVec2::new(y, -x),
    };
    let circ = [rot(1.0, 0.0), rot(1.0, 1.0), rot(0.0, 1.0)];
    let cw = [1.0, S, 1.0];
    let (mut c, mut w) = (Vec::new(), Vec::new());
    for z in [0.0, 0.5, 1.0] {
        for i in 0..3 {
            c.push(DVec3::new(circ[i].x, circ[i].y, z));
            w.push(cw[i]);
        }
    }
    RationalBezierPatch::new((2, 2), c, w).unwrap()
}

/// A quarter-by-quarter patch of the torus (sqrt(x^2 + y^2) - 2)^2 + z^2 = 1: the quarter
/// circle profile revolved by a quarter turn, exact as a tensor product of rational quadratics.
fn torus_patch() -> RationalBezierPatch {
    let around = [DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0)];
    let profile = [DVec2::new(3.0, 0.0), DVec2::new(3.0, 1.0), DVec2::new(2.0, 1.0)];
    let cw = [1.0, S, 1.0];
    let (mut c, mut w) = (Vec::new(), Vec::new());
    for j in 0..3 {
        for i in 0..3 {
            let (rho, z) = (profile[j].x, profile[j].y);
            c.push(DVec3::new(rho * around[i].x, rho * around[i].y, z));
            w.push(cw[i] * cw[j]);
        }
    }
    RationalBezierPatch::new((2, 2), c, w).unwrap()
}

fn quality(m: &PatchesMesh, h: f64) -> BezierQuality {
    BezierQuality::measure(&m.points, &m.triangles, h)
}

fn row(name: &str, q: &BezierQuality, extra: &str) {
    println!(
        "| {name:<34} | {:>5} | {:>5} | {:>6.1} | {:>6.3} | {:>6.4} | {:>5.1}% | {:>5.3} | {extra}",
        q.vertices,
        q.triangles,
        q.min_angle,
        q.min_q,
        q.mean_q,
        100.0 * q.size_deviation,
        q.mean_size_ratio
    );
}

fn header() {
    println!("| mesh                               | nodes | tris  | min ang | min q | mean q | size dev | L/h | note");
}

/// Edges used by one triangle (boundary) and by two (interior); none by more.
fn manifold_with_boundary(m: &PatchesMesh) -> (usize, usize) {
    let (_, _) = TriMesh::from_arrays(&m.points, &m.triangles).expect("union is a valid triangle mesh");
    let mut count = std::collections::HashMap::new();
    for t in &m.triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0usize) += 1;
        }
    }
    let b = count.values().filter(|&&c| c == 1).count();
    let i = count.values().filter(|&&c| c == 2).count();
    assert_eq!(b + i, count.len(), "an edge in more than two triangles");
    (b, i)
}

#[test]
fn figure_3_8_space_beats_parameter_plane() {
    let h = 0.12;
    let p = distorted();
    let space = mesh_patches(std::slice::from_ref(&p), &BezierOptions::new(h)).unwrap();
    let mut plane_opts = BezierOptions::new(h);
    plane_opts.in_space = false;
    let plane = mesh_patches(std::slice::from_ref(&p), &plane_opts).unwrap();
    let qs = quality(&space, h);
    let qp = quality(&plane, h);
    header();
    row("fig 3-8 style, in space", &qs, "");
    row("fig 3-8 style, parameter plane", &qp, "same loop in (u, v), mapped");
    // Every node is r(u, v) of its own parameters, and an interior node's (u, v) is a stationary
    // point of |r - p|^2: check the points are the patch's.
    for (i, &q) in space.patches[0].points.iter().enumerate() {
        let uv = space.patches[0].uv[i];
        assert!((p.point(uv) - q).length() <= 1e-12);
    }
    assert!(qs.mean_q > qp.mean_q + 0.05, "space {} vs plane {}", qs.mean_q, qp.mean_q);
    assert!(qs.min_angle > qp.min_angle, "space {} vs plane {}", qs.min_angle, qp.min_angle);
    assert!(qs.size_deviation < qp.size_deviation);
    let (b, _) = manifold_with_boundary(&space);
    assert!(b > 0);
}

#[test]
fn figure_3_8_targets() {
    let h = 0.12;
    let space = mesh_patches(&[distorted()], &BezierOptions::new(h)).unwrap();
    let q = quality(&space, h);
    header();
    row("fig 3-8 style targets", &q, "issue: mean q >= 0.95, min angle >= 25");
    // Nodes on the patch: projecting each node again (damped Newton, eq. 3.29) moves it by
    // less than 1e-10.
    let pm = &space.patches[0];
    let p = distorted();
    let mut worst = 0.0f64;
    for (i, &x) in pm.points.iter().enumerate() {
        let uv = p.project(x, pm.uv[i], None);
        worst = worst.max(p.point(uv).distance(x));
    }
    println!("Newton re-projection residual: {worst:.1e}");
    assert!(worst <= 1e-10, "{worst}");
    assert!(q.mean_q >= 0.95, "mean q {}", q.mean_q);
    assert!(q.min_angle >= 25.0, "min angle {}", q.min_angle);
}

#[test]
fn exact_quadratic_surfaces_all_nodes_on_surface() {
    header();
    let h = 0.1;
    let cyl = mesh_patches(&[quarter_cylinder(0)], &BezierOptions::new(h)).unwrap();
    let worst = cyl.points.iter().map(|p| (DVec2::new(p.x, p.y).length() - 1.0).abs()).fold(0.0, f64::max);
    row("quarter cylinder", &quality(&cyl, h), &format!("max |r - 1| = {worst:.1e}"));
    assert!(worst <= 1e-9, "{worst}");
    let tor = mesh_patches(&[torus_patch()], &BezierOptions::new(h)).unwrap();
    let worst_t = tor
        .points
        .iter()
        .map(|p| {
            let rho = DVec2::new(p.x, p.y).length();
            (((rho - 2.0).powi(2) + p.z * p.z).sqrt() - 1.0).abs()
        })
        .fold(0.0, f64::max);
    row("torus quarter x quarter", &quality(&tor, h), &format!("max dist = {worst_t:.1e}"));
    assert!(worst_t <= 1e-9, "{worst_t}");
    for m in [&cyl, &tor] {
        let q = quality(m, h);
        assert!(q.min_angle >= 30.0 && q.mean_q >= 0.95, "{q:?}");
    }
}

#[test]
fn trimmed_patch_boundary_on_trim_curve() {
    let h = 0.1;
    let trim: Arc<dyn Fn(f64, f64) -> f64 + Send + Sync> =
        Arc::new(|u: f64, v: f64| (u - 0.55).powi(2) + (v - 0.5).powi(2) - 0.35f64.powi(2));
    let p = distorted().with_trim(trim.clone());
    let m = mesh_patches(std::slice::from_ref(&p), &BezierOptions::new(h)).unwrap();
    let q = quality(&m, h);
    header();
    row("fig 3-8 style, trimmed by a circle", &q, "");
    let pm = &m.patches[0];
    let (b, _) = manifold_with_boundary(&m);
    assert!(b > 10);
    // Boundary nodes: on the trim curve to 1e-10 in phi.
    let mut count = std::collections::HashMap::new();
    for t in &pm.triangles {
        for i in 0..3 {
            let (a, c) = (t[i], t[(i + 1) % 3]);
            *count.entry((a.min(c), a.max(c))).or_insert(0usize) += 1;
        }
    }
    let mut worst = 0.0f64;
    for (&(a, c), &n) in &count {
        if n == 1 {
            for i in [a, c] {
                worst = worst.max(trim(pm.uv[i].x, pm.uv[i].y).abs());
            }
        }
    }
    println!("trim residual of boundary nodes: {worst:.1e}");
    assert!(worst <= 1e-10, "{worst}");
    for uv in &pm.uv {
        assert!(trim(uv.x, uv.y) <= 1e-10);
    }
    assert!(q.min_angle >= 20.0 && q.mean_q >= 0.9, "{q:?}");
}

#[test]
fn two_patches_share_a_side_conformingly() {
    let h = 0.1;
    header();
    // Side u = 1 of the first quarter is side u = 0 of the second.
    let pair = [quarter_cylinder(0), quarter_cylinder(1)];
    let m = mesh_patches(&pair, &BezierOptions::new(h)).unwrap();
    let q = quality(&m, h);
    row("two quarter cylinders, shared side", &q, "");
    let side = |k: usize, u: f64| -> Vec<[f64; 3]> {
        let pm = &m.patches[k];
        let mut v: Vec<[f64; 3]> =
            (0..pm.uv.len()).filter(|&i| pm.uv[i].x == u).map(|i| pm.points[i].to_array()).collect();
        v.sort_by(|a, b| a[2].total_cmp(&b[2]));
        v
    };
    let (a, b) = (side(0, 1.0), side(1, 0.0));
    assert!(a.len() >= 10);
    assert_eq!(a, b, "shared side vertex lists differ");
    let (bnd, _) = manifold_with_boundary(&m);
    let (tm, _) = TriMesh::from_arrays(&m.points, &m.triangles).unwrap();
    tm.validate(Level::Topology).unwrap();
    assert_eq!(tm.boundary_loops().len(), 1, "the union is one disc");
    assert_eq!(tm.euler_characteristic(), 1);
    assert_eq!(m.points.len(), m.patches[0].points.len() + m.patches[1].points.len() - a.len());
    assert!(bnd > 0);
    assert!(q.min_angle >= 30.0, "{q:?}");

    // Reversed direction: the second patch's shared side runs the other way.
    let mut flipped = quarter_cylinder(1);
    let c = flipped.control.clone();
    let w = flipped.weights.clone();
    for j in 0..3 {
        for i in 0..3 {
            flipped.control[i + 3 * j] = c[i + 3 * (2 - j)];
            flipped.weights[i + 3 * j] = w[i + 3 * (2 - j)];
        }
    }
    let m2 = mesh_patches(&[quarter_cylinder(0), flipped], &BezierOptions::new(h)).unwrap();
    let (tm2, _) = TriMesh::from_arrays(&m2.points, &m2.triangles).unwrap();
    assert_eq!(tm2.boundary_loops().len(), 1);
    row("same, second patch reversed in v", &quality(&m2, h), "");
}

#[test]
fn bad_input_is_a_typed_error() {
    let c = vec![DVec3::ZERO; 9];
    assert!(RationalBezierPatch::new((2, 2), c[..8].to_vec(), vec![1.0; 9]).is_err());
    assert!(RationalBezierPatch::new((2, 2), c.clone(), vec![1.0; 8]).is_err());
    let mut w = vec![1.0; 9];
    w[4] = -1.0;
    assert!(RationalBezierPatch::new((2, 2), c.clone(), w.clone()).is_err());
    w[4] = 0.0;
    assert!(RationalBezierPatch::new((2, 2), c.clone(), w.clone()).is_err());
    w[4] = f64::NAN;
    assert!(RationalBezierPatch::new((2, 2), c.clone(), w).is_err());
    let mut bad = c.clone();
    bad[3].y = f64::INFINITY;
    assert!(RationalBezierPatch::new((2, 2), bad, vec![1.0; 9]).is_err());
    assert!(RationalBezierPatch::new((0, 2), vec![DVec3::ZERO; 3], vec![1.0; 3]).is_err());
    let p = distorted();
    for h in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(mesh_patches(std::slice::from_ref(&p), &BezierOptions::new(h)).is_err());
    }
    assert!(mesh_patches(&[], &BezierOptions::new(0.1)).is_err());
    assert!(matches!(
        mesh_patches(std::slice::from_ref(&p), &BezierOptions::new(1e-5)),
        Err(trussmesh::Error::TooManyElements { .. })
    ));
    assert!(matches!(
        mesh_patches(std::slice::from_ref(&p), &BezierOptions::new(1e-300)),
        Err(trussmesh::Error::TooManyElements { .. })
    ));
    // A trim that removes everything.
    let gone = p.with_trim(Arc::new(|_, _| 1.0));
    assert!(mesh_patches(&[gone], &BezierOptions::new(0.1)).is_err());
}

#[test]
fn derivatives_match_differences() {
    let p = distorted();
    let e = 1e-6;
    for &(u, v) in &[(0.3, 0.7), (0.0, 0.0), (0.9, 0.2)] {
        let a = p.eval(u, v);
        let du = (p.eval(u + e, v).r - p.eval(u - e, v).r) / (2.0 * e);
        let dv = (p.eval(u, v + e).r - p.eval(u, v - e).r) / (2.0 * e);
        let duu = (p.eval(u + e, v).ru - p.eval(u - e, v).ru) / (2.0 * e);
        let duv = (p.eval(u, v + e).ru - p.eval(u, v - e).ru) / (2.0 * e);
        let dvv = (p.eval(u, v + e).rv - p.eval(u, v - e).rv) / (2.0 * e);
        for (x, y) in [(a.ru, du), (a.rv, dv), (a.ruu, duu), (a.ruv, duv), (a.rvv, dvv)] {
            assert!((x - y).length() <= 1e-5 * (1.0 + x.length()), "{x} vs {y}");
        }
    }
    // Projection: a point off the patch along the normal comes back to its own (u, v).
    let at = p.eval(0.4, 0.6);
    let n = at.ru.cross(at.rv).normalize();
    let uv = p.project(at.r + 0.01 * n, DVec2::new(0.45, 0.55), None);
    assert!((uv - DVec2::new(0.4, 0.6)).length() <= 1e-9, "{uv}");
}

#[test]
fn cli_bezier_patches_file() {
    let dir = std::env::temp_dir().join(format!("trussmesh-bezier-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let json = dir.join("patch.json");
    std::fs::write(
        &json,
        r#"{"patches": [{"degree": [2, 2],
  "control": [[0,0,0],[0.3,0,0.2],[2,0,0],[0,1,0.3],[0.4,0.6,1.0],[2,1.2,0.4],[0,2,0],[0.8,2,0.3],[2.2,2.4,0.2]],
  "weights": [1,3,1,0.5,2,1,1,0.4,2], "trim": "(u-0.55)^2 + (v-0.5)^2 - 0.35^2"}]}"#,
    )
    .unwrap();
    let obj = dir.join("patch.obj");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_trussmesh"))
        .args(["surface", "--bezier"])
        .arg(&json)
        .args(["--h0", "0.1", "-o"])
        .arg(&obj)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout} {}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("min angle"), "{stdout}");
    let text = std::fs::read_to_string(&obj).unwrap();
    assert!(text.lines().filter(|l| l.starts_with("f ")).count() > 100);
    // Bad files: a wrong count, x in the trim, garbage.
    for bad in [
        r#"{"patches": [{"degree": [2, 2], "control": [[0,0,0]], "weights": [1]}]}"#,
        r#"{"patches": [{"degree": [1, 1], "control": [[0,0,0],[1,0,0],[0,1,0],[1,1,0]], "weights": [1,1,1,1], "trim": "x - 0.5"}]}"#,
        "not json",
    ] {
        std::fs::write(&json, bad).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_trussmesh"))
            .args(["surface", "--bezier"])
            .arg(&json)
            .args(["--h0", "0.1"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{bad}: {}", String::from_utf8_lossy(&out.stderr));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
