//! The expression language of the command line (x, y, z; arithmetic; the seed's distance helpers).
//!
//! Expressions are compiled once to a flat postfix program with constants folded, then
//! evaluated without allocating, from any number of threads. Gradients come from the same
//! program run on dual numbers, so they are analytic (no finite-difference step to tune).
//!
//! ```
//! use trussmesh::expr::Expr;
//! let d = Expr::parse("max(sqrt(x^2+y^2)-1, -y)").unwrap();
//! assert_eq!(d.eval(0.0, 0.5, 0.0), -0.5);
//! let (v, g) = d.eval_grad(2.0, 0.0, 0.0);
//! assert_eq!((v, g), (1.0, [1.0, 0.0, 0.0]));
//! assert!(Expr::parse("sqr(x)").is_err());
//! ```
//!
//! Grammar, loosest first: `+ -`, `* /`, unary `-` and `+`, `^` (right-associative and
//! tighter than a sign on its left, so `-x^2` is `-(x^2)`), then numbers, `x y z pi e`,
//! parentheses and calls. Functions: `sqrt cbrt abs sin cos tan asin acos atan sinh cosh tanh exp
//! ln log log10 floor ceil sign` (`log` is the natural log), `pow atan2 hypot`, `min max` (one or more arguments) and the
//! DistMesh helpers `dcircle dsphere drectangle dbox dpoly dunion ddiff dintersect`.

mod compile;
mod eval;
mod lex;

use std::fmt;

use glam::{DVec2, DVec3};

use crate::geometry::{Implicit2, Implicit3};
use eval::{run_sized, Dual, Op};

pub use compile::MAX_DEPTH;

/// A parse error, located at the offending token.
#[derive(Debug, Clone, PartialEq)]
pub struct ExprError {
    /// 1-based character column in the source.
    pub column: usize,
    /// What is wrong, naming the token, function or count involved.
    pub message: String,
}

impl fmt::Display for ExprError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "column {}: {}", self.column, self.message)
    }
}

impl std::error::Error for ExprError {}

impl ExprError {
    /// The source line and a caret under the error's column, for terminal output.
    /// Long sources are cut to a window around the column.
    pub fn render(&self, src: &str) -> String {
        const HALF: usize = 38;
        let chars: Vec<char> = src.chars().map(|c| if c.is_whitespace() || c.is_control() { ' ' } else { c }).collect();
        let col = self.column.clamp(1, chars.len() + 1) - 1;
        let (from, to) = if chars.len() <= 2 * HALF {
            (0, chars.len())
        } else {
            let from = col.saturating_sub(HALF);
            (from, (from + 2 * HALF).min(chars.len()))
        };
        let mut line = String::new();
        let mut caret = col - from;
        if from > 0 {
            line.push_str("...");
            caret += 3;
        }
        line.extend(&chars[from..to]);
        if to < chars.len() {
            line.push_str("...");
        }
        format!("{line}\n{}^", " ".repeat(caret))
    }
}

/// A compiled expression in x, y, z.
#[derive(Clone, Debug)]
pub struct Expr {
    src: String,
    code: Box<[Op]>,
    polys: Box<[f64]>,
    ranges: Box<[(u32, u32)]>,
    depth: usize,
    uses_z: bool,
}

impl Expr {
    /// Parses and compiles `src`.
    pub fn parse(src: &str) -> Result<Expr, ExprError> {
        let p = compile::compile(src)?;
        Ok(Expr {
            src: src.to_owned(),
            code: p.code.into(),
            polys: p.polys.into(),
            ranges: p.ranges.into(),
            depth: p.depth,
            uses_z: p.uses_z,
        })
    }

    /// The value at (x, y, z).
    #[inline]
    pub fn eval(&self, x: f64, y: f64, z: f64) -> f64 {
        run_sized::<f64>(&self.code, &self.polys, &self.ranges, [x, y, z], self.depth)
    }

    /// The value and its gradient (d/dx, d/dy, d/dz) at (x, y, z). The value is
    /// identical to [`Expr::eval`]'s. At kinks (abs, min, max, the centre of a circle)
    /// the gradient of the active branch, or zero, is returned. Where the value is finite but
    /// a derivative is not (`abs(x)^0.7` or `x^0.5` at x = 0: the function is fine, its slope
    /// infinite), that component is a finite difference (central, else one-sided), so that a
    /// domain such as `abs(x)^0.7+abs(y)^0.7-1` meshes rather than failing at its cusps.
    pub fn eval_grad(&self, x: f64, y: f64, z: f64) -> (f64, [f64; 3]) {
        let r = run_sized::<Dual>(&self.code, &self.polys, &self.ranges, [x, y, z], self.depth);
        let mut d = r.d;
        if r.v.is_finite() && d.iter().any(|g| !g.is_finite()) {
            for (i, g) in d.iter_mut().enumerate() {
                if !g.is_finite() {
                    *g = self.difference([x, y, z], r.v, i).unwrap_or(*g);
                }
            }
        }
        (r.v, d)
    }

