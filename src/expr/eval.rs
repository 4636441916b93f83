//! The interpreter: one generic loop run over `f64` (values) or [`Dual`] (value and gradient).
//!
//! Sharing the loop is what keeps `eval` and `eval_grad` bit-identical in their values.

use std::cell::RefCell;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// One instruction of the postfix program. The top of the stack lives in an accumulator;
/// ops with a `C` suffix take their second operand as an immediate constant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Op {
    Const(f64),
    Var(u8),
    // Unary, on the accumulator.
    Neg,
    Abs,
    Sqrt,
    Sin,
    Cos,
    Tan,
    Exp,
    Ln,
    Log10,
    Floor,
    Ceil,
    Asin,
    Acos,
    Atan,
    Sinh,
    Cosh,
    Tanh,
    Cbrt,
    Sign,
    Square,
    PowI(i32),
    // Accumulator with an immediate constant.
    AddC(f64),
    MulC(f64),
    /// c - acc
    RSubC(f64),
    DivC(f64),
    /// c / acc
    RDivC(f64),
    MinC(f64),
    MaxC(f64),
    PowC(f64),
    /// c ^ acc
    RPowC(f64),
    // Binary: stack top (left) with accumulator (right).
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Min,
    Max,
    Atan2,
    Hypot,
    // Distance helpers, arguments in source order on the stack.
    Circle,
    Sphere,
    Rect,
    Box3,
    /// dpoly with constant vertices: index into the program's polygon table.
    PolyConst(u32),
    /// dpoly with vertices computed at run time: vertex count; 2n + 2 operands.
    PolyStack(u32),
}

impl Op {
    /// Net change in stack height when the op runs.
    pub(crate) fn stack_effect(self) -> isize {
        use Op::*;
        match self {
            Const(_) | Var(_) => 1,
            Add | Sub | Mul | Div | Pow | Min | Max | Atan2 | Hypot | PolyConst(_) => -1,
            Circle => -4,
            Sphere => -6,
            Rect => -5,
            Box3 => -8,
            PolyStack(n) => -(2 * n as isize + 1),
            _ => 0,
        }
    }
}

