//! A planar domain from closed polylines (`Polygons2`): exact distance and sign against brute
//! force, meshes of drawn outlines with their corners held, the readers, and the command line
//! (`trussmesh mesh --domain FILE`), bad inputs refused with exit code 2 and nothing written.

use glam::DVec2;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::Command;
use trussmesh::geometry::polygons::read::loops_from_bytes;
use trussmesh::geometry::{Implicit2, Polygons2};
use trussmesh::mesher::{area, boundary_deviation, mesh_2d};
use trussmesh::testing::Rng;
use trussmesh::topology::{Level, VertexTag};
use trussmesh::Error;

fn poly(loops: &[Vec<[f64; 2]>]) -> Polygons2 {
    Polygons2::new(loops.to_vec()).expect("valid polylines")
}

fn l_shape() -> Vec<[f64; 2]> {
    vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]
}

fn square(c: [f64; 2], r: f64, ccw: bool) -> Vec<[f64; 2]> {
    let mut s = vec![[c[0] - r, c[1] - r], [c[0] + r, c[1] - r], [c[0] + r, c[1] + r], [c[0] - r, c[1] + r]];
    if !ccw {
        s.reverse();
    }
    s
}

fn star(points: usize, r_out: f64, r_in: f64) -> Vec<[f64; 2]> {
    (0..2 * points)
        .map(|k| {
            let a = PI * k as f64 / points as f64 + PI / 2.0;
            let r = if k % 2 == 0 { r_out } else { r_in };
            [r * a.cos(), r * a.sin()]
        })
        .collect()
}

fn circle(n: usize, r: f64) -> Vec<[f64; 2]> {
    (0..n).map(|k| 2.0 * PI * k as f64 / n as f64).map(|a| [r * a.cos(), r * a.sin()]).collect()
}

/// A star-shaped polygon about the origin: n points at jittered angles, radii in [0.55, 1].
fn random_star(seed: u64) -> Vec<[f64; 2]> {
    let mut r = Rng::new(seed);
    let n = 5 + (r.next_u64() % 8) as usize;
    (0..n)
        .map(|k| {
            let a = 2.0 * PI * (k as f64 + r.range(-0.3, 0.3)) / n as f64;
            let rad = r.range(0.55, 1.0);
            [rad * a.cos(), rad * a.sin()]
        })
        .collect()
}

/// The smallest interior angle (degrees) at a corner of the domain.
fn min_corner_angle(g: &Polygons2) -> f64 {
    let mut m: f64 = 180.0;
    for (l, c) in g.loops().iter().enumerate() {
        let n = c.len();
        for k in 0..n {
            let (u, v, w) = (c[(k + n - 1) % n], c[k], c[(k + 1) % n]);
            // The angle inside the domain at v: between v->u and v->w, on the domain's side.
            let a = (u - v).angle_to(w - v).to_degrees();
            let probe = v + 1e-9 * ((u - v).normalize() + (w - v).normalize());
            let inner = if g.contains(probe) { a.abs() } else { 360.0 - a.abs() };
            let _ = l;
            m = m.min(inner);
        }
    }
    m
}

struct Row {
    name: String,
    segments: usize,
    corners: usize,
    nodes: usize,
    q_min: f64,
    q_mean: f64,
    bdev: f64,
    h0: f64,
    corner_err: f64,
    /// Corners whose node is not on the mesh's boundary (the mesh closed over them).
    buried: usize,
    area_err: f64,
    min_angle: f64,
}

const HEADER: &str =
    "| domain | segments | corners | nodes | q min | q mean | max |d|/h0 | corner err | corners inside | area err | min corner angle |";

fn print(r: &Row) {
    println!(
        "| {} | {} | {} | {} | {:.3} | {:.4} | {:.1e} | {:.1e} | {} | {:.3}% | {:.1} |",
        r.name,
        r.segments,
        r.corners,
        r.nodes,
        r.q_min,
        r.q_mean,
        r.bdev,
        r.corner_err,
        r.buried,
        100.0 * r.area_err,
        r.min_angle
    );
}

