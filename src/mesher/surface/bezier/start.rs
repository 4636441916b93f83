//! The start of a patch mesh: side nodes by arc length (shared sides get the first patch's
//! nodes), an interior grid spaced by arc length, and a Delaunay triangulation in the
//! parameter plane cut to the trim (a start only: the flips in space then make it good in
//! space).

use super::{ccw, edges_sorted, BezierOptions, Kind, RationalBezierPatch};
use crate::topology::TriMesh;
use crate::Error;
use glam::{DVec2, DVec3};
use std::collections::HashMap;

/// Side s of the unit square: 0 v = 0, 1 u = 1, 2 v = 1, 3 u = 0. Returns (fixed axis, value).
pub(super) fn side_fix(s: usize) -> (usize, f64) {
    match s {
        0 => (1, 0.0),
        1 => (0, 1.0),
        2 => (1, 1.0),
        _ => (0, 0.0),
    }
}

/// The point of side s at parameter t (t runs from the side's first corner).
pub(super) fn side_uv(s: usize, t: f64) -> DVec2 {
    match s {
        0 => DVec2::new(t, 0.0),
        1 => DVec2::new(1.0, t),
        2 => DVec2::new(t, 1.0),
        _ => DVec2::new(0.0, t),
    }
}

/// Parameters t_0 = 0 < ... < t_k = 1 that split the side curve into k arcs of equal length
/// near h (from a fine polyline; the shared-curve placement of the conforming meshing).
fn side_params(p: &RationalBezierPatch, s: usize, h: f64) -> Vec<f64> {
    const FINE: usize = 2000;
    let mut cum = vec![0.0];
    let mut prev = p.point(side_uv(s, 0.0));
    for i in 1..=FINE {
        let q = p.point(side_uv(s, i as f64 / FINE as f64));
        cum.push(cum[i - 1] + prev.distance(q));
        prev = q;
    }
    let total = cum[FINE];
    let k = ((total / h).round() as usize).max(1);
    let mut out = vec![0.0];
    let mut j = 0;
    for i in 1..k {
        let target = total * i as f64 / k as f64;
        while cum[j + 1] < target {
            j += 1;
        }
        let f = (target - cum[j]) / (cum[j + 1] - cum[j]).max(1e-300);
        out.push((j as f64 + f) / FINE as f64);
    }
    out.push(1.0);
    out
}

/// Arc-length reparametrisation of one direction: parameters where the average length along
/// `axis` (sampled over the other parameter) is split into k equal parts.
fn axis_params(p: &RationalBezierPatch, axis: usize, h: f64) -> Vec<f64> {
    const FINE: usize = 400;
    const ACROSS: usize = 9;
    let mut cum = vec![0.0; FINE + 1];
    for a in 0..ACROSS {
        let o = a as f64 / (ACROSS - 1) as f64;
        let at = |t: f64| if axis == 0 { DVec2::new(t, o) } else { DVec2::new(o, t) };
        let mut prev = p.point(at(0.0));
        let mut acc = 0.0;
        for (i, c) in cum.iter_mut().enumerate().skip(1) {
            let q = p.point(at(i as f64 / FINE as f64));
            acc += prev.distance(q);
            *c += acc / ACROSS as f64;
            prev = q;
        }
    }
    let total = cum[FINE];
    let k = ((total / h).round() as usize).max(1);
    let mut out = Vec::new();
    let mut j = 0;
    for i in 0..=k {
        let target = total * i as f64 / k as f64;
        while j + 1 < FINE && cum[j + 1] < target {
            j += 1;
        }
        let f = ((target - cum[j]) / (cum[j + 1] - cum[j]).max(1e-300)).clamp(0.0, 1.0);
        out.push((j as f64 + f) / FINE as f64);
    }
    out
}

pub(super) fn side_params_len(sides: &[Vec<f64>; 4]) -> usize {
    sides.iter().map(|s| s.len()).sum()
}

