//! The surface as the boundary of the 3-D mesher's tetrahedra of the inside: the fallback for
//! sharp features the surface mesher fails to hold. The 3-D mesher holds a solid's edges and
//! corners as fixed start points; on random unions and differences of boxes, balls and cylinders
//! at h0 0.07 the boundary triangles of its tets had smallest angles of 23.6 to 31.6 degrees,
//! where surface runs of the same solids rounded the edges off or kept a 0.9-degree triangle.

use super::geom::SizeField;
use super::{SurfaceOptions, SurfaceOutput, SurfaceQuality};
use crate::geometry::Implicit3;
use crate::mesher::report::Report;
use crate::mesher::Options3;
use crate::topology::TriMesh;
use crate::Error;
use glam::DVec3;
use std::collections::HashMap;

/// A surface meshed with its sharp features held whose smallest angle is below this many
/// degrees is made from the 3-D mesh too, and the better of the two kept; where holding them
/// failed, the 3-D mesh's boundary is taken when no angle of it is below this.
pub(super) const TRY_BELOW_DEG: f64 = 20.0;

/// Whether the 3-D mesh's boundary `out` is a fair result where the surface mesher failed: no
/// angle below [`TRY_BELOW_DEG`] and no face against grad phi.
pub(super) fn fair(out: &SurfaceOutput) -> bool {
    out.report.quality.min_angle >= TRY_BELOW_DEG && out.report.quality.inward_faces == 0
}

/// The boundary of the tets of the inside of phi = 0 at the surface's sizes, oriented with its
/// normals along grad phi, checked closed, manifold and free of self-intersection, with the
/// quality measured as for any surface; `note` goes into the report.
pub(super) fn from_volume(
    phi: &dyn Implicit3,
    opts: &SurfaceOptions,
    size: &SizeField,
    note: String,
) -> Result<SurfaceOutput, Error> {
    let t0 = std::time::Instant::now();
    let h0 = opts.h0;
    let mut o3 = Options3::uniform(h0, opts.bbox[0], opts.bbox[1]);
    if !matches!(size, SizeField::Uniform(_)) {
        let field = size.clone();
        o3 = o3.with_size(move |p| field.at(p) / h0);
    }
    let vol = crate::mesher::mesh_3d(phi, &o3)?;
    let tm = &vol.mesh;
    let mut index: HashMap<crate::topology::TVertexId, usize> = HashMap::new();
    let mut points: Vec<DVec3> = Vec::new();
    let mut triangles: Vec<[usize; 3]> = Vec::new();
    for (t, i) in tm.boundary_faces() {
        let f = tm.face_vertices(t, i);
        let [a, b, c] = f.map(|v| tm.pos(v));
        // The tet's fourth vertex is inside: the outward normal points away from it.
        let apex = tm.tet(t).v[i];
        let outward = (b - a).cross(c - a).dot(a - tm.pos(apex)) > 0.0;
        let ids = f.map(|v| {
            *index.entry(v).or_insert_with(|| {
                points.push(tm.pos(v));
                points.len() - 1
            })
        });
        triangles.push(if outward { ids } else { [ids[0], ids[2], ids[1]] });
    }
    let (m, _) = TriMesh::from_arrays(&points, &triangles)?;
    m.validate_closed_surface().map_err(|e| Error::broken("the 3-D mesh's boundary is no closed surface", e))?;
    let mut report = Report::<SurfaceQuality> {
        quality: SurfaceQuality::measure(&m, phi, size),
        feature_points: vol.report.feature_points,
        ..Report::default()
    };
    report.notes.push(note);
    report.seconds = t0.elapsed().as_secs_f64();
    Ok(SurfaceOutput { mesh: m, size: size.clone(), report })
}
