use super::*;

/// The start is filled by splits up to this fraction of the survey's triangle estimate
/// ([`fill_to_estimate`]).
pub(super) const FILL_TO: f64 = 0.95;
/// [`fill_to_estimate`] splits only edges longer than this many targets: a uniform size's
/// lattice has every edge at one target, and splits there would break it.
pub(super) const FILL_ABOVE: f64 = 1.1;
/// Passes of [`fill_to_estimate`] at most.
pub(super) const FILL_PASSES: usize = 4;
/// Plain starts (uniform sizes, nothing fixed, no metric, no internal boundaries) estimated
/// above this many triangles are refined on flat arrays.
pub(super) const ARRAY_START_ABOVE: f64 = 80_000.0;
/// Seed 3.3.3: one large triangle around the box, refined by rounds of edge splits with
/// Delaunay flips, skipping edges whose triangles are certainly outside; then carved.
pub(super) fn initial_mesh(ctx: &mut Ctx, estimate: f64) -> Result<TriMesh<DVec2>, Error> {
    let opts = ctx.opts;
    let [lo, hi] = opts.bbox;
    let c = (lo + hi) * 0.5;
    let r_in = 0.5 * (hi - lo).length() * 1.05;
    // Side h0 2^k, the smallest that holds the box: uniform refinement then lands exactly on
    // the equilateral lattice of side h0 (edge midpoints of one level are the next level's
    // lattice points), the best start the forces can have.
    let side_min = 2.0 * 3f64.sqrt() * r_in;
    let side = opts.h0 * 2f64.powi((side_min / opts.h0).log2().ceil().max(0.0) as i32);
    let r_out = side / 3f64.sqrt();
    let s: Vec<DVec2> = (0..3)
        .map(|k| {
            let a = std::f64::consts::FRAC_PI_2 + k as f64 * std::f64::consts::TAU / 3.0;
            c + r_out * DVec2::new(a.cos(), a.sin())
        })
        .collect();
    for p in &opts.fixed {
        if ctx.approx_dist(*p)? > ctx.geps {
            return Err(Error::Invalid(format!("fixed point ({}, {}) lies outside the domain", p.x, p.y)));
        }
    }
    let cap = (8.0 * estimate + 10_000.0) as usize;
    let plain =
        opts.size.is_none() && ctx.metric.is_none() && ctx.internal.is_none() && opts.fixed.len() <= ARRAY_FIXED;
    if plain && estimate > ARRAY_START_ABOVE {
        let (mut points, tris) = refine_uniform(ctx, &s, cap)?;
        if let Some(fixed) = hold_fixed_on_arrays(ctx, &mut points, &tris)? {
            let n = points.len();
            let labels = vec![0; tris.len()];
            return carve_arrays(ctx, Cells { points, tris, labels, fixed, on_boundary: vec![false; n] }, 0.0);
        }
    }
    let (mut m, _) = TriMesh::from_arrays(&s, &[[0, 1, 2]]).map_err(|e| Error::internal(e.to_string()))?;
    // Rounds of red refinement: every edge longer than its target (and not certainly
    // outside) is split at its midpoint, then Lawson flips restore Delaunay. On a uniform
    // region the midpoints of one lattice level are exactly the next level's lattice.
    loop {
        let mut todo: Vec<(VertexId, VertexId)> = Vec::new();
        for h in m.edge_ids() {
            let (a, b) = (m.origin(h), m.dest(h));
            let (pa, pb) = (m.pos(a), m.pos(b));
            if ctx.ratio(pa, pb)? > ctx.init_split() && !edge_certainly_outside(ctx, &m, h)? {
                todo.push((a, b));
            }
        }
        if todo.is_empty() {
            break;
        }
        let mut new = Vec::with_capacity(todo.len());
        for (a, b) in todo {
            if let Some(h) = m.find_half_edge(a, b) {
                let mid = (m.pos(a) + m.pos(b)) * 0.5;
                if let Ok(v) = m.split_edge(h, mid) {
                    m.set_tag(v, VertexTag::Interior);
                    new.push(v);
                }
            }
        }
        // Splits the engine refuses (a midpoint that would flatten or turn over a needle)
        // would be asked for again at every round, for ever.
        if new.is_empty() {
            break;
        }
        // Only edges of triangles a split changed can have stopped being Delaunay.
        let stack = star_edges(&m, &new);
        ctx.legalize(&mut m, stack);
        if m.num_vertices() > cap {
            return Err(match ctx.metric {
                Some(_) => too_stretched(ctx, &m, cap, estimate)?,
                None => Error::internal(format!(
                    "initial refinement passed {cap} vertices (estimate {estimate:.0} triangles)"
                )),
            });
        }
    }
    // Fixed points go in after the refinement, exactly where given: inserted first, they would
    // bend the lattice into a grid of right triangles, a symmetric equilibrium of the truss
    // that the forces never leave (the unit square with its corners fixed did exactly that).
    // The nearest lattice vertex within half a lattice edge moves onto the point (no short
    // edges); otherwise the point is inserted.
    let mut hint = m.face_ids().next().expect("the refined mesh has faces");
    for p in &opts.fixed {
        use crate::topology::Location;
        let near = match m.locate(*p, hint) {
            Location::Vertex(v) => Some(v),
            Location::Face(f) => {
                m.face_vertices(f).into_iter().min_by(|&a, &b| m.pos(a).distance(*p).total_cmp(&m.pos(b).distance(*p)))
            }
            Location::Edge(h) => {
                let (a, b) = (m.origin(h), m.dest(h));
                Some(if m.pos(a).distance(*p) <= m.pos(b).distance(*p) { a } else { b })
            }
            Location::Outside(_) => None,
        };
        if let Some(v) = near {
            let free = m.tag(v) != VertexTag::Fixed;
            let old = m.pos(v);
            if free && old.distance(*p) < 0.5 * opts.h0 * ctx.h(*p)? && m.relocate(v, *p).is_ok() {
                // Only if the star stays fair; a sliver here would stall the alignment with
                // internal boundaries and the carving.
                let worst = m.vertex_faces(v).iter().map(|&f| m.face_quality(f)).fold(1.0, f64::min);
                if worst >= 0.3 {
                    m.set_tag(v, VertexTag::Fixed);
                    hint = m.face_of_vertex(v);
                    continue;
                }
                m.set_pos_unchecked(v, old);
            }
        }
        let (v, f) =
            m.insert_delaunay(*p, hint).ok_or_else(|| Error::internal("fixed point outside the enclosing triangle"))?;
        m.set_tag(v, VertexTag::Fixed);
        hint = f;
    }
    if let Some(di) = &ctx.internal {
        internal::align(&mut m, di, ctx.geps)?;
    }
    let t = Instant::now();
    let mut out = carve(ctx, m, 0.0)?;
    let free = super::carve::corners_left_free(ctx, &out);
    if !free.is_empty() {
        ctx.report.feature_points -= free.len();
        let at: Vec<String> = free.iter().map(|p| format!("({:.4}, {:.4})", p.x, p.y)).collect();
        ctx.report.notes.push(format!(
            "{} sharp corner(s) found at {} could not be held (no start node reaches them inside the domain: the start is too stretched there, or they belong to a part narrower than h0) and may be rounded off or left out; give them as fixed points to hold them, or lower h0",
            free.len(),
            at.join(", ")
        ));
    }
    let carved = out.num_faces();
    let splits =
        if ctx.metric.is_none() && ctx.internal.is_none() { fill_to_estimate(ctx, &mut out, estimate)? } else { 0 };
    if std::env::var_os("TRUSSMESH_TRACE").is_some() {
        eprintln!(
            "carve {:.3} s: {carved} triangles, {splits} splits toward the estimate {estimate:.0}",
            t.elapsed().as_secs_f64()
        );
    }
    Ok(out)
}

