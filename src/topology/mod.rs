//! Mesh topology engines.
