//! `mesh --domain GRID` and `--size GRID`: d and h sampled on a grid, read from a NumPy .npy
//! array (placed by --origin and --spacing) or a VTK .vti image (seed section 3.1, example 1
//! from a grid). The disk sampled at 0.05 meshes at the quality of its formula; bad files are
//! refused with exit code 2 and nothing written.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use trussmesh::glam::DVec2;
use trussmesh::io::grid_file::npy_bytes;
use trussmesh::io::{read_mesh, MeshData};
use trussmesh::quality::triangle_q;

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("grid_input").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trussmesh")).args(args).current_dir(dir).output().unwrap()
}

fn mesh(dir: &Path, args: &[&str]) -> MeshData {
    let out = run(dir, &[&["mesh", "-q", "-o", "m.vtu"], args].concat());
    assert!(out.status.success(), "trussmesh mesh failed: {}", String::from_utf8_lossy(&out.stderr));
    read_mesh(&dir.join("m.vtu")).unwrap()
}

/// Samples `f` on the grid origin + h (i, j), i < nx, j < ny: values x fastest.
fn sample2(f: impl Fn(f64, f64) -> f64, origin: [f64; 2], h: f64, n: [usize; 2]) -> Vec<f64> {
    let mut v = Vec::new();
    for j in 0..n[1] {
        for i in 0..n[0] {
            v.push(f(origin[0] + h * i as f64, origin[1] + h * j as f64));
        }
    }
    v
}

fn disk(x: f64, y: f64) -> f64 {
    (x * x + y * y).sqrt() - 1.0
}

/// A .vti image of `values` (x fastest), ASCII or with raw appended Float64 data.
fn vti(dims: [usize; 3], origin: [f64; 3], h: f64, values: &[f64], binary: bool) -> Vec<u8> {
    let ext = format!("0 {} 0 {} 0 {}", dims[0] - 1, dims[1] - 1, dims[2] - 1);
    let head = format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">\n<ImageData WholeExtent=\"{ext}\" Origin=\"{} {} {}\" Spacing=\"{h} {h} {h}\">\n\
         <Piece Extent=\"{ext}\">\n<PointData Scalars=\"d\">\n",
        origin[0], origin[1], origin[2]
    );
    let mut out = head.into_bytes();
    if binary {
        out.extend_from_slice(b"<DataArray type=\"Float64\" Name=\"d\" format=\"appended\" offset=\"0\"/>\n");
        out.extend_from_slice(b"</PointData>\n</Piece>\n</ImageData>\n<AppendedData encoding=\"raw\">\n_");
        out.extend_from_slice(&((values.len() * 8) as u64).to_le_bytes());
        for v in values {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");
    } else {
        out.extend_from_slice(b"<DataArray type=\"Float64\" Name=\"d\" format=\"ascii\">\n");
        let text: Vec<String> = values.iter().map(|v| format!("{v:e}")).collect();
        out.extend_from_slice(text.join(" ").as_bytes());
        out.extend_from_slice(b"\n</DataArray>\n</PointData>\n</Piece>\n</ImageData>\n</VTKFile>\n");
    }
    out
}

/// The smallest and mean q, and the largest distance of a node from the unit circle's outside.
fn disk_quality(m: &MeshData) -> (f64, f64, f64) {
    let (mut qmin, mut qsum) = (1.0f64, 0.0);
    for i in 0..m.num_cells() {
        let c = m.cell(i);
        let q = triangle_q([0, 1, 2].map(|k| DVec2::new(m.points[c[k]][0], m.points[c[k]][1])));
        qmin = qmin.min(q);
        qsum += q;
    }
    let out = m.points.iter().map(|p| disk(p[0], p[1])).fold(f64::NEG_INFINITY, f64::max);
    (qmin, qsum / m.num_cells() as f64, out)
}

/// Replaces the first `from` in `v` by `to` (of the same length).
fn replace(v: &mut [u8], from: &[u8], to: &[u8]) {
    let at = v.windows(from.len()).position(|w| w == from).unwrap();
    v[at..at + to.len()].copy_from_slice(to);
}

const N: usize = 45; // -1.1 to 1.1 at 0.05

