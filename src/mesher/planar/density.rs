use super::*;

/// Boundary edges are split above and collapsed below these many current mean lengths: the
/// boundary spacing follows the mesh's own scale, which the interior sets.
pub(super) const BOUNDARY_BAND: DensityBand = DensityBand::new(1.6, 0.6);
/// Edges to split, edges to collapse and faces to repair, found in parallel on the snapshot.
pub(super) struct Candidates {
    pub(super) long: Vec<(f64, HalfEdgeId)>,
    pub(super) short: Vec<(f64, HalfEdgeId)>,
    pub(super) bad: Vec<(f64, crate::topology::FaceId)>,
}

/// With a metric, boundary edges whose midpoint is farther from the boundary than this many
/// metric lengths are split (a chord must not cut into the layer of elements below it).
pub(super) const METRIC_SAGITTA: f64 = 0.5;
impl Candidates {
    pub(super) fn is_empty(&self) -> bool {
        self.long.is_empty() && self.short.is_empty() && self.bad.is_empty()
    }
}

/// `unit` is the current mean edge length (absolute), or with a metric `metric_unit`, the
/// mean metric edge length: boundary spacing follows it.
pub(super) fn density_candidates(
    ctx: &Ctx,
    snap: &Snapshot,
    p: &[DVec2],
    unit: f64,
    metric_unit: Option<f64>,
    band: DensityBand,
) -> Result<Candidates, Error> {
    let h0 = ctx.opts.h0;
    // (ratio, edge, +1 long / -1 short)
    let marks: Vec<(f64, HalfEdgeId, i8)> = snap
        .edges
        .par_iter()
        .with_min_len(CHUNK)
        .filter_map(|&(a, b, h, kind)| {
            // Not next to a held core (see `held`): it does not move.
            if a as usize >= snap.n_band || b as usize >= snap.n_band {
                return None;
            }
            let (pa, pb) = (p[a as usize], p[b as usize]);
            let (r, rb) = if let Some(mu) = metric_unit {
                match ctx.ratio(pa, pb) {
                    Ok(r) => (r, r / mu),
                    Err(e) => return Some(Err(e)),
                }
            } else {
                let hm = match ctx.h((pa + pb) * 0.5) {
                    Ok(v) => v,
                    Err(e) => return Some(Err(e)),
                };
                (pa.distance(pb) / (h0 * hm), pa.distance(pb) / (unit * hm))
            };
            if band.splits(r) {
                Some(Ok((r, h, 1)))
            } else if band.collapses(r) {
                Some(Ok((r, h, -1)))
            } else if kind != EDGE_INTERIOR {
                // Boundary (and internal-boundary) spacing follows the mesh's own current scale
                // (the interior sets it): the carved start may have too many boundary nodes.
                // With a metric, a boundary edge must also follow the curve to within a
                // fraction of the metric's size across it, or the layer next to it is cut.
                let sag = if metric_unit.is_some() && kind == EDGE_BOUNDARY {
                    match ctx.metric_sagitta(pa, pb) {
                        Ok(v) => v,
                        Err(e) => return Some(Err(e)),
                    }
                } else {
                    0.0
                };
                if BOUNDARY_BAND.splits(rb) || sag > METRIC_SAGITTA {
                    Some(Ok((rb.max(sag / METRIC_SAGITTA), h, 1)))
                } else if BOUNDARY_BAND.collapses(rb) && 4.0 * sag <= METRIC_SAGITTA {
                    Some(Ok((rb, h, -1)))
                } else {
                    None
                }
            } else {
                None
            }
        })
        .collect::<Result<_, Error>>()?;
    let bad: Vec<(f64, crate::topology::FaceId)> = snap
        .tris
        .par_iter()
        .zip(snap.tri_faces.par_iter())
        .with_min_len(CHUNK)
        .filter_map(|(t, f)| {
            if t.iter().any(|&v| v as usize >= snap.n_band) {
                return None;
            }
            let [a, b, c] = [p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]];
            if metric_unit.is_none() && surely_not_below_repair(a, b, c) {
                return None;
            }
            let q = ctx.tri_q([a, b, c]);
            (q < Q_REPAIR).then_some((q, *f))
        })
        .collect();
    let long = marks.iter().filter(|m| m.2 > 0).map(|m| (m.0, m.1)).collect();
    let short = marks.iter().filter(|m| m.2 < 0).map(|m| (m.0, m.1)).collect();
    Ok(Candidates { long, short, bad })
}

