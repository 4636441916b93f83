//! Lists boundary vertices that end off the boundary (development aid): `-- ex5`.
use trussmesh::gallery::EXAMPLES;
use trussmesh::geometry::Implicit2;
use trussmesh::mesher::mesh_2d;

fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "ex5".into());
    let ex = EXAMPLES.iter().find(|e| e.name == name).expect("example");
    let (domain, opts) = ex.build().unwrap();
    let out = mesh_2d(&domain, &opts).unwrap();
    let m = &out.mesh;
    for v in m.vertex_ids() {
        if m.is_boundary_vertex(v) {
            let d = domain.value(m.pos(v));
            if d.abs() > 1e-6 {
                println!("{:?} {:?} d = {:.4} valence {}", m.pos(v), m.tag(v), d, m.valence(v));
            }
        }
    }
    for (_, v) in m.vertices() {
        if (v.pos - glam::DVec2::new(-1.0, 0.5)).length() < 0.05 {
            println!("near corner: {:?} {:?}", v.pos, v.tag);
        }
    }
    let data = trussmesh::io::MeshData::from_trimesh2(m);
    trussmesh::io::write_png(std::path::Path::new("/tmp/off.png"), &data, &name, 1200).unwrap();
}
