//! The start mesh: the zero set of phi on a background grid by marching tetrahedra (seed
//! section 3.6.1 suggests triangulating the surface in each background cell and letting density
//! control coarsen or refine it), made at the coarsest level of the coarse-to-fine start that
//! still has the topology of the reference marching.
//!
//! Each grid cube is cut into the six Kuhn tetrahedra around its main diagonal; the cut is the
//! same on both sides of every shared cube face, so the piecewise-linear zero set is a closed
//! 2-manifold. Crossing points are keyed by their grid edge, so neighbouring tetrahedra weld.
//! A node value of exactly zero counts as positive, so no crossing lies on a grid node.

use super::geom::{self, project};
use super::improve::move_if_no_fold;
use crate::geometry::Implicit3;
use crate::predicates::{orient3d_dir, Sign};
use crate::topology::{TriMesh, VertexId};
use crate::Error;
use glam::DVec3;
use rayon::prelude::*;

/// The six tetrahedra of a cube (corner bits: 1 = x, 2 = y, 4 = z) around the diagonal 0-7.
const KUHN: [[usize; 4]; 6] = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];

/// Grid nodes allowed before refusing (about 1 GB of values).
pub const MAX_GRID_NODES: u64 = 64_000_000;

/// The crossing parameter along a grid edge is clamped to [T_CLAMP, 1 - T_CLAMP], which bounds
/// how thin a start triangle can be (the projection moves the points onto phi = 0 after).
const T_CLAMP: f64 = 0.02;

/// Grid values within this many spacings of zero count as zero (and so as outside).
const ON_ZERO: f64 = 1e-12;

/// Coarsest start level: the start mesh is made at up to 2^MAX_LEVELS times the target size.
pub(super) const MAX_LEVELS: u32 = 3;
/// The largest marching grid for the reference topology (about 250^3 nodes).
const REFERENCE_GRID_NODES: u64 = 16_000_000;
/// Largest turn of the normal along one edge of the coarsest start mesh, radians.
const MAX_TURN: f64 = 0.4;
/// Edges of the coarse start level across the thinnest sheet or gap, at least (and of the
/// finest: a finished surface that intersects itself where the sheets are closer is refused
/// with the thickness named).
pub(super) const COARSE_ACROSS: f64 = 2.0;

/// A triangle soup welded by grid edge: points and outward-oriented triangles.
pub struct Marched {
    /// Crossing points.
    pub points: Vec<DVec3>,
    /// Triangles, counter-clockwise seen from the side where phi > 0.
    pub triangles: Vec<[usize; 3]>,
}

/// Number of grid nodes [`march`] samples for `bbox` at spacing `h`.
pub fn grid_nodes(bbox: [DVec3; 2], h: f64) -> u64 {
    let span = bbox[1] - bbox[0] + DVec3::splat(2.0 * h);
    (0..3).map(|i| (span[i] / h).ceil() as u64 + 1).product()
}

