//! Triangulated geometry on the command line: `mesh --dim 3 --domain FILE` and `surface --input
//! FILE` on a surface the command line wrote itself, and every bad surface refused with exit 2
//! and nothing written.

use std::path::{Path, PathBuf};
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli_trisurf").join(name);
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

fn sphere_stl(d: &Path) {
    let (code, _, err) = run(
        d,
        &[
            "surface",
            "--phi",
            "sqrt(x^2+y^2+z^2)-1",
            "--bbox",
            "-1.2,-1.2,-1.2,1.2,1.2,1.2",
            "--h0",
            "0.2",
            "-q",
            "-o",
            "s.stl",
        ],
    );
    assert_eq!(code, 0, "{err}");
}

#[test]
fn meshes_inside_and_remeshes_a_surface_file() {
    let d = tmp("run");
    sphere_stl(&d);
    let (code, out, err) =
        run(&d, &["mesh", "--dim", "3", "--domain", "s.stl", "--h0", "0.25", "-o", "v.vtu", "-o", "v.mesh"]);
    assert_eq!(code, 0, "{err}");
    println!("{out}");
    assert!(d.join("v.vtu").exists() && d.join("v.mesh").exists());
    let (code, stats, err) = run(&d, &["stats", "v.vtu", "--check"]);
    assert_eq!(code, 0, "{err}");
    println!("{stats}");
    // The tet mesh's boundary is a closed surface again: mesh inside it.
    let (code, _, err) = run(
        &d,
        &["mesh", "--dim", "3", "--domain", "v.mesh", "--h0", "0.3", "--size", "1+0.5*abs(x)", "-q", "-o", "w.msh"],
    );
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = run(&d, &["surface", "--input", "s.stl", "--h0", "0.15", "-o", "r.obj"]);
    assert_eq!(code, 0, "{err}");
    println!("{out}");
    let (code, _, err) =
        run(&d, &["surface", "--input", "r.obj", "--h0", "0.1", "--size", "1+abs(z)", "-q", "-o", "r2.ply"]);
    assert_eq!(code, 0, "{err}");
    assert!(d.join("r2.ply").exists());
}

