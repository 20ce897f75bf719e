//! Trajectories: a replay re-simulated into what each robot was told and did, as files a
//! learner loads (`bw4t replay trajectories`). Per replay, a directory with `meta.json`
//! ([`TrajectoryMeta`]), the map (`map.toml`) and per robot either JSON lines of
//! [`RobotTick`] (`NAME.jsonl`: percepts, the words a language model reads, actions and
//! messages) or of [`EnvStep`] (`NAME.env.jsonl`: the single-learner environment's
//! observation, mask, action index, reward and episode end). Schemas in
//! `protocol/schema/trajectory/`.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::language::Said;
use crate::messages::Percepts;
use crate::vocabulary::EndReason;

/// The trajectory format version this build writes.
pub const TRAJECTORY_FORMAT: u32 = 1;

/// One line of `NAME.jsonl`: a tick at which the robot was told something (its percepts),
/// acted, or both. The percepts are those of the tick (polled after the step to it, as a
/// lockstep player is sent them); the actions were applied at the boundary after it, so
/// each line pairs what the robot knew with what it then did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RobotTick {
    /// The tick.
    pub tick: u64,
    /// The robot's id.
    pub robot: u32,
    /// Its player's name.
    pub name: String,
    /// What the robot was told at this tick, as the `percepts` message carries it, with
    /// `words`: everything it knows after them in plain English (what a player that asked
    /// for words, a language model, reads). `null`: nothing new this tick.
    pub percepts: Option<Percepts>,
    /// What changed since the robot's previous line, one short English line each.
    pub changes: Vec<String>,
    /// The robot's actions applied after this tick, in the order applied.
    pub actions: Vec<TrajectoryAction>,
    /// Messages the robot sent (its accepted `sendMessage` actions).
    pub sent: Vec<TrajectoryMessage>,
    /// Messages the robot received in these percepts.
    pub received: Vec<TrajectoryMessage>,
}

/// An action as the replay recorded it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrajectoryAction {
    /// The action's name (`goTo`, `sendMessage`, ...).
    pub action: String,
    /// Its arguments, as in `act`.
    pub args: Vec<Value>,
    /// Whether the match accepted it.
    pub ok: bool,
}

/// A message sent or received.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrajectoryMessage {
    /// The sender's name.
    pub from: String,
    /// `all`, or the receiver's name (a received message: the receiver, as far as known).
    pub to: String,
    /// The text as the match carried it.
    pub text: String,
    /// The message of the language the text is, if it is one.
    pub said: Option<Said>,
    /// What it says in English (a message of the language as its sentence, free text as it is).
    pub sentence: String,
}

/// One line of `NAME.env.jsonl`: an observation of the single-learner environment and,
/// except on the last line, the step taken from it. A step is `ticks_per_step` ticks (the
/// meta's); its action is the first of the robot's actions in those ticks that an index
/// stands for, moves and block actions before messages, else 0 (wait).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct EnvStep {
    /// The step, from 0 (the observation at the robot's joining).
    pub step: u64,
    /// The tick of the observation.
    pub tick: u64,
    /// The observation vector (`obs_len` values, the environment's segments).
    pub observation: Vec<f32>,
    /// The action mask (`n_actions` values, 1: allowed).
    pub action_mask: Vec<u8>,
    /// The step taken from this observation (`null` on the last line).
    pub then: Option<EnvStepTaken>,
}

/// A step taken from an observation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct EnvStepTaken {
    /// The action index.
    pub action: u32,
    /// The reward, as the environment's `Rewards` reckon it.
    pub reward: f32,
    /// The sequence was completed in this step.
    pub terminated: bool,
    /// The episode ends here otherwise: the tick limit, the robot leaving or the replay's end.
    pub truncated: bool,
    /// How many actions the robot took in the step.
    pub taken: u32,
    /// How many of them `action` does not stand for: besides the one chosen, every action
    /// no index stands for (a message to one player, free text, a block beyond the slots).
    pub left_out: u32,
}

/// A segment of a vector.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct LayoutSegment {
    /// Its name.
    pub name: String,
    /// Where it starts.
    pub offset: usize,
    /// Its length.
    pub len: usize,
}

/// The environment encoding an `env` export used.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct EnvEncoding {
    /// Ticks per step.
    pub ticks_per_step: u32,
    /// Visible-block slots (`K`).
    pub slots: usize,
    /// The tick the `time` segment divides by: the replay's tick limit, or its last tick
    /// when it has none.
    pub max_ticks: u64,
    /// The observation's length.
    pub obs_len: usize,
    /// The number of actions.
    pub n_actions: usize,
    /// The observation's segments.
    pub obs_layout: Vec<LayoutSegment>,
    /// The action index's segments.
    pub action_layout: Vec<LayoutSegment>,
    /// Reward per block delivered in order.
    pub delivery: f32,
    /// Reward per wrong-colour drop.
    pub wrong_drop: f32,
    /// Cost per step.
    pub step_cost: f32,
    /// `team` (every drop in the match counts) or `individual` (the robot's own).
    pub reward_mode: String,
}

/// One robot of an exported replay.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrajectoryRobot {
    /// Its id.
    pub robot: u32,
    /// Its player's name.
    pub name: String,
    /// Its file, relative to the directory.
    pub file: String,
    /// Lines written.
    pub lines: usize,
    /// Actions it took.
    pub actions: usize,
    /// The tick it joined.
    pub joined: u64,
    /// The tick it left, if it left before the end.
    pub left: Option<u64>,
}

/// `meta.json`: what an exported replay holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrajectoryMeta {
    /// [`TRAJECTORY_FORMAT`].
    pub format: u32,
    /// `symbolic` (`NAME.jsonl`) or `env` (`NAME.env.jsonl`).
    pub kind: String,
    /// The replay file it was made from.
    pub replay: String,
    /// The map's name (the map itself is `map.toml`).
    pub map: String,
    /// The match seed.
    pub seed: u64,
    /// The replay's labels (a study trial's `participant`, `condition`, `trial`).
    pub labels: BTreeMap<String, String>,
    /// The last tick.
    pub ticks: u64,
    /// The header's tick limit, if any.
    pub max_ticks: Option<u64>,
    /// Why the match ended.
    pub end_reason: Option<EndReason>,
    /// How far the sequence got, and its length.
    pub sequence_index: u32,
    /// The sequence's length.
    pub sequence_length: usize,
    /// Blocks delivered in order, the whole team.
    pub good_drops: u32,
    /// The encoding, for `env`.
    pub env: Option<EnvEncoding>,
    /// The robots, in joining order.
    pub robots: Vec<TrajectoryRobot>,
}
