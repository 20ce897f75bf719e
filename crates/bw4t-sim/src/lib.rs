//! The BW4T match as a deterministic, sans-IO simulation on a rapier2d world.
//!
//! Drive it with [`Match`]: `join` robots, `handle_action` for their players, `step` one
//! fixed tick at a time, and `poll_percepts` for what each player perceives. Same map,
//! config, seed and actions give the same [`Match::digest`], bit for bit.

mod action;
mod boundary;
mod clearance;
mod config;
mod digest;
mod game;
mod nav;
mod percept;
mod physics;
mod random_play;
mod stats;

pub use action::{Accepted, Action, OrderEnd, OrderId, OrderOutcome, Receiver, Rejection, RobotId};
pub use boundary::{Applied, Intent, Journal, Seats};
pub use config::{ConfigError, MatchConfig, Motion};
pub use digest::Digest;
pub use game::{BlockPlace, JoinError, MAX_NAME_LEN, Match, MatchError, REACH, RobotView, StepReport};
pub use percept::{
    ArgKind, ArgReader, ArgRef, BlockId, MoveState, PERCEPTS, Percept, PerceptDelta, PerceptKind, Scope,
    SendType,
};
pub use physics::ROBOT_HALF;
pub use random_play::{PlayCounts, RandomPlay};
pub use stats::{MatchStats, RobotStats};
