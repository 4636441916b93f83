//! Remeshing for strongly graded sizes (`remesh --size EXPR --gradient G`), the case
//! `0.02+abs(x)` at g = 3 among them: before the force step checked folds and boundary
//! crossings, it ended in "the finished mesh is invalid (FoldedVertex)". Each run must exit 0
//! with a valid mesh (the output check runs on every mesh) of q min at least 0.3 and no warning.

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_trussmesh");

fn run(args: &[&str]) -> (i32, String) {
    let out = Command::new(BIN).args(args).output().expect("run trussmesh");
    let text = String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    (out.status.code().unwrap_or(-1), text)
}

fn q_min(report: &str) -> Option<f64> {
    let line = report.lines().find(|l| l.starts_with("q min "))?;
    line.trim_start_matches("q min ").split(',').next()?.trim().parse().ok()
}

fn remesh_family(sizes: &[&str]) {
    let dir = std::env::temp_dir().join(format!("trussmesh-grading-{}-{}", std::process::id(), sizes.len()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("disk.vtu");
    let (code, text) = run(&[
        "mesh",
        "--domain",
        "sqrt(x^2+y^2)-1",
        "--h0",
        "0.1",
        "--bbox",
        "-1,-1,1,1",
        "-o",
        input.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{text}");
    println!("| size | g | exit | q min | warning |");
    println!("|---|---|---|---|---|");
    let mut bad = Vec::new();
    for size in sizes {
        for g in ["1", "3", "10"] {
            let out = dir.join("out.vtu");
            let (code, text) =
                run(&["remesh", input.to_str().unwrap(), "--size", size, "--gradient", g, "-o", out.to_str().unwrap()]);
            let q = q_min(&text);
            let warned = text.contains("warning:");
            println!("| {size} | {g} | {code} | {} | {warned} |", q.map_or("-".into(), |q| format!("{q:.4}")));
            if code != 0 || warned || q.is_none_or(|q| q < 0.3) {
                bad.push(format!("{size} g {g}: exit {code}: {text}"));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(bad.is_empty(), "{bad:#?}");
}

#[test]
fn strongly_graded_remeshing_gives_valid_meshes() {
    remesh_family(&["0.02+abs(x)", "0.01+0.5*abs(y-0.3)", "0.03+(x^2+y^2)"]);
}

#[test]
#[ignore = "open defect: with size 0.005+abs(x*y) every g gives a valid mesh with q min 0 (a 180-degree triangle, warned in the report); a check after every operation showed a vertex winding twice right after a boundary split in density control, undone later by the force loop"]
fn strongly_graded_remeshing_near_a_size_of_zero_slope() {
    remesh_family(&["0.005+abs(x*y)"]);
}
