//! The result of a match: sent in `match_end`, written to result files.

use bw4t_sim::{Match, RobotId};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::vocabulary::EndReason;

use crate::vocabulary::Mode;

/// The result of a match.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MatchResult {
    /// The map's name.
    pub map: String,
    /// The match seed.
    pub seed: u64,
    /// `realtime` or `lockstep` (absent for headless matches).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<Mode>,
    /// How many robots played.
    pub robots: usize,
    /// Whether the whole sequence was delivered.
    pub completed: bool,
    /// Why the match ended.
    pub end_reason: EndReason,
    /// Ticks simulated.
    pub ticks: u64,
    /// The first tick whose percepts show the whole sequence delivered (the tick after the
    /// boundary at which the last block was put down).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub completed_tick: Option<u64>,
    /// Simulated seconds.
    pub sim_seconds: f64,
    /// Wall-clock milliseconds from the first tick to the end (waiting for players before
    /// the first tick does not count).
    pub wall_ms: u64,
    /// The goal colours.
    pub sequence: Vec<String>,
    /// How far the sequence got.
    pub sequence_index: u32,
    /// Blocks delivered in order.
    pub good_drops: u32,
    /// Blocks delivered that were not needed.
    pub wrong_drops: u32,
    /// Messages sent.
    pub messages: u32,
    /// The state digest at the end, as 16 hex digits.
    pub digest: String,
    /// Per robot, by id.
    pub per_robot: Vec<RobotResult>,
    /// How often the operator paused the match (absent when never).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub pauses: u32,
}

/// One robot's part of a result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RobotResult {
    /// Robot id.
    pub id: u32,
    /// Player name.
    pub name: String,
    /// Blocks delivered in order.
    pub good_drops: u32,
    /// Blocks delivered that were not needed.
    pub wrong_drops: u32,
    /// Messages sent.
    pub messages_sent: u32,
    /// Ticks not travelling.
    pub idle_ticks: u64,
    /// Rooms entered.
    pub rooms_entered: u32,
    /// Map units travelled.
    pub distance: f64,
    /// Lockstep ticks the player answered after the deadline (or not at all).
    pub late_ticks: u64,
    /// Lines from the player that were not valid messages.
    #[serde(default)]
    pub errors: u64,
    /// Whether a player (or a built-in agent) ever played the robot.
    #[serde(default = "yes")]
    pub connected: bool,
    /// Whether the robot was still in the match at the end.
    pub present: bool,
    /// How often its player's connection dropped after the start (absent when never).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub disconnections: u32,
    /// Ticks made while its player was away after a drop, until it came back, its robot
    /// was taken out, or the match ended (absent when none).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub absent_ticks: u64,
    /// How its player says it was driven (its last `report`), if it sent one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub usage: Option<PlayerUsage>,
}

fn is_zero<T: Default + PartialEq>(n: &T) -> bool {
    *n == T::default()
}

/// How a player says it was driven: tool calls, thinking time and model tokens. Reported
/// by the player itself (`bw4t mcp` does), so it is as true as the player is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlayerUsage {
    /// Decisions made: tool calls, for a player driven through MCP (invalid ones included).
    #[serde(default)]
    pub tool_calls: u64,
    /// Of those, the calls refused for their arguments (an unknown place, a colour not of
    /// the game, a number out of range): answered as tool errors, nothing sent to the match.
    #[serde(default)]
    pub invalid_calls: u64,
    /// Estimated tokens of the tool results returned to the model, summed: each result's
    /// text at one token per four characters, rounded up (`bw4t mcp`'s estimate).
    #[serde(default)]
    pub result_tokens: u64,
    /// Wall milliseconds spent deciding, in all (between an answer and the next call).
    #[serde(default)]
    pub think_ms: u64,
    /// The longest single decision, in wall milliseconds.
    #[serde(default)]
    pub think_ms_max: u64,
    /// Model input tokens, where the driver reports them.
    #[serde(default)]
    pub prompt_tokens: u64,
    /// Model output tokens, where the driver reports them.
    #[serde(default)]
    pub completion_tokens: u64,
}

fn yes() -> bool {
    true
}

/// What the driver of a match knows about a robot's player beyond the match itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RobotExtra {
    /// Lockstep deadlines missed.
    pub late_ticks: u64,
    /// Invalid lines received.
    pub errors: u64,
    /// Whether anyone ever played the robot.
    pub connected: bool,
    /// What its player last reported of how it was driven.
    pub usage: Option<PlayerUsage>,
    /// Its player's connection drops after the start.
    pub disconnections: u32,
    /// Ticks its player was away after a drop.
    pub absent_ticks: u64,
}

impl RobotExtra {
    /// A robot played in-process: never late, never wrong, never away.
    pub const LOCAL: RobotExtra = RobotExtra {
        late_ticks: 0,
        errors: 0,
        connected: true,
        usage: None,
        disconnections: 0,
        absent_ticks: 0,
    };
}

impl MatchResult {
    /// The result of `game` as it stands; `late_ticks` gives each robot's late count.
    pub fn of(
        game: &Match,
        mode: Option<Mode>,
        end_reason: EndReason,
        wall_ms: u64,
        extra: impl Fn(RobotId) -> RobotExtra,
    ) -> Self {
        let stats = game.stats();
        let per_robot: Vec<RobotResult> = game
            .all_robot_stats()
            .map(|(id, name, s, present)| (id, name, s, present, extra(id)))
            .map(|(id, name, s, present, extra)| RobotResult {
                id: id.0,
                name: name.to_string(),
                good_drops: s.good_drops,
                wrong_drops: s.wrong_drops,
                messages_sent: s.messages_sent,
                idle_ticks: s.idle_ticks,
                rooms_entered: s.rooms_entered,
                distance: (s.distance * 1000.0).round() / 1000.0,
                late_ticks: extra.late_ticks,
                errors: extra.errors,
                connected: extra.connected,
                present,
                disconnections: extra.disconnections,
                absent_ticks: extra.absent_ticks,
                usage: extra.usage,
            })
            .collect();
        MatchResult {
            map: game.map().name().to_string(),
            seed: game.seed(),
            mode,
            robots: per_robot.len(),
            completed: game.is_complete(),
            end_reason,
            ticks: game.tick(),
            completed_tick: stats.completed_at,
            sim_seconds: game.config().seconds(game.tick()),
            wall_ms,
            sequence: game.sequence().iter().map(|c| c.name().to_string()).collect(),
            sequence_index: game.sequence_index(),
            good_drops: stats.good_drops,
            wrong_drops: stats.wrong_drops,
            messages: stats.messages,
            digest: format!("{:016x}", game.digest()),
            per_robot,
            pauses: 0,
        }
    }
}
