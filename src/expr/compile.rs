//! Recursive-descent parser that emits postfix code directly, folding constants as it goes.
//!
//! No syntax tree is built: a long flat input (`x+x+...`) then costs no recursion, and
//! nesting, the only thing that recurses, is capped at [`MAX_DEPTH`].

use super::eval::{run, Op};
use super::lex::{lex, Tok, Token};
use super::ExprError;

/// Deepest nesting of parentheses, calls, unary signs and powers accepted.
pub const MAX_DEPTH: usize = 256;

/// Largest operand code moved when a constant left operand becomes an immediate.
const MAX_SHIFT: usize = 64;

pub(crate) struct Program {
    pub code: Vec<Op>,
    pub polys: Vec<f64>,
    pub ranges: Vec<(u32, u32)>,
    pub depth: usize,
    pub uses_z: bool,
}

#[derive(Clone, Copy)]
enum Bin {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Min,
    Max,
    Atan2,
    Hypot,
}

enum Func {
    Unary(Op),
    Binary(Bin),
    /// min, max and their aliases: one or more arguments, folded pairwise.
    Variadic(Bin),
    Diff,
    Fixed(Op, usize),
    Poly,
}

fn lookup(name: &str) -> Option<Func> {
    use Func::*;
    Some(match name {
        "sqrt" => Unary(Op::Sqrt),
        "abs" => Unary(Op::Abs),
        "sin" => Unary(Op::Sin),
        "cos" => Unary(Op::Cos),
        "tan" => Unary(Op::Tan),
        "exp" => Unary(Op::Exp),
        "ln" | "log" => Unary(Op::Ln),
        "log10" => Unary(Op::Log10),
        "floor" => Unary(Op::Floor),
        "ceil" => Unary(Op::Ceil),
        "asin" => Unary(Op::Asin),
        "acos" => Unary(Op::Acos),
        "atan" => Unary(Op::Atan),
        "sinh" => Unary(Op::Sinh),
        "cosh" => Unary(Op::Cosh),
        "tanh" => Unary(Op::Tanh),
        "cbrt" => Unary(Op::Cbrt),
        "sign" => Unary(Op::Sign),
        "pow" => Binary(Bin::Pow),
        "atan2" => Binary(Bin::Atan2),
        "hypot" => Binary(Bin::Hypot),
        "min" | "dunion" => Variadic(Bin::Min),
        "max" | "dintersect" => Variadic(Bin::Max),
        "ddiff" => Diff,
        "dcircle" => Fixed(Op::Circle, 5),
        "dsphere" => Fixed(Op::Sphere, 7),
        "drectangle" => Fixed(Op::Rect, 6),
        "dbox" => Fixed(Op::Box3, 9),
        "dpoly" => Poly,
        _ => return None,
    })
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

struct Parser {
    toks: Vec<Token>,
    pos: usize,
    depth: usize,
    code: Vec<Op>,
    polys: Vec<f64>,
    ranges: Vec<(u32, u32)>,
    uses_z: bool,
}

pub(crate) fn compile(src: &str) -> Result<Program, ExprError> {
    let toks = lex(src)?;
    let mut p =
        Parser { toks, pos: 0, depth: 0, code: Vec::new(), polys: Vec::new(), ranges: Vec::new(), uses_z: false };
    if p.peek() == &Tok::End {
        return Err(p.error_here("empty expression".into()));
    }
    p.expr()?;
    if p.peek() != &Tok::End {
        let d = p.peek().describe();
        return Err(p.error_here(format!("unexpected {d} after a complete expression")));
    }
    let mut h: isize = 0;
    let mut depth: isize = 0;
    for op in &p.code {
        h += op.stack_effect();
        depth = depth.max(h);
    }
    debug_assert_eq!(h, 1);
    Ok(Program { code: p.code, polys: p.polys, ranges: p.ranges, depth: depth as usize, uses_z: p.uses_z })
}

impl Parser {
    fn peek(&self) -> &Tok {
        &self.toks[self.pos].tok
    }

    fn column(&self) -> usize {
        self.toks[self.pos].column
    }

    fn bump(&mut self) -> Token {
        let t = self.toks[self.pos].clone();
        if self.pos + 1 < self.toks.len() {
            self.pos += 1;
        }
        t
    }

    fn error_here(&self, message: String) -> ExprError {
        ExprError { column: self.column(), message }
    }

    /// The constant, if `code[start..end]` is exactly one constant.
    fn konst(&self, start: usize, end: usize) -> Option<f64> {
        match self.code[start..end] {
            [Op::Const(c)] => Some(c),
            _ => None,
        }
    }

    /// Replaces `code[start..]`, which uses no variables, by its value.
    fn fold_from(&mut self, start: usize) {
        let code = &self.code[start..];
        let mut stack = vec![0.0f64; code.len() + 2];
        let v: f64 = run(code, &self.polys, &self.ranges, [0.0; 3], &mut stack);
        self.code.truncate(start);
        self.code.push(Op::Const(v));
    }

    fn expr(&mut self) -> Result<usize, ExprError> {
        let start = self.term()?;
        loop {
            let op = match self.peek() {
                Tok::Plus => Bin::Add,
                Tok::Minus => Bin::Sub,
                _ => return Ok(start),
            };
            self.bump();
            let rhs = self.term()?;
            self.emit_bin(op, start, rhs);
        }
    }

    fn term(&mut self) -> Result<usize, ExprError> {
        let start = self.unary()?;
        loop {
            let op = match self.peek() {
                Tok::Star => Bin::Mul,
                Tok::Slash => Bin::Div,
                _ => return Ok(start),
            };
            self.bump();
            let rhs = self.unary()?;
            self.emit_bin(op, start, rhs);
        }
    }

    /// Every level of nesting passes through here, so the depth limit lives here.
    fn unary(&mut self) -> Result<usize, ExprError> {
        if self.depth >= MAX_DEPTH {
            return Err(self.error_here(format!("expression nested deeper than {MAX_DEPTH} levels")));
        }
        self.depth += 1;
        let r = self.unary_inner();
        self.depth -= 1;
        r
    }

    fn unary_inner(&mut self) -> Result<usize, ExprError> {
        match self.peek() {
            Tok::Minus => {
                self.bump();
                let s = self.unary()?;
                self.emit_neg(s);
                Ok(s)
            }
            Tok::Plus => {
                self.bump();
                self.unary()
            }
            _ => {
                // Power binds tighter than a sign on its left and is right-associative:
                // -x^2 = -(x^2), 2^3^2 = 2^9, 2^-1 = 0.5.
                let base = self.primary()?;
                if self.peek() == &Tok::Caret {
                    self.bump();
                    let e = self.unary()?;
                    self.emit_bin(Bin::Pow, base, e);
                }
                Ok(base)
            }
        }
    }

    fn primary(&mut self) -> Result<usize, ExprError> {
        let start = self.code.len();
        let t = self.bump();
        match t.tok {
            Tok::Num(v) => self.code.push(Op::Const(v)),
            Tok::LParen => {
                self.expr()?;
                self.expect_close(t.column, None)?;
            }
            Tok::Ident(name) => {
                if self.peek() == &Tok::LParen {
                    self.call(&name, t.column)?;
                } else {
                    let op = match name.as_str() {
                        "x" => Op::Var(0),
                        "y" => Op::Var(1),
                        "z" => {
                            self.uses_z = true;
                            Op::Var(2)
                        }
                        "pi" => Op::Const(std::f64::consts::PI),
                        "e" => Op::Const(std::f64::consts::E),
                        _ if lookup(&name).is_some() => {
                            return Err(ExprError {
                                column: t.column,
                                message: format!("function '{name}' needs its arguments in parentheses"),
                            })
                        }
                        _ => {
                            return Err(ExprError {
                                column: t.column,
                                message: format!("unknown variable '{name}' (the variables are x, y, z)"),
                            })
                        }
                    };
                    self.code.push(op);
                }
            }
            Tok::End => {
                return Err(ExprError {
                    column: t.column,
                    message: "unexpected end of input: expected a number, variable, function or '('".into(),
                })
            }
            other => {
                return Err(ExprError {
                    column: t.column,
                    message: format!("unexpected {}: expected a number, variable, function or '('", other.describe()),
                })
            }
        }
        Ok(start)
    }

    fn expect_close(&mut self, open_col: usize, func: Option<&str>) -> Result<(), ExprError> {
        match self.peek() {
            Tok::RParen => {
                self.bump();
                Ok(())
            }
            Tok::Comma if func.is_none() => {
                Err(self.error_here("unexpected ',' outside a function's arguments".into()))
            }
            t => {
                let what = match func {
                    Some(f) => format!("expected ',' or ')' in the arguments of '{f}' (opened at column {open_col})"),
                    None => format!("expected ')' to close the '(' at column {open_col}"),
                };
                let found = t.describe();
                Err(self.error_here(format!("{what}, found {found}")))
            }
        }
    }

    fn call(&mut self, name: &str, col: usize) -> Result<(), ExprError> {
        let Some(func) = lookup(name) else {
            let hint = match name {
                "x" | "y" | "z" => " (variables are not functions; write x*(...) for a product)",
                _ => "",
            };
            return Err(ExprError { column: col, message: format!("unknown function '{name}'{hint}") });
        };
        let open_col = self.bump().column; // '('
        let mut args: Vec<usize> = Vec::new();
        if self.peek() == &Tok::RParen {
            self.bump();
        } else {
            loop {
                let s = self.expr()?;
                args.push(s);
                // Reduce min/max as we go so the stack stays shallow for any argument count.
                if let Func::Variadic(op) = func {
                    if args.len() > 1 {
                        self.emit_bin(op, args[0], s);
                    }
                }
                if self.peek() == &Tok::Comma {
                    self.bump();
                    continue;
                }
                self.expect_close(open_col, Some(name))?;
                break;
            }
        }
        let n = args.len();
        let wrong =
            |expected: String| ExprError { column: col, message: format!("{name} expects {expected}, got {n}") };
        match func {
            Func::Unary(op) => {
                if n != 1 {
                    return Err(wrong("1 argument".into()));
                }
                self.emit_unary(op, args[0]);
            }
            Func::Binary(op) => {
                if n != 2 {
                    return Err(wrong("2 arguments".into()));
                }
                self.emit_bin(op, args[0], args[1]);
            }
            Func::Variadic(_) => {
                if n == 0 {
                    return Err(wrong("at least 1 argument".into()));
                }
            }
            Func::Diff => {
                if n != 2 {
                    return Err(wrong("2 arguments".into()));
                }
                self.emit_neg(args[1]);
                self.emit_bin(Bin::Max, args[0], args[1]);
            }
            Func::Fixed(op, k) => {
                if n != k {
                    return Err(wrong(format!("{k} argument{}", plural(k))));
                }
                let all_const = (0..n).all(|i| {
                    let end = args.get(i + 1).copied().unwrap_or(self.code.len());
                    self.konst(args[i], end).is_some()
                });
                self.code.push(op);
                if all_const {
                    self.fold_from(args[0]);
                }
            }
            Func::Poly => {
                if n < 8 || n % 2 != 0 {
                    return Err(wrong(
                        "x, y and an even number of at least 6 vertex coordinates (3 or more vertices)".into(),
                    ));
                }
                let end_of = |p: &Parser, i: usize| args.get(i + 1).copied().unwrap_or(p.code.len());
                let verts: Option<Vec<f64>> = (2..n).map(|i| self.konst(args[i], end_of(self, i))).collect();
                let xy_const = (0..2).all(|i| self.konst(args[i], end_of(self, i)).is_some());
                let nv = (n - 2) / 2;
                match verts {
                    Some(v) => {
                        self.code.truncate(args[2]);
                        let s = self.polys.len() as u32;
                        self.polys.extend_from_slice(&v);
                        self.ranges.push((s, self.polys.len() as u32));
                        self.code.push(Op::PolyConst(self.ranges.len() as u32 - 1));
                        if xy_const {
                            self.fold_from(args[0]);
                        }
                    }
                    None => self.code.push(Op::PolyStack(nv as u32)),
                }
            }
        }
        Ok(())
    }

    fn emit_unary(&mut self, op: Op, s: usize) {
        self.code.push(op);
        if self.konst(s, self.code.len() - 1).is_some() {
            self.fold_from(s);
        }
    }

    fn emit_neg(&mut self, s: usize) {
        let len = self.code.len();
        if let Some(c) = self.konst(s, len) {
            self.code[s] = Op::Const(-c);
            return;
        }
        // Absorb the sign into the last op when that is exact.
        let last = &mut self.code[len - 1];
        match *last {
            Op::Neg => {
                self.code.pop();
            }
            // -(a + c) = -c - a and -(c - a) = a + -c, exactly in IEEE arithmetic.
            Op::AddC(c) => *last = Op::RSubC(-c),
            Op::RSubC(c) => *last = Op::AddC(-c),
            Op::MulC(c) => *last = Op::MulC(-c),
            _ => self.code.push(Op::Neg),
        }
    }

    /// Emits `lhs op rhs` where the operands' code starts at `l` and `r` (ending at the end).
    fn emit_bin(&mut self, op: Bin, l: usize, r: usize) {
        let len = self.code.len();
        let lc = self.konst(l, r);
        let rc = self.konst(r, len);
        let general = match op {
            Bin::Add => Op::Add,
            Bin::Sub => Op::Sub,
            Bin::Mul => Op::Mul,
            Bin::Div => Op::Div,
            Bin::Pow => Op::Pow,
            Bin::Min => Op::Min,
            Bin::Max => Op::Max,
            Bin::Atan2 => Op::Atan2,
            Bin::Hypot => Op::Hypot,
        };
        if lc.is_some() && rc.is_some() {
            self.code.push(general);
            self.fold_from(l);
            return;
        }
        if let Some(c) = rc {
            let imm = match op {
                Bin::Add => Some(Op::AddC(c)),
                Bin::Sub => Some(Op::AddC(-c)),
                Bin::Mul => Some(Op::MulC(c)),
                Bin::Div => Some(Op::DivC(c)),
                Bin::Pow if c == 2.0 => Some(Op::Square),
                Bin::Pow if c == c.trunc() && c.abs() <= 64.0 => Some(Op::PowI(c as i32)),
                Bin::Pow => Some(Op::PowC(c)),
                Bin::Min => Some(Op::MinC(c)),
                Bin::Max => Some(Op::MaxC(c)),
                Bin::Atan2 | Bin::Hypot => None,
            };
            if let Some(imm) = imm {
                self.code.pop();
                self.code.push(imm);
                return;
            }
        }
        if let Some(c) = lc {
            if len - r <= MAX_SHIFT {
                let imm = match op {
                    Bin::Add => Some(Op::AddC(c)),
                    Bin::Sub => Some(Op::RSubC(c)),
                    Bin::Mul => Some(Op::MulC(c)),
                    Bin::Div => Some(Op::RDivC(c)),
                    Bin::Pow => Some(Op::RPowC(c)),
                    Bin::Min => Some(Op::MinC(c)),
                    Bin::Max => Some(Op::MaxC(c)),
                    Bin::Atan2 | Bin::Hypot => None,
                };
                if let Some(imm) = imm {
                    self.code.remove(l);
                    self.code.push(imm);
                    return;
                }
            }
        }
        self.code.push(general);
    }
}
