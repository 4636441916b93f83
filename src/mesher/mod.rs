//! The meshing pipelines: implicit geometry and size function in, mesh and report out.

pub mod background;
mod classic2d;
pub mod image;
mod input;
mod internal;
pub mod metric;
mod options;
mod planar;
mod report;
mod sharp;
pub mod surface;
mod truss;
mod volume;

pub use crate::quality::tet_circumradius as circumradius;
pub use crate::quality::{size_deviation, size_deviation_3d};
pub use metric::{Metric2, Metric3, MetricFn2, MetricGrid2, MetricStats};
pub use options::ProgressFn;
pub use planar::options::{Options2, SizeFn2, Strategy};
pub use planar::report::{area, boundary_deviation, QualityStats};
pub use report::{OpCounts, Report, StopReason, SurfaceStages};
pub use truss::DensityBand;
pub use volume::options::{Options3, SizeFn3};
pub use volume::report::{boundary_deviation_3d, pinched_boundary_vertices, QualityStats3};

use crate::geometry::{Implicit2, Implicit3};
use crate::topology::{TetMesh, TriMesh};
use glam::DVec2;

/// A mesh and the report of the run that made it.
#[derive(Clone, Debug)]
pub struct MeshOutput<M, Q> {
    /// The mesh (boundary vertices tagged `Boundary`, fixed points `Fixed`).
    pub mesh: M,
    /// Iterations, time, operation counts, quality statistics and why it stopped.
    pub report: Report<Q>,
}

/// The output of the 2-D mesher: a triangle mesh and its report.
pub type MeshOutput2 = MeshOutput<TriMesh<DVec2>, QualityStats>;
/// The output of the 3-D mesher: a tetrahedral mesh and its report.
pub type MeshOutput3 = MeshOutput<TetMesh, QualityStats3>;

/// A domain and the options of one of the two meshers, for [`estimated_elements`].
#[derive(Clone, Copy)]
pub enum Survey<'a> {
    /// The 2-D mesher's input.
    Planar(&'a dyn Implicit2, &'a Options2),
    /// The 3-D mesher's input.
    Volume(&'a dyn Implicit3, &'a Options3),
}

/// The number of elements (triangles in 2-D, tetrahedra in 3-D) the mesher's input survey
/// expects for this domain and these options, without meshing: what a caller checks a memory
/// budget against. It is not capped by `max_elements` (it may be infinite); bad input (h0, the
/// box, d or h not finite, an empty domain) is the error the mesher itself would return.
pub fn estimated_elements(survey: Survey<'_>) -> Result<f64, crate::Error> {
    let estimate = match survey {
        Survey::Planar(domain, opts) => {
            let mut o = opts.clone();
            o.max_elements = u64::MAX;
            input::survey(domain, &o).map(|s| s.estimated_triangles)
        }
        Survey::Volume(domain, opts) => {
            let mut o = opts.clone();
            o.max_elements = u64::MAX;
            volume::start::survey(domain, &o).map(|s| s.estimated_tets)
        }
    };
    match estimate {
        // Only an estimate past u64::MAX passes the lifted cap.
        Err(crate::Error::TooManyElements { .. }) => Ok(f64::INFINITY),
        e => e,
    }
}

/// Meshes {d < 0} in 3-D with tetrahedra: force equilibrium with local swaps, density control
/// and sliver removal inside the run (see the module notes of the 3-D mesher).
///
/// ```
/// use trussmesh::geometry::Ball;
/// use trussmesh::mesher::{mesh_3d, Options3};
/// let out = mesh_3d(&Ball::new([0.0, 0.0, 0.0], 1.0), &Options3::uniform(0.4, [-1.1; 3], [1.1; 3])).unwrap();
/// assert!(out.report.quality.dihedral_min > 5.0);
/// ```
pub fn mesh_3d(domain: &dyn Implicit3, opts: &Options3) -> Result<MeshOutput3, crate::Error> {
    on_pool(|| volume::run(domain, opts))
}

/// Runs `f` on a thread of rayon's pool. The meshers run many parallel loops over a few
/// hundred items; called from a thread outside the pool, each would hand its work over to the
/// pool and wait for it (microseconds apiece, thousands of times on a small mesh), where a
/// thread of the pool runs a loop too short to split at once.
pub fn on_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() {
        f()
    } else {
        rayon::scope(|_| f())
    }
}

/// Meshes {d < 0} in 2-D.
///
/// ```
/// use trussmesh::geometry::Circle;
/// use trussmesh::mesher::{mesh_2d, Options2};
/// let out = mesh_2d(&Circle::new([0.0, 0.0], 1.0), &Options2::uniform(0.2, [-1.0, -1.0], [1.0, 1.0])).unwrap();
/// assert!(out.report.quality.q_min > 0.7);
/// ```
pub fn mesh_2d(domain: &dyn Implicit2, opts: &Options2) -> Result<MeshOutput2, crate::Error> {
    on_pool(|| mesh_2d_here(domain, opts))
}

