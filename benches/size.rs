//! Mesh size functions: the fast gradient limiter (seed Algorithm 4-2) on the table 4.3 model
//! problem at 10^4 .. 6.4 x 10^5 nodes, the iterative H-J scheme at the small sizes, and fast
//! marching reinitialisation of a circle on a 1000 x 1000 grid.

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion, Throughput};
use glam::DVec2;
use trussmesh::geometry::Grid2;
use trussmesh::size::{gradient_limit_fast_2d, gradient_limit_hj_2d, reinitialize_2d, Slope};

/// (-50,50)^2 with n x n nodes, h(-10,0) = 1, h(10,0) = 5 at the nearest nodes, 1e10 elsewhere.
fn model(n: usize) -> (Vec<f64>, f64) {
    let dx = 100.0 / n as f64;
    let mut h = vec![1e10; n * n];
    for (x, v) in [(-10.0, 1.0), (10.0, 5.0)] {
        let i = ((x + 50.0) / dx).round() as usize;
        let j = (50.0 / dx).round() as usize;
        h[i + n * j] = v;
    }
    (h, dx)
}

fn limiter(c: &mut Criterion) {
    let mut g = c.benchmark_group("size/gradient_limit");
    g.sample_size(10);
    for n in [100usize, 200, 400, 800] {
        let (h0, dx) = model(n);
        g.throughput(Throughput::Elements((n * n) as u64));
        g.bench_with_input(BenchmarkId::new("fast", n * n), &n, |b, &n| {
            b.iter_batched(
                || h0.clone(),
                |mut h| {
                    gradient_limit_fast_2d(&mut h, (n, n), dx, &Slope::Constant(0.3)).unwrap();
                    h
                },
                BatchSize::LargeInput,
            )
        });
        if n <= 200 {
            g.bench_with_input(BenchmarkId::new("hj_iteration", n * n), &n, |b, &n| {
                b.iter_batched(
                    || h0.clone(),
                    |mut h| {
                        gradient_limit_hj_2d(&mut h, (n, n), dx, &Slope::Constant(0.3), 1e-2, 1 << 20).unwrap();
                        h
                    },
                    BatchSize::LargeInput,
                )
            });
        }
    }
    g.finish();
}

fn marching(c: &mut Criterion) {
    let n = 1000;
    let h = 2.0 / (n - 1) as f64;
    let phi = |p: DVec2| p.length_squared() - 0.25;
    let grid = Grid2::sample(&phi, [-1.0, -1.0], [1.0, 1.0], h).unwrap();
    let mut g = c.benchmark_group("size/fast_marching");
    g.sample_size(10);
    g.throughput(Throughput::Elements((n * n) as u64));
    g.bench_function("reinitialise circle 1000x1000", |b| b.iter(|| reinitialize_2d(&grid)));
    g.finish();
}

criterion_group!(benches, limiter, marching);
criterion_main!(benches);
