//! The input's sharp features in the form the surface mesher holds them: the triangles grouped
//! into smooth patches (connected across every edge that is not a feature edge), the feature
//! edges grouped by the two patches they separate, and the corners where three or more patches
//! meet. The surface mesher labels its own triangles by the patch under them, so that a mesh
//! vertex between two labels lies on the curve of that pair and is projected onto it: the
//! input's own edges, or the smooth curve through their vertices where the edges sample one
//! (see [`CurveSegment`] and [`crate::geometry::Creases`]).

use super::TriSurface;
use crate::geometry::{Creases, LabelledTriangulation};
use crate::topology::DisjointSets;
use glam::DVec3;
use std::collections::HashMap;

/// Labels are packed two to a curve id by the surface mesher: at most this many patches.
const MAX_PATCHES: usize = 65_535;

/// The patches, curves and corners of a surface at one feature angle.
#[derive(Clone, Debug, Default)]
pub struct CreaseData {
    /// The patch of each input triangle.
    pub(super) patch: Vec<u32>,
    /// The corners: input vertices where three or more patches meet.
    corners: Vec<DVec3>,
    /// The pins: input vertices where a curve turns sharply (see [`pins`]).
    pins: Vec<DVec3>,
    /// The feature edges between each two patches (lower label first), as pieces of the
    /// smooth curve through their vertices (see [`CurveSegment`]).
    curves: HashMap<(u32, u32), Vec<CurveSegment>>,
}

/// A feature edge of the input as a piece of the curve the mesher holds: the cubic Hermite
/// curve from `a` to `b` with end tangents `ta` and `tb` (scaled to the edge's length). Where
/// the input's curve turns by at most [`SMOOTH_TURN`] at a vertex, its tangent there is the
/// direction between the vertex's two neighbours along the curve (a finite-difference
/// tangent), so that a polygon sampling a smooth curve (a hole's rim in a CAD export) is held as
/// a smooth curve through its vertices: an output vertex between two input vertices lies on
/// the curve, not inside it on the chord, and an output chord spanning an input vertex cuts
/// the rim by its own sagitta only. Elsewhere (corners, sharp turns, curve ends) the tangent is
/// the edge's own direction and the piece is the straight edge.
#[derive(Clone, Copy, Debug)]
pub(super) struct CurveSegment {
    a: DVec3,
    b: DVec3,
    ta: DVec3,
    tb: DVec3,
}

impl CurveSegment {
    /// The curve piece of the input edge a-b, with the vertices' smooth tangents where they
    /// have one (oriented from a to b and scaled to the edge's length).
    pub(super) fn new(a: DVec3, b: DVec3, ta: Option<DVec3>, tb: Option<DVec3>) -> CurveSegment {
        let e = b - a;
        let (len, dir) = (e.length(), e.normalize_or_zero());
        // A tangent along the edge (within rounding) is the edge's: a straight run of the
        // curve stays exactly straight (see `CurveSegment::at`).
        let end = |t: Option<DVec3>| match t {
            Some(t) if t.cross(dir).length() > STRAIGHT => (if t.dot(e) < 0.0 { -t } else { t }) * len,
            _ => e,
        };
        CurveSegment { a, b, ta: end(ta), tb: end(tb) }
    }

    /// The point at parameter `t` in [0, 1] and the unit tangent there.
    pub(super) fn at(&self, t: f64) -> (DVec3, DVec3) {
        let e = self.b - self.a;
        if self.ta == e && self.tb == e {
            return (self.a + e * t, e.normalize_or_zero());
        }
        let (t2, t3) = (t * t, t * t * t);
        let p = self.a * (2.0 * t3 - 3.0 * t2 + 1.0)
            + self.ta * (t3 - 2.0 * t2 + t)
            + self.b * (-2.0 * t3 + 3.0 * t2)
            + self.tb * (t3 - t2);
        let d = (self.a - self.b) * (6.0 * t2 - 6.0 * t)
            + self.ta * (3.0 * t2 - 4.0 * t + 1.0)
            + self.tb * (3.0 * t2 - 2.0 * t);
        (p, d.try_normalize().unwrap_or_else(|| (self.b - self.a).normalize_or_zero()))
    }
}

