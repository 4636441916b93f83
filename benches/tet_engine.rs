//! The tetrahedral engine: 2-3 / 3-2 flips and edge removals per second, and Delaunay
//! tetrahedralization of random points. The 10^6-point Delaunay is timed once, outside
//! criterion's sampling (ten samples would take minutes on a shared machine).

use criterion::{criterion_group, BatchSize, Criterion, Throughput};
use std::time::{Duration, Instant};
use trussmesh::testing::{random_points_3d, SEED};
use trussmesh::topology::{TetId, TetMesh, EDGE_VERTICES};

/// One 2-3 flip and the 3-2 flip that undoes it, for every flippable face of a snapshot.
fn flip_pairs(m: &mut TetMesh, tets: &[TetId]) -> usize {
    let mut n = 0;
    for &t in tets {
        if !m.contains_tet(t) {
            continue;
        }
        for i in 0..4 {
            if !m.contains_tet(t) {
                break;
            }
            let Some((u, j)) = m.neighbour(t, i) else {
                continue;
            };
            let (d, e) = (m.tet(t).v[i], m.tet(u).v[j as usize]);
            let Ok(made) = m.flip23(t, i) else { continue };
            let s = made[0];
            let (a, b) = (m.local_index(s, d).unwrap(), m.local_index(s, e).unwrap());
            let k = EDGE_VERTICES.iter().position(|&[x, y]| (x == a && y == b) || (x == b && y == a)).unwrap();
            m.flip32(s, k).expect("a 2-3 flip can be undone");
            n += 2;
        }
    }
    n
}

fn removals(m: &mut TetMesh, tets: &[TetId]) -> usize {
    let mut n = 0;
    for &t in tets {
        for e in 0..6 {
            if m.contains_tet(t) && m.remove_edge(t, e).is_ok() {
                n += 1;
            }
        }
    }
    n
}

fn ops(c: &mut Criterion) {
    let (base, _) = TetMesh::delaunay(&random_points_3d(20_000, SEED)).unwrap();
    let tets: Vec<TetId> = base.tet_ids().collect();
    let mut g = c.benchmark_group("tet_engine");
    g.sample_size(10).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(4));
    let flips = flip_pairs(&mut base.clone(), &tets);
    g.throughput(Throughput::Elements(flips as u64));
    g.bench_function("2-3 + 3-2 flips (checked, exact)", |b| {
        b.iter_batched(|| base.clone(), |mut m| flip_pairs(&mut m, &tets), BatchSize::LargeInput)
    });
    let removed = removals(&mut base.clone(), &tets);
    g.throughput(Throughput::Elements(removed as u64));
    g.bench_function("edge removal (checked, DP, exact)", |b| {
        b.iter_batched(|| base.clone(), |mut m| removals(&mut m, &tets), BatchSize::LargeInput)
    });
    g.finish();
    println!("(flips per iteration {flips}, edge removals per iteration {removed})");
}

fn delaunay(c: &mut Criterion) {
    let mut g = c.benchmark_group("tet_delaunay");
    g.sample_size(10).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(10));
    let n = 100_000;
    let pts = random_points_3d(n, SEED);
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function(format!("incremental cavities {n}"), |b| b.iter(|| TetMesh::delaunay(&pts).unwrap().0.num_tets()));
    g.finish();
}

fn delaunay_1e6_once() {
    let n = 1_000_000;
    let pts = random_points_3d(n, SEED);
    let t = Instant::now();
    let (m, _) = TetMesh::delaunay(&pts).unwrap();
    let dt = t.elapsed().as_secs_f64();
    println!(
        "tet_delaunay/incremental cavities {n} (one run): {dt:.2} s, {:.0} points/s, {} tets",
        n as f64 / dt,
        m.num_tets()
    );
}

criterion_group!(benches, ops, delaunay);

fn main() {
    benches();
    delaunay_1e6_once();
    criterion::Criterion::default().configure_from_args().final_summary();
}
