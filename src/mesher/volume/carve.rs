//! Tets squashed against the boundary, several carved away at once with the mesh rebuilt, and
//! specks cut off the mesh.

use super::start::{repair_pinches, tag_built_mesh};
use super::{Ctx, CHUNK, GEPS};
use crate::topology::{TVertexId, TetId, TetMesh, VertexTag};
use crate::Error;
use rayon::prelude::*;
use slotmap::SecondaryMap;
use std::collections::HashMap;

/// Face-connected pieces with fewer tets than this (and under 1e-3 of the volume) are dropped
/// at the end ([`drop_specks`]).
const SPECK_TETS: usize = 10;
/// A carve that pinches the boundary keeps the tets at the pinches and tries again, at most
/// this many times.
const PINCH_ROUNDS: usize = 4;

/// Whether tet t is squashed against the boundary: three or four of its vertices on it and its
/// centroid within GEPS h of d = 0 (or outside). The seed's retriangulation drops such tets.
fn squashed(ctx: &Ctx, m: &TetMesh, t: TetId) -> Result<bool, Error> {
    let tx = m.tet(t);
    if tx.v.iter().filter(|&&v| m.tag(v) != VertexTag::Interior).count() < 3 {
        return Ok(false);
    }
    let p = m.tet_points(t);
    let c = (p[0] + p[1] + p[2] + p[3]) / 4.0;
    Ok(ctx.approx_dist(c)? > -GEPS * ctx.opts.h0 * ctx.h(c)?)
}

/// The squashed tets ([`squashed`]) that the local removal refuses, in arena order.
pub(super) fn stuck_tets(ctx: &Ctx, m: &TetMesh) -> Result<Vec<TetId>, Error> {
    let ids: Vec<TetId> = m.tet_ids().collect();
    ids.par_iter()
        .with_min_len(CHUNK)
        .map(|&t| Ok((squashed(ctx, m, t)? && m.check_remove_boundary_tet(t).is_err()).then_some(t)))
        .collect::<Result<Vec<Option<TetId>>, Error>>()
        .map(|v| v.into_iter().flatten().collect())
}

/// Drops the given tets at once and rebuilds the mesh from arrays with its pinches repaired,
/// as the start does. The force loop removes squashed tets one at a time where that keeps the
/// boundary a 2-manifold; a cluster of them bridging a concave part of the boundary (or
/// folded at a sharp edge) only goes together, and left alone it ends as slivers no swap can
/// reach. Returns whether the mesh changed; a carve that would lose a fixed point or split the
/// mesh into more pieces is not made, and one that would pinch the boundary at a vertex keeps
/// the tets there (up to PINCH_ROUNDS tries).
pub(super) fn carve(ctx: &Ctx, m: &mut TetMesh, gone: &[TetId]) -> Result<bool, Error> {
    if gone.is_empty() {
        return Ok(false);
    }
    let crate::topology::MeshArrays { points, cells: tets, .. } = m.to_arrays();
    let ids: Vec<TetId> = m.tet_ids().collect();
    let gone: SecondaryMap<TetId, ()> = gone.iter().map(|&t| (t, ())).collect();
    let mut drop: Vec<bool> = ids.iter().map(|&t| gone.contains_key(t)).collect();
    // The vertex at each position: a pinch found in the rebuilt mesh is named by position.
    let at: HashMap<[u64; 3], usize> =
        points.iter().enumerate().map(|(i, p)| (p.to_array().map(f64::to_bits), i)).collect();
    let pinched_before = super::report::pinched_boundary_vertices(m).len();
    let fixed = m.vertex_ids().filter(|&v| m.tag(v) == VertexTag::Fixed).count();
    for _ in 0..PINCH_ROUNDS {
        let mut kept: Vec<[usize; 4]> = tets.iter().zip(&drop).filter(|x| !x.1).map(|x| *x.0).collect();
        // A carve whose pinches do not resolve is not made (the mesh as it is stays valid).
        let Ok(mut carved) = repair_pinches(&points, &mut kept) else { return Ok(false) };
        // Nor one that pinches the boundary at a vertex (two fans of boundary faces meeting
        // there alone, the vertex's tets still face-connected: the rebuild cannot see it):
        // the dropped tets at such vertices stay, and the carve is tried again.
        let pinched = super::report::pinched_boundary_vertices(&carved);
        if pinched.len() > pinched_before {
            let spots: Vec<usize> =
                pinched.iter().filter_map(|&v| at.get(&carved.pos(v).to_array().map(f64::to_bits)).copied()).collect();
            let mut kept_back = 0;
            for (k, d) in drop.iter_mut().enumerate() {
                if *d && tets[k].iter().any(|i| spots.contains(i)) {
                    *d = false;
                    kept_back += 1;
                }
            }
            if kept_back == 0 || !drop.contains(&true) {
                return Ok(false);
            }
            continue;
        }
        let found = tag_built_mesh(&mut carved, &ctx.fixed);
        if found < fixed {
            return Ok(false);
        }
        // Nor one that splits the mesh: along a sharp edge the stuck tets can be all that holds a
        // corner on (the cube's corners broke off that way).
        if count_pieces(&carved) > count_pieces(m) {
            return Ok(false);
        }
        *m = carved;
        return Ok(true);
    }
    Ok(false)
}

