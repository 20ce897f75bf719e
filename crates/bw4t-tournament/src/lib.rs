//! Tournaments without playing them: the configuration file and the fixed list of matches
//! it describes, the rows written as matches end (`matches.jsonl`, `matches.csv`; the row
//! itself is `bw4t-protocol`'s), the
//! manifest of a tournament directory, and the summary (rates, intervals, paired
//! differences, the report and the chart). Every team plays the same (map, seed) pairs.
//!
//! Nothing here plays a match, reads a clock or touches a file; `bw4t-runner` plays the
//! matches and writes the directory.

mod chart;
mod cluster;
mod config;
mod manifest;
mod report;
mod stats;
pub mod suite;
mod words;

pub use cluster::{AutoShard, SHARDS_VAR, shard_from_env};
pub use config::{
    Agents, ConfigError, Planned, Resolved, Seeds, Shard, ShardError, Team, TeamConfig, TournamentConfig,
    builtin_strategy, derive_seeds, seats,
};
pub use manifest::{Machine, Manifest, ManifestError, ReplayPolicy};
pub use stats::{
    EndReasonCount, Interval, MapLimit, Method, PairStats, Setup, Summary, TeamMapStats, TeamRank, Totals,
    summarize,
};
pub use words::plural;

/// One finished match, as written to `matches.jsonl` and `matches.csv`: the protocol
/// crate's [`ResultRow`](bw4t_protocol::ResultRow), which knows the rows' JSON shape.
pub use bw4t_protocol::{CSV_COLUMNS, ResultRow as Row};