#[test]
fn the_disk_from_a_grid_meshes_at_the_quality_of_its_formula() {
    let d = tmp("disk");
    let values = sample2(disk, [-1.1, -1.1], 0.05, [N, N]);
    std::fs::write(d.join("disk.npy"), npy_bytes([N, N, 1], 2, &values)).unwrap();
    // Fortran order, the same values: a[j, i] stored with j fastest.
    let mut fortran = npy_bytes([N, N, 1], 2, &values);
    let data_at = fortran.len() - 8 * values.len();
    replace(&mut fortran, b"'fortran_order': False", b"'fortran_order': True ");
    for i in 0..N {
        for j in 0..N {
            let at = data_at + 8 * (j + N * i);
            fortran[at..at + 8].copy_from_slice(&values[i + N * j].to_le_bytes());
        }
    }
    std::fs::write(d.join("disk_f.npy"), &fortran).unwrap();
    std::fs::write(d.join("disk.vti"), vti([N, N, 1], [-1.1, -1.1, 0.0], 0.05, &values, false)).unwrap();
    std::fs::write(d.join("disk_b.vti"), vti([N, N, 1], [-1.1, -1.1, 0.0], 0.05, &values, true)).unwrap();

    let formula = mesh(&d, &["--domain", "sqrt(x^2+y^2)-1", "--h0", "0.1", "--bbox", "-1.1,-1.1,1.1,1.1"]);
    let npy = mesh(&d, &["--domain", "disk.npy", "--origin", "-1.1,-1.1", "--spacing", "0.05", "--h0", "0.1"]);
    let f = disk_quality(&formula);
    let g = disk_quality(&npy);
    println!("| disk, h0 0.1 | triangles | q min | q mean | max d at a node |");
    println!("| formula | {} | {:.4} | {:.4} | {:.1e} |", formula.num_cells(), f.0, f.1, f.2);
    println!("| grid 0.05 (.npy) | {} | {:.4} | {:.4} | {:.1e} |", npy.num_cells(), g.0, g.1, g.2);
    assert!(g.0 >= f.0 - 0.02, "q min {} from the grid vs {} from the formula", g.0, f.0);
    assert!(g.1 >= f.1 - 0.005, "q mean {} from the grid vs {} from the formula", g.1, f.1);
    assert!(g.2 < 2e-3, "a node {:.1e} outside the circle", g.2);
    let n = npy.num_cells() as f64 / formula.num_cells() as f64;
    assert!((0.95..1.05).contains(&n), "{} triangles vs {}", npy.num_cells(), formula.num_cells());
    // The same samples in Fortran order and in .vti files (text, appended binary) give the same mesh.
    let same = |m: &MeshData, what: &str| {
        assert_eq!(m.cells, npy.cells, "{what}");
        assert_eq!(m.points, npy.points, "{what}");
    };
    same(
        &mesh(&d, &["--domain", "disk_f.npy", "--origin", "-1.1,-1.1", "--spacing", "0.05", "--h0", "0.1"]),
        "fortran",
    );
    same(&mesh(&d, &["--domain", "disk.vti", "--h0", "0.1"]), "vti ascii");
    same(&mesh(&d, &["--domain", "disk_b.vti", "--h0", "0.1"]), "vti binary");
    // A scene file places the .npy grid the same way.
    std::fs::write(
        d.join("disk.toml"),
        "domain = \"disk.npy\"\norigin = [-1.1, -1.1]\nspacing = 0.05\nh0 = 0.1\nbbox = [-1.1, -1.1, 1.1, 1.1]\n",
    )
    .unwrap();
    let out = run(&d, &["mesh", "-q", "disk.toml", "-o", "scene.vtu"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    same(&read_mesh(&d.join("scene.vtu")).unwrap(), "scene file");
}

#[test]
fn a_size_grid_grades_the_mesh() {
    let d = tmp("size");
    // h = 1 + 2 x on the square [-1, 1]^2 (as a .vti with spacing 0.1), the disk from its formula.
    let values = sample2(|x, _| 1.0 + 2.0 * (x + 1.0) / 2.0, [-1.1, -1.1], 0.1, [23, 23]);
    std::fs::write(d.join("h.vti"), vti([23, 23, 1], [-1.1, -1.1, 0.0], 0.1, &values, true)).unwrap();
    let m =
        mesh(&d, &["--domain", "sqrt(x^2+y^2)-1", "--size", "h.vti", "--h0", "0.05", "--bbox", "-1.1,-1.1,1.1,1.1"]);
    let e = mesh(
        &d,
        &["--domain", "sqrt(x^2+y^2)-1", "--size", "1+2*(x+1)/2", "--h0", "0.05", "--bbox", "-1.1,-1.1,1.1,1.1"],
    );
    let mean_edge = |m: &MeshData, lo: f64, hi: f64| {
        let (mut s, mut n) = (0.0, 0);
        for i in 0..m.num_cells() {
            let c = m.cell(i);
            for k in 0..3 {
                let (p, q) = (m.points[c[k]], m.points[c[(k + 1) % 3]]);
                let x = 0.5 * (p[0] + q[0]);
                if x >= lo && x <= hi {
                    s += ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
                    n += 1;
                }
            }
        }
        s / n as f64
    };
    let ratio = mean_edge(&m, 0.6, 1.0) / mean_edge(&m, -1.0, -0.6);
    let ratio_e = mean_edge(&e, 0.6, 1.0) / mean_edge(&e, -1.0, -0.6);
    println!("| --size from a grid | {} triangles | right / left mean edge {ratio:.2} (expression: {} triangles, {ratio_e:.2}) |", m.num_cells(), e.num_cells());
    assert!(ratio > 1.8, "edges on the right {ratio:.2} times those on the left");
    assert!((ratio / ratio_e - 1.0).abs() < 0.1);
}

#[test]
fn a_ball_from_a_3d_grid() {
    let d = tmp("ball");
    let n = 27; // -1.3 to 1.3 at 0.1
    let mut v = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = [i, j, k].map(|c| -1.3 + 0.1 * c as f64);
                v.push((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0);
            }
        }
    }
    std::fs::write(d.join("ball.npy"), npy_bytes([n, n, n], 3, &v)).unwrap();
    let m = mesh(
        &d,
        &["--dim", "3", "--domain", "ball.npy", "--origin", "-1.3,-1.3,-1.3", "--spacing", "0.1", "--h0", "0.3"],
    );
    let r = m.points.iter().map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()).fold(0.0, f64::max);
    println!("| ball from a 3-D .npy | {} tets | largest radius {r:.4} |", m.num_cells());
    assert!(m.num_cells() > 100);
    assert!((r - 1.0).abs() < 5e-3, "largest radius {r}");
}

