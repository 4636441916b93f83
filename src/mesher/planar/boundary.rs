use super::*;

/// Tags `Fixed` every non-fixed node farther than `rings` edges from the nodes where the old
/// and new distance functions differ; returns them so that their tags can be restored.
pub(super) fn freeze_far_nodes(ctx: &Ctx, m: &mut TriMesh<DVec2>, fz: &Freeze) -> Result<Vec<VertexId>, Error> {
    let mut ring: SecondaryMap<VertexId, u32> = SecondaryMap::new();
    let mut front: Vec<VertexId> = Vec::new();
    for v in m.vertex_ids() {
        let p = m.pos(v);
        let (dn, dold) = (ctx.d(p)?, fz.old_domain.value(p));
        let off_boundary = m.is_boundary_vertex(v) && dn.abs() > ctx.geps;
        // Only where the boundary itself moved: near the old or the new zero set.
        let near = dn.abs().min(dold.abs()) < 1.5 * ctx.opts.h0 * ctx.h(p)?;
        if ((dn - dold).abs() > 1e-12 * (1.0 + dn.abs()) && near) || off_boundary {
            ring.insert(v, 0);
            front.push(v);
        }
    }
    within_rings(m, &mut ring, front, fz.rings);
    let frozen: Vec<VertexId> =
        m.vertex_ids().filter(|&v| !ring.contains_key(v) && m.tag(v) != VertexTag::Fixed).collect();
    for &v in &frozen {
        m.set_tag(v, VertexTag::Fixed);
    }
    Ok(frozen)
}

/// The engine's [`TriMesh::star_edges`]: the half-edges from each vertex and the link edges
/// opposite it, the edges whose Delaunay test a change at the vertex can alter.
pub(super) fn star_edges(m: &TriMesh<DVec2>, vertices: &[VertexId]) -> Vec<HalfEdgeId> {
    m.star_edges(vertices)
}

