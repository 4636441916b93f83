//! Every 2-D example of the seed (section 2.5 and figure 3-3) meshed by the local strategy,
//! each printing its row of the quality table and checking the thresholds of docs/quality.md.

use glam::DVec2;
use trussmesh::gallery::EXAMPLES;
use trussmesh::geometry::{Circle, Implicit2};
use trussmesh::mesher::{area, boundary_deviation, mesh_2d, size_deviation, Options2, Strategy};
use trussmesh::topology::{Level, VertexTag};
use trussmesh::{Error, StopReason};

struct Row {
    name: String,
    nodes: usize,
    tris: usize,
    q_min: f64,
    q_mean: f64,
    size_dev: f64,
    bdev: f64,
    area_err: Option<f64>,
    iterations: usize,
    off: usize,
}

fn run(name: &str) -> Row {
    let ex = EXAMPLES.iter().find(|e| e.name == name).expect("example exists");
    let (domain, opts) = ex.build().expect("example builds");
    let out = mesh_2d(&domain, &opts).expect("meshing succeeds");
    let m = &out.mesh;
    m.validate(Level::Geometry).expect("valid mesh, every triangle positive (exact)");
    let h = opts.size.clone();
    let size_dev = size_deviation(m, &|p: DVec2| h.as_ref().map_or(1.0, |f| f(p)));
    let row = Row {
        name: name.into(),
        nodes: m.num_vertices(),
        tris: m.num_faces(),
        q_min: out.report.quality.q_min,
        q_mean: out.report.quality.q_mean,
        size_dev,
        bdev: boundary_deviation(m, &domain) / opts.h0,
        area_err: ex.exact_area().map(|a| (area(m) - a).abs() / a),
        iterations: out.report.iterations,
        off: out.report.boundary_nodes_off,
    };
    println!("| example | nodes | triangles | q min | q mean | size dev | max |d|/h0 | area err | iterations |");
    println!(
        "| {} | {} | {} | {:.3} | {:.4} | {:.3} | {:.1e} | {} | {} |",
        row.name,
        row.nodes,
        row.tris,
        row.q_min,
        row.q_mean,
        row.size_dev,
        row.bdev,
        row.area_err.map_or("-".into(), |e| format!("{:.2}%", 100.0 * e)),
        row.iterations
    );
    // Fixed points stay exactly where they were given.
    for p in &opts.fixed {
        assert!(m.vertices().any(|(_, v)| v.tag == VertexTag::Fixed && v.pos == *p), "fixed point {p:?} kept");
    }
    row
}

fn check(name: &str, min_q: Option<f64>) {
    let r = run(name);
    let h0 = {
        let ex = EXAMPLES.iter().find(|e| e.name == name).unwrap();
        ex.build().unwrap().1.h0
    };
    assert!(r.bdev <= 1e-3, "{name}: boundary nodes {:.2e} h0 from the boundary", r.bdev);
    assert_eq!(r.off, 0, "{name}: the report counts boundary nodes off the boundary");
    if let Some(e) = r.area_err {
        if h0 <= 0.2 {
            assert!(e <= 0.01, "{name}: area error {:.3}%", 100.0 * e);
        }
    }
    if let Some(q) = min_q {
        assert!(r.q_min >= q, "{name}: q min {:.3} below {q}", r.q_min);
    }
    assert!(r.q_mean >= 0.97, "{name}: q mean {:.4} below 0.97", r.q_mean);
    assert!(r.size_dev <= 0.04, "{name}: size deviation {:.3} above 4%", r.size_dev);
}

#[test]
fn ex1a_circle_h04() {
    check("ex1a", Some(0.7));
}
#[test]
fn ex1b_circle_h02() {
    check("ex1b", Some(0.7));
}
#[test]
fn ex1c_circle_h01() {
    check("ex1c", Some(0.7));
}
#[test]
fn ex2_circle_with_hole() {
    check("ex2", Some(0.7));
}
#[test]
fn ex3a_square_with_hole() {
    check("ex3a", Some(0.7));
}
#[test]
fn ex3b_square_with_hole_graded() {
    check("ex3b", Some(0.7));
}
#[test]
fn ex4_hexagons() {
    check("ex4", Some(0.7));
}
#[test]
fn ex5_geometric_adaptivity() {
    check("ex5", Some(0.7));
}
#[test]
fn ex6_superellipse_ring() {
    check("ex6", Some(0.7));
}
#[test]
fn ex7_cosine_and_quartic() {
    check("ex7", Some(0.7));
}
#[test]
fn ex8_sharp_corner() {
    // A sharp corner: no minimum-quality threshold, as in the seed.
    check("ex8", None);
}
#[test]
fn ellipse_implicit() {
    check("ellipse", Some(0.7));
}

