use super::*;

/// Keeps the triangles whose centroid is inside (d < -geps), repairs pinched vertices, and
/// tags the boundary.
/// Takes the mesh by value: it is dropped before the carved one is built (peak memory).
pub(super) fn carve(ctx: &Ctx, m: TriMesh<DVec2>, boundary_slack: f64) -> Result<TriMesh<DVec2>, Error> {
    let crate::topology::MeshArrays { points, cells: tris, labels, keys, .. } = m.to_arrays();
    let on_boundary: Vec<bool> = keys.iter().map(|&k| boundary_slack > 0.0 && m.is_boundary_vertex(k)).collect();
    let fixed: Vec<bool> = keys.iter().map(|&k| m.tag(k) == VertexTag::Fixed).collect();
    drop(m);
    carve_arrays(ctx, Cells { points, tris, labels, fixed, on_boundary }, boundary_slack)
}

/// A triangle list with what carving needs to know of its vertices.
pub(super) struct Cells {
    pub(super) points: Vec<DVec2>,
    pub(super) tris: Vec<[usize; 3]>,
    pub(super) labels: Vec<u32>,
    pub(super) fixed: Vec<bool>,
    pub(super) on_boundary: Vec<bool>,
}

/// [`carve`] on arrays.
pub(super) fn carve_arrays(ctx: &Ctx, cells: Cells, boundary_slack: f64) -> Result<TriMesh<DVec2>, Error> {
    let Cells { points, tris, labels, fixed, on_boundary } = cells;
    // As the seed keeps only grid points with d < geps, keep the triangles whose three
    // vertices are inside; the pressure then pushes the outer row onto the boundary. Boundary
    // vertices of a previous mesh count as inside up to `boundary_slack` relative sizes
    // outside: they are projected onto the moved boundary instead of dropped with their row.
    let inside: Vec<bool> = points
        .par_iter()
        .zip(&on_boundary)
        .with_min_len(CHUNK)
        .map(|(p, &b)| {
            let slack = if b { boundary_slack * ctx.opts.h0 * ctx.h(*p)? } else { 0.0 };
            Ok(ctx.d(*p)? < ctx.geps + slack)
        })
        .collect::<Result<Vec<bool>, Error>>()?;
    let mut keep: Vec<[usize; 3]> = Vec::with_capacity(tris.len());
    // The fixed points sorted by x, to find those in a triangle's box.
    let mut fixed_pts: Vec<DVec2> = ctx.opts.fixed.clone();
    fixed_pts.sort_by(|a, b| a.x.total_cmp(&b.x));
    // Labels are looked up again after the clean-up below; with one subdomain (the usual
    // case) there is nothing to look up.
    let one_label = labels.iter().all(|&l| Some(&l) == labels.first());
    let mut keep_label: crate::FastMap<[usize; 3], u32> = crate::FastMap::default();
    for (t, &label) in tris.iter().zip(&labels) {
        // Around fixed points (often corners on d = 0) the centroid decides, so they stay.
        let touches_fixed = t.iter().any(|&i| fixed[i]);
        let c = (points[t[0]] + points[t[1]] + points[t[2]]) / 3.0;
        let all_inside = t.iter().all(|&i| inside[i]);
        // Triangles of inside vertices over a concave corner (a hole's corner) cover the
        // outside there; next to a fixed point on that corner they would close its fan over
        // the hole and leave the corner inside the mesh. Dropped (as the seed drops triangles
        // with an outside centroid), so the corner stays on the boundary.
        if all_inside && near_fixed(&fixed_pts, [points[t[0]], points[t[1]], points[t[2]]]) && ctx.d(c)? > ctx.geps {
            continue;
        }
        if all_inside || (touches_fixed && ctx.d(c)? < -ctx.geps) {
            keep.push(*t);
            if !one_label {
                keep_label.insert(*t, label);
            }
        }
    }
    keep = open_closed_corners(ctx, &points, &fixed, keep)?;
    keep = bridge_pieces(ctx, &points, &tris, &fixed, keep, |t| {
        if !one_label {
            keep_label.insert(tris[t], labels[t]);
        }
    })?;
    let still_pinched;
    (keep, still_pinched) = join_pinched_fans(ctx, &points, &tris, &fixed, keep, |t| {
        if !one_label {
            keep_label.insert(tris[t], labels[t]);
        }
    })?;
    keep = drop_islands(&keep, &inside);
    // Pinched vertices (two fans) would break the manifold structure: drop the triangles of
    // every fan but the largest, and repeat until none is left. (Dropping islands, whole
    // pieces, pinches no vertex: with none left after the join there is nothing to do.)
    if still_pinched {
        for _ in 0..64 {
            let pinched = pinched_vertices(points.len(), &keep);
            if pinched.is_empty() {
                break;
            }
            keep = drop_small_fans(&keep, &pinched, points.len());
        }
    }
    if keep.is_empty() {
        return Err(Error::EmptyDomain(
            "no triangle of the initial mesh has its centroid inside the domain: h0 is too large for it".into(),
        ));
    }
    // Compact and build.
    let mut map = vec![usize::MAX; points.len()];
    let mut pts = Vec::new();
    let mut is_fixed = Vec::new();
    for t in &keep {
        for &i in t {
            if map[i] == usize::MAX {
                map[i] = pts.len();
                pts.push(points[i]);
                is_fixed.push(fixed[i]);
            }
        }
    }
    // Large meshes: vertices along a Hilbert curve and faces by their first vertex there, so
    // that neighbours sit near each other in the arenas and in the force loop's arrays (the
    // refinement leaves each level's vertices in one block, and every sweep would wait on cache
    // misses). Small ones fit in cache and keep the refinement's order.
    let relayout = pts.len() > RELAYOUT_ABOVE;
    let order: Vec<usize> = if relayout { crate::topology::hilbert_order(&pts) } else { (0..pts.len()).collect() };
    let mut rank = vec![0usize; pts.len()];
    for (r, &i) in order.iter().enumerate() {
        rank[i] = r;
    }
    let pts: Vec<DVec2> = order.iter().map(|&i| pts[i]).collect();
    let is_fixed: Vec<bool> = order.iter().map(|&i| is_fixed[i]).collect();
    let label_of = |t: &[usize; 3]| if one_label { labels[0] } else { keep_label[t] };
    let mut tri: Vec<([usize; 3], u32)> =
        keep.iter().map(|t| ([rank[map[t[0]]], rank[map[t[1]]], rank[map[t[2]]]], label_of(t))).collect();
    if relayout {
        // Each triangle from its first vertex on (orientation kept), then by that vertex: the
        // arena order then follows from the triangles alone, however they were produced.
        for (t, _) in tri.iter_mut() {
            let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
            t.rotate_left(k);
        }
        // Distinct triangles: the same order for any thread count.
        tri.par_sort_unstable_by_key(|(t, _)| *t);
    }
    let (labels, tri): (Vec<u32>, Vec<[usize; 3]>) = tri.into_iter().map(|(t, l)| (l, t)).unzip();
    let (mut out, ids) =
        TriMesh::from_arrays(&pts, &tri).map_err(|e| Error::internal(format!("carving the initial mesh: {e}")))?;
    // from_arrays creates the faces in triangle order: labels (subdomains) carry over.
    let faces: Vec<crate::topology::FaceId> = out.face_ids().collect();
    for (f, l) in faces.into_iter().zip(labels) {
        out.set_label(f, l);
    }
    for (i, &v) in ids.iter().enumerate() {
        let tag = if is_fixed[i] {
            VertexTag::Fixed
        } else if out.is_boundary_vertex(v) {
            VertexTag::Boundary
        } else {
            VertexTag::Interior
        };
        out.set_tag(v, tag);
    }
    internal::tag_interface(&mut out);
    restore_fixed(ctx, &mut out)?;
    Ok(out)
}