/// Whether q = 2 r_in / r_out of the triangle is at least Q_REPAIR, by a bound without square
/// roots (the repair scan tests every triangle and finds almost none): q = 16 A^2 / (P la lb lc)
/// with perimeter P <= 3 L and each side <= L (L the longest), so q >= 16 A^2 / (3 L^4).
pub(super) fn surely_not_below_repair(a: DVec2, b: DVec2, c: DVec2) -> bool {
    let twice_area = 2.0 * crate::quality::triangle_area([a, b, c]);
    let l2 = a.distance_squared(b).max(b.distance_squared(c)).max(c.distance_squared(a));
    // 16 A^2 = 4 (2A)^2; a margin of 1% covers the rounding of both sides.
    4.0 * twice_area * twice_area >= 1.01 * 3.0 * Q_REPAIR * l2 * l2
}

/// Splits the long edges and collapses the short ones of `cands` (see [`density_candidates`]),
/// and the shortest edge of triangles below Q_REPAIR, then restores Delaunay.
/// Returns whether the topology changed.
pub(super) fn density_control(
    ctx: &mut Ctx,
    m: &mut TriMesh<DVec2>,
    cands: Candidates,
    global_pass: bool,
    mut loops: BoundaryLoops,
) -> Result<bool, Error> {
    let mut changed = false;
    let Candidates { mut long, mut short, mut bad } = cands;
    long.sort_by(|x, y| y.0.total_cmp(&x.0));
    for (_, h) in long {
        if !m.contains_half_edge(h) {
            continue;
        }
        let (a, b) = (m.pos(m.origin(h)), m.pos(m.dest(h)));
        let mut mid = (a + b) * 0.5;
        // A boundary edge splits on its chord, and the new vertex moves onto d = 0 by the
        // checked relocation (a split straight at the projection checks orientation only,
        // and can fold the open fans next to it).
        if m.is_boundary_edge(h) {
            let mut q = ctx.project(mid)?.unwrap_or(mid);
            // The relocation's check sees the edge's own loop; the new edges must also clear
            // the other loops (a coarse start's edge around a piece the carving left out
            // projects onto the far side of the domain, across the outer loop).
            let (va, vb) = (m.origin(h), m.dest(h));
            if q != mid && loops.crossed(m, &[va, vb], &[(a, q), (q, b)]) {
                q = mid;
            }
            if let Some((v, _)) = split_boundary_at(m, h, q) {
                loops.add_at(m, v);
                ctx.report.ops.splits += 1;
                changed = true;
                legalize_vertex(ctx, m, v);
            }
            continue;
        }
        if m.is_constrained_edge(h) {
            if let Some(q) = ctx.project_internal(mid)? {
                mid = q;
            }
        }
        let split_at = if m.check_split(h, mid).is_ok() { mid } else { (a + b) * 0.5 };
        if let Ok(v) = m.split_edge(h, split_at) {
            ctx.report.ops.splits += 1;
            changed = true;
            if split_at != mid {
                let _ = m.relocate(v, mid);
            }
            legalize_vertex(ctx, m, v);
        }
    }
    // Collapses: short edges, and the shortest edge of bad triangles.
    bad.sort_by(|x, y| x.0.total_cmp(&y.0));
    for (_, f) in bad {
        if !m.contains_face(f) || ctx.tri_q(m.face_points(f)) >= Q_REPAIR {
            continue;
        }
        // A flat ear goes with its middle vertex; otherwise its shortest edge collapses.
        let mut peeled = false;
        for u in m.face_vertices(f) {
            if super::boundary::peel_flat_ear(ctx, m, u)? {
                peeled = true;
                break;
            }
        }
        if peeled {
            changed = true;
            continue;
        }
        let hs = m.face_half_edges(f);
        let mut order: Vec<HalfEdgeId> = hs.to_vec();
        order.sort_by(|&x, &y| m.edge_length(x).total_cmp(&m.edge_length(y)));
        for h in order {
            if try_collapse(ctx, m, h, &mut loops)? {
                changed = true;
                break;
            }
        }
    }
    short.sort_by(|x, y| x.0.total_cmp(&y.0));
    // One collapse per neighbourhood and pass: the forces spread the change before the next.
    // Hashed: a few vertices of what may be a large mesh (a slot-indexed map would be laid
    // out up to the largest vertex index at every window).
    let mut touched: slotmap::SparseSecondaryMap<VertexId, ()> = slotmap::SparseSecondaryMap::new();
    for (_, h) in short {
        if !m.contains_half_edge(h) || touched.contains_key(m.origin(h)) || touched.contains_key(m.dest(h)) {
            continue;
        }
        let ring: Vec<VertexId> = m.neighbours(m.origin(h)).into_iter().chain(m.neighbours(m.dest(h))).collect();
        if try_collapse(ctx, m, h, &mut loops)? {
            changed = true;
            for v in ring {
                touched.insert(v, ());
            }
        }
    }
    // Each split and collapse restored Delaunay around its vertex. The pass over every edge
    // also catches edges that nodes made non-Delaunay since the last connectivity check: left
    // alone, ex8 runs into the iteration cap. Large meshes skip it (at 10^6 triangles it cost
    // 25 ms a window, a seventh of the run): their windows end in a connectivity check anyway.
    if changed && global_pass {
        ctx.report.ops.flips += ctx.make_delaunay(m);
    }
    Ok(changed)
}