/// The largest turn (radians, 20 degrees) of the input's feature curve at a vertex that is
/// taken as a sample of a smooth curve (see [`CurveSegment`]). A piece between two such
/// vertices bulges from its chord by about theta s / 8 for a turn theta and an edge s: at most
/// 0.044 s, within the input's own tessellation error of the curve it samples.
pub(super) const SMOOTH_TURN: f64 = 0.35;

/// A vertex tangent within this sine of its edge's direction is the edge's own.
const STRAIGHT: f64 = 1e-9;

/// The unit tangent of the smooth curve at input vertex `v`, whose neighbours along the curves
/// are `along`: None at a corner, a curve's end, or where [`smooth_tangent_at`] says so. Its
/// sign is arbitrary; [`CurveSegment::new`] orients it.
fn smooth_tangent(p: &[DVec3], v: usize, along: &[usize], patches_around: usize, coarse: f64) -> Option<DVec3> {
    let [k, j] = along else { return None };
    if patches_around != 2 {
        return None;
    }
    smooth_tangent_at(p[*k], p[v], p[*j], coarse)
}

/// The unit tangent of the smooth curve through `prev`, `v` and `next` at `v`: the direction
/// from `prev` to `next`, or None where the curve turns by more than SMOOTH_TURN at `v` or both
/// of its edges there are at least `coarse` long (the mesh follows such edges, and pins their
/// sharper turns, see [`pins`]: a faceted prism's rim stays a polygon).
pub(super) fn smooth_tangent_at(prev: DVec3, v: DVec3, next: DVec3, coarse: f64) -> Option<DVec3> {
    if prev.distance(v) >= coarse && next.distance(v) >= coarse {
        return None;
    }
    let turn = (v - prev).angle_between(next - v);
    (turn <= SMOOTH_TURN).then(|| (next - prev).try_normalize()).flatten()
}

impl CreaseData {
    /// The patches of `s` at `angle_deg` degrees, with the mesh size `h` (if known) those
    /// narrower than NARROW_FACE h merged into a neighbour (see [`merge_narrow`]) and the
    /// curves' sharp turns pinned (see [`pins`]); `None` when the surface has no feature edge
    /// between two different patches, or more patches than the mesher can label.
    pub(super) fn new(s: &TriSurface, angle_deg: f64, h: Option<f64>) -> Option<CreaseData> {
        let cos_max = angle_deg.to_radians().cos();
        let n = s.tris.len();
        let sharp = |t: usize, w: usize| s.normals.face(t).dot(s.normals.face(w)) < cos_max;
        let mut sets = DisjointSets::new(n);
        for t in 0..n {
            for k in 0..3 {
                let w = s.neighbors[t][k];
                if w > t && !sharp(t, w) {
                    sets.join(t, w);
                }
            }
        }
        if let Some(h) = h {
            merge_narrow(s, &mut sets, NARROW_FACE * h);
        }
        // Labels in the order of each patch's first triangle: deterministic.
        let mut label: HashMap<usize, u32> = HashMap::new();
        let mut patch = Vec::with_capacity(n);
        for t in 0..n {
            let r = sets.root(t);
            let next = label.len() as u32;
            patch.push(*label.entry(r).or_insert(next));
        }
        if label.len() > MAX_PATCHES {
            return None;
        }
        let mut edges: Vec<((u32, u32), usize, usize)> = Vec::new();
        let mut around: Vec<Vec<u32>> = vec![Vec::new(); s.points.len()];
        // Each vertex's neighbours along the curves, for the pins.
        let mut along: Vec<smallvec::SmallVec<[usize; 2]>> = vec![smallvec::SmallVec::new(); s.points.len()];
        for t in 0..n {
            for &v in &s.tris[t] {
                if !around[v].contains(&patch[t]) {
                    around[v].push(patch[t]);
                }
            }
            for k in 0..3 {
                let w = s.neighbors[t][k];
                let (a, b) = (patch[t], patch[w]);
                if w > t && a != b {
                    let (i, j) = (s.tris[t][k], s.tris[t][(k + 1) % 3]);
                    edges.push(((a.min(b), a.max(b)), i, j));
                    along[i].push(j);
                    along[j].push(i);
                }
            }
        }
        if edges.is_empty() {
            return None;
        }
        let coarse = h.map_or(f64::INFINITY, |h| PIN_GAP * h);
        let tangent: Vec<Option<DVec3>> =
            (0..s.points.len()).map(|v| smooth_tangent(&s.points, v, &along[v], around[v].len(), coarse)).collect();
        let mut curves: HashMap<(u32, u32), Vec<CurveSegment>> = HashMap::new();
        for (key, i, j) in edges {
            curves.entry(key).or_default().push(CurveSegment::new(s.points[i], s.points[j], tangent[i], tangent[j]));
        }
        let corners: Vec<DVec3> = (0..s.points.len()).filter(|&v| around[v].len() >= 3).map(|v| s.points[v]).collect();
        let pins = h.map_or_else(Vec::new, |h| pins(&s.points, &along, &corners, PIN_GAP * h));
        Some(CreaseData { patch, corners, pins, curves })
    }
}