/// At most this many fixed points are held on the array start ([`hold_fixed_on_arrays`]
/// scans the lattice once per point); more take the general refinement.
const ARRAY_FIXED: usize = 16;

/// A fixed point on the array start moves the nearest lattice vertex onto it from up to this
/// many lattice edges: every point of the plane is within 1/sqrt(3) of a vertex.
const ARRAY_FIXED_REACH: f64 = 0.6;

/// The fixed points on the array start, by the rule of the general refinement in
/// [`initial_mesh`] (which inserts a point farther than half a lattice edge from every vertex,
/// where this moves the nearest vertex from up to ARRAY_FIXED_REACH): the nearest lattice
/// vertex moves onto the point if its triangles stay positive and of quality at least 0.3.
/// Returns which points of `points` are fixed, or None when some point cannot be held so
/// (the general refinement then takes it).
fn hold_fixed_on_arrays(ctx: &Ctx, points: &mut [DVec2], tris: &[[usize; 3]]) -> Result<Option<Vec<bool>>, Error> {
    let mut fixed = vec![false; points.len()];
    for p in &ctx.opts.fixed {
        let near =
            tris.iter().flatten().copied().min_by(|&a, &b| {
                points[a].distance_squared(*p).total_cmp(&points[b].distance_squared(*p)).then(a.cmp(&b))
            });
        let Some(v) = near else { return Ok(None) };
        if fixed[v] || points[v].distance(*p) >= ARRAY_FIXED_REACH * ctx.opts.h0 * ctx.h(*p)? {
            return Ok(None);
        }
        let old = points[v];
        points[v] = *p;
        let fair = tris.iter().filter(|t| t.contains(&v)).all(|t| {
            let q = [points[t[0]], points[t[1]], points[t[2]]];
            orient2d(q[0], q[1], q[2]) == Sign::Positive && crate::quality::triangle_q(q) >= 0.3
        });
        if !fair {
            points[v] = old;
            return Ok(None);
        }
        fixed[v] = true;
    }
    Ok(Some(fixed))
}