/// Boundary nodes pushed inside become interior (a boundary ear is filled over them); interior
/// nodes pushed outside become boundary nodes (the boundary triangle below them is removed).
pub(super) fn change_membership(
    ctx: &mut Ctx,
    m: &mut TriMesh<DVec2>,
    snap: &Snapshot,
    leaving: &[(usize, DVec2)],
    joining: &[usize],
) -> Result<bool, Error> {
    let mut changed = false;
    let mut loops = BoundaryLoops::of_nodes(
        m,
        snap.ids.iter().zip(&snap.loop_nbrs).filter(|(_, l)| l.0 != u32::MAX).map(|(&v, _)| v),
    );
    for &(i, inner) in leaving {
        let b = snap.ids[i];
        if !m.contains_vertex(b) || m.tag(b) != VertexTag::Boundary || !m.is_boundary_vertex(b) {
            continue;
        }
        // An ear over a vertex whose neighbours are a single triangle would close the mesh.
        if m.num_faces() < 3 {
            continue;
        }
        let g = m.vertex(b).out; // b -> c on the boundary
        let e = m.prev(g); // a -> b
        let (a, c) = (m.origin(e), m.dest(g));
        if m.tag(a) == VertexTag::Interior || m.tag(c) == VertexTag::Interior {
            continue;
        }
        // The ear must lie inside the domain (the seed drops triangles with an outside
        // centroid): over a concave part of the boundary it would cover a hole.
        let (pa, pc) = (m.pos(a), m.pos(c));
        if ctx.approx_dist((pa + inner + pc) / 3.0)? > -ctx.geps || ctx.approx_dist((pa + pc) * 0.5)? > -ctx.geps {
            continue;
        }
        // Not while the ear would be a sliver: the node has barely crossed the chord.
        if ctx.tri_q([pa, inner, pc]) < EAR_Q {
            continue;
        }
        // The ear's edge a -> c, and the node's edges on the way, clear the other loops.
        if loops.crossed(m, &[a, b, c], &[(pa, pc), (pa, inner), (inner, pc)]) {
            continue;
        }
        let old = m.pos(b);
        if m.relocate(b, inner).is_err() {
            continue;
        }
        if m.fill_boundary_ear(e, m.face(m.face_of(m.twin(e)).expect("boundary edge has a face")).label).is_ok() {
            loops.add_at(m, a);
            m.set_tag(b, VertexTag::Interior);
            ctx.left += 1;
            changed = true;
        } else {
            m.set_pos_unchecked(b, old);
        }
    }
    for &i in joining {
        let v = snap.ids[i];
        if !m.contains_vertex(v) || m.tag(v) != VertexTag::Interior || m.is_boundary_vertex(v) {
            continue;
        }
        // The worst triangle with v as apex over a boundary edge that v stands over: v's
        // foot on the edge's line falls between its ends. Over a needle's short base (v
        // beyond either end) the loop would run out to v and straight back, a slit.
        let mut best: Option<(f64, HalfEdgeId)> = None;
        for x in m.outgoing(v) {
            if let Some(f) = m.face_of(x) {
                let opp = m.twin(m.next(x));
                if m.face_of(opp).is_none() && stands_over(m.pos(v), m.pos(m.origin(opp)), m.pos(m.dest(opp))) {
                    let q = ctx.tri_q(m.face_points(f));
                    if best.is_none_or(|(bq, _)| q < bq) {
                        best = Some((q, opp));
                    }
                }
            }
        }
        if let Some((_, t)) = best {
            let label = m.face(m.face_of(m.twin(t)).expect("an interior edge has a face")).label;
            if m.remove_boundary_triangle(t).is_ok() {
                // Onto d = 0 unless that crosses another loop (see [`BoundaryLoops`]) or
                // inverts a triangle; else the triangle goes back: a node left on the loop
                // inside the domain is a notch that nothing projects again.
                m.set_tag(v, VertexTag::Boundary);
                let g = m.vertex(v).out;
                let (p, x) = (m.origin(m.prev(g)), m.dest(g));
                let onto = match ctx.project(m.pos(v))? {
                    Some(q) => {
                        !loops.crossed(m, &[p, v, x], &[(m.pos(p), q), (q, m.pos(x))]) && m.relocate(v, q).is_ok()
                    }
                    None => false,
                };
                if onto || m.fill_boundary_ear(m.prev(g), label).is_err() {
                    ctx.joined += 1;
                    loops.add_at(m, v);
                    changed = true;
                } else {
                    // The restored edge p -> x is a new half-edge: the loops must see it.
                    loops.add_at(m, p);
                    m.set_tag(v, VertexTag::Interior);
                }
            }
        }
    }
    Ok(changed)
}

/// Whether the foot of `v` on the line through `a` and `b` lies strictly between them.
fn stands_over(v: DVec2, a: DVec2, b: DVec2) -> bool {
    let t = (v - a).dot(b - a);
    t > 0.0 && t < (b - a).length_squared()
}

/// Interior nodes that the forces push across an internal boundary join it (seed 3.4: "if a
/// new node tries to cross the boundary it is added to the list of boundary nodes"): the
/// worst triangle with the node as apex over an internal-boundary edge changes sides, so the
/// curve runs through the node, which is then projected onto d_I = 0.
pub(super) fn join_internal(
    ctx: &mut Ctx,
    m: &mut TriMesh<DVec2>,
    snap: &Snapshot,
    joining: &[usize],
) -> Result<bool, Error> {
    let mut changed = false;
    for &i in joining {
        let v = snap.ids[i];
        if !m.contains_vertex(v) || m.tag(v) != VertexTag::Interior || m.is_boundary_vertex(v) {
            continue;
        }
        let mut best: Option<(f64, crate::topology::FaceId, u32)> = None;
        for x in m.outgoing(v) {
            let Some(f) = m.face_of(x) else { continue };
            let opp = m.twin(m.next(x));
            if let Some(g) = m.face_of(opp) {
                if m.face(g).label != m.face(f).label {
                    let q = ctx.tri_q(m.face_points(f));
                    if best.is_none_or(|(bq, _, _)| q < bq) {
                        best = Some((q, f, m.face(g).label));
                    }
                }
            }
        }
        let Some((_, f, label)) = best else { continue };
        // The node joins between the two ends of that edge: its projection must land between
        // them and near the edge (near a corner of the curve it could land on another side).
        let Some(q) = ctx.project_internal(m.pos(v))? else { continue };
        let [x, y] = m
            .face_half_edges(f)
            .iter()
            .find(|&&h| m.origin(h) != v && m.dest(h) != v)
            .map_or([DVec2::NAN; 2], |&h| [m.pos(m.origin(h)), m.pos(m.dest(h))]);
        let between = (q - x).dot(y - x) > 0.0 && (q - y).dot(x - y) > 0.0;
        let off = (y - x).perp_dot(q - x).abs() / x.distance(y);
        if !between || off > 0.3 * x.distance(y) {
            continue;
        }
        m.set_label(f, label);
        m.set_tag(v, VertexTag::InternalBoundary { curve: 0 });
        ctx.joined += 1;
        let _ = m.relocate(v, q);
        changed = true;
    }
    Ok(changed)
}