/// Rounds of [`join_pinched_fans`] at most (each can pinch the next vertex along a thin part).
const JOIN_ROUNDS: usize = 16;

/// How far outside d = 0 a vertex of a triangle taken back by [`join_pinched_fans`] may lie,
/// in the triangle's shortest sides: the projection onto d = 0 then moves it a little. A vertex
/// deeper out (inside a hole the lattice is coarse over) would leave its triangle over the hole.
const JOIN_REACH: f64 = 0.25;

/// [`join_pinched_fans`] joins only where the element size is within this many h0: there the
/// part is narrow at the resolution, and nothing else would mesh it. Where the requested size is
/// wider, the pinch is cut as before, and a part it leaves out is meshed again with the size
/// capped by the local feature size (see `gaps`), which resolves it with two elements across.
const RESOLUTION: f64 = super::coverage::BY_SIZE;

/// Breadth-first steps of [`bridge_pieces`] at most: pieces farther apart than this many
/// triangles are not joined.
const BRIDGE_STEPS: usize = 6;

/// Whether the start's triangle `t` may be taken back by the seed's rule: its centroid inside,
/// the size there at the resolution ([`RESOLUTION`]), no held point among its corners (their
/// triangles were decided by the centroid already, and opened over a hole's corner), and its
/// vertices outside within [`JOIN_REACH`] of d = 0.
fn takes_back(ctx: &Ctx, points: &[DVec2], fixed: &[bool], t: [usize; 3]) -> Result<bool, Error> {
    if t.iter().any(|&i| fixed[i]) {
        return Ok(false);
    }
    let [a, b, c] = t.map(|i| points[i]);
    let reach = JOIN_REACH * a.distance(b).min(b.distance(c)).min(c.distance(a));
    let centre = (a + b + c) / 3.0;
    Ok(ctx.h(centre)? <= RESOLUTION && ctx.d(centre)? < -ctx.geps && within(ctx, [a, b, c], reach)?)
}