    /// The derivative along axis `i` at `p` (where the value is `v`) by differences: central,
    /// else forward, else backward (a function defined on one side only); `None` when none is
    /// finite. The step is 1e-6 of the point's largest coordinate (at least 1e-3): small
    /// against any domain the mesher can resolve, large against rounding.
    fn difference(&self, p: [f64; 3], v: f64, i: usize) -> Option<f64> {
        let h = 1e-6 * p.iter().fold(1e-3f64, |m, c| m.max(c.abs()));
        let at = |t: f64| {
            let mut q = p;
            q[i] += t;
            self.eval(q[0], q[1], q[2])
        };
        let (up, down) = (at(h), at(-h));
        [(up - down) / (2.0 * h), (up - v) / h, (v - down) / h].into_iter().find(|g| g.is_finite())
    }

    /// The number of operations of the compiled program: what one evaluation costs, about a
    /// few nanoseconds each.
    pub fn ops(&self) -> usize {
        self.code.len()
    }

    /// Whether the variable z appears (a 3-D expression).
    pub fn uses_z(&self) -> bool {
        self.uses_z
    }

    /// Whether the value depends on no variable (x, y and z are never read).
    pub fn is_constant(&self) -> bool {
        !self.code.iter().any(|op| matches!(op, eval::Op::Var(_)))
    }

    /// The source text this was compiled from.
    pub fn source(&self) -> &str {
        &self.src
    }

    /// The compiled program, for tests and curiosity.
    #[doc(hidden)]
    pub fn dump(&self) -> String {
        format!("depth {} {:?}", self.depth, self.code)
    }

    /// Number of instructions after folding (for tests and curiosity).
    #[doc(hidden)]
    pub fn program_len(&self) -> usize {
        self.code.len()
    }
}

impl std::str::FromStr for Expr {
    type Err = ExprError;
    fn from_str(s: &str) -> Result<Expr, ExprError> {
        Expr::parse(s)
    }
}

/// An expression as a 2-D geometry, evaluated at z = 0, with the analytic gradient.
#[derive(Clone, Debug)]
pub struct ExprImplicit2 {
    /// The expression.
    pub expr: Expr,
    /// Whether the caller vouches that the expression is a signed distance
    /// (the mesher then projects in one step).
    pub distance: bool,
}

impl ExprImplicit2 {
    /// Wraps `expr`, not claimed to be a distance.
    pub fn new(expr: Expr) -> Self {
        ExprImplicit2 { expr, distance: false }
    }
}

impl Implicit2 for ExprImplicit2 {
    fn value(&self, p: DVec2) -> f64 {
        self.expr.eval(p.x, p.y, 0.0)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        let (_, g) = self.expr.eval_grad(p.x, p.y, 0.0);
        DVec2::new(g[0], g[1])
    }
    /// The caller's claim (false for [`Self::new`]).
    fn is_distance(&self) -> bool {
        self.distance
    }
    /// A claimed distance is declared; otherwise the meshers decide from the gradient.
    fn declared_distance(&self) -> Option<bool> {
        self.distance.then_some(true)
    }
}

/// An expression as a 3-D geometry, with the analytic gradient.
#[derive(Clone, Debug)]
pub struct ExprImplicit3 {
    /// The expression.
    pub expr: Expr,
    /// Whether the caller vouches that the expression is a signed distance.
    pub distance: bool,
}

impl ExprImplicit3 {
    /// Wraps `expr`, not claimed to be a distance.
    pub fn new(expr: Expr) -> Self {
        ExprImplicit3 { expr, distance: false }
    }
}

