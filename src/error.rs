//! The crate's error type: bad input names the value and where it came from.

use crate::topology::InvariantViolation;
use thiserror::Error;

/// Everything that can go wrong at the library's boundary.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum Error {
    /// A user function (distance, size, metric) returned NaN or infinity.
    #[error("{what} returned a non-finite value {value} at {at:?}")]
    NonFinite {
        /// Which function or input.
        what: &'static str,
        /// The bad value.
        value: f64,
        /// Where it was evaluated.
        at: [f64; 3],
    },
    /// A non-finite or out-of-range coordinate in the input.
    #[error("bad coordinate in {what}: {value}")]
    BadCoordinate {
        /// Which input.
        what: &'static str,
        /// The bad value.
        value: f64,
    },
    /// The domain has no interior point inside the bounding box.
    #[error("empty domain: {0}")]
    EmptyDomain(String),
    /// A size (h0, h(x)) that is not positive and finite.
    #[error("bad size: {0}")]
    BadSize(String),
    /// A bounding box that is empty, inverted or not finite.
    #[error("bad bounding box: {0}")]
    BadBox(String),
    /// The estimated element count passes the configured limit.
    #[error("about {} elements would be made, past the limit of {limit}", count_text(*estimated))]
    TooManyElements {
        /// Estimated count.
        estimated: u64,
        /// The configured limit.
        limit: u64,
    },
    /// The work would need more memory than the budget allows (the message gives the
    /// estimate, the budget and what to change).
    #[error("{0}")]
    OverBudget(String),
    /// Input arrays that do not describe a valid mesh.
    #[error("invalid mesh input: {0}")]
    InvalidMesh(String),
    /// A file could not be read or written.
    #[error("i/o error on {path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// What the system said.
        message: String,
    },
    /// A garbled or truncated file.
    #[error("parse error in {path}, line {line}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// 1-based line (0 when not line-oriented).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A triangle mesh that bounds no solid (empty, open, non-manifold, self-intersecting).
    #[error("bad surface: {0}")]
    Surface(#[from] crate::geometry::trisurf::SurfaceError),
    /// Polylines that bound no planar domain (empty, open, too short, crossing).
    #[error("bad polylines: {0}")]
    Polygon(#[from] crate::geometry::polygons::PolygonError),
    /// Any other invalid option.
    #[error("invalid input: {0}")]
    Invalid(String),
    /// A broken internal invariant: a bug in trussmesh; please report it. `violation` is the
    /// mesh invariant that broke, when a validation found it.
    #[error("internal error (please report): {message}")]
    Internal {
        /// What was being done and what went wrong.
        message: String,
        /// The broken mesh invariant, when a validation found it.
        violation: Option<InvariantViolation>,
    },
}

/// An element count as people read it: exact below 10^5, "1.23e7" above, and "more than
/// 1.8e19" for an estimate that saturated the counter (an h0 of 1e-300 does that).
fn count_text(n: u64) -> String {
    if n == u64::MAX {
        "more than 1.8e19".into()
    } else if n < 100_000 {
        n.to_string()
    } else {
        format!("{:.2e}", n as f64)
    }
}

impl Error {
    /// An internal error without a mesh invariant behind it.
    pub fn internal(message: impl Into<String>) -> Self {
        Error::Internal { message: message.into(), violation: None }
    }

    /// An internal error: validating the mesh after `context` found `violation` broken.
    pub fn broken(context: &str, violation: InvariantViolation) -> Self {
        Error::Internal { message: format!("{context}: {violation}"), violation: Some(violation) }
    }
}