/// The triangles of `all` sharing an edge with triangle `t`.
fn across<'a>(all: &'a [[usize; 3]], around: &'a Incidence, t: usize) -> impl Iterator<Item = usize> + 'a {
    let tri = all[t];
    (0..3).flat_map(move |k| {
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        around.of(a).iter().map(|&u| u as usize).filter(move |&u| u != t && all[u].contains(&b))
    })
}

/// Where a part is narrower than about two lattice rows, keeping only the triangles of inside
/// vertices leaves it in pieces that do not even touch (a ring 1.6 h0 wide came out in up to
/// 28), and the force loop never joins pieces again. The seed's rule keeps every triangle with
/// its centroid inside (section 2.2): from every piece at once, the start's triangles that rule
/// would keep ([`takes_back`]) are walked breadth first, and where two walks from different
/// pieces meet, the triangles of both walks back to their pieces are taken back, joining them;
/// so are two walks from one piece whose start triangles are far apart within it (the two sides
/// of a gap, a ring cut open; see [`near_within`]). Pieces that no such walk of
/// [`BRIDGE_STEPS`] triangles joins (separate parts of the domain) stay apart. `taken` is told
/// the index in `all` of each triangle taken back.
fn bridge_pieces(
    ctx: &Ctx,
    points: &[DVec2],
    all: &[[usize; 3]],
    fixed: &[bool],
    mut keep: Vec<[usize; 3]>,
    mut taken: impl FnMut(usize),
) -> Result<Vec<[usize; 3]>, Error> {
    if ctx.metric.is_some() || keep.len() < 2 {
        return Ok(keep);
    }
    // Pieces of the kept triangles (sharing edges), and their rim: the kept triangles with an
    // edge no other kept triangle shares, the only ones next to anything else.
    let kept_around = Incidence::new(points.len(), &keep);
    let mut pieces = crate::topology::DisjointSets::new(keep.len());
    let mut rim: Vec<usize> = Vec::new();
    for t in 0..keep.len() {
        let mut shared = 0;
        for u in across(&keep, &kept_around, t) {
            pieces.join(t, u);
            shared += 1;
        }
        if shared < 3 {
            rim.push(t);
        }
    }
    let around = Incidence::new(points.len(), all);
    // For each triangle of `all` a walk reached: the kept triangle (index into `keep`) it came
    // from, and the triangle before it (none for a kept one).
    let mut label: crate::FastMap<usize, usize> = crate::FastMap::default();
    let mut parent: crate::FastMap<usize, usize> = crate::FastMap::default();
    let mut frontier: Vec<usize> = Vec::new();
    for &k in &rim {
        let tri = keep[k];
        if let Some(&t) = around.of(tri[0]).iter().find(|&&u| all[u as usize] == tri) {
            label.insert(t as usize, k);
            frontier.push(t as usize);
        }
    }
    let kept_count = keep.len();
    let mut checked: crate::FastMap<usize, bool> = crate::FastMap::default();
    let mut added: std::collections::HashSet<usize> = std::collections::HashSet::new();
    for _ in 0..BRIDGE_STEPS {
        let mut next = Vec::new();
        for &t in &frontier {
            for u in across(all, &around, t) {
                if let Some(&b) = label.get(&u) {
                    // Two walks meet: join their pieces through both, or close a gap in one
                    // piece (a ring cut open) whose sides are far apart within it.
                    let a = label[&t];
                    let gap = a != b
                        && pieces.root(a) == pieces.root(b)
                        && !near_within(&keep[..kept_count], &kept_around, a, b);
                    if pieces.join(a, b) || gap {
                        for mut w in [t, u] {
                            while let Some(&p) = parent.get(&w) {
                                if added.insert(w) {
                                    keep.push(all[w]);
                                    taken(w);
                                }
                                w = p;
                            }
                        }
                    }
                    continue;
                }
                // (A kept triangle off the rim is never reached: its neighbours are all kept.)
                let ok = match checked.get(&u) {
                    Some(&ok) => ok,
                    None => {
                        let ok = takes_back(ctx, points, fixed, all[u])?;
                        checked.insert(u, ok);
                        ok
                    }
                };
                if ok {
                    label.insert(u, label[&t]);
                    parent.insert(u, t);
                    next.push(u);
                }
            }
        }
        if next.is_empty() {
            break;
        }
        frontier = next;
    }
    Ok(keep)
}

