//! The 3-D mesher on the two examples (the seed's unit ball and the cylinder minus a
//! ball with a graded size), each printing its row of the quality table of docs/quality.md and
//! checking the targets there. Targets not reached are separate `#[ignore]` tests holding the
//! measured figure; the thresholds themselves are never loosened.

use glam::DVec3;
use std::f64::consts::PI;
use trussmesh::geometry::{difference, Ball, Cylinder, Implicit3};
use trussmesh::mesher::{boundary_deviation_3d, mesh_3d, size_deviation_3d, MeshOutput3, Options3};
use trussmesh::topology::{Level, VertexTag};
use trussmesh::Error;

struct Row {
    out: MeshOutput3,
    h0: f64,
    size_dev: f64,
    bdev: f64,
    vol_err: f64,
}

fn ball() -> (Ball, Options3) {
    (Ball::new([0.0, 0.0, 0.0], 1.0), Options3::uniform(0.15, [-1.1; 3], [1.1; 3]))
}

fn cyl_minus_ball() -> (impl Implicit3, Options3, f64) {
    let d = difference(Cylinder::new(1.0, -1.0, 1.0), Ball::new([0.0, 0.0, 0.0], 0.5));
    let opts = Options3::uniform(0.1, [-1.1; 3], [1.1; 3]).with_size(|p: DVec3| (4.0 * p.length() - 1.0).min(2.0));
    (d, opts, 2.0 * PI - 4.0 / 3.0 * PI * 0.125)
}

fn measure(name: &str, domain: &dyn Implicit3, opts: &Options3, exact_volume: f64) -> Row {
    let out = mesh_3d(domain, opts).expect("meshing succeeds");
    let m = &out.mesh;
    m.validate(Level::Geometry).expect("valid mesh, every tet positive (exact)");
    let h = opts.size.clone();
    let size_dev = size_deviation_3d(m, &|p: DVec3| h.as_ref().map_or(1.0, |f| f(p)));
    let row = Row {
        h0: opts.h0,
        size_dev,
        bdev: boundary_deviation_3d(m, domain) / opts.h0,
        vol_err: (m.volume() - exact_volume).abs() / exact_volume,
        out,
    };
    let q = &row.out.report.quality;
    println!("| example | nodes | tets | min dihedral | max dihedral | rr min | rr mean | size dev | max |d|/h0 | volume err | iterations | seconds |");
    println!(
        "| {name} | {} | {} | {:.1} | {:.1} | {:.3} | {:.4} | {:.1}% | {:.1e} | {:.2}% | {} | {:.2} |",
        q.vertices,
        q.tets,
        q.dihedral_min,
        q.dihedral_max,
        q.rr_min,
        q.rr_mean,
        100.0 * row.size_dev,
        row.bdev,
        100.0 * row.vol_err,
        row.out.report.iterations,
        row.out.report.seconds
    );
    println!("{}", row.out.report);
    row
}

/// The targets every run must meet (validity, boundary, volume).
fn check_basic(r: &Row) {
    assert!(r.out.mesh.tet_ids().all(|t| r.out.mesh.tet_volume(t) > 0.0), "no inverted or flat tet");
    assert!(r.bdev <= 1e-3, "boundary nodes within 1e-3 h0 of d = 0: {:.2e} h0", r.bdev);
    assert_eq!(r.out.report.boundary_nodes_off, 0);
    assert!(r.vol_err <= 0.01, "volume within 1%: {:.3}%", 100.0 * r.vol_err);
    let _ = r.h0;
}

/// The element-quality targets of the issue (better than every generator it lists).
fn check_quality(r: &Row) {
    let q = &r.out.report.quality;
    assert!(q.dihedral_min >= 26.0, "minimum dihedral {:.2} >= 26", q.dihedral_min);
    assert!(q.dihedral_max <= 137.0, "maximum dihedral {:.2} <= 137", q.dihedral_max);
}

fn check_mean(r: &Row) {
    let q = &r.out.report.quality;
    assert!(q.rr_mean >= 0.88, "mean radius ratio {:.4} >= 0.88", q.rr_mean);
}

fn check_size(r: &Row) {
    assert!(r.size_dev <= 0.09, "size deviation {:.2}% <= 9%", 100.0 * r.size_dev);
}

/// Every target of the issue.
fn check_all(r: &Row) {
    check_basic(r);
    check_quality(r);
    check_mean(r);
    check_size(r);
}

#[test]
fn unit_ball_h015() {
    let (d, o) = ball();
    check_all(&measure("unit ball, h0 = 0.15", &d, &o, 4.0 / 3.0 * PI));
}

