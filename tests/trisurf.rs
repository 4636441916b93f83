//! Triangulated geometry (docs/trisurf.md): the signed distance to a closed triangle mesh against
//! brute force, its sign, the sharp features found, the refused inputs, and the meshers run on
//! surfaces the project makes itself (a sphere, a torus, a noisy sphere from the surface
//! mesher; a box minus a cylinder from the boundary of a tet mesh). Prints the tables kept in
//! docs/trisurf.md (`--nocapture`).

use glam::DVec3;
use std::sync::OnceLock;
use trussmesh::geometry::trisurf::{Features, SurfaceError, DEFAULT_FEATURE_ANGLE};
use trussmesh::geometry::TriSurface;
use trussmesh::io::MeshData;
use trussmesh::testing::{Rng, SEED};
use trussmesh::{Error, Implicit3};

mod trisurf_inputs;
use trisurf_inputs::{from_surface_mesher, noisy, part_clearance, part_inside, sphere_phi, torus_phi, PART_VOLUME};

fn sphere() -> &'static TriSurface {
    static S: OnceLock<TriSurface> = OnceLock::new();
    S.get_or_init(|| from_surface_mesher(sphere_phi, 0.12, 1.2))
}

fn torus() -> &'static TriSurface {
    static S: OnceLock<TriSurface> = OnceLock::new();
    S.get_or_init(|| from_surface_mesher(torus_phi, 0.08, 1.5))
}

fn noisy_sphere() -> &'static TriSurface {
    static S: OnceLock<TriSurface> = OnceLock::new();
    S.get_or_init(|| noisy(sphere()))
}

fn part() -> &'static TriSurface {
    static S: OnceLock<TriSurface> = OnceLock::new();
    S.get_or_init(|| trisurf_inputs::part(0.1))
}

/// A cube [-1, 1]^3 with every face split into n x n squares of two triangles.
fn cube(n: usize) -> TriSurface {
    let mut pts = Vec::new();
    let mut tris = Vec::new();
    for axis in 0..3 {
        for side in [-1.0, 1.0] {
            let base = pts.len();
            for j in 0..=n {
                for i in 0..=n {
                    let (u, v) = (-1.0 + 2.0 * i as f64 / n as f64, -1.0 + 2.0 * j as f64 / n as f64);
                    let mut p = [0.0; 3];
                    p[axis] = side;
                    p[(axis + 1) % 3] = u;
                    p[(axis + 2) % 3] = v;
                    pts.push(p);
                }
            }
            for j in 0..n {
                for i in 0..n {
                    let a = base + j * (n + 1) + i;
                    let (b, c, d) = (a + 1, a + n + 2, a + n + 1);
                    if side > 0.0 {
                        tris.push([a, b, c]);
                        tris.push([a, c, d]);
                    } else {
                        tris.push([a, c, b]);
                        tris.push([a, d, c]);
                    }
                }
            }
        }
    }
    TriSurface::new(pts, tris).expect("cube")
}

fn random_in(s: &TriSurface, n: usize, seed: u64) -> Vec<DVec3> {
    let [lo, hi] = s.bbox();
    let (c, r) = ((lo + hi) * 0.5, (hi - lo) * 0.75);
    let mut rng = Rng::new(seed);
    (0..n).map(|_| c + DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * r).collect()
}

#[test]
fn distance_matches_brute_force() {
    println!("| input | triangles | points | max abs(d - brute) | nearest points apart max | volume | Euler |");
    println!("|---|---|---|---|---|---|---|");
    for (name, s) in [("sphere", sphere()), ("torus", torus()), ("noisy sphere", noisy_sphere()), ("part", part())] {
        let pts = random_in(s, 2000, SEED);
        let (mut worst, mut apart) = (0.0f64, 0.0f64);
        for (k, &p) in pts.iter().enumerate() {
            let (a, b) = (s.closest(p), s.closest_brute_force(p));
            worst = worst.max((a.dist2.sqrt() - b.dist2.sqrt()).abs());
            apart = apart.max(a.point.distance(b.point));
            // Near the surface too: points within 1e-3 of it.
            if k % 4 == 0 {
                let q = b.point + (p - b.point).normalize_or_zero() * 1e-3;
                let (a, b) = (s.closest(q), s.closest_brute_force(q));
                worst = worst.max((a.dist2.sqrt() - b.dist2.sqrt()).abs());
            }
        }
        println!(
            "| {name} | {} | 2000 | {worst:.1e} | {apart:.1e} | {:.4} | {} |",
            s.triangles().len(),
            s.volume(),
            s.euler_characteristic()
        );
        assert!(worst <= 1e-12, "{name}: distance differs from brute force by {worst}");
    }
    assert_eq!(sphere().euler_characteristic(), 2);
    assert_eq!(torus().euler_characteristic(), 0);
    assert_eq!(part().euler_characteristic(), 0);
    assert!((part().volume() / PART_VOLUME - 1.0).abs() < 0.01, "part volume {}", part().volume());
}