/// Whether kept triangles `a` and `b` are within 2 [`BRIDGE_STEPS`] + 2 triangles of each
/// other through the kept triangles (vertex neighbours): two walks from such triangles meet
/// along an ordinary stretch of boundary, while the two sides of a gap in one piece are far
/// apart around it.
fn near_within(keep: &[[usize; 3]], around: &Incidence, a: usize, b: usize) -> bool {
    let mut seen = std::collections::HashSet::from([a]);
    let mut frontier = vec![a];
    for _ in 0..2 * BRIDGE_STEPS + 2 {
        let mut next = Vec::new();
        for &t in &frontier {
            for &v in &keep[t] {
                for &u in around.of(v) {
                    let u = u as usize;
                    if u == b {
                        return true;
                    }
                    if seen.insert(u) {
                        next.push(u);
                    }
                }
            }
        }
        frontier = next;
    }
    false
}

/// Whether every point of `t` has d below `reach`.
fn within(ctx: &Ctx, t: [DVec2; 3], reach: f64) -> Result<bool, Error> {
    for p in t {
        if ctx.d(p)? >= reach {
            return Ok(false);
        }
    }
    Ok(true)
}

/// Keeping only the triangles of inside vertices is stricter than the seed's rule, which keeps
/// every triangle of the inside points whose centroid is inside (section 2.2): where the domain
/// is about two lattice rows wide, the kept triangles touch only at vertices (pinched) and the
/// part falls into pieces that the force loop, with no global retriangulation, never joins
/// again. At each pinched vertex, the start's own triangles around it that the seed's rule
/// keeps ([`takes_back`]) are taken back, closing the gaps between its fans; their vertices
/// outside are boundary nodes that the loop projects onto d = 0. `taken` is told the index in
/// `all` of each triangle taken back. Returns the triangles and whether a vertex may still be
/// pinched.
fn join_pinched_fans(
    ctx: &Ctx,
    points: &[DVec2],
    all: &[[usize; 3]],
    fixed: &[bool],
    mut keep: Vec<[usize; 3]>,
    mut taken: impl FnMut(usize),
) -> Result<(Vec<[usize; 3]>, bool), Error> {
    // Not with a metric: its start is a stretched lattice, whose triangles at a pinch reach
    // far across the boundary along the long axis.
    if ctx.metric.is_some() {
        return Ok((keep, true));
    }
    let mut pinched = pinched_vertices(points.len(), &keep);
    if pinched.is_empty() {
        return Ok((keep, false));
    }
    let around = Incidence::new(points.len(), all);
    let mut kept: std::collections::HashSet<[usize; 3]> = keep.iter().copied().collect();
    for _ in 0..JOIN_ROUNDS {
        let mut added = false;
        for &v in &pinched {
            for &t in around.of(v) {
                let tri = all[t as usize];
                if !kept.contains(&tri) && takes_back(ctx, points, fixed, tri)? {
                    kept.insert(tri);
                    keep.push(tri);
                    taken(t as usize);
                    added = true;
                }
            }
        }
        if !added {
            break;
        }
        pinched = pinched_vertices(points.len(), &keep);
        if pinched.is_empty() {
            break;
        }
    }
    let still = !pinched.is_empty();
    Ok((keep, still))
}

