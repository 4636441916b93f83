//! Density control of a patch mesh (seed section 2.4): short edges lose a free node, long
//! ones get their midpoint, slivers against the boundary lose the node pressed into them.

use super::{edges_sorted, BezierOptions, Kind, RationalBezierPatch};
use crate::mesher::truss::DensityBand;
use crate::quality::triangle_q3;
use glam::{DVec2, DVec3};

/// Edges longer than 1.6 h get a node, shorter than h / 2 lose one (the surface mesher's band).
const BAND: DensityBand = DensityBand::new(1.6, 0.5);

/// Density control (seed section 2.4): a free node on an edge below `BAND` is removed,
/// an interior edge above it gets its midpoint (projected onto the patch). Removing nodes
/// that the pressure pushed against a fixed side is what keeps slivers off the sides. Returns
/// whether anything changed (the caller then retriangulates).
#[allow(clippy::too_many_arguments)]
pub(super) fn density(
    p: &RationalBezierPatch,
    pts: &mut Vec<DVec3>,
    uv: &mut Vec<DVec2>,
    kind: &mut Vec<Kind>,
    tris: &[[usize; 3]],
    h: f64,
    opts: &BezierOptions,
    pos_of: &dyn Fn(DVec2) -> DVec3,
) -> bool {
    let mut gone = vec![false; pts.len()];
    let mut add: Vec<DVec2> = Vec::new();
    let mut add_trim: Vec<DVec2> = Vec::new();
    for ((a, b), ts) in edges_sorted(tris) {
        let l = pts[a].distance(pts[b]);
        if l < BAND.collapse_below * h {
            if gone[a] || gone[b] {
                continue;
            }
            let victim = [b, a].into_iter().find(|&i| kind[i] != Kind::Fixed);
            if let Some(i) = victim {
                gone[i] = true;
            }
        } else if l > BAND.split_above * h && ts.len() == 2 && kind[a] != Kind::Fixed && kind[b] != Kind::Fixed {
            let mid = 0.5 * (uv[a] + uv[b]);
            add.push(if opts.in_space { p.project(0.5 * (pts[a] + pts[b]), mid, None) } else { mid });
        } else if l > BAND.split_above * h && ts.len() == 1 && (kind[a] == Kind::Trim || kind[b] == Kind::Trim) {
            // A long piece of the trim curve: a new node on the curve.
            let mid = 0.5 * (uv[a] + uv[b]);
            let q = if opts.in_space { p.project(0.5 * (pts[a] + pts[b]), mid, None) } else { mid };
            add_trim.push(p.to_trim_curve(q, None));
        }
    }
    // A sliver left by a node pressed against the boundary loses that node (the one opposite
    // its longest edge) when it is free.
    for t in tris {
        let q = t.map(|i| pts[i]);
        if triangle_q3(q) >= 0.2 || t.iter().any(|&i| gone[i]) {
            continue;
        }
        let opp = (0..3).max_by(|&a, &b| {
            let la = q[(a + 1) % 3].distance(q[(a + 2) % 3]);
            let lb = q[(b + 1) % 3].distance(q[(b + 2) % 3]);
            la.total_cmp(&lb)
        });
        if let Some(k) = opp {
            if kind[t[k]] != Kind::Fixed {
                gone[t[k]] = true;
            }
        }
    }
    if add.is_empty() && add_trim.is_empty() && !gone.iter().any(|&g| g) {
        return false;
    }
    let mut k = 0;
    uv.retain(|_| {
        k += 1;
        !gone[k - 1]
    });
    k = 0;
    kind.retain(|_| {
        k += 1;
        !gone[k - 1]
    });
    for q in add {
        uv.push(q);
        kind.push(Kind::Interior);
    }
    for q in add_trim {
        uv.push(q);
        kind.push(Kind::Trim);
    }
    *pts = uv.iter().map(|&q| pos_of(q)).collect();
    true
}