/// Boundary nodes that the guarded projection could not bring onto d = 0 (a notch the forces
/// never closed) are projected one by one, or else merged into a boundary neighbour.
pub(super) fn settle_boundary(ctx: &mut Ctx, m: &mut TriMesh<DVec2>) -> Result<(), Error> {
    let tol = ctx.geps;
    for _ in 0..3 {
        let off: Vec<VertexId> = m
            .vertex_ids()
            .filter(|&v| m.tag(v) == VertexTag::Boundary && m.is_boundary_vertex(v))
            .filter(|&v| ctx.approx_dist(m.pos(v)).map(|d| d.abs() > tol).unwrap_or(true))
            .collect();
        if off.is_empty() {
            return Ok(());
        }
        let mut loops = BoundaryLoops::default();
        for v in off {
            if !m.contains_vertex(v) {
                continue;
            }
            // Neither the move nor the merge may cross another loop (see [`BoundaryLoops`]).
            let g = m.vertex(v).out;
            let e = m.prev(g);
            let (a, c) = (m.origin(e), m.dest(g));
            if let Some(q) = ctx.project(m.pos(v))? {
                if !loops.crossed(m, &[a, v, c], &[(m.pos(a), q), (q, m.pos(c))]) && m.relocate(v, q).is_ok() {
                    continue;
                }
            }
            if close_slit(ctx, m, v)? {
                continue;
            }
            let g = m.vertex(v).out;
            let e = m.prev(g);
            let targets = [(g, m.dest(g), m.origin(e)), (m.twin(e), m.origin(e), m.dest(g))];
            for (h, w, u) in targets {
                if loops.crossed(m, &[u, v, w], &[(m.pos(u), m.pos(w))]) {
                    continue;
                }
                if m.collapse(h, m.pos(w)).is_ok() {
                    ctx.report.ops.collapses += 1;
                    break;
                }
            }
        }
        ctx.report.ops.flips += ctx.make_delaunay(m);
    }
    peel_flat_ears(ctx, m)?;
    // What could not be settled is reported, not hidden.
    ctx.report.boundary_nodes_off = m
        .vertex_ids()
        .filter(|&v| m.tag(v) == VertexTag::Boundary && m.is_boundary_vertex(v))
        .filter(|&v| ctx.approx_dist(m.pos(v)).map(|d| d.abs() > tol).unwrap_or(true))
        .count();
    Ok(())
}