/// Splits the longest interior edges of the carved start (in target lengths, each longer than
/// FILL_ABOVE targets, no two splits on one vertex in a pass) until it has FILL_TO of the triangles the
/// survey estimates. The lattice's levels are a factor 2 apart, so where h varies the start can
/// be coarser than h asks for (example 3b at h0 = 0.051: 368 triangles at the end where the
/// estimate is 475), and the truss keeps the count it starts with (its density control acts only
/// beyond 2 targets). Returns the number of splits.
pub(super) fn fill_to_estimate(ctx: &mut Ctx, m: &mut TriMesh<DVec2>, estimate: f64) -> Result<usize, Error> {
    let want = (FILL_TO * estimate) as usize;
    let mut splits = 0;
    for _ in 0..FILL_PASSES {
        if m.num_faces() >= want {
            break;
        }
        let mut cands: Vec<(f64, VertexId, VertexId)> = Vec::new();
        for h in m.edge_ids() {
            if m.is_boundary_edge(h) || m.is_constrained_edge(h) {
                continue;
            }
            let (a, b) = (m.origin(h), m.dest(h));
            let r = ctx.ratio(m.pos(a), m.pos(b))?;
            if r > FILL_ABOVE {
                cands.push((r, a, b));
            }
        }
        // Stable: equal ratios keep the mesh's edge order (deterministic).
        cands.sort_by(|x, y| y.0.total_cmp(&x.0));
        let mut used: SecondaryMap<VertexId, ()> = SecondaryMap::new();
        let mut new = Vec::new();
        for (_, a, b) in cands {
            if m.num_faces() >= want {
                break;
            }
            if used.contains_key(a) || used.contains_key(b) {
                continue;
            }
            let Some(h) = m.find_half_edge(a, b) else { continue };
            if let Ok(v) = m.split_edge(h, (m.pos(a) + m.pos(b)) * 0.5) {
                m.set_tag(v, VertexTag::Interior);
                used.insert(a, ());
                used.insert(b, ());
                new.push(v);
                splits += 1;
            }
        }
        if new.is_empty() {
            break;
        }
        let stack = star_edges(m, &new);
        ctx.legalize(m, stack);
    }
    Ok(splits)
}

