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
/// faces meet ([`corner_points`]) and then these points are thinned greedily, in the start's
/// lattice order, to sharp::SPACING target lengths apart and kept clear of the user's fixed
/// points.
pub(super) fn crease_points(
    ctx: &Ctx,
    grid: &HashMap<[i64; 3], SmallVec<[DVec3; 4]>>,
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
            // A surface point on the edge itself (the projection of a lattice point as far from
            // both faces ends there): the normals a hair's breadth away on either side differ.
            let eps = sharp::PROBE * gap * h1;
            // Probes a little inside (a distance built from unsigned distances has a kink on
            // d = 0, where its gradient can be anything), on every side of the point.
            let probes = [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z]
                .map(|e| ctx.domain.gradient(q1 + (e - n1) * eps).normalize_or_zero());
            // A probe without a normal says nothing.
            let probes: SmallVec<[DVec3; 6]> = probes.into_iter().filter(|n| n.length_squared() > 0.5).collect();
            let split = crate::mesher::sharp::widest_split(&probes, DVec3::dot);
            if let Some((cos, a, b)) = split {
                if cos < cos_max {
                    found.push((q1, a, b));
                }
            }
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
                            // x = m + alpha n1 + beta n2 on both tangent planes.
                            let m = (q1 + q2) * 0.5;
                            let (r1, r2) = (n1.dot(q1 - m), n2.dot(q2 - m));
                            let det = 1.0 - cos * cos;
                            let x = m + n1 * ((r1 - cos * r2) / det) + n2 * ((r2 - cos * r1) / det);
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
    let corners = corner_points(ctx, &found, gap, cos_max)?;
    let n_corners = corners.len();
    let mut kept: Vec<DVec3> = Vec::new();
    let candidates = corners.into_iter().map(|p| (p, None)).chain(found.into_iter().map(|f| (f.0, Some((f.1, f.2)))));
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
            Some((n1, n2)) if k >= n_corners => refine_edge_point(ctx, p, n1, n2, gap * h)?,
            _ => p,
        };
        kept.push(p);
    }
    Ok(kept)
}

/// Moves the edge point `p` (faces of normals `n1`, `n2`) to the point nearest it on the line
/// where the faces' tangent planes meet, the planes taken at points of each face ever closer to
/// it (from a tenth of `s` down by ten each, sharp::REFINE_STEPS steps): exact already for planar
/// faces; on a curved edge (a cylinder's rim) the error falls with the square of the distance.
fn refine_edge_point(ctx: &Ctx, p: DVec3, n1: DVec3, n2: DVec3, s: f64) -> Result<DVec3, Error> {
    let (mut x, mut a, mut b) = (p, n1, n2);
    let mut delta = 0.1 * s;
    for _ in 0..sharp::REFINE_STEPS {
        // A point of each face, delta from the edge across it: of the two ways, the one whose
        // normal (taken a little inside) stays with the face.
        let face = |n: DVec3, other: DVec3| -> Result<Option<(DVec3, DVec3)>, Error> {
            let Some(across) = (other - n * n.dot(other)).try_normalize() else { return Ok(None) };
            let mut best: Option<(f64, DVec3, DVec3)> = None;
            for dir in [across, -across] {
                if let Some(q) = ctx.project(x + dir * delta)? {
                    let m = ctx.domain.gradient(q - n * (1e-3 * delta)).normalize_or_zero();
                    if m.length_squared() > 0.5 && best.is_none_or(|(c, _, _)| m.dot(n) > c) {
                        best = Some((m.dot(n), q, m));
                    }
                }
            }
            Ok(best.map(|(_, q, m)| (q, m)))
        };
        let (Some((q1, m1)), Some((q2, m2))) = (face(a, b)?, face(b, a)?) else { break };
        let cos = m1.dot(m2);
        let det = 1.0 - cos * cos;
        if det < 1e-6 {
            break;
        }
        // The point of both planes nearest x: x + alpha m1 + beta m2.
        let (r1, r2) = (m1.dot(q1 - x), m2.dot(q2 - x));
        let y = x + m1 * ((r1 - cos * r2) / det) + m2 * ((r2 - cos * r1) / det);
        let Some(y) = ctx.project(y)? else { break };
        if y.distance(x) > 2.0 * delta {
            break;
        }
        (x, a, b) = (y, m1, m2);
        delta *= 0.1;
    }
    Ok(x)
}

/// Corners where three faces meet, from the points on edges (`found`, each with the normals of
/// its two faces): two such points within reach whose faces bring a third normal (more than
/// sharp::SHARP_DEG from both of the first point's) meet at the point of all three tangent planes,
/// kept when its projection onto d = 0 hardly moves it. They go first into the thinning.
fn corner_points(ctx: &Ctx, found: &[(DVec3, DVec3, DVec3)], gap: f64, cos_max: f64) -> Result<Vec<DVec3>, Error> {
    let uniform = ctx.opts.size.is_none();
    let cell = |p: DVec3| (p / gap).floor().as_i64vec3().to_array();
    let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (k, f) in found.iter().enumerate() {
        cells.entry(cell(f.0)).or_default().push(k);
    }
    let distinct = |n: DVec3, m: DVec3| {
        let c = n.dot(m);
        c < cos_max && c > -cos_max
    };
    let mut corners = Vec::new();
    for (k, &(pa, a1, a2)) in found.iter().enumerate() {
        let h = if uniform { 1.0 } else { ctx.h(pa)? };
        let reach = sharp::REACH * gap * h;
        let span = (reach / gap).ceil() as i64;
        let c = cell(pa);
        for dz in -span..=span {
            for dy in -span..=span {
                for dx in -span..=span {
                    let Some(list) = cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else { continue };
                    for &j in list {
                        let (pb, b1, b2) = found[j];
                        if j <= k || pb.distance(pa) > reach {
                            continue;
                        }
                        for nb in [b1, b2] {
                            if !distinct(nb, a1) || !distinct(nb, a2) {
                                continue;
                            }
                            let m = glam::DMat3::from_cols(a1, a2, nb).transpose();
                            if m.determinant().abs() < 0.1 {
                                continue;
                            }
                            let x = m.inverse() * DVec3::new(a1.dot(pa), a2.dot(pa), nb.dot(pb));
                            if !x.is_finite() || x.distance(pa) > reach {
                                continue;
                            }
                            let Some(p) = ctx.project(x)? else { continue };
                            if p.distance(x) <= sharp::TOL * gap * h {
                                corners.push(p);
                            }
                        }
                    }
                }
            }
        }
    }
    Ok(corners)
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