/// Projects every boundary node (used once at the start).
pub(super) fn project_boundary(ctx: &Ctx, snap: &Snapshot, p: &mut [DVec2], m: &TriMesh<DVec2>) -> Result<(), Error> {
    let old = p.to_vec();
    let mut newp = p.to_vec();
    for i in 0..p.len() {
        let q = match snap.kind[i] {
            NodeKind::Boundary => ctx.project(p[i])?,
            NodeKind::Internal => ctx.project_internal(p[i])?,
            _ => None,
        };
        if let Some(q) = q {
            newp[i] = q;
        }
    }
    let metrics = match ctx.metric {
        Some(_) => Some(old.iter().map(|&x| ctx.metric_at(x)).collect::<Result<Vec<Metric2>, Error>>()?),
        None => None,
    };
    snap.guard_inversions(&old, &mut newp, None, metrics.as_deref());
    // The force step's fold control too: a projection can fold a fan or lay one stretch of
    // boundary across another as a step can.
    if ctx.metric.is_some() {
        snap.guard_folds(&old, &mut newp);
    } else {
        snap.guard_folds_screened(&old, &mut newp, None);
    }
    p.copy_from_slice(&newp);
    let _ = m;
    Ok(())
}

/// Removes the boundary vertex `v` with its only triangle when that triangle is below
/// Q_REPAIR and the edge left in its place lies on d = 0 (within the boundary tolerance): a
/// flat ear on a straight stretch of boundary, or the tip of a zero-width tongue that the
/// boundary loop makes by running along a straight stretch and back. Forces cannot open such
/// a triangle (all three vertices are held on the same line) and a collapse along the
/// boundary is often refused there; the removal changes the covered area by the ear's.
pub(super) fn peel_flat_ear(ctx: &mut Ctx, m: &mut TriMesh<DVec2>, v: VertexId) -> Result<bool, Error> {
    if !m.contains_vertex(v) || m.tag(v) != VertexTag::Boundary {
        return Ok(false);
    }
    let faces = m.vertex_faces(v);
    let [f] = faces.as_slice() else {
        return Ok(false);
    };
    if ctx.tri_q(m.face_points(*f)) >= Q_REPAIR {
        return Ok(false);
    }
    let others: Vec<DVec2> = m.face_vertices(*f).into_iter().filter(|&u| u != v).map(|u| m.pos(u)).collect();
    if ctx.approx_dist((others[0] + others[1]) * 0.5)?.abs() > ctx.geps {
        return Ok(false);
    }
    if m.remove_boundary_ear(v).is_err() {
        return Ok(false);
    }
    ctx.report.ops.collapses += 1;
    Ok(true)
}

/// [`peel_flat_ear`] over every boundary vertex until none is left: peeling one ear of a
/// tongue leaves the next vertex with a single flat triangle.
pub(super) fn peel_flat_ears(ctx: &mut Ctx, m: &mut TriMesh<DVec2>) -> Result<usize, Error> {
    let queue: Vec<VertexId> = m.vertex_ids().filter(|&v| m.is_boundary_vertex(v)).collect();
    peel_flat_ears_from(ctx, m, queue)
}

/// [`peel_flat_ears`] over the boundary vertices `queue` (in key order) and what peeling
/// them opens.
fn peel_flat_ears_from(ctx: &mut Ctx, m: &mut TriMesh<DVec2>, mut queue: Vec<VertexId>) -> Result<usize, Error> {
    let mut peeled = 0;
    while let Some(v) = queue.pop() {
        if !m.contains_vertex(v) {
            continue;
        }
        let ring = m.neighbours(v);
        if peel_flat_ear(ctx, m, v)? {
            peeled += 1;
            queue.extend(ring.into_iter().filter(|&u| m.contains_vertex(u)));
        }
    }
    if peeled > 0 {
        ctx.report.ops.flips += ctx.make_delaunay(m);
    }
    Ok(peeled)
}

/// A slit closes when the outside angle at a boundary node off d = 0 is below this (radians).
const SLIT_ANGLE: f64 = 0.05;