/// An input vertex where a feature curve turns by more than this (radians, 8.6 degrees) is
/// pinned when its curve is tessellated coarser than the mesh: an output edge of length c whose
/// ends slide along the input's curve on either side of a turn theta cuts it by up to
/// theta c / 4 (0.06 to 0.13 h for the 15 to 30 degree steps of a cylinder's rim in a CAD
/// export), and a pin holds an output vertex there instead.
pub(super) const PIN_TURN: f64 = 0.15;
/// Pins need both of their curve edges in the input at least this many mesh sizes long, and lie
/// at least as far from the corners and from each other: finer curves are followed by the
/// sliding vertices within a sag, and pins closer than the mesh size would force short edges
/// (measured on the part at h0 0.08, whose rims are tessellated at about h: pins down to 0.5 h
/// apart held the rims exactly but left 26-29 degree triangles).
pub(super) const PIN_GAP: f64 = 1.0;

/// The pins of the curves (see [`PIN_TURN`]), given as each vertex's neighbours along them:
/// vertices on exactly one curve (two neighbours, both at least `gap` away) that turn by more
/// than PIN_TURN, sharpest first (the lower vertex on a tie), each kept when at least `gap` from
/// the corners and the pins kept before it.
fn pins(p: &[DVec3], along: &[smallvec::SmallVec<[usize; 2]>], corners: &[DVec3], gap: f64) -> Vec<DVec3> {
    if gap.is_nan() || gap <= 0.0 {
        return Vec::new();
    }
    let mut turns: Vec<(f64, usize)> = (0..p.len())
        .filter(|&v| along[v].len() == 2 && along[v].iter().all(|&w| p[w].distance(p[v]) >= gap))
        .map(|v| ((p[v] - p[along[v][0]]).angle_between(p[along[v][1]] - p[v]), v))
        .filter(|&(turn, _)| turn > PIN_TURN)
        .collect();
    if turns.is_empty() {
        return Vec::new();
    }
    turns.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    // A hash grid of cell `gap`: a point within `gap` of q lies in one of the 27 cells around q's.
    let cell = |q: DVec3| (q / gap).floor().as_i64vec3();
    let mut grid: HashMap<glam::I64Vec3, Vec<DVec3>> = HashMap::new();
    for &c in corners {
        grid.entry(cell(c)).or_default().push(c);
    }
    let mut out = Vec::new();
    for (_, v) in turns {
        let (q, c) = (p[v], cell(p[v]));
        let near =
            (-1..=1).flat_map(|x| (-1..=1).flat_map(move |y| (-1..=1).map(move |z| glam::I64Vec3::new(x, y, z))));
        let crowded =
            near.into_iter().any(|d| grid.get(&(c + d)).is_some_and(|l| l.iter().any(|k| k.distance(q) < gap)));
        if !crowded {
            grid.entry(c).or_default().push(q);
            out.push(q);
        }
    }
    out
}

/// A patch narrower than this many mesh sizes (twice its area over its perimeter) is merged
/// into a neighbour: its two sides would be a fraction of an edge apart.
pub(super) const NARROW_FACE: f64 = 0.25;

