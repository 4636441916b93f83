//! The input's sharp features in the form the surface mesher holds them: the triangles grouped
//! into smooth patches (connected across every edge that is not a feature edge), the feature
//! edges grouped by the two patches they separate, and the corners where three or more patches
//! meet. The surface mesher labels its own triangles by the patch under them, so that a mesh
//! vertex between two labels lies on the curve of that pair and is projected onto the input's
//! own edges there, exactly (see [`crate::geometry::Creases`]).

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
    /// The feature edges between each two patches (lower label first), as segments.
    curves: HashMap<(u32, u32), Vec<[DVec3; 2]>>,
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
        let mut curves: HashMap<(u32, u32), Vec<[DVec3; 2]>> = HashMap::new();
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
                    curves.entry((a.min(b), a.max(b))).or_default().push([s.points[i], s.points[j]]);
                    along[i].push(j);
                    along[j].push(i);
                }
            }
        }
        if curves.is_empty() {
            return None;
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

/// The nearest point of segment `s` to `p`.
fn on_segment(p: DVec3, s: [DVec3; 2]) -> DVec3 {
    let d = s[1] - s[0];
    let l2 = d.length_squared();
    let t = if l2 > 0.0 { ((p - s[0]).dot(d) / l2).clamp(0.0, 1.0) } else { 0.0 };
    s[0] + d * t
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
        let mut best: Option<(f64, DVec3, DVec3)> = None;
        for &s in segs {
            let q = on_segment(p, s);
            let d2 = q.distance_squared(p);
            if best.is_none_or(|b| d2 < b.0) {
                best = Some((d2, q, (s[1] - s[0]).normalize_or_zero()));
            }
        }
        best.map(|(_, q, t)| (q, t))
    }
}
