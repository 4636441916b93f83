//! The memory budget: every command estimates the bytes its work needs from what it knows
//! before the work (the element estimate of the mesher's survey, a picture's header) and
//! refuses at once, with the estimate, a run that cannot fit.
//!
//! The bytes per element and per pixel are peak resident sizes measured on this code base
//! (`/usr/bin/time -f %M`), divided by the count, rounded up:
//!
//! | work | measured | per unit |
//! |---|---|---|
//! | 2-D mesh | 5.07 GB at 1.48 x 10^7 triangles | 350 bytes a triangle |
//! | 3-D mesh | 732 MB at 1.37 x 10^6 tets | 550 bytes a tet |
//! | surface mesh | 583 MB at 1.04 x 10^6 triangles (a sphere, h0 0.0051) | 575 bytes a triangle |
//! | picture (decoding, distance, sizes) | 75 MB at 10^6 pixels, 287 MB at 4 x 10^6 | 75 bytes a pixel |

use super::Failure;

/// Peak bytes per triangle of the 2-D mesher.
pub const BYTES_PER_TRIANGLE_2D: f64 = 350.0;
/// Peak bytes per tetrahedron of the 3-D mesher.
pub const BYTES_PER_TET: f64 = 550.0;
/// Peak bytes per triangle of the surface mesher.
pub const BYTES_PER_SURFACE_TRIANGLE: f64 = 575.0;
/// Peak bytes per pixel of a picture's decoding, distance and size function.
pub const BYTES_PER_PIXEL: f64 = 75.0;
/// What the program needs with no work at all (code, buffers, threads).
pub const BASE_BYTES: f64 = 16e6;

/// The default budget is this fraction of the machine's memory: the machine is shared, and
/// a run that takes all of it takes it from everything else too.
pub const DEFAULT_FRACTION: f64 = 0.25;
/// The default budget where the machine's memory cannot be read.
pub const FALLBACK_BYTES: u64 = 4 << 30;

/// A memory limit and where it came from, for the messages.
#[derive(Clone, Debug)]
pub struct Budget {
    /// Bytes.
    pub limit: u64,
    /// "--max-memory 2G", or "a quarter of this machine's 23.4 GB".
    pub source: String,
}

/// The machine's memory in bytes (MemTotal of /proc/meminfo), where it can be read.
pub fn machine_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// Bytes in the units people read: "2.00 GB", "740 MB", "12.3 TB".
pub fn human(bytes: f64) -> String {
    if !bytes.is_finite() {
        return "more bytes than can be counted".into();
    }
    const UNITS: [(&str, f64); 6] = [("EB", 1e18), ("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)];
    for (name, size) in UNITS {
        if bytes >= size {
            let v = bytes / size;
            return if v >= 100.0 { format!("{v:.0} {name}") } else { format!("{v:.2} {name}") };
        }
    }
    format!("{bytes:.0} bytes")
}

/// Parses a byte count: a number with an optional unit k, M, G, T (powers of 1000, with an
/// optional B) or KiB, MiB, GiB, TiB (powers of 1024); no unit means bytes.
pub fn parse_bytes(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let bad = || {
        format!("{text:?} is not an amount of memory: give a number with an optional unit, such as 2G, 500M, 1.5GiB or 800000000")
    };
    let v: f64 = num.parse().map_err(|_| bad())?;
    let scale = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "k" | "kb" => 1e3,
        "m" | "mb" => 1e6,
        "g" | "gb" => 1e9,
        "t" | "tb" => 1e12,
        "kib" => 1024.0,
        "mib" => 1024.0 * 1024.0,
        "gib" => 1024.0 * 1024.0 * 1024.0,
        "tib" => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        _ => return Err(bad()),
    };
    let bytes = v * scale;
    if !(1.0..1.8e19).contains(&bytes) {
        return Err(format!("--max-memory {text:?} must be at least one byte and below 18 EB"));
    }
    Ok(bytes as u64)
}

impl Budget {
    /// The budget of `--max-memory` when given, else the default fraction of the machine.
    pub fn new(max_memory: Option<&str>) -> Result<Budget, Failure> {
        if let Some(text) = max_memory {
            let limit = parse_bytes(text).map_err(Failure::bad)?;
            return Ok(Budget { limit, source: format!("--max-memory {}", text.trim()) });
        }
        Ok(match machine_memory() {
            Some(m) => Budget {
                limit: (m as f64 * DEFAULT_FRACTION) as u64,
                source: format!("the default, a quarter of this machine's {}", human(m as f64)),
            },
            None => {
                Budget { limit: FALLBACK_BYTES, source: "the default where the machine's memory is unknown".into() }
            }
        })
    }

    /// Refuses `bytes` past the limit: "the 2-D mesh would need about 5.3 GB (1.5e7 triangles at
    /// about 350 bytes each), past the memory budget of 2.00 GB (--max-memory 2G)".
    pub fn check(&self, what: &str, bytes: f64, detail: &str, advice: &str) -> Result<(), Failure> {
        if bytes <= self.limit as f64 {
            return Ok(());
        }
        Err(Failure::bad(format!(
            "{what} would need about {} of memory ({detail}), past the memory budget of {} ({}); {advice}, or raise the budget with --max-memory",
            human(bytes),
            human(self.limit as f64),
            self.source
        )))
    }
}

/// A count in the units people read: 15000000 as "1.5e7", small counts as they are.
pub fn count(n: f64) -> String {
    if !n.is_finite() {
        return "more than can be counted".into();
    }
    if n < 1e5 {
        format!("{n:.0}")
    } else {
        format!("{n:.2e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_parse_in_both_unit_systems() {
        assert_eq!(parse_bytes("2G").unwrap(), 2_000_000_000);
        assert_eq!(parse_bytes("2GB").unwrap(), 2_000_000_000);
        assert_eq!(parse_bytes("1GiB").unwrap(), 1 << 30);
        assert_eq!(parse_bytes("500m").unwrap(), 500_000_000);
        assert_eq!(parse_bytes("800000").unwrap(), 800_000);
        for bad in ["", "G", "-1G", "2X", "1e400", "0", "nan"] {
            assert!(parse_bytes(bad).is_err(), "{bad:?} was accepted");
        }
    }

    #[test]
    fn the_check_names_the_estimate_and_the_limit() {
        let b = Budget { limit: 2_000_000_000, source: "--max-memory 2G".into() };
        assert!(b.check("the 2-D mesh", 1.9e9, "x", "y").is_ok());
        let e = b.check("the 2-D mesh", 5.25e9, "1.50e7 triangles", "use a larger --h0").unwrap_err();
        assert_eq!(e.code, 2);
        assert!(
            e.message.contains("about 5.25 GB") && e.message.contains("2.00 GB (--max-memory 2G)"),
            "{}",
            e.message
        );
        assert_eq!(human(f64::INFINITY), "more bytes than can be counted");
        assert_eq!(count(1.5e7), "1.50e7");
    }
}