#[test]
fn unit_disk_h005_beats_the_classic_algorithm() {
    let disk = Circle::new([0.0, 0.0], 1.0);
    let opts = Options2::uniform(0.05, [-1.0, -1.0], [1.0, 1.0]);
    let local = mesh_2d(&disk, &opts).unwrap();
    let classic = mesh_2d(&disk, &opts.clone().with_strategy(Strategy::GlobalDelaunay)).unwrap();
    local.mesh.validate(Level::Geometry).unwrap();
    let dev_l = size_deviation(&local.mesh, &|_| 1.0);
    let dev_c = size_deviation(&classic.mesh, &|_| 1.0);
    let (ql, qc) = (local.report.quality, classic.report.quality);
    println!("| strategy | nodes | q min | q mean | size dev | seconds |");
    println!(
        "| local | {} | {:.4} | {:.4} | {:.4} | {:.3} |",
        ql.vertices, ql.q_min, ql.q_mean, dev_l, local.report.seconds
    );
    println!(
        "| classic | {} | {:.4} | {:.4} | {:.4} | {:.3} |",
        qc.vertices, qc.q_min, qc.q_mean, dev_c, classic.report.seconds
    );
    assert!(ql.q_mean >= 0.994, "q mean {}", ql.q_mean);
    assert!(ql.q_min >= 0.85, "q min {}", ql.q_min);
    assert!(dev_l <= 0.016, "size deviation {dev_l}");
    assert!(boundary_deviation(&local.mesh, &disk) <= 1e-3 * 0.05);
}

#[test]
fn same_input_same_output_bit_for_bit() {
    for name in ["ex3b", "ex5"] {
        let ex = EXAMPLES.iter().find(|e| e.name == name).unwrap();
        let (domain, opts) = ex.build().unwrap();
        let a = mesh_2d(&domain, &opts).unwrap().mesh.to_arrays();
        let b = mesh_2d(&domain, &opts).unwrap().mesh.to_arrays();
        let bits = |v: &Vec<DVec2>| v.iter().map(|p| (p.x.to_bits(), p.y.to_bits())).collect::<Vec<_>>();
        assert_eq!(bits(&a.points), bits(&b.points), "{name}: points differ between runs");
        assert_eq!(a.cells, b.cells, "{name}: triangles differ between runs");
    }
}

#[test]
fn iteration_cap_returns_a_valid_mesh_with_a_report() {
    let disk = Circle::new([0.0, 0.0], 1.0);
    let out = mesh_2d(&disk, &Options2::uniform(0.1, [-1.0, -1.0], [1.0, 1.0]).with_max_iter(3)).unwrap();
    assert!(!out.report.converged);
    assert_eq!(out.report.iterations, 3);
    assert_eq!(out.report.stop, StopReason::IterationCap { max_iter: 3 }, "{}", out.report.stop);
    out.mesh.validate(Level::Geometry).unwrap();
}

// ---------------------------------------------------------------- bad input

fn disk() -> Circle {
    Circle::new([0.0, 0.0], 1.0)
}
fn unit_box(h0: f64) -> Options2 {
    Options2::uniform(h0, [-1.0, -1.0], [1.0, 1.0])
}

#[test]
fn bad_h0() {
    for h0 in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = mesh_2d(&disk(), &unit_box(h0)).unwrap_err();
        assert!(matches!(e, Error::BadSize(_)), "{e}");
        assert!(e.to_string().contains("h0"), "{e}");
    }
}

