//! The truss step of a patch mesh: bar forces in space, projection back onto the patch.

use super::{ccw, edges_sorted, BezierOptions, Kind, RationalBezierPatch};
use crate::mesher::truss::{bar_force, RestScale};
use glam::{DVec2, DVec3};

/// One truss step: repulsive bar forces toward Fscale h (seed eq. 2.6, scaled so the bars fill
/// the surface), forward Euler in space, projection of each node back onto the patch (interior
/// eq. 3.29, trim curve eq. 3.31-3.32); a move that would turn a triangle in (u, v) is undone.
/// Returns the largest move relative to h and whether a node joined the trim boundary (then
/// the triangles must be rebuilt).
#[allow(clippy::too_many_arguments)]
pub(super) fn force_step(
    p: &RationalBezierPatch,
    pts: &mut [DVec3],
    uv: &mut [DVec2],
    kind: &mut [Kind],
    tris: &[[usize; 3]],
    h: f64,
    opts: &BezierOptions,
    pos_of: &dyn Fn(DVec2) -> DVec3,
) -> (f64, bool) {
    let edges = edges_sorted(tris);
    // One size everywhere on a patch: every bar's relative size is 1.
    let mut rest = RestScale::new(2);
    for ((a, b), _) in &edges {
        rest.add(pts[*a].distance_squared(pts[*b]), 1.0);
    }
    let l0 = rest.scale(opts.fscale);
    let _ = h;
    let mut force = vec![DVec3::ZERO; pts.len()];
    for ((a, b), _) in &edges {
        let d = pts[*a] - pts[*b];
        let f = bar_force(d, d.length(), l0);
        force[*a] += f;
        force[*b] -= f;
    }
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); pts.len()];
    for (k, t) in tris.iter().enumerate() {
        for &i in t {
            around[i].push(k);
        }
    }
    let mut moved = 0.0f64;
    let mut became_boundary = false;
    for i in 0..pts.len() {
        if kind[i] == Kind::Fixed {
            continue;
        }
        let mut joined = false;
        let target = pts[i] + opts.deltat * force[i];
        let new_uv = if opts.in_space {
            let q = p.project(target, uv[i], None);
            // As in DistMesh, a node pushed out of the trimmed domain becomes a boundary node.
            if kind[i] == Kind::Interior && p.trim_value(q) > 0.0 {
                kind[i] = Kind::Trim;
                became_boundary = true;
                joined = true;
            }
            if kind[i] == Kind::Trim {
                // Two steps (eq. 3.31, 3.32): the free projection, then back onto the curve,
                // repeated so the pair settles at the constrained minimum.
                let mut q = p.to_trim_curve(q, None);
                for _ in 0..3 {
                    q = p.to_trim_curve(p.project(target, q, None), None);
                }
                q
            } else {
                q
            }
        } else {
            let q = DVec2::new(target.x, target.y).clamp(DVec2::ZERO, DVec2::ONE);
            if kind[i] == Kind::Interior && p.trim_value(q) > 0.0 {
                kind[i] = Kind::Trim;
                became_boundary = true;
                joined = true;
            }
            if kind[i] == Kind::Trim {
                p.to_trim_curve(q, None)
            } else {
                q
            }
        };
        let old = uv[i];
        uv[i] = new_uv;
        // A node that joined the boundary moves regardless: the caller retriangulates.
        let ok = joined
            || around[i].iter().all(|&k| {
                let t = tris[k];
                ccw(uv[t[0]], uv[t[1]], uv[t[2]])
            });
        if ok {
            let np = pos_of(new_uv);
            moved = moved.max(np.distance(pts[i]) / l0.max(1e-300));
            pts[i] = np;
        } else {
            uv[i] = old;
        }
    }
    (moved, became_boundary)
}