/// Directions sampled around a fixed vertex whose fan closed, to find where the outside is.
const CORNER_SAMPLES: usize = 72;

/// A fixed vertex on the boundary (a hole's corner) whose kept triangles close all the way
/// around it would end inside the mesh, the hole's wedge there covered. The centroid rule
/// cannot see it: at a reflex corner a triangle spanning the hole's wedge can have its
/// centroid inside. Around each such vertex d is sampled on a small circle, and the
/// triangles whose angle at the vertex holds an outside direction are dropped, opening the
/// fan over the outside. Fixed points truly inside the domain have no outside direction and
/// keep their closed fans.
fn open_closed_corners(
    ctx: &Ctx,
    points: &[DVec2],
    fixed: &[bool],
    keep: Vec<[usize; 3]>,
) -> Result<Vec<[usize; 3]>, Error> {
    if !fixed.iter().any(|&f| f) {
        return Ok(keep);
    }
    let around = Incidence::new(points.len(), &keep);
    let mut drop = vec![false; keep.len()];
    for v in (0..points.len()).filter(|&i| fixed[i]) {
        let fan = around.of(v);
        if fan.is_empty() {
            continue;
        }
        // The edges v -> a and b -> v of each triangle (a, b the next two, counter-clockwise);
        // the fan is closed when every a is some triangle's b.
        let legs: Vec<(usize, usize, usize)> = fan
            .iter()
            .map(|&t| {
                let t = t as usize;
                let tri = keep[t];
                let k = (0..3).find(|&k| tri[k] == v).unwrap_or(0);
                (t, tri[(k + 1) % 3], tri[(k + 2) % 3])
            })
            .collect();
        let closed = legs.iter().all(|&(_, a, _)| legs.iter().any(|&(_, _, b)| b == a));
        if !closed {
            continue;
        }
        let pv = points[v];
        let r = 0.25 * legs.iter().map(|&(_, a, _)| points[a].distance(pv)).fold(f64::INFINITY, f64::min);
        let mut outside = Vec::new();
        for k in 0..CORNER_SAMPLES {
            let ang = std::f64::consts::TAU * (k as f64 + 0.5) / CORNER_SAMPLES as f64;
            let dir = DVec2::new(ang.cos(), ang.sin());
            if ctx.d(pv + r * dir)? > ctx.geps {
                outside.push(dir);
            }
        }
        for &(t, a, b) in &legs {
            let (ea, eb) = (points[a] - pv, points[b] - pv);
            // Strictly inside the angle from ea to eb (counter-clockwise, below 180 degrees).
            if outside.iter().any(|u| ea.perp_dot(*u) > 0.0 && u.perp_dot(eb) > 0.0) {
                drop[t] = true;
            }
        }
    }
    Ok(keep.into_iter().zip(drop).filter(|(_, d)| !d).map(|(t, _)| t).collect())
}