/// Quality at scale (issue 22): the unit ball at about 3x10^5 tets keeps a minimum dihedral of
/// at least 37 degrees, with the box touching the ball (as in the seed's examples) and with a
/// margin around it. With the box touching, a node squeezed between the boundary and the next
/// layer held the worst tets at 35.0 degrees until the polish collapsed such crowded spots.
#[test]
fn unit_ball_at_3e5_tets_keeps_37_degrees() {
    for half in [1.0, 1.1] {
        let opts = Options3::uniform(0.05, [-half; 3], [half; 3]);
        let r =
            measure(&format!("unit ball, h0 = 0.05, box +-{half}"), &Ball::new([0.0; 3], 1.0), &opts, 4.0 / 3.0 * PI);
        check_basic(&r);
        check_mean(&r);
        let q = &r.out.report.quality;
        assert!(q.tets >= 250_000, "{} tets", q.tets);
        assert!(q.dihedral_min >= 37.0, "minimum dihedral {:.2} >= 37 at {} tets", q.dihedral_min, q.tets);
    }
}

/// The same ball given as an expression, as `trussmesh mesh --dim 3 --domain ...` gives it
/// (gradients by finite differences): the same targets. Its run differs from the library
/// ball's, and once met a worst tet that only the perturbations of a second polish round moved.
#[test]
fn unit_ball_from_an_expression_h015() {
    let expr = trussmesh::expr::Expr::parse("sqrt(x^2+y^2+z^2)-1").expect("parses");
    let d = trussmesh::expr::ExprImplicit3 { expr, distance: true };
    let (_, o) = ball();
    check_all(&measure("unit ball as an expression, h0 = 0.15", &d, &o, 4.0 / 3.0 * PI));
}

#[test]
fn cylinder_minus_ball_graded() {
    let (d, o, v) = cyl_minus_ball();
    let r = measure("cylinder minus ball, h = min(4|x| - 1, 2), h0 = 0.1", &d, &o, v);
    check_basic(&r);
    check_quality(&r);
    check_size(&r);
}

/// The same domain at h0 = 0.09: here a flat tet folded at the rim stayed (0.02 to 179.9
/// degrees) while the local removal refused it, until squashed tets stuck at two checks in a
/// row were carved together. The validity and element-quality targets.
#[test]
fn cylinder_minus_ball_h009_has_no_stuck_sliver() {
    let (d, mut o, v) = cyl_minus_ball();
    o.h0 = 0.09;
    let r = measure("cylinder minus ball, h = min(4|x| - 1, 2), h0 = 0.09", &d, &o, v);
    check_basic(&r);
    check_quality(&r);
}

/// The cube as the command line gives it (`max(max(abs(x),abs(y)),abs(z))-1`), with its corners
/// fixed and without, at the sizes that showed a defect before the start put points on sharp
/// edges: at h0 = 0.17 the boundary folded on a face, where nodes near an edge were projected
/// onto one face or the other, and flat tets stayed (0.0 / 180.0 degrees; 24.7 / 141.6 at
/// h0 = 0.15). Every target of the issue, the volume within 1% included.
#[test]
fn cube_sharp_edges() {
    let expr = trussmesh::expr::Expr::parse("max(max(abs(x),abs(y)),abs(z))-1").expect("parses");
    let d = trussmesh::expr::ExprImplicit3 { expr, distance: true };
    let corners: Vec<[f64; 3]> = (0..8).map(|i| [0, 1, 2].map(|k| if i >> k & 1 == 1 { 1.0 } else { -1.0 })).collect();
    for h0 in [0.17, 0.15, 0.25] {
        for fixed in [true, false] {
            let mut o = Options3::uniform(h0, [-1.1; 3], [1.1; 3]);
            if fixed {
                o = o.with_fixed(corners.clone());
            }
            let name = format!("cube, h0 = {h0}, corners {}", if fixed { "fixed" } else { "free" });
            let r = measure(&name, &d, &o, 8.0);
            check_all(&r);
        }
    }
}

/// Boxes turned so that no edge lies in a plane of the start lattice (about z, and about a
/// skew axis): the polish once smoothed a boundary node so that its faces lay over a face two
/// rings away beside an edge (every tet positive, every edge ring winding once), and the run
/// ended in an internal error (SelfIntersection) after 99 s at h0 0.08. Each must mesh valid
/// and meet every target.
#[test]
fn turned_boxes_mesh_valid() {
    turned_boxes(&[("about z by 36.87 deg", 0.6435, 0.0, 0.08), ("about z and x", 0.5, 0.7, 0.1)]);
}

/// The box turned by 15 degrees in the box +-1.25 folds its boundary in the first two runs
/// (an internal error before the third); the third, from a start lattice shifted by a third of
/// a side, meshes it.
#[test]
fn box_turned_by_15_degrees_meshes_valid() {
    turned_boxes(&[("about z by 15 deg", 0.2618, 0.0, 0.1)]);
}