/// The bounded query (`value_near`, which spares the surface mesher's start the deep queries):
/// exactly `value` bit for bit wherever the surface is within the radius, and `None` only where
/// it is farther.
#[test]
fn bounded_queries_agree_with_full_ones() {
    println!("| input | radius | points | exact answers | none (farther) |");
    for (name, s) in [("sphere", sphere()), ("torus", torus()), ("part", part())] {
        for r in [0.01, 0.1, 0.5] {
            let pts = random_in(s, 4000, SEED ^ 5);
            let (mut exact, mut none) = (0, 0);
            for &p in &pts {
                let v = s.value(p);
                match s.value_near(p, r) {
                    Some(w) => {
                        assert_eq!(w.to_bits(), v.to_bits(), "{name} at {p}: {w} vs {v}");
                        exact += 1;
                    }
                    None => {
                        assert!(v.abs() >= r, "{name} at {p}: none within {r} but d = {v}");
                        none += 1;
                    }
                }
                if v.abs() < r {
                    assert!(s.value_near(p, r).is_some(), "{name} at {p}: d = {v} within {r}");
                }
            }
            println!("| {name} | {r} | {} | {exact} | {none} |", pts.len());
            assert!(none > 0 && exact > 0, "{name} r {r}: both kinds of answer are exercised");
        }
    }
}

#[test]
fn sign_right_at_random_points() {
    use rayon::prelude::*;
    println!("| input | points | wrong sign (vs winding number) | wrong sign (vs formula, |d| > 2e-2) |");
    println!("|---|---|---|---|");
    type Case = (&'static str, &'static TriSurface, Option<fn(DVec3) -> f64>);
    let cases: [Case; 3] =
        [("sphere", sphere(), Some(sphere_phi)), ("torus", torus(), Some(torus_phi)), ("part", part(), None)];
    for (name, s, phi) in cases {
        let pts = random_in(s, 100_000, SEED ^ 3);
        let wrong: usize = pts
            .par_iter()
            .map(|&p| {
                let d = s.signed_distance(p);
                let inside = s.winding_number(p) > 0.5;
                usize::from((d < 0.0) != inside && d != 0.0)
            })
            .sum();
        let wrong_phi: usize = match phi {
            Some(f) => pts
                .iter()
                .filter(|&&p| f(p).abs() > 2e-2)
                .map(|&p| usize::from((s.signed_distance(p) < 0.0) != (f(p) < 0.0)))
                .sum(),
            None => pts
                .iter()
                .filter(|&&p| part_clearance(p) > 2e-2)
                .map(|&p| usize::from((s.signed_distance(p) < 0.0) != part_inside(p)))
                .sum(),
        };
        println!("| {name} | 100000 | {wrong} | {wrong_phi} |");
        assert_eq!(wrong, 0, "{name}: {wrong} signs disagree with the winding number");
        assert_eq!(wrong_phi, 0, "{name}: {wrong_phi} signs disagree with the formula");
    }
}

#[test]
fn gradient_projects_exactly() {
    let s = torus();
    let mut worst = 0.0f64;
    for p in random_in(s, 2000, SEED ^ 5) {
        let (d, g) = s.value_and_gradient(p);
        let q = p - d * g;
        worst = worst.max(q.distance(s.closest(p).point));
        assert!((g.length() - 1.0).abs() < 1e-12);
    }
    println!("projection p - d grad d vs nearest point: {worst:.1e}");
    assert!(worst < 1e-12);
}

fn feature_summary(name: &str, s: &TriSurface, f: &Features) {
    println!("| {name} | {} | {} | {} | {} |", s.triangles().len(), f.edges.len(), f.corners.len(), f.curves.len());
}

