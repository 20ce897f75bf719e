//! What an environment is: the map, who plays each robot, how long a step is, the rewards.

use bw4t_agents::Strategy;
use bw4t_map::Map;
use bw4t_sim::MatchConfig;

/// Who plays one robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seat {
    /// A learning robot: its actions come from `step`, and it has an observation, a mask
    /// and a reward.
    Learner,
    /// A built-in teammate, deciding as in a headless match.
    Builtin(Strategy),
}

/// Who gets a delivery's reward.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RewardMode {
    /// Every learner gets the reward of every drop in the match (teammates' included).
    Team,
    /// Each learner gets the reward of its own drops only.
    Individual,
}

/// The reward of one step, per learner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rewards {
    /// For each block delivered in order.
    pub delivery: f32,
    /// For each block dropped in the drop zone that was not the colour needed (negative).
    pub wrong_drop: f32,
    /// Taken from every learner every step.
    pub step_cost: f32,
    /// Whose drops count.
    pub mode: RewardMode,
}

impl Default for Rewards {
    /// `+1` per delivery and `-0.5` per wrong drop, shared by the team; `0.001` per step.
    fn default() -> Self {
        Rewards { delivery: 1.0, wrong_drop: -0.5, step_cost: 0.001, mode: RewardMode::Team }
    }
}

/// Default ticks per step: half a simulated second at 20 ticks/s, 5 map units of travel.
pub const DEFAULT_TICKS_PER_STEP: u32 = 10;
/// Default slots for visible blocks: a room starts with at most this many.
pub const DEFAULT_SLOTS: usize = bw4t_map::MAX_BLOCKS_PER_ROOM;
/// Default tick limit: that of a match on a small map (`bw4t run`'s least default).
pub const DEFAULT_MAX_TICKS: u64 = 20_000;

/// An environment's configuration.
#[derive(Clone, Debug)]
pub struct EnvConfig {
    /// The map every episode is played on (its content follows each episode's seed).
    pub map: Map,
    /// The match's timing and rules.
    pub match_config: MatchConfig,
    /// One per robot, in robot-id order. Learners are named `Agent1`, `Agent2`, ...,
    /// built-in teammates `Bot1`, `Bot2`, ..., as in `bw4t run`.
    pub seats: Vec<Seat>,
    /// Simulated ticks per step (at least 1).
    pub ticks_per_step: u32,
    /// The episode is truncated at this tick.
    pub max_ticks: u64,
    /// Visible-block slots (`K`).
    pub slots: usize,
    /// The rewards.
    pub rewards: Rewards,
}

impl EnvConfig {
    /// `learners` learning robots and nobody else (the parallel, one-agent-per-robot setting).
    pub fn parallel(map: Map, learners: usize) -> EnvConfig {
        EnvConfig::with_seats(map, vec![Seat::Learner; learners])
    }

    /// One learning robot (robot 0) among `teammates` built-in robots of `strategy`.
    pub fn single(map: Map, teammates: usize, strategy: Strategy) -> EnvConfig {
        let mut seats = vec![Seat::Learner];
        seats.extend(std::iter::repeat_n(Seat::Builtin(strategy), teammates));
        EnvConfig::with_seats(map, seats)
    }

    /// These seats, and the defaults for everything else.
    pub fn with_seats(map: Map, seats: Vec<Seat>) -> EnvConfig {
        EnvConfig {
            map,
            match_config: MatchConfig::default(),
            seats,
            ticks_per_step: DEFAULT_TICKS_PER_STEP,
            max_ticks: DEFAULT_MAX_TICKS,
            slots: DEFAULT_SLOTS,
            rewards: Rewards::default(),
        }
    }

    /// How many learning robots there are.
    pub fn learners(&self) -> usize {
        self.seats.iter().filter(|s| **s == Seat::Learner).count()
    }
}