fn turned_boxes(cases: &[(&str, f64, f64, f64)]) {
    for &(name, yaw, pitch, h0) in cases {
        // u = Rx(pitch) Rz(yaw) p; the box |u|_inf <= 0.7.
        let (cy, sy, cp, sp) = (yaw.cos(), yaw.sin(), pitch.cos(), pitch.sin());
        let rows = [[cy, -sy, 0.0], [cp * sy, cp * cy, -sp], [sp * sy, sp * cy, cp]];
        let u: Vec<String> = rows.iter().map(|r| format!("abs({}*x+{}*y+{}*z)", r[0], r[1], r[2])).collect();
        let text = format!("max(max({},{}),{})-0.7", u[0], u[1], u[2]);
        let expr = trussmesh::expr::Expr::parse(&text).expect("parses");
        let d = trussmesh::expr::ExprImplicit3 { expr, distance: true };
        let o = Options3::uniform(h0, [-1.25; 3], [1.25; 3]);
        let r = measure(&format!("box turned {name}, h0 = {h0}"), &d, &o, 1.4f64.powi(3));
        check_all(&r);
    }
}

/// The points the start holds on sharp edges lie on the cube's edges (two coordinates at +-1),
/// about one target length apart, on all twelve edges, and on all eight corners (three at
/// +-1); a ball has none.
#[test]
fn sharp_edge_points_lie_on_the_edges() {
    let expr = trussmesh::expr::Expr::parse("max(max(abs(x),abs(y)),abs(z))-1").expect("parses");
    let cube = trussmesh::expr::ExprImplicit3 { expr, distance: true };
    let h0 = 0.2;
    let out = mesh_3d(&cube, &Options3::uniform(h0, [-1.1; 3], [1.1; 3])).expect("meshes");
    let m = &out.mesh;
    let held: Vec<DVec3> = m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed).map(|v| m.pos(v)).collect();
    assert_eq!(held.len(), out.report.feature_points);
    let on = |x: f64| (x.abs() - 1.0).abs() < 1e-9;
    let mut per_edge = std::collections::BTreeMap::new();
    let mut corners = 0;
    for p in &held {
        let c = p.to_array();
        let at = c.iter().filter(|&&x| on(x)).count();
        assert!(at >= 2, "{p:?} is on an edge");
        if at == 3 {
            corners += 1;
            continue;
        }
        let key: Vec<i32> = c.iter().map(|&x| if on(x) { x.signum() as i32 } else { 0 }).collect();
        *per_edge.entry(key).or_insert(0usize) += 1;
    }
    // Each edge is 2 long: about 2 / h0 points, fewer near the corners.
    assert_eq!(per_edge.len(), 12, "every edge: {per_edge:?}");
    assert_eq!(corners, 8, "every corner");
    assert!(per_edge.values().all(|&n| (6..=10).contains(&n)), "{per_edge:?}");
    let ball = Ball::new([0.0, 0.0, 0.0], 1.0);
    let out = mesh_3d(&ball, &Options3::uniform(h0, [-1.1; 3], [1.1; 3])).expect("meshes");
    assert_eq!(out.report.feature_points, 0);
    // Turned off, nothing is held.
    let out = mesh_3d(&cube, &Options3::uniform(h0, [-1.1; 3], [1.1; 3]).with_sharp_edges(false)).expect("meshes");
    assert_eq!(out.report.feature_points, 0);
    assert!(out.mesh.vertex_ids().all(|v| out.mesh.tag(v) != VertexTag::Fixed));
}

/// On a curved edge (the rims of a cylinder written with max(), as on the command line) the
/// held points lie on the edge itself: the tangent planes are taken ever closer to it.
#[test]
fn points_on_curved_edges_lie_on_them() {
    let expr = trussmesh::expr::Expr::parse("max(sqrt(x^2+y^2)-1, abs(z)-1)").expect("parses");
    let cyl = trussmesh::expr::ExprImplicit3 { expr, distance: true };
    let out = mesh_3d(&cyl, &Options3::uniform(0.15, [-1.1; 3], [1.1; 3])).expect("meshes");
    let m = &out.mesh;
    let held: Vec<DVec3> = m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed).map(|v| m.pos(v)).collect();
    // Greedy thinning at one target length leaves gaps below two: at least 4 pi / 0.3 points.
    assert!(held.len() >= 42, "two rims of length 2 pi at h0 = 0.15: {} points", held.len());
    for p in &held {
        let (r, z) = (p.truncate().length(), p.z.abs());
        assert!((r - 1.0).abs() < 1e-6 && (z - 1.0).abs() < 1e-6, "{p:?} on a rim (r {r}, |z| {z})");
    }
}

