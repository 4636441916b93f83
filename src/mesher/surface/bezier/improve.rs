//! Quality flips of a patch mesh in space.

use super::{ccw, edge_map};
use crate::quality::triangle_q3;
use glam::{DVec2, DVec3};

/// Flips interior edges in space when the worse of the two triangles gets better and both new
/// triangles stay counter-clockwise in (u, v); sweeps until nothing flips.
pub(super) fn flip_pass(pts: &[DVec3], uv: &[DVec2], tris: &mut [[usize; 3]]) -> usize {
    let mut total = 0;
    for _ in 0..20 {
        let mut n = 0;
        let mut edges = edge_map(tris);
        let mut keys: Vec<(usize, usize)> = edges.keys().copied().collect();
        keys.sort_unstable();
        for e in keys {
            let Some(ts) = edges.get(&e).cloned() else { continue };
            if ts.len() != 2 {
                continue;
            }
            let (a, b) = e;
            let (t0, t1) = (ts[0], ts[1]);
            let third = |t: [usize; 3]| t.iter().copied().find(|&x| x != a && x != b);
            let (Some(c), Some(d)) = (third(tris[t0]), third(tris[t1])) else { continue };
            if edges.contains_key(&(c.min(d), c.max(d))) {
                continue;
            }
            // Orient: t0 = (a, b, c) counter-clockwise or (b, a, c).
            let (a, b) = if ccw(uv[a], uv[b], uv[c]) { (a, b) } else { (b, a) };
            let old = triangle_q3([pts[a], pts[b], pts[c]]).min(triangle_q3([pts[b], pts[a], pts[d]]));
            let n0 = [c, a, d];
            let n1 = [d, b, c];
            if !ccw(uv[n0[0]], uv[n0[1]], uv[n0[2]]) || !ccw(uv[n1[0]], uv[n1[1]], uv[n1[2]]) {
                continue;
            }
            let new = triangle_q3(n0.map(|i| pts[i])).min(triangle_q3(n1.map(|i| pts[i])));
            if new <= old + 1e-9 {
                continue;
            }
            tris[t0] = n0;
            tris[t1] = n1;
            for (x, y) in [(a, b), (c, a), (a, d), (d, b), (b, c), (c, d)] {
                edges.remove(&(x.min(y), x.max(y)));
            }
            for (k, t) in [(t0, n0), (t1, n1)] {
                for i in 0..3 {
                    let (x, y) = (t[i], t[(i + 1) % 3]);
                    edges.entry((x.min(y), x.max(y))).or_default().push(k);
                }
            }
            n += 1;
        }
        total += n;
        if n == 0 {
            break;
        }
    }
    total
}
