//! Planar polylines: signed-distance queries per second (nearest segment through the hierarchy
//! plus the exact even-odd ray) and the cost of building the geometry (checks for crossings,
//! hierarchy) on a wavy closed outline of 10^3 to 10^6 segments, the queries against brute force
//! over every segment at 10^3 (the ratio is the hierarchy's gain).
//!
//! `cargo bench --bench polygons` (criterion; `-- distance` for the queries only).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::DVec2;
use std::f64::consts::PI;
use trussmesh::geometry::{Implicit2, Polygons2};

fn outline(n: usize) -> Vec<Vec<[f64; 2]>> {
    vec![(0..n)
        .map(|k| {
            let a = 2.0 * PI * k as f64 / n as f64;
            let r = 1.0 + 0.2 * (7.0 * a).sin();
            [r * a.cos(), r * a.sin()]
        })
        .collect()]
}

fn points(n: usize) -> Vec<DVec2> {
    let mut r = trussmesh::testing::Rng::new(trussmesh::testing::SEED);
    (0..n).map(|_| DVec2::new(r.range(-1.4, 1.4), r.range(-1.4, 1.4))).collect()
}

fn distance(c: &mut Criterion) {
    let ps = points(1000);
    let mut g = c.benchmark_group("distance");
    g.throughput(Throughput::Elements(ps.len() as u64));
    for n in [1_000usize, 10_000, 100_000, 1_000_000] {
        let geom = Polygons2::new(outline(n)).expect("a valid outline");
        g.bench_with_input(BenchmarkId::new("hierarchy", n), &geom, |b, geom| {
            b.iter(|| ps.iter().map(|&p| geom.value(p)).sum::<f64>())
        });
        if n == 1_000 {
            g.bench_with_input(BenchmarkId::new("brute force", n), &geom, |b, geom| {
                b.iter(|| {
                    ps.iter()
                        .map(|&p| {
                            let d = geom.nearest_brute_force(p).dist2.sqrt();
                            if geom.contains_brute_force(p) {
                                -d
                            } else {
                                d
                            }
                        })
                        .sum::<f64>()
                })
            });
        }
    }
    g.finish();
}

fn build(c: &mut Criterion) {
    let mut g = c.benchmark_group("build");
    g.sample_size(10);
    for n in [1_000usize, 10_000, 100_000, 1_000_000] {
        let loops = outline(n);
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &loops, |b, loops| {
            b.iter(|| Polygons2::new(loops.clone()).expect("valid").num_segments())
        });
    }
    g.finish();
}

criterion_group!(benches, distance, build);
criterion_main!(benches);