/// Closes a slit: the boundary loop runs from the boundary into the domain to the node `v`
/// off d = 0 and straight back, its two sides nearly on top of each other (the outside
/// angle at `v` below SLIT_ANGLE). An ear over `v` makes it interior, and the ear's short
/// boundary edge collapses, which zips the two sides together. Returns whether it closed.
pub(super) fn close_slit(ctx: &mut Ctx, m: &mut TriMesh<DVec2>, v: VertexId) -> Result<bool, Error> {
    if m.tag(v) != VertexTag::Boundary || !m.is_boundary_vertex(v) || m.num_faces() < 3 {
        return Ok(false);
    }
    let g = m.vertex(v).out; // v -> c on the boundary
    let e = m.prev(g); // a -> v
    let (a, c) = (m.origin(e), m.dest(g));
    if !matches!(m.tag(a), VertexTag::Boundary | VertexTag::Fixed)
        || !matches!(m.tag(c), VertexTag::Boundary | VertexTag::Fixed)
    {
        return Ok(false);
    }
    let pv = m.pos(v);
    let inside: f64 = m
        .vertex_faces(v)
        .iter()
        .map(|&f| {
            let vs = m.face_vertices(f);
            let k = vs.iter().position(|&u| u == v).unwrap_or(0);
            (m.pos(vs[(k + 1) % 3]) - pv).angle_to(m.pos(vs[(k + 2) % 3]) - pv).abs()
        })
        .sum();
    if 2.0 * std::f64::consts::PI - inside > SLIT_ANGLE {
        return Ok(false);
    }
    let label = m.face(m.face_of(m.twin(e)).expect("boundary edge has a face")).label;
    let Ok(f) = m.fill_boundary_ear(e, label) else { return Ok(false) };
    m.set_tag(v, VertexTag::Interior);
    // The ear's new boundary edge a -> c.
    let ac = m.face_half_edges(f).into_iter().find(|&h| m.origin(m.twin(h)) == a && m.face_of(m.twin(h)).is_none());
    let closed = match ac.map(|h| m.twin(h)) {
        Some(t) => try_collapse(ctx, m, t, &mut BoundaryLoops::default())?,
        None => false,
    };
    if !closed {
        // The ear alone would leave a needle: undo it (the vertex goes back to the boundary).
        if let Some(t) = ac.map(|h| m.twin(h)) {
            if m.remove_boundary_triangle(t).is_ok() {
                m.set_tag(v, VertexTag::Boundary);
            }
        }
        return Ok(false);
    }
    Ok(true)
}

/// [`close_slit`] at every boundary node off d = 0, then [`peel_flat_ears`]: run with density
/// control, so that a slit or a flat tongue does not stay for the rest of the run. Returns
/// whether the topology changed.
///
/// `seeds` has a vertex of every boundary loop: the loops are walked from them instead of
/// scanning every vertex of the mesh (the band of a large mesh).
pub(super) fn close_slits(ctx: &mut Ctx, m: &mut TriMesh<DVec2>, seeds: &[VertexId]) -> Result<bool, Error> {
    let boundary = loop_vertices(m, seeds);
    let mut off: Vec<VertexId> = Vec::new();
    for &v in &boundary {
        if m.tag(v) == VertexTag::Boundary && ctx.approx_dist(m.pos(v))?.abs() > ctx.geps {
            off.push(v);
        }
    }
    let mut changed = false;
    for v in off {
        if m.contains_vertex(v) {
            changed |= close_slit(ctx, m, v)?;
        }
    }
    let queue = loop_vertices(m, &boundary);
    Ok(peel_flat_ears_from(ctx, m, queue)? > 0 || changed)
}

/// The vertices of the boundary loops through the boundary vertices among `seeds`, in key
/// order (the order of a scan over every vertex).
fn loop_vertices(m: &TriMesh<DVec2>, seeds: &[VertexId]) -> Vec<VertexId> {
    let mut seen: std::collections::HashSet<VertexId> = std::collections::HashSet::new();
    for &s in seeds {
        if !m.contains_vertex(s) || !m.is_boundary_vertex(s) || seen.contains(&s) {
            continue;
        }
        let start = m.vertex(s).out;
        let mut g = start;
        for _ in 0..2 * m.num_edges() {
            seen.insert(m.origin(g));
            g = m.next(g);
            if g == start {
                break;
            }
        }
    }
    let mut out: Vec<VertexId> = seen.into_iter().collect();
    out.sort_unstable();
    out
}
