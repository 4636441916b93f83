//! `trussmesh surface`: files written and readable, a shaded picture, and every bad input exits 2
//! with a message.

use std::path::{Path, PathBuf};
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli_surface").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs the binary in `dir`: (exit code, stdout, stderr).
fn run(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_trussmesh")).args(args).current_dir(dir).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

const SPHERE: &str = "sqrt(x^2+y^2+z^2)-1";
const BOX: &str = "-1.2,-1.2,-1.2,1.2,1.2,1.2";

#[test]
fn sphere_to_every_format() {
    let d = tmp("formats");
    let files = ["s.obj", "s.stl", "s.ply", "s.vtu", "s.json", "s.png", "s.svg"];
    let mut args = vec!["surface", "--phi", SPHERE, "--bbox", BOX, "--h0", "0.25"];
    for f in &files {
        args.extend(["-o", f]);
    }
    let (code, out, err) = run(&d, &args);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("Euler characteristic 2 (closed manifold, 0 inward faces)"), "{out}");
    for f in &files[..5] {
        let m = trussmesh::io::read_mesh(&d.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(m.dim, 3, "{f}");
        let nv = m.points.len() as i64;
        let nf = m.num_cells() as i64;
        // A closed triangulated sphere: E = 3F/2 and V - E + F = 2.
        assert_eq!(nv - 3 * nf / 2 + nf, 2, "{f}: {nv} points, {nf} triangles");
        for p in &m.points {
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            assert!((r - 1.0).abs() < 1e-6, "{f}: point at radius {r}");
        }
    }
    let png = std::fs::read(d.join("s.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    assert!(std::fs::read_to_string(d.join("s.svg")).unwrap().contains("<polygon"));
}

#[test]
fn curvature_sizes_from_the_command_line() {
    let d = tmp("curvature");
    let torus = "sqrt((sqrt(x^2+y^2)-1)^2+z^2)-0.3";
    let (code, out, err) = run(
        &d,
        &[
            "surface",
            "--phi",
            torus,
            "--bbox",
            "-1.5,-1.5,-0.5,1.5,1.5,0.5",
            "--h0",
            "0.08",
            "--curvature",
            "3",
            "--hmax",
            "0.2",
            "-o",
            "t.obj",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("Euler characteristic 0 (closed manifold, 0 inward faces)"), "{out}");
}

#[test]
fn bad_input_exits_2() {
    let d = tmp("bad");
    let cases: [(&[&str], &str); 7] = [
        (&["--phi", "sqrt(x^2+y^2+z^2)+1", "--bbox", BOX, "--h0", "0.2"], "empty domain"),
        (&["--phi", "sqrt(x^2+y^2+z^2-1)", "--bbox", BOX, "--h0", "0.2"], "non-finite"),
        (&["--phi", SPHERE, "--bbox", BOX, "--h0", "0"], "h0 = 0 must be positive"),
        (&["--phi", SPHERE, "--bbox", BOX, "--h0", "-0.1"], "must be positive"),
        (
            &["--phi", SPHERE, "--bbox", "-0.5,-0.5,-0.5,0.5,0.5,0.5", "--h0", "0.1"],
            "not closed inside the bounding box",
        ),
        (&["--phi", SPHERE, "--bbox", "-1,-1,1,1,1", "--h0", "0.1"], "needs 6 numbers"),
        (&["--phi", "sqrt(x^2+", "--bbox", BOX, "--h0", "0.1"], "bad phi expression"),
    ];
    for (args, msg) in cases {
        let mut a = vec!["surface"];
        a.extend_from_slice(args);
        a.extend(["-o", "x.obj"]);
        let (code, _, err) = run(&d, &a);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(msg), "{args:?}: expected {msg:?} in {err}");
    }
    let (code, _, err) = run(&d, &["surface", "--phi", SPHERE, "--bbox", BOX, "--h0", "0.1", "-o", "x.xyz"]);
    assert_eq!(code, 2);
    assert!(err.contains("unknown output extension"), "{err}");
}

/// `stats` of a closed surface: its topology and the distance of every vertex to phi = 0, not
/// a boundary fidelity (there is no boundary).
#[test]
fn stats_of_closed_surfaces() {
    let d = tmp("stats");
    let torus = "sqrt((sqrt(x^2+y^2)-1)^2+z^2)-0.4";
    for (name, phi, bbox, chi, genus) in
        [("sphere", SPHERE, BOX, 2, 0), ("torus", torus, "-1.5,-1.5,-0.6,1.5,1.5,0.6", 0, 1)]
    {
        let file = format!("{name}.obj");
        let (code, _, err) = run(&d, &["surface", "--phi", phi, "--bbox", bbox, "--h0", "0.2", "-q", "-o", &file]);
        assert_eq!(code, 0, "{err}");
        let (code, out, err) = run(&d, &["stats", &file, "--domain", phi]);
        assert_eq!(code, 0, "{err}");
        println!("{name}:\n{out}");
        assert!(!out.contains("boundary fidelity"), "{out}");
        let want = format!("surface: closed, manifold, 1 component, Euler characteristic {chi}, genus {genus}");
        assert!(out.contains(&want), "{name}: no {want:?} in\n{out}");
        let (code, json, err) = run(&d, &["stats", &file, "--domain", phi, "--json"]);
        assert_eq!(code, 0, "{err}");
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        let s = &v["surface"];
        assert_eq!(s["euler_characteristic"], chi);
        assert_eq!(s["genus"], genus);
        assert_eq!(s["manifold"], true);
        let dist = s["max_distance"].as_f64().unwrap();
        // Every node is projected onto phi = 0 (to 1e-9 h0); OBJ keeps 17 digits.
        assert!(dist < 1e-8, "{name}: a vertex lies {dist:e} from phi = 0");
        assert!(v.get("boundary_max_abs_d").is_none());
    }
}

/// `surface --size auto --per-radian K` is the old `--curvature K`: the same mesh bit for bit.
#[test]
fn size_auto_is_the_old_curvature_flag() {
    let d = tmp("size_auto");
    let torus = "sqrt((sqrt(x^2+y^2)-1)^2+z^2)-0.3";
    let common = ["surface", "--phi", torus, "--bbox", "-1.5,-1.5,-0.5,1.5,1.5,0.5", "--h0", "0.1", "--hmax", "0.25"];
    let a: Vec<&str> =
        common.iter().copied().chain(["--size", "auto", "--per-radian", "3", "-q", "-o", "a.obj"]).collect();
    let b: Vec<&str> = common.iter().copied().chain(["--curvature", "3", "-q", "-o", "b.obj"]).collect();
    for args in [&a, &b] {
        let (code, _, err) = run(&d, args);
        assert_eq!(code, 0, "{err}");
    }
    let (fa, fb) = (std::fs::read(d.join("a.obj")).unwrap(), std::fs::read(d.join("b.obj")).unwrap());
    assert_eq!(fa, fb, "--size auto --per-radian 3 and --curvature 3 differ");
    let m = trussmesh::io::read_mesh(&d.join("a.obj")).unwrap();
    let u: Vec<&str> = common[..7].iter().copied().chain(["-q", "-o", "u.obj"]).collect();
    let (code, _, err) = run(&d, &u);
    assert_eq!(code, 0, "{err}");
    let uniform = trussmesh::io::read_mesh(&d.join("u.obj")).unwrap();
    println!("torus: {} triangles with --size auto, {} uniform at h0", m.num_cells(), uniform.num_cells());
    assert!(m.num_cells() < uniform.num_cells(), "curvature sizes grow above h0 on the flat side");
    // A size expression is a relative size now; with --hmax (a flag of --size auto) it is refused.
    let (code, _, err) = run(&d, &common.iter().copied().chain(["--size", "x+1", "-o", "c.obj"]).collect::<Vec<_>>());
    assert_eq!(code, 2);
    assert!(err.contains("go with --size auto"), "{err}");
    assert!(!d.join("c.obj").exists());
}

/// `surface --phi ... --size EXPR`: a relative size for an implicit surface; the edge lengths
/// follow h (the smallest size near the surface becomes h0).
#[test]
fn a_size_expression_grades_an_implicit_surface() {
    let d = tmp("size_expr");
    let h = |x: f64| 2.0 + x; // 1 at x = -1, 3 at x = 1
    let (code, out, err) =
        run(&d, &["surface", "--phi", SPHERE, "--bbox", BOX, "--h0", "0.08", "--size", "2+x", "-o", "s.obj"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("Euler characteristic 2"), "{out}");
    let m = trussmesh::io::read_mesh(&d.join("s.obj")).unwrap();
    let (mut left, mut right, mut ratios) = ((0.0, 0), (0.0, 0), Vec::new());
    for i in 0..m.num_cells() {
        let c = m.cell(i);
        for k in 0..3 {
            let (p, q) = (m.points[c[k]], m.points[c[(k + 1) % 3]]);
            let len = (0..3).map(|j| (p[j] - q[j]).powi(2)).sum::<f64>().sqrt();
            let x = 0.5 * (p[0] + q[0]);
            ratios.push(len / h(x));
            if x < -0.8 {
                left.0 += len;
                left.1 += 1;
            } else if x > 0.8 {
                right.0 += len;
                right.1 += 1;
            }
        }
    }
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    let spread = (ratios.iter().map(|r| (r / mean - 1.0).powi(2)).sum::<f64>() / ratios.len() as f64).sqrt();
    let (l, r) = (left.0 / left.1 as f64, right.0 / right.1 as f64);
    let uniform = run(&d, &["surface", "--phi", SPHERE, "--bbox", BOX, "--h0", "0.08", "-q", "-o", "u.obj"]);
    assert_eq!(uniform.0, 0, "{}", uniform.2);
    let u = trussmesh::io::read_mesh(&d.join("u.obj")).unwrap();
    println!("| sphere, --size 2+x, h0 0.08 | triangles | mean edge x < -0.8 | mean edge x > 0.8 | ratio (h: about 2.6) | spread of length / h | uniform triangles |");
    println!("| | {} | {l:.4} | {r:.4} | {:.2} | {spread:.3} | {} |", m.num_cells(), r / l, u.num_cells());
    assert!(r / l > 2.0, "edges near x = 1 are {:.2} times those near x = -1", r / l);
    assert!(spread < 0.2, "edge length / h spreads by {spread:.3}");
    assert!((l / 0.08 - 1.0).abs() < 0.35, "the smallest edges {l:.4} are about h0 = 0.08");
    assert!(m.num_cells() * 3 < u.num_cells(), "{} graded vs {} uniform triangles", m.num_cells(), u.num_cells());
    for p in &m.points {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        assert!((r - 1.0).abs() < 1e-6, "a vertex at radius {r}");
    }
}
