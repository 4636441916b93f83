//! Our JSON layout. Parsed by a small hand-written reader instead of serde_json because
//! serde_json's default float parsing is not always exact, and we want every error to carry
//! a line number.

use super::text::{parse_f64, perr};
use super::{CellType, MeshData};
use crate::Error;

/// A JSON value that keeps numbers as text (parsed later, exactly) and its line.
enum Value<'a> {
    Null,
    Bool,
    Num(&'a str),
    Str(String),
    Arr(Vec<Value<'a>>, usize),
    Obj(Vec<(String, Value<'a>, usize)>),
}

const MAX_DEPTH: usize = 64;

struct Parser<'a> {
    s: &'a str,
    b: &'a [u8],
    i: usize,
    line: usize,
    path: &'a str,
}

impl<'a> Parser<'a> {
    fn err(&self, m: impl Into<String>) -> Error {
        perr(self.path, self.line, m)
    }

    fn unexpected(&self, wanted: &str) -> Error {
        if self.i >= self.b.len() {
            self.err(format!("unexpected end of JSON (truncated file?) while expecting {wanted}"))
        } else {
            self.err(format!("expected {wanted}"))
        }
    }

    fn ws(&mut self) {
        while let Some(&c) = self.b.get(self.i) {
            match c {
                b'\n' => self.line += 1,
                b' ' | b'\t' | b'\r' => {}
                _ => break,
            }
            self.i += 1;
        }
    }

    fn value(&mut self, depth: usize) -> Result<Value<'a>, Error> {
        if depth > MAX_DEPTH {
            return Err(self.err("JSON nested too deeply"));
        }
        self.ws();
        let line = self.line;
        match self.b.get(self.i) {
            None => Err(self.err("unexpected end of JSON (truncated file?)")),
            Some(b'{') => {
                self.i += 1;
                let mut fields = Vec::new();
                self.ws();
                if self.b.get(self.i) == Some(&b'}') {
                    self.i += 1;
                    return Ok(Value::Obj(fields));
                }
                loop {
                    self.ws();
                    let kline = self.line;
                    if self.b.get(self.i) != Some(&b'"') {
                        return Err(self.err("expected a quoted key in JSON object"));
                    }
                    let k = self.string()?;
                    self.ws();
                    if self.b.get(self.i) != Some(&b':') {
                        return Err(self.err(format!("expected ':' after key {k:?}")));
                    }
                    self.i += 1;
                    let v = self.value(depth + 1)?;
                    fields.push((k, v, kline));
                    self.ws();
                    match self.b.get(self.i) {
                        Some(b',') => self.i += 1,
                        Some(b'}') => {
                            self.i += 1;
                            return Ok(Value::Obj(fields));
                        }
                        _ => return Err(self.unexpected("',' or '}' in JSON object")),
                    }
                }
            }
            Some(b'[') => {
                self.i += 1;
                let mut items = Vec::new();
                self.ws();
                if self.b.get(self.i) == Some(&b']') {
                    self.i += 1;
                    return Ok(Value::Arr(items, line));
                }
                loop {
                    items.push(self.value(depth + 1)?);
                    self.ws();
                    match self.b.get(self.i) {
                        Some(b',') => self.i += 1,
                        Some(b']') => {
                            self.i += 1;
                            return Ok(Value::Arr(items, line));
                        }
                        _ => return Err(self.unexpected("',' or ']' in JSON array")),
                    }
                }
            }
            Some(b'"') => Ok(Value::Str(self.string()?)),
            Some(c) if *c == b'-' || c.is_ascii_digit() => {
                let start = self.i;
                while let Some(c) = self.b.get(self.i) {
                    if c.is_ascii_digit() || matches!(c, b'-' | b'+' | b'.' | b'e' | b'E') {
                        self.i += 1;
                    } else {
                        break;
                    }
                }
                Ok(Value::Num(&self.s[start..self.i]))
            }
            Some(_) => {
                for (word, v) in [("null", Value::Null), ("true", Value::Bool), ("false", Value::Bool)] {
                    if self.s[self.i..].starts_with(word) {
                        self.i += word.len();
                        return Ok(v);
                    }
                }
                Err(self.err("unexpected character in JSON"))
            }
        }
    }

    /// A string; escapes are kept simple (keys and cell types never need them).
    fn string(&mut self) -> Result<String, Error> {
        self.i += 1;
        let start = self.i;
        while let Some(&c) = self.b.get(self.i) {
            match c {
                b'"' => {
                    let s = self.s[start..self.i].to_string();
                    self.i += 1;
                    return Ok(s);
                }
                b'\\' => self.i += 2,
                b'\n' => return Err(self.err("newline inside a JSON string")),
                _ => self.i += 1,
            }
        }
        Err(self.err("unterminated JSON string"))
    }
}

pub(crate) fn read(s: &str, path: &str) -> Result<MeshData, Error> {
    let mut p = Parser { s, b: s.as_bytes(), i: 0, line: 1, path };
    let v = p.value(0)?;
    p.ws();
    if p.i != p.b.len() {
        return Err(p.err("trailing characters after the JSON value"));
    }
    let fields = match v {
        Value::Obj(f) => f,
        _ => return Err(perr(path, 1, "expected a JSON object at the top level")),
    };
    let get = |k: &str| fields.iter().find(|f| f.0 == k);
    let need = |k: &str| get(k).ok_or_else(|| perr(path, 1, format!("missing key {k:?} in mesh JSON")));
    let (_, dv, dline) = need("dim")?;
    let dim = match dv {
        Value::Num("2") => 2,
        Value::Num("3") => 3,
        _ => return Err(perr(path, *dline, "\"dim\" must be 2 or 3")),
    };
    let (_, cv, cline) = need("cell_type")?;
    let cell_type = match cv {
        Value::Str(s) if s == "triangle" => CellType::Triangle,
        Value::Str(s) if s == "tetra" => CellType::Tetra,
        _ => return Err(perr(path, *cline, "\"cell_type\" must be \"triangle\" or \"tetra\"")),
    };
    if cell_type == CellType::Tetra && dim != 3 {
        return Err(perr(path, *cline, "tetra meshes need \"dim\": 3"));
    }
    let (_, pv, pline) = need("points")?;
    let Value::Arr(pts, _) = pv else {
        return Err(perr(path, *pline, "\"points\" must be an array"));
    };
    let mut points = Vec::with_capacity(pts.len());
    for (i, q) in pts.iter().enumerate() {
        let Value::Arr(cs, line) = q else {
            return Err(perr(path, *pline, format!("point {i} is not an array")));
        };
        if cs.len() != dim {
            return Err(perr(path, *line, format!("point {i} has {} coordinates, expected {dim}", cs.len())));
        }
        let mut x = [0.0; 3];
        for (k, c) in cs.iter().enumerate() {
            x[k] = match c {
                Value::Num(t) => parse_f64(t),
                _ => None,
            }
            .ok_or_else(|| perr(path, *line, format!("point {i}: coordinate is not a finite number")))?;
        }
        points.push(x);
    }
    let (_, cv, cline) = need("cells")?;
    let Value::Arr(cs, _) = cv else {
        return Err(perr(path, *cline, "\"cells\" must be an array"));
    };
    let k = cell_type.nodes();
    let mut cells = Vec::with_capacity(cs.len() * k);
    for (i, c) in cs.iter().enumerate() {
        let Value::Arr(ix, line) = c else {
            return Err(perr(path, *cline, format!("cell {i} is not an array")));
        };
        if ix.len() != k {
            return Err(perr(
                path,
                *line,
                format!(
                    "cell {i} has {} nodes, a {cv_name} needs {k}",
                    ix.len(),
                    cv_name = if k == 3 { "triangle" } else { "tetra" }
                ),
            ));
        }
        for v in ix {
            let j = match v {
                Value::Num(t) => t.parse::<usize>().ok(),
                _ => None,
            }
            .ok_or_else(|| perr(path, *line, format!("cell {i}: node index is not a non-negative integer")))?;
            if j >= points.len() {
                return Err(perr(
                    path,
                    *line,
                    format!("cell {i} uses node {j} but there are only {} points", points.len()),
                ));
            }
            cells.push(j);
        }
    }
    if cells.is_empty() {
        return Err(perr(path, *cline, "the mesh has no cells"));
    }
    let subdomain = match get("subdomain") {
        None | Some((_, Value::Null, _)) => None,
        Some((_, Value::Arr(ls, line), _)) => {
            if ls.len() != cs.len() {
                return Err(perr(path, *line, format!("{} subdomain labels for {} cells", ls.len(), cs.len())));
            }
            let mut out = Vec::with_capacity(ls.len());
            for l in ls {
                out.push(
                    match l {
                        Value::Num(t) => t.parse::<i32>().ok(),
                        _ => None,
                    }
                    .ok_or_else(|| perr(path, *line, "subdomain labels must be 32-bit integers"))?,
                );
            }
            Some(out)
        }
        Some((_, _, line)) => return Err(perr(path, *line, "\"subdomain\" must be an array")),
    };
    Ok(MeshData { dim, cell_type, points, cells, subdomain })
}

/// Appends rows 0..n to `s`, each "    [...]" with `row` writing its numbers and a comma after
/// all but the last: formatted straight into strings (no string per number), in blocks of rows
/// in parallel joined in order, so the same bytes for any thread count. `width` is a guess of
/// a row's length.
fn rows(s: &mut String, n: usize, width: usize, row: impl Fn(usize, &mut String) + Sync) {
    use rayon::prelude::*;
    const BLOCK: usize = 1 << 14;
    let blocks: Vec<String> = (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut out = String::with_capacity(width * BLOCK);
            for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                out.push_str("    [");
                row(i, &mut out);
                out.push_str(if i + 1 < n { "],\n" } else { "]\n" });
            }
            out
        })
        .collect();
    s.reserve(blocks.iter().map(String::len).sum());
    blocks.iter().for_each(|b| s.push_str(b));
}