/// Collapses the edge of `h` in whichever direction the tags allow: an interior vertex goes
/// into the other end; two boundary vertices on a boundary edge meet at the projected midpoint.
pub(super) fn try_collapse(
    ctx: &mut Ctx,
    m: &mut TriMesh<DVec2>,
    h: HalfEdgeId,
    loops: &mut BoundaryLoops,
) -> Result<bool, Error> {
    let t = m.twin(h);
    let (a, b) = (m.origin(h), m.dest(h));
    let (ta, tb) = (m.tag(a), m.tag(b));
    let mut tries: Vec<(HalfEdgeId, DVec2)> = Vec::with_capacity(3);
    match (ta, tb) {
        (VertexTag::Interior, VertexTag::Interior) => {
            tries.push((h, (m.pos(a) + m.pos(b)) * 0.5));
            tries.push((h, m.pos(b)));
            tries.push((t, m.pos(a)));
        }
        (VertexTag::Interior, _) => tries.push((h, m.pos(b))),
        (_, VertexTag::Interior) => tries.push((t, m.pos(a))),
        (VertexTag::Boundary, VertexTag::Boundary) if m.is_boundary_edge(h) => {
            let mid = (m.pos(a) + m.pos(b)) * 0.5;
            if let Some(q) = ctx.project(mid)? {
                tries.push((h, q));
            }
            tries.push((h, m.pos(b)));
        }
        (VertexTag::Boundary, VertexTag::Fixed) if m.is_boundary_edge(h) => tries.push((h, m.pos(b))),
        (VertexTag::Fixed, VertexTag::Boundary) if m.is_boundary_edge(h) => tries.push((t, m.pos(a))),
        // Along an internal boundary, as along the boundary.
        (VertexTag::InternalBoundary { .. }, VertexTag::InternalBoundary { .. }) if m.is_constrained_edge(h) => {
            if let Some(q) = ctx.project_internal((m.pos(a) + m.pos(b)) * 0.5)? {
                tries.push((h, q));
            }
            tries.push((h, m.pos(b)));
        }
        (VertexTag::InternalBoundary { .. }, VertexTag::Fixed) if m.is_constrained_edge(h) => tries.push((h, m.pos(b))),
        (VertexTag::Fixed, VertexTag::InternalBoundary { .. }) if m.is_constrained_edge(h) => tries.push((t, m.pos(a))),
        _ => {}
    }
    // A boundary edge u -> w (no face) collapsing to pos leaves the boundary edges
    // prev -> pos -> next, which must clear the other loops too (see [`BoundaryLoops`]).
    let open = if m.face_of(h).is_none() {
        Some(h)
    } else if m.face_of(t).is_none() {
        Some(t)
    } else {
        None
    };
    let around = open.map(|g| (m.origin(m.prev(g)), m.origin(g), m.dest(g), m.dest(m.next(g))));
    for (e, pos) in tries {
        if let Some((p, u, w, x)) = around {
            if loops.crossed(m, &[p, u, w, x], &[(m.pos(p), pos), (pos, m.pos(x))]) {
                continue;
            }
        }
        if let Ok(v) = m.collapse(e, pos) {
            ctx.report.ops.collapses += 1;
            legalize_vertex(ctx, m, v);
            return Ok(true);
        }
    }
    Ok(false)
}

