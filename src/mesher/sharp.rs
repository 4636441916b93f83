//! The thresholds of sharp-feature detection, shared by the 2-D corner finder
//! (`planar::features`) and the 3-D edge and corner finder (`volume::features`). Lengths are
//! in sample spacings: the 2-D grid's spacing, or the 3-D surface start points' gap (times h).
//! The geometric constructions on a 3-D zero set (the point where two faces' tangent planes
//! meet, its refinement onto a curved edge, corners where three faces meet) are shared by the
//! 3-D mesher's start and the surface mesher's feature curves.

use crate::Error;
use glam::DVec3;
use std::collections::HashMap;

/// Normals differing by more than this many degrees mark a corner or an edge.
pub(crate) const SHARP_DEG: f64 = 40.0;
/// Pairs of boundary samples are looked at up to this many spacings apart.
pub(crate) const REACH: f64 = 1.6;
/// A point where tangent lines (planes) meet is kept when the projection moves it by at most
/// this many spacings: more, and the boundary is curved, not sharp, there.
pub(crate) const TOL: f64 = 0.1;
/// The probes on either side of a sample are this many spacings away from it.
pub(crate) const PROBE: f64 = 1e-3;
/// Held points are at least this many target lengths (h0 h) apart, and as far from the user's
/// fixed points.
pub(crate) const SPACING: f64 = 1.0;
/// Steps of the refinement onto a curved side or edge (tangents taken ever closer).
pub(crate) const REFINE_STEPS: usize = 3;

/// The two probe normals that differ most (smallest dot product), with that dot product: a
/// sample whose probes split this widely lies on a sharp feature itself.
pub(crate) fn widest_split<P: Copy>(probes: &[P], dot: impl Fn(P, P) -> f64) -> Option<(f64, P, P)> {
    probes
        .iter()
        .flat_map(|&a| probes.iter().map(move |&b| (a, b)))
        .map(|(a, b)| (dot(a, b), a, b))
        .min_by(|x, y| x.0.total_cmp(&y.0))
}

/// The point nearest `m` on the line where the plane through `q1` with unit normal `n1` meets
/// the plane through `q2` with unit normal `n2` (x = m + alpha n1 + beta n2 on both planes).
/// Not finite when the planes are parallel.
pub(crate) fn planes_meet(q1: DVec3, n1: DVec3, q2: DVec3, n2: DVec3, m: DVec3) -> DVec3 {
    let cos = n1.dot(n2);
    let (r1, r2) = (n1.dot(q1 - m), n2.dot(q2 - m));
    let det = 1.0 - cos * cos;
    m + n1 * ((r1 - cos * r2) / det) + n2 * ((r2 - cos * r1) / det)
}

/// What the feature finders ask of a geometry: the projection onto its zero set (`None` where it
/// fails without an error) and its gradient. The 3-D mesher and the surface mesher each wrap
/// their own projection.
pub(crate) trait Zero {
    /// The projection of `p` onto the zero set.
    fn project(&self, p: DVec3) -> Result<Option<DVec3>, Error>;
    /// The gradient at `p`.
    fn gradient(&self, p: DVec3) -> DVec3;
}

/// One step of the construction that puts a point on an edge where two faces meet: a point of
/// each face `delta` from `x` across the edge (of the two ways, the one whose normal, taken a
/// little inside, stays with the face), the point of both faces' tangent planes there nearest
/// `x`, projected onto the zero set. Returns the new point and the two faces' normals, or
/// `None` when a face is not found or the planes are nearly parallel.
pub(crate) fn crease_step(
    g: &dyn Zero,
    x: DVec3,
    a: DVec3,
    b: DVec3,
    delta: f64,
) -> Result<Option<(DVec3, DVec3, DVec3)>, Error> {
    let face = |n: DVec3, other: DVec3| -> Result<Option<(DVec3, DVec3)>, Error> {
        let Some(across) = (other - n * n.dot(other)).try_normalize() else { return Ok(None) };
        let mut best: Option<(f64, DVec3, DVec3)> = None;
        for dir in [across, -across] {
            if let Some(q) = g.project(x + dir * delta)? {
                let m = g.gradient(q - n * (1e-3 * delta)).normalize_or_zero();
                // A sample of this face, not of the other: nearer n than `other`. Two samples
                // of one face meet nowhere near the edge (near a curved concave edge they put
                // the edge point back on the face it started on).
                let here = m.dot(n) > m.dot(other);
                if m.length_squared() > 0.5 && here && best.is_none_or(|(c, _, _)| m.dot(n) > c) {
                    best = Some((m.dot(n), q, m));
                }
            }
        }
        Ok(best.map(|(_, q, m)| (q, m)))
    };
    let (Some((q1, m1)), Some((q2, m2))) = (face(a, b)?, face(b, a)?) else { return Ok(None) };
    if 1.0 - m1.dot(m2).powi(2) < 1e-6 {
        return Ok(None);
    }
    let y = planes_meet(q1, m1, q2, m2, x);
    Ok(g.project(y)?.map(|y| (y, m1, m2)))
}

