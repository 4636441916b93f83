//! The `trussmesh` binary: every command of docs/cli.md, bad input, `stats` numbers.

use std::path::{Path, PathBuf};
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs the binary in `dir`: (exit code, stdout, stderr).
fn run(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_trussmesh"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("cannot start trussmesh");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Splits a shell line into words (single and double quotes, no expansion).
fn shell_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut cur = String::new();
    let mut in_word = false;
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        match c {
            '\'' => {
                in_word = true;
                for q in chars.by_ref() {
                    if q == '\'' {
                        break;
                    }
                    cur.push(q);
                }
            }
            '"' => {
                in_word = true;
                while let Some(q) = chars.next() {
                    match q {
                        '"' => break,
                        '\\' => cur.extend(chars.next()),
                        _ => cur.push(q),
                    }
                }
            }
            '\\' => {
                in_word = true;
                cur.extend(chars.next());
            }
            c if c.is_whitespace() => {
                if in_word {
                    words.push(std::mem::take(&mut cur));
                    in_word = false;
                }
            }
            c => {
                in_word = true;
                cur.push(c);
            }
        }
    }
    if in_word {
        words.push(cur);
    }
    words
}

/// The fenced blocks of docs/cli.md in language `lang`.
fn doc_blocks(lang: &str) -> Vec<String> {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/cli.md")).expect("docs/cli.md");
    let mut blocks = Vec::new();
    let mut cur: Option<String> = None;
    for line in text.lines() {
        match &mut cur {
            None if line.trim_start().starts_with("```") => {
                if line.trim() == format!("```{lang}") {
                    cur = Some(String::new());
                } else {
                    cur = Some("\u{0}".into()); // another language: skip
                }
            }
            Some(b) if line.trim_start().starts_with("```") => {
                if !b.starts_with('\u{0}') {
                    blocks.push(std::mem::take(b));
                }
                cur = None;
            }
            Some(b) => {
                b.push_str(line);
                b.push('\n');
            }
            None => {}
        }
    }
    blocks
}

fn doc_mesh_commands() -> Vec<String> {
    doc_blocks("sh")
        .iter()
        .flat_map(|b| b.lines().map(str::trim).map(String::from).collect::<Vec<_>>())
        .filter(|l| l.starts_with("trussmesh mesh"))
        .collect()
}

fn is_mesh_file(p: &str) -> bool {
    !(p.ends_with(".svg") || p.ends_with(".png"))
}

#[test]
fn docs_list_every_gallery_example() {
    let dir = tmp("list");
    let (code, out, err) = run(&dir, &["gallery", "--list"]);
    assert_eq!(code, 0, "{err}");
    let docs = doc_mesh_commands();
    let listed: Vec<&str> = out.lines().collect();
    assert!(listed.len() >= 12, "{out}");
    for l in &listed {
        assert!(docs.iter().any(|d| d == l), "docs/cli.md lacks the command\n{l}");
    }
}

