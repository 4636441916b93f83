//! Shared pieces of the binary readers and writers: the ASCII / binary choice, a bounds-checked
//! little-endian byte cursor whose errors name the byte offset, and base64 for VTK's inline
//! binary arrays.

use super::text::perr;
use crate::Error;

/// How a format that has both forms stores its numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Encoding {
    /// Text: readable and diffable, about three times larger and ten times slower to write.
    Ascii,
    /// Raw little-endian numbers: exact, compact and fast.
    Binary,
    /// ASCII below [`Encoding::AUTO_BINARY_CELLS`] cells, binary from there on.
    #[default]
    Auto,
}

impl Encoding {
    /// Cell count from which [`Encoding::Auto`] writes binary: larger text files take seconds
    /// to write and read while nobody reads them by eye.
    pub const AUTO_BINARY_CELLS: usize = 100_000;

    /// Whether a mesh of `cells` cells is written binary.
    pub fn is_binary(self, cells: usize) -> bool {
        match self {
            Encoding::Ascii => false,
            Encoding::Binary => true,
            Encoding::Auto => cells >= Self::AUTO_BINARY_CELLS,
        }
    }
}

/// Reads little-endian numbers from a byte slice; every read is checked against the end.
pub(crate) struct Cursor<'a> {
    pub bytes: &'a [u8],
    pub pos: usize,
    pub path: &'a str,
}

impl<'a> Cursor<'a> {
    pub fn new(bytes: &'a [u8], pos: usize, path: &'a str) -> Self {
        Cursor { bytes, pos, path }
    }

    /// A parse error at the current byte (reported in the line field as a byte offset would
    /// be misleading: the message names the offset instead).
    pub fn err(&self, message: impl Into<String>) -> Error {
        perr(self.path, 0, format!("at byte {}: {}", self.pos, message.into()))
    }

    /// The next `n` bytes.
    pub fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], Error> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| {
            self.err(format!("the file ends inside {what} ({n} bytes needed, {} left)", self.bytes.len() - self.pos))
        })?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    pub fn i32(&mut self, what: &str) -> Result<i32, Error> {
        Ok(i32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }

    pub fn u64(&mut self, what: &str) -> Result<u64, Error> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }

    /// A finite f64.
    pub fn f64(&mut self, what: &str) -> Result<f64, Error> {
        let v = f64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes"));
        if !v.is_finite() {
            self.pos -= 8;
            return Err(self.err(format!("{what} is not a finite number ({v})")));
        }
        Ok(v)
    }

    /// A count of items of at least `per` bytes each, capped by the bytes left, so that a
    /// corrupt header cannot ask for a huge allocation.
    pub fn count(&mut self, what: &str, per: usize) -> Result<usize, Error> {
        let v = self.u64(what)?;
        let left = (self.bytes.len() - self.pos) / per.max(1);
        usize::try_from(v).ok().filter(|&v| v <= left).ok_or_else(|| {
            self.pos -= 8;
            self.err(format!("{what} {v} is more than the {left} the rest of the file can hold"))
        })
    }
}

/// Decodes a VTK inline binary array: base64 of a `header_bytes` size header and the data,
/// either as one stream or (as some writers do) as two separately padded streams.
pub(crate) fn base64_decode(text: &[u8], header_bytes: usize) -> Option<Vec<u8>> {
    use base64::Engine;
    let clean: Vec<u8> = text.iter().copied().filter(|c| !c.is_ascii_whitespace()).collect();
    let engine = &base64::engine::general_purpose::STANDARD;
    if let Ok(v) = engine.decode(&clean) {
        return Some(v);
    }
    let split = header_bytes.div_ceil(3) * 4;
    if clean.len() < split {
        return None;
    }
    let mut head = engine.decode(&clean[..split]).ok()?;
    head.extend(engine.decode(&clean[split..]).ok()?);
    Some(head)
}

/// Standard base64 with padding (tests write VTK's inline form with it).
#[cfg(test)]
pub(crate) fn base64_encode(bytes: &[u8]) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_every_length() {
        for n in 0..40usize {
            let bytes: Vec<u8> = (0..n).map(|i| (i * 37 + 11) as u8).collect();
            let s = base64_encode(&bytes);
            assert_eq!(s.len() % 4, 0);
            assert_eq!(base64_decode(s.as_bytes(), 8).unwrap(), bytes, "length {n}");
        }
        assert_eq!(base64_encode(b"Man"), "TWFu");
        assert!(base64_decode(b"TW!u", 8).is_none());
    }

    #[test]
    fn two_padded_groups_decode_as_one_stream() {
        let (a, b) = (b"abcd".to_vec(), b"efg".to_vec());
        let s = base64_encode(&a) + &base64_encode(&b);
        assert_eq!(base64_decode(s.as_bytes(), 4).unwrap(), b"abcdefg");
    }

    #[test]
    fn cursor_errors_name_the_offset() {
        let bytes = [1u8, 0, 0, 0, 5];
        let mut c = Cursor::new(&bytes, 0, "f");
        assert_eq!(c.i32("x").unwrap(), 1);
        let e = c.u64("count").unwrap_err().to_string();
        assert!(e.contains("byte 4") && e.contains("count"), "{e}");
    }
}
