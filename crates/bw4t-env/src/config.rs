//! What an environment is: the map, who plays each robot, how long a step is, the rewards.

use bw4t_agents::{MatchSetup, Player, Strategy, named_seats};
use bw4t_map::Map;

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

impl Rewards {
    /// One step's reward for `good` blocks delivered in order and `wrong` blocks of the
    /// wrong colour dropped in the drop zone (the drops the [`RewardMode`] counts).
    pub fn of_step(&self, good: u32, wrong: u32) -> f32 {
        good as f32 * self.delivery + wrong as f32 * self.wrong_drop - self.step_cost
    }
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
    /// The match each episode plays: its map (whose content follows each episode's seed;
    /// `setup.seed` is not used), timing and rules, tick limit (where an episode is
    /// truncated; required), and seats in robot-id order: learners (`Player::Learner`) and
    /// in-process teammates (built-in or the caller's agents), named as `bw4t run` names
    /// them by [`EnvConfig::with_players`].
    pub setup: MatchSetup,
    /// Simulated ticks per step (at least 1).
    pub ticks_per_step: u32,
    /// Visible-block slots (`K`).
    pub slots: usize,
    /// The rewards.
    pub rewards: Rewards,
}

impl EnvConfig {
    /// `learners` learning robots and nobody else (the parallel, one-agent-per-robot setting).
    pub fn parallel(map: Map, learners: usize) -> EnvConfig {
        EnvConfig::with_players(map, vec![Player::Learner; learners])
    }

    /// One learning robot (robot 0) among `teammates` built-in robots of `strategy`.
    pub fn single(map: Map, teammates: usize, strategy: Strategy) -> EnvConfig {
        let mut players = vec![Player::Learner];
        players.extend(std::iter::repeat_n(Player::Builtin(strategy), teammates));
        EnvConfig::with_players(map, players)
    }

    /// A seat for each of `players`, in robot-id order (learners named `Agent1`, `Agent2`,
    /// ..., built-in teammates `Bot1`, `Bot2`, ...), and the defaults for everything else.
    pub fn with_players(map: Map, players: Vec<Player>) -> EnvConfig {
        let setup = MatchSetup {
            seats: named_seats(players),
            max_ticks: Some(DEFAULT_MAX_TICKS),
            ..MatchSetup::new(map)
        };
        EnvConfig {
            setup,
            ticks_per_step: DEFAULT_TICKS_PER_STEP,
            slots: DEFAULT_SLOTS,
            rewards: Rewards::default(),
        }
    }

    /// How many learning robots there are.
    pub fn learners(&self) -> usize {
        self.setup.seats.iter().filter(|s| matches!(s.player, Player::Learner)).count()
    }
}
