//! Meshing images (seed section 5.3): a synthetic picture drawn here, meshed, checked against
//! the shapes it was drawn from; and the bad inputs.

use glam::DVec2;
use trussmesh::mesher::image::{mesh_image, read_png_grey, ImageOptions};
use trussmesh::topology::Level;
use trussmesh::Error;

/// Discs and a blob (two overlapping discs), white on black, 512 x 512.
const DISCS: [(f64, f64, f64); 4] =
    [(150.0, 150.0, 80.0), (350.0, 330.0, 100.0), (380.0, 120.0, 50.0), (430.0, 150.0, 45.0)];

fn draw(path: &std::path::Path) {
    let mut pix = tiny_skia::Pixmap::new(512, 512).unwrap();
    pix.fill(tiny_skia::Color::BLACK);
    let mut paint = tiny_skia::Paint::default();
    paint.set_color(tiny_skia::Color::WHITE);
    paint.anti_alias = true;
    for (x, y, r) in DISCS {
        let c = tiny_skia::PathBuilder::from_circle(x as f32, y as f32, r as f32).unwrap();
        pix.fill_path(&c, &paint, tiny_skia::FillRule::Winding, tiny_skia::Transform::identity(), None);
    }
    pix.save_png(path).unwrap();
}

fn true_distance(p: DVec2) -> f64 {
    DISCS.iter().map(|&(x, y, r)| p.distance(DVec2::new(x, y)) - r).fold(f64::INFINITY, f64::min)
}

#[test]
fn synthetic_image_meshes_within_a_pixel() {
    let dir = std::env::temp_dir().join(format!("trussmesh-image-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("discs.png");
    draw(&path);
    let (grey, w, h) = read_png_grey(&path).unwrap();
    assert_eq!((w, h), (512, 512));
    let out = mesh_image(&grey, w, h, &ImageOptions::default()).unwrap();
    let m = &out.mesh;
    m.validate(Level::Geometry).unwrap();
    let worst =
        m.vertex_ids().filter(|&v| m.is_boundary_vertex(v)).map(|v| true_distance(m.pos(v)).abs()).fold(0.0, f64::max);
    let q = out.report.quality;
    println!("| image | nodes | triangles | q min | q mean | worst boundary node (px) | seconds |");
    println!(
        "| 512 x 512, 4 discs | {} | {} | {:.3} | {:.4} | {:.3} | {:.2} |",
        q.vertices, q.triangles, q.q_min, q.q_mean, worst, out.report.seconds
    );
    assert!(worst <= 1.0, "a boundary node is {worst} px from the true boundary");
    assert!(q.q_mean >= 0.95, "q mean {}", q.q_mean);
    // Three separate regions: three boundary loops.
    assert_eq!(m.boundary_loops().len(), 3);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn unreadable_image_is_an_io_error() {
    let dir = std::env::temp_dir().join(format!("trussmesh-image-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("garbage.png");
    std::fs::write(&path, b"this is not a png").unwrap();
    match read_png_grey(&path) {
        Err(Error::Parse { message, .. }) => assert!(message.contains("not a PNG picture"), "{message}"),
        other => panic!("{other:?}"),
    }
    assert!(matches!(read_png_grey(&dir.join("missing.png")), Err(Error::Io { .. })));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn empty_mask_is_an_empty_domain() {
    let grey = vec![0.0; 64 * 64];
    match mesh_image(&grey, 64, 64, &ImageOptions::default()) {
        Err(Error::EmptyDomain(msg)) => assert!(msg.contains("mask is empty"), "{msg}"),
        other => panic!("{:?}", other.map(|o| o.report)),
    }
    let bad = ImageOptions { threshold: 2.0, ..ImageOptions::default() };
    assert!(matches!(mesh_image(&[1.0; 16], 4, 4, &bad), Err(Error::Invalid(_))));
    assert!(matches!(mesh_image(&[1.0; 3], 4, 4, &ImageOptions::default()), Err(Error::Invalid(_))));
}

#[test]
fn command_line_image() {
    let exe = env!("CARGO_BIN_EXE_trussmesh");
    let dir = std::env::temp_dir().join(format!("trussmesh-image-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("discs.png");
    draw(&png);
    let out_vtu = dir.join("discs.vtu");
    let st = std::process::Command::new(exe)
        .args(["image", png.to_str().unwrap(), "--h0", "6", "--quiet", "-o", out_vtu.to_str().unwrap()])
        .status()
        .unwrap();
    assert_eq!(st.code(), Some(0));
    let mesh = trussmesh::io::read_mesh(&out_vtu).unwrap();
    assert!(mesh.num_cells() > 100);
    // Bad input: a garbled picture and an empty mask exit with code 2 and say why.
    let bad = dir.join("bad.png");
    std::fs::write(&bad, b"garbage").unwrap();
    let o = std::process::Command::new(exe).args(["image", bad.to_str().unwrap(), "-o", "x.vtu"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("PNG"));
    let o = std::process::Command::new(exe)
        .args(["image", png.to_str().unwrap(), "--threshold", "1.0", "-o", dir.join("y.vtu").to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("empty"), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_dir_all(&dir).ok();
}
