//! What makes a triangle mesh the boundary of a solid, checked before any distance is taken:
//! finite coordinates, no degenerate triangle, every edge shared by exactly two triangles,
//! every vertex a single fan, a consistent orientation (repaired when only some triangles are
//! reversed) with outward normals, and no two triangles crossing.

use super::bvh::Bvh;
use crate::predicates::{orient2d, orient3d, Sign};
use crate::FastMap;
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use thiserror::Error;

/// Why a triangle mesh is no closed surface. Triangles and vertices are numbered from 0 in the
/// order of the input after exact duplicate vertices are merged.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum SurfaceError {
    /// No triangles at all.
    #[error("the surface has no triangles (empty input)")]
    Empty,
    /// A triangle names a vertex that does not exist.
    #[error("triangle {triangle} uses vertex {vertex} but there are {count} vertices")]
    BadIndex {
        /// The triangle.
        triangle: usize,
        /// The index it uses.
        vertex: usize,
        /// The number of vertices.
        count: usize,
    },
    /// A NaN or infinite coordinate.
    #[error("vertex {vertex} has a non-finite coordinate {at:?}")]
    NonFinite {
        /// The vertex.
        vertex: usize,
        /// Its coordinates.
        at: [f64; 3],
    },
    /// A triangle with a repeated vertex or no area.
    #[error("triangle {triangle} is degenerate (zero area) at {at:?}")]
    Degenerate {
        /// The triangle.
        triangle: usize,
        /// Its first corner.
        at: [f64; 3],
    },
    /// An edge with one triangle: the surface has a hole and bounds no solid.
    #[error(
        "the surface is open: the edge from {a:?} to {b:?} (of triangle {triangle}) has no second triangle \
         ({edges} such boundary edges); close the holes first"
    )]
    Open {
        /// A triangle on the hole's rim.
        triangle: usize,
        /// The edge's ends.
        a: [f64; 3],
        /// The edge's ends.
        b: [f64; 3],
        /// How many edges have one triangle.
        edges: usize,
    },
    /// An edge with three or more triangles.
    #[error(
        "the surface is non-manifold: the edge from {a:?} to {b:?} is shared by {count} triangles (first {triangle})"
    )]
    NonManifoldEdge {
        /// The first triangle on it.
        triangle: usize,
        /// The edge's ends.
        a: [f64; 3],
        /// The edge's ends.
        b: [f64; 3],
        /// How many triangles share it.
        count: usize,
    },
    /// A vertex where two or more separate fans of triangles meet (two solids touching at a point).
    #[error("the surface is non-manifold at vertex {vertex} {at:?}: {fans} separate fans of triangles meet there")]
    NonManifoldVertex {
        /// The vertex.
        vertex: usize,
        /// Its coordinates.
        at: [f64; 3],
        /// How many fans.
        fans: usize,
    },
    /// No consistent orientation exists (a Klein bottle's triangulation, say).
    #[error("the surface is not orientable: the triangles around triangle {triangle} cannot all face one way")]
    NotOrientable {
        /// Where the conflict was found.
        triangle: usize,
    },
    /// Two triangles that share no vertex cross or touch.
    #[error("the surface intersects itself: triangles {} and {} cross near {at:?}", .triangles[0], .triangles[1])]
    SelfIntersecting {
        /// The two triangles.
        triangles: [usize; 2],
        /// The first corner of the first one.
        at: [f64; 3],
    },
}

/// The (triangle, local edge) pairs on one undirected edge.
type EdgeUses = smallvec::SmallVec<[(usize, u8); 2]>;

/// The checked connectivity: for each triangle, the triangle across each of its edges (edge k
/// from corner k to corner k + 1).
pub(super) struct Checked {
    pub tris: Vec<[usize; 3]>,
    pub neighbors: Vec<[usize; 3]>,
}

