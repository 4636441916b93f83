//! The held core of a large uniform mesh. The start of a uniform size is a lattice of equal
//! bars: away from the boundary every force is zero from the first step, and the relaxation
//! that the boundary sets off fades within a few dozen rows (on the unit disk at 10^6
//! triangles, nodes 20 sizes deep move 0.02 sizes over the whole run, 30 deep 1e-6). The
//! force loop of such a mesh works on the band of vertices within `rings` edges of the
//! boundary (and of the fixed points) and holds the rest (the core): the arrays it rebuilds
//! after each topology change, its full sweeps and its mesh-wide passes then cost in
//! proportion to the band, not the mesh. Should the relaxation reach the band's inner rim
//! after all, the band is widened.

use super::*;

/// The band's width in edges from the boundary at first (about 35 sizes).
pub(super) const CORE_RINGS: usize = 40;
/// The band is used when the core holds at least this share of the vertices.
const CORE_SHARE: f64 = 0.25;
/// The band is widened (twice the rings) once a vertex of its inner rim has moved this many
/// sizes in all: the relaxation has reached the core.
pub(super) const RIM_DRIFT: f64 = SETTLE;

/// The held core, and what the force loop's arrays leave out of its sums.
pub(super) struct HeldCore {
    /// The held vertices.
    pub(super) held: SecondaryMap<VertexId, ()>,
    /// The band's width in edges.
    pub(super) rings: usize,
    /// The bar terms of seed eq. 2.6 (sum L^2, sum h^2) of the bars the arrays leave out.
    scale_offset: (f64, f64),
    /// Sum and count of the qualities of the triangles the arrays leave out.
    q_offset: (f64, usize),
    /// The inner rim (band vertices next to the halo) with their positions when the arrays
    /// were built, and a bound on how far any rim vertex moved before that.
    rim: Vec<(u32, DVec2)>,
    drift_before: f64,
}

impl HeldCore {
    /// The core of `m` beyond `rings` edges from the boundary and from every fixed vertex
    /// (a fixed point moved a lattice vertex or was inserted, and the lattice relaxes around
    /// it too), or None when it would hold less than CORE_SHARE of the vertices (or the mesh
    /// has no boundary).
    pub(super) fn find(m: &TriMesh<DVec2>, rings: usize) -> Option<HeldCore> {
        let mut depth: SecondaryMap<VertexId, u32> = SecondaryMap::with_capacity(m.num_vertices());
        let front: Vec<VertexId> =
            m.vertex_ids().filter(|&v| m.is_boundary_vertex(v) || m.tag(v) == VertexTag::Fixed).collect();
        if front.is_empty() {
            return None;
        }
        for &v in &front {
            depth.insert(v, 0);
        }
        within_rings(m, &mut depth, front, rings);
        let held: SecondaryMap<VertexId, ()> =
            m.vertex_ids().filter(|&v| !depth.contains_key(v)).map(|v| (v, ())).collect();
        if (held.len() as f64) < CORE_SHARE * m.num_vertices() as f64 {
            return None;
        }
        Some(HeldCore { held, rings, scale_offset: (0.0, 0.0), q_offset: (0.0, 0), rim: Vec::new(), drift_before: 0.0 })
    }

    /// Measures what the band's arrays `snap` leave out of the whole mesh `m` (uniform sizes:
    /// every bar's h is one): the scale terms and the triangle qualities, summed over the
    /// whole mesh less the arrays' own. The core does not move, so these hold for the run.
    pub(super) fn measure(&mut self, ctx: &Ctx, m: &TriMesh<DVec2>, snap: &Snapshot, p: &[DVec2]) {
        let all_bars: f64 = m.edge_ids().map(|h| 2.0 * m.pos(m.origin(h)).distance_squared(m.pos(m.dest(h)))).sum();
        let band_bars: f64 =
            snap.edges.iter().map(|&(a, b, _, _)| 2.0 * p[a as usize].distance_squared(p[b as usize])).sum();
        let bars_out = 2 * (m.num_edges() - snap.edges.len());
        self.scale_offset = (all_bars - band_bars, bars_out as f64);
        let all_q: f64 = m.face_ids().map(|f| ctx.tri_q(m.face_points(f))).sum();
        let band_q: f64 = snap.tris.iter().map(|t| ctx.tri_q(t.map(|v| p[v as usize]))).sum();
        self.q_offset = (all_q - band_q, m.num_faces() - snap.tris.len());
        self.track_rim(snap, p);
    }

    /// The scale sums of the whole mesh from the arrays' own.
    pub(super) fn scale_sums(&self, (l, h): (f64, f64)) -> (f64, f64) {
        (l + self.scale_offset.0, h + self.scale_offset.1)
    }

    /// The mean triangle quality of the whole mesh from the arrays' mean `q` over `n` triangles.
    pub(super) fn mean_quality(&self, q: f64, n: usize) -> f64 {
        (q * n as f64 + self.q_offset.0) / (n + self.q_offset.1).max(1) as f64
    }

    /// Before the arrays are rebuilt (at positions `p` of the old arrays): the rim's moves so
    /// far are kept as a bound.
    pub(super) fn fold_rim(&mut self, p: &[DVec2]) {
        self.drift_before += self.rim_drift(p);
        self.rim.clear();
    }

    /// After the arrays `snap` were built at positions `p`: the rim is tracked from here.
    pub(super) fn track_rim(&mut self, snap: &Snapshot, p: &[DVec2]) {
        self.rim = (0..snap.n_band)
            .filter(|&i| {
                snap.adj[snap.adj_start[i] as usize..snap.adj_start[i + 1] as usize]
                    .iter()
                    .any(|&j| j as usize >= snap.n_band)
            })
            .map(|i| (i as u32, p[i]))
            .collect();
    }

    /// The largest move of a rim vertex since the arrays were built.
    fn rim_drift(&self, p: &[DVec2]) -> f64 {
        self.rim.iter().map(|&(i, x)| p[i as usize].distance(x)).fold(0.0, f64::max)
    }

    /// Whether a rim vertex may have moved more than `limit` in all: the band is too narrow.
    pub(super) fn reached(&self, p: &[DVec2], limit: f64) -> bool {
        self.drift_before + self.rim_drift(p) > limit
    }
}
