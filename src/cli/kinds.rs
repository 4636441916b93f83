//! The kind of every node of a finished mesh (interior, boundary, fixed, feature, internal
//! boundary) in the order of its plain arrays, for the .vtu point data `node_kind`.

use glam::{DVec2, DVec3};
use trussmesh::io::NodeKind;
use trussmesh::topology::{TetMesh, TriMesh, VertexTag};

/// A held node is `Fixed` when it is one of the given points (to rounding), else `Feature`
/// (a sharp corner or a point on a sharp edge the mesher found).
fn kind(tag: VertexTag, p: [f64; 3], fix: &[Vec<f64>], scale: f64) -> NodeKind {
    match tag {
        VertexTag::Interior => NodeKind::Interior,
        VertexTag::Boundary => NodeKind::Boundary,
        VertexTag::InternalBoundary { .. } => NodeKind::Internal,
        VertexTag::Fixed => {
            let given = fix.iter().any(|q| q.iter().zip(p).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) <= scale);
            if given {
                NodeKind::Fixed
            } else {
                NodeKind::Feature
            }
        }
    }
}

/// Node kinds of a planar mesh, in the order of `MeshData::from_trimesh2`.
pub fn planar(m: &TriMesh<DVec2>, fix: &[Vec<f64>], h0: f64) -> Vec<NodeKind> {
    m.to_arrays().keys.iter().map(|&v| kind(m.tag(v), [m.pos(v).x, m.pos(v).y, 0.0], fix, 1e-9 * h0)).collect()
}

/// Node kinds of a tetrahedral mesh, in the order of its `to_arrays`.
pub fn volume(m: &TetMesh, fix: &[Vec<f64>], h0: f64) -> Vec<NodeKind> {
    m.to_arrays().keys.iter().map(|&v| kind(m.tag(v), DVec3::to_array(&m.pos(v)), fix, 1e-9 * h0)).collect()
}
