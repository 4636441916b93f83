//! Sharp corners of a 2-D domain, found from d alone, to be held as fixed points: the seed keeps
//! sharp features with fixed points (section 2.5), and a corner left free is rounded off by the
//! projection (a square without its corners given lost area at each of them).
//!
//! Boundary samples come from a grid: the grid points within one spacing of d = 0, projected
//! onto it, each with its unit normal. Two samples closer than REACH spacings whose normals
//! differ by more than SHARP_DEG degrees straddle a corner: the point where their tangent
//! lines meet, projected onto d = 0, is on it (exactly where the sides are straight). A sample
//! whose normals differ on either side of it lies on a corner itself. The candidates are thinned
//! to one per SPACING target lengths, the first in grid order kept, and each kept one is moved
//! to where the tangent lines taken ever closer to it meet ([`refine`]: curved sides).

use super::Options2;
use crate::geometry::Implicit2;
use crate::mesher::input::{eval_d, eval_h_floor};
use crate::mesher::sharp::{PROBE, REACH, REFINE_STEPS, SHARP_DEG, SPACING, TOL};
use crate::Error;
use glam::DVec2;
use std::collections::HashMap;

/// Grid points per side at most (as the survey).
const MAX_SIDE: usize = 512;

/// The corners of `domain` in `opts`'s box, not within a target length of a fixed point.
/// `h_floor` is the smallest relative size inside (the survey's).
pub(crate) fn find(
    domain: &dyn Implicit2,
    opts: &Options2,
    h_floor: f64,
    project: &dyn Fn(DVec2) -> Result<Option<DVec2>, Error>,
) -> Result<Vec<DVec2>, Error> {
    let [lo, hi] = opts.bbox;
    let ext = hi - lo;
    let nx = ((ext.x / opts.h0).ceil() as usize + 1).clamp(8, MAX_SIDE);
    let ny = ((ext.y / opts.h0).ceil() as usize + 1).clamp(8, MAX_SIDE);
    let step = DVec2::new(ext.x / (nx - 1) as f64, ext.y / (ny - 1) as f64);
    let s = step.x.max(step.y);
    let cos_max = SHARP_DEG.to_radians().cos();
    let normal = |p: DVec2| domain.gradient(p).normalize_or_zero();
    // Samples in grid order, and a hash of them by cell of side s.
    let mut samples: Vec<(DVec2, DVec2)> = Vec::new();
    let mut cells: HashMap<[i64; 2], Vec<usize>> = HashMap::new();
    let cell = |p: DVec2| ((p - lo) / s).floor().as_i64vec2().to_array();
    for j in 0..ny {
        for i in 0..nx {
            let p = lo + DVec2::new(i as f64, j as f64) * step;
            let d = eval_d(domain, p)?;
            let g = if domain.is_distance() { 1.0 } else { domain.gradient(p).length() };
            // (A NaN gradient fails the first test.)
            if g.is_nan() || g <= 0.0 || (d / g).abs() > s {
                continue;
            }
            let Some(q) = project(p)? else { continue };
            // The normal where d is smooth off the boundary: on it, a distance built from
            // unsigned distances (a polygon's) has no gradient.
            let n = [normal(p), normal(q)].into_iter().find(|n| n.length_squared() > 0.5);
            let Some(n) = n else { continue };
            cells.entry(cell(q)).or_default().push(samples.len());
            samples.push((q, n));
        }
    }
    // Candidates with the normals of their two sides.
    let mut found: Vec<(DVec2, DVec2, DVec2)> = Vec::new();
    let reach = REACH * s;
    let span = REACH.ceil() as i64;
    for (k, &(q1, n1)) in samples.iter().enumerate() {
        let eps = PROBE * s;
        // Probes a little inside (off the kink of d on d = 0) on every side of the sample.
        let probes = [DVec2::X, DVec2::NEG_X, DVec2::Y, DVec2::NEG_Y].map(|e| normal(q1 + (e - n1) * eps));
        // A probe without a normal says nothing.
        let probes: Vec<DVec2> = probes.into_iter().filter(|n| n.length_squared() > 0.5).collect();
        let split = crate::mesher::sharp::widest_split(&probes, DVec2::dot);
        if let Some((cos, a, b)) = split {
            if cos < cos_max {
                found.push((q1, a, b));
            }
        }
        let c = cell(q1);
        for dy in -span..=span {
            for dx in -span..=span {
                let Some(list) = cells.get(&[c[0] + dx, c[1] + dy]) else { continue };
                for &k2 in list {
                    // Each pair once.
                    if k2 <= k {
                        continue;
                    }
                    let (q2, n2) = samples[k2];
                    let cos = n1.dot(n2);
                    if q2.distance(q1) > reach || cos > cos_max || cos < -cos_max {
                        continue;
                    }
                    // The tangent lines n1 . x = n1 . q1 and n2 . x = n2 . q2 meet at x.
                    let Some(x) = meet(q1, n1, q2, n2) else { continue };
                    if x.distance((q1 + q2) * 0.5) > reach {
                        continue;
                    }
                    let Some(p) = project(x)? else { continue };
                    if p.distance(x) <= TOL * s {
                        found.push((p, n1, n2));
                    }
                }
            }
        }
    }
    let mut kept: Vec<DVec2> = Vec::new();
    for (p, n1, n2) in found {
        if p.cmplt(lo).any() || p.cmpgt(hi).any() {
            continue;
        }
        let gap = SPACING * opts.h0 * eval_h_floor(opts, p, h_floor)? / h_floor;
        if kept.iter().chain(&opts.fixed).any(|k| k.distance(p) < gap) {
            continue;
        }
        let x = refine(p, n1, n2, s, &normal, project)?;
        if !smooth_turn(x, n1, n2, s, &normal, project)? {
            kept.push(x);
        }
    }
    Ok(kept)
}