/// Moves the edge point `p` (faces of normals `n1`, `n2`) to the point nearest it on the line
/// where the faces' tangent planes meet, the planes taken at points of each face ever closer to
/// it (from a tenth of `s` down by ten each, REFINE_STEPS steps of [`crease_step`]): exact
/// already for planar faces; on a curved edge (a cylinder's rim) the error falls with the
/// square of the distance.
pub(crate) fn refine_edge_point(g: &dyn Zero, p: DVec3, n1: DVec3, n2: DVec3, s: f64) -> Result<DVec3, Error> {
    let (mut x, mut a, mut b) = (p, n1, n2);
    let mut delta = 0.1 * s;
    for _ in 0..REFINE_STEPS {
        let Some((y, m1, m2)) = crease_step(g, x, a, b, delta)? else { break };
        if y.distance(x) > 2.0 * delta {
            break;
        }
        (x, a, b) = (y, m1, m2);
        delta *= 0.1;
    }
    Ok(x)
}

/// A corner found by [`corner_points`]: the point and the normals of its three faces.
pub(crate) type Corner = (DVec3, [DVec3; 3]);

/// Corners where three faces meet, from points on edges (`found`, each with the normals of its
/// two faces, in cells of side `gap`; `limits(p)` is how far apart two of them may be and how far
/// the projection may move a corner): two such points within reach whose faces bring a third
/// normal (more than SHARP_DEG from both of the first point's) meet at the point of all three
/// tangent planes, kept when its projection onto the zero set moves it by at most the limit.
/// The points are only as good as the edge points they come from: [`refine_corner`] puts one
/// on the corner.
pub(crate) fn corner_points(
    g: &dyn Zero,
    found: &[(DVec3, DVec3, DVec3)],
    gap: f64,
    limits: &dyn Fn(DVec3) -> Result<(f64, f64), Error>,
) -> Result<Vec<Corner>, Error> {
    let cos_max = SHARP_DEG.to_radians().cos();
    let cell = |p: DVec3| (p / gap).floor().as_i64vec3().to_array();
    let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (k, f) in found.iter().enumerate() {
        cells.entry(cell(f.0)).or_default().push(k);
    }
    let distinct = |n: DVec3, m: DVec3| {
        let c = n.dot(m);
        c < cos_max && c > -cos_max
    };
    let mut corners = Vec::new();
    for (k, &(pa, a1, a2)) in found.iter().enumerate() {
        let (reach, tol) = limits(pa)?;
        let span = (reach / gap).ceil() as i64;
        let c = cell(pa);
        for dz in -span..=span {
            for dy in -span..=span {
                for dx in -span..=span {
                    let Some(list) = cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else { continue };
                    for &j in list {
                        let (pb, b1, b2) = found[j];
                        if j <= k || pb.distance(pa) > reach {
                            continue;
                        }
                        for nb in [b1, b2] {
                            if !distinct(nb, a1) || !distinct(nb, a2) {
                                continue;
                            }
                            let m = glam::DMat3::from_cols(a1, a2, nb).transpose();
                            if m.determinant().abs() < 0.1 {
                                continue;
                            }
                            let x = m.inverse() * DVec3::new(a1.dot(pa), a2.dot(pa), nb.dot(pb));
                            if !x.is_finite() || x.distance(pa) > reach {
                                continue;
                            }
                            let Some(p) = g.project(x)? else { continue };
                            if p.distance(x) <= tol {
                                corners.push((p, [a1, a2, nb]));
                            }
                        }
                    }
                }
            }
        }
    }
    Ok(corners)
}