/// Whether a fixed point (of `sorted`, sorted by x) lies within the triangle `t`'s box grown
/// by its longest side: the triangle is next to a held corner.
fn near_fixed(sorted: &[DVec2], t: [DVec2; 3]) -> bool {
    let reach = t[0].distance(t[1]).max(t[1].distance(t[2])).max(t[2].distance(t[0]));
    let (lo, hi) = (t[0].min(t[1]).min(t[2]) - reach, t[0].max(t[1]).max(t[2]) + reach);
    let first = sorted.partition_point(|p| p.x < lo.x);
    sorted[first..].iter().take_while(|p| p.x <= hi.x).any(|p| p.y >= lo.y && p.y <= hi.y)
}

/// Boundary vertices (or edges) tried, nearest first, to put a fixed point outside the mesh in.
const RESTORE_TRIES: usize = 8;

/// Fixed points whose triangles were all carved away go back in: inside the mesh by insertion,
/// outside it by moving a near boundary vertex onto them, or else by splitting a near boundary
/// edge at them.
pub(super) fn restore_fixed(ctx: &Ctx, m: &mut TriMesh<DVec2>) -> Result<(), Error> {
    use crate::topology::Location;
    // The sharp corners found from d come after the given points; one that cannot be put in
    // (a stretched start far from it) is left free, see [`corners_left_free`].
    let given = ctx.opts.fixed.len() - ctx.report.feature_points;
    for (i, &p) in ctx.opts.fixed.iter().enumerate() {
        if m.vertices().any(|(_, v)| v.tag == VertexTag::Fixed && v.pos == p) {
            continue;
        }
        let start = m.face_ids().next().expect("the carved mesh has faces");
        let v = match m.locate(p, start) {
            Location::Vertex(v) => Some(v),
            Location::Face(f) => m.insert_in_face(f, p).ok(),
            Location::Edge(h) => m.split_edge(h, p).ok(),
            Location::Outside(_) => {
                // The nearest boundary vertex whose move keeps its triangles positive (in a
                // stretched start the nearest one may fold, a neighbour along the side not).
                let mut near: Vec<(f64, VertexId)> = m
                    .vertex_ids()
                    .filter(|&v| m.is_boundary_vertex(v) && m.tag(v) != VertexTag::Fixed)
                    .map(|v| (m.pos(v).distance(p), v))
                    .collect();
                near.sort_by(|a, b| a.0.total_cmp(&b.0));
                let mut placed = None;
                // A start in pieces: the moved vertex's boundary edges must clear the other
                // pieces too (the relocation tests its own loop only).
                let walls = crate::topology::boundary_edges_if_split(m);
                for &(_, v) in near.iter().take(RESTORE_TRIES) {
                    let old = m.pos(v);
                    if !path_inside(ctx, old, p)? || m.relocate(v, p).is_err() {
                        continue;
                    }
                    if crate::topology::boundary_clear(m, v, &walls) && star_inside(ctx, m, v)? {
                        placed = Some(v);
                        break;
                    }
                    m.set_pos_unchecked(v, old);
                }
                match placed {
                    Some(v) => Some(v),
                    None => split_toward(ctx, m, p)?,
                }
            }
        };
        match v {
            Some(v) => m.set_tag(v, VertexTag::Fixed),
            None if i >= given => {}
            None => {
                return Err(Error::Invalid(format!(
                    "fixed point ({}, {}) could not be placed in the mesh: it is too close to another node or outside the domain",
                    p.x, p.y
                )))
            }
        }
    }
    Ok(())
}

/// The sharp corners found from d (after the given fixed points in the options) that
/// [`restore_fixed`] could not put in: they are left free, and the report says so.
pub(super) fn corners_left_free(ctx: &Ctx, m: &TriMesh<DVec2>) -> Vec<DVec2> {
    let given = ctx.opts.fixed.len() - ctx.report.feature_points;
    ctx.opts.fixed[given..]
        .iter()
        .copied()
        .filter(|&p| !m.vertices().any(|(_, v)| v.tag == VertexTag::Fixed && v.pos == p))
        .collect()
}

