//! Diagnostics of the worst triangles of a disk mesh (development aid).
use trussmesh::geometry::Circle;
use trussmesh::mesher::{mesh_2d, Options2};
use trussmesh::topology::VertexTag;

fn main() {
    let h0: f64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(0.05);
    let disk = Circle::new([0.0, 0.0], 1.0);
    let mut opts = Options2::uniform(h0, [-1.0, -1.0], [1.0, 1.0]);
    if std::env::var_os("CLASSIC").is_some() {
        opts = opts.with_strategy(trussmesh::mesher::Strategy::GlobalDelaunay);
    }
    let out = mesh_2d(&disk, &opts).expect("meshing failed");
    let m = &out.mesh;
    let mut bad: Vec<_> = m.face_ids().map(|f| (m.face_quality(f), f)).filter(|x| x.0 < 0.9).collect();
    bad.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut hist = std::collections::BTreeMap::new();
    for (q, f) in &bad {
        let vs = m.face_vertices(*f);
        let desc: Vec<String> = vs
            .iter()
            .map(|&v| format!("{}{}", if m.tag(v) == VertexTag::Interior { "I" } else { "B" }, m.valence(v)))
            .collect();
        let mut key = desc.clone();
        key.sort();
        *hist.entry(key.join(",")).or_insert(0) += 1;
        if *q < 0.8 {
            println!("q {q:.3} {:?}", desc);
        }
    }
    println!("{} triangles below 0.9", bad.len());
    let mut bins = [0usize; 6];
    let mut by_r = [(0.0, 0usize); 10];
    for f in m.face_ids() {
        let q = m.face_quality(f);
        let k = if q < 0.9 { 0 } else if q < 0.95 { 1 } else if q < 0.98 { 2 } else if q < 0.99 { 3 } else if q < 0.995 { 4 } else { 5 };
        bins[k] += 1;
        let [a, b, c] = m.face_points(f);
        let r = ((a + b + c) / 3.0).length();
        let i = ((r * 10.0) as usize).min(9);
        by_r[i].0 += q;
        by_r[i].1 += 1;
    }
    println!("q bins <.9 {:?} (<.95 <.98 <.99 <.995 rest)", bins);
    println!("mean q by radius: {:?}", by_r.iter().map(|(s, n)| format!("{:.4}", s / *n as f64)).collect::<Vec<_>>());
    let (mut sb, mut nb, mut si, mut ni) = (0.0, 0, 0.0, 0);
    for h in m.edge_ids() {
        if m.is_boundary_edge(h) {
            sb += m.edge_length(h);
            nb += 1;
        } else {
            si += m.edge_length(h);
            ni += 1;
        }
    }
    println!("boundary edges {nb} mean {:.4}; interior edges {ni} mean {:.4}", sb / nb as f64, si / ni as f64);
    for (k, n) in hist {
        println!("{k}: {n}");
    }
}
