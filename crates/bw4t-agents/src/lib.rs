//! Built-in agents. They see only what a remote player sees (percepts, the outcomes of
//! their actions, messages) and act only through actions, behind the [`Agent`] trait that
//! any driver (the headless runner, the server, a TCP client) can call.

mod baseline;
mod coop;
mod drive;
mod orders;
mod random;
mod setup;
mod view;

use bw4t_sim::{Action, OrderOutcome, PerceptDelta};

pub use baseline::Baseline;
pub use coop::{CLAIM_LAPSE_TICKS, Cooperative, STALL_TICKS, WORD_CLAIM_LAPSE_TICKS};
pub use drive::{Driver, Team};
pub use random::RandomPlayer;
pub use setup::{AgentFactory, MatchSetup, Player, Seat, SetupError, bot_name, named_seats};

/// The outcome of one of the agent's actions, numbered in the order the agent returned
/// them (0, 1, 2, ... over the whole match).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ActionAck {
    /// The action's number.
    pub action: u64,
    /// `Ok`, or the rejection code (e.g. `not_at_block`).
    pub result: Result<(), String>,
}

/// How a durative action (`goTo`, `goToBlock`) ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OrderDone {
    /// The action's number.
    pub action: u64,
    /// Arrived, collided or superseded.
    pub outcome: OrderOutcome,
}

/// Everything a player was told since the agent was last called.
#[derive(Clone, Debug, Default)]
pub struct Observation {
    /// The current tick.
    pub tick: u64,
    /// Percept deltas, oldest first (usually one).
    pub percepts: Vec<PerceptDelta>,
    /// Outcomes of actions applied since the last call.
    pub acks: Vec<ActionAck>,
    /// Durative actions that ended since the last call.
    pub done: Vec<OrderDone>,
}

impl Observation {
    /// Whether there is anything in it.
    pub fn is_empty(&self) -> bool {
        self.percepts.iter().all(PerceptDelta::is_empty) && self.acks.is_empty() && self.done.is_empty()
    }
}

/// A player's brain. Drivers call [`Agent::decide`] at every tick the player is told
/// something (a non-empty percept delta, or the end of an order), or that the agent asked
/// to be woken at ([`Agent::wake_at`]), and apply the returned actions, in order, at the
/// next tick boundary.
pub trait Agent: Send {
    /// The actions to take now.
    fn decide(&mut self, observation: &Observation) -> Vec<Action>;

    /// A tick at which to be called even if told nothing (something it waits for may have
    /// run out by then); `None`: only when told something.
    fn wake_at(&self) -> Option<u64> {
        None
    }
}

/// The built-in strategies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Explore without duplicating work, share what rooms hold, agree who fetches which
    /// colour, deliver in order; speaks the message language, answers questions and
    /// follows requests (see [`Cooperative`]).
    Cooperative,
    /// The cooperative play without a word: sends no messages, still listens (and
    /// follows requests).
    Silent,
    /// The cooperative play and messages, but hears only what the team says to
    /// coordinate: no answers, no requests followed, no claims or knowledge of others.
    Ignoring,
    /// Each robot alone, no messages: fetch the colour needed now, put back what is not.
    Baseline,
    /// No plan: whenever idle, one action drawn at random from those that could be valid
    /// (see [`RandomPlayer`]); the floor of the evaluation suite.
    Random,
}

impl Strategy {
    /// Every strategy, the default first.
    pub const ALL: [Strategy; 5] =
        [Strategy::Cooperative, Strategy::Silent, Strategy::Ignoring, Strategy::Baseline, Strategy::Random];

    /// The name used on the command line (`builtin:NAME`).
    pub fn name(self) -> &'static str {
        match self {
            Strategy::Cooperative => "coop",
            Strategy::Silent => "silent",
            Strategy::Ignoring => "ignoring",
            Strategy::Baseline => "baseline",
            Strategy::Random => "random",
        }
    }

    /// The strategy with this name.
    pub fn named(name: &str) -> Option<Strategy> {
        Strategy::ALL.into_iter().find(|s| s.name() == name)
    }

    /// A new agent of this strategy for the player `name`.
    pub fn agent(self, name: &str) -> Box<dyn Agent> {
        match self {
            Strategy::Cooperative => Box::new(Cooperative::new(name)),
            Strategy::Silent => Box::new(Cooperative::silent(name)),
            Strategy::Ignoring => Box::new(Cooperative::ignoring(name)),
            Strategy::Baseline => Box::new(Baseline::new(name)),
            Strategy::Random => Box::new(RandomPlayer::new(name)),
        }
    }
}
