//! Closed triangle meshes the project makes itself, for the triangulated-geometry tests: a
//! sphere and a torus from the surface mesher, a noisy sphere (every vertex moved radially by up
//! to 1%, like a scan), and a CSG part with exact sharp edges (a square minus a disk meshed by
//! the 2-D mesher, extruded: the box [-1, 1]^2 x [-0.5, 0.5] minus a cylinder of radius 0.4).
#![allow(dead_code)]

use glam::DVec3;
use std::collections::HashMap;
use trussmesh::geometry::trisurf::DEFAULT_FEATURE_ANGLE;
use trussmesh::geometry::{difference, Circle, Rectangle, TriSurface};
use trussmesh::io::MeshData;
use trussmesh::testing::{Rng, SEED};
use trussmesh::{mesh_2d, mesh_surface, Options2, SurfaceOptions};

pub fn sphere_phi(p: DVec3) -> f64 {
    p.length() - 1.0
}

pub fn torus_phi(p: DVec3) -> f64 {
    let rho = (p.x * p.x + p.y * p.y).sqrt() - 1.0;
    (rho * rho + p.z * p.z).sqrt() - 0.35
}

/// The part's exact signed distance is not needed; its inside test is.
pub fn part_inside(p: DVec3) -> bool {
    p.x.abs() < 1.0 && p.y.abs() < 1.0 && p.z.abs() < 0.5 && p.x.hypot(p.y) > 0.4
}

/// Distance from the part's boundary, for points not within it.
pub fn part_clearance(p: DVec3) -> f64 {
    let faces =
        [(1.0 - p.x.abs()).abs(), (1.0 - p.y.abs()).abs(), (0.5 - p.z.abs()).abs(), (p.x.hypot(p.y) - 0.4).abs()];
    faces.into_iter().fold(f64::INFINITY, f64::min)
}

pub const PART_VOLUME: f64 = 4.0 - std::f64::consts::PI * 0.16;

pub fn from_surface_mesher(phi: fn(DVec3) -> f64, h: f64, r: f64) -> TriSurface {
    let out = mesh_surface(&phi, &SurfaceOptions::uniform(h, [-r; 3], [r; 3])).expect("surface mesh");
    TriSurface::from_mesh_data(&MeshData::from_trimesh3(&out.mesh)).expect("closed surface")
}

pub fn noisy(s: &TriSurface) -> TriSurface {
    let mut rng = Rng::new(SEED ^ 7);
    let pts: Vec<[f64; 3]> = s.points().iter().map(|p| (*p * (1.0 + rng.range(-0.01, 0.01))).to_array()).collect();
    TriSurface::new(pts, s.triangles().to_vec()).expect("noisy sphere")
}

/// The part at edge length about `h`: top and bottom from the 2-D mesh, walls in layers.
pub fn part(h: f64) -> TriSurface {
    let domain = difference(Rectangle::new([-1.0, -1.0], [1.0, 1.0]), Circle::new([0.0, 0.0], 0.4));
    let out = mesh_2d(&domain, &Options2::uniform(h, [-1.0, -1.0], [1.0, 1.0])).expect("2-D part");
    let a = out.mesh.to_arrays();
    let n = a.points.len();
    let layers = (1.0 / h).round().max(1.0) as usize;
    let mut pts: Vec<[f64; 3]> = Vec::new();
    for z in [-0.5, 0.5] {
        pts.extend(a.points.iter().map(|p| [p.x, p.y, z]));
    }
    let mut tris: Vec<[usize; 3]> = Vec::new();
    for c in &a.cells {
        tris.push([c[0] + n, c[1] + n, c[2] + n]);
        tris.push([c[0], c[2], c[1]]);
    }
    // Boundary edges of the planar mesh (used by one triangle), each a wall of `layers` rows.
    let mut count: HashMap<(usize, usize), usize> = HashMap::new();
    for c in &a.cells {
        for k in 0..3 {
            let (u, v) = (c[k], c[(k + 1) % 3]);
            *count.entry((u.min(v), u.max(v))).or_insert(0) += 1;
        }
    }
    let mut ring: HashMap<usize, Vec<usize>> = HashMap::new();
    let level = |v: usize, l: usize, pts: &mut Vec<[f64; 3]>, ring: &mut HashMap<usize, Vec<usize>>| -> usize {
        if l == 0 {
            return v;
        }
        if l == layers {
            return v + n;
        }
        let r = ring.entry(v).or_insert_with(|| {
            (1..layers)
                .map(|i| {
                    let p = a.points[v];
                    pts.push([p.x, p.y, -0.5 + i as f64 / layers as f64]);
                    pts.len() - 1
                })
                .collect()
        });
        r[l - 1]
    };
    let mut edges: Vec<(usize, usize)> = Vec::new();
    for c in &a.cells {
        for k in 0..3 {
            let (u, v) = (c[k], c[(k + 1) % 3]);
            if count[&(u.min(v), u.max(v))] == 1 {
                edges.push((u, v));
            }
        }
    }
    for (u, v) in edges {
        for l in 0..layers {
            let (u0, v0) = (level(u, l, &mut pts, &mut ring), level(v, l, &mut pts, &mut ring));
            let (u1, v1) = (level(u, l + 1, &mut pts, &mut ring), level(v, l + 1, &mut pts, &mut ring));
            tris.push([u0, v0, v1]);
            tris.push([u0, v1, u1]);
        }
    }
    TriSurface::new(pts, tris).expect("part surface")
}

