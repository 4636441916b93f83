//! Level sets on Cartesian grids (seed section 5.1.1): a boundary phi = 0 moved by a velocity
//! field (eq. 5.1, phi_t + v . grad phi = 0) or a normal speed (eq. 5.2, phi_t + F |grad phi|
//! = 0) with first-order upwind differences (eq. 5.3 to 5.5), then reinitialised to a signed
//! distance by fast marching. Each step is meshed with [`crate::mesher::move_mesh_2d`].
//!
//! ```
//! use trussmesh::geometry::{levelset, Circle, Grid2, Implicit2};
//! let phi = Grid2::sample(&Circle::new([0.0, 0.0], 0.3), [-1.0, -1.0], [1.0, 1.0], 0.02).unwrap();
//! // Grow the circle at unit normal speed for 0.2: its radius becomes 0.5.
//! let grown = levelset::move_normal_2d(&phi, |_| 1.0, 0.2).unwrap();
//! assert!((grown.value([0.5, 0.0].into())).abs() < 0.02);
//! ```

use super::Grid2;
use crate::Error;
use glam::DVec2;

/// Largest share of a grid cell the front may cross in one sub-step (CFL number).
const CFL: f64 = 0.5;

/// Backward and forward differences of `v` at (i, j) along x and y, one-sided (zero) at the
/// grid's border: (D-x, D+x, D-y, D+y).
#[inline]
fn differences(v: &[f64], nx: usize, ny: usize, h: f64, i: usize, j: usize) -> (f64, f64, f64, f64) {
    let at = |i: usize, j: usize| v[i + nx * j];
    let c = at(i, j);
    let dmx = if i > 0 { (c - at(i - 1, j)) / h } else { 0.0 };
    let dpx = if i + 1 < nx { (at(i + 1, j) - c) / h } else { 0.0 };
    let dmy = if j > 0 { (c - at(i, j - 1)) / h } else { 0.0 };
    let dpy = if j + 1 < ny { (at(i, j + 1) - c) / h } else { 0.0 };
    (dmx, dpx, dmy, dpy)
}

fn check_step(dt: f64) -> Result<(), Error> {
    if dt.is_finite() && dt >= 0.0 {
        Ok(())
    } else {
        Err(Error::Invalid(format!("the level-set time step must be finite and non-negative, got {dt}")))
    }
}

/// Sub-steps so that the fastest speed crosses at most CFL of a cell per sub-step.
fn substeps(dt: f64, max_speed: f64, h: f64) -> Result<usize, Error> {
    if !max_speed.is_finite() {
        return Err(Error::NonFinite { what: "the level-set speed", value: max_speed, at: [0.0; 3] });
    }
    let n = (dt * max_speed / (CFL * h)).ceil().max(1.0);
    if n > 1e6 {
        return Err(Error::Invalid(format!(
            "a level-set step of {dt} at speed {max_speed} on a grid of spacing {h} needs {n} sub-steps"
        )));
    }
    Ok(n as usize)
}

/// Speeds at the grid nodes, failing on a non-finite value.
fn node_values<T: Copy>(g: &Grid2, f: impl Fn(DVec2) -> T, finite: impl Fn(T) -> bool) -> Result<Vec<T>, Error> {
    let (nx, ny) = g.dims();
    let mut out = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let p = g.origin() + g.spacing() * DVec2::new(i as f64, j as f64);
            let v = f(p);
            if !finite(v) {
                return Err(Error::NonFinite { what: "the level-set speed", value: f64::NAN, at: [p.x, p.y, 0.0] });
            }
            out.push(v);
        }
    }
    Ok(out)
}

/// Advances phi by the velocity field `v` for time `dt` (seed eq. 5.1, first-order upwind, in
/// CFL-limited sub-steps) and reinitialises it to a signed distance.
pub fn advect_2d(phi: &Grid2, v: impl Fn(DVec2) -> DVec2, dt: f64) -> Result<Grid2, Error> {
    check_step(dt)?;
    let h = phi.spacing();
    let vel = node_values(phi, v, |w: DVec2| w.is_finite())?;
    let vmax = vel.iter().map(|w| w.abs().max_element()).fold(0.0, f64::max);
    let n = substeps(dt, 2.0 * vmax, h)?;
    let values = evolve(phi, dt / n as f64, n, |k, (dmx, dpx, dmy, dpy)| {
        let w = vel[k];
        // Upwind: information comes from where the flow comes from.
        let gx = if w.x > 0.0 { dmx } else { dpx };
        let gy = if w.y > 0.0 { dmy } else { dpy };
        w.x * gx + w.y * gy
    });
    finish(phi, values)
}

