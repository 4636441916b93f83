//! Same input, same output bit for bit, for any thread count: the 2-D mesher run in rayon
//! pools of one and of two threads, on a small graded mesh (the search and polish) and on a
//! mesh above the large-mesh threshold (Hilbert layout, partial steps, the worst-triangle polish).

use glam::DVec2;
use trussmesh::geometry::{Circle, Difference, Rectangle};
use trussmesh::mesher::{mesh_2d, Options2};

fn bits(m: &trussmesh::topology::TriMesh<DVec2>) -> (Vec<[u64; 2]>, Vec<[usize; 3]>) {
    let a = m.to_arrays();
    (a.points.iter().map(|p| [p.x.to_bits(), p.y.to_bits()]).collect(), a.cells.clone())
}

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool").install(f)
}

#[test]
fn one_and_two_threads_give_the_same_mesh() {
    let graded = Difference::new(Rectangle::new([-1.0, -1.0], [1.0, 1.0]), Circle::new([0.0, 0.0], 0.4));
    let small = Options2::uniform(0.05, [-1.0, -1.0], [1.0, 1.0])
        .with_size(|p: DVec2| (4.0 * p.length() - 1.0).min(2.0))
        .with_fixed(vec![[-1.0, -1.0], [-1.0, 1.0], [1.0, -1.0], [1.0, 1.0]]);
    let disk = Circle::new([0.0, 0.0], 1.0);
    let large = Options2::uniform(0.012, [-1.0, -1.0], [1.0, 1.0]);
    println!("| case | triangles | q min | same with 1 and 2 threads |");
    println!("|---|---|---|---|");
    for (name, domain, opts) in [
        ("graded square with hole", &graded as &dyn trussmesh::geometry::Implicit2, &small),
        ("unit disk", &disk, &large),
    ] {
        let one = in_pool(1, || mesh_2d(domain, opts).expect("meshing"));
        let two = in_pool(2, || mesh_2d(domain, opts).expect("meshing"));
        let same = bits(&one.mesh) == bits(&two.mesh);
        println!("| {name} | {} | {:.4} | {same} |", one.report.quality.triangles, one.report.quality.q_min);
        assert!(same, "{name}: the meshes differ between 1 and 2 threads");
    }
}