/// Samples `phi` at spacing `h` on a grid covering `bbox` padded by one cell on every side and
/// triangulates its zero set. Errors: non-finite phi, no zero in the box, a zero set that
/// reaches the box (the surface must be closed inside it), too many grid nodes.
pub fn march(phi: &dyn Implicit3, bbox: [DVec3; 2], h: f64) -> Result<Marched, Error> {
    let lo = bbox[0] - DVec3::splat(h);
    let span = bbox[1] + DVec3::splat(h) - lo;
    let n = [(span.x / h).ceil() as usize + 1, (span.y / h).ceil() as usize + 1, (span.z / h).ceil() as usize + 1];
    let total = n.iter().map(|&k| k as u64).product::<u64>();
    if total > MAX_GRID_NODES {
        return Err(Error::TooManyElements { estimated: total, limit: MAX_GRID_NODES });
    }
    let idx = |i: usize, j: usize, k: usize| i + n[0] * (j + n[1] * k);
    let at = |i: usize, j: usize, k: usize| lo + h * DVec3::new(i as f64, j as f64, k as f64);
    // Sampled in parallel by z-slabs (each value is independent; the order of the vector is
    // fixed, so the result does not depend on the thread count).
    let slab = n[0] * n[1];
    // Exact values within REACH spacings of the surface (every corner of a cube that phi = 0
    // crosses is within its diagonal, sqrt 3 spacings, of it); farther nodes, where the
    // geometry can tell that nothing is near (`value_near`), only need their sign, which
    // [`fill_signs`] carries over from their neighbours.
    let reach = REACH * h;
    let mut near: Vec<Option<f64>> = vec![None; total as usize];
    near.par_chunks_mut(slab).enumerate().for_each(|(k, out)| {
        for j in 0..n[1] {
            for i in 0..n[0] {
                out[i + n[0] * j] = phi.value_near(at(i, j, k), reach);
            }
        }
    });
    let mut f = fill_signs(near, n, reach, || phi.value(at(0, 0, 0)));
    // A grid node on phi = 0 up to rounding counts as outside: the sign of a value that small
    // is noise (a distance to a triangulated face through a plane of grid nodes comes out as
    // +-1e-17), and noisy signs along such a plane march a crumpled sheet whose projection
    // onto the face folds (coarse cones whose base lay on a grid plane failed so at h0 0.06
    // to 0.1).
    let on_zero = ON_ZERO * h;
    for v in &mut f {
        if v.abs() <= on_zero {
            *v = 0.0;
        }
    }
    let (mut neg, mut pos) = (false, false);
    for (m, &v) in f.iter().enumerate() {
        if !v.is_finite() {
            let p = at(m % n[0], (m / n[0]) % n[1], m / slab);
            return Err(Error::NonFinite { what: "phi", value: v, at: p.to_array() });
        }
        neg |= v < 0.0;
        pos |= v >= 0.0;
    }
    if !(neg && pos) {
        let sign = if neg { "negative" } else { "positive" };
        return Err(Error::EmptyDomain(format!(
            "phi is {sign} everywhere in the bounding box: no surface phi = 0 in it"
        )));
    }
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let on_side = i == 0 || j == 0 || k == 0 || i + 1 == n[0] || j + 1 == n[1] || k + 1 == n[2];
                if on_side && f[idx(i, j, k)] < 0.0 {
                    return Err(Error::Invalid(format!(
                        "phi < 0 at {} on the edge of the box: the surface phi = 0 is not closed inside the bounding box (enlarge it)",
                        at(i, j, k)
                    )));
                }
            }
        }
    }
    let mut points: Vec<DVec3> = Vec::new();
    let mut key_of: crate::FastMap<(usize, usize), usize> = crate::FastMap::default();
    let mut triangles: Vec<[usize; 3]> = Vec::new();
    for k in 0..n[2] - 1 {
        for j in 0..n[1] - 1 {
            for i in 0..n[0] - 1 {
                let corner = |b: usize| (i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
                let gid: [usize; 8] = std::array::from_fn(|b| {
                    let (a, c, d) = corner(b);
                    idx(a, c, d)
                });
                if gid.iter().all(|&g| f[g] < 0.0) || gid.iter().all(|&g| f[g] >= 0.0) {
                    continue;
                }
                for tet in KUHN {
                    let g = tet.map(|b| gid[b]);
                    let p = tet.map(|b| {
                        let (a, c, d) = corner(b);
                        at(a, c, d)
                    });
                    let inside: Vec<usize> = (0..4).filter(|&m| f[g[m]] < 0.0).collect();
                    let outside: Vec<usize> = (0..4).filter(|&m| f[g[m]] >= 0.0).collect();
                    if inside.is_empty() || outside.is_empty() {
                        continue;
                    }
                    let mut cross = |a: usize, b: usize| -> usize {
                        let (ga, gb) = (g[a], g[b]);
                        let key = (ga.min(gb), ga.max(gb));
                        *key_of.entry(key).or_insert_with(|| {
                            let (fa, fb) = (f[ga], f[gb]);
                            let t = (fa / (fa - fb)).clamp(T_CLAMP, 1.0 - T_CLAMP);
                            points.push(p[a] + t * (p[b] - p[a]));
                            points.len() - 1
                        })
                    };
                    // The gradient of the linear interpolant on the tetrahedron: the outward direction.
                    let edges = glam::DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]).transpose();
                    let df = DVec3::new(f[g[1]] - f[g[0]], f[g[2]] - f[g[0]], f[g[3]] - f[g[0]]);
                    let grad_lin = edges.inverse() * df;
                    let mut tris: Vec<[usize; 3]> = Vec::with_capacity(2);
                    match inside.len() {
                        1 | 3 => {
                            let (lone, rest) =
                                if inside.len() == 1 { (inside[0], &outside) } else { (outside[0], &inside) };
                            tris.push([cross(lone, rest[0]), cross(lone, rest[1]), cross(lone, rest[2])]);
                        }
                        _ => {
                            // The quad in cyclic order: in0-out0, in0-out1, in1-out1, in1-out0.
                            let (a, b) = (inside[0], inside[1]);
                            let (c, d) = (outside[0], outside[1]);
                            let q = [cross(a, c), cross(a, d), cross(b, d), cross(b, c)];
                            tris.push([q[0], q[1], q[2]]);
                            tris.push([q[0], q[2], q[3]]);
                        }
                    }
                    for mut t in tris {
                        // Orient by the side of phi > 0: the normal points from inside to outside.
                        if orient3d_dir(points[t[0]], points[t[1]], points[t[2]], grad_lin) == Sign::Negative {
                            t.swap(1, 2);
                        }
                        triangles.push(t);
                    }
                }
            }
        }
    }
    Ok(Marched { points, triangles })
}

