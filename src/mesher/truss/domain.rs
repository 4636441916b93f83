//! The domain evaluator every mesher shares: d and h evaluated with their inputs checked, so
//! that a bad value is a typed error naming the function and the point, found before anything
//! large is allocated.

use crate::geometry::project::{NonFiniteIn, ProjectError};
use crate::Error;
use glam::{DVec2, DVec3};

/// A point of the domain's space, as the checks read it.
pub(crate) trait DomainPoint: Copy {
    /// The coordinates.
    fn coords(self) -> Vec<f64>;
    /// The point in 3-D (z = 0 in the plane), as errors report it.
    fn xyz(self) -> [f64; 3] {
        let c = self.coords();
        [c[0], c[1], c.get(2).copied().unwrap_or(0.0)]
    }
    /// "(x, y)" or "(x, y, z)".
    fn show(self) -> String {
        let c: Vec<String> = self.coords().iter().map(|x| x.to_string()).collect();
        format!("({})", c.join(", "))
    }
}

impl DomainPoint for DVec2 {
    fn coords(self) -> Vec<f64> {
        self.to_array().to_vec()
    }
}

impl DomainPoint for DVec3 {
    fn coords(self) -> Vec<f64> {
        self.to_array().to_vec()
    }
}

/// The value `d` of the distance function at `p`, or the error that names it when it is not
/// finite.
#[inline]
pub(crate) fn checked_d<P: DomainPoint>(d: f64, p: P) -> Result<f64, Error> {
    if d.is_finite() {
        Ok(d)
    } else {
        Err(Error::NonFinite { what: "the distance function", value: d, at: p.xyz() })
    }
}

/// The error for a projection that met a non-finite number, naming what was not finite and
/// where it was evaluated (a derived gradient is not called the function's value); `None` for
/// the other projection failures. `function` is "the distance function" or the like.
pub(crate) fn projection_non_finite(e: &ProjectError, function: Function) -> Option<Error> {
    let ProjectError::NonFinite { value, kind, at } = *e else { return None };
    let what = match (kind, function) {
        (NonFiniteIn::Value, Function::Domain) => "the distance function, evaluated where a boundary projection led,",
        (NonFiniteIn::Gradient, Function::Domain) => "the gradient of the distance function",
        (NonFiniteIn::Value, Function::Internal) => "the internal-boundary function, evaluated where a projection led,",
        (NonFiniteIn::Gradient, Function::Internal) => "the gradient of the internal-boundary function",
        (NonFiniteIn::Point, _) => "a node position being projected onto the boundary",
    };
    Some(Error::NonFinite { what, value, at })
}

/// Which function a projection worked on, for [`projection_non_finite`].
#[derive(Clone, Copy)]
pub(crate) enum Function {
    /// The domain's d.
    Domain,
    /// An internal boundary's d_I.
    Internal,
}

/// The relative size at `p` (1 without a size function), raised to `floor` where it is not
/// positive: size functions need only make sense inside the domain (the seed's often are not
/// positive outside, in holes); non-finite values are errors.
#[inline]
pub(crate) fn checked_h<P: DomainPoint>(
    size: Option<&(dyn Fn(P) -> f64 + Send + Sync)>,
    p: P,
    floor: f64,
) -> Result<f64, Error> {
    match size {
        None => Ok(1.0),
        Some(h) => {
            let v = h(p);
            if !v.is_finite() {
                Err(Error::NonFinite { what: "the size function", value: v, at: p.xyz() })
            } else {
                Ok(v.max(floor))
            }
        }
    }
}

/// An approximate distance to d = 0 from the value `d` and the gradient length `grad`: d itself
/// for a signed distance, d / |grad d| for a level set (d where the gradient vanishes).
#[inline]
pub(crate) fn approx_distance(d: f64, grad: f64, is_distance: bool) -> f64 {
    if is_distance || !(grad > 0.0 && grad.is_finite()) {
        d
    } else {
        d / grad
    }
}

/// Checks h0, the box [lo, hi] and the fixed points: h0 positive and finite, the box finite
/// and not empty, every fixed point finite and in the box.
pub(crate) fn check_input<P: DomainPoint>(h0: f64, lo: P, hi: P, fixed: &[P]) -> Result<(), Error> {
    if !h0.is_finite() || h0 <= 0.0 {
        return Err(Error::BadSize(format!("h0 must be positive and finite, got {h0}")));
    }
    let (l, u) = (lo.coords(), hi.coords());
    if l.iter().chain(&u).any(|x| !x.is_finite()) {
        return Err(Error::BadBox(format!("the box {} - {} is not finite", lo.show(), hi.show())));
    }
    if l.iter().zip(&u).any(|(a, b)| b.partial_cmp(a) != Some(std::cmp::Ordering::Greater)) {
        return Err(Error::BadBox(format!(
            "the box {} - {} is empty or inverted: each max must exceed its min",
            lo.show(),
            hi.show()
        )));
    }
    for &p in fixed {
        let c = p.coords();
        if let Some(&bad) = c.iter().find(|x| !x.is_finite()) {
            return Err(Error::BadCoordinate { what: "fixed point", value: bad });
        }
        if c.iter().zip(l.iter().zip(&u)).any(|(x, (a, b))| x < a || x > b) {
            return Err(Error::Invalid(format!("fixed point {} lies outside the box", p.show())));
        }
    }
    check_fixed_gaps(h0, fixed)
}

/// Fixed points closer than this many h0 (the smallest target edge length) are refused: the
/// edge between them would be that short, and no triangle on it could be good.
pub(crate) const FIXED_GAP: f64 = 0.1;

/// Fixed points pairwise at least [`FIXED_GAP`] h0 apart (a sweep along the first coordinate).
fn check_fixed_gaps<P: DomainPoint>(h0: f64, fixed: &[P]) -> Result<(), Error> {
    let gap = FIXED_GAP * h0;
    let mut order: Vec<(Vec<f64>, usize)> = fixed.iter().enumerate().map(|(i, p)| (p.coords(), i)).collect();
    order.sort_by(|a, b| a.0[0].total_cmp(&b.0[0]).then(a.1.cmp(&b.1)));
    for (k, (a, ia)) in order.iter().enumerate() {
        for (b, ib) in &order[k + 1..] {
            if b[0] - a[0] >= gap {
                break;
            }
            let dist = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt();
            if dist < gap {
                let (i, j) = ((*ia).min(*ib), (*ia).max(*ib));
                return Err(Error::Invalid(format!(
                    "fixed points {} and {} are {dist:e} apart, closer than {FIXED_GAP} h0 = {gap} (h0 is the \
                     smallest edge length): no good element can join them; merge them or lower h0",
                    fixed[i].show(),
                    fixed[j].show()
                )));
            }
        }
    }
    Ok(())
}

/// A sample `p` of the box's boundary where d < 0 by more than 1e-3 h0 (d / |grad d| for a
/// level set): the domain reaches past the box, which the meshers refuse (the start would
/// mesh the enclosing simplex, far outside the box).
pub(crate) fn check_box_boundary<P: DomainPoint>(d: f64, grad: f64, p: P, h0: f64) -> Result<(), Error> {
    let dist = if grad > 0.0 && grad.is_finite() { d / grad } else { d };
    if dist < -1e-3 * h0 {
        return Err(Error::BadBox(format!(
            "the domain reaches past the box: d = {d} < 0 at {} on the box's boundary. The box must \
             contain the domain: enlarge it, or clip the domain to it (max(d, the box's distance))",
            p.show()
        )));
    }
    Ok(())
}