#[test]
fn feature_edges_found() {
    println!("| input | triangles | feature edges | corners | curves |");
    println!("|---|---|---|---|---|");
    let c = cube(4);
    let f = c.features(DEFAULT_FEATURE_ANGLE);
    feature_summary("cube 4x4 per face", &c, &f);
    assert_eq!(f.edges.len(), 12 * 4);
    assert_eq!(f.corners.len(), 8);
    assert_eq!(f.curves.len(), 12);
    let s = sphere().features(DEFAULT_FEATURE_ANGLE);
    feature_summary("sphere", sphere(), &s);
    assert!(s.edges.is_empty() && s.corners.is_empty());
    let n = noisy_sphere().features(DEFAULT_FEATURE_ANGLE);
    feature_summary("noisy sphere", noisy_sphere(), &n);
    assert!(n.edges.is_empty());
    let p = part().features(DEFAULT_FEATURE_ANGLE);
    feature_summary("part", part(), &p);
    // 12 box edges and 2 rims of the hole; every feature edge on one of them.
    let pts = part().points();
    let spurious: Vec<DVec3> = p
        .edges
        .iter()
        .map(|&[a, b]| (pts[a] + pts[b]) * 0.5)
        .filter(|m| {
            let on_box_edge =
                [m.x.abs() > 1.0 - 1e-9, m.y.abs() > 1.0 - 1e-9, m.z.abs() > 0.5 - 1e-9].iter().filter(|&&x| x).count()
                    >= 2;
            let on_rim = m.z.abs() > 0.5 - 1e-9 && (m.x.hypot(m.y) - 0.4).abs() < 0.01;
            !(on_box_edge || on_rim)
        })
        .collect();
    println!(
        "part: {} feature edges on no sharp edge of the part: {:?}",
        spurious.len(),
        &spurious[..spurious.len().min(8)]
    );
    assert!(spurious.is_empty());
    assert_eq!(p.corners.len(), 8, "corners {:?}", p.corners.iter().map(|&c| pts[c]).collect::<Vec<_>>());
    assert_eq!(p.curves.len(), 14);
    // Sampling: points about h apart on the curves, corners included.
    let samples = p.sample(part(), &|_| 0.1);
    println!("part: {} feature points at spacing 0.1", samples.len());
    let expected = (8.0 * 2.0 + 4.0 * 1.0 + 2.0 * 2.0 * std::f64::consts::PI * 0.4) / 0.1;
    assert!((samples.len() as f64) > 0.9 * expected && (samples.len() as f64) < 1.1 * expected + 8.0);
}

fn expect_surface_error(r: Result<TriSurface, Error>, what: &str, ok: impl Fn(&SurfaceError) -> bool) {
    match r {
        Err(Error::Surface(e)) if ok(&e) => println!("{what}: {e}"),
        Err(e) => panic!("{what}: wrong error {e}"),
        Ok(_) => panic!("{what}: accepted"),
    }
}

#[test]
fn bad_surfaces_refused() {
    let s = sphere();
    let pts: Vec<[f64; 3]> = s.points().iter().map(|p| p.to_array()).collect();
    let tris = s.triangles().to_vec();
    // Open: one triangle missing.
    expect_surface_error(TriSurface::new(pts.clone(), tris[1..].to_vec()), "open", |e| {
        matches!(e, SurfaceError::Open { edges: 3, .. })
    });
    // Non-manifold: a fin on an edge (a third triangle on it).
    let mut fin_pts = pts.clone();
    fin_pts.push([5.0, 5.0, 5.0]);
    let mut fin = tris.clone();
    fin.push([tris[0][0], tris[0][1], pts.len()]);
    expect_surface_error(TriSurface::new(fin_pts, fin), "non-manifold", |e| {
        matches!(e, SurfaceError::NonManifoldEdge { .. })
    });
    // Non-manifold vertex: two cubes touching at a corner.
    let c = cube(1);
    let mut two: Vec<[f64; 3]> = c.points().iter().map(|p| p.to_array()).collect();
    let n = two.len();
    two.extend(c.points().iter().map(|p| (*p + DVec3::splat(2.0)).to_array()));
    let mut t2 = c.triangles().to_vec();
    t2.extend(c.triangles().iter().map(|t| t.map(|v| v + n)));
    expect_surface_error(TriSurface::new(two, t2), "touching cubes", |e| {
        matches!(e, SurfaceError::NonManifoldVertex { .. })
    });
    // Self-intersecting: two overlapping spheres.
    let mut both = pts.clone();
    both.extend(pts.iter().map(|p| [p[0] + 0.5, p[1], p[2]]));
    let mut bt = tris.clone();
    bt.extend(tris.iter().map(|t| t.map(|v| v + pts.len())));
    expect_surface_error(TriSurface::new(both, bt), "self-intersecting", |e| {
        matches!(e, SurfaceError::SelfIntersecting { .. })
    });
    expect_surface_error(TriSurface::new(Vec::new(), Vec::new()), "empty", |e| matches!(e, SurfaceError::Empty));
    // Reversed triangles are turned, and an inside-out surface is turned outward.
    let mut flipped = tris.clone();
    for t in flipped.iter_mut().step_by(3) {
        t.swap(1, 2);
    }
    let f = TriSurface::new(pts.clone(), flipped).expect("partly reversed sphere is repaired");
    assert!((f.volume() - s.volume()).abs() < 1e-12);
    let inside_out: Vec<[usize; 3]> = tris.iter().map(|t| [t[0], t[2], t[1]]).collect();
    let f = TriSurface::new(pts, inside_out).expect("inside-out sphere is turned");
    assert!(f.signed_distance(DVec3::ZERO) < 0.0);
}