/// The box of half sides `half`, each face split into n x n squares of two triangles, turned by
/// `rot` about its centre and moved to `centre`: exact sharp edges in no grid plane.
pub fn turned_box(n: usize, half: DVec3, rot: glam::DMat3, centre: DVec3) -> TriSurface {
    let mut index: HashMap<[i64; 3], usize> = HashMap::new();
    let mut pts: Vec<[f64; 3]> = Vec::new();
    let mut tris: Vec<[usize; 3]> = Vec::new();
    // Lattice coordinates in 0..=n on each axis; the point is shared by the faces it is on.
    let mut id = |l: [i64; 3], pts: &mut Vec<[f64; 3]>| -> usize {
        *index.entry(l).or_insert_with(|| {
            let u = DVec3::new(l[0] as f64, l[1] as f64, l[2] as f64) * (2.0 / n as f64) - DVec3::ONE;
            pts.push((centre + rot * (u * half)).to_array());
            pts.len() - 1
        })
    };
    let n = n as i64;
    for ax in 0..3 {
        let (o0, o1) = ((ax + 1) % 3, (ax + 2) % 3);
        for side in [0, n] {
            for i in 0..n {
                for j in 0..n {
                    let at = |a: i64, b: i64| {
                        let mut l = [0i64; 3];
                        l[ax] = side;
                        l[o0] = a;
                        l[o1] = b;
                        l
                    };
                    let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)].map(|l| id(l, &mut pts));
                    // (o0, o1, ax) is right-handed: counter-clockwise in (o0, o1) faces +ax.
                    if side == n {
                        tris.push([q[0], q[1], q[2]]);
                        tris.push([q[0], q[2], q[3]]);
                    } else {
                        tris.push([q[0], q[2], q[1]]);
                        tris.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    TriSurface::new(pts, tris).expect("turned box")
}

/// The seed of the turned-box family.
pub const BOX_SEED: u64 = 0x5a4b;

/// The next box of a random family: turned about a random axis by 0.2 to 1.4 radians, half
/// sides 0.6 to 1.0.
pub fn random_turned_box(rng: &mut Rng) -> TriSurface {
    let axis = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize();
    let rot = glam::DMat3::from_axis_angle(axis, rng.range(0.2, 1.4));
    let half = DVec3::new(rng.range(0.6, 1.0), rng.range(0.6, 1.0), rng.range(0.6, 1.0));
    turned_box(5, half, rot, DVec3::ZERO)
}

/// The largest distance from points 0.1 h0 apart on the input's feature edges to the nearest
/// feature edge of `out` (at the same feature angle), over h0, and the number of corners of `out`.
pub fn feature_gap(input: &TriSurface, out: &TriSurface, h0: f64) -> (f64, usize) {
    let fin = input.features(DEFAULT_FEATURE_ANGLE);
    let fout = out.features(DEFAULT_FEATURE_ANGLE);
    let bp = out.points();
    let segs: Vec<(DVec3, DVec3)> = fout.edges.iter().map(|&[a, b]| (bp[a], bp[b])).collect();
    let seg_dist = |q: DVec3, a: DVec3, b: DVec3| {
        let t = ((q - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
        q.distance(a + (b - a) * t)
    };
    // Points on the input's own feature edges (not the library's sampling, which may follow a
    // smooth curve through them), 0.1 h0 apart or closer, ends included.
    let ip = input.points();
    let points: Vec<DVec3> = fin
        .edges
        .iter()
        .flat_map(|&[a, b]| {
            let (pa, pb) = (ip[a], ip[b]);
            let n = (pa.distance(pb) / (0.1 * h0)).ceil().max(1.0) as usize;
            (0..=n).map(move |k| pa.lerp(pb, k as f64 / n as f64))
        })
        .collect();
    let worst = points
        .iter()
        .map(|&q| segs.iter().map(|&(a, b)| seg_dist(q, a, b)).fold(f64::INFINITY, f64::min))
        .fold(0.0, f64::max);
    (worst / h0, fout.corners.len())
}

/// A prism over a regular `n`-gon of circumradius `r`, from z = -`half` to `half`: the coarse
/// tessellation a CAD export gives a cylinder (its rims turn 360 / n degrees at each vertex),
/// the caps fanned from their centres and each wall rectangle cut into two triangles.
pub fn polygon_prism(n: usize, r: f64, half: f64) -> TriSurface {
    let mut pts: Vec<[f64; 3]> = vec![[0.0, 0.0, -half], [0.0, 0.0, half]];
    for z in [-half, half] {
        for k in 0..n {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            pts.push([r * a.cos(), r * a.sin(), z]);
        }
    }
    let (lo, hi) = (|k: usize| 2 + k % n, |k: usize| 2 + n + k % n);
    let mut tris = Vec::new();
    for k in 0..n {
        tris.push([0, hi(k + 1) - n, lo(k)]);
        tris.push([1, hi(k), hi(k + 1)]);
        tris.push([lo(k), lo(k + 1), hi(k + 1)]);
        tris.push([lo(k), hi(k + 1), hi(k)]);
    }
    TriSurface::new(pts, tris).expect("a closed prism")
}

/// A cone over a regular `n`-gon of circumradius `r` at z = 0, apex at z = `height`: the coarse
/// tessellation a CAD export gives a cone (its facets narrow to nothing at the apex).
pub fn polygon_cone(n: usize, r: f64, height: f64) -> TriSurface {
    let mut pts: Vec<[f64; 3]> = vec![[0.0, 0.0, 0.0], [0.0, 0.0, height]];
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        pts.push([r * a.cos(), r * a.sin(), 0.0]);
    }
    let mut tris = Vec::new();
    for k in 0..n {
        let (a, b) = (2 + k, 2 + (k + 1) % n);
        tris.push([0, b, a]);
        tris.push([1, a, b]);
    }
    TriSurface::new(pts, tris).expect("a closed cone")
}
