//! Triangulated geometry: signed-distance queries per second and the cost of building the
//! geometry (checks, hierarchy, normals) on icospheres of about 2 10^4 to 1.3 10^6 triangles,
//! and whole runs against the input size at a fixed h0: tetrahedra inside them, and their
//! surfaces remeshed.
//!
//! `cargo bench --bench trisurf` (criterion; `-- distance` for the queries only).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::DVec3;
use std::collections::HashMap;
use trussmesh::geometry::TriSurface;
use trussmesh::{mesh_3d, mesh_surface, Implicit3};

/// The unit icosphere after `levels` subdivisions: 20 4^levels triangles.
fn icosphere(levels: u32) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pts: Vec<DVec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| DVec3::from_array(*p).normalize())
    .collect();
    let mut tris: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
        let mut next = Vec::with_capacity(4 * tris.len());
        for t in &tris {
            let mut m = [0; 3];
            for k in 0..3 {
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                m[k] = *mid.entry((a, b)).or_insert_with(|| {
                    pts.push(((pts[a] + pts[b]) * 0.5).normalize());
                    pts.len() - 1
                });
            }
            next.push([t[0], m[0], m[2]]);
            next.push([t[1], m[1], m[0]]);
            next.push([t[2], m[2], m[1]]);
            next.push(m);
        }
        tris = next;
    }
    (pts.iter().map(|p| p.to_array()).collect(), tris)
}

fn queries(n: usize) -> Vec<DVec3> {
    let mut rng = trussmesh::testing::Rng::new(trussmesh::testing::SEED);
    (0..n).map(|_| DVec3::new(rng.range(-1.3, 1.3), rng.range(-1.3, 1.3), rng.range(-1.3, 1.3))).collect()
}

fn bench(c: &mut Criterion) {
    let pts = queries(2_000);
    let mut dist = c.benchmark_group("distance");
    dist.sample_size(10);
    dist.throughput(Throughput::Elements(pts.len() as u64));
    let mut built = Vec::new();
    for levels in [5, 6, 7, 8] {
        let (p, t) = icosphere(levels);
        let n = t.len();
        let s = TriSurface::new(p.clone(), t.clone()).expect("icosphere");
        dist.bench_with_input(BenchmarkId::new("signed distance", n), &s, |b, s| {
            b.iter(|| pts.iter().map(|&q| s.value(q)).sum::<f64>())
        });
        // Near the surface, where the meshers ask.
        let near: Vec<DVec3> = pts.iter().map(|q| q.normalize_or_zero() * 1.01).collect();
        dist.bench_with_input(BenchmarkId::new("signed distance near", n), &s, |b, s| {
            b.iter(|| near.iter().map(|&q| s.value(q)).sum::<f64>())
        });
        built.push((n, p, t));
    }
    dist.finish();
    let mut build = c.benchmark_group("build");
    build.sample_size(10);
    let built = &built[..];
    for (n, p, t) in built {
        build.throughput(Throughput::Elements(*n as u64));
        build.bench_function(BenchmarkId::new("check and index", n), |b| {
            b.iter(|| TriSurface::new(p.clone(), t.clone()).expect("icosphere"))
        });
    }
    build.finish();
    let mut run = c.benchmark_group("volume run h0 0.2");
    run.sample_size(10);
    for (n, p, t) in built {
        let s = TriSurface::new(p.clone(), t.clone()).expect("icosphere");
        let opts = s.volume_options(0.2, None, Some(trussmesh::geometry::trisurf::DEFAULT_FEATURE_ANGLE));
        run.bench_function(BenchmarkId::new("mesh_3d", n), |b| b.iter(|| mesh_3d(&s, &opts).expect("mesh")));
    }
    run.finish();
    let mut remesh = c.benchmark_group("surface remesh h0 0.1");
    remesh.sample_size(10);
    for (n, p, t) in built {
        let s = TriSurface::new(p.clone(), t.clone()).expect("icosphere");
        let opts = s.surface_options(0.1);
        remesh
            .bench_function(BenchmarkId::new("mesh_surface", n), |b| b.iter(|| mesh_surface(&s, &opts).expect("mesh")));
    }
    remesh.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