/// An OBJ file of the given vertices and triangles (1-based in the file).
fn obj(d: &Path, name: &str, pts: &[[f64; 3]], tris: &[[usize; 3]]) {
    let mut s = String::new();
    for p in pts {
        s.push_str(&format!("v {} {} {}\n", p[0], p[1], p[2]));
    }
    for t in tris {
        s.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    std::fs::write(d.join(name), s).unwrap();
}

const TET: [[f64; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
const TET_FACES: [[usize; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];

#[test]
fn bad_surfaces_exit_2_and_write_nothing() {
    let d = tmp("bad");
    std::fs::write(d.join("empty.stl"), b"").unwrap();
    // A binary STL whose header claims 3 triangles but holds one.
    let mut stl = vec![0u8; 80];
    stl.extend(3u32.to_le_bytes());
    stl.extend([0u8; 50]);
    std::fs::write(d.join("short.stl"), &stl).unwrap();
    obj(&d, "open.obj", &TET, &TET_FACES[..3]);
    // Two tetrahedra sharing the edge from vertex 0 to vertex 3 only: four triangles on it.
    let mut two = TET.to_vec();
    two.extend([[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]);
    let mut faces = TET_FACES.to_vec();
    faces.extend([[0, 5, 4], [0, 4, 3], [4, 5, 3], [0, 3, 5]]);
    obj(&d, "fin.obj", &two, &faces);
    // Two overlapping tetrahedra.
    let mut cross = TET.to_vec();
    cross.extend(TET.iter().map(|p| [p[0] + 0.2, p[1] + 0.2, p[2] + 0.2]));
    let mut faces = TET_FACES.to_vec();
    faces.extend(TET_FACES.iter().map(|t| t.map(|v| v + 4)));
    obj(&d, "cross.obj", &cross, &faces);
    let cases = [
        ("empty.stl", "empty"),
        ("short.stl", "claims 3 triangles"),
        ("open.obj", "open"),
        ("fin.obj", "non-manifold"),
        ("cross.obj", "intersects itself"),
        ("missing.stl", "does not exist"),
    ];
    for (file, says) in cases {
        let (code, _, err) = run(&d, &["mesh", "--dim", "3", "--domain", file, "--h0", "0.1", "-o", "out.vtu"]);
        println!("mesh {file}: {}", err.trim());
        assert_eq!(code, 2, "{file}: {err}");
        assert!(err.contains(says), "{file}: {err}");
        let (code, _, err) = run(&d, &["surface", "--input", file, "--h0", "0.1", "-o", "out.obj"]);
        assert_eq!(code, 2, "{file}: {err}");
        assert!(err.contains(says), "{file}: {err}");
        assert!(!d.join("out.vtu").exists() && !d.join("out.obj").exists(), "{file}: an output was written");
    }
    sphere_stl(&d);
    let (code, _, err) = run(&d, &["mesh", "--dim", "2", "--domain", "s.stl", "--h0", "0.1", "-o", "out.vtu"]);
    assert_eq!(code, 2, "{err}");
    for cmd in [&["mesh", "--dim", "3", "--domain"][..], &["surface", "--input"][..]] {
        let mut a = cmd.to_vec();
        a.extend(["s.stl", "--h0", "0.001", "--max-memory", "100M", "-o", "out.vtu"]);
        let (code, _, err) = run(&d, &a);
        println!("{}", err.trim());
        assert_eq!(code, 2, "{err}");
        assert!(err.contains("past the memory budget"), "{err}");
    }
    let (code, _, err) =
        run(&d, &["mesh", "--dim", "3", "--domain", "s.stl", "--h0", "0.1", "--feature-angle", "0", "-o", "out.vtu"]);
    assert_eq!(code, 2, "{err}");
    assert!(!d.join("out.vtu").exists());
}

/// The cube [-1, 1]^3 as 12 triangles.
fn cube_obj(d: &Path) {
    let pts: Vec<[f64; 3]> = (0..8)
        .map(|i| [(i & 1) as f64 * 2.0 - 1.0, (i >> 1 & 1) as f64 * 2.0 - 1.0, (i >> 2 & 1) as f64 * 2.0 - 1.0])
        .collect();
    let tris = [
        [0, 2, 3],
        [0, 3, 1],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    obj(d, "cube.obj", &pts, &tris);
}

/// `surface --input` holds the input's sharp edges and corners: every output vertex on the
/// cube, the 8 corners among them exactly, every vertex near an edge on it; `--no-sharp`
/// rounds them.
#[test]
fn surface_input_keeps_the_cube_sharp() {
    let d = tmp("cube");
    cube_obj(&d);
    let on_cube = |p: [f64; 3]| p.iter().map(|c| c.abs()).fold(0.0, f64::max);
    for h0 in ["0.2", "0.3"] {
        let (code, out, err) = run(&d, &["surface", "--input", "cube.obj", "--h0", h0, "-o", "r.obj"]);
        assert_eq!(code, 0, "{err}");
        println!("h0 {h0}: {out}");
        let m = trussmesh::io::read_mesh(&d.join("r.obj")).unwrap();
        assert!(m.points.iter().all(|&p| (on_cube(p) - 1.0).abs() < 1e-9), "a vertex off the cube");
        let corners = m.points.iter().filter(|p| p.iter().all(|c| (c.abs() - 1.0).abs() < 1e-12)).count();
        assert_eq!(corners, 8, "h0 {h0}");
        // On an edge: two coordinates at +-1.
        let on_edge = |p: &[f64; 3]| p.iter().filter(|c| (c.abs() - 1.0).abs() < 1e-9).count() >= 2;
        let edge_vertices = m.points.iter().filter(|p| on_edge(p)).count();
        let h: f64 = h0.parse().unwrap();
        assert!(edge_vertices as f64 >= 12.0 * 2.0 / h * 0.8, "h0 {h0}: {edge_vertices} vertices on the edges");
    }
    let (code, _, err) = run(&d, &["surface", "--input", "cube.obj", "--h0", "0.2", "--no-sharp", "-q", "-o", "n.obj"]);
    assert_eq!(code, 0, "{err}");
    let m = trussmesh::io::read_mesh(&d.join("n.obj")).unwrap();
    let corners = m.points.iter().filter(|p| p.iter().all(|c| (c.abs() - 1.0).abs() < 1e-12)).count();
    assert!(corners < 8, "--no-sharp held {corners} corners");
}

/// The mean edge length of the triangles of `m` whose centroid passes `keep`.
fn mean_edge_where(m: &trussmesh::io::MeshData, keep: impl Fn([f64; 3]) -> bool) -> (f64, usize) {
    let (mut sum, mut n) = (0.0, 0);
    for i in 0..m.num_cells() {
        let c = m.cell(i);
        let p: Vec<[f64; 3]> = c.iter().map(|&v| m.points[v]).collect();
        let centroid = [0, 1, 2].map(|j| p.iter().map(|q| q[j]).sum::<f64>() / p.len() as f64);
        if !keep(centroid) {
            continue;
        }
        for a in 0..p.len() {
            for b in a + 1..p.len() {
                sum += (0..3).map(|j| (p[a][j] - p[b][j]).powi(2)).sum::<f64>().sqrt();
                n += 1;
            }
        }
    }
    (sum / n.max(1) as f64, n)
}

/// `--size auto` with a surface file: sizes from the curvature of the input's own triangles. An
/// ellipsoid with semi-axes 2, 1, 1 curves twice as much at its tips as around its equator, so
/// the edges there come out about half as long; the tets inside it follow the same sizes.
#[test]
fn auto_sizes_follow_the_curvature_of_a_surface_file() {
    let d = tmp("auto");
    let (code, _, err) = run(
        &d,
        &[
            "surface",
            "--phi",
            "x^2/4+y^2+z^2-1",
            "--bbox",
            "-2.2,-1.2,-1.2,2.2,1.2,1.2",
            "--h0",
            "0.06",
            "-q",
            "-o",
            "e.stl",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let (code, out, err) =
        run(&d, &["surface", "--input", "e.stl", "--size", "auto", "--h0", "0.08", "--hmax", "0.6", "-o", "r.obj"]);
    assert_eq!(code, 0, "{err}");
    println!("{out}");
    let m = trussmesh::io::read_mesh(&d.join("r.obj")).unwrap();
    let (tips, nt) = mean_edge_where(&m, |c| c[0].abs() > 1.8);
    let (middle, nm) = mean_edge_where(&m, |c| c[0].abs() < 0.3);
    println!("| surface | tips (|x| > 1.8) | equator (|x| < 0.3) | ratio |");
    println!(
        "| {} triangles | {tips:.3} ({nt} edges) | {middle:.3} ({nm} edges) | {:.2} |",
        m.num_cells(),
        middle / tips
    );
    assert!((1.5..=2.6).contains(&(middle / tips)), "equator / tip edge length {:.2}, 2 expected", middle / tips);
    let (code, out, err) = run(
        &d,
        &["mesh", "--dim", "3", "--domain", "e.stl", "--size", "auto", "--h0", "0.1", "--hmax", "0.6", "-o", "v.vtu"],
    );
    assert_eq!(code, 0, "{err}");
    println!("{out}");
    let v = trussmesh::io::read_mesh(&d.join("v.vtu")).unwrap();
    let (tips, _) = mean_edge_where(&v, |c| c[0].abs() > 1.7);
    let (middle, _) = mean_edge_where(&v, |c| c[0].abs() < 0.3 && c[1].hypot(c[2]) > 0.8);
    println!("| tets | {} tets | tips {tips:.3} | equator {middle:.3} | ratio {:.2} |", v.num_cells(), middle / tips);
    assert!(middle / tips >= 1.4, "equator / tip edge length in the tets {:.2}", middle / tips);
    let dihedral = out
        .lines()
        .find_map(|l| l.split("dihedral angles ").nth(1))
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse::<f64>().ok())
        .expect("the report's dihedral angles");
    assert!(dihedral >= 30.0, "min dihedral {dihedral}");
}