/// True when the boundary turns smoothly at `x` (a tight curve such as a thin ellipse's tip or
/// a leading edge, not a corner): on a smooth curve of radius R the normals a step delta either
/// way along it differ by about 2 delta / R, so the turn halves with the step, while at a corner
/// it stays the angle of the corner. Tried with delta half the spacing `s`, then a tenth and a
/// hundredth of that (a curve tighter than the spacing looks like a corner until the step is
/// below its radius); a scale where the turn is under a degree says nothing (both probes on one
/// side of a corner).
fn smooth_turn(
    x: DVec2,
    n1: DVec2,
    n2: DVec2,
    s: f64,
    normal: &dyn Fn(DVec2) -> DVec2,
    project: &dyn Fn(DVec2) -> Result<Option<DVec2>, Error>,
) -> Result<bool, Error> {
    let bisector = (n1 + n2).normalize_or_zero();
    let t = if bisector.length_squared() > 0.5 { bisector.perp() } else { n1.perp() };
    let turn = |delta: f64| -> Result<Option<f64>, Error> {
        let mut m = [DVec2::ZERO; 2];
        for (k, dir) in [t, -t].into_iter().enumerate() {
            let Some(q) = project(x + dir * delta)? else { return Ok(None) };
            // Taken a little inside, off the kink a distance may have on d = 0.
            let n = normal(q);
            m[k] = normal(q - n * (1e-3 * delta));
            if m[k].length_squared() < 0.5 {
                return Ok(None);
            }
        }
        Ok(Some(m[0].dot(m[1]).clamp(-1.0, 1.0).acos()))
    };
    for delta in [0.5 * s, 0.05 * s, 0.005 * s] {
        let (Some(full), Some(half)) = (turn(delta)?, turn(0.5 * delta)?) else { continue };
        if full > 1f64.to_radians() && half < 0.75 * full {
            return Ok(true);
        }
    }
    Ok(false)
}

/// Where the lines n1 . x = n1 . q1 and n2 . x = n2 . q2 meet (`None` when parallel).
fn meet(q1: DVec2, n1: DVec2, q2: DVec2, n2: DVec2) -> Option<DVec2> {
    let det = n1.perp_dot(n2);
    let (r1, r2) = (n1.dot(q1), n2.dot(q2));
    let x = DVec2::new(r1 * n2.y - r2 * n1.y, n1.x * r2 - n2.x * r1) / det;
    x.is_finite().then_some(x)
}

/// Moves the corner `p` (sides of normals `n1`, `n2`) to where the two sides' tangent lines
/// meet, taken at points of each side ever closer to it (REFINE_STEPS steps, from a tenth of
/// the spacing `s` down by ten each): exact already for straight sides, and for curved ones
/// the error falls with the square of the distance to the corner.
fn refine(
    p: DVec2,
    n1: DVec2,
    n2: DVec2,
    s: f64,
    normal: &dyn Fn(DVec2) -> DVec2,
    project: &dyn Fn(DVec2) -> Result<Option<DVec2>, Error>,
) -> Result<DVec2, Error> {
    let (mut x, mut a, mut b) = (p, n1, n2);
    let mut delta = 0.1 * s;
    for _ in 0..REFINE_STEPS {
        // A point of each side, delta from the corner: of the two ways along its tangent, the
        // one whose normal stays with the side.
        let side = |n: DVec2| -> Result<Option<(DVec2, DVec2)>, Error> {
            let mut best: Option<(f64, DVec2, DVec2)> = None;
            for t in [n.perp(), -n.perp()] {
                if let Some(q) = project(x + t * delta)? {
                    // Taken a little inside: on d = 0 a distance built from unsigned distances
                    // has a kink, and its gradient there can be anything.
                    let m = normal(q - n * (1e-3 * delta));
                    if m.length_squared() > 0.5 && best.is_none_or(|(c, _, _)| m.dot(n) > c) {
                        best = Some((m.dot(n), q, m));
                    }
                }
            }
            Ok(best.map(|(_, q, m)| (q, m)))
        };
        let (Some((q1, m1)), Some((q2, m2))) = (side(a)?, side(b)?) else { break };
        let Some(y) = meet(q1, m1, q2, m2) else { break };
        let Some(y) = project(y)? else { break };
        if y.distance(x) > 2.0 * delta {
            break;
        }
        (x, a, b) = (y, m1, m2);
        delta *= 0.1;
    }
    Ok(x)
}
