//! Input checks shared by the 2-D strategies: every bad input is a typed error, found before
//! anything large is allocated.

use super::Options2;
use crate::geometry::Implicit2;
use crate::mesher::truss::domain::{check_box_boundary, check_input, checked_d, checked_h};
use crate::Error;
use glam::DVec2;

/// What the checks learned about the domain.
pub(crate) struct DomainSurvey {
    /// Estimated triangle count at the requested sizes.
    pub estimated_triangles: f64,
    /// Smallest relative size sampled inside the domain.
    pub h_floor: f64,
}

/// Evaluates d, failing on a non-finite value.
#[inline]
pub(crate) fn eval_d(domain: &dyn Implicit2, p: DVec2) -> Result<f64, Error> {
    checked_d(domain.value(p), p)
}

/// Evaluates the relative size h, failing on a non-finite value. Size functions are only
/// meaningful inside the domain (the seed's often are not positive outside, in holes), so a
/// non-positive value is raised to `floor`, the smallest size sampled inside; [`survey`]
/// rejects non-positive sizes inside.
#[inline]
pub(crate) fn eval_h_floor(opts: &Options2, p: DVec2, floor: f64) -> Result<f64, Error> {
    checked_h(opts.size.as_deref(), p, floor)
}

/// Evaluates the relative size h strictly: non-finite or non-positive values are errors.
#[inline]
pub(crate) fn eval_h(opts: &Options2, p: DVec2) -> Result<f64, Error> {
    let v = eval_h_floor(opts, p, f64::NEG_INFINITY)?;
    if v <= 0.0 {
        Err(Error::BadSize(format!(
            "the size function is {v} at ({}, {}) inside the domain; it must be positive",
            p.x, p.y
        )))
    } else {
        Ok(v)
    }
}

/// Checks h0, the box, the fixed points, d and h on a sample grid, and the element estimate.
pub(crate) fn survey(domain: &dyn Implicit2, opts: &Options2) -> Result<DomainSurvey, Error> {
    let h0 = opts.h0;
    let [lo, hi] = opts.bbox;
    check_input(h0, lo, hi, &opts.fixed)?;
    let ext = hi - lo;
    // Sample at about h0 (at most 512 per side): d and h must be finite, some point inside.
    let nx = ((ext.x / h0).ceil() as usize + 1).clamp(8, 512);
    let ny = ((ext.y / h0).ceil() as usize + 1).clamp(8, 512);
    let dx = ext.x / (nx - 1) as f64;
    let dy = ext.y / (ny - 1) as f64;
    let mut inside = 0usize;
    let mut density = 0.0;
    let mut h_floor = f64::INFINITY;
    for j in 0..ny {
        for i in 0..nx {
            let p = lo + DVec2::new(i as f64 * dx, j as f64 * dy);
            let d = eval_d(domain, p)?;
            if d < 0.0 && (i == 0 || j == 0 || i == nx - 1 || j == ny - 1) {
                check_box_boundary(d, domain.gradient(p).length(), p, h0)?;
            }
            if d < 0.0 {
                inside += 1;
                if let Some(f) = &opts.metric {
                    // Triangles equilateral in M have area sqrt(3)/4 / sqrt(det M).
                    let m = super::metric::eval_metric(f, p)?;
                    density += (m.a * m.c - m.b * m.b).sqrt() * h0 * h0;
                    h_floor = 1.0;
                    continue;
                }
                let h = eval_h(opts, p)?;
                density += 1.0 / (h * h);
                h_floor = h_floor.min(h);
            } else {
                eval_h_floor(opts, p, 0.0)?;
            }
        }
    }
    let cell = dx * dy;
    if inside == 0 {
        // Try the centre of each cell once more before giving up (thin domains).
        let mut found = false;
        'outer: for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let p = lo + DVec2::new((i as f64 + 0.5) * dx, (j as f64 + 0.5) * dy);
                if eval_d(domain, p)? < 0.0 {
                    found = true;
                    break 'outer;
                }
            }
        }
        if !found {
            return Err(Error::EmptyDomain(format!(
                "the distance function is non-negative at every sample of the box ({}, {}) - ({}, {})",
                lo.x, lo.y, hi.x, hi.y
            )));
        }
        inside = 1;
        density = 1.0;
        h_floor = 1.0;
    }
    let area = inside as f64 * cell;
    // h is relative (seed section 2.2): the smallest size inside gets edges of length h0, so
    // the target is h0 h / h_min. Equilateral triangles of side L have area sqrt(3)/4 L^2.
    let estimated_triangles = density * h_floor * h_floor * cell / (3f64.sqrt() / 4.0 * h0 * h0);
    if estimated_triangles > opts.max_elements as f64 {
        return Err(Error::TooManyElements { estimated: estimated_triangles as u64, limit: opts.max_elements });
    }
    let _ = area;
    Ok(DomainSurvey { estimated_triangles, h_floor })
}