/// A zero-length edge, as CAD exports write them (two corners of a triangle at one point): the
/// two triangles on it are dropped, which collapses it, and the rest is a valid closed surface.
/// A triangle with three distinct corners on a line (no area) is still refused.
#[test]
fn zero_length_edges_are_collapsed() {
    let s = sphere();
    let mut pts: Vec<[f64; 3]> = s.points().iter().map(|p| p.to_array()).collect();
    let tris = s.triangles().to_vec();
    let [a, b, _] = tris[0];
    pts[b] = pts[a];
    let r = TriSurface::new(pts, tris.clone()).expect("the zero-length edge collapses");
    println!(
        "sphere of {} triangles with one zero-length edge: {} dropped, {} left, Euler {}",
        tris.len(),
        r.dropped_triangles(),
        r.triangles().len(),
        r.euler_characteristic()
    );
    assert_eq!(r.dropped_triangles(), 2);
    assert_eq!(r.triangles().len(), tris.len() - 2);
    assert_eq!(r.euler_characteristic(), 2);
    assert!((r.volume() / s.volume() - 1.0).abs() < 1e-2);
    assert_eq!(s.dropped_triangles(), 0);
    // Three distinct corners on a line: no area, refused.
    let flat = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    expect_surface_error(TriSurface::new(flat, vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]]), "collinear", |e| {
        matches!(e, SurfaceError::Degenerate { .. })
    });
}

