//! Scene files (TOML) and the numbers and expressions of the command line: parsed with
//! messages that name the field and the problem.

use super::mesh::{ProjectionArg, Spec};
use super::Failure;
use serde::Deserialize;
use std::path::PathBuf;
use trussmesh::expr::Expr;

/// A count given on the command line: a whole number from 0 up, with a message that says so
/// (a negative number is not taken for a flag).
pub fn whole_number<T: std::str::FromStr>(s: &str) -> Result<T, String> {
    s.trim().parse::<T>().map_err(|_| {
        if s.trim().starts_with('-') {
            format!("{s} is negative: give a whole number from 0 up")
        } else {
            format!("{s:?} is not a whole number: give one from 0 up, such as 500")
        }
    })
}

/// A number in a scene file: a TOML number or a constant expression string.
#[derive(Debug, Clone)]
pub(super) enum Num {
    F(f64),
    S(String),
}

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Num, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Num;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number (such as 0.1) or a constant expression in a string (such as \"0.05/3\")")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Num, E> {
                if v.is_finite() {
                    Ok(Num::F(v))
                } else {
                    Err(E::custom(format!("{v} is not a finite number")))
                }
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Num, E> {
                Ok(Num::F(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Num, E> {
                Ok(Num::F(v as f64))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Num, E> {
                Ok(Num::S(v.to_string()))
            }
        }
        d.deserialize_any(V)
    }
}

impl Num {
    fn text(&self) -> String {
        match self {
            Num::F(v) => format!("{v:?}"),
            Num::S(s) => s.clone(),
        }
    }
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneFile {
    dim: Option<usize>,
    domain: String,
    size: Option<String>,
    h0: Num,
    bbox: Vec<Num>,
    origin: Option<Vec<Num>>,
    spacing: Option<Num>,
    fix: Option<Vec<Vec<Num>>>,
    max_iter: Option<usize>,
    seed: Option<u64>,
    projection: Option<ProjectionArg>,
    implicit: Option<bool>,
    internal: Option<String>,
    metric: Option<String>,
    sharp: Option<bool>,
    output: Option<Vec<PathBuf>>,
    max_memory: Option<String>,
}

/// Splits at `sep` outside parentheses.
pub fn split_top(s: &str, sep: char) -> Vec<String> {
    let mut out = Vec::new();
    let mut depth = 0i32;
    let mut cur = String::new();
    for c in s.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            _ => {}
        }
        if c == sep && depth <= 0 {
            out.push(std::mem::take(&mut cur));
        } else {
            cur.push(c);
        }
    }
    out.push(cur);
    out
}

/// The run a scene file's text describes (`name` names it in errors).
pub fn scene_spec(text: &str, name: &str) -> Result<Spec, Failure> {
    let s: SceneFile = toml::from_str(text).map_err(|e| Failure::bad(format!("bad scene file {name}: {e}")))?;
    Ok(Spec {
        dim: s.dim.unwrap_or(2),
        domain: s.domain,
        size: s.size,
        auto: Default::default(),
        h0: s.h0.text(),
        bbox: s.bbox.iter().map(Num::text).collect(),
        place: super::fields::Placement {
            origin: s.origin.map(|o| o.iter().map(Num::text).collect::<Vec<_>>().join(",")),
            spacing: s.spacing.map(|h| h.text()),
        },
        fix: s.fix.unwrap_or_default().iter().map(|p| p.iter().map(Num::text).collect()).collect(),
        max_iter: s.max_iter,
        seed: s.seed,
        projection: s.projection,
        implicit: s.implicit.unwrap_or(false),
        internal: s.internal,
        metric: s.metric,
        sharp: s.sharp.unwrap_or(true),
        outputs: s.output.unwrap_or_default(),
        max_memory: s.max_memory,
    })
}

/// Parses an expression, reporting errors with a caret under the column.
pub fn parse_expr(what: &str, src: &str) -> Result<Expr, Failure> {
    Expr::parse(src).map_err(|e| Failure::bad(format!("bad {what} expression, {e}\n{}", e.render(src))))
}

/// A constant expression (a number, or something like 5*pi/2).
pub fn constant(what: &str, src: &str) -> Result<f64, Failure> {
    let e = parse_expr(what, src.trim())?;
    let v = e.eval(0.0, 0.0, 0.0);
    if e.eval(0.37, -1.3, 2.1).to_bits() != v.to_bits() && !v.is_nan() {
        return Err(Failure::bad(format!("{what} must be a constant, not {src:?} (it depends on x, y or z)")));
    }
    if !v.is_finite() {
        return Err(Failure::bad(format!("{what} {src:?} is not a finite number")));
    }
    Ok(v)
}
