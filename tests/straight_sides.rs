//! Polygons with long straight sides come to an end before the iteration cap. Their trusses
//! settle into a slow mode (the lattice creeping to fit a side it does not line up with, a flip
//! travelling along the side one node at a time) in which the largest step stays just above
//! dptol for hundreds of iterations while the mean quality barely moves; such runs used to go to
//! the cap of 1000 iterations (a square at h0 0.03, an L-shape, a 3:1 rectangle at h0 0.015).
//! The stall rule ends them once the mean quality's deficit has stopped falling.

use trussmesh::expr::{Expr, ExprImplicit2};
use trussmesh::mesher::{area, mesh_2d, Options2};
use trussmesh::topology::Level;

/// (name, domain, box, exact area)
const SHAPES: [(&str, &str, [f64; 4], f64); 6] = [
    ("square", "max(abs(x),abs(y))-1", [-1.0, -1.0, 1.0, 1.0], 4.0),
    ("rectangle 2:1", "max(abs(x)-1,abs(y)-0.5)", [-1.0, -0.5, 1.0, 0.5], 2.0),
    ("rectangle 3:1", "max(abs(x)-1.5,abs(y)-0.5)", [-1.5, -0.5, 1.5, 0.5], 3.0),
    ("L-shape", "max(max(abs(x),abs(y))-1,-max(x,y))", [-1.0, -1.0, 1.0, 1.0], 3.0),
    // A rectangle turned by 30 degrees: no side lines up with the start's lattice.
    (
        "turned rectangle",
        "max(abs(0.8660254037844386*x+0.5*y)-0.9,abs(-0.5*x+0.8660254037844386*y)-0.4)",
        [-1.0, -1.0, 1.0, 1.0],
        1.44,
    ),
    ("triangle", "max(max(-y,y-1.7*x),y+1.7*x-1.7)", [0.0, 0.0, 1.0, 0.9], 0.425),
];

#[test]
fn polygons_with_straight_sides_stop_before_the_cap() {
    println!("| shape | h0 | triangles | iterations | stop | q min | q mean | area error |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut bad = Vec::new();
    for (name, domain, b, exact) in SHAPES {
        for h0 in [0.03, 0.015] {
            let d = ExprImplicit2::new(Expr::parse(domain).expect("parses"));
            let out = mesh_2d(&d, &Options2::uniform(h0, [b[0], b[1]], [b[2], b[3]])).expect("meshes");
            out.mesh.validate(Level::Geometry).expect("an embedding");
            let (r, q) = (&out.report, out.report.quality);
            let err = (area(&out.mesh) - exact).abs() / exact;
            println!(
                "| {name} | {h0} | {} | {} | {} | {:.4} | {:.4} | {:.1e} |",
                q.triangles, r.iterations, r.stop, q.q_min, q.q_mean, err
            );
            if !r.converged || r.iterations >= 800 {
                bad.push(format!("{name} at h0 {h0}: {} iterations, {}", r.iterations, r.stop));
            }
            if q.q_min < 0.75 || q.q_mean < 0.99 {
                bad.push(format!("{name} at h0 {h0}: q min {:.4}, q mean {:.4}", q.q_min, q.q_mean));
            }
            if err > 1e-9 {
                bad.push(format!("{name} at h0 {h0}: area off by {err:.1e}"));
            }
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}