/// Checks everything but self-intersection (which needs the hierarchy, see [`self_intersection`])
/// and orients the triangles outward.
pub(super) fn check(points: &[DVec3], mut tris: Vec<[usize; 3]>) -> Result<Checked, SurfaceError> {
    if tris.is_empty() {
        return Err(SurfaceError::Empty);
    }
    for (i, p) in points.iter().enumerate() {
        if !p.is_finite() {
            return Err(SurfaceError::NonFinite { vertex: i, at: p.to_array() });
        }
    }
    for (t, tri) in tris.iter().enumerate() {
        if let Some(&v) = tri.iter().find(|&&v| v >= points.len()) {
            return Err(SurfaceError::BadIndex { triangle: t, vertex: v, count: points.len() });
        }
        let [a, b, c] = tri.map(|v| points[v]);
        if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || (b - a).cross(c - a).length_squared() == 0.0 {
            return Err(SurfaceError::Degenerate { triangle: t, at: a.to_array() });
        }
    }
    let at = |v: usize| points[v].to_array();
    // Undirected edge -> the (triangle, local edge) uses.
    let mut uses: FastMap<(usize, usize), EdgeUses> = FastMap::default();
    uses.reserve(tris.len() * 3 / 2);
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            uses.entry((a.min(b), a.max(b))).or_default().push((t, k as u8));
        }
    }
    let mut open = 0;
    let mut first_open: Option<(usize, usize, usize)> = None;
    let mut first_many: Option<(usize, usize, usize, usize)> = None;
    for (&(a, b), u) in &uses {
        let t0 = u.iter().map(|x| x.0).min().unwrap_or(0);
        if u.len() == 1 {
            open += 1;
            if first_open.is_none_or(|f| t0 < f.0) {
                first_open = Some((t0, a, b));
            }
        } else if u.len() > 2 && first_many.is_none_or(|f| t0 < f.0) {
            first_many = Some((t0, a, b, u.len()));
        }
    }
    if let Some((t, a, b, count)) = first_many {
        return Err(SurfaceError::NonManifoldEdge { triangle: t, a: at(a), b: at(b), count });
    }
    if let Some((t, a, b)) = first_open {
        return Err(SurfaceError::Open { triangle: t, a: at(a), b: at(b), edges: open });
    }
    let mut neighbors = vec![[usize::MAX; 3]; tris.len()];
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let u = &uses[&(a.min(b), a.max(b))];
            neighbors[t][k] = if u[0].0 == t { u[1].0 } else { u[0].0 };
        }
    }
    // One fan per vertex: the triangles reached around it across shared edges are all of them.
    let mut count = vec![0u32; points.len()];
    for tri in &tris {
        for &v in tri {
            count[v] += 1;
        }
    }
    let mut seen_fan = vec![false; points.len()];
    for (t, tri) in tris.iter().enumerate() {
        for &v in tri {
            if seen_fan[v] {
                continue;
            }
            seen_fan[v] = true;
            // Walk around v from t: across the edges of each triangle that contain v.
            let (mut prev, mut cur, mut n) = (usize::MAX, t, 0u32);
            loop {
                n += 1;
                let c = tris[cur];
                let next = (0..3)
                    .filter(|&k| c[k] == v || c[(k + 1) % 3] == v)
                    .map(|k| neighbors[cur][k])
                    .find(|&w| w != prev)
                    .unwrap_or(prev);
                prev = cur;
                cur = next;
                if cur == t || n > count[v] {
                    break;
                }
            }
            if n != count[v] {
                let fans = (count[v] as usize).div_ceil(n.max(1) as usize).max(2);
                return Err(SurfaceError::NonManifoldVertex { vertex: v, at: at(v), fans });
            }
        }
    }
    orient(points, &mut tris, &neighbors)?;
    // Turned triangles have their edges in another order: recompute who is across which.
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let u = &uses[&(a.min(b), a.max(b))];
            neighbors[t][k] = if u[0].0 == t { u[1].0 } else { u[0].0 };
        }
    }
    Ok(Checked { tris, neighbors })
}