/// The face-connected piece of each tet (a representative tet index per piece), in arena order.
fn pieces(m: &TetMesh) -> (Vec<TetId>, Vec<usize>) {
    let ids: Vec<TetId> = m.tet_ids().collect();
    let mut index: SecondaryMap<TetId, usize> = SecondaryMap::with_capacity(ids.len());
    for (k, &t) in ids.iter().enumerate() {
        index.insert(t, k);
    }
    let mut sets = crate::topology::DisjointSets::new(ids.len());
    for (k, &t) in ids.iter().enumerate() {
        for (u, _) in m.tet(t).adj.iter().flatten() {
            sets.join(k, index[*u]);
        }
    }
    let roots = (0..ids.len()).map(|k| sets.root(k)).collect();
    (ids, roots)
}

/// How many face-connected pieces the mesh has.
pub(super) fn count_pieces(m: &TetMesh) -> usize {
    let (_, mut roots) = pieces(m);
    roots.sort_unstable();
    roots.dedup();
    roots.len()
}

/// Drops face-connected pieces of fewer than SPECK_TETS tets holding less than 1e-3 of the
/// volume, unless they alone hold a fixed point: a tet whose neighbours all left one by one
/// (each removal keeps its own boundary manifold, not a neighbour's) is cut off, and at a sharp
/// edge it may be flat. Returns whether the mesh changed.
pub(super) fn drop_specks(ctx: &Ctx, m: &mut TetMesh) -> Result<bool, Error> {
    let (ids, roots) = pieces(m);
    let vols: Vec<f64> = ids.iter().map(|&t| crate::quality::tet_volume(m.tet_points(t))).collect();
    let total: f64 = vols.iter().sum();
    let mut piece: HashMap<usize, (usize, f64)> = HashMap::new();
    for (&root, &vol) in roots.iter().zip(&vols) {
        let e = piece.entry(root).or_insert((0, 0.0));
        e.0 += 1;
        e.1 += vol;
    }
    let speck = |k: usize| {
        let (n, v) = piece[&roots[k]];
        n < SPECK_TETS && v < 1e-3 * total
    };
    // A fixed point that only specks hold keeps them.
    let mut kept_fixed: SecondaryMap<TVertexId, bool> = SecondaryMap::new();
    for (k, &t) in ids.iter().enumerate() {
        let is_speck = speck(k);
        for &v in &m.tet(t).v {
            if m.tag(v) == VertexTag::Fixed {
                let e = kept_fixed.entry(v).expect("live vertex").or_insert(false);
                *e |= !is_speck;
            }
        }
    }
    let gone: Vec<TetId> = (0..ids.len())
        .filter(|&k| speck(k) && m.tet(ids[k]).v.iter().all(|&v| m.tag(v) != VertexTag::Fixed || kept_fixed[v]))
        .map(|k| ids[k])
        .collect();
    carve(ctx, m, &gone)
}
