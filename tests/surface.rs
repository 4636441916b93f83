//! Surface meshes of implicit surfaces (seed section 3.6.1): the seed's figure 3-7 surface, a
//! sphere, a torus and a genus-2 surface, with the quality thresholds. Prints the table
//! kept in docs/quality.md.

use glam::DVec3;
use trussmesh::surface::{mesh_surface, SurfaceOptions, SurfaceOutput, SurfaceQuality};
use trussmesh::topology::Level;
use trussmesh::Error;

/// Seed eq. 3.27: the blending function of the smoothed set operations.
fn g_blend(s: f64, r: f64) -> f64 {
    if s <= r {
        4.0 * (s - r) * (s - r) * (9.0 * r / 4.0 - s) / (9.0 * r * r * r)
    } else {
        0.0
    }
}

/// Seed eq. 3.24-3.26: a ball of radius 1.2 minus a cylinder of radius 0.5 along y, smoothed
/// with R = 0.5. A ball with a hole through it: genus 1.
fn fig37(p: DVec3) -> f64 {
    let d1 = p.length() - 1.2;
    let d2 = (p.x * p.x + p.z * p.z).sqrt() - 0.5;
    g_blend(-d1, 0.5) + g_blend(d2, 0.5) - 1.0
}

fn sphere(p: DVec3) -> f64 {
    p.length() - 1.0
}

fn torus_at(p: DVec3, c: DVec3, big: f64, small: f64) -> f64 {
    let q = p - c;
    let rho = (q.x * q.x + q.y * q.y).sqrt() - big;
    (rho * rho + q.z * q.z).sqrt() - small
}

fn torus(p: DVec3) -> f64 {
    torus_at(p, DVec3::ZERO, 1.0, 0.3)
}

/// Two tori (R = 1, r = 0.3) centred 1.8 apart, joined by a polynomial smooth minimum of
/// width 0.2: a double torus, genus 2.
fn double_torus(p: DVec3) -> f64 {
    let a = torus_at(p, DVec3::new(-0.9, 0.0, 0.0), 1.0, 0.3);
    let b = torus_at(p, DVec3::new(0.9, 0.0, 0.0), 1.0, 0.3);
    let k = 0.2;
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    b + (a - b) * h - k * h * (1.0 - h)
}

struct Case {
    name: &'static str,
    out: SurfaceOutput,
    euler: i64,
    h0: f64,
}

