//! The same domain perturbed by 1e-12 to 1e-5 (d + eps x) must mesh at the same quality: a
//! mesher whose result hangs on such a perturbation gives a user (or a numpy callable, whose
//! values differ from an expression's in the last bits) a worse mesh by chance.
//!
//! `cargo test --release --test perturbed_inputs -- --nocapture` prints the table.

use std::f64::consts::PI;
use std::sync::Arc;
use trussmesh::glam::DVec2;
use trussmesh::mesher::{mesh_2d, Options2};

const EPS: [f64; 5] = [0.0, 1e-12, 1e-9, 1e-7, 1e-5];
/// The largest spread of q mean over the perturbations.
const Q_MEAN_SPREAD: f64 = 0.003;
/// The largest spread of q min over the perturbations.
const Q_MIN_SPREAD: f64 = 0.04;

type D = Arc<dyn Fn(DVec2) -> f64 + Send + Sync>;

struct Case {
    name: String,
    d: D,
    h0: f64,
    bbox: [f64; 4],
    fixed: Vec<[f64; 2]>,
    size: Option<Arc<dyn Fn(DVec2) -> f64 + Send + Sync>>,
}

fn rect(p: DVec2, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    (x0 - p.x).max(p.x - x1).max(y0 - p.y).max(p.y - y1)
}

fn cases() -> Vec<Case> {
    let mut v = vec![
        Case {
            name: "ex2 annulus".into(),
            d: Arc::new(|p: DVec2| -0.3 + (0.7 - p.length()).abs()),
            h0: 0.1,
            bbox: [-1.0, -1.0, 1.0, 1.0],
            fixed: vec![],
            size: None,
        },
        Case {
            name: "ex1c disk".into(),
            d: Arc::new(|p: DVec2| p.length() - 1.0),
            h0: 0.1,
            bbox: [-1.0, -1.0, 1.0, 1.0],
            fixed: vec![],
            size: None,
        },
        Case {
            name: "ellipse (level set)".into(),
            d: Arc::new(|p: DVec2| p.x * p.x / 4.0 + p.y * p.y - 1.0),
            h0: 0.2,
            bbox: [-2.0, -1.0, 2.0, 1.0],
            fixed: vec![],
            size: None,
        },
        Case {
            name: "ex3b graded".into(),
            d: Arc::new(|p: DVec2| rect(p, -1.0, 1.0, -1.0, 1.0).max(0.5 - p.length())),
            h0: 0.05,
            bbox: [-1.0, -1.0, 1.0, 1.0],
            fixed: vec![[-1.0, -1.0], [-1.0, 1.0], [1.0, -1.0], [1.0, 1.0]],
            size: Some(Arc::new(|p: DVec2| 0.05 + 0.3 * (p.length() - 0.5))),
        },
    ];
    // A family of flowers r < a + b cos(k theta) (level sets), of several sizes.
    for (k, a, b, h0) in [(3, 0.8, 0.15, 0.08), (5, 0.7, 0.1, 0.06), (4, 0.9, 0.2, 0.1)] {
        v.push(Case {
            name: format!("flower k={k} a={a} b={b}"),
            d: Arc::new(move |p: DVec2| p.length() - (a + b * (k as f64 * p.y.atan2(p.x)).cos())),
            h0,
            bbox: [-1.2, -1.2, 1.2, 1.2],
            fixed: vec![],
            size: None,
        });
    }
    // Rotated ellipses (level sets) with a circular hole.
    for (angle, hole) in [(0.3, 0.3), (1.1, 0.2)] {
        let (c, s) = ((angle * PI / 2.0_f64).cos(), (angle * PI / 2.0_f64).sin());
        v.push(Case {
            name: format!("rotated ellipse {angle}, hole {hole}"),
            d: Arc::new(move |p: DVec2| {
                let (x, y) = (c * p.x + s * p.y, -s * p.x + c * p.y);
                (x * x / 1.44 + y * y / 0.49 - 1.0).max(hole - p.length())
            }),
            h0: 0.08,
            bbox: [-1.3, -1.3, 1.3, 1.3],
            fixed: vec![],
            size: None,
        });
    }
    v
}

fn square_with_hole() -> Case {
    Case {
        name: "ex3a square with hole, corners fixed".into(),
        d: Arc::new(|p: DVec2| rect(p, -1.0, 1.0, -1.0, 1.0).max(0.4 - p.length())),
        h0: 0.15,
        bbox: [-1.0, -1.0, 1.0, 1.0],
        fixed: vec![[-1.0, -1.0], [-1.0, 1.0], [1.0, -1.0], [1.0, 1.0]],
        size: None,
    }
}

#[test]
fn perturbed_domains_mesh_at_the_same_quality() {
    check(cases());
}

/// With d + 1e-12 x the fixed corners (1, +-1) are 1e-12 outside the shifted side x = 1 - 1e-12.
/// The mesh used to end with a boundary sliver there (q 2.6e-10, a node 1e-12 inside the
/// chord from the corner); the force step now keeps triangles from turning flat and flat
/// boundary ears are peeled.
#[test]
fn fixed_corners_a_hair_off_the_boundary_mesh_at_the_same_quality() {
    check(vec![square_with_hole()]);
}

fn check(cases: Vec<Case>) {
    println!("| case | eps | vertices | q min | q mean |");
    println!("|---|---|---|---|---|");
    let mut failures = Vec::new();
    for case in cases {
        let (mut qmins, mut qmeans) = (Vec::new(), Vec::new());
        for eps in EPS {
            let d = case.d.clone();
            let domain = move |p: DVec2| d(p) + eps * p.x;
            let b = case.bbox;
            let mut o = Options2::uniform(case.h0, [b[0], b[1]], [b[2], b[3]]).with_fixed(case.fixed.iter().copied());
            if let Some(h) = &case.size {
                let h = h.clone();
                o = o.with_size(move |p| h(p));
            }
            let out = mesh_2d(&domain, &o).unwrap_or_else(|e| panic!("{}: {e}", case.name));
            let q = &out.report.quality;
            println!("| {} | {eps:e} | {} | {:.4} | {:.4} |", case.name, out.mesh.num_vertices(), q.q_min, q.q_mean);
            qmins.push(q.q_min);
            qmeans.push(q.q_mean);
        }
        let spread = |v: &[f64]| {
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max) - v.iter().copied().fold(f64::INFINITY, f64::min)
        };
        let (sm, sq) = (spread(&qmeans), spread(&qmins));
        println!("| {} | spread | | {sq:.4} | {sm:.4} |", case.name);
        if sm > Q_MEAN_SPREAD || sq > Q_MIN_SPREAD {
            failures.push(format!(
                "{}: q mean spread {sm:.4} (max {Q_MEAN_SPREAD}), q min spread {sq:.4} (max {Q_MIN_SPREAD})",
                case.name
            ));
        }
    }
    assert!(failures.is_empty(), "quality hangs on perturbations of 1e-12 to 1e-5:\n{}", failures.join("\n"));
}
