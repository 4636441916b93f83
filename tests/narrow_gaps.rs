//! Sizes wider than the domain is narrow: holes near the walls of a square with a size that
//! grows past the gaps between them. The start has no node deep enough in such a gap to
//! survive the carve, so the first run leaves the part out; `mesh_2d` then meshes the domain
//! again with the size capped by the local feature size (two elements across), and the whole
//! domain is meshed, with a note saying the size was capped.

use std::f64::consts::PI;
use std::sync::Arc;
use trussmesh::expr::{Expr, ExprImplicit2};
use trussmesh::glam::DVec2;
use trussmesh::{mesh_2d, Options2};

/// A square [-1, 1]^2 with round holes (centre, radius), meshed with the relative size `size`
/// at h0; returns the mesh's area over the exact area, q min, the notes and the triangles.
fn run(holes: &[(f64, f64, f64)], size: &str, h0: f64) -> (f64, f64, Vec<String>, usize) {
    let cut: Vec<String> = holes.iter().map(|(x, y, r)| format!("dcircle(x,y,{x},{y},{r})")).collect();
    let mut holes_d = cut[0].clone();
    for c in &cut[1..] {
        holes_d = format!("min({holes_d},{c})");
    }
    let dom = format!("max(drectangle(x,y,-1,1,-1,1),-{holes_d})");
    let domain = ExprImplicit2::new(Expr::parse(&dom).unwrap());
    let size = Expr::parse(size).unwrap();
    let mut opts = Options2::uniform(h0, [-1.0, -1.0], [1.0, 1.0]);
    opts.size = Some(Arc::new(move |p: DVec2| size.eval(p.x, p.y, 0.0)));
    let out = mesh_2d(&domain, &opts).expect("meshes");
    let area: f64 = out
        .mesh
        .face_ids()
        .map(|f| {
            let [a, b, c] = out.mesh.face_points(f);
            0.5 * (b - a).perp_dot(c - a)
        })
        .sum();
    let exact = 4.0 - holes.iter().map(|h| PI * h.2 * h.2).sum::<f64>();
    (area / exact, out.report.quality.q_min, out.report.notes, out.mesh.num_faces())
}

/// Prints one row; returns what misses: any part left out, an area off by more than `tol`
/// (relative: chords of holes meshed at sizes near their radius bulge into them, 0.8% at 0.3 on
/// a radius of 0.2), or q min below 0.3 (the floor under which the report must warn).
fn check(holes: &[(f64, f64, f64)], size: &str, h0: f64, tol: f64) -> Option<String> {
    let (ratio, q, notes, n) = run(holes, size, h0);
    let capped = notes.iter().any(|n| n.contains("capped by the local feature size"));
    println!("| {} | {size} | {h0} | {n} | {ratio:.5} | {q:.4} | {capped} |", holes.len());
    let left = notes.iter().filter(|n| n.contains("is not meshed")).count();
    ((ratio - 1.0).abs() > tol || left > 0 || q < 0.3)
        .then(|| format!("{size}: area ratio {ratio:.5}, q min {q:.4}, notes {notes:?}"))
}

/// Holes (centre x, y, radius), the relative size, h0.
type Case = (&'static [(f64, f64, f64)], &'static str, f64);

const HEADER: &str = "| holes | size | h0 | triangles | area / exact | q min | capped |\n|---|---|---|---|---|---|---|";

/// The first two left parts out before the size was capped (an internal error before that: a
/// node slid over a piece the start had cut off).
#[test]
fn sizes_wider_than_the_gaps_still_mesh_the_whole_domain() {
    let cases: [Case; 2] = [
        (&[(-0.5, -0.5, 0.2), (0.5, 0.5, 0.2), (0.5, -0.5, 0.1)], "0.02+0.3*abs(sqrt(x^2+y^2)-0.3)", 0.02),
        (&[(-0.6, -0.6, 0.3), (0.6, 0.6, 0.3)], "1+8*(x+1)", 0.01),
    ];
    println!("{HEADER}");
    let bad: Vec<String> = cases.into_iter().filter_map(|(holes, size, h0)| check(holes, size, h0, 0.01)).collect();
    assert!(bad.is_empty(), "{bad:#?}");
}

/// Two cases not reached:
/// - a gap of 0.05 between a hole and the wall where elements are 0.7 wide: the start leaves it
///   out, and the coverage check does not see it (it counts only samples deeper than a fifth of
///   the local element size, so that chords of curved boundaries do not count), so the size is
///   not capped and 0.5% of the area is missing;
/// - the wedge between a square's corner and a hole 0.17 from it, where elements are 0.27
///   wide: left out (2 samples at 0.015) by the first run and by the run with the capped size.
#[test]
#[ignore = "not reached: a gap narrower than two fifths of the local element size is left out unseen (area 0.995 of the exact); a corner wedge by a hole is left out even with the capped size"]
fn gaps_far_narrower_than_the_elements_are_meshed() {
    println!("{HEADER}");
    let miss: Vec<String> = [
        check(&[(0.75, 0.0, 0.2)], "1+20*(x+1)^2", 0.01, 0.002),
        check(&[(-0.7, 0.7, 0.25), (0.0, -0.75, 0.2)], "1+10*(x^2+y^2)", 0.015, 0.01),
    ]
    .into_iter()
    .flatten()
    .collect();
    assert!(miss.is_empty(), "{miss:#?}");
}