/// Puts `p`, outside the mesh, in by splitting one of the boundary edges nearest to it at `p`:
/// the edge's triangle becomes two, with the triangle between the edge and `p` added. Only an
/// edge whose two new triangles are positive and whose added triangle holds no vertex.
fn split_toward(ctx: &Ctx, m: &mut TriMesh<DVec2>, p: DVec2) -> Result<Option<VertexId>, Error> {
    use crate::predicates::{orient2d, Sign};
    use crate::topology::segments_meet;
    let seg_dist = |a: DVec2, b: DVec2| {
        let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
        (a + (b - a) * t).distance(p)
    };
    let mut edges: Vec<(f64, HalfEdgeId)> = m
        .half_edge_ids()
        .filter(|&h| m.face_of(h).is_some() && m.is_boundary_edge(h))
        .map(|h| (seg_dist(m.pos(m.origin(h)), m.pos(m.dest(h))), h))
        .collect();
    edges.sort_by(|a, b| a.0.total_cmp(&b.0));
    for &(_, h) in edges.iter().take(RESTORE_TRIES) {
        let (a, b) = (m.pos(m.origin(h)), m.pos(m.dest(h)));
        // p beyond the edge (the mesh is on its left).
        if orient2d(a, b, p) != Sign::Negative {
            continue;
        }
        let holds = m.vertex_ids().any(|v| {
            let q = m.pos(v);
            q != a
                && q != b
                && orient2d(b, a, q) != Sign::Negative
                && orient2d(a, p, q) != Sign::Negative
                && orient2d(p, b, q) != Sign::Negative
        });
        // The new boundary edges a-p and p-b must cross no boundary edge either (one can pass
        // through the new triangle with both ends outside it).
        let (ha, hb) = (m.origin(h), m.dest(h));
        let crosses = edges.iter().any(|&(_, e)| {
            let (u, w) = (m.origin(e), m.dest(e));
            let (pu, pw) = (m.pos(u), m.pos(w));
            (u != ha && w != ha && segments_meet(a, p, pu, pw)) || (u != hb && w != hb && segments_meet(p, b, pu, pw))
        });
        if !holds && !crosses && path_inside(ctx, a, p)? && path_inside(ctx, p, b)? {
            if let Ok(v) = m.split_edge(h, p) {
                return Ok(Some(v));
            }
        }
    }
    Ok(None)
}

/// How far outside the domain, in local target lengths, the way from the mesh to a fixed
/// point may pass (a chord over a concave stretch of the boundary).
const RESTORE_SLACK: f64 = 0.25;

/// Whether the segment a-b stays inside the domain to within [`RESTORE_SLACK`] local lengths,
/// sampled every quarter of a local length. A fixed point whose way to the mesh leaves the
/// domain (a corner of a separate part narrower than the start's lattice) would pull the
/// mesh across the gap: such a corner is left out instead.
fn path_inside(ctx: &Ctx, a: DVec2, b: DVec2) -> Result<bool, Error> {
    let local = |q: DVec2| -> Result<f64, Error> { Ok(ctx.opts.h0 * ctx.h(q)?) };
    let len = a.distance(b);
    let n = (len / (0.25 * local(a)?.min(local(b)?))).ceil().clamp(1.0, 1e4) as usize;
    for k in 1..n {
        let q = a.lerp(b, k as f64 / n as f64);
        if ctx.approx_dist(q)? > RESTORE_SLACK * local(q)? {
            return Ok(false);
        }
    }
    Ok(true)
}

/// Whether every triangle around `v` has its centroid inside the domain (the seed keeps a
/// triangle by its centroid, section 2.2).
fn star_inside(ctx: &Ctx, m: &TriMesh<DVec2>, v: VertexId) -> Result<bool, Error> {
    for f in m.vertex_faces(v) {
        let t = m.face_points(f);
        if ctx.approx_dist((t[0] + t[1] + t[2]) / 3.0)? > 0.0 {
            return Ok(false);
        }
    }
    Ok(true)
}

