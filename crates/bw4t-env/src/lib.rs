//! BW4T as reinforcement-learning environments, in Rust only: the core a Python binding
//! wraps (a parallel one-agent-per-robot environment, a one-learner environment among
//! built-in teammates, and a vector of environments stepped without the interpreter).
//!
//! - [`Env`]: one match. [`Env::reset`] and [`Env::step`] write each learning robot's
//!   observation (`f32`), action mask (`u8`) and reward (`f32`) into slices the caller owns.
//! - [`VecEnv`]: `N` environments stepped together into arrays the caller allocated once,
//!   on one or more threads, with same-step auto-reset (see [`VecEnv`]).
//! - [`EnvConfig`]: the match's set-up (map, seats: learners or in-process teammates,
//!   tick limit), the step's length, the slots and the [`Rewards`].
//!
//! # Observation
//!
//! One `f32` vector per learning robot; its length depends only on the map and the config.
//! `P`: places (every zone, map order), `R`: rooms (zones of kind room, the drop zone
//! included, map order), `C` = 9 colours (`Blue Cyan Magenta Orange Red White Green Yellow
//! Pink`), `K`: visible-block slots ([`EnvConfig::slots`], default 10), `L`: the goal
//! sequence's length (fixed by the map), `M` = 30 kinds of message
//! ([`bw4t_protocol::KINDS`] order). Segments follow one another in this order, each
//! starting where the previous ends ([`OBS_SEGMENTS`]; [`Spaces::obs_layout`] gives the
//! offsets for a map):
//!
//! | segment | size | holds |
//! |---|---|---|
//! | `at` | P | one-hot: the place the robot is at (`at`) |
//! | `in_room` | 1 | 1 when the robot is in a room (`in`) |
//! | `holding` | 1 | 1 when the robot holds a block |
//! | `held_colour` | C | one-hot: the held block's colour |
//! | `room_colours` | C | count of the blocks of each colour visible in the robot's room |
//! | `slots` | K*C | per slot k: the colour one-hot of the k-th visible block by id (zeros: empty) |
//! | `at_block` | 1 | 1 when a block is within reach (`atBlock`) |
//! | `sequence` | L*C | per position: the goal colour one-hot |
//! | `sequence_index` | L+1 | one-hot: the index of the next colour needed (L: complete) |
//! | `delivered` | L | 1 for each position already delivered |
//! | `occupied` | R | 1 for each room some robot is in (`occupied`) |
//! | `move_state` | 3 | one-hot: arrived, traveling, collided (`state`) |
//! | `messages` | M+1 | messages received during the step, per kind of the language; last: free text |
//! | `time` | 1 | the tick over the tick limit |
//!
//! On the shipped `default` map with the defaults (P = 28, R = 10, K = 10, L = 6), the
//! observation is 251 long:
//!
//! | segment | offset | size |
//! |---|---|---|
//! | `at` | 0 | 28 |
//! | `in_room` | 28 | 1 |
//! | `holding` | 29 | 1 |
//! | `held_colour` | 30 | 9 |
//! | `room_colours` | 39 | 9 |
//! | `slots` | 48 | 90 |
//! | `at_block` | 138 | 1 |
//! | `sequence` | 139 | 54 |
//! | `sequence_index` | 193 | 7 |
//! | `delivered` | 200 | 6 |
//! | `occupied` | 206 | 10 |
//! | `move_state` | 216 | 3 |
//! | `messages` | 219 | 31 |
//! | `time` | 250 | 1 |
//!
//! The robot's own facts come from its percepts, kept as a remote player keeps them; the
//! sequence and its index are the `sequence` and `sequenceIndex` facts.
//!
//! # Actions
//!
//! One `Discrete(n)` index per learning robot, through these segments in order
//! ([`ACTION_SEGMENTS`], [`Spaces::action_layout`]); the mask (one `u8` per action) is 1
//! exactly for the actions valid now:
//!
//! | segment | size | does | allowed when |
//! |---|---|---|---|
//! | `wait` | 1 | nothing (an order under way goes on) | always |
//! | `go_to` | P | `goTo` place p | p is not a blockade |
//! | `go_to_block` | K | `goToBlock` the block in visible slot k | slot k holds a block |
//! | `pick_up` | 1 | `pickUp` the block the robot is at | at a block, holding none |
//! | `put_down` | 1 | `putDown` the held block | holding a block |
//! | `say_will_get` | C | to all: `will_get` colour c | there is another robot |
//! | `say_contains` | C | to all: `contains` the robot's room, colour c | another robot; in a room where a c block is visible |
//! | `say_empty` | 1 | to all: `empty` the robot's room | another robot; in a room with no visible block |
//! | `say_going_to` | R | to all: `going_to` room r | there is another robot |
//!
//! On the `default` map: 70 actions (`wait` 0, `go_to` 1, `go_to_block` 29, `pick_up` 39,
//! `put_down` 40, `say_will_get` 41, `say_contains` 50, `say_empty` 59, `say_going_to`
//! 60). A masked-out (or out-of-range) action does nothing and is reported as
//! [`ActionOutcome::Masked`]; an allowed one is handed to the match, which accepts it
//! (the one exception: `putDown` in a room so full of blocks that no spot is free is
//! refused with `no_space`).
//!
//! # Global state
//!
//! For centralised critics, [`Env::write_state`] writes the whole world's facts (not one
//! robot's view) as one `f32` vector, through these segments in order
//! ([`STATE_SEGMENTS`], [`StateSpace::layout`]); `N` is the number of robots (every seat,
//! learners and built-in teammates, in robot-id order). `room_blocks` holds counts; every
//! other value is 0/1 or in `[0, 1]`:
//!
//! | state segment | size | holds |
//! |---|---|---|
//! | `robot_position` | N*2 | per robot: its centre's x and y over the map's width and height |
//! | `robot_room` | N*(R+1) | per robot: one-hot, the room it is in (last: none) |
//! | `robot_state` | N*3 | per robot: one-hot, arrived, traveling, collided |
//! | `robot_holding` | N*C | per robot: the held block's colour one-hot (zeros: none) |
//! | `room_blocks` | R*C | per room: count of the blocks of each colour lying in it |
//! | `sequence` | L*C | per position: the goal colour one-hot |
//! | `sequence_index` | L+1 | one-hot: the index of the next colour needed (L: complete) |
//! | `delivered` | L | 1 for each position already delivered |
//! | `time` | 1 | the tick over the tick limit |
//!
//! # Copying an episode
//!
//! [`Env::episode`] is the episode's seed and every action index played since its reset;
//! [`Env::replay`] plays them again into another environment of the same config, which is
//! then the same match bit for bit (how the Python environments are pickled).
//! [`VecEnv::snapshot`] and [`VecEnv::restore`] do the same for a vector's matches, with
//! their seed streams.
//!
//! # Rewards, termination, truncation
//!
//! Per step and learner ([`Rewards`], default in brackets): `delivery` (+1) per block
//! delivered in order, `wrong_drop` (−0.5) per block of the wrong colour dropped in the
//! drop zone, and `step_cost` (0.001) taken every step. With [`RewardMode::Team`] (the
//! default) every learner is rewarded for every drop in the match, built-in teammates'
//! included; with [`RewardMode::Individual`] for its own. The episode *terminates* when
//! the whole sequence is delivered and is *truncated* at the setup's tick limit
//! (`EnvConfig::setup.max_ticks`, default 20,000 ticks, `bw4t run`'s limit on small maps;
//! pass a larger map's own).
//!
//! # A step
//!
//! [`Env::step`]: each learner's action is queued for the next tick boundary; then
//! `ticks_per_step` ticks (default 10: half a simulated second, 5 map units of travel, so
//! a learner is not asked again every tick while an order is under way) are played as a
//! headless match plays them: every built-in teammate told something decides, the
//! boundary applies every robot's queued actions in robot-id order (the learners' only at
//! the first), and the match steps. The step stops early when the sequence is complete or
//! the tick limit is reached. The learners' percepts are then polled: their observation
//! counts the messages that arrived during the step.
//!
//! Determinism: the same config, `reset(seed)` and actions give the same observations,
//! rewards and [`Env::digest`], bit for bit.

mod bench;
mod config;
mod encode;
mod env;
mod recorded;
mod render;
mod seen;
mod spaces;
mod state;
#[cfg(test)]
mod tests;
mod vec_env;

pub use bench::{Figures, single as bench_single, vector as bench_vector};
pub use config::{DEFAULT_MAX_TICKS, DEFAULT_SLOTS, DEFAULT_TICKS_PER_STEP, EnvConfig, RewardMode, Rewards};
pub use env::{ActionOutcome, Env, EnvError, StepEnd};
pub use recorded::RecordedView;
pub use render::Rgb;
pub use spaces::{ACTION_SEGMENTS, Dims, OBS_SEGMENTS, Segment, SegmentRow, Size, Spaces};
pub use state::{STATE_SEGMENTS, StateDims, StateRow, StateSize, StateSpace};
pub use vec_env::{EpisodeEnd, SeedStream, SlotState, StepBuffers, VecBuffers, VecEnv};
