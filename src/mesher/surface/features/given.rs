//! Sharp features the geometry gives exactly (a triangulated surface's feature edges and
//! corners): cut into an even mesh of the surface, or its own triangulation as the start.

use super::{
    curve_id, curve_labels, curve_normals, face_normal, fix_corner, place, split, tag_by_labels, unflatten, CUT_END,
    CUT_PASSES, GIVEN_SAG, LEAK_FACES, ON_CURVE, PIN_REACH,
};
use crate::geometry::{Creases, Implicit3};
use crate::topology::{FaceId, HalfEdgeId, TriMesh, VertexId, VertexTag};
use glam::DVec3;
use slotmap::SecondaryMap;

/// [`imprint`](super::imprint) with the sharp features the geometry gives exactly (`c`), into an even mesh of
/// the surface: vertices already on a curve are held there; the nearest vertex that can move
/// onto each corner without folding does so and is fixed; every edge between two patches is
/// cut where the curve of those two crosses it (or its end near the curve moves onto it); the
/// faces are labelled by [`label_given`], the vertices tagged by the labels around them (the
/// placed corners stay fixed), and the curve vertices put on their curve. Returns false,
/// leaving `m` untouched, when a vertex has no patch.
pub(super) fn imprint_given(m: &mut TriMesh<DVec3>, phi: &dyn Implicit3, c: &dyn Creases) -> bool {
    let mut patch: SecondaryMap<VertexId, u32> = SecondaryMap::new();
    for v in m.vertex_ids() {
        let Some(l) = c.patch(m.pos(v)) else { return false };
        patch.insert(v, l);
    }
    // Vertices already on a curve (projections onto a convex edge land on it) are held there.
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    for &v in &ids {
        let p = m.pos(v);
        for w in m.neighbours(v) {
            let (a, b) = (patch[v], patch[w]);
            if a == b {
                continue;
            }
            if let Some((q, _)) = c.onto(a, b, p) {
                if q.distance(p) <= ON_CURVE * p.distance(m.pos(w)) {
                    m.set_tag(v, VertexTag::InternalBoundary { curve: curve_id(a, b) });
                    break;
                }
            }
        }
    }
    for &k in c.corners() {
        fix_corner(m, k, phi.gradient(k).normalize_or_zero(), false);
    }
    for _ in 0..CUT_PASSES {
        let mut cuts = Vec::new();
        for e in crate::mesher::surface::density::edge_list(m) {
            let (a, b) = (e.1, e.2);
            if m.tag(a) != VertexTag::Interior || m.tag(b) != VertexTag::Interior || patch[a] == patch[b] {
                continue;
            }
            let (pa, pb) = (m.pos(a), m.pos(b));
            let (mid, len) = (0.5 * (pa + pb), pa.distance(pb));
            if let Some((x, _)) = c.onto(patch[a], patch[b], mid) {
                if x.distance(mid) <= len {
                    cuts.push((e, x, patch[a].min(patch[b]), patch[a].max(patch[b])));
                }
            }
        }
        if cuts.is_empty() {
            break;
        }
        for (e, x, la, lb) in cuts {
            let Some(hh) = crate::mesher::surface::density::edge_now(m, e) else { continue };
            if m.tag(e.1) != VertexTag::Interior || m.tag(e.2) != VertexTag::Interior {
                continue;
            }
            let (pa, pb) = (m.pos(e.1), m.pos(e.2));
            let len = pa.distance(pb);
            let dir = (phi.gradient(pa) + phi.gradient(pb)).normalize_or_zero();
            // An end already near the curve moves onto it (a cut there would leave a sliver).
            let (da, db) = (x.distance(pa), x.distance(pb));
            let end = if da <= db { e.1 } else { e.2 };
            let mut v = (da.min(db) < CUT_END * len && place(m, end, x, dir)).then_some(end);
            if v.is_none() {
                v = m.split_edge(hh, x).ok();
            }
            if let Some(v) = v {
                m.set_tag(v, VertexTag::InternalBoundary { curve: curve_id(la, lb) });
            }
        }
    }
    unflatten(m);
    let corners: Vec<VertexId> = m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed).collect();
    label_given(m, c);
    tag_by_labels(m);
    for v in corners {
        m.set_tag(v, VertexTag::Fixed);
    }
    // A vertex where three patches meet that is not on a corner yet (the nearest vertex could
    // not move there without folding its star) goes onto the nearest corner: its star spans
    // the patches around it.
    let held: Vec<VertexId> = m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed).collect();
    for v in held {
        let p = m.pos(v);
        let near = c.corners().iter().copied().min_by(|a, b| a.distance(p).total_cmp(&b.distance(p)));
        if let Some(k) = near {
            if k != p {
                place(m, v, k, phi.gradient(k).normalize_or_zero());
            }
        }
    }
    let curve: Vec<VertexId> =
        m.vertex_ids().filter(|&v| matches!(m.tag(v), VertexTag::InternalBoundary { .. })).collect();
    for v in curve {
        let (Some((a, b)), Some((n1, n2))) = (curve_labels(m, v), curve_normals(m, v)) else { continue };
        if let Some((q, _)) = c.onto(a, b, m.pos(v)) {
            place(m, v, q, (n1 + n2).normalize_or_zero());
        }
    }
    hold_pins(m, c.pins());
    true
}