/// Lawson flips from the star of `v` ([`TriMesh::star_edges`]) by [`Ctx::legalize`]'s test:
/// exact in-circle, or the metric's.
pub(super) fn legalize_vertex(ctx: &mut Ctx, m: &mut TriMesh<DVec2>, v: VertexId) {
    let stack = m.star_edges(&[v]);
    ctx.report.ops.flips += ctx.legalize(m, stack);
}

/// The boundary half-edges (no face) of a mesh, read once when first asked for and kept
/// current by the caller's splits: the relocation and collapse checks of [`TriMesh`] walk the
/// edge's own loop only, while a move can also cross another loop (a coarse start's edge
/// around a piece the carving left out projects onto the far side of the domain, across the
/// outer loop). Stale entries are skipped.
#[derive(Default)]
pub(super) struct BoundaryLoops {
    edges: Option<Vec<HalfEdgeId>>,
}

impl BoundaryLoops {
    /// The list read from the boundary nodes given (a snapshot's), not from the whole arena:
    /// a boundary vertex's `out` is its boundary half-edge.
    pub(super) fn of_nodes(m: &TriMesh<DVec2>, nodes: impl Iterator<Item = VertexId>) -> BoundaryLoops {
        let edges = nodes
            .filter(|&v| m.contains_vertex(v))
            .map(|v| m.vertex(v).out)
            .filter(|&h| m.face_of(h).is_none())
            .collect();
        BoundaryLoops { edges: Some(edges) }
    }

    /// Records the boundary half-edges at v (after a split made them).
    pub(super) fn add_at(&mut self, m: &TriMesh<DVec2>, v: VertexId) {
        if let Some(list) = &mut self.edges {
            list.extend(m.outgoing(v).into_iter().flat_map(|h| [h, m.twin(h)]).filter(|&h| m.face_of(h).is_none()));
        }
    }

    /// Whether the segments `segs` would meet a boundary edge that has no end in `skip` (exact
    /// segment tests, boxes first).
    pub(super) fn crossed(&mut self, m: &TriMesh<DVec2>, skip: &[VertexId], segs: &[(DVec2, DVec2)]) -> bool {
        let list = self.edges.get_or_insert_with(|| m.half_edge_ids().filter(|&h| m.face_of(h).is_none()).collect());
        let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
        for &(p, q) in segs {
            lo = lo.min(p).min(q);
            hi = hi.max(p).max(q);
        }
        list.iter().any(|&g| {
            if !m.contains_half_edge(g) || m.face_of(g).is_some() {
                return false;
            }
            let (u, w) = (m.origin(g), m.dest(g));
            if skip.contains(&u) || skip.contains(&w) {
                return false;
            }
            let (pu, pw) = (m.pos(u), m.pos(w));
            if pu.x.max(pw.x) < lo.x || pu.x.min(pw.x) > hi.x || pu.y.max(pw.y) < lo.y || pu.y.min(pw.y) > hi.y {
                return false;
            }
            segs.iter().any(|&(p, q)| crate::topology::segments_meet(p, q, pu, pw))
        })
    }
}

/// Triangles below this quality are repaired by collapsing their shortest edge.
pub(super) const Q_REPAIR: f64 = 0.02;

/// Splits the boundary edge `h` at the point `q` off its chord (the chord's midpoint projected
/// onto d = 0): on the chord first, then the new vertex moved to `q` by the checked
/// relocation. A split straight at `q` checks only the orientation of its two triangles, while
/// the move checks what an outward point can break: the open fans of the vertex and its
/// boundary neighbours, and the new boundary edges against the rest of the loop. Returns the
/// new vertex and whether it reached `q`.
pub(super) fn split_boundary_at(m: &mut TriMesh<DVec2>, h: HalfEdgeId, q: DVec2) -> Option<(VertexId, bool)> {
    let chord = (m.pos(m.origin(h)) + m.pos(m.dest(h))) * 0.5;
    let v = m.split_edge(h, chord).ok()?;
    Some((v, q == chord || m.relocate(v, q).is_ok()))
}
