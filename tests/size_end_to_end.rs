//! The automatic size function end to end (seed figure 4-6 style): a domain with a narrow
//! channel meshed with h = gradlimit(min(h_curv, h_lfs, hmax)), checked for elements across
//! the channel and for the growth between neighbouring elements.

use glam::DVec2;
use trussmesh::geometry::{union, Implicit2, Rectangle};
use trussmesh::mesher::{mesh_2d, Options2};
use trussmesh::size::{auto_size_2d, SizeParams};
use trussmesh::topology::Level;

#[test]
fn narrow_channel_gets_elements_across_and_graded_sizes() {
    // Two blocks joined by a channel of width 0.1.
    let left = Rectangle::new([-1.0, -0.5], [-0.3, 0.5]);
    let right = Rectangle::new([0.3, -0.5], [1.0, 0.5]);
    let channel = Rectangle::new([-0.31, -0.05], [0.31, 0.05]);
    let domain = union(union(left, right), channel);
    let bbox = [DVec2::new(-1.1, -0.6), DVec2::new(1.1, 0.6)];
    let g = 0.3;
    let params = SizeParams { k: 0.0, r: 2.0, g, hmin: 0.02, hmax: 0.25, ..SizeParams::default() };
    let size = auto_size_2d(&domain, bbox, 0.005, &params).expect("size function");
    let h_channel = size.value(DVec2::new(0.0, 0.0));
    let h_far = size.value(DVec2::new(-0.8, 0.3));
    println!("h in the channel {h_channel:.4}, far from it {h_far:.4}");
    let sz = size.clone();
    let opts = Options2::uniform(params.hmin, [bbox[0].x, bbox[0].y], [bbox[1].x, bbox[1].y])
        .with_size(move |p| sz.value(p))
        .with_fixed([
            [-1.0, -0.5],
            [-1.0, 0.5],
            [1.0, -0.5],
            [1.0, 0.5],
            [-0.3, 0.5],
            [-0.3, -0.5],
            [0.3, 0.5],
            [0.3, -0.5],
        ]);
    let out = mesh_2d(&domain, &opts).expect("meshing");
    let m = &out.mesh;
    m.validate(Level::Geometry).unwrap();
    println!("{}", out.report);

    // Elements across the channel: triangles cut by the segment x = 0, |y| < 0.05.
    let mut across = 0;
    for f in m.face_ids() {
        let [a, b, c] = m.face_points(f);
        let (lo, hi) = (a.x.min(b.x).min(c.x), a.x.max(b.x).max(c.x));
        let (ylo, yhi) = (a.y.min(b.y).min(c.y), a.y.max(b.y).max(c.y));
        if lo < 0.0 && hi > 0.0 && yhi > -0.05 && ylo < 0.05 {
            across += 1;
        }
    }
    // A strip of triangles crossed by a line holds about twice as many triangles as layers.
    let layers = across as f64 / 2.0;
    println!("triangles crossing x = 0 in the channel: {across} (about {layers} element layers)");
    assert!(layers >= 3.0, "only {layers} element layers across the channel");

    // Growth between neighbours: the ratio of the sizes (square root of area) of triangles
    // sharing an edge.
    let size_of = |f| {
        let t = m.face_points(f);
        trussmesh::quality::triangle_area(t).sqrt()
    };
    let mut ratios: Vec<f64> = Vec::new();
    for h in m.edge_ids() {
        if let (Some(f1), Some(f2)) = (m.face_of(h), m.face_of(m.twin(h))) {
            let (s1, s2) = (size_of(f1), size_of(f2));
            ratios.push(s1.max(s2) / s1.min(s2));
        }
    }
    ratios.sort_by(f64::total_cmp);
    let p99 = ratios[(ratios.len() as f64 * 0.99) as usize];
    let max = *ratios.last().unwrap();
    let tol = 0.25;
    println!(
        "neighbour size ratio: median {:.3}, 99th percentile {p99:.3}, max {max:.3}; bound (1 + g)(1 + {tol}) = {:.3}",
        ratios[ratios.len() / 2],
        (1.0 + g) * (1.0 + tol)
    );
    assert!(p99 <= 1.0 + g, "99% of neighbours within 1 + g: {p99}");
    assert!(max <= (1.0 + g) * (1.0 + tol), "largest neighbour ratio {max}");
    // The size really is graded: far elements are much larger than channel elements.
    assert!(h_far > 3.0 * h_channel);
}
