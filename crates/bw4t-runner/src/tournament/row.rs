//! One finished match of a tournament, as written to `matches.jsonl` and `matches.csv`.

use serde::{Deserialize, Serialize};

/// One finished match.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Identifies the match within the tournament: `team/map/seed/repetition`.
    pub key: String,
    /// The match's index in the tournament's fixed order (for sharding).
    pub index: u64,
    /// The team's name.
    pub team: String,
    /// The map as given in the config (name or path).
    pub map: String,
    /// The match seed.
    pub seed: u64,
    /// Repetition number, from 0.
    pub repetition: u32,
    /// Robots in the team.
    pub robots: usize,
    /// Whether the sequence was completed.
    pub completed: bool,
    /// Ticks simulated.
    pub ticks: u64,
    /// The first tick whose percepts showed the sequence complete, when completed.
    pub completed_tick: Option<u64>,
    /// Wall-clock milliseconds from the match's first tick to its end, as in its result; 0
    /// for a match that could not run.
    pub wall_ms: u64,
    /// Blocks delivered in order.
    pub good_drops: u32,
    /// Blocks delivered out of order.
    pub wrong_drops: u32,
    /// Messages sent.
    pub messages: u32,
    /// Agents that missed deadlines (external agents only).
    pub late_agents: u32,
    /// Agents that crashed, never connected, hung or talked garbage.
    pub crashed_agents: u32,
    /// `completed`, `max_ticks`, `interrupted` or `error`.
    pub end_reason: String,
    /// The final state digest.
    pub digest: String,
    /// The replay file, relative to the tournament directory, when kept.
    pub replay: Option<String>,
}