fn run(name: &'static str, phi: fn(DVec3) -> f64, opts: SurfaceOptions, euler: i64) -> Case {
    let h0 = opts.h0;
    let out = mesh_surface(&phi, &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
    Case { name, out, euler, h0 }
}

fn table(cases: &[&Case]) {
    println!(
        "| surface | h0 | vertices | triangles | Euler | min angle | mean q | min q | size dev (circumradius) | size dev (edges) | vertex residual / h0 | centroid dev max / h | iterations | time s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for c in cases {
        let q = &c.out.report.quality;
        println!(
            "| {} | {} | {} | {} | {} | {:.1} | {:.4} | {:.3} | {:.1}% | {:.1}% | {:.0e} | {:.1e} | {} | {:.1} |",
            c.name,
            c.h0,
            q.vertices,
            q.triangles,
            q.euler,
            q.min_angle,
            q.mean_q,
            q.min_q,
            100.0 * q.circumradius_deviation,
            100.0 * q.size_deviation,
            q.vertex_residual,
            q.centroid_deviation_max,
            c.out.report.iterations,
            c.out.report.seconds
        );
    }
}

/// The topology and distance checks every case must pass.
fn check_valid(c: &Case) {
    let q: &SurfaceQuality = &c.out.report.quality;
    c.out.mesh.validate(Level::Topology).unwrap_or_else(|e| panic!("{}: {e}", c.name));
    assert!(q.closed_manifold, "{}: not a closed manifold", c.name);
    assert_eq!(q.inward_faces, 0, "{}: faces against grad phi", c.name);
    assert_eq!(q.euler, c.euler, "{}: Euler characteristic", c.name);
    assert!(q.vertex_residual < 1e-6, "{}: vertex residual {} h0", c.name, q.vertex_residual);
    // A flat triangle of size h on curvature kappa sits about h^2 kappa / 6 off the surface at
    // its centroid; with h kappa <= 1/2 that is below 0.1 h.
    assert!(q.centroid_deviation_max < 0.1, "{}: centroid deviation {}", c.name, q.centroid_deviation_max);
}

/// The thresholds, one at a time, so that each unmet one can stay an ignored test with
/// its measured figure.
fn min_angle_at_least_35(c: &Case) {
    let q = &c.out.report.quality;
    assert!(q.min_angle >= 35.0, "{}: min angle {}", c.name, q.min_angle);
}
fn mean_q_at_least_098(c: &Case) {
    let q = &c.out.report.quality;
    assert!(q.mean_q >= 0.98, "{}: mean q {}", c.name, q.mean_q);
}
/// Size deviation as everywhere in the project (docs/quality.md, seed section 2.7): std/mean
/// of circumradius / h over the triangles. The edge-length spread is printed beside it.
fn size_deviation_at_most_5pct(c: &Case) {
    let q = &c.out.report.quality;
    assert!(q.circumradius_deviation <= 0.05, "{}: size deviation {}", c.name, q.circumradius_deviation);
}
/// Strictly better than a reference mesher's (min angle, mean q, size deviation).
fn better_than(c: &Case, who: &str, reference: (f64, f64, f64)) {
    let q = &c.out.report.quality;
    assert!(q.min_angle > reference.0, "{}: min angle {} vs {who} {}", c.name, q.min_angle, reference.0);
    assert!(q.mean_q > reference.1, "{}: mean q {} vs {who} {}", c.name, q.mean_q, reference.1);
    assert!(
        q.circumradius_deviation < reference.2,
        "{}: size deviation {} vs {who} {}",
        c.name,
        q.circumradius_deviation,
        reference.2
    );
}

fn bbox(r: f64) -> [DVec3; 2] {
    [DVec3::splat(-r), DVec3::splat(r)]
}

/// Uniform options of size `h` in the box `b`.
fn uniform(h: f64, b: [DVec3; 2]) -> SurfaceOptions {
    SurfaceOptions::uniform(h, b[0], b[1])
}

fn sphere_case() -> Case {
    let c = run("unit sphere", sphere, uniform(0.1, bbox(1.2)), 2);
    table(&[&c]);
    println!("{}", c.out.report);
    check_valid(&c);
    c
}

fn torus_case() -> Case {
    let b = [DVec3::new(-1.5, -1.5, -0.5), DVec3::new(1.5, 1.5, 0.5)];
    let c = run("torus R=1 r=0.3", torus, uniform(0.1, b), 0);
    table(&[&c]);
    println!("{}", c.out.report);
    check_valid(&c);
    c
}

fn genus2_case() -> Case {
    let b = [DVec3::new(-2.4, -1.5, -0.5), DVec3::new(2.4, 1.5, 0.5)];
    let c = run("double torus", double_torus, uniform(0.1, b), -2);
    table(&[&c]);
    println!("{}", c.out.report);
    check_valid(&c);
    c
}

/// Sizes from curvature (3 elements per radian) and gradient limiting (g = 0.2), between
/// h0 = 0.05 and 0.15, as the seed's figure does.
fn fig37_case() -> Case {
    let opts = uniform(0.05, bbox(1.4)).with_curvature(3.0, 0.2, 0.15);
    let c = run("seed fig. 3-7", fig37, opts, 0);
    table(&[&c]);
    println!("{}", c.out.report);
    check_valid(&c);
    c
}

#[test]
fn sphere_h01() {
    let c = sphere_case();
    min_angle_at_least_35(&c);
    mean_q_at_least_098(&c);
    better_than(&c, "Gmsh", (26.8, 0.986, 0.058));
}

#[test]
fn sphere_h01_size_deviation() {
    size_deviation_at_most_5pct(&sphere_case());
}

#[test]
fn torus_h01() {
    let c = torus_case();
    min_angle_at_least_35(&c);
    mean_q_at_least_098(&c);
    better_than(&c, "Gmsh", (37.7, 0.980, 0.062));
}

#[test]
fn torus_h01_size_deviation() {
    size_deviation_at_most_5pct(&torus_case());
}

#[test]
fn genus2_h01() {
    let c = genus2_case();
    min_angle_at_least_35(&c);
    mean_q_at_least_098(&c);
}

#[test]
fn genus2_h01_size_deviation() {
    size_deviation_at_most_5pct(&genus2_case());
}

#[test]
fn fig37_curvature() {
    let c = fig37_case();
    min_angle_at_least_35(&c);
    mean_q_at_least_098(&c);
    better_than(&c, "CGAL", (30.2, 0.918, 0.14));
}

#[test]
fn fig37_curvature_size_deviation() {
    size_deviation_at_most_5pct(&fig37_case());
}

#[test]
fn same_input_same_mesh() {
    let opts = uniform(0.2, bbox(1.2)).with_max_iter(60);
    let a = mesh_surface(&sphere, &opts).unwrap();
    let b = mesh_surface(&sphere, &opts).unwrap();
    let trussmesh::topology::MeshArrays { points: pa, cells: ta, .. } = a.mesh.to_arrays();
    let trussmesh::topology::MeshArrays { points: pb, cells: tb, .. } = b.mesh.to_arrays();
    assert_eq!(ta, tb);
    assert!(pa.iter().zip(&pb).all(|(x, y)| x.to_array().map(f64::to_bits) == y.to_array().map(f64::to_bits)));
    assert!(a.report.quality.closed_manifold);
}

#[test]
fn bad_input_is_a_typed_error() {
    let b = bbox(1.2);
    let e = mesh_surface(&sphere, &uniform(0.0, b)).unwrap_err();
    assert!(matches!(e, Error::BadSize(_)), "{e}");
    let e = mesh_surface(&sphere, &uniform(-1.0, b)).unwrap_err();
    assert!(matches!(e, Error::BadSize(_)), "{e}");
    let e = mesh_surface(&|p: DVec3| p.length() - 5.0, &uniform(0.2, b)).unwrap_err();
    assert!(matches!(e, Error::EmptyDomain(_)), "{e}");
    let e = mesh_surface(&|p: DVec3| p.length() + 1.0, &uniform(0.2, b)).unwrap_err();
    assert!(matches!(e, Error::EmptyDomain(_)), "{e}");
    let e = mesh_surface(&|p: DVec3| (p.length() - 1.0).sqrt(), &uniform(0.2, b)).unwrap_err();
    assert!(matches!(e, Error::NonFinite { .. }), "{e}");
    // A surface cut by the box is not closed.
    let e = mesh_surface(&sphere, &uniform(0.2, bbox(0.6))).unwrap_err();
    assert!(matches!(e, Error::Invalid(_)), "{e}");
    let e = mesh_surface(&sphere, &SurfaceOptions::uniform(0.2, DVec3::ONE, -DVec3::ONE)).unwrap_err();
    assert!(matches!(e, Error::BadBox(_)), "{e}");
}

#[test]
fn marching_start_is_closed_and_outward() {
    let mc = trussmesh::surface::march::march(&sphere, bbox(1.2), 0.15).unwrap();
    let (m, _) = trussmesh::topology::TriMesh::from_arrays(&mc.points, &mc.triangles).unwrap();
    m.validate(Level::Topology).unwrap();
    assert!(m.boundary_loops().is_empty());
    assert_eq!(m.euler_characteristic(), 2);
    // Outward: every normal points away from the centre of the sphere.
    for f in m.face_ids() {
        let [a, b, c] = m.face_points(f);
        assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
    }
    let torus_box = [DVec3::new(-1.5, -1.5, -0.5), DVec3::new(1.5, 1.5, 0.5)];
    let mc = trussmesh::surface::march::march(&torus, torus_box, 0.1).unwrap();
    let (m, _) = trussmesh::topology::TriMesh::from_arrays(&mc.points, &mc.triangles).unwrap();
    assert_eq!(m.euler_characteristic(), 0);
}

#[test]
fn subdivision_adds_only_regular_vertices() {
    let mc = trussmesh::surface::march::march(&sphere, bbox(1.2), 0.4).unwrap();
    let (mut m, _) = trussmesh::topology::TriMesh::from_arrays(&mc.points, &mc.triangles).unwrap();
    let irregular = |m: &trussmesh::topology::TriMesh<DVec3>| m.vertex_ids().filter(|&v| m.valence(v) != 6).count();
    let (v0, e0, f0, i0) = (m.num_vertices(), m.num_edges(), m.num_faces(), irregular(&m));
    let n = trussmesh::surface::ops::subdivide(&mut m, &sphere, 1e-12).unwrap();
    assert_eq!(n, e0);
    assert_eq!((m.num_vertices(), m.num_faces()), (v0 + e0, 4 * f0));
    assert_eq!(irregular(&m), i0);
    m.validate(Level::Topology).unwrap();
    assert_eq!(m.euler_characteristic(), 2);
}

#[test]
fn progress_reports_every_stage_in_order() {
    use std::sync::{Arc, Mutex};
    let seen = Arc::new(Mutex::new(Vec::new()));
    let log = seen.clone();
    let opts = uniform(0.1, bbox(1.2)).with_progress(move |d, t| log.lock().unwrap().push((d, t)));
    let out = mesh_surface(&sphere, &opts).unwrap();
    let seen = seen.lock().unwrap();
    let total = seen[0].1;
    // The start, each level of the coarse-to-fine start (two subdivisions here), the equalising.
    assert!(total >= 3, "{seen:?}");
    assert!(seen.iter().all(|&(_, t)| t == total), "{seen:?}");
    assert_eq!(seen.iter().map(|&(d, _)| d).collect::<Vec<_>>(), (1..=total).collect::<Vec<_>>());
    // The callback does not change the result.
    let plain = mesh_surface(&sphere, &uniform(0.1, bbox(1.2))).unwrap();
    assert_eq!(out.mesh.to_arrays().points, plain.mesh.to_arrays().points);
}

/// A spherical shell of mid-radius 1 and thickness `t`.
fn shell(t: f64) -> impl Fn(DVec3) -> f64 + Sync {
    move |p: DVec3| (p.length() - 1.0 - 0.5 * t).max(1.0 - 0.5 * t - p.length())
}

/// Shells and gaps near the size (h0 0.1): from two edges across they mesh as two closed
/// sheets (Euler characteristic 4, no self-intersection: the mesher's final check); thinner
/// ones are refused with the thickness named. Before the start level kept two edges across,
/// the shell 0.3 thick (started at 2 h0) intersected itself.
#[test]
fn thin_shells_and_close_balls_mesh_or_name_the_thickness() {
    let h0 = 0.1;
    println!("| case | vertices | Euler | min angle | mean q | size dev |");
    println!("|---|---|---|---|---|---|");
    let mut meshed: Vec<(String, SurfaceOutput)> = Vec::new();
    for t in [0.2, 0.25, 0.3, 0.4, 0.5] {
        let out = mesh_surface(&shell(t), &uniform(h0, bbox(1.4))).unwrap_or_else(|e| panic!("shell {t}: {e}"));
        meshed.push((format!("shell {t} thick"), out));
    }
    for gap in [0.15, 0.2, 0.3] {
        let c = 0.5 + 0.5 * gap;
        let balls =
            move |p: DVec3| (p - DVec3::new(c, 0.0, 0.0)).length().min((p + DVec3::new(c, 0.0, 0.0)).length()) - 0.5;
        let out = mesh_surface(&balls, &uniform(h0, bbox(1.4))).unwrap_or_else(|e| panic!("balls {gap} apart: {e}"));
        meshed.push((format!("balls {gap} apart"), out));
    }
    for (name, out) in &meshed {
        let q = &out.report.quality;
        println!(
            "| {name} | {} | {} | {:.1} | {:.4} | {:.1}% |",
            q.vertices,
            q.euler,
            q.min_angle,
            q.mean_q,
            100.0 * q.circumradius_deviation
        );
        out.mesh.validate(Level::Topology).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(q.closed_manifold && q.inward_faces == 0, "{name}");
        assert_eq!(q.euler, 4, "{name}: two spheres");
        assert!(q.min_angle >= 35.0, "{name}: min angle {}", q.min_angle);
    }
    for t in [0.01, 0.02, 0.05, 0.12, 0.15] {
        match mesh_surface(&shell(t), &uniform(h0, bbox(1.4))) {
            Err(Error::BadSize(msg)) => {
                println!("| shell {t} thick | refused: {msg} |");
                assert!(msg.contains("comes back within"), "shell {t}: {msg}");
                let named: f64 =
                    msg.split("within ").nth(1).and_then(|s| s.split(' ').next()).unwrap().parse().unwrap();
                assert!((named - t).abs() < 1e-3, "shell {t}: named {named}");
            }
            Err(e) => panic!("shell {t}: not the thickness named: {e}"),
            Ok(out) => {
                let q = &out.report.quality;
                println!(
                    "| shell {t} thick | {} | {} | {:.1} | {:.4} | - |",
                    q.vertices, q.euler, q.min_angle, q.mean_q
                );
                assert_eq!(q.euler, 4, "shell {t}");
            }
        }
    }
}

/// A shell exactly one size thick ran for minutes: nodes moving between the sheets made
/// density control split without end (30,000 to 87,000 vertices in 80 iterations). The force
/// loop now stops a mesh that runs away, and the run ends in a mesh or the refusal above, with
/// the thickness named.
#[test]
fn a_shell_one_size_thick_ends() {
    let t0 = std::time::Instant::now();
    let r = mesh_surface(&shell(0.1), &uniform(0.1, bbox(1.4)));
    println!("shell 0.1 thick at h0 0.1: {:.1} s, {:?}", t0.elapsed().as_secs_f64(), r.as_ref().err());
    match r {
        Ok(out) => assert_eq!(out.report.quality.euler, 4),
        Err(Error::BadSize(msg)) => assert!(msg.contains("comes back within"), "{msg}"),
        Err(e) => panic!("neither a mesh nor the thickness named: {e}"),
    }
}

/// The unit ball with a hole of radius 0.3 through it (no blend): its rims are sharp edges with
/// a 73-degree wedge.
fn ball_with_a_hole(p: DVec3) -> f64 {
    (p.length() - 1.0).max(0.3 - (p.x * p.x + p.y * p.y).sqrt())
}

/// Where the wedge's two faces come within a few sizes of each other near the rim, the refusal
/// for thin sheets used to name a "shell or gap" 0.0106 thick at h0 0.05 (exit 2) for a solid
/// that is nowhere thin; only sheets that face each other count now. At h0 0.1 the surface
/// meshes with its rims held.
#[test]
fn a_sharp_wedge_is_no_thin_sheet() {
    let out = mesh_surface(&ball_with_a_hole, &uniform(0.1, bbox(1.2))).expect("the ball with a hole at h0 0.1");
    let q = &out.report.quality;
    println!(
        "ball with a hole, h0 0.1: {} vertices, Euler {}, min angle {:.1}, notes {:?}",
        q.vertices, q.euler, q.min_angle, out.report.notes
    );
    assert!(q.closed_manifold && q.euler == 0, "a torus: Euler {}", q.euler);
    assert!(q.min_angle >= 30.0, "min angle {}", q.min_angle);
    match mesh_surface(&ball_with_a_hole, &uniform(0.05, bbox(1.2))) {
        Ok(out) => assert_eq!(out.report.quality.euler, 0),
        Err(e) => {
            println!("ball with a hole, h0 0.05: {e}");
            assert!(!matches!(e, Error::BadSize(_)), "a thin sheet named where there is none: {e}");
        }
    }
}

/// The same ball at h0 0.05.
#[test]
#[ignore = "not reached: at h0 0.05 holding the rims crosses the surface over itself (cylinder-wall \
            triangles beside the rim turn over where a rim vertex sits between two others that the sphere's \
            side joins directly), and the smooth mesh, rounding the 73-degree wedge, crosses itself too: \
            the result is the boundary of the 3-D mesh of the inside, which the report says"]
fn a_ball_with_a_hole_at_h0_005_holds_its_rims() {
    let out = mesh_surface(&ball_with_a_hole, &uniform(0.05, bbox(1.2))).expect("the ball with a hole at h0 0.05");
    let q = &out.report.quality;
    assert!(out.report.notes.is_empty(), "{:?}", out.report.notes);
    assert!(q.closed_manifold && q.euler == 0 && q.min_angle >= 30.0, "Euler {}, min angle {}", q.euler, q.min_angle);
}

/// The inward-face count of the report: 0 on a meshed sphere, every face on the same mesh
/// turned inside out (the normal against grad phi at the centroid and at all three corners),
/// and 0 on a box's faces beside its edges (a face a fraction of a degree past the right angle
/// whose centroid lies nearer the other side's plane is not inward).
#[test]
fn inward_faces_are_counted() {
    use trussmesh::surface::SizeField;
    use trussmesh::topology::TriMesh;
    let ball = |p: DVec3| p.length() - 1.0;
    let out = mesh_surface(&ball, &SurfaceOptions::uniform(0.3, [-1.2; 3], [1.2; 3])).expect("sphere");
    let size = SizeField::Uniform(0.3);
    let q = SurfaceQuality::measure(&out.mesh, &ball, &size);
    let a = out.mesh.to_arrays();
    let turned: Vec<[usize; 3]> = a.cells.iter().map(|t| [t[0], t[2], t[1]]).collect();
    let (inside_out, _) = TriMesh::from_arrays(&a.points, &turned).expect("the same surface, turned");
    let r = SurfaceQuality::measure(&inside_out, &ball, &size);
    println!("sphere: {} faces, {} inward; turned: {} inward", q.triangles, q.inward_faces, r.inward_faces);
    assert_eq!(q.inward_faces, 0);
    assert_eq!(r.inward_faces, r.triangles);
    let cube = |p: DVec3| p.x.abs().max(p.y.abs()).max(p.z.abs()) - 0.7;
    let c = mesh_surface(&cube, &SurfaceOptions::uniform(0.15, [-1.0; 3], [1.0; 3])).expect("box");
    println!("box: {} faces, {} inward", c.report.quality.triangles, c.report.quality.inward_faces);
    assert_eq!(c.report.quality.inward_faces, 0);
}

/// A ball of radius 0.4 less the slab |z| < `c`: two caps whose rims are wedges of
/// acos(c / 0.4) degrees (41 at c = 0.30, 34 at 0.33), and only 0.07 to 0.12 thick.
fn ball_less_slab(c: f64) -> impl Fn(DVec3) -> f64 + Sync {
    move |p: DVec3| (p.length() - 0.4).max(c - p.z.abs())
}

/// Caps with rims of 41 and 46 degrees, at least 1.5 sizes thick: the surface mesher fails on
/// them (nodes land on the rim's other face). c = 0.30 was refused at h0 0.025, 0.05 and 0.067
/// as a "shell or gap" 6.8e-3 to 3.8e-2 thin near the rim, with an h0 of half that advised
/// (which failed again); the boundary of the 3-D mesh of the inside, which holds the rims, is
/// the result now, its report saying so: two closed surfaces, every face outward, no angle below 20
/// degrees. A cap about one size thick (c = 0.33, 0.07 at its middle, h0 0.067) may still be
/// refused, but with the thickness where its faces face each other (0.04 to 0.07), not the
/// rim's (it was 1.2e-2).
#[test]
fn caps_with_sharp_rims_mesh_from_the_solid() {
    println!("| c | h0 | vertices | Euler | min angle | mean q | note |");
    println!("|---|---|---|---|---|---|---|");
    for (c, h0) in [(0.30, 0.067), (0.30, 0.05), (0.30, 0.025), (0.28, 0.05)] {
        let out =
            mesh_surface(&ball_less_slab(c), &uniform(h0, bbox(0.6))).unwrap_or_else(|e| panic!("c {c}, h0 {h0}: {e}"));
        let q = &out.report.quality;
        let from_solid = out.report.notes.iter().any(|n| n.contains("boundary of the 3-D mesh"));
        println!(
            "| {c} | {h0} | {} | {} | {:.1} | {:.4} | {} |",
            q.vertices, q.euler, q.min_angle, q.mean_q, from_solid
        );
        out.mesh.validate(Level::Topology).unwrap_or_else(|e| panic!("c {c}, h0 {h0}: {e}"));
        assert!(q.closed_manifold && q.inward_faces == 0, "c {c}, h0 {h0}");
        assert_eq!(q.euler, 4, "c {c}, h0 {h0}: two caps");
        assert!(q.min_angle >= 20.0, "c {c}, h0 {h0}: min angle {}", q.min_angle);
        assert!(q.vertex_residual < 1e-6, "c {c}, h0 {h0}: vertices {} h off phi = 0", q.vertex_residual);
    }
    match mesh_surface(&ball_less_slab(0.33), &uniform(0.067, bbox(0.6))) {
        Ok(out) => assert_eq!(out.report.quality.euler, 4),
        Err(Error::BadSize(msg)) => {
            println!("| 0.33 | 0.067 | refused: {msg} |");
            let named: f64 = msg
                .split("within ")
                .nth(1)
                .and_then(|s| s.split(' ').next())
                .and_then(|s| s.parse().ok())
                .unwrap_or_else(|| panic!("no thickness named: {msg}"));
            assert!((0.04..=0.07).contains(&named), "named {named}: {msg}");
        }
        Err(e) => panic!("c 0.33, h0 0.067: {e}"),
    }
}
