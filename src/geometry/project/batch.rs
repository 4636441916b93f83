#![allow(clippy::neg_cmp_op_on_partial_ord)]

//! Many points projected at once: the steps of [`super::project`] taken in lockstep, so that
//! each step evaluates the function once over every point still moving (through
//! [`Implicit2::values`] and [`Implicit2::gradients`]), not once per point. Exact and
//! first-order projections (those `Auto` picks) run batched; second-order and Newton
//! projections run point by point. Each point gets bit for bit what [`super::project2`] gives.

use super::{
    at3, axpy, dot, first_non_finite, multiplicity, project, resolve, scaled_step_taken, Geom, NonFiniteIn,
    ProjectError, Projection, Vector, G2, G3,
};
use crate::geometry::{Implicit2, Implicit3};
use glam::{DVec2, DVec3};

/// [`super::project2`] of every point of `ps`.
pub fn project_many2(
    g: &dyn Implicit2,
    ps: &[DVec2],
    method: Projection,
    tol: f64,
    max_iter: usize,
) -> Vec<Result<DVec2, ProjectError>> {
    let ps: Vec<Vector<2>> = ps.iter().map(|p| p.to_array()).collect();
    project_many(&G2(g), &ps, method, tol, max_iter).into_iter().map(|r| r.map(DVec2::from_array)).collect()
}

/// [`super::project3`] of every point of `ps`.
pub fn project_many3(
    g: &dyn Implicit3,
    ps: &[DVec3],
    method: Projection,
    tol: f64,
    max_iter: usize,
) -> Vec<Result<DVec3, ProjectError>> {
    let ps: Vec<Vector<3>> = ps.iter().map(|p| p.to_array()).collect();
    project_many(&G3(g), &ps, method, tol, max_iter).into_iter().map(|r| r.map(DVec3::from_array)).collect()
}

/// A first-order step waiting for the value at the end of its accelerated form.
struct Pending<const N: usize> {
    k: usize,
    phi: f64,
    /// The multiplicity the step is scaled by (see [`multiplicity`]).
    m: f64,
    first: Vector<N>,
    long: Vector<N>,
}

fn project_many<const N: usize>(
    g: &impl Geom<N>,
    ps: &[Vector<N>],
    method: Projection,
    tol: f64,
    max_iter: usize,
) -> Vec<Result<Vector<N>, ProjectError>> {
    let method = resolve(g, method);
    if !matches!(method, Projection::Exact | Projection::FirstOrder) {
        return ps.iter().map(|&p| project(g, p, method, tol, max_iter)).collect();
    }
    let n = ps.len();
    let mut out: Vec<Option<Result<Vector<N>, ProjectError>>> = vec![None; n];
    let mut x = ps.to_vec();
    let mut previous: Vec<Option<Vector<N>>> = vec![None; n];
    let mut live: Vec<usize> = Vec::with_capacity(n);
    for (k, p) in ps.iter().enumerate() {
        match first_non_finite(p) {
            Some(value) => out[k] = Some(Err(ProjectError::NonFinite { value, kind: NonFiniteIn::Point, at: at3(p) })),
            None => live.push(k),
        }
    }
    for it in 0..=max_iter {
        if live.is_empty() {
            break;
        }
        let xs: Vec<Vector<N>> = live.iter().map(|&k| x[k]).collect();
        let (phis, grads) = (g.values(&xs), g.gradients(&xs));
        let mut next = Vec::with_capacity(live.len());
        let mut pending: Vec<Pending<N>> = Vec::new();
        for (j, &k) in live.iter().enumerate() {
            let (phi, grad) = (phis[j], grads[j]);
            let decided = if !phi.is_finite() {
                Some(Err(ProjectError::NonFinite { value: phi, kind: NonFiniteIn::Value, at: at3(&x[k]) }))
            } else if let Some(value) = first_non_finite(&grad) {
                Some(Err(ProjectError::NonFinite { value, kind: NonFiniteIn::Gradient, at: at3(&x[k]) }))
            } else if phi == 0.0 {
                Some(Ok(x[k]))
            } else {
                step_one(g, method, it, max_iter, tol, phi, grad, &mut x[k], &mut previous[k], k, &mut pending)
            };
            match decided {
                Some(r) => out[k] = Some(r),
                None => next.push(k),
            }
        }
        if !pending.is_empty() {
            // Taken as the single projection decides (see [`scaled_step_taken`]).
            let probes: Vec<Vector<N>> = pending.iter().map(|s| axpy(x[s.k], 1.0, s.long)).collect();
            for (s, v) in pending.into_iter().zip(g.values(&probes)) {
                let step = if scaled_step_taken(s.m, s.phi, v) {
                    previous[s.k] = None;
                    s.long
                } else {
                    s.first
                };
                x[s.k] = axpy(x[s.k], 1.0, step);
            }
        }
        live = next;
    }
    out.into_iter().map(|r| r.unwrap_or(Err(ProjectError::NoConvergence { residual: f64::INFINITY }))).collect()
}

/// One point's step `it` from `x` with phi and its gradient there: the verdict when the point is
/// done, else `None` with `x` moved (or its accelerated step queued in `pending`).
#[allow(clippy::too_many_arguments)]
fn step_one<const N: usize>(
    g: &impl Geom<N>,
    method: Projection,
    it: usize,
    max_iter: usize,
    tol: f64,
    phi: f64,
    grad: Vector<N>,
    x: &mut Vector<N>,
    previous: &mut Option<Vector<N>>,
    k: usize,
    pending: &mut Vec<Pending<N>>,
) -> Option<Result<Vector<N>, ProjectError>> {
    let g2 = dot(grad, grad);
    if !(g2 > 0.0) {
        return Some(Err(ProjectError::ZeroGradient));
    }
    let gl = g2.sqrt();
    let residual = if method == Projection::Exact { phi.abs() } else { phi.abs() / gl };
    if residual < tol {
        return Some(Ok(*x));
    }
    if it == max_iter {
        // The single projection's tail, point by point (rare: mostly zigzags into a crease).
        return Some(super::crease_mode(g, *x, method, tol, max_iter));
    }
    let first = axpy([0.0; N], -phi / g2, grad); // seed eq. 3.9
    if method == Projection::Exact {
        *x = axpy(*x, 1.0, axpy([0.0; N], -phi / gl, grad));
        return None;
    }
    let m = previous.map_or(1.0, |s| multiplicity(s, first));
    *previous = Some(first);
    if m != 1.0 {
        pending.push(Pending { k, phi, m, first, long: axpy([0.0; N], m, first) });
    } else {
        *x = axpy(*x, 1.0, first);
    }
    None
}
