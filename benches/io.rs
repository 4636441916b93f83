//! Writing and reading a million-triangle mesh: binary VTU and Gmsh files against their text
//! forms (the ratio is the point; absolute times depend on the machine).

use criterion::{criterion_group, criterion_main, Criterion};
use trussmesh::io::{read_mesh_bytes, write_mesh_bytes_with, write_mesh_with, Encoding, Format};

fn bench(c: &mut Criterion) {
    let m = trussmesh::testing::grid_mesh_data(708);
    println!("{} triangles, {} points", m.num_cells(), m.points.len());
    let dir = std::env::temp_dir().join(format!("trussmesh-bench-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut g = c.benchmark_group("io_1m_triangles");
    g.sample_size(10);
    for (format, enc, label) in [
        (Format::Vtu, Encoding::Binary, "vtu_binary"),
        (Format::Msh, Encoding::Binary, "msh_binary"),
        (Format::Vtu, Encoding::Ascii, "vtu_text"),
    ] {
        let path = dir.join(format!("m.{}", format.extension()));
        g.bench_function(format!("write_file_{label}"), |b| b.iter(|| write_mesh_with(&path, &m, enc).unwrap()));
        g.bench_function(format!("write_bytes_{label}"), |b| {
            b.iter(|| write_mesh_bytes_with(&m, format, enc).unwrap())
        });
        let bytes = write_mesh_bytes_with(&m, format, enc).unwrap();
        println!("{label}: {:.1} MB", bytes.len() as f64 / 1e6);
        g.bench_function(format!("read_{label}"), |b| b.iter(|| read_mesh_bytes(&bytes, format).unwrap()));
    }
    g.finish();
    std::fs::remove_dir_all(&dir).ok();
}

criterion_group!(benches, bench);
criterion_main!(benches);
