//! Shared pieces of the text readers: a whitespace token stream that remembers line numbers
//! (so every error can point at a line) and number parsing that rejects non-finite values.

use super::CellType;
use crate::Error;

/// Shortest text that parses back to exactly the same f64 (Rust's Debug is round-trip exact,
/// and uses exponents for very large or small values).
pub(crate) fn fmt_f64(x: f64) -> String {
    format!("{x:?}")
}

/// A parse error at `line` of `path`.
pub(crate) fn perr(path: &str, line: usize, message: impl Into<String>) -> Error {
    Error::Parse { path: path.to_string(), line, message: message.into() }
}

/// Whitespace-separated tokens with their 1-based line numbers.
pub(crate) struct Tokens<'a> {
    toks: Vec<(usize, &'a str)>,
    pos: usize,
    last_line: usize,
    pub path: &'a str,
}

impl<'a> Tokens<'a> {
    /// Splits `text` (starting at line `first_line`), dropping anything after `comment` on a line.
    pub fn new(text: &'a str, path: &'a str, comment: Option<char>, first_line: usize) -> Self {
        let mut toks = Vec::new();
        let mut last_line = first_line;
        for (i, line) in text.lines().enumerate() {
            let line = match comment.and_then(|c| line.find(c)) {
                Some(k) => &line[..k],
                None => line,
            };
            last_line = first_line + i;
            for t in line.split_whitespace() {
                toks.push((first_line + i, t));
            }
        }
        Tokens { toks, pos: 0, last_line, path }
    }

    /// Tokens not yet consumed: the cap for any count a header claims.
    pub fn remaining(&self) -> usize {
        self.toks.len() - self.pos
    }

    /// Line of the next token (or the last line at the end).
    pub fn line(&self) -> usize {
        self.toks.get(self.pos).map_or(self.last_line, |t| t.0)
    }

    pub fn err(&self, message: impl Into<String>) -> Error {
        perr(self.path, self.line(), message)
    }

    pub fn err_at(&self, line: usize, message: impl Into<String>) -> Error {
        perr(self.path, line, message)
    }

    pub fn peek(&self) -> Option<&'a str> {
        self.toks.get(self.pos).map(|t| t.1)
    }

    pub fn next(&mut self, what: &str) -> Result<&'a str, Error> {
        match self.toks.get(self.pos) {
            Some(t) => {
                self.pos += 1;
                Ok(t.1)
            }
            None => Err(self.err(format!("unexpected end of file while reading {what}"))),
        }
    }

    /// Line of the token just consumed.
    pub fn prev_line(&self) -> usize {
        if self.pos == 0 {
            1
        } else {
            self.toks[self.pos - 1].0
        }
    }

    pub fn expect(&mut self, word: &str) -> Result<(), Error> {
        let t = self.next(word)?;
        if t != word {
            return Err(self.err_at(self.prev_line(), format!("expected {word:?}, found {t:?}")));
        }
        Ok(())
    }

    pub fn f64(&mut self, what: &str) -> Result<f64, Error> {
        let t = self.next(what)?;
        parse_f64(t).ok_or_else(|| self.err_at(self.prev_line(), format!("{what}: {t:?} is not a finite number")))
    }

    pub fn i64(&mut self, what: &str) -> Result<i64, Error> {
        let t = self.next(what)?;
        t.parse::<i64>().map_err(|_| self.err_at(self.prev_line(), format!("{what}: {t:?} is not an integer")))
    }

    pub fn i32(&mut self, what: &str) -> Result<i32, Error> {
        let v = self.i64(what)?;
        i32::try_from(v).map_err(|_| self.err_at(self.prev_line(), format!("{what}: {v} does not fit in 32 bits")))
    }

    pub fn usize(&mut self, what: &str) -> Result<usize, Error> {
        let t = self.next(what)?;
        t.parse::<usize>()
            .map_err(|_| self.err_at(self.prev_line(), format!("{what}: {t:?} is not a non-negative integer")))
    }

    /// A count of items of `per` tokens each, rejected when the rest of the file cannot hold it.
    pub fn count(&mut self, what: &str, per: usize) -> Result<usize, Error> {
        let n = self.usize(what)?;
        if n.saturating_mul(per.max(1)) > self.remaining() {
            return Err(self.err_at(
                self.prev_line(),
                format!("{what} {n} is more than the rest of the file holds (truncated or garbled)"),
            ));
        }
        Ok(n)
    }

    /// The tokens left on the line of the next token.
    pub fn rest_of_line(&mut self) -> Vec<&'a str> {
        let line = self.line();
        let mut out = Vec::new();
        while let Some(t) = self.toks.get(self.pos) {
            if t.0 != line {
                break;
            }
            out.push(t.1);
            self.pos += 1;
        }
        out
    }
}

/// A finite f64, or None.
pub(crate) fn parse_f64(t: &str) -> Option<f64> {
    t.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Formats that always store three coordinates call a triangle mesh planar (dim 2) when every
/// z is zero; -0.0 is normalised so the result writes back identically.
pub(crate) fn settle_dim(points: &mut [[f64; 3]], cell_type: CellType) -> usize {
    if cell_type == CellType::Triangle && points.iter().all(|p| p[2] == 0.0) {
        for p in points.iter_mut() {
            p[2] = 0.0;
        }
        2
    } else {
        3
    }
}