/// Spacings within which [`march`] asks for exact values.
const REACH: f64 = 2.0;

/// The grid values `near` (sides `n`) with every unknown node (`None`) given the value
/// `reach` with the sign of a known neighbour, breadth first from the known nodes in index
/// order. A node with nothing within `reach` (more than a spacing) of it has the sign of each
/// neighbour: the grid edge between them does not cross the surface. With no known node at
/// all, the sign comes from `first` (the value at node 0).
fn fill_signs(mut near: Vec<Option<f64>>, n: [usize; 3], reach: f64, first: impl FnOnce() -> f64) -> Vec<f64> {
    if near.iter().all(Option::is_some) {
        return near.into_iter().flatten().collect();
    }
    let mut queue: std::collections::VecDeque<usize> = (0..near.len()).filter(|&m| near[m].is_some()).collect();
    if queue.is_empty() {
        near[0] = Some(first());
        queue.push_back(0);
    }
    let (sx, sy) = (n[0], n[0] * n[1]);
    while let Some(m) = queue.pop_front() {
        let (i, j, k) = (m % n[0], (m / sx) % n[1], m / sy);
        let value = if near[m].is_some_and(|v| v < 0.0) { -reach } else { reach };
        let mut visit = |q: usize| {
            if near[q].is_none() {
                near[q] = Some(value);
                queue.push_back(q);
            }
        };
        if i > 0 {
            visit(m - 1);
        }
        if i + 1 < n[0] {
            visit(m + 1);
        }
        if j > 0 {
            visit(m - sx);
        }
        if j + 1 < n[1] {
            visit(m + sx);
        }
        if k > 0 {
            visit(m - sy);
        }
        if k + 1 < n[2] {
            visit(m + sy);
        }
    }
    near.into_iter().map(|v| v.unwrap_or(reach)).collect()
}

/// Number of connected components (by shared vertices) of a triangle list over `n` points.
pub fn components(n: usize, tris: &[[usize; 3]]) -> usize {
    let mut sets = crate::topology::DisjointSets::new(n);
    for t in tris {
        sets.join(t[0], t[1]);
        sets.join(t[0], t[2]);
    }
    (0..n).filter(|&i| sets.root(i) == i).count()
}

