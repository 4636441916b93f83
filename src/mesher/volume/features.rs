//! Sharp features: the points on the domain's sharp edges and corners that the start holds fixed,
//! and the test for a boundary node on such a feature.

use super::Ctx;
use crate::mesher::sharp;
use crate::topology::{TVertexId, TetMesh};
use crate::Error;
use glam::DVec3;
use smallvec::SmallVec;
use std::collections::HashMap;

/// Boundary faces turning more than this (degrees) from the surface normal mark a sharp edge.
const RR_SHARP: f64 = 30.0;

/// Points on the domain's sharp edges, at about one target length apart, which the start
/// holds fixed: the seed keeps sharp features with fixed points, and a polyhedron meshed
/// without them folds its boundary where nodes near an edge are projected onto one face or the
/// other (the cube at h0 = 0.17 kept 0-degree tets). Two surface start points (`grid`, cells
/// of side `gap`) closer than sharp::REACH gaps whose normals differ by more than sharp::SHARP_DEG
/// degrees straddle an edge: the point of the line where their tangent planes meet nearest to
/// their midpoint, projected onto d = 0, is on it (exactly for planar faces). A surface point
/// whose normals differ on either side of it lies on an edge itself. The corners where three
/// faces meet (`sharp::corner_points`) and then these points are thinned greedily, in the start's
/// lattice order, to sharp::SPACING target lengths apart and kept clear of the user's fixed
/// points.
pub(super) fn crease_points(
    ctx: &Ctx,
    grid: &HashMap<[i64; 3], SmallVec<[DVec3; 4]>>,
    every: &HashMap<[i64; 3], SmallVec<[DVec3; 4]>>,
    gap: f64,
) -> Result<Vec<DVec3>, Error> {
    let opts = ctx.opts;
    let uniform = opts.size.is_none();
    let cos_max = sharp::SHARP_DEG.to_radians().cos();
    let mut cells: Vec<&[i64; 3]> = grid.keys().collect();
    cells.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
    // Each surface point with its unit normal, computed once.
    let mut normals: HashMap<[i64; 3], SmallVec<[(DVec3, DVec3); 4]>> = HashMap::with_capacity(cells.len());
    for &c in &cells {
        let list = grid[c].iter().map(|&q| (q, ctx.domain.gradient(q).normalize_or_zero())).collect();
        normals.insert(*c, list);
    }
    // Points on edges with the normals of their two faces.
    let mut found: Vec<(DVec3, DVec3, DVec3)> = Vec::new();
    for c in cells {
        for &(q1, n1) in &normals[c] {
            if n1.length_squared() < 0.5 {
                continue;
            }
            let h1 = if uniform { 1.0 } else { ctx.h(q1)? };
            found.extend(on_edge(ctx, q1, n1, sharp::PROBE * gap * h1));
            let reach = sharp::REACH * gap * h1;
            let span = (reach / gap).ceil() as i64;
            for dz in -span..=span {
                for dy in -span..=span {
                    for dx in -span..=span {
                        let Some(list) = normals.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else { continue };
                        for &(q2, n2) in list {
                            // Each pair once, in a fixed order.
                            if q2.to_array() <= q1.to_array() || q2.distance(q1) > reach || n2.length_squared() < 0.5 {
                                continue;
                            }
                            let cos = n1.dot(n2);
                            if cos > cos_max || cos < -cos_max {
                                continue;
                            }
                            let m = (q1 + q2) * 0.5;
                            let x = sharp::planes_meet(q1, n1, q2, n2, m);
                            if x.distance(m) > reach {
                                continue;
                            }
                            let Some(p) = ctx.project(x)? else { continue };
                            if p.distance(x) <= sharp::TOL * gap * h1 {
                                found.push((p, n1, n2));
                            }
                        }
                    }
                }
            }
        }
    }
    let limits = |p: DVec3| -> Result<(f64, f64), Error> {
        let h = if uniform { 1.0 } else { ctx.h(p)? };
        Ok((sharp::REACH * gap * h, sharp::TOL * gap * h))
    };
    let corners = sharp::corner_points(ctx, &found, gap, &limits)?;
    // Every other projected start point on an edge itself: the thinned points can miss a whole
    // edge (see `initial_mesh`), while the lattice points beyond a convex edge all project onto
    // it. After the others, so that the thinning below prefers those, and not in the search
    // for corners (which, given these too, found corners along curved edges).
    let mut cells: Vec<&[i64; 3]> = every.keys().collect();
    cells.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
    for c in cells {
        for &q in &every[c] {
            let n = ctx.domain.gradient(q).normalize_or_zero();
            if n.length_squared() >= 0.5 {
                let h = if uniform { 1.0 } else { ctx.h(q)? };
                found.extend(on_edge(ctx, q, n, sharp::PROBE * gap * h));
            }
        }
    }
    let n_corners = corners.len();
    let mut kept: Vec<DVec3> = Vec::new();
    let candidates =
        corners.into_iter().map(|(p, _)| (p, None)).chain(found.into_iter().map(|f| (f.0, Some((f.1, f.2)))));
    for (k, (p, faces)) in candidates.enumerate() {
        let h = if uniform { 1.0 } else { ctx.h(p)? };
        let s = sharp::SPACING * opts.h0 * h;
        if kept.iter().any(|k| k.distance(p) < s) || opts.fixed.iter().any(|f| f.distance(p) < s) {
            continue;
        }
        if p.cmplt(opts.bbox[0]).any() || p.cmpgt(opts.bbox[1]).any() {
            continue;
        }
        let p = match faces {
            Some((n1, n2)) if k >= n_corners => sharp::refine_edge_point(ctx, p, n1, n2, gap * h)?,
            _ => p,
        };
        kept.push(p);
    }
    Ok(kept)
}

