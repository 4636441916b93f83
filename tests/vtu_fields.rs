//! The .vtu files' data as another reader sees it: python's meshio reads the quality fields,
//! the subdomain labels and the node kinds back by name (skipped, with a message, when meshio
//! is not installed).

use std::path::{Path, PathBuf};
use std::process::Command;
use trussmesh::io::{read_mesh, Measure};

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("vtu_fields").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn meshio() -> bool {
    let ok = Command::new("python3").args(["-c", "import meshio"]).output().is_ok_and(|o| o.status.success());
    if !ok {
        println!("meshio not installed (pip install meshio): skipping the .vtu field test");
    }
    ok
}

fn mesh(dir: &Path, args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_trussmesh")).arg("mesh").args(args).current_dir(dir).output().unwrap();
    assert!(out.status.success(), "trussmesh mesh failed: {}", String::from_utf8_lossy(&out.stderr));
}

/// meshio's view of a file: for each named array, its values (cell data of the first cell
/// block of `cell_type`, or point data).
fn read_by_meshio(path: &Path, cell_type: &str, cell_names: &[&str], point_names: &[&str]) -> Vec<Vec<f64>> {
    let script = format!(
        "import meshio, sys, json\n\
         m = meshio.read(sys.argv[1])\n\
         k = [i for i, c in enumerate(m.cells) if c.type == '{cell_type}'][0]\n\
         out = [list(map(float, m.cell_data[n][k])) for n in {cell_names:?}]\n\
         out += [list(map(float, m.point_data[n])) for n in {point_names:?}]\n\
         print(json.dumps(out))"
    );
    let out = Command::new("python3").args(["-c", &script, path.to_str().unwrap()]).output().unwrap();
    assert!(out.status.success(), "meshio failed on {}: {}", path.display(), String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("meshio's arrays as JSON")
}

fn count(v: &[f64], k: f64) -> usize {
    v.iter().filter(|&&x| x == k).count()
}

#[test]
fn meshio_reads_quality_subdomains_and_node_kinds_by_name() {
    if !meshio() {
        return;
    }
    let d = tmp("fields");
    // 2-D: a square (corners found as features) with one given point and an internal circle.
    mesh(
        &d,
        &[
            "--domain",
            "drectangle(x,y,-1,1,-1,1)",
            "--h0",
            "0.15",
            "--bbox",
            "-1,-1,1,1",
            "--fix",
            "0,-1",
            "--internal",
            "dcircle(x,y,0,0,0.5)",
            "-q",
            "-o",
            "square.vtu",
        ],
    );
    let p = d.join("square.vtu");
    let a = read_by_meshio(&p, "triangle", &["q", "subdomain"], &["node_kind"]);
    let ours = read_mesh(&p).unwrap();
    let q = Measure::default_for(&ours).values;
    let (kq, sd, kinds) = (&a[0], &a[1], &a[2]);
    let dq = kq.iter().zip(&q).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    println!(
        "2-D: {} triangles, meshio q min {:.3}, max |q - ours| {dq:.1e}; subdomains {} / {}; node kinds interior {} \
         boundary {} fixed {} feature {} internal {}",
        kq.len(),
        kq.iter().copied().fold(1.0, f64::min),
        count(sd, 0.0),
        count(sd, 1.0),
        count(kinds, 0.0),
        count(kinds, 1.0),
        count(kinds, 2.0),
        count(kinds, 3.0),
        count(kinds, 4.0)
    );
    assert_eq!(kq.len(), ours.num_cells());
    assert!(dq < 1e-12, "meshio's q differs from ours by {dq}");
    assert!(kq.iter().all(|&v| v > 0.5 && v <= 1.0), "q out of (0.5, 1]");
    assert_eq!(sd.len(), ours.num_cells());
    assert!(count(sd, 0.0) > 10 && count(sd, 1.0) > 10, "both subdomains hold triangles");
    assert_eq!(kinds.len(), ours.points.len());
    assert_eq!(count(kinds, 2.0), 1, "the one given point is fixed");
    assert_eq!(count(kinds, 3.0), 4, "the square's four corners are features");
    assert!(count(kinds, 0.0) > 10 && count(kinds, 1.0) > 10 && count(kinds, 4.0) > 10);

    // 3-D: a cube, whose edges and corners the mesher holds as features.
    mesh(
        &d,
        &[
            "--dim",
            "3",
            "--domain",
            "max(max(abs(x),abs(y)),abs(z))-1",
            "--h0",
            "0.4",
            "--bbox",
            "-1.1,-1.1,-1.1,1.1,1.1,1.1",
            "-q",
            "-o",
            "cube.vtu",
        ],
    );
    let p = d.join("cube.vtu");
    let a = read_by_meshio(&p, "tetra", &["radius_ratio", "min_dihedral"], &["node_kind"]);
    let ours = read_mesh(&p).unwrap();
    let dihedral = Measure::default_for(&ours).values;
    let (rr, md, kinds) = (&a[0], &a[1], &a[2]);
    let dd = md.iter().zip(&dihedral).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    println!(
        "3-D: {} tets, radius ratio min {:.3}, min dihedral min {:.1} deg (max |diff| {dd:.1e}); node kinds \
         interior {} boundary {} feature {}",
        rr.len(),
        rr.iter().copied().fold(1.0, f64::min),
        md.iter().copied().fold(90.0, f64::min),
        count(kinds, 0.0),
        count(kinds, 1.0),
        count(kinds, 3.0)
    );
    assert_eq!(rr.len(), ours.num_cells());
    assert!(rr.iter().all(|&v| v > 0.0 && v <= 1.0), "radius ratio out of (0, 1]");
    assert!(md.iter().all(|&v| v > 0.0 && v < 70.6), "min dihedral out of (0, 70.6)");
    assert!(dd < 1e-9, "meshio's min dihedral differs from ours by {dd}");
    assert!(count(kinds, 3.0) >= 8, "at least the cube's 8 corners are features");
    assert!(count(kinds, 0.0) > 0 && count(kinds, 1.0) > 0);
}