fn mesh_row(name: &str, g: &Polygons2, h0: f64) -> Row {
    try_mesh_row(name, g, h0).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn try_mesh_row(name: &str, g: &Polygons2, h0: f64) -> Result<Row, Error> {
    let corners = g.corners(trussmesh::geometry::polygons::DEFAULT_FEATURE_ANGLE);
    let out = mesh_2d(g, &g.options(h0, None, Some(trussmesh::geometry::polygons::DEFAULT_FEATURE_ANGLE)))?;
    let m = &out.mesh;
    m.validate(Level::Geometry).unwrap_or_else(|e| panic!("{name}: invalid mesh: {e}"));
    let fixed: Vec<DVec2> = m.vertices().filter(|(_, v)| v.tag == VertexTag::Fixed).map(|(_, v)| v.pos).collect();
    let buried = m
        .vertices()
        .filter(|(v, x)| x.tag == VertexTag::Fixed && corners.contains(&x.pos) && !m.is_boundary_vertex(*v))
        .count();
    let corner_err =
        corners.iter().map(|c| fixed.iter().map(|f| f.distance(*c)).fold(f64::INFINITY, f64::min)).fold(0.0, f64::max);
    Ok(Row {
        name: name.into(),
        segments: g.num_segments(),
        corners: corners.len(),
        nodes: m.num_vertices(),
        q_min: out.report.quality.q_min,
        q_mean: out.report.quality.q_mean,
        bdev: boundary_deviation(m, g) / h0,
        h0,
        corner_err,
        buried,
        area_err: (area(m) - g.area()).abs() / g.area(),
        min_angle: min_corner_angle(g),
    })
}

/// The quality rule: q min >= 0.7 where every corner of the domain is at least 60 degrees
/// inside (a sharper corner forces a triangle with that angle: q min then >= 0.8 times the q
/// of the isosceles triangle with the corner's angle at its apex); q mean >= 0.97 always.
fn q_floor(min_angle_deg: f64) -> f64 {
    if min_angle_deg >= 60.0 {
        return 0.7;
    }
    let a = min_angle_deg.to_radians();
    // Isosceles, apex a, legs 1: base 2 sin(a/2).
    let q = trussmesh::quality::triangle_q_from_lengths(1.0, 1.0, 2.0 * (a / 2.0).sin());
    0.8 * q
}

/// Meshes and prints one row and says whether it passes every check (a mesher error fails).
fn row_passes(name: &str, g: &Polygons2, h0: f64) -> bool {
    match try_mesh_row(name, g, h0) {
        Ok(r) => {
            print(&r);
            std::panic::catch_unwind(|| check_row(&r, true)).is_ok()
        }
        Err(e) => {
            println!("| {name} | mesher error: {e} |");
            false
        }
    }
}

fn check_row(r: &Row, q_min: bool) {
    assert!(r.corner_err <= 1e-12, "{}: a corner {:.1e} from a fixed node", r.name, r.corner_err);
    assert_eq!(r.buried, 0, "{}: corners inside the mesh, not on its boundary", r.name);
    // The mesher projects boundary nodes to within 1e-9 h0 (compared as it does, in length).
    assert!(
        r.bdev * r.h0 <= 1e-9 * r.h0 * (1.0 + 1e-12),
        "{}: boundary nodes {:.1e} h0 off the polylines",
        r.name,
        r.bdev
    );
    assert!(r.area_err <= 0.01, "{}: area off by {:.3}%", r.name, 100.0 * r.area_err);
    let floor = q_floor(r.min_angle);
    assert!(!q_min || r.q_min >= floor, "{}: q min {:.3} below {floor:.3}", r.name, r.q_min);
    assert!(r.q_mean >= 0.97, "{}: q mean {:.4} below 0.97", r.name, r.q_mean);
}

#[test]
fn distance_matches_brute_force() {
    // A wavy outline of 4,000 segments with 30 square holes.
    let n = 4000;
    let outer: Vec<[f64; 2]> = (0..n)
        .map(|k| {
            let a = 2.0 * PI * k as f64 / n as f64;
            let r = 3.0 + 0.3 * (7.0 * a).sin() + 0.1 * (31.0 * a).cos();
            [r * a.cos(), r * a.sin()]
        })
        .collect();
    let mut loops = vec![outer];
    for i in 0..6 {
        for j in 0..5 {
            loops.push(square([-1.5 + 0.6 * i as f64, -1.2 + 0.6 * j as f64], 0.2, (i + j) % 2 == 0));
        }
    }
    let g = poly(&loops);
    let mut rng = Rng::new(trussmesh::testing::SEED);
    let (mut worst, mut grad_worst, mut proj_worst) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..10_000 {
        let p = DVec2::new(rng.range(-4.0, 4.0), rng.range(-4.0, 4.0));
        let (fast, slow) = (g.nearest(p), g.nearest_brute_force(p));
        worst = worst.max((fast.dist2.sqrt() - slow.dist2.sqrt()).abs());
        let (d, grad) = g.distance_and_gradient(p);
        grad_worst = grad_worst.max((grad.length() - 1.0).abs());
        // One step of p - d grad d lands on the nearest point.
        proj_worst = proj_worst.max((p - d * grad).distance(slow.point));
        assert_eq!(d.abs(), fast.dist2.sqrt());
    }
    println!("| query points | segments | max |d - d_brute| | max ||grad d| - 1| | max |p - d grad - c| |");
    println!("| 10000 | {} | {worst:.1e} | {grad_worst:.1e} | {proj_worst:.1e} |", g.num_segments());
    assert!(worst <= 1e-12, "distance off brute force by {worst:.1e}");
    assert!(grad_worst <= 1e-12 && proj_worst <= 1e-12);
    assert!(g.is_distance());
}

#[test]
fn sign_right_at_random_points() {
    // The square with two holes, whose inside is known in closed form.
    let g = poly(&[square([0.0, 0.0], 1.0, true), square([-0.5, 0.0], 0.3, true), square([0.5, 0.2], 0.25, false)]);
    let inside = |p: DVec2| {
        let in_sq = |c: DVec2, r: f64| (p - c).abs().max_element() < r;
        in_sq(DVec2::ZERO, 1.0) && !in_sq(DVec2::new(-0.5, 0.0), 0.3) && !in_sq(DVec2::new(0.5, 0.2), 0.25)
    };
    let star_g = poly(&[star(7, 1.0, 0.4), circle(300, 0.2)]);
    let mut rng = Rng::new(trussmesh::testing::SEED ^ 1);
    let (mut wrong, mut wrong_star) = (0, 0);
    let n = 100_000;
    for _ in 0..n {
        let p = DVec2::new(rng.range(-1.5, 1.5), rng.range(-1.5, 1.5));
        if (g.value(p) < 0.0) != inside(p) {
            wrong += 1;
        }
        if (star_g.value(p) < 0.0) != star_g.contains_brute_force(p) {
            wrong_star += 1;
        }
    }
    println!("| domain | points | wrong signs |");
    println!("| square with two holes (closed form) | {n} | {wrong} |");
    println!("| 7-star with a round hole (brute force) | {n} | {wrong_star} |");
    assert_eq!((wrong, wrong_star), (0, 0));
    assert!(g.is_hole(1) && g.is_hole(2) && !g.is_hole(0));
    assert!((g.area() - (4.0 - 0.36 - 0.25)).abs() < 1e-12);
}

#[test]
fn drawn_domains_keep_their_corners() {
    println!("{HEADER}");
    let cases: Vec<(&str, Polygons2, f64)> = vec![
        ("L-shape", poly(&[l_shape()]), 0.1),
        (
            "square with two holes",
            poly(&[square([0.0, 0.0], 1.0, true), square([-0.5, 0.0], 0.3, true), square([0.5, 0.2], 0.25, false)]),
            0.08,
        ),
        ("5-star", poly(&[star(5, 1.0, 0.5)]), 0.06),
        ("circle, 256 segments", poly(&[circle(256, 1.0)]), 0.1),
    ];
    for (name, g, h0) in &cases {
        let r = mesh_row(name, g, *h0);
        print(&r);
        check_row(&r, true);
    }
    // The finely sampled circle has no corner and meshes as the implicit disk does.
    assert_eq!(cases[3].1.corners(40.0).len(), 0);
    let disk = mesh_2d(
        &trussmesh::geometry::Circle::new([0.0, 0.0], 1.0),
        &trussmesh::Options2::uniform(0.1, [-1.1, -1.1], [1.1, 1.1]),
    )
    .unwrap();
    let r = mesh_row("circle", &cases[3].1, 0.1);
    println!(
        "implicit disk at h0 0.1: q min {:.3}, q mean {:.4}",
        disk.report.quality.q_min, disk.report.quality.q_mean
    );
    assert!(r.q_mean >= disk.report.quality.q_mean - 0.005 && r.q_min >= 0.7);
}

/// Twenty random star-shaped polygons (seeds fixed): every check on each, and the table.
/// Seed 15 had a flat triangle at a fixed corner (a corner and two boundary nodes on one
/// straight side, q 0) and seed 18 an invalid finished mesh; both pass since the force step
/// keeps triangles from turning flat and flat boundary ears are peeled.
#[test]
fn random_star_shaped_family() {
    println!("{HEADER}");
    for seed in 0..20u64 {
        let g = poly(&[random_star(1000 + seed)]);
        let r = mesh_row(&format!("random star {seed}"), &g, 0.05);
        print(&r);
        check_row(&r, true);
    }
}

/// The carving keeps no triangle over a hole's corner next to a held corner: the square with
/// two holes as a formula, its corners found from d, has the exact area at h0 0.1 (it had
/// 3.3985 for 3.39, a triangle closed over a corner of the first hole).
#[test]
fn formula_holes_keep_their_corners() {
    use trussmesh::geometry::{difference, Rectangle};
    let d = difference(
        difference(Rectangle::new([-1.0, -1.0], [1.0, 1.0]), Rectangle::new([-0.8, -0.3], [-0.2, 0.3])),
        Rectangle::new([0.25, -0.05], [0.75, 0.45]),
    );
    let out = mesh_2d(&d, &trussmesh::Options2::uniform(0.1, [-1.1, -1.1], [1.1, 1.1])).unwrap();
    out.mesh.validate(Level::Geometry).unwrap();
    let a = area(&out.mesh);
    println!("square with two holes (formula), h0 0.1: area {a:.15}, {} corners held", out.report.feature_points);
    assert_eq!(out.report.feature_points, 12);
    assert!((a - 3.39).abs() < 1e-9, "area {a}");
}

/// The square with two holes over a range of h0, every check on each. At h0 0.06 one held
/// corner of a hole ended inside the mesh (area 0.042% over): a start triangle spanning the
/// hole's wedge at the corner had its centroid inside; carving now opens any closed fan of a
/// fixed vertex over the outside directions found around it. h0 0.09, which had a flat
/// triangle along a side at a fixed corner (q 0), passes since the force step keeps
/// triangles from turning flat.
#[test]
fn square_with_two_holes_at_many_sizes() {
    let g = poly(&[square([0.0, 0.0], 1.0, true), square([-0.5, 0.0], 0.3, true), square([0.5, 0.2], 0.25, false)]);
    println!("{HEADER}");
    let mut failed = Vec::new();
    for h0 in [0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.1] {
        if !row_passes(&format!("two holes, h0 {h0}"), &g, h0) {
            failed.push(h0);
        }
    }
    assert!(failed.is_empty(), "failed at h0 {failed:?}");
}

/// A rectangle of half-sides (a, b) about c, turned by `turn` radians.
fn rotated_rect(c: [f64; 2], a: f64, b: f64, turn: f64, ccw: bool) -> Vec<[f64; 2]> {
    let (s, co) = turn.sin_cos();
    let mut r: Vec<[f64; 2]> = [[-a, -b], [a, -b], [a, b], [-a, b]]
        .iter()
        .map(|p| [c[0] + co * p[0] - s * p[1], c[1] + s * p[0] + co * p[1]])
        .collect();
    if !ccw {
        r.reverse();
    }
    r
}

/// Random plates with holes: the square [-1, 1]^2 with two or three turned rectangular holes
/// (sizes, places, turns and orientations drawn; holes kept apart), each at a drawn h0 in
/// [0.04, 0.1]. Every check on each: no held corner of a hole may end inside the mesh.
#[test]
fn random_plates_with_holes() {
    println!("{HEADER}");
    let mut rng = Rng::new(trussmesh::testing::SEED ^ 0x401e);
    let mut failed = Vec::new();
    for k in 0..12 {
        let n_holes = 2 + (rng.next_u64() % 2) as usize;
        let mut loops = vec![square([0.0, 0.0], 1.0, true)];
        let mut placed: Vec<([f64; 2], f64)> = Vec::new();
        while placed.len() < n_holes {
            let (a, b) = (rng.range(0.1, 0.3), rng.range(0.1, 0.3));
            let reach = (a * a + b * b).sqrt();
            let c = [rng.range(-0.95 + reach, 0.95 - reach), rng.range(-0.95 + reach, 0.95 - reach)];
            if placed.iter().any(|(q, r)| ((q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2)).sqrt() < r + reach + 0.1) {
                continue;
            }
            let turn = rng.range(0.0, std::f64::consts::FRAC_PI_2);
            loops.push(rotated_rect(c, a, b, turn, rng.next_u64() % 2 == 0));
            placed.push((c, reach));
        }
        let g = poly(&loops);
        let h0 = (rng.range(0.04, 0.1) * 1000.0).round() / 1000.0;
        let name = format!("plate {k}, {n_holes} holes, h0 {h0}");
        if !row_passes(&name, &g, h0) {
            failed.push(name);
        }
    }
    assert!(failed.is_empty(), "failed: {failed:?}");
}

// ------------------------------------------------------------------------------------------
// Readers.

#[test]
fn readers_give_the_same_loops() {
    let text =
        "# the L, then a square hole\n0 0\n2 0\n2 1\n1 1\n1 2\n0 2\n0 0\n\n0.2, 0.2\n0.6, 0.2\n0.6, 0.6\n0.2, 0.6\n";
    let t = Polygons2::new(loops_from_bytes(text.as_bytes(), "txt", "l.txt").unwrap()).unwrap();
    // One loop as one l record, the hole as three records joined at shared points, numbered back.
    let obj = "v 0 0\nv 2 0\nv 2 1\nv 1 1\nv 1 2\nv 0 2 0\nl 1 2 3 4 5 6 1\nv 0.2 0.2\nv 0.6 0.2\nv 0.6 0.6\nv 0.2 0.6\nl -4 -3\nl -3 -2 -1\nl 10 7\n";
    let o = Polygons2::new(loops_from_bytes(obj.as_bytes(), "obj", "l.obj").unwrap()).unwrap();
    for g in [&t, &o] {
        assert_eq!(g.loops().len(), 2);
        assert_eq!(g.num_segments(), 10);
        assert!((g.area() - (3.0 - 0.16)).abs() < 1e-12, "area {}", g.area());
        assert!(g.is_hole(1));
        assert_eq!(g.corners(40.0).len(), 10);
    }
    let mut rng = Rng::new(7);
    for _ in 0..1000 {
        let p = DVec2::new(rng.range(-0.5, 2.5), rng.range(-0.5, 2.5));
        assert_eq!(t.value(p), o.value(p));
    }
}

// ------------------------------------------------------------------------------------------
// The command line.

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("polygon_domain").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_trussmesh")).args(args).current_dir(dir).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Mesh a drawn outline, write it as .msh and .vtu, read each one's boundary back as a domain:
/// the same loops (same area, same corners), meshed again.
#[test]
fn round_trip_through_mesh_files() {
    let d = tmp("round_trip");
    std::fs::write(d.join("l.txt"), "0 0\n2 0\n2 1\n1 1\n1 2\n0 2\n").unwrap();
    let (code, out, err) = run(&d, &["mesh", "--domain", "l.txt", "--h0", "0.1", "-o", "l.msh", "-o", "l.vtu"]);
    assert_eq!(code, 0, "{err}");
    println!("{out}");
    let first = Polygons2::read(&d.join("l.txt")).unwrap();
    println!("| file | loops | segments | area | corners |");
    for f in ["l.msh", "l.vtu"] {
        let g = Polygons2::read(&d.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        let c = g.corners(40.0);
        println!("| {f} | {} | {} | {:.12} | {} |", g.loops().len(), g.num_segments(), g.area(), c.len());
        assert_eq!(g.loops().len(), 1);
        assert!((g.area() - first.area()).abs() < 1e-9, "{f}: area {}", g.area());
        assert_eq!(c.len(), 6);
        for k in first.corners(40.0) {
            assert!(c.iter().any(|q| q.distance(k) <= 1e-12), "{f}: corner {k:?} kept");
        }
        // Meshed again, without --dim: the content says planar.
        let again = format!("again-{f}.vtu");
        let (code, _, err) = run(&d, &["mesh", "--domain", f, "--h0", "0.1", "-q", "-o", &again]);
        assert_eq!(code, 0, "{f}: {err}");
        assert!(d.join(&again).exists());
    }
}

#[test]
fn command_line_options_apply() {
    let d = tmp("options");
    std::fs::write(d.join("sq.obj"), "v 0 0\nv 2 0\nv 2 2\nv 0 2\nv 0.5 0.5\nv 1 0.5\nv 1 1\nl 1 2 3 4 1\nl 5 6 7 5\n")
        .unwrap();
    for args in [
        vec!["--size", "1+x"],
        vec!["--size", "auto"],
        vec!["--fix", "1.5,1.5"],
        vec!["--feature-angle", "100"],
        vec!["--no-sharp"],
        vec!["--bbox", "-0.5,-0.5,2.5,2.5"],
    ] {
        let mut a = vec!["mesh", "--domain", "sq.obj", "--h0", "0.1", "-o", "out.vtu"];
        a.extend(&args);
        let (code, out, err) = run(&d, &a);
        assert_eq!(code, 0, "{args:?}: {err}");
        println!("{args:?}:\n{out}");
        let m = trussmesh::io::read_mesh(&d.join("out.vtu")).unwrap();
        assert!(m.num_cells() > 100, "{args:?}");
        if args == ["--fix", "1.5,1.5"] {
            assert!(m.points.iter().any(|p| p[0] == 1.5 && p[1] == 1.5), "the fixed point is a node");
        }
    }
}

/// Bad inputs: each refused with exit 2, a message naming the problem and where, nothing written.
#[test]
fn bad_polylines_are_refused() {
    let d = tmp("bad");
    let cases: [(&str, &str, &str); 9] = [
        (
            "open.obj",
            "v 0 0\nv 1 0\nv 1 1\nl 1 2 3\n",
            "open polyline: the polyline of the l record on line 4 ends at (0, 0)",
        ),
        (
            "bow.txt",
            "0 0\n1 1\n1 0\n0 1\n",
            "segment 0 of loop 0 and segment 2 of loop 0 cross (a self-intersecting loop) near (0.5, 0.5)",
        ),
        (
            "cross.txt",
            "0 0\n2 0\n2 2\n0 2\n\n1 1\n3 1\n3 3\n1 3\n",
            "segment 1 of loop 0 and segment 0 of loop 1 cross (loops cross) near (2, 1)",
        ),
        ("touch.txt", "0 0\n2 0\n2 2\n0 2\n\n2 1\n3 0\n3 2\n", "cross (loops cross) near (2, 1)"),
        ("spike.txt", "0 0\n2 0\n2 2\n2 3\n2 2.5\n0 2\n", "self-intersecting"),
        ("two.txt", "0 0\n1 0\n", "loop 0 has 2 distinct point(s), starting at (0, 0)"),
        ("empty.txt", "\n  \n", "the file is empty"),
        ("nan.txt", "0 0\nnan 0\n1 1\n", "point 1 of loop 0 has a non-finite coordinate (NaN, 0)"),
        ("branch.obj", "v 0 0\nv 1 0\nv 1 1\nv 0 1\nl 1 2 3 1\nl 1 4 3\n", "3 segments meet at the point (0, 0)"),
    ];
    println!("| input | exit | message |");
    for (name, body, want) in cases {
        std::fs::write(d.join(name), body).unwrap();
        let (code, _, err) = run(&d, &["mesh", "--domain", name, "--h0", "0.1", "-o", "out.vtu"]);
        println!("| {name} | {code} | {} |", err.trim());
        assert_eq!(code, 2, "{name}: {err}");
        assert!(err.contains(want), "{name}: {err:?} should say {want:?}");
        assert!(err.contains(name), "{name}: the message names the file");
        assert!(!d.join("out.vtu").exists(), "{name}: nothing written");
    }
}