/// Runs every `trussmesh mesh` command of docs/cli.md (after writing its TOML scenes) and reads
/// every mesh it writes back. Needs the 2-D mesher: fails while it returns an error.
#[test]
fn docs_commands_run() {
    let dir = tmp("docs");
    for b in doc_blocks("toml") {
        let first = b.lines().next().unwrap_or("");
        let name = first.trim_start_matches('#').trim();
        assert!(
            first.starts_with('#') && name.ends_with(".toml"),
            "a toml block of docs/cli.md must start with '# NAME.toml'"
        );
        std::fs::write(dir.join(name), &b).unwrap();
    }
    // The grid example's .npy, as its python line makes it: the unit disk's distance at 0.05.
    std::fs::create_dir_all(dir.join("out")).unwrap();
    let x: Vec<f64> = (0..45).map(|i| -1.1 + 0.05 * i as f64).collect();
    let disk: Vec<f64> = x.iter().flat_map(|y| x.iter().map(move |x| x.hypot(*y) - 1.0)).collect();
    std::fs::write(dir.join("out/disk.npy"), trussmesh::io::grid_file::npy_bytes([45, 45, 1], 2, &disk)).unwrap();
    let cmds = doc_mesh_commands();
    assert!(cmds.len() >= 15, "{cmds:?}");
    let mut failures = Vec::new();
    for line in &cmds {
        let words = shell_words(line);
        assert_eq!(words[0], "trussmesh");
        let args: Vec<&str> = words[1..].iter().map(String::as_str).collect();
        let (code, _, err) = run(&dir, &args);
        if code != 0 {
            failures.push(format!("exit {code}: {line}\n{err}"));
            continue;
        }
        let mut outputs: Vec<String> =
            args.windows(2).filter(|w| w[0] == "-o" || w[0] == "--output").map(|w| w[1].to_string()).collect();
        if let Some(scene) = args.iter().find(|a| a.ends_with(".toml")) {
            let t: toml::Table = toml::from_str(&std::fs::read_to_string(dir.join(scene)).unwrap()).unwrap();
            for o in t["output"].as_array().unwrap() {
                outputs.push(o.as_str().unwrap().to_string());
            }
        }
        assert!(!outputs.is_empty(), "{line}");
        for o in outputs {
            let p = dir.join(&o);
            assert!(p.exists(), "{line}: {o} was not written");
            if is_mesh_file(&o) {
                let m = trussmesh::io::read_mesh(&p).unwrap_or_else(|e| panic!("{line}: reading {o} back: {e}"));
                assert!(m.num_cells() > 0, "{line}: {o} has no cells");
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} docs/cli.md commands failed:\n{}",
        failures.len(),
        cmds.len(),
        failures.join("\n")
    );
}

fn bad(args: &[&str], needles: &[&str]) {
    let dir = tmp(&format!("bad{}", args.join("_").len()));
    bad_in(&dir, args, needles);
}

fn bad_in(dir: &Path, args: &[&str], needles: &[&str]) {
    let (code, _, err) = run(dir, args);
    assert_eq!(code, 2, "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: stderr lacks {n:?}:\n{err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

const SQ: [&str; 4] = ["--h0", "0.1", "--bbox", "-1,-1,1,1"];

fn mesh_args<'a>(domain: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["mesh", "--domain", domain];
    a.extend_from_slice(extra);
    a.extend_from_slice(&["-o", "a.vtu"]);
    a
}

#[test]
fn malformed_expression_names_the_column() {
    let a = mesh_args("sqrt(x^2+y^2", &SQ);
    bad(&a, &["column 13", "sqrt(x^2+y^2\n            ^"]);
    let mut a = mesh_args("x", &SQ);
    a.extend_from_slice(&["--size", "1+*x"]);
    bad(&a, &["--size", "column 3"]);
}

#[test]
fn unknown_function() {
    bad(&mesh_args("sqr(x)-1", &SQ), &["unknown function 'sqr'", "column 1"]);
}

#[test]
fn wrong_bbox_count() {
    let a = mesh_args("x", &["--dim", "2", "--h0", "0.1", "--bbox", "-1,-1,1"]);
    bad(&a, &["--bbox needs 4 values", "got 3"]);
    let a = mesh_args("x", &["--dim", "3", "--h0", "0.1", "--bbox", "-1,-1,1,1"]);
    bad(&a, &["--bbox needs 6 values", "got 4"]);
    let a = mesh_args("x", &["--h0", "0.1", "--bbox", "1,-1,-1,1"]);
    bad(&a, &["empty along axis x"]);
}

#[test]
fn negative_h0() {
    let a = mesh_args("x", &["--h0", "-1", "--bbox", "-1,-1,1,1"]);
    bad(&a, &["h0 must be positive"]);
}

#[test]
fn other_bad_mesh_input() {
    let a = ["mesh", "--dim", "3", "--domain", "x", "--h0", "0.1", "--bbox", "-1,-1,-1,1,1,1", "-o", "a.obj"];
    bad(&a, &["cannot hold tetrahedra"]);
    let a = mesh_args("x", &["--h0", "0.1", "--bbox", "-1,-1,1,1", "--fix", "0,0,0"]);
    bad(&a, &["fixed point 1 has 3 coordinates"]);
    let a = ["mesh", "--domain", "x", "--h0", "0.1", "--bbox", "-1,-1,1,1", "-o", "a.txt"];
    bad(&a, &["unknown output extension"]);
    let a = ["mesh", "--domain", "x", "--h0", "x", "--bbox", "-1,-1,1,1", "-o", "a.vtu"];
    bad(&a, &["must be a constant"]);
    let a = ["mesh", "--domain", "x", "--h0", "0.1", "--bbox", "-1,-1,1,1"];
    bad(&a, &["required arguments were not provided", "--output"]);
    let dir = tmp("scene");
    std::fs::write(dir.join("s.toml"), "domain = \"x\"\nh0 = -2\nbbox = [-1, -1, 1, 1]\noutput = [\"a.vtu\"]\n")
        .unwrap();
    bad_in(&dir, &["mesh", "s.toml"], &["h0 must be positive"]);
    std::fs::write(dir.join("t.toml"), "domain = \"x\"\nh = 1\n").unwrap();
    bad_in(&dir, &["mesh", "t.toml"], &["bad scene file", "t.toml"]);
}

#[test]
fn internal_boundaries_label_subdomains() {
    let dir = tmp("internal");
    let args = [
        "mesh",
        "--domain",
        "drectangle(x,y,-1,1,-1,1)",
        "--internal",
        "min(dcircle(x,y,-0.4,0,0.3), dcircle(x,y,0.5,0.2,0.3))",
        "--h0",
        "0.1",
        "--bbox",
        "-1,-1,1,1",
        "--fix",
        "-1,-1; 1,-1; 1,1; -1,1",
        "-o",
        "m.msh",
    ];
    let (code, _, err) = run(&dir, &args);
    assert_eq!(code, 0, "{err}");
    let m = trussmesh::io::read_mesh(&dir.join("m.msh")).expect("the .msh reads back");
    let labels: std::collections::BTreeSet<i32> = m.subdomain.expect("subdomain labels").into_iter().collect();
    assert_eq!(labels.len(), 3, "outside and inside each circle: {labels:?}");
}

#[test]
fn bad_metric_and_internal_input() {
    let a = mesh_args("sqrt(x^2+y^2)-1", &["--h0", "0.1", "--bbox", "-1,-1,1,1", "--metric", "1;0"]);
    bad(&a, &["--metric needs three expressions", "got 2"]);
    let a = mesh_args("sqrt(x^2+y^2)-1", &["--h0", "0.1", "--bbox", "-1,-1,1,1", "--metric", "1;2;1"]);
    bad(&a, &["not positive definite"]);
    let a = mesh_args("sqrt(x^2+y^2)-1", &["--h0", "0.1", "--bbox", "-1,-1,1,1", "--metric", "1;0;sqrt(-1)"]);
    bad(&a, &["the metric returned a non-finite value"]);
    let a = mesh_args("sqrt(x^2+y^2)-1", &["--h0", "0.1", "--bbox", "-1,-1,1,1", "--metric", "1;0;1", "--size", "1"]);
    bad(&a, &["either --size or --metric"]);
    let a = mesh_args("sqrt(x^2+y^2)-1", &["--h0", "0.1", "--bbox", "-1,-1,1,1", "--internal", "x+(y"]);
    bad(&a, &["--internal", "column"]);
}

#[test]
fn stats_rejects_garbled_and_truncated_files() {
    let dir = tmp("garbled");
    std::fs::write(dir.join("g.json"), "{\"dim\": 2, \"points\": [[0, 0], [1,").unwrap();
    bad_in(&dir, &["stats", "g.json"], &["g.json", "truncated"]);
    std::fs::write(dir.join("g.vtu"), "this is not xml").unwrap();
    bad_in(&dir, &["stats", "g.vtu"], &["g.vtu"]);
    let m = square();
    let bytes = trussmesh::io::write_mesh_bytes(&m, trussmesh::io::Format::Msh).unwrap();
    std::fs::write(dir.join("t.msh"), &bytes[..bytes.len() / 2]).unwrap();
    bad_in(&dir, &["stats", "t.msh"], &["parse error in t.msh"]);
    bad_in(&dir, &["stats", "missing.vtu"], &["missing.vtu"]);
}

fn square() -> trussmesh::io::MeshData {
    trussmesh::io::MeshData {
        dim: 2,
        cell_type: trussmesh::io::CellType::Triangle,
        points: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
        cells: vec![0, 1, 2, 0, 2, 3],
        subdomain: None,
    }
}

#[test]
fn stats_numbers_of_a_hand_made_mesh() {
    let dir = tmp("stats");
    std::fs::write(
        dir.join("sq.json"),
        r#"{"dim": 2, "cell_type": "triangle",
            "points": [[0, 0], [1, 0], [1, 1], [0, 1], [2, 0.5]],
            "cells": [[0, 1, 2], [0, 2, 3], [1, 4, 2]]}"#,
    )
    .unwrap();
    let (code, out, err) = run(&dir, &["stats", "sq.json", "--json", "--domain", "sqrt(x^2+y^2)-1", "--size", "1+x"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let f = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {out}"));
    let t = |k: &str| v["triangles"][k].as_f64().unwrap_or_else(|| panic!("{k} in {out}"));
    assert_eq!(v["nodes"], 5);
    assert_eq!(v["cells"], 3);
    assert_eq!(v["boundary_facets"], 5);
    // Two right isosceles triangles (q = 2 sqrt 2 - 2) and one with sides 1, sqrt 1.25, sqrt 1.25.
    let q_right = 2.0 * 2f64.sqrt() - 2.0;
    let (a, b, c) = (1.0, 1.25f64.sqrt(), 1.25f64.sqrt());
    let q_third = (b + c - a) * (c + a - b) * (a + b - c) / (a * b * c);
    assert!((t("q_min") - q_right).abs() < 1e-12);
    assert!((t("q_mean") - (2.0 * q_right + q_third) / 3.0).abs() < 1e-12);
    assert!((t("q_p1") - q_right).abs() < 1e-12);
    assert!((t("q_p50") - q_right).abs() < 1e-12);
    assert!((t("angle_min") - 45.0).abs() < 1e-9);
    assert!((t("angle_max") - 90.0).abs() < 1e-9);
    // Boundary vertices are all five; |d| is largest at (2, 0.5).
    assert!((f("boundary_max_abs_d") - (4.25f64.sqrt() - 1.0)).abs() < 1e-12);
    // Circumradius / h(centroid), circumradius = abc / (4 area).
    let r3 = a * b * c / (4.0 * 0.5);
    let rs = [2f64.sqrt() / 2.0 / (1.0 + 2.0 / 3.0), 2f64.sqrt() / 2.0 / (1.0 + 1.0 / 3.0), r3 / (1.0 + 4.0 / 3.0)];
    let mean = rs.iter().sum::<f64>() / 3.0;
    let std = (rs.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / 3.0).sqrt();
    assert!((f("size_deviation") - std / mean).abs() < 1e-12, "{out}");

    let (code, out, err) = run(&dir, &["stats", "sq.json"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("5 nodes, 3 cells, 5 boundary facets"), "{out}");
    assert!(out.contains("q: min 0.8284"), "{out}");
}

#[test]
fn help_works() {
    let dir = tmp("help");
    let (code, out, _) = run(&dir, &["--help"]);
    assert_eq!(code, 0);
    for w in ["mesh", "stats", "gallery"] {
        assert!(out.contains(w), "{out}");
    }
    let (code, out, _) = run(&dir, &["mesh", "--help"]);
    assert_eq!(code, 0);
    for w in ["--domain", "--bbox", "--fix", "--projection", "SCENE.toml"] {
        assert!(out.contains(w), "{out}");
    }
    let (code, _, err) = run(&dir, &["mesh", "--no-such-flag"]);
    assert_eq!(code, 2, "{err}");
}

#[test]
fn sharp_corners_are_held_unless_turned_off() {
    let dir = tmp("sharp");
    let base = ["mesh", "--domain", "drectangle(x,y,-1,1,-1,1)", "--h0", "0.2", "--bbox", "-1,-1,1,1", "-o", "sq.json"];
    let (code, out, err) = run(&dir, &base);
    assert_eq!(code, 0, "{err}");
    assert!(format!("{out}{err}").contains("4 sharp corners held fixed"), "{out}{err}");
    let mut off = base.to_vec();
    off.push("--no-sharp");
    let (code, out, err) = run(&dir, &off);
    assert_eq!(code, 0, "{err}");
    assert!(!format!("{out}{err}").contains("sharp corners"), "{out}{err}");
    // The same in a scene file.
    std::fs::write(
        dir.join("scene.toml"),
        "domain = \"drectangle(x,y,-1,1,-1,1)\"\nh0 = 0.2\nbbox = [-1, -1, 1, 1]\nsharp = false\noutput = [\"s.json\"]\n",
    )
    .unwrap();
    let (code, out, err) = run(&dir, &["mesh", "scene.toml"]);
    assert_eq!(code, 0, "{err}");
    assert!(!format!("{out}{err}").contains("sharp corners"), "{out}{err}");
}

/// Sizes are relative: a positive constant `--size` is the uniform size, and the output is the
/// same bytes as without `--size` (in 2-D and 3-D); a constant that is not positive is still
/// refused, and so is a constant `--size` beside `--metric`.
#[test]
fn constant_size_is_the_uniform_size() {
    let dir = tmp("constant_size");
    for (dim, domain, h0, bbox) in
        [("2", "sqrt(x^2+y^2)-1", "0.1", "-1,-1,1,1"), ("3", "sqrt(x^2+y^2+z^2)-1", "0.3", "-1,-1,-1,1,1,1")]
    {
        let base = ["mesh", "--dim", dim, "--domain", domain, "--h0", h0, "--bbox", bbox, "--quiet"];
        let mut outputs = Vec::new();
        for (k, size) in [None, Some("1"), Some("2.5*pi")].into_iter().enumerate() {
            let name = format!("m{dim}_{k}.json");
            let mut args: Vec<&str> = base.to_vec();
            if let Some(s) = size {
                args.extend(["--size", s]);
            }
            args.extend(["-o", &name]);
            let (code, _, err) = run(&dir, &args);
            assert_eq!(code, 0, "--size {size:?}: {err}");
            outputs.push(std::fs::read(dir.join(&name)).unwrap());
        }
        assert!(outputs.iter().all(|o| *o == outputs[0]), "dim {dim}: a constant size changed the mesh");
    }
    let (code, _, err) =
        run(&dir, &mesh_args("sqrt(x^2+y^2)-1", &["--h0", "0.1", "--bbox", "-1,-1,1,1", "--size", "-1"]));
    assert_eq!(code, 2, "{err}");
    let a = mesh_args("sqrt(x^2+y^2)-1", &["--h0", "0.1", "--bbox", "-1,-1,1,1", "--size", "1", "--metric", "1;0;1"]);
    bad(&a, &["either --size or --metric"]);
}
