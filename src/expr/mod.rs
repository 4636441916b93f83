//! The expression language of the command line (x, y, z; arithmetic; the seed's distance helpers).
