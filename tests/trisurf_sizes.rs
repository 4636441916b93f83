//! Automatic sizes for triangulated input: the curvature a `TriSurface` gives (the turn of the
//! normals across each smooth edge), and `auto_size_3d` on it against the same shape as a
//! formula.

use glam::DVec3;
use trussmesh::geometry::TriSurface;
use trussmesh::size::{auto_size_3d, SizeParams};
use trussmesh::Implicit3;

mod trisurf_inputs;
use trisurf_inputs::{from_surface_mesher, noisy, part, sphere_phi};

fn ellipsoid_phi(p: DVec3) -> f64 {
    p.x * p.x / 4.0 + p.y * p.y + p.z * p.z - 1.0
}

/// The curvature the surface gives at the point of its own nearest `p`.
fn kappa(s: &TriSurface, p: DVec3) -> f64 {
    s.surface_curvature(p).expect("a triangulated surface gives its curvature")
}

#[test]
fn triangulated_surfaces_give_their_curvature() {
    let sphere = from_surface_mesher(sphere_phi, 0.1, 1.3);
    let rough = noisy(&sphere);
    let part = part(0.1);
    println!("| surface | where | curvature | exact |");
    println!("|---|---|---|---|");
    let mut rows = Vec::new();
    for (i, dir) in [DVec3::X, DVec3::new(0.3, -0.5, 0.8), DVec3::new(-0.6, 0.2, -0.7), DVec3::NEG_Z].iter().enumerate()
    {
        let p = dir.normalize() * 1.01;
        rows.push(("sphere", format!("point {i}"), kappa(&sphere, p), 1.0, 0.2));
    }
    // The part: flat top and walls (their sharp rims count for nothing), the hole's wall of
    // radius 0.4.
    rows.push(("part", "top face".into(), kappa(&part, DVec3::new(0.7, -0.6, 0.51)), 0.0, 0.0));
    rows.push(("part", "outer wall".into(), kappa(&part, DVec3::new(1.01, 0.3, 0.1)), 0.0, 0.0));
    rows.push(("part", "hole wall".into(), kappa(&part, DVec3::new(0.0, 0.38, 0.1)), 2.5, 0.2));
    rows.push(("part", "hole wall".into(), kappa(&part, DVec3::new(-0.27, -0.27, -0.2)), 2.5, 0.2));
    let mut bad = Vec::new();
    for (name, at, k, exact, tol) in &rows {
        println!("| {name} | {at} | {k:.3} | {exact} |");
        if (k - exact).abs() > tol * exact + 1e-6 {
            bad.push(format!("{name} {at}: {k:.3} for {exact}"));
        }
    }
    // A scan's noise turns the normals more than the shape does: the curvature it gives is at
    // least the shape's, so sizes from it are never coarser than the smooth shape's.
    let k_rough = kappa(&rough, DVec3::new(0.0, 0.0, 1.01));
    println!("| noisy sphere | top | {k_rough:.3} | 1 |");
    assert!(k_rough >= 0.8, "the noisy sphere's curvature {k_rough}");
    assert!(bad.is_empty(), "{bad:#?}");
}

#[test]
fn auto_sizes_of_a_triangulated_ellipsoid_match_its_formula() {
    let surf = from_surface_mesher(ellipsoid_phi, 0.06, 2.3);
    let params = SizeParams { k: 2.0, r: 0.0, g: 0.3, hmin: 0.1, hmax: 0.6, ..SizeParams::default() };
    let bbox = [DVec3::new(-2.3, -1.3, -1.3), DVec3::new(2.3, 1.3, 1.3)];
    let from_file = auto_size_3d(&surf, bbox, 0.05, &params).expect("sizes of the surface");
    let formula = |p: DVec3| ellipsoid_phi(p);
    let from_formula = auto_size_3d(&formula, bbox, 0.05, &params).expect("sizes of the formula");
    // Largest principal curvature: 2 at the tips (+-2, 0, 0), 1 around the equator x = 0: the
    // sizes 1 / (K kappa) are 0.25 and 0.5. The triangles' own unevenness adds curvature, so a
    // size from them may come out finer (down to 0.7 of it), never coarser by more than 10%.
    println!("| point | exact | from the triangles | from the formula |");
    println!("|---|---|---|---|");
    let mut bad = Vec::new();
    for (p, exact) in [
        (DVec3::new(2.0, 0.0, 0.0), 0.25),
        (DVec3::new(-2.0, 0.0, 0.0), 0.25),
        (DVec3::new(0.0, 1.0, 0.0), 0.5),
        (DVec3::new(0.0, -0.6, 0.8), 0.5),
    ] {
        let (a, b) = (from_file.value(p), from_formula.value(p));
        println!("| {p} | {exact} | {a:.3} | {b:.3} |");
        if !(0.7 * exact..=1.1 * exact).contains(&a) {
            bad.push(format!("{p}: {a:.3} from the triangles for {exact}"));
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}