/// The surface point `q` (unit normal `n`) with the normals of two faces when it lies on an
/// edge itself (the projection of a lattice point beyond a convex edge ends there): normals
/// probed `eps` away on every side, a little inside (a distance built from unsigned distances
/// has a kink on d = 0, where its gradient can be anything), differ by more than
/// sharp::SHARP_DEG degrees.
fn on_edge(ctx: &Ctx, q: DVec3, n: DVec3, eps: f64) -> Option<(DVec3, DVec3, DVec3)> {
    let probes = [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z]
        .map(|e| ctx.domain.gradient(q + (e - n) * eps).normalize_or_zero());
    // A probe without a normal says nothing.
    let probes: SmallVec<[DVec3; 6]> = probes.into_iter().filter(|n| n.length_squared() > 0.5).collect();
    let (cos, a, b) = sharp::widest_split(&probes, DVec3::dot)?;
    (cos < sharp::SHARP_DEG.to_radians().cos()).then_some((q, a, b))
}

/// Whether a boundary face around `v` turns more than RR_SHARP degrees from the surface
/// normal at `v`: a node on a sharp edge or corner of the domain, whose tangential moves would
/// round it off.
pub(super) fn on_sharp_feature(ctx: &Ctx, m: &TetMesh, v: TVertexId) -> bool {
    let nrm = ctx.domain.gradient(m.pos(v)).normalize_or_zero();
    let cos = RR_SHARP.to_radians().cos();
    for t in m.vertex_tets(v) {
        let tx = m.tet(t);
        for f in 0..4 {
            if tx.adj[f].is_some() || tx.v[f] == v {
                continue;
            }
            let [a, b, c] = m.face_vertices(t, f).map(|w| m.pos(w));
            let n = (b - a).cross(c - a).normalize_or_zero();
            if n.dot(nrm).abs() < cos {
                return true;
            }
        }
    }
    false
}

impl sharp::Zero for Ctx<'_> {
    fn project(&self, p: DVec3) -> Result<Option<DVec3>, Error> {
        Ctx::project(self, p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.domain.gradient(p)
    }
}