/// The geometry's own triangulation ([`Creases::triangulation`]) as a start: its curves are its
/// edges, so nothing is cut; its faces are labelled by their patches, its vertices tagged by
/// the labels around them, and the pins held. None when the geometry gives none or it does not
/// load into the engine.
pub(in crate::mesher::surface) fn input_start(c: &dyn Creases) -> Option<TriMesh<DVec3>> {
    let t = c.triangulation()?;
    let (mut m, _) = TriMesh::from_arrays(&t.points, &t.triangles).ok()?;
    let patch = t.patch;
    // The engine numbers the faces in the order of the triangles given.
    let faces: Vec<_> = m.face_ids().collect();
    if faces.len() != patch.len() {
        return None;
    }
    for (f, l) in faces.into_iter().zip(patch) {
        m.set_label(f, l);
    }
    tag_by_labels(&mut m);
    hold_pins(&mut m, c.pins());
    Some(m)
}

/// Holds a vertex at each pin (a point on a curve, [`Creases::pins`]): the curve edge nearest
/// the pin is split there, or its end moves onto it when near, and the vertex is fixed. A pin
/// with no curve edge within PIN_REACH edge lengths is left (its curve was not cut there).
fn hold_pins(m: &mut TriMesh<DVec3>, pins: &[DVec3]) {
    if pins.is_empty() {
        return;
    }
    let mut edges: Vec<(VertexId, VertexId)> =
        m.edge_ids().filter(|&h| m.is_constrained_edge(h)).map(|h| (m.origin(h), m.dest(h))).collect();
    for &k in pins {
        // The nearest curve edge, its parameter at the pin and the pin's distance from it.
        let mut best: Option<(f64, usize, f64)> = None;
        for (i, &(a, b)) in edges.iter().enumerate() {
            if !m.contains_vertex(a) || !m.contains_vertex(b) {
                continue;
            }
            let (pa, pb) = (m.pos(a), m.pos(b));
            let d = pb - pa;
            let t = ((k - pa).dot(d) / d.length_squared()).clamp(0.0, 1.0);
            let dist = k.distance(pa + d * t);
            if best.is_none_or(|x| dist < x.0) {
                best = Some((dist, i, t));
            }
        }
        let Some((dist, i, t)) = best else { return };
        let (a, b) = edges[i];
        let Some(h) = m.find_half_edge(a, b) else { continue };
        let len = m.pos(a).distance(m.pos(b));
        // A chord of the curve cuts a turn theta by up to theta len / 4.
        if dist > PIN_REACH * len {
            continue;
        }
        let (n1, n2) = match (m.face_of(h), m.face_of(m.twin(h))) {
            (Some(f), Some(g)) => (face_normal(m, f), face_normal(m, g)),
            _ => continue,
        };
        let dir = (n1 + n2).normalize_or_zero();
        // The nearer end, if it slides on the curve, moves onto the pin (the curve's vertices
        // then even out around it); a split would leave an edge shorter than half the others.
        let end = if t < 0.5 { a } else { b };
        if t.min(1.0 - t) < CUT_END && m.tag(end) == VertexTag::Fixed {
            continue;
        }
        if matches!(m.tag(end), VertexTag::InternalBoundary { .. }) && place(m, end, k, dir) {
            m.set_tag(end, VertexTag::Fixed);
            continue;
        }
        if let Some(v) = split(m, h, k) {
            m.set_tag(v, VertexTag::Fixed);
            edges[i] = (a, v);
            edges.push((v, b));
        }
    }
}

