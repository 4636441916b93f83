//! Remeshing for adaptation (seed section 5.2, figure 5-8): a uniform mesh of the unit square
//! is remeshed for a size field with a point singularity (the shape of an energy-norm error
//! estimate for Poisson's equation with a delta source), gradient limited on the old mesh.

use glam::DVec2;
use trussmesh::geometry::Rectangle;
use trussmesh::mesher::{mesh_2d, remesh_adapt_2d, Options2};
use trussmesh::topology::Level;

#[test]
fn figure_5_8_point_singularity() {
    let square = Rectangle::new([0.0, 0.0], [1.0, 1.0]);
    let opts =
        Options2::uniform(0.05, [0.0, 0.0], [1.0, 1.0]).with_fixed([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    let old = mesh_2d(&square, &opts).unwrap().mesh;
    let src = DVec2::new(0.5, 0.5);
    let g = 0.3;
    // Requested size: small at the singularity, growing faster than g allows.
    let raw = |p: DVec2| 0.01 + 0.8 * p.distance(src);
    let h_nodes: Vec<f64> = old.vertex_ids().map(|v| raw(old.pos(v))).collect();
    let out = remesh_adapt_2d(&old, h_nodes, g, 1000).unwrap();
    let m = &out.mesh;
    m.validate(Level::Geometry).unwrap();
    println!("{}", out.report);
    if let Some(f) = m.face_ids().min_by(|&a, &b| m.face_quality(a).total_cmp(&m.face_quality(b))) {
        let desc: Vec<String> = m
            .face_vertices(f)
            .iter()
            .map(|&v| format!("{:?} {:?} valence {}", m.pos(v), m.tag(v), m.valence(v)))
            .collect();
        println!("worst triangle q {:.3}: {}", m.face_quality(f), desc.join(" | "));
    }
    // The gradient-limited size of a point source is h(x) = min(raw(x), 0.01 + g |x - src|).
    let limited = |p: DVec2| raw(p).min(0.01 + g * p.distance(src));
    let mut ratios: Vec<f64> = m
        .edge_ids()
        .map(|h| {
            let (a, b) = (m.pos(m.origin(h)), m.pos(m.dest(h)));
            a.distance(b) / limited((a + b) * 0.5)
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    let q = out.report.quality;
    println!("| old nodes | new nodes | q min | q mean | median edge / limited h | 10% / 90% |");
    println!(
        "| {} | {} | {:.3} | {:.4} | {:.3} | {:.3} / {:.3} |",
        old.num_vertices(),
        q.vertices,
        q.q_min,
        q.q_mean,
        median,
        ratios[ratios.len() / 10],
        ratios[ratios.len() * 9 / 10]
    );
    assert!((median - 1.0).abs() <= 0.1, "median ratio {median}");
    assert!(q.q_mean >= 0.95, "q mean {}", q.q_mean);
}

#[test]
fn command_line_remesh_and_bad_input() {
    let exe = env!("CARGO_BIN_EXE_trussmesh");
    let dir = std::env::temp_dir().join(format!("trussmesh-remesh-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let square = Rectangle::new([0.0, 0.0], [1.0, 1.0]);
    let opts =
        Options2::uniform(0.1, [0.0, 0.0], [1.0, 1.0]).with_fixed([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    let old = mesh_2d(&square, &opts).unwrap().mesh;
    let old_path = dir.join("old.json");
    trussmesh::io::write_mesh(&old_path, &trussmesh::io::MeshData::from_trimesh2(&old)).unwrap();
    let new_path = dir.join("new.vtu");
    let o = std::process::Command::new(exe)
        .args(["remesh", old_path.to_str().unwrap(), "--size", "0.03+0.3*sqrt((x-0.5)^2+(y-0.5)^2)", "--quiet"])
        .args(["-o", new_path.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let new = trussmesh::io::read_mesh(&new_path).unwrap();
    let near = |pts: Vec<[f64; 3]>| pts.iter().filter(|p| (p[0] - 0.5).hypot(p[1] - 0.5) < 0.15).count();
    let (before, after) =
        (near(old.vertices().map(|(_, v)| [v.pos.x, v.pos.y, 0.0]).collect()), near(new.points.clone()));
    assert!(after > 2 * before, "finer near the centre: {before} nodes before, {after} after");
    // An inverted triangle in the input: exit 2 and a message that says so.
    let bad = dir.join("inverted.json");
    std::fs::write(
        &bad,
        r#"{"dim": 2, "cell_type": "triangle", "points": [[0,0],[1,0],[0,1],[1,1]], "cells": [[0,1,2],[1,2,3]]}"#,
    )
    .unwrap();
    let o = std::process::Command::new(exe)
        .args(["remesh", bad.to_str().unwrap(), "--size", "0.1", "-o", "x.vtu"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let msg = String::from_utf8_lossy(&o.stderr);
    assert!(msg.contains("invalid") || msg.contains("inverted") || msg.contains("orientation"), "{msg}");
    std::fs::remove_dir_all(&dir).ok();
}