/// The start mesh for the smallest size `hmin`, its nodes projected onto phi = 0 to `tol`, its
/// level k (it was made at 2^k hmin, and the pipeline subdivides it k times), and whether it
/// holds sharp features (looked for when `sharp`; a mesh holding them is not subdivided).
/// Levels above `top` are not tried.
pub(super) fn start_mesh(
    phi: &dyn Implicit3,
    bbox: [DVec3; 2],
    hmin: f64,
    tol: f64,
    sharp: bool,
    top: u32,
) -> Result<(TriMesh<DVec3>, u32, bool), Error> {
    // The reference marching fixes the topology; the start mesh is made at the coarsest level
    // 2^k h with the same Euler characteristic and component count, then subdivided k times,
    // so that the fine mesh has only the coarse mesh's irregular vertices. The reference is the
    // finest level whose grid stays below REFERENCE_GRID_NODES: marching costs the volume of
    // the box over h^3 while the mesh costs its area over h^2, so at h itself a large mesh
    // would spend most of its time (and memory) on the grid.
    let mut reference = 0;
    while reference < MAX_LEVELS && grid_nodes(bbox, hmin * (1u32 << reference) as f64) > REFERENCE_GRID_NODES {
        reference += 1;
    }
    let fine = march(phi, bbox, hmin * (1u32 << reference) as f64)?;
    let signature = |mc: &Marched| {
        let mut edges: Vec<(usize, usize)> = mc
            .triangles
            .iter()
            .flat_map(|t| [0, 1, 2].map(|k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let chi = mc.points.len() as i64 - edges.len() as i64 + mc.triangles.len() as i64;
        (chi, components(mc.points.len(), &mc.triangles))
    };
    let want = signature(&fine);
    // Sharp edges are cut into the reference level itself (a coarser level would round them
    // before they are found); a surface without them takes the coarse-to-fine start.
    let mut m = welded(phi, &fine, tol)?;
    if sharp && super::features::imprint(&mut m, phi, hmin * (1u32 << reference) as f64, tol)? {
        return Ok((m, reference, true));
    }
    // The coarse level must still follow the surface: at most MAX_TURN radians per edge.
    let on: Vec<DVec3> = fine.points.par_iter().map(|&p| project(phi, p, tol)).collect::<Result<_, Error>>()?;
    let kmax = on.par_iter().map(|&p| geom::max_curvature(phi, p).abs()).reduce(|| 0.0, f64::max);
    // And keep COARSE_ACROSS edges across every sheet and every gap between sheets: a shell
    // 3 h thick, started at 2 h, had nodes projected onto the other sheet (a self-intersection).
    let coarsest = hmin * (1u32 << MAX_LEVELS) as f64;
    let thin = geom::thinnest(phi, &on, hmin, COARSE_ACROSS * coarsest, tol, 180.0).map_or(f64::INFINITY, |t| t.across);
    let mut levels = reference;
    let mut marched = fine;
    for k in (reference + 1..=MAX_LEVELS.min(top)).rev() {
        let hk = hmin * (1u32 << k) as f64;
        if hk * kmax > MAX_TURN || COARSE_ACROSS * hk > thin {
            continue;
        }
        let coarse = march(phi, bbox, hk);
        if let Ok(c) = coarse {
            if signature(&c) == want {
                levels = k;
                marched = c;
                break;
            }
        }
    }
    if levels == reference {
        return Ok((m, levels, false));
    }
    Ok((welded(phi, &marched, tol)?, levels, false))
}

/// The marched soup welded into the engine, its nodes projected onto phi = 0 to `tol`.
fn welded(phi: &dyn Implicit3, marched: &Marched, tol: f64) -> Result<TriMesh<DVec3>, Error> {
    let (mut m, _) = TriMesh::from_arrays(&marched.points, &marched.triangles)
        .map_err(|e| Error::internal(format!("marching tetrahedra made an invalid mesh: {e}")))?;
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    for v in ids {
        let p = project(phi, m.pos(v), tol)?;
        move_if_no_fold(&mut m, phi, v, p);
    }
    Ok(m)
}
