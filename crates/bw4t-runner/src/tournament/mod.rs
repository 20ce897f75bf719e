//! Tournaments: every team plays the same (map, seed) pairs; rows are written as matches
//! end, and the summary gives rates, intervals and paired differences.

mod chart;
mod config;
mod report;
mod row;
mod run;
mod stats;

pub use config::{
    Agents, ConfigError, Planned, Resolved, Seeds, Team, TeamConfig, TournamentConfig, builtin_strategy,
    derive_seeds, seats,
};
pub use row::{CSV_COLUMNS, Row};
pub use run::{Options, Outcome, Progress, ReplayPolicy, TournamentError, merge, run_tournament, setup};
pub use stats::{
    EndReasonCount, Interval, MapLimit, Method, PairStats, Setup, TeamMapStats, TeamRank, Totals,
};
pub use stats::{Summary, summarize};