/// Moves the front phi = 0 along its normal at speed `f` for time `dt` (seed eq. 5.2 to 5.5:
/// phi_t + F |grad phi| = 0, so F > 0 grows the region phi < 0), in CFL-limited sub-steps, and
/// reinitialises phi to a signed distance.
pub fn move_normal_2d(phi: &Grid2, f: impl Fn(DVec2) -> f64, dt: f64) -> Result<Grid2, Error> {
    check_step(dt)?;
    let h = phi.spacing();
    let speed = node_values(phi, f, |s: f64| s.is_finite())?;
    let smax = speed.iter().map(|s| s.abs()).fold(0.0, f64::max);
    let n = substeps(dt, 2.0 * smax, h)?;
    let values = evolve(phi, dt / n as f64, n, |k, (dmx, dpx, dmy, dpy)| {
        // Eq. 5.4 and 5.5 (Osher and Sethian's upwind gradient norms).
        let grad_plus =
            (dmx.max(0.0).powi(2) + dpx.min(0.0).powi(2) + dmy.max(0.0).powi(2) + dpy.min(0.0).powi(2)).sqrt();
        let grad_minus =
            (dmx.min(0.0).powi(2) + dpx.max(0.0).powi(2) + dmy.min(0.0).powi(2) + dpy.max(0.0).powi(2)).sqrt();
        let s = speed[k];
        s.max(0.0) * grad_plus + s.min(0.0) * grad_minus
    });
    finish(phi, values)
}

/// `n` explicit sub-steps of length `tau` of phi_t + H = 0, with H at node k given by `rate`
/// from the one-sided differences there.
fn evolve(phi: &Grid2, tau: f64, n: usize, rate: impl Fn(usize, (f64, f64, f64, f64)) -> f64) -> Vec<f64> {
    let (nx, ny) = phi.dims();
    let h = phi.spacing();
    let mut cur = phi.values().to_vec();
    let mut next = cur.clone();
    for _ in 0..n {
        for j in 0..ny {
            for i in 0..nx {
                let k = i + nx * j;
                next[k] = cur[k] - tau * rate(k, differences(&cur, nx, ny, h, i, j));
            }
        }
        std::mem::swap(&mut cur, &mut next);
    }
    cur
}

fn finish(phi: &Grid2, values: Vec<f64>) -> Result<Grid2, Error> {
    let (nx, ny) = phi.dims();
    if !values.iter().any(|&v| v < 0.0) {
        return Err(Error::EmptyDomain("the level set moved out of the grid: phi >= 0 everywhere".into()));
    }
    let g = Grid2::new(phi.origin(), phi.spacing(), nx, ny, values)?;
    Ok(crate::size::reinitialize_2d(&g))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Circle, Implicit2};

    fn circle_grid(c: [f64; 2], r: f64) -> Grid2 {
        Grid2::sample(&Circle::new(c, r), [-1.0, -1.0], [1.0, 1.0], 0.02).unwrap()
    }

    #[test]
    fn advection_translates_a_circle() {
        let g = advect_2d(&circle_grid([-0.3, 0.0], 0.3), |_| DVec2::new(1.0, 0.5), 0.4).unwrap();
        // The centre moved to (0.1, 0.2); first-order upwinding smooths the distance's kink
        // there, while the front itself stays within a grid cell.
        let c = DVec2::new(0.1, 0.2);
        assert!(g.value(c) < -0.25, "{}", g.value(c));
        for k in 0..16 {
            let a = k as f64 * std::f64::consts::TAU / 16.0;
            let p = c + 0.3 * DVec2::new(a.cos(), a.sin());
            assert!(g.value(p).abs() < 0.02, "boundary point {p}: {}", g.value(p));
        }
    }

    #[test]
    fn normal_speed_grows_and_shrinks_a_circle() {
        let grow = move_normal_2d(&circle_grid([0.0, 0.0], 0.3), |_| 1.0, 0.25).unwrap();
        assert!(grow.value(DVec2::new(0.55, 0.0)).abs() < 0.02);
        assert!(grow.value(DVec2::new(0.0, -0.55)).abs() < 0.02);
        let shrink = move_normal_2d(&circle_grid([0.0, 0.0], 0.5), |_| -1.0, 0.2).unwrap();
        assert!(shrink.value(DVec2::new(0.3, 0.0)).abs() < 0.02, "{}", shrink.value(DVec2::new(0.3, 0.0)));
    }

    #[test]
    fn bad_steps_are_errors() {
        let g = circle_grid([0.0, 0.0], 0.3);
        assert!(advect_2d(&g, |_| DVec2::X, f64::NAN).is_err());
        assert!(move_normal_2d(&g, |_| f64::INFINITY, 0.1).is_err());
        // Shrinking the circle away entirely.
        assert!(matches!(move_normal_2d(&g, |_| -1.0, 0.5), Err(Error::EmptyDomain(_))));
    }
}
