//! Sharp corners of 2-D domains are found from d alone and held fixed: a domain meshed without
//! its corners given keeps them (the area comes out exact for polygons), and a smooth domain
//! gets none.

use glam::DVec2;
use trussmesh::expr::{Expr, ExprImplicit2};
use trussmesh::mesher::{area, mesh_2d, MeshOutput2, Options2};
use trussmesh::topology::{Level, VertexTag};

fn mesh(domain: &str, h0: f64) -> MeshOutput2 {
    let d = ExprImplicit2 { expr: Expr::parse(domain).expect("parses"), distance: true };
    let out = mesh_2d(&d, &Options2::uniform(h0, [-1.0, -1.0], [1.0, 1.0])).expect("meshes");
    out.mesh.validate(Level::Geometry).expect("valid");
    println!("{domain}, h0 = {h0}:\n{}", out.report);
    out
}

fn fixed(out: &MeshOutput2) -> Vec<DVec2> {
    out.mesh.vertices().filter(|(_, v)| v.tag == VertexTag::Fixed).map(|(_, v)| v.pos).collect()
}

fn has(points: &[DVec2], p: DVec2, tol: f64) -> bool {
    points.iter().any(|q| q.distance(p) <= tol)
}

#[test]
fn square_keeps_its_corners() {
    for h0 in [0.1, 0.17, 0.3] {
        let out = mesh("drectangle(x,y,-1,1,-1,1)", h0);
        assert_eq!(out.report.feature_points, 4);
        let held = fixed(&out);
        for c in [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]] {
            assert!(has(&held, DVec2::from(c), 1e-12), "corner {c:?} held: {held:?}");
        }
        let a = area(&out.mesh);
        assert!((a - 4.0).abs() < 1e-9, "area {a}");
    }
}

/// Turned off, the corners are not looked for and the projection rounds them off.
#[test]
fn corners_can_be_turned_off() {
    let d = ExprImplicit2 { expr: Expr::parse("drectangle(x,y,-1,1,-1,1)").expect("parses"), distance: true };
    let o = Options2::uniform(0.17, [-1.0, -1.0], [1.0, 1.0]).with_sharp_corners(false);
    let out = mesh_2d(&d, &o).expect("meshes");
    out.mesh.validate(Level::Geometry).expect("valid");
    assert_eq!(out.report.feature_points, 0);
    assert!(fixed(&out).is_empty());
    assert!(area(&out.mesh) < 4.0 - 1e-4, "corners cut: area {}", area(&out.mesh));
}

#[test]
fn hexagon_with_a_hole_keeps_all_twelve_corners() {
    let outer = "dpoly(x,y, 1,0, 0.5,sqrt(3)/2, -0.5,sqrt(3)/2, -1,0, -0.5,-sqrt(3)/2, 0.5,-sqrt(3)/2)";
    let inner = "dpoly(x,y, sqrt(3)/4,0.25, 0,0.5, -sqrt(3)/4,0.25, -sqrt(3)/4,-0.25, 0,-0.5, sqrt(3)/4,-0.25)";
    let out = mesh(&format!("ddiff({outer}, {inner})"), 0.1);
    assert_eq!(out.report.feature_points, 12);
    let held = fixed(&out);
    let s = 3f64.sqrt();
    for k in 0..6 {
        let a = k as f64 * std::f64::consts::PI / 3.0;
        assert!(has(&held, DVec2::new(a.cos(), a.sin()), 1e-9), "outer corner {k}: {held:?}");
        let b = a + std::f64::consts::PI / 6.0;
        assert!(has(&held, DVec2::new(b.cos(), b.sin()) * 0.5, 1e-9), "inner corner {k}");
    }
    let exact = 3.0 * s / 2.0 * (1.0 - 0.25);
    let a = area(&out.mesh);
    assert!((a - exact).abs() < 1e-9, "area {a} against {exact}");
}

#[test]
fn smooth_domains_have_no_corners() {
    assert_eq!(mesh("sqrt(x^2+y^2)-1", 0.1).report.feature_points, 0);
    assert_eq!(mesh("ddiff(dcircle(x,y,0,0,1), dcircle(x,y,0.2,0,0.4))", 0.1).report.feature_points, 0);
}

/// Where a circle meets a straight side the corner is found exactly: the tangent lines meet off
/// the true corner when a side is curved, and are taken ever closer to it until they do not.
#[test]
fn corner_between_a_circle_and_a_line() {
    let out = mesh("max(dcircle(x,y,0,0,0.7), y-0.3)", 0.1);
    assert_eq!(out.report.feature_points, 2);
    let held = fixed(&out);
    let x = (0.49f64 - 0.09).sqrt();
    for c in [DVec2::new(-x, 0.3), DVec2::new(x, 0.3)] {
        assert!(has(&held, c, 1e-6), "corner {c:?} in {held:?}");
    }
}
