//! Element quality measures.