#[test]
fn cylinder_minus_ball_mean_quality() {
    let (d, o, v) = cyl_minus_ball();
    let r = measure("cylinder minus ball, h = min(4|x| - 1, 2), h0 = 0.1", &d, &o, v);
    check_mean(&r);
}

#[test]
fn same_input_same_output() {
    let d = difference(Cylinder::new(1.0, -1.0, 1.0), Ball::new([0.0, 0.0, 0.0], 0.5));
    let o = Options3::uniform(0.3, [-1.1; 3], [1.1; 3]).with_size(|p: DVec3| (4.0 * p.length() - 1.0).min(2.0));
    let a = mesh_3d(&d, &o).expect("meshes").mesh.to_arrays();
    let b = mesh_3d(&d, &o).expect("meshes").mesh.to_arrays();
    assert!(a.cells.len() > 100, "a real mesh: {} tets", a.cells.len());
    assert_eq!(a.cells, b.cells, "same tets");
    let bits = |p: &[DVec3]| p.iter().flat_map(|q| q.to_array().map(f64::to_bits)).collect::<Vec<u64>>();
    assert_eq!(bits(&a.points), bits(&b.points), "same coordinates, bit for bit");
}

#[test]
fn bad_input_is_a_typed_error() {
    let b = Ball::new([0.0, 0.0, 0.0], 1.0);
    let box3 = ([-1.1; 3], [1.1; 3]);
    let err = |d: &dyn Implicit3, o: &Options3| mesh_3d(d, o).expect_err("must fail");
    assert!(matches!(err(&b, &Options3::uniform(0.0, box3.0, box3.1)), Error::BadSize(_)));
    assert!(matches!(err(&b, &Options3::uniform(-1.0, box3.0, box3.1)), Error::BadSize(_)));
    assert!(matches!(err(&b, &Options3::uniform(f64::NAN, box3.0, box3.1)), Error::BadSize(_)));
    assert!(matches!(err(&b, &Options3::uniform(0.2, [1.0; 3], [-1.0; 3])), Error::BadBox(_)));
    assert!(matches!(err(&b, &Options3::uniform(0.2, [f64::NAN; 3], [1.0; 3])), Error::BadBox(_)));
    // Empty: the ball lies outside the box.
    let far = Ball::new([10.0, 10.0, 10.0], 1.0);
    assert!(matches!(err(&far, &Options3::uniform(0.2, box3.0, box3.1)), Error::EmptyDomain(_)));
    // Non-finite distance or size.
    struct Nan;
    impl Implicit3 for Nan {
        fn value(&self, p: DVec3) -> f64 {
            if p.x > 0.5 {
                f64::NAN
            } else {
                p.length() - 1.0
            }
        }
    }
    assert!(matches!(err(&Nan, &Options3::uniform(0.2, box3.0, box3.1)), Error::NonFinite { .. }));
    let o = Options3::uniform(0.2, box3.0, box3.1).with_size(|p: DVec3| if p.y > 0.3 { f64::INFINITY } else { 1.0 });
    assert!(matches!(err(&b, &o), Error::NonFinite { .. }));
    let o = Options3::uniform(0.2, box3.0, box3.1).with_size(|p: DVec3| p.x);
    assert!(matches!(err(&b, &o), Error::BadSize(_)));
    // Past the element limit, before anything large is built.
    let o = Options3::uniform(0.001, box3.0, box3.1);
    assert!(matches!(err(&b, &o), Error::TooManyElements { .. }));
    let o = Options3::uniform(0.2, box3.0, box3.1).with_max_elements(100);
    assert!(matches!(err(&b, &o), Error::TooManyElements { .. }));
    // A fixed point outside the box.
    let o = Options3::uniform(0.2, box3.0, box3.1).with_fixed([[5.0, 0.0, 0.0]]);
    assert!(matches!(err(&b, &o), Error::Invalid(_)));
}

#[test]
fn fixed_points_stay_and_the_cap_returns_a_valid_mesh() {
    let b = Ball::new([0.0, 0.0, 0.0], 1.0);
    let fixed = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    let o = Options3::uniform(0.25, [-1.1; 3], [1.1; 3]).with_fixed(fixed).with_max_iter(5);
    let out = mesh_3d(&b, &o).expect("meshes");
    out.mesh.validate(Level::Geometry).expect("valid");
    assert!(!out.report.converged, "five iterations hit the cap");
    for f in fixed {
        let f = DVec3::from(f);
        assert!(out.mesh.vertex_ids().any(|v| out.mesh.pos(v) == f), "fixed point {f:?} is a vertex");
    }
}
