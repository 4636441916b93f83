//! Parts of the domain the finished mesh does not cover: a separate component smaller than the
//! resolution (an island of radius below h0) has no start node deep enough to survive the carve
//! and is dropped. That is the right mesh at this h0, but not a silent one: each uncovered part
//! becomes a note of the report, with where it is and the advice to lower h0.
//!
//! The check samples the box at about h0 (as the survey does) and looks for points deeper
//! inside than a fifth of the local target length (deeper than the chords of any boundary the
//! mesh resolves cut off) that lie in no triangle.

use super::Ctx;
use crate::mesher::truss::domain::approx_distance;
use crate::topology::TriMesh;
use crate::Error;
use glam::DVec2;
use rayon::prelude::*;

/// Depth, in local target lengths, past which a sample must be covered.
const DEPTH: f64 = 0.2;

/// A local element size past this many h0 where a part is dropped: the requested size, not
/// the resolution, left it out.
pub(super) const BY_SIZE: f64 = 1.5;

/// The parts of the domain `mesh` leaves uncovered: a note for each (empty when it covers it),
/// and those the requested size left out (a point of each and the element size there).
pub(super) type Uncovered = (Vec<String>, Vec<([f64; 2], f64)>);

/// See [`Uncovered`].
pub(super) fn uncovered(ctx: &Ctx, mesh: &TriMesh<DVec2>) -> Result<Uncovered, Error> {
    let opts = ctx.opts;
    let [lo, hi] = opts.bbox;
    let ext = hi - lo;
    let nx = ((ext.x / opts.h0).ceil() as usize + 1).clamp(8, 512);
    let ny = ((ext.y / opts.h0).ceil() as usize + 1).clamp(8, 512);
    let step = DVec2::new(ext.x / (nx - 1) as f64, ext.y / (ny - 1) as f64);
    // Triangles bucketed by the cells of the sample grid their bounding boxes touch (flat
    // arrays: a count per cell, then the triangles of cell c at start[c]..start[c + 1]).
    let tris: Vec<[DVec2; 3]> = mesh.face_ids().map(|f| mesh.face_points(f)).collect();
    let cell = |p: DVec2| {
        let c = ((p - lo) / step).floor();
        [c.x.clamp(0.0, (nx - 1) as f64) as usize, c.y.clamp(0.0, (ny - 1) as f64) as usize]
    };
    let spans: Vec<([usize; 2], [usize; 2])> =
        tris.par_iter().map(|t| (cell(t[0].min(t[1]).min(t[2])), cell(t[0].max(t[1]).max(t[2])))).collect();
    let mut start = vec![0u32; nx * ny + 1];
    for (a, b) in &spans {
        for j in a[1]..=b[1] {
            for i in a[0]..=b[0] {
                start[i + nx * j + 1] += 1;
            }
        }
    }
    for c in 0..nx * ny {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut in_cell = vec![0u32; start[nx * ny] as usize];
    for (k, (a, b)) in spans.iter().enumerate() {
        for j in a[1]..=b[1] {
            for i in a[0]..=b[0] {
                let c = i + nx * j;
                in_cell[fill[c] as usize] = k as u32;
                fill[c] += 1;
            }
        }
    }
    let bucket = |c: [usize; 2]| &in_cell[start[c[0] + nx * c[1]] as usize..start[c[0] + nx * c[1] + 1] as usize];
    let inside = |t: &[DVec2; 3], p: DVec2| {
        let s = [(t[1] - t[0]).perp_dot(p - t[0]), (t[2] - t[1]).perp_dot(p - t[1]), (t[0] - t[2]).perp_dot(p - t[2])];
        let tol = -1e-12 * (t[1] - t[0]).perp_dot(t[2] - t[0]).abs();
        s.iter().all(|&v| v >= tol)
    };
    // The samples, a row at a time in parallel.
    let rows: Vec<Vec<bool>> = (0..ny)
        .into_par_iter()
        .map(|j| {
            (0..nx)
                .map(|i| {
                    let p = lo + DVec2::new(i as f64, j as f64) * step;
                    let d = ctx.d(p)?;
                    if d >= 0.0 {
                        return Ok(false);
                    }
                    let g = if ctx.domain.is_distance() { 1.0 } else { ctx.domain.gradient(p).length() };
                    let depth = -approx_distance(d, g, ctx.domain.is_distance());
                    if depth <= DEPTH * opts.h0 * ctx.h(p)? {
                        return Ok(false);
                    }
                    let c = cell(p);
                    let covered = [c, [c[0].saturating_sub(1), c[1]], [c[0], c[1].saturating_sub(1)]]
                        .iter()
                        .flat_map(|&c| bucket(c))
                        .any(|&k| inside(&tris[k as usize], p));
                    Ok(!covered)
                })
                .collect::<Result<Vec<bool>, Error>>()
        })
        .collect::<Result<Vec<Vec<bool>>, Error>>()?;
    let missed: Vec<bool> = rows.into_iter().flatten().collect();
    // Group the missed samples into parts (8-connected on the grid), one note each.
    let (mut notes, mut by_size) = (Vec::new(), Vec::new());
    let mut seen = vec![false; nx * ny];
    for start in 0..nx * ny {
        if !missed[start] || seen[start] {
            continue;
        }
        let (mut stack, mut count) = (vec![start], 0usize);
        seen[start] = true;
        while let Some(k) = stack.pop() {
            count += 1;
            let (i, j) = ((k % nx) as i64, (k / nx) as i64);
            for (di, dj) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                let (a, b) = (i + di, j + dj);
                if a < 0 || b < 0 || a >= nx as i64 || b >= ny as i64 {
                    continue;
                }
                let n = a as usize + nx * b as usize;
                if missed[n] && !seen[n] {
                    seen[n] = true;
                    stack.push(n);
                }
            }
        }
        let p = lo + DVec2::new((start % nx) as f64, (start / nx) as f64) * step;
        // The element size there: a part narrower than it has no start node deep enough inside.
        let local = opts.h0 * ctx.h(p)?;
        if local > BY_SIZE * opts.h0 {
            by_size.push((p.to_array(), local));
        }
        // With a metric, h0 only sets tolerances: the part was left out by the start, whose
        // cells are as long as the metric's long size.
        let why = if ctx.metric.is_some() {
            "the start, stretched as the metric asks, left it out (its cells there are about as long as the \
             domain is wide); smaller sizes in the metric there mesh it"
                .to_string()
        } else if local > BY_SIZE * opts.h0 {
            format!("it is below the local element size {local:.3} and was dropped; lower the size there (--size) or h0 to mesh it")
        } else {
            format!("it is below the resolution h0 = {} and was dropped; lower h0 to mesh it", opts.h0)
        };
        notes.push(format!(
            "a part of the domain at ({}, {}) ({count} sample{} at spacing {:.3}) is not meshed: {why}",
            p.x,
            p.y,
            if count == 1 { "" } else { "s" },
            step.x.max(step.y),
        ));
    }
    Ok((notes, by_size))
}