/// Numbers the interpreter can run on.
pub(crate) trait Num:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    const ZERO: Self;
    fn cst(c: f64) -> Self;
    fn var(v: f64, i: usize) -> Self;
    fn abs(self) -> Self;
    fn sqrt(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn tan(self) -> Self;
    fn exp(self) -> Self;
    fn ln(self) -> Self;
    fn log10(self) -> Self;
    fn floor(self) -> Self;
    fn ceil(self) -> Self;
    fn asin(self) -> Self;
    fn acos(self) -> Self;
    fn atan(self) -> Self;
    fn sinh(self) -> Self;
    fn cosh(self) -> Self;
    fn tanh(self) -> Self;
    fn cbrt(self) -> Self;
    fn sign(self) -> Self;
    fn square(self) -> Self;
    fn powi(self, n: i32) -> Self;
    fn powc(self, c: f64) -> Self;
    fn rpowc(c: f64, e: Self) -> Self;
    fn pow(self, e: Self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn hypot(self, o: Self) -> Self;
    fn min(self, o: Self) -> Self;
    fn max(self, o: Self) -> Self;
    fn add_c(self, c: f64) -> Self;
    fn mul_c(self, c: f64) -> Self;
    fn rsub_c(self, c: f64) -> Self;
    fn div_c(self, c: f64) -> Self;
    fn rdiv_c(self, c: f64) -> Self;
    fn dpoly_const(x: Self, y: Self, verts: &[f64]) -> Self;
    fn dpoly_stack(x: Self, y: Self, verts: &[Self]) -> Self;
    /// Runs `f` on a scratch buffer of at least `n` elements without allocating per call.
    fn with_scratch<R>(n: usize, f: impl FnOnce(&mut [Self]) -> R) -> R;
}

impl Num for f64 {
    const ZERO: Self = 0.0;
    #[inline(always)]
    fn cst(c: f64) -> Self {
        c
    }
    #[inline(always)]
    fn var(v: f64, _i: usize) -> Self {
        v
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        f64::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        f64::cos(self)
    }
    #[inline(always)]
    fn tan(self) -> Self {
        f64::tan(self)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        f64::exp(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        f64::ln(self)
    }
    #[inline(always)]
    fn log10(self) -> Self {
        f64::log10(self)
    }
    #[inline(always)]
    fn floor(self) -> Self {
        f64::floor(self)
    }
    #[inline(always)]
    fn ceil(self) -> Self {
        f64::ceil(self)
    }
    #[inline(always)]
    fn asin(self) -> Self {
        f64::asin(self)
    }
    #[inline(always)]
    fn acos(self) -> Self {
        f64::acos(self)
    }
    #[inline(always)]
    fn atan(self) -> Self {
        f64::atan(self)
    }
    #[inline(always)]
    fn sinh(self) -> Self {
        f64::sinh(self)
    }
    #[inline(always)]
    fn cosh(self) -> Self {
        f64::cosh(self)
    }
    #[inline(always)]
    fn tanh(self) -> Self {
        f64::tanh(self)
    }
    #[inline(always)]
    fn cbrt(self) -> Self {
        f64::cbrt(self)
    }
    /// -1, 0 or 1 (NaN stays NaN).
    #[inline(always)]
    fn sign(self) -> Self {
        if self > 0.0 {
            1.0
        } else if self < 0.0 {
            -1.0
        } else {
            self * 0.0
        }
    }
    #[inline(always)]
    fn square(self) -> Self {
        self * self
    }
    #[inline(always)]
    fn powi(self, n: i32) -> Self {
        f64::powi(self, n)
    }
    #[inline(always)]
    fn powc(self, c: f64) -> Self {
        f64::powf(self, c)
    }
    #[inline(always)]
    fn rpowc(c: f64, e: Self) -> Self {
        f64::powf(c, e)
    }
    #[inline(always)]
    fn pow(self, e: Self) -> Self {
        f64::powf(self, e)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    #[inline(always)]
    fn hypot(self, o: Self) -> Self {
        f64::hypot(self, o)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        f64::min(self, o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        f64::max(self, o)
    }
    #[inline(always)]
    fn add_c(self, c: f64) -> Self {
        self + c
    }
    #[inline(always)]
    fn mul_c(self, c: f64) -> Self {
        self * c
    }
    #[inline(always)]
    fn rsub_c(self, c: f64) -> Self {
        c - self
    }
    #[inline(always)]
    fn div_c(self, c: f64) -> Self {
        self / c
    }
    #[inline(always)]
    fn rdiv_c(self, c: f64) -> Self {
        c / self
    }
    fn dpoly_const(x: Self, y: Self, verts: &[f64]) -> Self {
        poly_nearest(x, y, verts.len() / 2, |i| (verts[2 * i], verts[2 * i + 1])).dist
    }
    fn dpoly_stack(x: Self, y: Self, verts: &[Self]) -> Self {
        Self::dpoly_const(x, y, verts)
    }
    fn with_scratch<R>(n: usize, f: impl FnOnce(&mut [Self]) -> R) -> R {
        thread_local!(static SCRATCH: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) });
        with_tls(&SCRATCH, n, f)
    }
}

fn with_tls<T: Num, R>(
    key: &'static std::thread::LocalKey<RefCell<Vec<T>>>,
    n: usize,
    f: impl FnOnce(&mut [T]) -> R,
) -> R {
    let mut f = Some(f);
    let r = key.with(|cell| {
        // Evaluation never re-enters itself, but stay correct if it ever does.
        let mut buf = cell.try_borrow_mut().ok()?;
        if buf.len() < n {
            buf.resize(n, T::ZERO);
        }
        Some((f.take().expect("called once"))(&mut buf[..n]))
    });
    match r {
        Some(r) => r,
        None => (f.take().expect("called once"))(&mut vec![T::ZERO; n]),
    }
}

/// A forward-mode dual number: value and the partials with respect to x, y, z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Dual {
    pub v: f64,
    pub d: [f64; 3],
}

/// `d * k`, except that a zero partial stays zero even when `k` is infinite or NaN
/// (a variable the subexpression does not depend on must not poison the gradient).
#[inline(always)]
fn scale(d: [f64; 3], k: f64) -> [f64; 3] {
    let s = |a: f64| if a == 0.0 { 0.0 } else { a * k };
    [s(d[0]), s(d[1]), s(d[2])]
}

#[inline(always)]
fn lin(a: [f64; 3], ka: f64, b: [f64; 3], kb: f64) -> [f64; 3] {
    let a = scale(a, ka);
    let b = scale(b, kb);
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

impl Dual {
    #[inline(always)]
    fn chain(self, v: f64, k: f64) -> Dual {
        Dual { v, d: scale(self.d, k) }
    }
}

impl Add for Dual {
    type Output = Dual;
    #[inline(always)]
    fn add(self, o: Dual) -> Dual {
        Dual { v: self.v + o.v, d: [self.d[0] + o.d[0], self.d[1] + o.d[1], self.d[2] + o.d[2]] }
    }
}

impl Sub for Dual {
    type Output = Dual;
    #[inline(always)]
    fn sub(self, o: Dual) -> Dual {
        Dual { v: self.v - o.v, d: [self.d[0] - o.d[0], self.d[1] - o.d[1], self.d[2] - o.d[2]] }
    }
}

impl Mul for Dual {
    type Output = Dual;
    #[inline(always)]
    fn mul(self, o: Dual) -> Dual {
        Dual { v: self.v * o.v, d: lin(self.d, o.v, o.d, self.v) }
    }
}

impl Div for Dual {
    type Output = Dual;
    #[inline(always)]
    fn div(self, o: Dual) -> Dual {
        let q = self.v / o.v;
        Dual { v: q, d: lin(self.d, 1.0 / o.v, o.d, -q / o.v) }
    }
}

impl Neg for Dual {
    type Output = Dual;
    #[inline(always)]
    fn neg(self) -> Dual {
        Dual { v: -self.v, d: [-self.d[0], -self.d[1], -self.d[2]] }
    }
}

/// Which operand `f64::min` would return (it returns the non-NaN one when there is one).
#[inline(always)]
fn first_is_min(a: f64, b: f64) -> bool {
    b.is_nan() || a <= b
}

#[inline(always)]
fn first_is_max(a: f64, b: f64) -> bool {
    b.is_nan() || a >= b
}

impl Num for Dual {
    const ZERO: Self = Dual { v: 0.0, d: [0.0; 3] };
    #[inline(always)]
    fn cst(c: f64) -> Self {
        Dual { v: c, d: [0.0; 3] }
    }
    #[inline(always)]
    fn var(v: f64, i: usize) -> Self {
        // No dynamic index into `d`: that would pin the accumulator to memory.
        let d = match i {
            0 => [1.0, 0.0, 0.0],
            1 => [0.0, 1.0, 0.0],
            _ => [0.0, 0.0, 1.0],
        };
        Dual { v, d }
    }
    fn abs(self) -> Self {
        // At the kink take the right-hand derivative: any subgradient is as good.
        let k = if self.v < 0.0 { -1.0 } else { 1.0 };
        self.chain(self.v.abs(), k)
    }
    fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        // At 0 the derivative is infinite; 0 keeps sqrt(x^2 + y^2) sane at its centre.
        let k = if s > 0.0 { 0.5 / s } else { 0.0 };
        self.chain(s, k)
    }
    fn sin(self) -> Self {
        self.chain(self.v.sin(), self.v.cos())
    }
    fn cos(self) -> Self {
        self.chain(self.v.cos(), -self.v.sin())
    }
    fn tan(self) -> Self {
        let t = self.v.tan();
        self.chain(t, 1.0 + t * t)
    }
    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }
    fn ln(self) -> Self {
        self.chain(self.v.ln(), 1.0 / self.v)
    }
    fn log10(self) -> Self {
        self.chain(self.v.log10(), 1.0 / (self.v * std::f64::consts::LN_10))
    }
    fn floor(self) -> Self {
        Dual::cst(self.v.floor())
    }
    fn ceil(self) -> Self {
        Dual::cst(self.v.ceil())
    }
    fn asin(self) -> Self {
        self.chain(self.v.asin(), 1.0 / (1.0 - self.v * self.v).sqrt())
    }
    fn acos(self) -> Self {
        self.chain(self.v.acos(), -1.0 / (1.0 - self.v * self.v).sqrt())
    }
    fn atan(self) -> Self {
        self.chain(self.v.atan(), 1.0 / (1.0 + self.v * self.v))
    }
    fn sinh(self) -> Self {
        self.chain(self.v.sinh(), self.v.cosh())
    }
    fn cosh(self) -> Self {
        self.chain(self.v.cosh(), self.v.sinh())
    }
    fn tanh(self) -> Self {
        let t = self.v.tanh();
        self.chain(t, 1.0 - t * t)
    }
    fn cbrt(self) -> Self {
        // 1 / (3 cbrt(v)^2). At v = 0 the slope is infinite, or finite where v is a cube
        // (cbrt(x^3), whose inner slope is 0 there): not known from the chain rule, so it is
        // left undefined for `Expr::eval_grad` to take a difference.
        let c = self.v.cbrt();
        if c == 0.0 {
            return Dual { v: c, d: [f64::NAN; 3] };
        }
        self.chain(c, 1.0 / (3.0 * c * c))
    }
    fn sign(self) -> Self {
        // Flat on either side; at 0 the step's derivative is taken as 0, as floor's.
        Dual::cst(Num::sign(self.v))
    }
    fn square(self) -> Self {
        self.chain(self.v * self.v, 2.0 * self.v)
    }
    fn powi(self, n: i32) -> Self {
        let k = if n == 0 { 0.0 } else { n as f64 * self.v.powi(n - 1) };
        self.chain(self.v.powi(n), k)
    }
    fn powc(self, c: f64) -> Self {
        let k = if c == 0.0 { 0.0 } else { c * self.v.powf(c - 1.0) };
        self.chain(self.v.powf(c), k)
    }
    fn rpowc(c: f64, e: Self) -> Self {
        let v = c.powf(e.v);
        e.chain(v, v * c.ln())
    }
    fn pow(self, e: Self) -> Self {
        let v = self.v.powf(e.v);
        let ka = if e.v == 0.0 { 0.0 } else { e.v * self.v.powf(e.v - 1.0) };
        // The ln term only matters when the exponent varies; skipping it otherwise keeps
        // negative bases with constant exponents finite.
        let kb = if e.d == [0.0; 3] { 0.0 } else { v * self.v.ln() };
        Dual { v, d: lin(self.d, ka, e.d, kb) }
    }
    fn atan2(self, x: Self) -> Self {
        let r2 = self.v * self.v + x.v * x.v;
        let (ky, kx) = if r2 > 0.0 { (x.v / r2, -self.v / r2) } else { (0.0, 0.0) };
        Dual { v: self.v.atan2(x.v), d: lin(self.d, ky, x.d, kx) }
    }
    fn hypot(self, o: Self) -> Self {
        // (a a' + b b') / hypot(a, b); zero at the origin, as at a circle's centre.
        let h = self.v.hypot(o.v);
        let (ka, kb) = if h > 0.0 { (self.v / h, o.v / h) } else { (0.0, 0.0) };
        Dual { v: h, d: lin(self.d, ka, o.d, kb) }
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        if first_is_min(self.v, o.v) {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        if first_is_max(self.v, o.v) {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn add_c(self, c: f64) -> Self {
        Dual { v: self.v + c, d: self.d }
    }
    #[inline(always)]
    fn mul_c(self, c: f64) -> Self {
        self.chain(self.v * c, c)
    }
    #[inline(always)]
    fn rsub_c(self, c: f64) -> Self {
        Dual { v: c - self.v, d: [-self.d[0], -self.d[1], -self.d[2]] }
    }
    #[inline(always)]
    fn div_c(self, c: f64) -> Self {
        self.chain(self.v / c, 1.0 / c)
    }
    fn rdiv_c(self, c: f64) -> Self {
        let q = c / self.v;
        self.chain(q, -q / self.v)
    }
    fn dpoly_const(x: Self, y: Self, verts: &[f64]) -> Self {
        let n = verts.len() / 2;
        let near = poly_nearest(x.v, y.v, n, |i| (verts[2 * i], verts[2 * i + 1]));
        Dual { v: near.dist, d: lin(x.d, near.sign * near.nx, y.d, near.sign * near.ny) }
    }
    fn dpoly_stack(x: Self, y: Self, verts: &[Self]) -> Self {
        let n = verts.len() / 2;
        let near = poly_nearest(x.v, y.v, n, |i| (verts[2 * i].v, verts[2 * i + 1].v));
        // d = |p - q|, q = (1 - t) a + t b: dd = s n . (dp - (1 - t) da - t db).
        // (The derivative of t itself is orthogonal to n, or zero when t is clamped.)
        let (i, j) = (near.seg, (near.seg + 1) % n.max(1));
        let (sx, sy) = (near.sign * near.nx, near.sign * near.ny);
        let t = near.t;
        let mut d = lin(x.d, sx, y.d, sy);
        if n > 0 {
            let da = lin(verts[2 * i].d, sx, verts[2 * i + 1].d, sy);
            let db = lin(verts[2 * j].d, sx, verts[2 * j + 1].d, sy);
            for k in 0..3 {
                d[k] -= (1.0 - t) * da[k] + t * db[k];
            }
        }
        Dual { v: near.dist, d }
    }
    fn with_scratch<R>(n: usize, f: impl FnOnce(&mut [Self]) -> R) -> R {
        thread_local!(static SCRATCH: RefCell<Vec<Dual>> = const { RefCell::new(Vec::new()) });
        with_tls(&SCRATCH, n, f)
    }
}

/// The nearest boundary point of a closed polygon.
pub(crate) struct PolyNear {
    /// Signed distance: negative inside (even-odd crossing rule).
    pub dist: f64,
    /// Segment from vertex `seg` to `seg + 1` holding the nearest point.
    pub seg: usize,
    /// Parameter of the nearest point on that segment.
    pub t: f64,
    /// Unit vector from the nearest point to p (zero on the boundary).
    pub nx: f64,
    pub ny: f64,
    /// -1 inside, +1 outside.
    pub sign: f64,
}

/// Exact distance to a closed polygon with `n` vertices given by `vert`.
pub(crate) fn poly_nearest(px: f64, py: f64, n: usize, vert: impl Fn(usize) -> (f64, f64)) -> PolyNear {
    let mut best = f64::INFINITY;
    let (mut seg, mut bt, mut bdx, mut bdy) = (0, 0.0, 0.0, 0.0);
    let mut inside = false;
    for i in 0..n {
        let (ax, ay) = vert(i);
        let (bx, by) = vert(if i + 1 == n { 0 } else { i + 1 });
        let (ex, ey) = (bx - ax, by - ay);
        let (wx, wy) = (px - ax, py - ay);
        let ee = ex * ex + ey * ey;
        let t = if ee > 0.0 { ((wx * ex + wy * ey) / ee).clamp(0.0, 1.0) } else { 0.0 };
        let (dx, dy) = (wx - t * ex, wy - t * ey);
        let d2 = dx * dx + dy * dy;
        // A NaN distance sticks: once `best` is NaN no comparison is true.
        if d2 < best || d2.is_nan() {
            best = d2;
            seg = i;
            bt = t;
            bdx = dx;
            bdy = dy;
        }
        if (ay > py) != (by > py) {
            let xc = ax + (py - ay) * ex / ey;
            if px < xc {
                inside = !inside;
            }
        }
    }
    let d = best.sqrt();
    let sign = if inside { -1.0 } else { 1.0 };
    let (nx, ny) = if d > 0.0 { (bdx / d, bdy / d) } else { (0.0, 0.0) };
    PolyNear { dist: sign * d, seg, t: bt, nx, ny, sign }
}

/// Runs `code` with the accumulator convention. `stack` must hold the program's depth + 1.
#[inline(always)]
pub(crate) fn run<T: Num>(code: &[Op], polys: &[f64], ranges: &[(u32, u32)], vars: [f64; 3], stack: &mut [T]) -> T {
    let mut acc = T::ZERO;
    let mut sp = 0usize;
    for op in code {
        match *op {
            Op::Const(c) => {
                stack[sp] = acc;
                sp += 1;
                acc = T::cst(c);
            }
            Op::Var(i) => {
                stack[sp] = acc;
                sp += 1;
                let i = i as usize;
                acc = T::var(vars[i], i);
            }
            Op::Neg => acc = -acc,
            Op::Abs => acc = acc.abs(),
            Op::Sqrt => acc = acc.sqrt(),
            Op::Sin => acc = acc.sin(),
            Op::Cos => acc = acc.cos(),
            Op::Tan => acc = acc.tan(),
            Op::Exp => acc = acc.exp(),
            Op::Ln => acc = acc.ln(),
            Op::Log10 => acc = acc.log10(),
            Op::Floor => acc = acc.floor(),
            Op::Ceil => acc = acc.ceil(),
            Op::Asin => acc = acc.asin(),
            Op::Acos => acc = acc.acos(),
            Op::Atan => acc = acc.atan(),
            Op::Sinh => acc = acc.sinh(),
            Op::Cosh => acc = acc.cosh(),
            Op::Tanh => acc = acc.tanh(),
            Op::Cbrt => acc = acc.cbrt(),
            Op::Sign => acc = acc.sign(),
            Op::Square => acc = acc.square(),
            Op::PowI(n) => acc = acc.powi(n),
            Op::AddC(c) => acc = acc.add_c(c),
            Op::MulC(c) => acc = acc.mul_c(c),
            Op::RSubC(c) => acc = acc.rsub_c(c),
            Op::DivC(c) => acc = acc.div_c(c),
            Op::RDivC(c) => acc = acc.rdiv_c(c),
            Op::MinC(c) => acc = acc.min(T::cst(c)),
            Op::MaxC(c) => acc = acc.max(T::cst(c)),
            Op::PowC(c) => acc = acc.powc(c),
            Op::RPowC(c) => acc = T::rpowc(c, acc),
            Op::Add => {
                sp -= 1;
                acc = stack[sp] + acc;
            }
            Op::Sub => {
                sp -= 1;
                acc = stack[sp] - acc;
            }
            Op::Mul => {
                sp -= 1;
                acc = stack[sp] * acc;
            }
            Op::Div => {
                sp -= 1;
                acc = stack[sp] / acc;
            }
            Op::Pow => {
                sp -= 1;
                acc = stack[sp].pow(acc);
            }
            Op::Min => {
                sp -= 1;
                acc = stack[sp].min(acc);
            }
            Op::Max => {
                sp -= 1;
                acc = stack[sp].max(acc);
            }
            Op::Atan2 => {
                sp -= 1;
                acc = stack[sp].atan2(acc);
            }
            Op::Hypot => {
                sp -= 1;
                acc = stack[sp].hypot(acc);
            }
            Op::Circle => {
                sp -= 4;
                let a = &stack[sp..sp + 4];
                acc = ((a[0] - a[2]).square() + (a[1] - a[3]).square()).sqrt() - acc;
            }
            Op::Sphere => {
                sp -= 6;
                let a = &stack[sp..sp + 6];
                acc = ((a[0] - a[3]).square() + (a[1] - a[4]).square() + (a[2] - a[5]).square()).sqrt() - acc;
            }
            Op::Rect => {
                // drectangle(x, y, x1, x2, y1, y2), the seed's cheap (not exact) form.
                sp -= 5;
                let a = &stack[sp..sp + 5];
                let (x, y, x1, x2, y1, y2) = (a[0], a[1], a[2], a[3], a[4], acc);
                acc = -((-y1 + y).min(y2 - y).min(-x1 + x).min(x2 - x));
            }
            Op::Box3 => {
                sp -= 8;
                let a = &stack[sp..sp + 8];
                let (x, y, z, x1, x2, y1, y2, z1, z2) = (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], acc);
                acc = -((-z1 + z).min(z2 - z).min(-y1 + y).min(y2 - y).min(-x1 + x).min(x2 - x));
            }
            Op::PolyConst(k) => {
                sp -= 1;
                let (s, e) = ranges[k as usize];
                acc = T::dpoly_const(stack[sp], acc, &polys[s as usize..e as usize]);
            }
            Op::PolyStack(n) => {
                let m = 2 * n as usize + 1;
                stack[sp] = acc;
                sp -= m;
                let a = &stack[sp..sp + m + 1];
                acc = T::dpoly_stack(a[0], a[1], &a[2..]);
            }
        }
    }
    acc
}

/// Runs `code` on a stack buffer sized for `depth`, spilling to a thread-local buffer
/// only for unusually deep programs.
#[inline(always)]
pub(crate) fn run_sized<T: Num>(code: &[Op], polys: &[f64], ranges: &[(u32, u32)], vars: [f64; 3], depth: usize) -> T {
    let need = depth + 1;
    if need <= 8 {
        let mut s = [T::ZERO; 8];
        run(code, polys, ranges, vars, &mut s)
    } else if need <= 32 {
        let mut s = [T::ZERO; 32];
        run(code, polys, ranges, vars, &mut s)
    } else {
        T::with_scratch(need, |s| run(code, polys, ranges, vars, s))
    }
}
