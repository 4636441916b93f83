//! Test helpers: a seeded generator and finite-difference checks of derivatives.

use super::{Implicit2, Implicit3};
use glam::{DVec2, DVec3};

/// SplitMix64: a tiny reproducible generator, so tests need no extra dependency.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
    pub fn point2(&mut self, r: f64) -> DVec2 {
        DVec2::new(self.uniform(-r, r), self.uniform(-r, r))
    }
    pub fn point3(&mut self, r: f64) -> DVec3 {
        DVec3::new(self.uniform(-r, r), self.uniform(-r, r), self.uniform(-r, r))
    }
}

const H: f64 = 1e-6;

/// True when the analytic gradient jumps inside the stencil: a kink, where differences mean nothing.
fn kinked2(g: &dyn Implicit2, p: DVec2) -> bool {
    let g0 = g.gradient(p);
    [DVec2::X, DVec2::Y, -DVec2::X, -DVec2::Y].iter().any(|e| (g.gradient(p + 2.0 * H * *e) - g0).length() > 1e-3)
}

fn kinked3(g: &dyn Implicit3, p: DVec3) -> bool {
    let g0 = g.gradient(p);
    [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z]
        .iter()
        .any(|e| (g.gradient(p + 2.0 * H * *e) - g0).length() > 1e-3)
}

/// Central differences of `value` against `gradient`; returns false when skipped at a kink.
pub fn check_gradient2(g: &dyn Implicit2, p: DVec2, tol: f64) -> bool {
    if kinked2(g, p) {
        return false;
    }
    let fd = DVec2::new(
        (g.value(p + DVec2::X * H) - g.value(p - DVec2::X * H)) / (2.0 * H),
        (g.value(p + DVec2::Y * H) - g.value(p - DVec2::Y * H)) / (2.0 * H),
    );
    let an = g.gradient(p);
    assert!((fd - an).length() < tol * (1.0 + an.length()), "gradient at {p}: analytic {an}, differences {fd}");
    if g.is_distance() {
        assert!((an.length() - 1.0).abs() < 1e-8, "distance gradient not unit at {p}: {an}");
    }
    true
}

/// Central differences of `gradient` against `hessian`, when the geometry gives one.
pub fn check_hessian2(g: &dyn Implicit2, p: DVec2, tol: f64) {
    let Some(hs) = g.hessian(p) else { return };
    if kinked2(g, p) {
        return;
    }
    for (i, e) in [DVec2::X, DVec2::Y].into_iter().enumerate() {
        let fd = (g.gradient(p + e * H) - g.gradient(p - e * H)) / (2.0 * H);
        let col = hs.col(i);
        assert!((fd - col).length() < tol * (1.0 + col.length()), "hessian col {i} at {p}: {col} vs {fd}");
    }
}

/// 3-D [`check_gradient2`].
pub fn check_gradient3(g: &dyn Implicit3, p: DVec3, tol: f64) -> bool {
    if kinked3(g, p) {
        return false;
    }
    let mut fd = DVec3::ZERO;
    for i in 0..3 {
        let mut e = DVec3::ZERO;
        e[i] = H;
        fd[i] = (g.value(p + e) - g.value(p - e)) / (2.0 * H);
    }
    let an = g.gradient(p);
    assert!((fd - an).length() < tol * (1.0 + an.length()), "gradient at {p}: analytic {an}, differences {fd}");
    if g.is_distance() {
        assert!((an.length() - 1.0).abs() < 1e-8, "distance gradient not unit at {p}: {an}");
    }
    true
}

/// 3-D [`check_hessian2`].
pub fn check_hessian3(g: &dyn Implicit3, p: DVec3, tol: f64) {
    let Some(hs) = g.hessian(p) else { return };
    if kinked3(g, p) {
        return;
    }
    for (i, e) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
        let fd = (g.gradient(p + e * H) - g.gradient(p - e * H)) / (2.0 * H);
        let col = hs.col(i);
        assert!((fd - col).length() < tol * (1.0 + col.length()), "hessian col {i} at {p}: {col} vs {fd}");
    }
}
