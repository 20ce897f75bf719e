//! Statistics over tournament rows.

use serde::Serialize;

use super::row::Row;

/// The summary of a tournament.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Matches summarised.
    pub matches: usize,
}

/// Summarises `rows`; `wall_seconds` is the tournament's elapsed time.
pub fn summarize(rows: &[Row], wall_seconds: f64) -> Summary {
    let _ = wall_seconds;
    Summary { matches: rows.len() }
}