/// Makes the orientation consistent in each connected component (flipping triangles that
/// disagree with their first-met neighbour), then outward: a component not inside another has
/// positive enclosed volume, one inside an odd number of others (a cavity) negative.
fn orient(points: &[DVec3], tris: &mut [[usize; 3]], neighbors: &[[usize; 3]]) -> Result<(), SurfaceError> {
    let n = tris.len();
    let mut comp = vec![usize::MAX; n];
    let mut flip = vec![false; n];
    let mut comps: Vec<Vec<usize>> = Vec::new();
    let has_edge = |tri: &[usize; 3], a: usize, b: usize| (0..3).any(|k| tri[k] == a && tri[(k + 1) % 3] == b);
    for s in 0..n {
        if comp[s] != usize::MAX {
            continue;
        }
        let id = comps.len();
        let mut members = vec![s];
        comp[s] = id;
        let mut i = 0;
        while i < members.len() {
            let t = members[i];
            i += 1;
            let tt = tris[t];
            for k in 0..3 {
                // neighbors[t][k] is across the input's edge k of t; as t now runs it.
                let w = neighbors[t][k];
                let (a, b) = if flip[t] { (tt[(k + 1) % 3], tt[k]) } else { (tt[k], tt[(k + 1) % 3]) };
                // Consistent when w runs the shared edge the other way.
                let w_same = has_edge(&tris[w], a, b);
                let want_flip = w_same;
                if comp[w] == usize::MAX {
                    comp[w] = id;
                    flip[w] = want_flip;
                    members.push(w);
                } else {
                    let mut wt = tris[w];
                    if flip[w] {
                        wt.swap(1, 2);
                    }
                    if has_edge(&wt, a, b) {
                        return Err(SurfaceError::NotOrientable { triangle: w });
                    }
                }
            }
        }
        comps.push(members);
    }
    for t in 0..n {
        if flip[t] {
            tris[t].swap(1, 2);
        }
    }
    let volume = |members: &[usize], tris: &[[usize; 3]]| -> f64 {
        members
            .iter()
            .map(|&t| {
                let [a, b, c] = tris[t].map(|v| points[v]);
                a.dot(b.cross(c))
            })
            .sum::<f64>()
    };
    // Nesting depth of each component: how many others hold one of its vertices (by their
    // winding number, whose magnitude does not depend on their orientation). Skipped past
    // MAX_NESTED components, where every component is taken as an outer one.
    const MAX_NESTED: usize = 64;
    let depth: Vec<usize> = if comps.len() > 1 && comps.len() <= MAX_NESTED {
        (0..comps.len())
            .map(|c| {
                let p = points[tris[comps[c][0]][0]];
                (0..comps.len())
                    .filter(|&o| o != c)
                    .filter(|&o| {
                        let w: f64 = comps[o]
                            .iter()
                            .map(|&t| {
                                let [a, b, cc] = tris[t].map(|v| points[v]);
                                super::distance::solid_angle(p, a, b, cc)
                            })
                            .sum();
                        (w / (4.0 * std::f64::consts::PI)).abs() > 0.5
                    })
                    .count()
            })
            .collect()
    } else {
        vec![0; comps.len()]
    };
    for (c, members) in comps.iter().enumerate() {
        let v = volume(members, tris);
        let want_positive = depth[c] % 2 == 0;
        if (v > 0.0) != want_positive {
            for &t in members {
                tris[t].swap(1, 2);
            }
        }
    }
    Ok(())
}

