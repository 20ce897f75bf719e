//! Tournaments: every team plays the same (map, seed) pairs; rows are written as matches
//! end, and the summary gives rates, intervals and paired differences.

mod row;
mod stats;

pub use row::Row;
pub use stats::{Summary, summarize};