/// The start nodes of one patch: the side nodes (kept where the side parameters put them),
/// then an interior grid spaced by arc length (in space mode) or uniformly (parameter-plane
/// mode), kept off the sides.
pub(super) fn start_nodes(
    p: &RationalBezierPatch,
    sides: &[Vec<f64>; 4],
    opts: &BezierOptions,
) -> (Vec<DVec2>, Vec<Kind>) {
    // Start points: the side nodes, then an interior grid spaced by arc length (in space mode)
    // or uniformly (parameter-plane mode), kept off the sides by half a spacing.
    let mut uv: Vec<DVec2> = Vec::new();
    let mut kind: Vec<Kind> = Vec::new();
    for (s, ts) in sides.iter().enumerate() {
        for &t in ts {
            let q = side_uv(s, t);
            // Corners end two sides: once.
            if !uv.contains(&q) {
                uv.push(q);
                kind.push(Kind::Fixed);
            }
        }
    }
    let (us, vs) = if opts.in_space {
        (axis_params(p, 0, opts.h0), axis_params(p, 1, opts.h0))
    } else {
        let k = ((sides[0].len() + sides[1].len() + sides[2].len() + sides[3].len()) as f64 / 4.0).round().max(2.0)
            as usize;
        let g: Vec<f64> = (0..k).map(|i| i as f64 / (k - 1) as f64).collect();
        (g.clone(), g)
    };
    for (j, &v) in vs.iter().enumerate().take(vs.len().saturating_sub(1)).skip(1) {
        for (i, &u) in us.iter().enumerate().take(us.len().saturating_sub(1)).skip(1) {
            // Shift odd rows by half a cell: a start close to equilateral.
            let u = if j % 2 == 1 && i + 1 < us.len() { 0.5 * (u + us[i + 1]) } else { u };
            let du = 0.35 * (us[1] - us[0]).min(us[us.len() - 1] - us[us.len() - 2]);
            let dv = 0.35 * (vs[1] - vs[0]).min(vs[vs.len() - 1] - vs[vs.len() - 2]);
            if u < du || u > 1.0 - du || v < dv || v > 1.0 - dv {
                continue;
            }
            uv.push(DVec2::new(u, v));
            kind.push(Kind::Interior);
        }
    }
    (uv, kind)
}

/// Delaunay triangulation of the nodes in (u, v), cut to the trim (triangles whose centroid is
/// outside are dropped, their outside nodes moved onto the curve), compacted to the used nodes.
/// A start only: the flips in space then make it good in space.
pub(super) fn triangulate(
    p: &RationalBezierPatch,
    uv: &mut Vec<DVec2>,
    kind: &mut Vec<Kind>,
) -> Result<Vec<[usize; 3]>, Error> {
    let (dm, ids) = TriMesh::<DVec2>::delaunay(uv)?;
    let crate::topology::MeshArrays { cells: tris_raw, keys, .. } = dm.to_arrays();
    let mut key_to_input = HashMap::new();
    for (i, k) in ids.iter().enumerate() {
        key_to_input.entry(*k).or_insert(i);
    }
    let remap: Vec<usize> = keys.iter().map(|k| key_to_input[k]).collect();
    let mut tris: Vec<[usize; 3]> = tris_raw.iter().map(|t| t.map(|i| remap[i])).collect();
    if p.trim.is_some() {
        tris.retain(|t| p.trim_value((uv[t[0]] + uv[t[1]] + uv[t[2]]) / 3.0) <= 0.0);
        let used = used_nodes(uv.len(), &tris);
        for i in 0..uv.len() {
            if used[i] && kind[i] != Kind::Trim && p.trim_value(uv[i]) > 0.0 {
                let fix = side_of(uv[i]);
                uv[i] = p.to_trim_curve(uv[i], fix);
                kind[i] = if fix.is_some() { Kind::Fixed } else { Kind::Trim };
            }
        }
        // Boundary nodes of the kept region that are inside but not on a side go to the curve.
        for ((a, b), ts) in edges_sorted(&tris) {
            if ts.len() == 1 {
                for i in [a, b] {
                    if kind[i] == Kind::Interior {
                        uv[i] = p.to_trim_curve(uv[i], None);
                        kind[i] = Kind::Trim;
                    }
                }
            }
        }
        tris.retain(|t| ccw(uv[t[0]], uv[t[1]], uv[t[2]]));
        if tris.is_empty() {
            return Err(Error::EmptyDomain("the trim leaves no triangle of the patch".into()));
        }
    }
    let used = used_nodes(uv.len(), &tris);
    let mut new_index = vec![usize::MAX; uv.len()];
    let (mut uv2, mut kind2) = (Vec::new(), Vec::new());
    for i in 0..uv.len() {
        if used[i] {
            new_index[i] = uv2.len();
            uv2.push(uv[i]);
            kind2.push(kind[i]);
        }
    }
    *uv = uv2;
    *kind = kind2;
    Ok(tris.iter().map(|t| t.map(|i| new_index[i])).collect())
}

