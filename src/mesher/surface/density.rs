//! Density control in space: split long edges, collapse short ones (the engine's checked split
//! and collapse plus the surface conditions the engine cannot know: no fold against grad phi,
//! quality), the remeshing passes that bring the start mesh to h(x), and the regular
//! subdivision between the levels of the coarse-to-fine start.

use super::features;
use super::geom::{faces_out, SizeField};
use super::improve::{flip_pass, smooth_tangential, FlipGoal, FOLD_COS};
use crate::geometry::Implicit3;
use crate::mesher::report::OpCounts;
use crate::mesher::truss::DensityBand;
use crate::quality::triangle_q3;
use crate::topology::{HalfEdgeId, TriMesh, VertexId, VertexTag};
use crate::Error;
use glam::DVec3;
use slotmap::SecondaryMap;

/// Remeshing passes that bring the start mesh to the target density.
pub(super) const REMESH_PASSES: usize = 12;
/// Split above 4/3 h, collapse below 4/5 h (the remeshing hysteresis of Botsch and Kobbelt).
const REMESH_BAND: DensityBand = DensityBand::new(4.0 / 3.0, 0.8);
/// Density control during the force loop: wider hysteresis so nodes do not go in and out.
const DENSITY_BAND: DensityBand = DensityBand::new(1.6, 0.5);

/// Every edge as one half-edge and its two end vertices, in arena order: a stable list to walk
/// while the mesh changes. [`edge_now`] finds the edge again.
pub fn edge_list(m: &TriMesh<DVec3>) -> Vec<(HalfEdgeId, VertexId, VertexId)> {
    m.edge_ids().map(|h| (h, m.origin(h), m.dest(h))).collect()
}

/// The half-edge a -> b of a listed edge now, or `None` if the edge is gone. The listed
/// half-edge usually still runs a -> b (an O(1) check); otherwise a search around a.
#[inline]
pub fn edge_now(m: &TriMesh<DVec3>, (h, a, b): (HalfEdgeId, VertexId, VertexId)) -> Option<HalfEdgeId> {
    if m.contains_half_edge(h) && m.origin(h) == a && m.dest(h) == b {
        return Some(h);
    }
    if !m.contains_vertex(a) || !m.contains_vertex(b) {
        return None;
    }
    m.find_half_edge(a, b)
}

/// Visits every edge of the list taken now, as it stands when reached (`edge_now`), with its
/// length, its midpoint and h there; `visit` may change the mesh and says whether it did.
/// Returns the number of changes.
fn each_edge(
    m: &mut TriMesh<DVec3>,
    size: &SizeField,
    mut visit: impl FnMut(&mut TriMesh<DVec3>, HalfEdgeId, f64, DVec3, f64) -> Result<bool, Error>,
) -> Result<usize, Error> {
    let mut n = 0;
    for e in edge_list(m) {
        let Some(h) = edge_now(m, e) else { continue };
        let (pa, pb) = (m.pos(e.1), m.pos(e.2));
        let mid = 0.5 * (pa + pb);
        if visit(m, h, pa.distance(pb), mid, size.at(mid))? {
            n += 1;
        }
    }
    Ok(n)
}

/// The triangles around `a` and `b` that survive collapsing the edge a-b, with both ends moved
/// to `pos`, as point triples (counter-clockwise).
fn collapse_ring(m: &TriMesh<DVec3>, h: HalfEdgeId, pos: DVec3) -> (Vec<[DVec3; 3]>, Vec<DVec3>) {
    let t = m.twin(h);
    let (a, b) = (m.origin(h), m.origin(t));
    let gone = [m.face_of(h), m.face_of(t)];
    let mut tris = Vec::new();
    let mut ring = Vec::new();
    for v in [a, b] {
        for x in m.outgoing(v) {
            let w = m.dest(x);
            if w != a && w != b {
                ring.push(m.pos(w));
            }
            let Some(f) = m.face_of(x) else { continue };
            if gone.contains(&Some(f)) {
                continue;
            }
            let y = m.next(x);
            tris.push([pos, m.pos(m.origin(y)), m.pos(m.dest(y))]);
        }
    }
    (tris, ring)
}