#[test]
fn empty_or_inverted_box() {
    let e = mesh_2d(&disk(), &Options2::uniform(0.1, [1.0, -1.0], [-1.0, 1.0])).unwrap_err();
    assert!(matches!(e, Error::BadBox(_)), "{e}");
    let e = mesh_2d(&disk(), &Options2::uniform(0.1, [0.0, 0.0], [0.0, 1.0])).unwrap_err();
    assert!(matches!(e, Error::BadBox(_)), "{e}");
    let e = mesh_2d(&disk(), &Options2::uniform(0.1, [f64::NAN, 0.0], [1.0, 1.0])).unwrap_err();
    assert!(matches!(e, Error::BadBox(_)), "{e}");
}

#[test]
fn no_interior_point() {
    let far = Circle::new([10.0, 10.0], 1.0);
    let e = mesh_2d(&far, &unit_box(0.1)).unwrap_err();
    assert!(matches!(e, Error::EmptyDomain(_)), "{e}");
}

#[test]
fn non_finite_distance() {
    let nan_inside = |p: DVec2| if p.x > 0.5 { f64::NAN } else { p.length() - 1.0 };
    let e = mesh_2d(&nan_inside, &unit_box(0.1)).unwrap_err();
    assert!(matches!(e, Error::NonFinite { what: "the distance function", .. }), "{e}");
}

#[test]
fn bad_size_function() {
    let e = mesh_2d(&disk(), &unit_box(0.1).with_size(|p| if p.x > 0.0 { f64::INFINITY } else { 1.0 })).unwrap_err();
    assert!(matches!(e, Error::NonFinite { what: "the size function", .. }), "{e}");
    let e = mesh_2d(&disk(), &unit_box(0.1).with_size(|p| p.x)).unwrap_err();
    assert!(matches!(e, Error::BadSize(_)), "{e}");
    assert!(e.to_string().contains("positive"), "{e}");
}

#[test]
fn element_count_limit() {
    let e = mesh_2d(&disk(), &unit_box(1e-4).with_max_elements(1_000_000)).unwrap_err();
    match e {
        Error::TooManyElements { estimated, limit } => {
            assert_eq!(limit, 1_000_000);
            assert!(estimated > 100_000_000, "estimate {estimated}");
        }
        other => panic!("{other}"),
    }
}

#[test]
fn fixed_point_outside_the_domain() {
    let e = mesh_2d(&disk(), &unit_box(0.1).with_fixed([[0.99, 0.99]])).unwrap_err();
    assert!(matches!(e, Error::Invalid(_)), "{e}");
    assert!(e.to_string().contains("fixed point"), "{e}");
}

#[test]
fn domain_is_used_only_through_the_trait() {
    // A level set that is not a distance still meshes (first-order projections).
    struct Lens;
    impl Implicit2 for Lens {
        fn value(&self, p: DVec2) -> f64 {
            (p.x * p.x) / 0.8 + p.y * p.y * 2.0 - 1.0
        }
        fn is_distance(&self) -> bool {
            false
        }
    }
    let out = mesh_2d(&Lens, &Options2::uniform(0.1, [-1.0, -1.0], [1.0, 1.0])).unwrap();
    out.mesh.validate(Level::Geometry).unwrap();
    assert!(out.report.quality.q_mean > 0.95);
}

#[test]
fn classic_baseline_runs_every_example() {
    for ex in EXAMPLES {
        let (domain, opts) = ex.build().unwrap();
        if ex.internal.is_some() || ex.metric.is_some() {
            // The classic algorithm has neither: a clear error, not a mesh.
            let e = mesh_2d(&domain, &opts.with_strategy(Strategy::GlobalDelaunay)).unwrap_err();
            assert!(matches!(e, Error::Invalid(_)), "{}: {e}", ex.name);
            continue;
        }
        let out = mesh_2d(&domain, &opts.with_strategy(Strategy::GlobalDelaunay))
            .unwrap_or_else(|e| panic!("{}: {e}", ex.name));
        out.mesh.validate(Level::Geometry).unwrap_or_else(|e| panic!("{}: {e}", ex.name));
    }
}

