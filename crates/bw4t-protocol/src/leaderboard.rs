//! A leaderboard row of `bw4t eval`: one agent on one tier and split of the named suite,
//! scored against the built-in team on the same matches (`protocol/schema/eval/row.json`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Who was evaluated, as the evaluator says (nothing here is checked but the command).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AgentInfo {
    /// The row's name for the agent.
    pub name: String,
    /// What played the agent's seats: `builtin:STRATEGY`, a command line, or
    /// `python:POLICY` for a policy run through the learning environment.
    pub command: String,
    /// The language model, for a model-driven agent.
    pub model: Option<String>,
    /// Who served the model.
    pub provider: Option<String>,
    /// The model's sampling temperature.
    pub temperature: Option<f64>,
    /// The harness (the program between the model and `bw4t mcp`) and its version.
    pub harness: Option<String>,
}

/// Sums of what model-driven players reported over every match of the row (zero for
/// players that report nothing).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct UsageTotals {
    /// Tool calls (decisions).
    pub tool_calls: u64,
    /// Tool calls refused as invalid (a bad place, colour or number).
    pub invalid_calls: u64,
    /// Model input tokens, as the driver reported them.
    pub prompt_tokens: u64,
    /// Model output tokens, as the driver reported them.
    pub completion_tokens: u64,
    /// Estimated tokens of every tool result the model was given.
    pub result_tokens: u64,
}

/// One agent on one tier and split of the suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LeaderboardRow {
    /// The suite's name, `bw4t-suite`.
    pub suite: String,
    /// The suite's version: tiers, seeds and scoring are fixed within a version.
    pub suite_version: u32,
    /// The tier (`bw4t eval tiers` lists them).
    pub tier: String,
    /// `dev` (for tuning) or `test` (held out: for reporting).
    pub split: String,
    /// The agent.
    pub agent: AgentInfo,
    /// The bw4t version that played the matches.
    pub bw4t_version: String,
    /// Distinct tasks (teammates, map, seed).
    pub tasks: u32,
    /// Times each task was played.
    pub repetitions: u32,
    /// Matches played: tasks times repetitions.
    pub matches: u32,
    /// The normalised score: over every match, the built-in team's ticks on the same task
    /// over the agent's ticks when the agent completed, 0 when it did not; the mean.
    /// The built-in team itself scores 1.
    pub score: f64,
    /// 95% percentile-bootstrap interval of `score` over tasks (each task's mean over its
    /// repetitions); none with fewer than two tasks.
    pub score_interval: Option<[f64; 2]>,
    /// The share of matches completed.
    pub completion: f64,
    /// 95% Wilson score interval of `completion`.
    pub completion_interval: [f64; 2],
    /// `pass_k[j - 1]` is pass^j: the chance that j repetitions of a task, drawn without
    /// replacement from those played, all complete, averaged over tasks (`C(c, j) / C(n, j)`
    /// for c completions of n). One entry per repetition.
    pub pass_k: Vec<f64>,
    /// Mean ticks to complete over the completed matches; none when none completed.
    pub mean_ticks: Option<f64>,
    /// The built-in team's mean ticks over the same tasks (the tick limit where it did not
    /// complete).
    pub reference_mean_ticks: f64,
    /// Matches in which an agent program crashed, never connected or was dropped.
    pub crashed_matches: u32,
    /// Matches that could not be played (the row's error).
    pub failed_matches: u32,
    /// What model-driven players reported, summed.
    pub usage: UsageTotals,
    /// SHA-256 over every match's key and state digest, in key order: two rows with the
    /// same digest played the same matches bit for bit. Empty when a front end gave none.
    pub digest: String,
}
