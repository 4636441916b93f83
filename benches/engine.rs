//! The half-edge engine: flips, splits and collapses per second, and Delaunay construction of
//! random points compared with spade on the same points in the same run.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, SamplingMode, Throughput};
use glam::DVec2;
use trussmesh::testing::{random_points, SEED};
use trussmesh::topology::TriMesh;

fn flips(c: &mut Criterion) {
    let (mut m, _) = TriMesh::delaunay(&random_points(100_000, SEED)).unwrap();
    let edges: Vec<_> = m.edge_ids().filter(|&h| m.check_flip(h).is_ok()).collect();
    let mut g = c.benchmark_group("engine");
    g.throughput(Throughput::Elements(2 * edges.len() as u64));
    g.sample_size(10);
    // Each edge is flipped and flipped back: two checked flips per edge.
    g.bench_function("flip (checked, exact orientation)", |b| {
        b.iter(|| {
            let mut n = 0;
            for &h in &edges {
                if m.flip(h).is_ok() {
                    n += 1;
                    let _ = m.flip(h);
                }
            }
            n
        })
    });
    g.finish();
}

fn splits_and_collapses(c: &mut Criterion) {
    let (base, _) = TriMesh::delaunay(&random_points(50_000, SEED)).unwrap();
    let edges: Vec<_> = base.edge_ids().filter(|&h| !base.is_boundary_edge(h)).collect();
    let mut g = c.benchmark_group("engine");
    g.sample_size(10);
    g.throughput(Throughput::Elements(edges.len() as u64));
    g.bench_function("split (checked, midpoint)", |b| {
        b.iter_batched(
            || base.clone(),
            |mut m| {
                for &h in &edges {
                    let p = (m.pos(m.origin(h)) + m.pos(m.dest(h))) * 0.5;
                    let _ = m.split_edge(h, p);
                }
                m
            },
            BatchSize::LargeInput,
        )
    });
    // Split every edge once, then collapse each new vertex back along the first half.
    let mut split = base.clone();
    let mut halves = Vec::new();
    for &h in &edges {
        let p = (split.pos(split.origin(h)) + split.pos(split.dest(h))) * 0.5;
        if let Ok(v) = split.split_edge(h, p) {
            halves.push(split.find_half_edge(v, split.origin(h)).unwrap());
        }
    }
    g.throughput(Throughput::Elements(halves.len() as u64));
    g.bench_function("collapse (checked, link condition)", |b| {
        b.iter_batched(
            || split.clone(),
            |mut m| {
                for &h in &halves {
                    if m.contains_half_edge(h) {
                        let p = m.pos(m.dest(h));
                        let _ = m.collapse(h, p);
                    }
                }
                m
            },
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

fn delaunay(c: &mut Criterion) {
    use spade::{DelaunayTriangulation, Point2, Triangulation};
    let mut g = c.benchmark_group("delaunay");
    g.sample_size(10);
    // One iteration per sample: linear sampling would run 55 iterations of spade's unordered
    // incremental insertion of 10^6 points (tens of seconds each).
    g.sampling_mode(SamplingMode::Flat);
    for &n in &[100_000usize, 1_000_000] {
        let pts = random_points(n, SEED);
        let sp: Vec<Point2<f64>> = pts.iter().map(|p: &DVec2| Point2::new(p.x, p.y)).collect();
        g.throughput(Throughput::Elements(n as u64));
        g.bench_function(format!("trussmesh incremental {n}"), |b| {
            b.iter(|| TriMesh::delaunay(&pts).unwrap().0.num_faces())
        });
        g.bench_function(format!("spade bulk_load {n}"), |b| {
            b.iter(|| DelaunayTriangulation::<Point2<f64>>::bulk_load(sp.clone()).unwrap().num_inner_faces())
        });
        g.bench_function(format!("spade incremental {n}"), |b| {
            b.iter(|| {
                let mut t = DelaunayTriangulation::<Point2<f64>>::new();
                for p in &sp {
                    t.insert(*p).unwrap();
                }
                t.num_inner_faces()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, flips, splits_and_collapses, delaunay);
criterion_main!(benches);