/// Merges every patch of `sets` (triangles joined across their smooth edges) whose width, twice
/// its area over its perimeter, is below `narrow` into the neighbouring patch it shares the
/// longest border with (the lower root on a tie), narrowest first; a merged patch that is still
/// narrow is looked at again. Ordered maps throughout: the same merges on every run.
fn merge_narrow(s: &TriSurface, sets: &mut DisjointSets, narrow: f64) {
    use std::collections::BTreeMap;
    let n = s.tris.len();
    let mut area: BTreeMap<usize, f64> = BTreeMap::new();
    // Border length between each two neighbouring patches, both ways.
    let mut adj: BTreeMap<usize, BTreeMap<usize, f64>> = BTreeMap::new();
    for t in 0..n {
        let [a, b, c] = s.tris[t].map(|v| s.points[v]);
        *area.entry(sets.root(t)).or_default() += 0.5 * (b - a).cross(c - a).length();
        for k in 0..3 {
            let w = s.neighbors[t][k];
            let (rt, rw) = (sets.root(t), sets.root(w));
            if w > t && rt != rw {
                let len = s.points[s.tris[t][k]].distance(s.points[s.tris[t][(k + 1) % 3]]);
                *adj.entry(rt).or_default().entry(rw).or_default() += len;
                *adj.entry(rw).or_default().entry(rt).or_default() += len;
            }
        }
    }
    let width = |r: usize, area: &BTreeMap<usize, f64>, adj: &BTreeMap<usize, BTreeMap<usize, f64>>| {
        let perimeter: f64 = adj.get(&r).map_or(0.0, |m| m.values().sum());
        if perimeter > 0.0 {
            2.0 * area[&r] / perimeter
        } else {
            f64::INFINITY
        }
    };
    let mut todo: Vec<(f64, usize)> =
        adj.keys().map(|&r| (width(r, &area, &adj), r)).filter(|x| x.0 < narrow).collect();
    // Narrowest last (popped first).
    todo.sort_by(|a, b| b.0.total_cmp(&a.0).then(b.1.cmp(&a.1)));
    while let Some((_, thin)) = todo.pop() {
        if sets.root(thin) != thin || width(thin, &area, &adj) >= narrow {
            continue;
        }
        let Some(into) = adj[&thin].iter().max_by(|x, y| x.1.total_cmp(y.1).then(y.0.cmp(x.0))).map(|x| *x.0) else {
            continue;
        };
        sets.join(thin, into);
        let root = sets.root(thin);
        let gone = if root == thin { into } else { thin };
        // The gone patch's area and borders move to the root.
        let a = area.remove(&gone).unwrap_or(0.0);
        *area.entry(root).or_default() += a;
        let borders = adj.remove(&gone).unwrap_or_default();
        for (x, l) in borders {
            let mx = adj.get_mut(&x).expect("borders are kept both ways");
            mx.remove(&gone);
            if x != root {
                *mx.entry(root).or_default() += l;
                *adj.get_mut(&root).expect("a patch with borders").entry(x).or_default() += l;
            }
        }
        let w = width(root, &area, &adj);
        if w < narrow {
            todo.push((w, root));
        }
    }
}

/// The parameter in [0, 1] of the nearest point of segment `s` to `p`.
fn on_segment(p: DVec3, s: [DVec3; 2]) -> f64 {
    let d = s[1] - s[0];
    let l2 = d.length_squared();
    if l2 > 0.0 {
        ((p - s[0]).dot(d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

impl Creases for TriSurface {
    fn patch(&self, p: DVec3) -> Option<u32> {
        let data = self.crease_data()?;
        Some(data.patch[self.closest(p).triangle])
    }
    fn corners(&self) -> &[DVec3] {
        self.crease_data().map_or(&[], |d| &d.corners)
    }
    fn pins(&self) -> &[DVec3] {
        self.crease_data().map_or(&[], |d| &d.pins)
    }
    fn triangulation(&self) -> Option<LabelledTriangulation> {
        let data = self.crease_data()?;
        Some(LabelledTriangulation {
            points: self.points.clone(),
            triangles: self.tris.clone(),
            patch: data.patch.clone(),
        })
    }
    fn onto(&self, a: u32, b: u32, p: DVec3) -> Option<(DVec3, DVec3)> {
        let segs = self.crease_data()?.curves.get(&(a.min(b), a.max(b)))?;
        // The nearest input edge, then the point of its curve piece at the same parameter.
        let mut best: Option<(f64, usize, f64)> = None;
        for (k, c) in segs.iter().enumerate() {
            let t = on_segment(p, [c.a, c.b]);
            let d2 = (c.a + (c.b - c.a) * t).distance_squared(p);
            if best.is_none_or(|b| d2 < b.0) {
                best = Some((d2, k, t));
            }
        }
        best.map(|(_, k, t)| segs[k].at(t))
    }
}