impl Implicit3 for ExprImplicit3 {
    fn value(&self, p: DVec3) -> f64 {
        self.expr.eval(p.x, p.y, p.z)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let (_, g) = self.expr.eval_grad(p.x, p.y, p.z);
        DVec3::from_array(g)
    }
    fn value_and_gradient(&self, p: DVec3) -> (f64, DVec3) {
        // `eval_grad`'s value equals `eval`'s bit for bit (checked by the fuzz target).
        let (v, g) = self.expr.eval_grad(p.x, p.y, p.z);
        (v, DVec3::from_array(g))
    }
    /// The caller's claim (false for [`Self::new`]).
    fn is_distance(&self) -> bool {
        self.distance
    }
    /// A claimed distance is declared; otherwise the meshers decide from the gradient.
    fn declared_distance(&self) -> Option<bool> {
        self.distance.then_some(true)
    }
}

/// Fuzz entry: parse arbitrary bytes; if they compile, evaluate at a few points and check
/// that nothing panics and that `eval` and `eval_grad` agree on the value.
#[doc(hidden)]
pub fn fuzz_parse(data: &[u8]) {
    let src = String::from_utf8_lossy(data);
    match Expr::parse(&src) {
        Ok(e) => {
            assert_eq!(e.source(), &*src);
            const PTS: [[f64; 3]; 6] = [
                [0.0, 0.0, 0.0],
                [0.3, -0.7, 1.1],
                [-2.5, 4.0, -0.25],
                [1.0, 1.0, 1.0],
                [1e6, -1e-6, 3.0],
                [f64::NAN, 0.5, f64::INFINITY],
            ];
            for [x, y, z] in PTS {
                let v = e.eval(x, y, z);
                let (w, _) = e.eval_grad(x, y, z);
                assert!(
                    v == w || (v.is_nan() && w.is_nan()),
                    "eval {v} != eval_grad {w} at ({x}, {y}, {z}) for {src:?}"
                );
            }
        }
        Err(err) => {
            let n = src.chars().count();
            assert!(err.column >= 1 && err.column <= n + 1, "column {} out of range", err.column);
            let _ = err.to_string();
            let _ = err.render(&src);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(s: &str) -> f64 {
        Expr::parse(s).unwrap().eval(0.0, 0.0, 0.0)
    }

    #[test]
    fn folds_constants() {
        let e = Expr::parse("2*pi*(1+3)^2 - sqrt(16)").unwrap();
        assert_eq!(e.program_len(), 1);
        assert_eq!(e.eval(0.0, 0.0, 0.0), 2.0 * std::f64::consts::PI * 16.0 - 4.0);
        let e = Expr::parse("dpoly(x, y, 0,0, 1,0, 1,1, 0,1)").unwrap();
        assert_eq!(e.program_len(), 3);
    }

    #[test]
    fn compact_program() {
        let e = Expr::parse("max(sqrt(x^2+y^2)-1, -(sqrt((x+0.4)^2+y^2)-0.55), -y)").unwrap();
        assert_eq!(e.program_len(), 19, "{}", e.dump());
        assert!(e.dump().starts_with("depth 3 "));
    }

    /// Infinite slopes where the value is finite become finite differences: symmetric cusps
    /// (central), one-sided roots (forward); a finite analytic gradient is left as it is.
    #[test]
    fn infinite_slopes_become_differences() {
        let cusp = Expr::parse("abs(x)^0.7+abs(y)^0.7-1").unwrap();
        let (v, g) = cusp.eval_grad(0.0, -1.0, 0.0);
        assert_eq!(v, 0.0);
        assert!(g.iter().all(|c| c.is_finite()), "{g:?}");
        assert_eq!(g[0], 0.0, "symmetric about x = 0");
        assert!((g[1] + 0.7).abs() < 1e-5, "d/dy = -0.7 at y = -1: {}", g[1]);
        let root = Expr::parse("x^0.5-y").unwrap();
        let (_, g) = root.eval_grad(0.0, 0.5, 0.0);
        assert!(g[0].is_finite() && g[0] > 100.0, "a steep forward slope: {}", g[0]);
        assert_eq!(g[1], -1.0);
        let smooth = Expr::parse("x^2+y^2-1").unwrap();
        assert_eq!(smooth.eval_grad(0.5, 0.25, 0.0).1, [1.0, 0.5, 0.0]);
        // Nowhere finite: left for the caller's error.
        let bad = Expr::parse("x^0.5+(-x)^0.5").unwrap();
        assert!(!bad.eval_grad(0.0, 0.0, 0.0).1[0].is_finite());
    }

    #[test]
    fn inverse_and_hyperbolic_functions() {
        assert_eq!(ev("4*atan(1)"), std::f64::consts::PI);
        assert_eq!(Expr::parse("4*atan(1)").unwrap().program_len(), 1, "folded");
        assert_eq!((ev("asin(1)"), ev("acos(1)")), (std::f64::consts::FRAC_PI_2, 0.0));
        assert_eq!((ev("sinh(0)"), ev("cosh(0)"), ev("tanh(0)")), (0.0, 1.0, 0.0));
        assert_eq!((ev("sign(-2)"), ev("sign(3)"), ev("sign(0)")), (-1.0, 1.0, 0.0));
        let e = Expr::parse("sign(x)*tanh(y)").unwrap();
        assert_eq!(e.eval_grad(-1.0, 0.0, 0.0), (-0.0, [0.0, -1.0, 0.0]));
    }

    #[test]
    fn cube_roots_and_hypotenuses() {
        assert_eq!((ev("cbrt(-27)"), ev("cbrt(8)"), ev("cbrt(0)")), (-3.0, 2.0, 0.0));
        assert_eq!(ev("hypot(3, -4)"), 5.0);
        assert_eq!(ev("hypot(1e200, 1e200)"), 1e200 * 2f64.sqrt(), "no overflow");
        // cbrt of a cube is a level set with a usable slope: where the cube's is zero, the
        // root's comes from a difference.
        let e = Expr::parse("cbrt((x-1)^3)").unwrap();
        let (v, g) = e.eval_grad(1.0, 0.0, 0.0);
        assert_eq!(v, 0.0);
        assert!((g[0] - 1.0).abs() < 1e-9, "{g:?}");
        let h = Expr::parse("hypot(x, y) - 1").unwrap();
        assert_eq!(h.eval_grad(0.0, 0.0, 0.0), (-1.0, [0.0, 0.0, 0.0]), "zero at the centre");
        assert_eq!(h.eval_grad(3.0, 4.0, 0.0), (4.0, [0.6, 0.8, 0.0]));
    }

    #[test]
    fn precedence() {
        assert_eq!(ev("-2^2"), -4.0);
        assert_eq!(ev("2^3^2"), 512.0);
        assert_eq!(ev("2^-1"), 0.5);
        assert_eq!(ev("1-2-3"), -4.0);
        assert_eq!(ev("8/4/2"), 1.0);
        assert_eq!(ev("--3"), 3.0);
    }

    #[test]
    fn sign_absorption_is_exact() {
        let e = Expr::parse("-(x+0.4)").unwrap();
        assert_eq!(e.eval(0.1, 0.0, 0.0), -(0.1 + 0.4));
        let e = Expr::parse("-(0.55-x)").unwrap();
        assert_eq!(e.eval(0.1, 0.0, 0.0), -(0.55 - 0.1));
        let e = Expr::parse("-(-x)").unwrap();
        assert_eq!(e.program_len(), 1);
    }

    #[test]
    fn deep_program_uses_scratch() {
        let mut s = String::from("x");
        for _ in 0..100 {
            s = format!("1+x*({s})");
        }
        let e = Expr::parse(&s).unwrap();
        let v = e.eval(0.5, 0.0, 0.0);
        assert!((v - 2.0).abs() < 1e-12, "{v}");
        // A non-constant polygon needs its vertices on the stack.
        let e = Expr::parse("dpoly(x,y, 0,0, 1+z,0, 1,1, 0,1, -1,x, -2,3, -3,2, -4,1, -5,0, -6,-1, -7,-2, -8,-3, -9,-4, -10,-5, -11,-6, -12,-7, -13,-8)").unwrap();
        let (v, _) = e.eval_grad(0.5, 0.5, 0.0);
        assert_eq!(v, e.eval(0.5, 0.5, 0.0));
    }

    #[test]
    fn threads() {
        let e = std::sync::Arc::new(Expr::parse("dcircle(x,y,0,0,1)").unwrap());
        let hs: Vec<_> = (0..4)
            .map(|i| {
                let e = e.clone();
                std::thread::spawn(move || e.eval(i as f64, 0.0, 0.0))
            })
            .collect();
        for (i, h) in hs.into_iter().enumerate() {
            assert_eq!(h.join().unwrap(), i as f64 - 1.0);
        }
    }

    #[test]
    fn render_caret() {
        let err = Expr::parse("1 + sqr(x)").unwrap_err();
        assert_eq!(err.column, 5);
        assert_eq!(err.to_string(), "column 5: unknown function 'sqr'");
        assert_eq!(err.render("1 + sqr(x)"), "1 + sqr(x)\n    ^");
    }
}