/// Drops the pieces (edge-connected) of a carved triangle list that have no triangle with all
/// three vertices inside: the triangles kept only for a fixed point at a corner can form an
/// island apart from the mesh, which the boundary rows would later slide over. The fixed
/// point is then restored onto the mesh by [`restore_fixed`].
pub(super) fn drop_islands(tris: &[[usize; 3]], inside: &[bool]) -> Vec<[usize; 3]> {
    // Triangles sharing an edge are joined (union-find; the triangles on an edge a-b are found
    // among the few around a: no map and no sort, which cost most of the carving on large
    // starts).
    let around = Incidence::new(inside.len(), tris);
    let mut sets = crate::topology::DisjointSets::new(tris.len());
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            for &u in around.of(a) {
                let u = u as usize;
                if u > t && tris[u].contains(&b) {
                    sets.join(t, u);
                }
            }
        }
    }
    let mut core = vec![false; tris.len()];
    for (t, tri) in tris.iter().enumerate() {
        if tri.iter().all(|&i| inside[i]) {
            core[sets.root(t)] = true;
        }
    }
    let mut out = Vec::with_capacity(tris.len());
    for (t, tri) in tris.iter().enumerate() {
        if core[sets.root(t)] {
            out.push(*tri);
        }
    }
    out
}

/// Vertices with more than one boundary edge leaving them in a triangle list.
pub(crate) fn pinched_vertices(n: usize, tris: &[[usize; 3]]) -> Vec<usize> {
    let around = Incidence::new(n, tris);
    // Whether some triangle holds the directed edge a -> b (it is then among a's triangles).
    let has = |a: usize, b: usize| {
        around.of(a).iter().any(|&u| (0..3).any(|k| tris[u as usize][k] == a && tris[u as usize][(k + 1) % 3] == b))
    };
    let mut count = vec![0u8; n];
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if !has(b, a) {
                // b -> a is a boundary half-edge leaving b.
                count[b] = count[b].saturating_add(1);
            }
        }
    }
    (0..n).filter(|&i| count[i] > 1).collect()
}

/// For each pinched vertex keeps only its largest fan of triangles.
pub(crate) fn drop_small_fans(tris: &[[usize; 3]], pinched: &[usize], n: usize) -> Vec<[usize; 3]> {
    let mut is_pinched = vec![false; n];
    for &v in pinched {
        is_pinched[v] = true;
    }
    let mut drop = vec![false; tris.len()];
    let mut around: std::collections::HashMap<usize, Vec<usize>> = std::collections::HashMap::new();
    for (i, t) in tris.iter().enumerate() {
        for &v in t {
            if is_pinched[v] {
                around.entry(v).or_default().push(i);
            }
        }
    }
    let mut vs: Vec<usize> = around.keys().copied().collect();
    vs.sort_unstable();
    for v in vs {
        let fs = &around[&v];
        // Union the triangles around v that share an edge at v.
        let mut comp: Vec<usize> = (0..fs.len()).collect();
        fn find(c: &mut [usize], i: usize) -> usize {
            let mut r = i;
            while c[r] != r {
                r = c[r];
            }
            c[i] = r;
            r
        }
        for i in 0..fs.len() {
            for j in i + 1..fs.len() {
                let (a, b) = (tris[fs[i]], tris[fs[j]]);
                let shared = a.iter().filter(|&&x| x != v && b.contains(&x)).count();
                if shared > 0 {
                    let (ri, rj) = (find(&mut comp, i), find(&mut comp, j));
                    comp[ri] = rj;
                }
            }
        }
        let mut sizes = std::collections::BTreeMap::new();
        for i in 0..fs.len() {
            *sizes.entry(find(&mut comp, i)).or_insert(0usize) += 1;
        }
        let best = sizes.iter().max_by_key(|(r, s)| (**s, std::cmp::Reverse(**r))).map(|(r, _)| *r).unwrap_or(0);
        for i in 0..fs.len() {
            if find(&mut comp, i) != best {
                drop[fs[i]] = true;
            }
        }
    }
    tris.iter().zip(drop).filter(|(_, d)| !d).map(|(t, _)| *t).collect()
}

// ============================ force equilibrium ============================