/// Density control by `band` (seed section 2.4): every edge longer than `band.split_above`
/// times h(midpoint) is split at its midpoint projected onto the surface; then every edge
/// shorter than `band.collapse_below` times h collapses into its projected midpoint, when the
/// link condition holds (the engine's check), no new triangle folds or falls below quality
/// `min_q`, and no new edge passes `band.split_above` times h. Returns (splits, collapses).
pub fn apply_band(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    band: DensityBand,
    min_q: f64,
    tol: f64,
) -> Result<(usize, usize), Error> {
    let splits = each_edge(m, size, |m, h, len, _mid, hm| {
        if len <= band.split_above * hm {
            return Ok(false);
        }
        let Some(p) = features::split_point(m, phi, h, hm, tol)? else { return Ok(false) };
        Ok(features::split(m, h, p).is_some())
    })?;
    let collapses = each_edge(m, size, |m, h, len, _mid, hm| {
        if len >= band.collapse_below * hm || m.num_vertices() <= 4 {
            return Ok(false);
        }
        let Some((h, p)) = features::collapse_choice(m, phi, h, hm, tol)? else { return Ok(false) };
        let (tris, ring) = collapse_ring(m, h, p);
        let hp = size.at(p);
        if ring.iter().any(|&r| r.distance(p) > band.split_above * hp) {
            return Ok(false);
        }
        if tris.iter().any(|t| triangle_q3(*t) < min_q || !faces_out(phi, t[0], t[1], t[2], FOLD_COS)) {
            return Ok(false);
        }
        Ok(m.collapse(h, p).is_ok())
    })?;
    Ok((splits, collapses))
}

/// A mesh with more vertices than this times the count its sizes ask for after the remeshing
/// passes is crowded (see [`against_crowding`]).
const CROWDED: f64 = 1.05;
/// Remeshing passes at most over a crowded mesh, after the ordinary ones.
pub(super) const CROWDED_PASSES: usize = 6;

/// The sizes for a remeshing pass over a crowded mesh: `size` scaled by sqrt(n / expected)
/// when the mesh has n > CROWDED expected vertices, None otherwise. A start whose edges sit
/// near the collapse threshold (an input triangulation at about 0.8 h, as a surface file
/// remeshed a little coarser than it was made) is in equilibrium under the remeshing band:
/// half its short edges collapse, the rest stay, and the run ended with a fifth more vertices
/// than asked (edge lengths 0.9 h, a size deviation of 10%). Scaled, the band sees the mean
/// spacing the count implies and collapses toward the count. Used only after the ordinary
/// passes (a marching start is crowded at first, and those passes bring it to its count).
pub(super) fn against_crowding(m: &TriMesh<DVec3>, size: &SizeField, expected: usize) -> Option<SizeField> {
    let n = m.num_vertices() as f64;
    let want = expected.max(1) as f64;
    (n > CROWDED * want).then(|| size.scaled((n / want).sqrt()))
}

/// One remeshing pass (the isotropic remeshing loop of Botsch and Kobbelt, 2004): split long,
/// collapse short, valence flips, tangential smoothing with projection.
pub(super) fn remesh_pass(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    tol: f64,
    counts: &mut OpCounts,
) -> Result<(), Error> {
    let (s, c) = apply_band(m, phi, size, REMESH_BAND, 0.0, tol)?;
    counts.splits += s;
    counts.collapses += c;
    counts.flips += flip_pass(m, phi, FlipGoal::Valence, 3);
    smooth_tangential(m, phi, 0.5, tol)?;
    Ok(())
}

/// Density control during the force loop: splits and collapses outside DENSITY_BAND (keeping
/// every new triangle above quality 0.3), then quality flips if anything
/// changed. Returns the number of splits and collapses.
pub(super) fn density_control(
    m: &mut TriMesh<DVec3>,
    phi: &dyn Implicit3,
    size: &SizeField,
    tol: f64,
    counts: &mut OpCounts,
) -> Result<usize, Error> {
    let (s, c) = apply_band(m, phi, size, DENSITY_BAND, 0.3, tol)?;
    counts.splits += s;
    counts.collapses += c;
    if s + c > 0 {
        counts.flips += flip_pass(m, phi, FlipGoal::Quality, 10);
    }
    Ok(s + c)
}