/// The pair of patches a curve vertex was cut or found on.
fn pair_of(tag: VertexTag) -> Option<(u32, u32)> {
    match tag {
        VertexTag::InternalBoundary { curve } => Some((curve / 65_536, curve % 65_536)),
        _ => None,
    }
}

/// Labels the faces of the cut mesh by the given patches: regions flooded across every edge but
/// those along a curve (both ends held, the midpoint on the curve of an end's pair), each region
/// labelled by the patch under most of its triangles' centroids. A triangle whose centroid
/// strays across a curve (near a corner) so keeps the label of its side.
fn label_given(m: &mut TriMesh<DVec3>, c: &dyn Creases) {
    let along = |m: &TriMesh<DVec3>, h: HalfEdgeId| -> bool {
        let (a, b) = (m.origin(h), m.dest(h));
        if m.tag(a) == VertexTag::Interior || m.tag(b) == VertexTag::Interior {
            return false;
        }
        let (pa, pb) = (m.pos(a), m.pos(b));
        let (mid, len) = (0.5 * (pa + pb), pa.distance(pb));
        match (pair_of(m.tag(a)), pair_of(m.tag(b))) {
            (None, None) => true,
            (x, y) => [x, y]
                .into_iter()
                .flatten()
                .any(|(p, q)| c.onto(p, q, mid).is_some_and(|(on, _)| on.distance(mid) <= GIVEN_SAG * len)),
        }
    };
    let faces: Vec<FaceId> = m.face_ids().collect();
    let mut region: SecondaryMap<FaceId, usize> = SecondaryMap::new();
    let mut regions: Vec<Vec<FaceId>> = Vec::new();
    for &f0 in &faces {
        if region.contains_key(f0) {
            continue;
        }
        let k = regions.len();
        region.insert(f0, k);
        let mut members = vec![f0];
        let mut i = 0;
        while i < members.len() {
            let f = members[i];
            i += 1;
            for h in m.face_half_edges(f) {
                let Some(g) = m.face_of(m.twin(h)) else { continue };
                if region.contains_key(g) || along(m, h) {
                    continue;
                }
                region.insert(g, k);
                members.push(g);
            }
        }
        regions.push(members);
    }
    for members in regions {
        // The patch under each triangle's centroid, once.
        let own: Vec<Option<u32>> = members
            .iter()
            .map(|&f| c.patch(m.face_vertices(f).map(|v| m.pos(v)).iter().sum::<DVec3>() / 3.0))
            .collect();
        let mut votes: Vec<(u32, usize)> = Vec::new();
        for l in own.iter().map(|l| l.unwrap_or(0)) {
            match votes.iter_mut().find(|x| x.0 == l) {
                Some(x) => x.1 += 1,
                None => votes.push((l, 1)),
            }
        }
        // Most votes; the lower patch on a tie (deterministic).
        let best = votes.iter().max_by(|x, y| x.1.cmp(&y.1).then(y.0.cmp(&x.0))).map_or(0, |x| x.0);
        // A region with many faces of another patch has leaked through a gap in the cut
        // curves: its faces take their own patches, and the faces at the gap meet along
        // edges that the pipeline then holds on the curve between them.
        let leaked = votes.iter().any(|&(l, n)| l != best && n > LEAK_FACES.max(members.len() / 20));
        for (&f, l) in members.iter().zip(own) {
            let l = if leaked { l.unwrap_or(best) } else { best };
            m.set_label(f, l.min(65_535));
        }
    }
}
