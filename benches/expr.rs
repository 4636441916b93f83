//! Interpreted expression against the same distance written as a Rust closure.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use trussmesh::expr::Expr;

const SRC: &str = "max(sqrt(x^2+y^2)-1, -(sqrt((x+0.4)^2+y^2)-0.55), -y)";

fn closure(x: f64, y: f64) -> f64 {
    let a = (x * x + y * y).sqrt() - 1.0;
    let b = -(((x + 0.4) * (x + 0.4) + y * y).sqrt() - 0.55);
    a.max(b).max(-y)
}

/// A few points spread over the domain so branches are not trivially predicted.
fn points() -> Vec<(f64, f64)> {
    (0..64)
        .map(|i| {
            let t = i as f64 * 0.37;
            (1.3 * t.cos(), 1.1 * (1.7 * t).sin())
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let e = Expr::parse(SRC).unwrap();
    let pts = points();
    for &(x, y) in &pts {
        assert!((e.eval(x, y, 0.0) - closure(x, y)).abs() < 1e-15);
    }
    let n = pts.len() as u32;
    let mut g = c.benchmark_group("moon");
    g.bench_function("closure", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for &(x, y) in black_box(&pts) {
                s += closure(black_box(x), black_box(y));
            }
            s / n as f64
        })
    });
    g.bench_function("expr_eval", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for &(x, y) in black_box(&pts) {
                s += e.eval(black_box(x), black_box(y), 0.0);
            }
            s / n as f64
        })
    });
    g.bench_function("expr_eval_grad", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for &(x, y) in black_box(&pts) {
                s += e.eval_grad(black_box(x), black_box(y), 0.0).1[0];
            }
            s / n as f64
        })
    });
    g.finish();
    c.bench_function("parse", |b| b.iter(|| Expr::parse(black_box(SRC)).unwrap()));
}

criterion_group!(benches, bench);
criterion_main!(benches);