fn mesh_2d_here(domain: &dyn Implicit2, opts: &Options2) -> Result<MeshOutput2, crate::Error> {
    match opts.strategy {
        Strategy::Local => planar::run(domain, opts),
        Strategy::GlobalDelaunay if opts.internal.is_some() || opts.metric.is_some() => Err(crate::Error::Invalid(
            "internal boundaries and metrics need the local strategy (the classic global-Delaunay baseline has neither)"
                .into(),
        )),
        Strategy::GlobalDelaunay => classic2d::run(domain, opts),
    }
}

/// Meshes {d < 0} starting from an existing mesh instead of from scratch: one step of a moving
/// mesh or a remeshing for a new size field (seed sections 5.1 and 5.2). The previous mesh is
/// cut to the new domain (triangles with a vertex outside are dropped), then the usual force
/// iterations with density control move, add and remove nodes. `opts.max_iter` bounds the
/// work per step (a few dozen iterations are typical when the geometry moved a little).
///
/// An invalid start (an inverted or broken element) is an `Error::InvalidMesh`.
pub fn remesh_2d(prev: &TriMesh<DVec2>, domain: &dyn Implicit2, opts: &Options2) -> Result<MeshOutput2, crate::Error> {
    on_pool(|| planar::run_from(domain, opts, Some(prev)))
}

/// Remeshing for adaptation (seed section 5.2): the old mesh is the background for d (its
/// boundary, [`background::BoundaryDistance`]) and for h (`h_nodes`, one size per vertex in
/// `old.vertex_ids()` order, gradient limited on the old mesh with slope `g`), then the old
/// mesh is carved, its density controlled by splits and collapses, and the forces iterated.
/// Boundary corners sharper than 30 degrees are kept as fixed points; `h0` is the smallest
/// limited size (sizes are absolute here), the box the old mesh's bounding box.
pub fn remesh_adapt_2d(
    old: &TriMesh<DVec2>,
    h_nodes: Vec<f64>,
    g: f64,
    max_iter: usize,
) -> Result<MeshOutput2, crate::Error> {
    use background::{BoundaryDistance, MeshSize};
    if let Err(e) = old.validate(crate::topology::Level::Geometry) {
        return Err(crate::Error::InvalidMesh(format!(
            "the mesh to remesh is invalid ({e}): inverted or broken elements"
        )));
    }
    let size = MeshSize::new(old, h_nodes, g)?;
    let hmin = size.values().iter().copied().fold(f64::INFINITY, f64::min);
    let domain = BoundaryDistance::of(old);
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for (_, v) in old.vertices() {
        lo = lo.min(v.pos);
        hi = hi.max(v.pos);
    }
    let pad = DVec2::splat(hmin);
    // Corners: boundary vertices where the boundary turns by more than 30 degrees.
    let mut corners = Vec::new();
    for lp in old.boundary_loops() {
        for h in lp {
            let (a, b, c) = (old.pos(old.origin(h)), old.pos(old.dest(h)), old.pos(old.dest(old.next(h))));
            let (u, w) = ((b - a).normalize(), (c - b).normalize());
            let vb = old.dest(h);
            let tol = 1e-9 * (hi - lo).length();
            let is_corner = old.tag(vb) == crate::topology::VertexTag::Fixed || u.dot(w) < 30f64.to_radians().cos();
            // A node crowded onto a corner (a near duplicate) is not a second corner.
            if is_corner && !corners.iter().any(|c: &[f64; 2]| DVec2::from(*c).distance(b) <= tol) {
                corners.push([b.x, b.y]);
            }
        }
    }
    let opts = Options2::uniform(hmin, lo - pad, hi + pad)
        .with_size(move |p| size.at(p))
        .with_fixed(corners)
        .with_max_iter(max_iter);
    planar::run_moving(&domain, &opts, Some(old), None, true)
}

/// One step of a moving mesh with freezing: as [`remesh_2d`], but nodes more than
/// `freeze_rings` edges away from every node where `old_domain` and `new_domain` disagree are
/// held still for the step (seed section 5.1: the stiffness grows with the distance from the
/// moving boundary), so that only the neighbourhood of the motion is remeshed. As the held
/// nodes pass no compression or tension on, density control acts sooner in such a step (edges
/// collapse below 0.82 target lengths instead of 0.6), so the region the boundary leaves
/// behind is not frozen distorted.
pub fn move_mesh_2d(
    prev: &TriMesh<DVec2>,
    old_domain: &dyn Implicit2,
    new_domain: &dyn Implicit2,
    opts: &Options2,
    freeze_rings: usize,
) -> Result<MeshOutput2, crate::Error> {
    on_pool(|| {
        planar::run_moving(
            new_domain,
            opts,
            Some(prev),
            Some(planar::Freeze { old_domain, rings: freeze_rings }),
            false,
        )
    })
}