/// The same surface rebuilt with its vertices in Hilbert-curve order and its faces by their
/// first vertex there, so that neighbours sit near each other in the arenas. Meshes grown by
/// splits and subdivision scatter them, and every sweep then waits on cache misses.
pub fn relayout(m: &TriMesh<DVec3>) -> Result<TriMesh<DVec3>, Error> {
    let crate::topology::MeshArrays { points, cells: tris, labels, keys } = m.to_arrays();
    let tags: Vec<VertexTag> = keys.iter().map(|&v| m.tag(v)).collect();
    let order = crate::topology::hilbert_sort_3d(&points);
    let mut rank = vec![0usize; points.len()];
    for (r, &i) in order.iter().enumerate() {
        rank[i] = r;
    }
    let pts: Vec<DVec3> = order.iter().map(|&i| points[i]).collect();
    let mut faces: Vec<[usize; 3]> = tris.iter().map(|t| [rank[t[0]], rank[t[1]], rank[t[2]]]).collect();
    faces.sort_by_key(|t| (t[0].min(t[1]).min(t[2]), t[0], t[1], t[2]));
    let labels: Vec<u32> = {
        // The same order as the faces: by first vertex, then the rest.
        let mut keyed: Vec<([usize; 3], u32)> =
            tris.iter().zip(&labels).map(|(t, &lab)| ([rank[t[0]], rank[t[1]], rank[t[2]]], lab)).collect();
        keyed.sort_by_key(|(t, _)| (t[0].min(t[1]).min(t[2]), t[0], t[1], t[2]));
        keyed.into_iter().map(|(_, lab)| lab).collect()
    };
    let (mut out, ids) = TriMesh::from_arrays(&pts, &faces)
        .map_err(|e| Error::internal(format!("rebuilding a valid surface mesh failed: {e}")))?;
    // Labels and tags carry the sharp features: kept with their faces and vertices.
    if labels.iter().any(|&l| l != 0) || tags.iter().any(|&t| t != VertexTag::Interior) {
        let fids: Vec<crate::topology::FaceId> = out.face_ids().collect();
        for (f, &l) in fids.iter().zip(&labels) {
            out.set_label(*f, l);
        }
        for (r, &i) in order.iter().enumerate() {
            out.set_tag(ids[r], tags[i]);
        }
    }
    Ok(out)
}

/// Regular 1-to-4 subdivision: every edge split at its projected midpoint, then every edge
/// from a new vertex to an old vertex that is not its parent flipped. New vertices get valence
/// 6, so the irregular vertices of the coarse mesh are all the fine mesh has.
pub fn subdivide(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, tol: f64) -> Result<usize, Error> {
    let mut old: SecondaryMap<VertexId, ()> = SecondaryMap::new();
    for v in m.vertex_ids() {
        old.insert(v, ());
    }
    let mut parent: SecondaryMap<VertexId, (VertexId, VertexId)> = SecondaryMap::new();
    let mut n = 0;
    for e in edge_list(m) {
        let Some(h) = edge_now(m, e) else { continue };
        let (a, b) = (e.1, e.2);
        let s = m.pos(a).distance(m.pos(b));
        let Some(p) = features::split_point(m, phi, h, s, tol)? else { continue };
        if let Some(v) = features::split(m, h, p) {
            parent.insert(v, (a, b));
            n += 1;
        }
    }
    for e in edge_list(m) {
        let (a, b) = (e.1, e.2);
        let (new, o) = if parent.contains_key(a) && old.contains_key(b) {
            (a, b)
        } else if parent.contains_key(b) && old.contains_key(a) {
            (b, a)
        } else {
            continue;
        };
        let (p0, p1) = parent[new];
        if o == p0 || o == p1 {
            continue;
        }
        if let Some(h) = edge_now(m, e) {
            // A refused flip leaves a valence defect, never an invalid mesh.
            let _ = m.flip(h);
        }
    }
    Ok(n)
}