/// Steps of [`refine_corner`].
const CORNER_STEPS: usize = 8;
/// Directions, evenly spread in a face's tangent plane, in which [`refine_corner`] looks for a
/// point of that face.
const CORNER_DIRS: usize = 8;

/// Moves the corner point `x` (faces of normals `n`) onto the corner: the point of the three
/// faces' tangent planes, the planes taken at points of each face ever closer to it (from a
/// tenth of `s` down by ten each, no nearer than `finest`), projected onto the zero set. Exact
/// already for planar faces, whatever edge points `x` was found from (a corner from the
/// tangent planes at a rotated box's start vertices was 0.14 h off); on curved faces the error
/// falls with the square of the distance. `x` unchanged when a face is not found. Returns the
/// point and the three faces' normals there.
pub(crate) fn refine_corner(g: &dyn Zero, x: DVec3, n: [DVec3; 3], s: f64, finest: f64) -> Result<Corner, Error> {
    let (mut x, mut n) = (x, n);
    let mut delta = 0.1 * s;
    for _ in 0..CORNER_STEPS {
        // Farther from the corner than delta a face is not met: wider samples then.
        let planes = loop {
            match corner_planes(g, x, n, delta)? {
                Some(p) => break p,
                None if delta < s => delta *= 3.0,
                None => return Ok((x, n)),
            }
        };
        let m = glam::DMat3::from_cols(planes[0].1, planes[1].1, planes[2].1).transpose();
        if m.determinant().abs() < 0.1 {
            return Ok((x, n));
        }
        let y = m.inverse()
            * DVec3::new(planes[0].1.dot(planes[0].0), planes[1].1.dot(planes[1].0), planes[2].1.dot(planes[2].0));
        let Some(z) = g.project(y)? else { return Ok((x, n)) };
        if !z.is_finite() || z.distance(x) > 2.0 * delta {
            return Ok((x, n));
        }
        let moved = z.distance(x);
        x = z;
        n = planes.map(|p| p.1);
        if moved <= 1e-12 * s || delta <= finest {
            break;
        }
        delta = (0.1 * delta).max(finest);
    }
    Ok((x, n))
}

/// A point and the normal of each face of normals `n` about `delta` from `x` ([`corner_face`]),
/// or `None` when a face is not met.
fn corner_planes(g: &dyn Zero, x: DVec3, n: [DVec3; 3], delta: f64) -> Result<Option<[(DVec3, DVec3); 3]>, Error> {
    let mut planes = [(DVec3::ZERO, DVec3::ZERO); 3];
    for i in 0..3 {
        let Some(p) = corner_face(g, x, n[i], n[(i + 1) % 3], n[(i + 2) % 3], delta)? else { return Ok(None) };
        planes[i] = p;
    }
    Ok(Some(planes))
}

/// A point of the face of normal `ni` about `delta` from `x` (not of the faces of normals `o1`,
/// `o2`: its normal, taken a little inside, nearer `ni` than either) and its normal; of those met
/// in CORNER_DIRS directions, the one whose normal is nearest `ni`.
fn corner_face(
    g: &dyn Zero,
    x: DVec3,
    ni: DVec3,
    o1: DVec3,
    o2: DVec3,
    delta: f64,
) -> Result<Option<(DVec3, DVec3)>, Error> {
    let (t1, t2) = ni.any_orthonormal_pair();
    let mut best: Option<(f64, DVec3, DVec3)> = None;
    for k in 0..CORNER_DIRS {
        let a = std::f64::consts::TAU * k as f64 / CORNER_DIRS as f64;
        let Some(q) = g.project(x + (t1 * a.cos() + t2 * a.sin()) * delta)? else { continue };
        let m = g.gradient(q - ni * (1e-3 * delta)).normalize_or_zero();
        let c = m.dot(ni);
        if m.length_squared() > 0.5 && c > m.dot(o1) && c > m.dot(o2) && best.is_none_or(|b| c > b.0) {
            best = Some((c, q, m));
        }
    }
    Ok(best.map(|b| (b.1, b.2)))
}