#[test]
fn ex1_from_a_grid() {
    // Seed example 1 with d sampled on [-1.1, 1.1]^2 at spacing 0.1 and interpolated bilinearly.
    let circle = Circle::new([0.0, 0.0], 1.0);
    let grid = trussmesh::geometry::Grid2::sample(&circle, DVec2::new(-1.1, -1.1), DVec2::new(1.1, 1.1), 0.1).unwrap();
    let out = mesh_2d(&grid, &Options2::uniform(0.2, [-1.0, -1.0], [1.0, 1.0])).unwrap();
    let m = &out.mesh;
    m.validate(Level::Geometry).unwrap();
    let q = out.report.quality;
    // Boundary nodes lie on the interpolated zero set; against the true circle the error is
    // the interpolation error of a 0.1 grid.
    let bdev_grid = boundary_deviation(m, &grid);
    let bdev_true = boundary_deviation(m, &circle);
    println!(
        "| ex1 from a grid | {} | {} | {:.3} | {:.4} | grid {:.1e} h0, true circle {:.1e} |",
        q.vertices,
        q.triangles,
        q.q_min,
        q.q_mean,
        bdev_grid / 0.2,
        bdev_true
    );
    assert!(bdev_grid <= 1e-3 * 0.2);
    assert!(bdev_true <= 0.01, "bilinear interpolation error {bdev_true}");
    assert!(q.q_mean >= 0.97 && q.q_min >= 0.7, "{q:?}");
}

/// The plain square with its corners fixed, at sizes that once gave a grid of right triangles
/// (fixed points bent the start lattice) or corner islands the boundary slid over (area
/// above one): every mesh must cover the square exactly once, with good triangles.
#[test]
fn unit_square_with_fixed_corners() {
    use trussmesh::geometry::Rectangle;
    println!("| h0 | nodes | q min | q mean | area - 1 |");
    for h0 in [0.04, 0.05, 0.06, 0.07, 0.1, 0.15] {
        let opts =
            Options2::uniform(h0, [0.0, 0.0], [1.0, 1.0]).with_fixed([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        let out = mesh_2d(&Rectangle::cheap([0.0, 0.0], [1.0, 1.0]), &opts).expect("meshing succeeds");
        out.mesh.validate(Level::Geometry).expect("valid");
        let q = out.report.quality;
        let a = area(&out.mesh) - 1.0;
        println!("| {h0} | {} | {:.3} | {:.4} | {a:.1e} |", q.vertices, q.q_min, q.q_mean);
        assert!(a.abs() < 1e-9, "h0 {h0}: the mesh covers {a} more than the square");
        assert!(q.q_min >= 0.6, "h0 {h0}: q min {}", q.q_min);
        assert!(q.q_mean >= 0.95, "h0 {h0}: q mean {}", q.q_mean);
    }
}

/// A large plain start is refined on flat arrays; with a size function (here constant) the
/// start goes through the general refinement loop on the half-edge mesh. Both must carve the
/// same lattice, laid out the same way: the meshes before any force step (and the final
/// clean-up) are identical, bit for bit. (The force steps differ in rounding: the plain run
/// holds its lattice core and sums the rest scale of eq. 2.6 over the band plus the core's
/// constant share.)
#[test]
fn large_start_on_arrays_matches_the_general_refinement() {
    let disk = Circle::new([0.0, 0.0], 1.0);
    let h0 = 0.0075; // about 1.3x10^5 triangles: above the array start's threshold
    let plain = Options2::uniform(h0, [-1.0, -1.0], [1.0, 1.0]).with_max_iter(0);
    let sized = plain.clone().with_size(|_| 1.0);
    let a = mesh_2d(&disk, &plain).expect("plain start").mesh;
    let b = mesh_2d(&disk, &sized).expect("start with a size function").mesh;
    assert!(a.num_faces() > 100_000, "{} triangles", a.num_faces());
    let trussmesh::topology::MeshArrays { points: pa, cells: ta, .. } = a.to_arrays();
    let trussmesh::topology::MeshArrays { points: pb, cells: tb, .. } = b.to_arrays();
    assert_eq!(pa.len(), pb.len());
    assert!(pa.iter().zip(&pb).all(|(x, y)| x.x.to_bits() == y.x.to_bits() && x.y.to_bits() == y.y.to_bits()));
    assert_eq!(ta, tb);
}