pub(crate) fn write(m: &MeshData) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    s.push_str(&format!("{{\n  \"dim\": {},\n", m.dim));
    let ct = match m.cell_type {
        CellType::Triangle => "triangle",
        CellType::Tetra => "tetra",
    };
    s.push_str(&format!("  \"cell_type\": \"{ct}\",\n  \"points\": [\n"));
    rows(&mut s, m.points.len(), 48, |i, out| {
        let mut buf = zmij::Buffer::new();
        for (k, &x) in m.points[i][..m.dim].iter().enumerate() {
            if k > 0 {
                out.push_str(", ");
            }
            if x.is_finite() {
                out.push_str(buf.format_finite(x));
            } else {
                let _ = write!(out, "{x:?}");
            }
        }
    });
    s.push_str("  ],\n  \"cells\": [\n");
    rows(&mut s, m.num_cells(), 24, |i, out| {
        let mut buf = itoa::Buffer::new();
        for (k, &v) in m.cell(i).iter().enumerate() {
            if k > 0 {
                out.push_str(", ");
            }
            out.push_str(buf.format(v));
        }
    });
    s.push_str("  ]");
    if let Some(sd) = &m.subdomain {
        let ls: Vec<String> = sd.iter().map(|v| v.to_string()).collect();
        s.push_str(&format!(",\n  \"subdomain\": [{}]", ls.join(", ")));
    }
    s.push_str("\n}\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Coordinates come back bit for bit, whatever their size (shortest round-trip digits).
    #[test]
    fn coordinates_round_trip_exactly() {
        let xs = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.1,
            1e-7,
            -2.5e-300,
            5e-324,
            1.7976931348623157e308,
            123456789.12345679,
            std::f64::consts::PI,
            1e16,
            -1e21,
        ];
        let points: Vec<[f64; 3]> = xs.chunks(1).map(|c| [c[0], -c[0], 0.0]).collect();
        let n = points.len();
        let m = MeshData {
            dim: 2,
            cell_type: CellType::Triangle,
            points,
            cells: (0..n - 2).flat_map(|i| [i, i + 1, i + 2]).collect(),
            subdomain: None,
        };
        let back = read(&write(&m), "test").expect("reads back");
        for (a, b) in m.points.iter().zip(&back.points) {
            assert_eq!(a[0].to_bits(), b[0].to_bits(), "{} came back as {}", a[0], b[0]);
            assert_eq!(a[1].to_bits(), b[1].to_bits(), "{} came back as {}", a[1], b[1]);
        }
        assert_eq!(m.cells, back.cells);
    }
}