fn used_nodes(n: usize, tris: &[[usize; 3]]) -> Vec<bool> {
    let mut used = vec![false; n];
    for t in tris {
        for &i in t {
            used[i] = true;
        }
    }
    used
}

/// Which side of the unit square `uv` lies on, as a (fixed axis, value) pair.
fn side_of(uv: DVec2) -> Option<(usize, f64)> {
    for s in 0..4 {
        let (a, val) = side_fix(s);
        if uv[a] == val {
            return Some((a, val));
        }
    }
    None
}

/// Whether side s of patch a and side t of patch b are the same curve (same control points and
/// proportional weights, same or reversed direction). Returns Some(reversed).
fn same_side(a: &RationalBezierPatch, s: usize, b: &RationalBezierPatch, t: usize) -> Option<bool> {
    let row = |p: &RationalBezierPatch, s: usize| -> Vec<(DVec3, f64)> {
        let (m, n) = p.degree;
        let idx: Vec<usize> = match s {
            0 => (0..=m).collect(),
            1 => (0..=n).map(|j| m + (m + 1) * j).collect(),
            2 => (0..=m).map(|i| i + (m + 1) * n).collect(),
            _ => (0..=n).map(|j| (m + 1) * j).collect(),
        };
        idx.iter().map(|&k| (p.control[k], p.weights[k])).collect()
    };
    let (ra, rb) = (row(a, s), row(b, t));
    if ra.len() != rb.len() {
        return None;
    }
    let matches = |rb: &[(DVec3, f64)]| {
        let ratio = rb[0].1 / ra[0].1;
        ra.iter().zip(rb).all(|(x, y)| x.0 == y.0 && (y.1 - ratio * x.1).abs() <= 1e-14 * y.1)
    };
    if matches(&rb) {
        return Some(false);
    }
    let rev: Vec<_> = rb.iter().rev().copied().collect();
    if matches(&rev) {
        return Some(true);
    }
    None
}

/// Where the side nodes of several patches go: per patch and side the parameters of its
/// nodes, the earlier patch and side it shares (with whether it runs reversed), and whether
/// the patch's triangles are reversed in the union.
pub(super) struct SidePlan {
    pub(super) sides: Vec<[Vec<f64>; 4]>,
    pub(super) shared: Vec<[Option<(usize, usize, bool)>; 4]>,
    pub(super) reversed: Vec<bool>,
}

/// The side nodes of `patches` at size `h`: a side that an earlier patch shares takes that
/// patch's parameters, any other is placed by arc length ([`side_params`]).
pub(super) fn plan_sides(patches: &[RationalBezierPatch], h: f64) -> SidePlan {
    let mut sides: Vec<[Vec<f64>; 4]> = Vec::new();
    let mut shared: Vec<[Option<(usize, usize, bool)>; 4]> = Vec::new();
    for (k, p) in patches.iter().enumerate() {
        let mut mine: [Vec<f64>; 4] = Default::default();
        let mut links: [Option<(usize, usize, bool)>; 4] = [None; 4];
        for (s, slot) in mine.iter_mut().enumerate() {
            let mut found = None;
            'outer: for (j, q) in patches[..k].iter().enumerate() {
                for t in 0..4 {
                    if let Some(rev) = same_side(p, s, q, t) {
                        found = Some((j, t, rev));
                        break 'outer;
                    }
                }
            }
            // Same control row and weights up to a factor: the same rational curve with the
            // same parametrisation, so the first patch's parameters serve (mirrored if reversed).
            *slot = match found {
                Some((j, t, false)) => sides[j][t].clone(),
                Some((j, t, true)) => sides[j][t].iter().rev().map(|x| 1.0 - x).collect(),
                None => side_params(p, s, h),
            };
            links[s] = found;
        }
        sides.push(mine);
        shared.push(links);
    }
    // Orientation: the counter-clockwise boundary loop of the unit square runs sides 0 and 1
    // forward and sides 2 and 3 backward; two patches are consistently oriented when their
    // loops run the shared curve in opposite directions. A patch that is not gets its
    // triangles reversed in the union.
    let dir = |s: usize| if s < 2 { 1i32 } else { -1 };
    let mut reversed = vec![false; patches.len()];
    for k in 0..patches.len() {
        if let Some((s, (j, t, rev))) = shared[k].iter().enumerate().find_map(|(s, l)| l.map(|l| (s, l))) {
            let mine = dir(s) * if rev { -1 } else { 1 };
            reversed[k] = reversed[j] ^ (mine == dir(t));
        }
    }
    SidePlan { sides, shared, reversed }
}
