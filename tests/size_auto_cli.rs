//! `mesh --size auto`: sizes from curvature and local feature size, gradient limited, from the
//! command line. A 2-D channel (a 0.04 gap between two discs) and a 3-D slab (0.06 thick,
//! between two balls) get enough elements across, and neighbouring elements' sizes stay within
//! a factor 1 + g.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use trussmesh::io::{read_mesh, MeshData};

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("size_auto_cli").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn mesh(dir: &Path, args: &[&str]) -> MeshData {
    let out = Command::new(env!("CARGO_BIN_EXE_trussmesh"))
        .args(["mesh", "-q", "-o", "m.vtu"])
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "trussmesh mesh failed: {}", String::from_utf8_lossy(&out.stderr));
    read_mesh(&dir.join("m.vtu")).unwrap()
}

/// The longest edge whose midpoint lies in the box `lo`..`hi`, and how many such edges.
fn longest_edge_in(m: &MeshData, lo: [f64; 3], hi: [f64; 3]) -> (f64, usize) {
    let k = m.cell_type.nodes();
    let (mut longest, mut n) = (0.0f64, 0);
    for i in 0..m.num_cells() {
        let c = m.cell(i);
        for a in 0..k {
            for b in a + 1..k {
                let (p, q) = (m.points[c[a]], m.points[c[b]]);
                let mid = [0, 1, 2].map(|j| 0.5 * (p[j] + q[j]));
                if (0..3).all(|j| mid[j] >= lo[j] && mid[j] <= hi[j]) {
                    let len = (0..3).map(|j| (p[j] - q[j]).powi(2)).sum::<f64>().sqrt();
                    longest = longest.max(len);
                    n += 1;
                }
            }
        }
    }
    (longest, n)
}

/// The ratio of the sizes (mean edge lengths) of every two cells that share a facet: the
/// largest and the 99th percentile.
fn neighbour_ratios(m: &MeshData) -> (f64, f64) {
    let k = m.cell_type.nodes();
    let size: Vec<f64> = (0..m.num_cells())
        .map(|i| {
            let c = m.cell(i);
            let mut s = 0.0;
            for a in 0..k {
                for b in a + 1..k {
                    let (p, q) = (m.points[c[a]], m.points[c[b]]);
                    s += (0..3).map(|j| (p[j] - q[j]).powi(2)).sum::<f64>().sqrt();
                }
            }
            s / (k * (k - 1) / 2) as f64
        })
        .collect();
    let mut by_facet: HashMap<Vec<usize>, Vec<usize>> = HashMap::new();
    for i in 0..m.num_cells() {
        let c = m.cell(i);
        for skip in 0..k {
            let mut f: Vec<usize> = (0..k).filter(|&j| j != skip).map(|j| c[j]).collect();
            f.sort_unstable();
            by_facet.entry(f).or_default().push(i);
        }
    }
    let mut r: Vec<f64> = by_facet
        .values()
        .filter(|v| v.len() == 2)
        .map(|v| (size[v[0]] / size[v[1]]).max(size[v[1]] / size[v[0]]))
        .collect();
    r.sort_by(f64::total_cmp);
    (r[r.len() - 1], r[(0.99 * (r.len() - 1) as f64) as usize])
}

#[test]
fn a_channel_between_two_discs_gets_three_elements_across() {
    let d = tmp("channel");
    let g = 0.3;
    // Discs of radius 0.4 at x = -0.42 and 0.42: a gap of 0.04 at the origin.
    let m = mesh(
        &d,
        &[
            "--domain",
            "ddiff(drectangle(x,y,-1,1,-0.6,0.6), dunion(dcircle(x,y,-0.42,0,0.4), dcircle(x,y,0.42,0,0.4)))",
            "--size",
            "auto",
            "--gradient",
            "0.3",
            "--h0",
            "0.005",
            "--hmax",
            "0.1",
            "--bbox",
            "-1,-0.6,1,0.6",
        ],
    );
    let gap = 0.04;
    let (longest, n) = longest_edge_in(&m, [-0.5 * gap, -0.01, -1.0], [0.5 * gap, 0.01, 1.0]);
    let (far, _) = longest_edge_in(&m, [-1.0, -0.6, -1.0], [1.0, 0.6, 1.0]);
    let (max_ratio, p99) = neighbour_ratios(&m);
    println!("| 2-D channel | triangles | edges in the gap | longest there | elements across | longest anywhere | neighbour size ratio max / p99 |");
    println!(
        "| gap {gap} | {} | {n} | {longest:.4} | {:.2} | {far:.3} | {max_ratio:.3} / {p99:.3} |",
        m.num_cells(),
        gap / longest
    );
    assert!(n > 5, "only {n} edges in the gap");
    assert!(gap / longest >= 3.0, "{:.2} elements across the gap (longest edge {longest})", gap / longest);
    assert!(far > 4.0 * longest, "the sizes grow away from the gap: longest edge {far} vs {longest} in the gap");
    assert!(p99 <= 1.0 + g, "99% of neighbouring sizes within 1 + g = {}: p99 {p99}", 1.0 + g);
}

#[test]
fn a_slab_between_two_balls_gets_two_elements_across() {
    let d = tmp("slab");
    let g = 0.3;
    // Balls of radius 0.25 at x = -0.28 and 0.28 cut out of a ball of radius 0.55: a slab 0.06
    // thick at the origin (a ball outside, not a box, so that no edges call for small sizes).
    let m = mesh(
        &d,
        &[
            "--dim",
            "3",
            "--domain",
            "ddiff(dsphere(x,y,z,0,0,0,0.55), dunion(dsphere(x,y,z,-0.28,0,0,0.25), dsphere(x,y,z,0.28,0,0,0.25)))",
            "--size",
            "auto",
            "--gradient",
            "0.3",
            "--h0",
            "0.015",
            "--hmax",
            "0.12",
            "--bbox",
            "-0.56,-0.56,-0.56,0.56,0.56,0.56",
        ],
    );
    let gap = 0.06;
    let (longest, n) = longest_edge_in(&m, [-0.5 * gap, -0.015, -0.015], [0.5 * gap, 0.015, 0.015]);
    let (far, _) = longest_edge_in(&m, [-0.56; 3], [0.56; 3]);
    let (max_ratio, p99) = neighbour_ratios(&m);
    println!("| 3-D slab | tets | edges in the slab | longest there | elements across | longest anywhere | neighbour size ratio max / p99 |");
    println!(
        "| slab {gap} | {} | {n} | {longest:.4} | {:.2} | {far:.3} | {max_ratio:.3} / {p99:.3} |",
        m.num_cells(),
        gap / longest
    );
    assert!(n > 3, "only {n} edges in the slab");
    assert!(gap / longest >= 2.0, "{:.2} elements across the slab (longest edge {longest})", gap / longest);
    assert!(far > 3.0 * longest, "the sizes grow away from the slab: longest edge {far} vs {longest} in it");
    assert!(p99 <= 1.0 + g, "99% of neighbouring sizes within 1 + g = {}: p99 {p99}", 1.0 + g);
}

#[test]
fn auto_size_flags_need_size_auto() {
    let out = Command::new(env!("CARGO_BIN_EXE_trussmesh"))
        .args(["mesh", "--domain", "x", "--h0", "0.1", "--bbox", "-1,-1,1,1", "--hmax", "1", "-o", "a.vtu"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("go with --size auto"));
}