/// The first pair (by the lower triangle index) of triangles sharing no vertex that cross or
/// touch, by exact orientation tests. Triangles sharing a vertex or an edge are not tested
/// against each other.
pub(super) fn self_intersection(points: &[DVec3], tris: &[[usize; 3]], bvh: &Bvh) -> Option<[usize; 2]> {
    (0..tris.len()).into_par_iter().find_map_first(|i| {
        let ti = tris[i].map(|v| points[v]);
        let (lo, hi) = (ti[0].min(ti[1]).min(ti[2]), ti[0].max(ti[1]).max(ti[2]));
        let mut hit: Option<usize> = None;
        bvh.overlapping(lo, hi, |j| {
            if j <= i || hit.is_some_and(|h| h < j) || tris[j].iter().any(|v| tris[i].contains(v)) {
                return;
            }
            if triangles_meet(ti, tris[j].map(|v| points[v])) {
                hit = Some(j);
            }
        });
        hit.map(|j| [i, j])
    })
}

/// Whether two closed triangles share a point (exact).
fn triangles_meet(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    let sb = b.map(|q| orient3d(a[0], a[1], a[2], q));
    if sb.iter().all(|&s| s == Sign::Positive) || sb.iter().all(|&s| s == Sign::Negative) {
        return false;
    }
    let sa = a.map(|q| orient3d(b[0], b[1], b[2], q));
    if sa.iter().all(|&s| s == Sign::Positive) || sa.iter().all(|&s| s == Sign::Negative) {
        return false;
    }
    if sb.iter().all(|&s| s == Sign::Zero) {
        return coplanar_meet(a, b);
    }
    // Not coplanar: the intersection, if any, is a segment whose ends lie on edges, so some
    // edge of one triangle meets the other.
    (0..3).any(|k| segment_meets(a[k], a[(k + 1) % 3], b)) || (0..3).any(|k| segment_meets(b[k], b[(k + 1) % 3], a))
}

/// Whether the closed segment pq meets the closed triangle t, for p, q not both in t's plane.
fn segment_meets(p: DVec3, q: DVec3, t: [DVec3; 3]) -> bool {
    let (o1, o2) = (orient3d(t[0], t[1], t[2], p), orient3d(t[0], t[1], t[2], q));
    if (o1 == o2 && o1 != Sign::Zero) || (o1 == Sign::Zero && o2 == Sign::Zero) {
        return false;
    }
    let s = [orient3d(p, q, t[0], t[1]), orient3d(p, q, t[1], t[2]), orient3d(p, q, t[2], t[0])];
    !(s.contains(&Sign::Positive) && s.contains(&Sign::Negative))
}

/// Coplanar triangles, in the coordinate plane the normal is most nearly perpendicular to.
fn coplanar_meet(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    let n = (a[1] - a[0]).cross(a[2] - a[0]).abs();
    let drop = if n.x >= n.y && n.x >= n.z {
        0
    } else if n.y >= n.z {
        1
    } else {
        2
    };
    let flat = |p: DVec3| match drop {
        0 => DVec2::new(p.y, p.z),
        1 => DVec2::new(p.z, p.x),
        _ => DVec2::new(p.x, p.y),
    };
    let (a, b) = (a.map(flat), b.map(flat));
    let inside = |p: DVec2, t: [DVec2; 3]| {
        let s = [orient2d(t[0], t[1], p), orient2d(t[1], t[2], p), orient2d(t[2], t[0], p)];
        !(s.contains(&Sign::Positive) && s.contains(&Sign::Negative))
    };
    let cross = |p: DVec2, q: DVec2, r: DVec2, s: DVec2| {
        let (o1, o2) = (orient2d(p, q, r), orient2d(p, q, s));
        let (o3, o4) = (orient2d(r, s, p), orient2d(r, s, q));
        o1 != o2 && o3 != o4 && o1 != Sign::Zero && o2 != Sign::Zero && o3 != Sign::Zero && o4 != Sign::Zero
    };
    a.iter().any(|&p| inside(p, b))
        || b.iter().any(|&p| inside(p, a))
        || (0..3).any(|i| (0..3).any(|j| cross(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3])))
}
