//! Map checking: every problem of a map file, with where it is.
