//! A marker for closures that are level sets rather than signed distances.

use super::{Implicit2, Implicit3};
use glam::{DVec2, DVec3};

/// Wraps a function whose zero set is the boundary but whose value is not a distance (a
/// level set such as `x^2/4 + y^2 - 1`): the meshers then divide by |grad d| where they need a
/// distance and project by gradient steps. A bare closure is taken as a signed distance.
///
/// ```
/// use trussmesh::geometry::{Implicit2, LevelSet};
/// let ellipse = LevelSet(|p: trussmesh::glam::DVec2| p.x * p.x / 4.0 + p.y * p.y - 1.0);
/// assert!(!ellipse.is_distance());
/// ```
#[derive(Clone, Copy, Debug)]
pub struct LevelSet<F>(pub F);

impl<F: Fn(DVec2) -> f64 + Sync + Send> Implicit2 for LevelSet<F> {
    fn value(&self, p: DVec2) -> f64 {
        (self.0)(p)
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(false)
    }
}

impl<F: Fn(DVec3) -> f64 + Sync + Send> Implicit3 for LevelSet<F> {
    fn value(&self, p: DVec3) -> f64 {
        (self.0)(p)
    }
    fn declared_distance(&self) -> Option<bool> {
        Some(false)
    }
}
