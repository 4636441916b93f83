//! Mesh topology engines: the half-edge [`TriMesh`] for planar and surface triangles, and the
//! tetrahedral [`TetMesh`] with face neighbours.
//!
//! Topology never asks for what it does not need: navigation and the combinatorial half of every
//! operation have no bound on the point type beyond [`MeshPoint`]; geometric validity is decided
//! by exact orientation ([`crate::predicates`]) through [`MeshPoint::orientation`].
//!
//! Every local operation comes as a pair: `check_*` only reads and returns a plan or a
//! [`Refusal`]; `apply_*` only writes and cannot fail. The one-call form (`flip`, `split_edge`,
//! ...) does both. A refused operation leaves the mesh exactly as it was.

mod delaunay;
mod disjoint_sets;
pub(crate) mod embedding;
mod fan;
mod incidence;
mod intersect;
pub(crate) use intersect::segments_meet;
mod tet_collapse;
mod tet_delaunay;
mod tet_delaunay_kernel;
mod tet_edge_removal;
mod tet_ops;
mod tet_validate;
mod tetmesh;
mod tri_ops;
mod tri_validate;
mod trimesh;

pub use delaunay::hilbert_order;
pub use disjoint_sets::DisjointSets;
pub(crate) use embedding::{
    boundary_clear, boundary_edges_if_split, faces_meet, fan_winds_once, ring_winds_once, surface_star_meets,
};
pub use incidence::{Incidence, VertexIndex};
pub use tet_delaunay::{hilbert_order_3d, hilbert_sort_3d};
pub use tet_edge_removal::Objective;
pub use tet_ops::{Flip23Plan, Flip32Plan, TetPatch};
pub use tetmesh::{
    EdgeShell, Journal, TVertex, TVertexId, Tet, TetId, TetMesh, EDGE_OPPOSITE, EDGE_VERTICES, FACE_VERTICES,
};
pub use tri_ops::{CollapsePlan, FlipPlan, InsertPlan, SplitPlan};
pub use tri_validate::{Invariant, InvariantViolation, Level};
pub use trimesh::{Face, FaceId, HalfEdge, HalfEdgeId, MeshArrays, MeshPoint, TriMesh, Vertex, VertexId, VertexTag};

/// Why a local operation declined. Refusals are values, never panics; the mesh is untouched.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Refusal {
    /// A key that does not name a live element.
    StaleKey,
    /// The operation would make an element with negative orientation.
    WouldInvert,
    /// The operation would make an element with zero area.
    WouldDegenerate,
    /// An edge collapse that fails the link condition (would make the mesh non-manifold).
    LinkCondition,
    /// The edge is on the boundary, where the operation is not allowed.
    BoundaryEdge,
    /// The edge separates two subdomains (an internal boundary) and may not be flipped.
    Constrained,
    /// The vertex's tag protects it from this operation.
    Protected(VertexTag),
    /// The result would repeat an existing edge.
    DuplicateEdge,
    /// The mesh is too small for the operation (it would vanish or pinch).
    TooSmall,
    /// A point that is not finite.
    NonFinite,
    /// The face is on the boundary (3-D), where the operation is not allowed.
    BoundaryFace,
    /// The region is not convex enough: no valid set of new elements exists.
    NotConvex,
    /// The best result fails the caller's acceptance test (it would not improve the mesh).
    NotBetter,
    /// Every element would stay positive, but a vertex fan would wind around its vertex more
    /// than once (a fold: the mesh would cover part of the plane twice).
    WouldFold,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = match self {
            Refusal::StaleKey => "the key names no live element",
            Refusal::WouldInvert => "the result would hold an inverted element",
            Refusal::WouldDegenerate => "the result would hold a zero-area element",
            Refusal::LinkCondition => "the collapse fails the link condition",
            Refusal::BoundaryEdge => "the edge is on the boundary",
            Refusal::Constrained => "the edge is an internal boundary",
            Refusal::Protected(_) => "a vertex tag protects the vertex",
            Refusal::DuplicateEdge => "the result would repeat an existing edge",
            Refusal::TooSmall => "the mesh is too small for the operation",
            Refusal::NonFinite => "the point is not finite",
            Refusal::BoundaryFace => "the face is on the boundary",
            Refusal::NotConvex => "no valid set of new elements exists (not convex)",
            Refusal::NotBetter => "the best result fails the acceptance test",
            Refusal::WouldFold => "the result would fold a vertex fan (wind around it twice)",
        };
        f.write_str(s)
    }
}

impl std::error::Error for Refusal {}

pub use delaunay::Location;