/// The error for a metric whose start refinement ran past `cap` vertices: the rounds halve
/// every edge longer than its metric length, across the stretch as along it, so the start
/// grows with the stretch (about 550:1 over a square asked for ten times the nodes its
/// metric does). Names the largest stretch met among the start's vertices and where.
fn too_stretched(ctx: &Ctx, m: &TriMesh<DVec2>, cap: usize, estimate: f64) -> Result<Error, Error> {
    let mut worst = (1.0f64, DVec2::ZERO);
    for v in m.vertex_ids() {
        let p = m.pos(v);
        if ctx.approx_dist(p)? > 0.0 {
            continue;
        }
        let mp = ctx.metric_at(p)?;
        let stretch = mp.largest_size() / mp.smallest_size();
        if stretch > worst.0 {
            worst = (stretch, p);
        }
    }
    let (r, p) = worst;
    Ok(Error::BadSize(format!(
        "the metric is stretched {r:.0}:1 at ({:.4}, {:.4}), more than the start can follow: it refines evenly in \
         every direction and passed {cap} vertices where the metric asks for about {estimate:.0} triangles; lower the \
         stretch",
        p.x, p.y
    )))
}

/// Uniform sizes, no fixed points, a large start: the rounds of red refinement of
/// [`initial_mesh`] on flat arrays. Every edge of a round has the same length, so a round
/// splits every triangle that is not certainly outside into four equilateral ones (no flips
/// needed); certainly outside triangles are dropped at once, where the general loop keeps
/// them (halved where a neighbour split their edge) until carving drops them. The carved
/// lattice is the same, without the arena's bookkeeping per split.
pub(super) fn refine_uniform(ctx: &Ctx, corners: &[DVec2], cap: usize) -> Result<(Vec<DVec2>, Vec<[usize; 3]>), Error> {
    let safety = if ctx.domain.is_distance() { 1.0 } else { 2.0 };
    let mut pts = corners.to_vec();
    let mut tris = vec![[0usize, 1, 2]];
    while let Some(t0) = tris.first() {
        if ctx.ratio(pts[t0[0]], pts[t0[1]])? <= INIT_SPLIT {
            break;
        }
        let outside: Vec<bool> = tris
            .par_iter()
            .with_min_len(CHUNK)
            .map(|t| {
                let [a, b, c] = t.map(|i| pts[i]);
                let lmax = a.distance(b).max(b.distance(c)).max(c.distance(a));
                Ok(ctx.distance_bound([a, b, c])? > safety * lmax)
            })
            .collect::<Result<Vec<bool>, Error>>()?;
        let kept = outside.iter().filter(|&&o| !o).count();
        let mut mids: crate::FastMap<(usize, usize), usize> =
            crate::FastMap::with_capacity_and_hasher(2 * kept, Default::default());
        let mut next = Vec::with_capacity(4 * kept);
        for (t, _) in tris.iter().zip(&outside).filter(|(_, &o)| !o) {
            let mut mid = |a: usize, b: usize| {
                *mids.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    pts.push((pts[a] + pts[b]) * 0.5);
                    pts.len() - 1
                })
            };
            let [a, b, c] = *t;
            let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        tris = next;
        if pts.len() > cap {
            return Err(Error::internal(format!("initial refinement passed {cap} vertices")));
        }
    }
    Ok((pts, tris))
}

/// A face is certainly outside when its approximate distance at the centroid exceeds its
/// longest edge (twice that for non-distance functions).
pub(super) fn face_certainly_outside(ctx: &Ctx, m: &TriMesh<DVec2>, f: crate::topology::FaceId) -> Result<bool, Error> {
    let [a, b, c] = m.face_points(f);
    let lmax = a.distance(b).max(b.distance(c)).max(c.distance(a));
    let d = ctx.distance_bound([a, b, c])?;
    let safety = if ctx.domain.is_distance() { 1.0 } else { 2.0 };
    Ok(d > safety * lmax)
}

pub(super) fn edge_certainly_outside(ctx: &Ctx, m: &TriMesh<DVec2>, h: HalfEdgeId) -> Result<bool, Error> {
    for side in [h, m.twin(h)] {
        if let Some(f) = m.face_of(side) {
            if !face_certainly_outside(ctx, m, f)? {
                return Ok(false);
            }
        }
    }
    Ok(true)
}
