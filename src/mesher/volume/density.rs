//! Density control: edges longer than the target split, shorter ones collapsed.

use super::snapshot::Snapshot;
use super::Ctx;
use crate::mesher::truss::DensityBand;
use crate::topology::{TVertexId, TetId, TetMesh, VertexTag, EDGE_VERTICES};
use crate::Error;
use glam::DVec3;

/// Edges longer than 1.6 current target lengths are split, shorter than 0.5 collapsed.
const BAND: DensityBand = DensityBand::new(1.6, 0.5);

/// Splits and collapses the edges outside [`BAND`], in units of the current target (the
/// mesh's own scale `unit` times h), one change per neighbourhood.
pub(super) fn density_control(
    ctx: &mut Ctx,
    m: &mut TetMesh,
    snap: &Snapshot,
    p: &[DVec3],
    hv: &[f64],
    unit: f64,
) -> Result<bool, Error> {
    let mut long: Vec<(f64, u32, u32)> = Vec::new();
    let mut short: Vec<(f64, u32, u32)> = Vec::new();
    for i in 0..p.len() {
        for &j in snap.row(i) {
            let j = j as usize;
            if j <= i {
                continue;
            }
            let r = p[i].distance(p[j]) / (unit * 0.5 * (hv[i] + hv[j]));
            if BAND.splits(r) {
                long.push((r, i as u32, j as u32));
            } else if BAND.collapses(r) {
                short.push((r, i as u32, j as u32));
            }
        }
    }
    let mut changed = false;
    let mut touched = vec![false; p.len()];
    long.sort_by(|x, y| y.0.total_cmp(&x.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    for (_, i, j) in long {
        let (a, b) = (snap.ids[i as usize], snap.ids[j as usize]);
        if touched[i as usize] || touched[j as usize] {
            continue;
        }
        let Some(t) = m.find_edge(a, b) else { continue };
        let e = edge_index(m, t, a, b);
        let mid = (m.pos(a) + m.pos(b)) * 0.5;
        let boundary = !m.edge_shell(t, EDGE_VERTICES[e][0], EDGE_VERTICES[e][1]).closed;
        // At the midpoint the split covers the same region; a boundary node then moves onto
        // d = 0 by a checked relocation (no tet inverted, no boundary ring wrapped), or stays
        // for the next projection.
        if let Ok(v) = m.split_edge(t, e, mid) {
            if boundary {
                if let Some(q) = ctx.project(mid)? {
                    let _ = m.relocate(v, q);
                }
            }
            ctx.report.ops.splits += 1;
            changed = true;
            touched[i as usize] = true;
            touched[j as usize] = true;
            ctx.report.ops.flips += m.lawson_star(v);
        }
    }
    short.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    for (_, i, j) in short {
        if touched[i as usize] || touched[j as usize] {
            continue;
        }
        let (a, b) = (snap.ids[i as usize], snap.ids[j as usize]);
        if !m.contains_vertex(a) || !m.contains_vertex(b) {
            continue;
        }
        let Some(t) = m.find_edge(a, b) else { continue };
        let e = edge_index(m, t, a, b);
        // Interior vertices merge into the other end; two interior ends meet at the midpoint.
        let (pa, pb) = (m.pos(a), m.pos(b));
        let both_interior = m.tag(a) == VertexTag::Interior && m.tag(b) == VertexTag::Interior;
        let [li, _] = EDGE_VERTICES[e];
        let a_first = m.tet(t).v[li] == a;
        let mut done = None;
        for reverse in [false, true] {
            // `reverse == false` merges the edge's first local vertex into the second.
            let (gone, stay) = if a_first != reverse { (a, b) } else { (b, a) };
            let _ = gone;
            let pos = if both_interior { (pa + pb) * 0.5 } else { m.pos(stay) };
            if let Ok(plan) = m.check_collapse(t, e, reverse, pos) {
                if plan.min_quality > 0.05 {
                    let (made, _) = m.apply_patch(plan);
                    done = made.first().copied();
                    break;
                }
            }
        }
        if let Some(t) = done {
            ctx.report.ops.collapses += 1;
            changed = true;
            touched[i as usize] = true;
            touched[j as usize] = true;
            let v = m.tet(t).v[0];
            ctx.report.ops.flips += m.lawson_star(v);
        }
    }
    Ok(changed)
}

/// Local index (0..6) of edge a-b in tet t.
pub(super) fn edge_index(m: &TetMesh, t: TetId, a: TVertexId, b: TVertexId) -> usize {
    let (i, j) = (m.local_index(t, a).expect("edge"), m.local_index(t, b).expect("edge"));
    let (i, j) = (i.min(j), i.max(j));
    EDGE_VERTICES.iter().position(|&[x, y]| x == i && y == j).expect("edge")
}