/// Reading every format: each written by the project's own writers (and binary STL and PLY by
/// hand), read back to the same surface.
#[test]
fn every_format_reads() {
    let dir = std::env::temp_dir().join(format!("trussmesh-trisurf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let s = torus();
    let data = MeshData {
        dim: 3,
        cell_type: trussmesh::io::CellType::Triangle,
        points: s.points().iter().map(|p| p.to_array()).collect(),
        cells: s.triangles().iter().flatten().copied().collect(),
        subdomain: None,
    };
    for ext in ["stl", "obj", "ply", "mesh", "msh", "vtu"] {
        let path = dir.join(format!("torus.{ext}"));
        trussmesh::io::write_mesh(&path, &data).unwrap();
        let r = TriSurface::read(&path).unwrap_or_else(|e| panic!("{ext}: {e}"));
        assert_eq!(r.triangles().len(), s.triangles().len(), "{ext}");
        assert!((r.volume() - s.volume()).abs() < 1e-9 * s.volume().abs(), "{ext}");
    }
    // Binary STL (f32 corners).
    let mut stl = vec![0u8; 80];
    stl.extend((s.triangles().len() as u32).to_le_bytes());
    for t in s.triangles() {
        stl.extend([0u8; 12]);
        for &v in t {
            for c in s.points()[v].to_array() {
                stl.extend((c as f32).to_le_bytes());
            }
        }
        stl.extend([0u8; 2]);
    }
    let path = dir.join("binary.stl");
    std::fs::write(&path, &stl).unwrap();
    let r = TriSurface::read(&path).unwrap();
    assert_eq!(r.triangles().len(), s.triangles().len());
    assert!((r.volume() - s.volume()).abs() < 1e-5);
    // Truncated: the count disagrees with the size.
    std::fs::write(&path, &stl[..stl.len() - 7]).unwrap();
    let e = TriSurface::read(&path).unwrap_err();
    println!("truncated binary STL: {e}");
    assert!(e.to_string().contains("claims"), "{e}");
    // Binary PLY, little endian, float vertices and uchar/int faces.
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        s.points().len(),
        s.triangles().len()
    )
    .into_bytes();
    for p in s.points() {
        for c in p.to_array() {
            ply.extend((c as f32).to_le_bytes());
        }
    }
    for t in s.triangles() {
        ply.push(3);
        for &v in t {
            ply.extend((v as i32).to_le_bytes());
        }
    }
    let path = dir.join("binary.ply");
    std::fs::write(&path, &ply).unwrap();
    let r = TriSurface::read(&path).unwrap();
    assert_eq!(r.triangles().len(), s.triangles().len());
    // Empty files.
    let path = dir.join("empty.stl");
    std::fs::write(&path, b"").unwrap();
    let e = TriSurface::read(&path).unwrap_err();
    println!("empty file: {e}");
    assert!(e.to_string().contains("empty"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The box [-1, 1]^3 with its edge x = y = 1 cut by a chamfer of width `c` (along x and y),
/// each face a fan of triangles.
fn chamfered_box(c: f64) -> TriSurface {
    let faces: Vec<Vec<[f64; 3]>> = vec![
        vec![[1.0, -1.0, -1.0], [1.0, 1.0 - c, -1.0], [1.0, 1.0 - c, 1.0], [1.0, -1.0, 1.0]],
        vec![[-1.0, 1.0, -1.0], [-1.0, 1.0, 1.0], [1.0 - c, 1.0, 1.0], [1.0 - c, 1.0, -1.0]],
        vec![[1.0, 1.0 - c, -1.0], [1.0 - c, 1.0, -1.0], [1.0 - c, 1.0, 1.0], [1.0, 1.0 - c, 1.0]],
        vec![[-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [1.0, 1.0 - c, 1.0], [1.0 - c, 1.0, 1.0], [-1.0, 1.0, 1.0]],
        vec![[-1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [1.0 - c, 1.0, -1.0], [1.0, 1.0 - c, -1.0], [1.0, -1.0, -1.0]],
        vec![[-1.0, -1.0, -1.0], [-1.0, -1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, 1.0, -1.0]],
        vec![[-1.0, -1.0, -1.0], [1.0, -1.0, -1.0], [1.0, -1.0, 1.0], [-1.0, -1.0, 1.0]],
    ];
    let mut pts: Vec<[f64; 3]> = Vec::new();
    let mut tris = Vec::new();
    for f in faces {
        let base = pts.len();
        pts.extend(&f);
        for k in 1..f.len() - 1 {
            tris.push([base, base + k, base + k + 1]);
        }
    }
    TriSurface::new(pts, tris).expect("chamfered box")
}

/// A face narrower than a quarter of the mesh size joins a neighbour (its border with it is no
/// longer a curve to hold, and the corners at its ends are gone); at a fine enough size it stays.
#[test]
fn narrow_faces_merge_at_the_mesh_size() {
    let chamfer = DVec3::new(1.0 - 0.005, 1.0 - 0.005, 0.0);
    let (xface, yface) = (DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0));
    for (h, merged) in [(None, false), (Some(0.001), false), (Some(0.1), true), (Some(1.0), true)] {
        let s = chamfered_box(0.01).with_feature_size(h);
        let c = s.creases().expect("the box has sharp edges");
        let [pc, px, py] = [chamfer, xface, yface].map(|p| c.patch(p).expect("a patch"));
        println!("feature size {h:?}: chamfer patch {pc}, x face {px}, y face {py}, {} corners", c.corners().len());
        assert_ne!(px, py);
        assert_eq!(pc == px || pc == py, merged);
        assert_eq!(c.corners().len(), if merged { 8 } else { 10 });
        // The curve between the two faces exists only once the chamfer is part of one of them.
        assert_eq!(c.onto(px, py, DVec3::new(1.0, 1.0, 0.0)).is_some(), merged);
    }
}