/// A bad input: exit code 2, the message, and no output file.
fn refused(dir: &Path, args: &[&str], says: &str) {
    let out = run(dir, &[&["mesh", "-o", "never.vtu", "--h0", "0.1"], args].concat());
    let err = String::from_utf8_lossy(&out.stderr);
    println!("| {:?} | exit {:?} | {} |", args, out.status.code(), err.trim());
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains(says), "{args:?}: {err:?} does not say {says:?}");
    assert!(!dir.join("never.vtu").exists());
}

#[test]
fn bad_grid_files_are_refused() {
    let d = tmp("bad");
    let values = sample2(disk, [-1.1, -1.1], 0.05, [N, N]);
    let good = npy_bytes([N, N, 1], 2, &values);
    std::fs::write(d.join("short.npy"), &good[..good.len() - 100]).unwrap();
    let mut int = good.clone();
    replace(&mut int, b"<f8", b"<i8");
    std::fs::write(d.join("int.npy"), &int).unwrap();
    let mut nan = values.clone();
    nan[3 + N * 7] = f64::NAN;
    std::fs::write(d.join("nan.npy"), npy_bytes([N, N, 1], 2, &nan)).unwrap();
    std::fs::write(d.join("disk.npy"), &good).unwrap();
    std::fs::write(d.join("junk.npy"), b"not numpy at all").unwrap();
    let mut v = vti([N, N, 1], [-1.1, -1.1, 0.0], 0.05, &values, false);
    std::fs::write(d.join("short.vti"), &v[..v.len() / 2]).unwrap();
    v = vti([N, N + 1, 1], [-1.1, -1.1, 0.0], 0.05, &values, true);
    std::fs::write(d.join("shape.vti"), &v).unwrap();
    std::fs::write(d.join("nan.vti"), vti([N, N, 1], [-1.1, -1.1, 0.0], 0.05, &nan, false)).unwrap();
    std::fs::write(d.join("disk.vti"), vti([N, N, 1], [-1.1, -1.1, 0.0], 0.05, &values, false)).unwrap();
    let place = ["--origin", "-1.1,-1.1", "--spacing", "0.05"];
    refused(&d, &[&["--domain", "short.npy"], &place[..]].concat(), "(truncated)");
    refused(&d, &[&["--domain", "int.npy"], &place[..]].concat(), "is not float32 or float64");
    refused(&d, &[&["--domain", "nan.npy"], &place[..]].concat(), "the value at sample [3, 7] (x, y, z index) is NaN");
    refused(&d, &[&["--domain", "junk.npy"], &place[..]].concat(), "not a .npy file");
    refused(&d, &[&["--domain", "missing.npy"], &place[..]].concat(), "missing.npy");
    refused(&d, &["--domain", "disk.npy"], "give --spacing H");
    refused(&d, &["--domain", "disk.npy", "--spacing", "0.05", "--origin", "1,2,3"], "--origin needs 2 values");
    refused(&d, &["--domain", "disk.npy", "--spacing", "-1"], "--spacing must be positive");
    refused(&d, &["--dim", "3", "--domain", "disk.npy", "--spacing", "0.05"], "is a 2-D grid");
    refused(&d, &["--domain", "short.vti"], "truncated");
    refused(&d, &["--domain", "shape.vti"], "shape [45, 46] needs 2070 values but the file holds 2025");
    refused(&d, &["--domain", "nan.vti"], "grid value: \"NaN\" is not a finite number");
    refused(&d, &["--domain", "disk.vti", "--spacing", "0.05"], "gives its own origin and spacing");
    refused(&d, &["--domain", "sqrt(x^2+y^2)-1", "--bbox", "-1,-1,1,1", "--spacing", "0.05"], "go with a .npy grid");
    refused(
        &d,
        &["--domain", "sqrt(x^2+y^2)-1", "--bbox", "-1,-1,1,1", "--size", "nan.npy", "--spacing", "0.05"],
        "is NaN",
    );
}
