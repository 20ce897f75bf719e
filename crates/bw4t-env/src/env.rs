//! One match as an environment: actions in, observations, masks and rewards out.

use std::sync::Arc;

use bw4t_agents::{Driver, Player, Team};
use bw4t_sim::{
    Accepted, Action, Intent, Match, MatchError, MatchStats, OrderEnd, Percept, PerceptDelta, Rejection,
    RobotId, Seats,
};

use crate::config::{EnvConfig, RewardMode};
use crate::encode::Codec;
use crate::seen::Seen;
use crate::spaces::{Dims, Spaces};
use crate::state::StateSpace;

/// Why an environment could not be made or reset.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The match could not be created (a bad match config, content that does not fit).
    #[error(transparent)]
    Match(#[from] MatchError),
    /// The map has fewer spawn points than seats, or a seat could not join.
    #[error("robot {seat} cannot join: {reason}")]
    Join {
        /// The seat, from 0.
        seat: usize,
        /// Why.
        reason: String,
    },
    /// A config value is out of range.
    #[error("{0}")]
    Config(&'static str),
    /// A seat's player cannot play in an environment (only learners and in-process
    /// agents can).
    #[error(transparent)]
    Setup(#[from] bw4t_agents::SetupError),
}

/// What became of a learner's last action.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ActionOutcome {
    /// It waited (action 0), or no step has been taken yet.
    Waited,
    /// The action was masked out (or out of range): nothing was done.
    Masked,
    /// The match accepted it.
    Accepted,
    /// The match refused it, with this code (`not_at_block`, ...).
    Rejected(&'static str),
    /// The episode ended before it could be applied.
    Dropped,
}

/// How a step ended the episode, if it did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepEnd {
    /// The whole sequence is delivered.
    pub terminated: bool,
    /// The tick limit was reached first.
    pub truncated: bool,
}

impl StepEnd {
    /// Whether the episode is over.
    pub fn done(self) -> bool {
        self.terminated || self.truncated
    }
}

struct Learner {
    name: String,
    robot: RobotId,
    seen: Seen,
    pending: Option<Action>,
    outcome: ActionOutcome,
    /// The percepts polled at the end of the last step (or reset).
    delta: Option<PerceptDelta>,
}

/// One BW4T match as an environment (see the crate docs for the spaces and the step).
pub struct Env {
    config: Arc<EnvConfig>,
    /// The tick at which an episode is truncated (`config.setup.max_ticks`, required).
    max_ticks: u64,
    codec: Arc<Codec>,
    game: Match,
    team: Team,
    learners: Vec<Learner>,
    /// The masks last written, learner after learner.
    masks: Vec<u8>,
    intents: Vec<Intent<u64>>,
    /// The global state's layout (for centralised critics).
    state: Arc<StateSpace>,
    /// The seed this episode was reset on.
    seed: u64,
    /// Every step's action indices since the reset, learner after learner: with `seed`,
    /// enough to play the episode again ([`Env::replay`]).
    played: Vec<u32>,
    /// Whether `played` tells the whole episode (not when a step took the match's own
    /// actions, [`Env::step_actions`]).
    replayable: bool,
}

impl Env {
    /// An environment for `config`, reset with seed 0.
    pub fn new(config: EnvConfig) -> Result<Env, EnvError> {
        let spaces = Spaces::new(Dims::of(&config.setup.map, config.slots));
        let codec = Codec::new(spaces, &config.setup.map);
        let state = StateSpace::new(&config.setup.map, config.setup.seats.len());
        Env::shared(Arc::new(config), Arc::new(codec), Arc::new(state))
    }

    /// An environment sharing its config, codec and state layout with others.
    pub(crate) fn shared(
        config: Arc<EnvConfig>,
        codec: Arc<Codec>,
        state: Arc<StateSpace>,
    ) -> Result<Env, EnvError> {
        if config.ticks_per_step == 0 {
            return Err(EnvError::Config("ticks_per_step must be at least 1"));
        }
        if config.learners() == 0 {
            return Err(EnvError::Config("at least one seat must be a learner"));
        }
        let Some(max_ticks) = config.setup.max_ticks else {
            return Err(EnvError::Config("an environment needs a tick limit (setup.max_ticks)"));
        };
        config.setup.only_players("in a learning environment", |p| {
            matches!(p, Player::Learner | Player::Builtin(_) | Player::Agent(_))
        })?;
        let game = Match::new(&config.setup.map, &config.setup.game, 0)?;
        let masks = vec![0; config.learners() * codec.spaces().n_actions()];
        let mut env = Env {
            config,
            max_ticks,
            codec,
            game,
            team: Team::new(Vec::new()),
            learners: Vec::new(),
            masks,
            intents: Vec::new(),
            state,
            seed: 0,
            played: Vec::new(),
            replayable: true,
        };
        env.start(0)?;
        Ok(env)
    }

    pub(crate) fn codec(&self) -> &Arc<Codec> {
        &self.codec
    }

    /// The global state's layout.
    pub fn state_space(&self) -> &Arc<StateSpace> {
        &self.state
    }

    /// Writes the global state now (the whole world, for a centralised critic) into `out`
    /// (of [`StateSpace::len`]).
    pub fn write_state(&self, out: &mut [f32]) {
        self.state.write(&self.game, self.max_ticks, out);
    }

    /// The seed this episode was reset on and every step's action indices since (learner
    /// after learner), which [`Env::replay`] plays again; `None` when a step took the
    /// match's own actions ([`Env::step_actions`]), which indices cannot tell.
    pub fn episode(&self) -> Option<(u64, &[u32])> {
        self.replayable.then_some((self.seed, self.played.as_slice()))
    }

    /// Resets on `seed` and steps with `played` (a whole number of steps of action
    /// indices, as [`Env::episode`] gives them): the same episode, bit for bit, as the
    /// one that was played. Writes the last observations and masks.
    pub fn replay(
        &mut self,
        seed: u64,
        played: &[u32],
        obs: &mut [f32],
        masks: &mut [u8],
    ) -> Result<(), EnvError> {
        let agents = self.agents();
        if !played.len().is_multiple_of(agents) {
            return Err(EnvError::Config("a replay's actions must be one per learner for each step"));
        }
        self.reset(seed, obs, masks)?;
        let mut rewards = vec![0.0; agents];
        for actions in played.chunks(agents) {
            self.step(actions, obs, masks, &mut rewards);
        }
        Ok(())
    }

    /// The configuration.
    pub fn config(&self) -> &Arc<EnvConfig> {
        &self.config
    }

    /// The spaces.
    pub fn spaces(&self) -> &Spaces {
        self.codec.spaces()
    }

    /// How many learning robots there are (the agents of the parallel setting).
    pub fn agents(&self) -> usize {
        self.learners.len()
    }

    /// A new episode on `seed`; writes each learner's observation and mask
    /// (`obs`: agents × obs_len, `masks`: agents × n_actions).
    pub fn reset(&mut self, seed: u64, obs: &mut [f32], masks: &mut [u8]) -> Result<(), EnvError> {
        self.start(seed)?;
        self.write(obs, masks);
        Ok(())
    }

    fn start(&mut self, seed: u64) -> Result<(), EnvError> {
        self.seed = seed;
        self.played.clear();
        self.replayable = true;
        let config = &self.config;
        let mut game = Match::new(&config.setup.map, &config.setup.game, seed)?;
        let (mut drivers, mut learners) = (Vec::new(), Vec::new());
        for (i, seat) in config.setup.seats.iter().enumerate() {
            let name = seat.name.clone();
            let robot = game.join(&name).map_err(|e| EnvError::Join { seat: i, reason: e.to_string() })?;
            match seat.player.agent(&name) {
                None => learners.push(Learner {
                    name,
                    robot,
                    seen: self.codec.blank_view(),
                    pending: None,
                    outcome: ActionOutcome::Waited,
                    delta: None,
                }),
                Some(agent) => drivers.push(Driver::new(robot, agent)),
            }
        }
        self.game = game;
        self.team = Team::new(drivers);
        self.learners = learners;
        self.poll();
        self.refresh_masks();
        Ok(())
    }

    /// Each learner's new percepts, into what it has seen.
    fn poll(&mut self) {
        for learner in &mut self.learners {
            learner.delta = self.game.poll_percepts(learner.robot);
            if let Some(delta) = &learner.delta {
                learner.seen.apply(delta);
            }
        }
    }

    /// One step: each learner's action (an index into the action space; masked-out ones
    /// do nothing) applied at the next tick boundary, then `ticks_per_step` ticks with the
    /// built-in teammates deciding as in a headless match. Writes the observations, masks
    /// and rewards (`rewards`: one per learner).
    pub fn step(
        &mut self,
        actions: &[u32],
        obs: &mut [f32],
        masks: &mut [u8],
        rewards: &mut [f32],
    ) -> StepEnd {
        let n_actions = self.spaces().n_actions();
        assert_eq!(actions.len(), self.learners.len(), "one action per learner");
        self.played.extend_from_slice(actions);
        for (i, learner) in self.learners.iter_mut().enumerate() {
            let action = actions[i] as usize;
            let allowed = action < n_actions && self.masks[i * n_actions + action] == 1;
            learner.pending = None;
            learner.outcome = if !allowed {
                ActionOutcome::Masked
            } else {
                learner.pending = self.codec.action(&learner.seen, &self.game, action);
                if learner.pending.is_some() { ActionOutcome::Dropped } else { ActionOutcome::Waited }
            };
        }
        let end = self.advance(rewards);
        self.refresh_masks();
        self.write(obs, masks);
        end
    }

    /// One step with each learner's action given as the match's own action (`None`:
    /// wait), whatever the mask says: the symbolic way in, as a remote player acts. The
    /// match accepts or refuses it as it would a player's ([`Env::outcomes`] tells).
    /// Writes the rewards; [`Env::delta`] has each learner's new percepts.
    pub fn step_actions(&mut self, actions: Vec<Option<Action>>, rewards: &mut [f32]) -> StepEnd {
        assert_eq!(actions.len(), self.learners.len(), "one action per learner");
        self.replayable = false;
        for (learner, action) in self.learners.iter_mut().zip(actions) {
            learner.outcome = if action.is_some() { ActionOutcome::Dropped } else { ActionOutcome::Waited };
            learner.pending = action;
        }
        let end = self.advance(rewards);
        self.refresh_masks();
        end
    }

    /// Plays the step's ticks with the learners' pending actions; writes the rewards.
    fn advance(&mut self, rewards: &mut [f32]) -> StepEnd {
        assert_eq!(rewards.len(), self.learners.len(), "one reward per learner");
        for learner in &mut self.learners {
            learner.seen.start_step();
        }
        let before = self.drops();
        let max_ticks = self.max_ticks;
        for _ in 0..self.config.ticks_per_step {
            self.team.observe(&mut self.game);
            if self.game.is_complete() || self.game.tick() >= max_ticks {
                break;
            }
            let mut seats =
                Seating { team: &mut self.team, learners: &mut self.learners, intents: &mut self.intents };
            self.game.boundary(&mut seats, &mut ());
        }
        for learner in &mut self.learners {
            learner.pending = None;
        }
        self.poll();
        let after = self.drops();
        let r = &self.config.rewards;
        for (i, reward) in rewards.iter_mut().enumerate() {
            let (good, wrong) = match r.mode {
                RewardMode::Team => (after.team.0 - before.team.0, after.team.1 - before.team.1),
                RewardMode::Individual => {
                    (after.own[i].0 - before.own[i].0, after.own[i].1 - before.own[i].1)
                }
            };
            *reward = r.of_step(good, wrong);
        }
        let terminated = self.game.is_complete();
        StepEnd { terminated, truncated: !terminated && self.game.tick() >= max_ticks }
    }

    /// Good and wrong drops so far: the whole match's and each learner's.
    fn drops(&self) -> Drops {
        let stats = self.game.stats();
        let own = self
            .learners
            .iter()
            .map(|l| self.game.robot_stats(l.robot).map_or((0, 0), |s| (s.good_drops, s.wrong_drops)))
            .collect();
        Drops { team: (stats.good_drops, stats.wrong_drops), own }
    }

    /// Writes each learner's observation and mask (the masks were refreshed by the step).
    fn write(&mut self, obs: &mut [f32], masks: &mut [u8]) {
        let obs_len = self.codec.spaces().obs_len();
        assert_eq!(obs.len(), self.learners.len() * obs_len, "obs is agents x obs_len");
        assert_eq!(masks.len(), self.masks.len(), "masks is agents x n_actions");
        for (learner, o) in self.learners.iter().zip(obs.chunks_mut(obs_len)) {
            self.codec.observe(&learner.seen, &self.game, self.max_ticks, o);
        }
        masks.copy_from_slice(&self.masks);
    }

    /// Each learner's mask of the actions valid now.
    fn refresh_masks(&mut self) {
        let n_actions = self.codec.spaces().n_actions();
        let others = self.config.setup.seats.len() > 1;
        for (learner, mask) in self.learners.iter().zip(self.masks.chunks_mut(n_actions)) {
            self.codec.mask(&learner.seen, others, mask);
        }
    }

    /// Learner `agent`'s percepts polled at the end of the last step (or at reset: a full
    /// snapshot); `None` when nothing changed for it.
    pub fn delta(&self, agent: usize) -> Option<&PerceptDelta> {
        self.learners.get(agent)?.delta.as_ref()
    }

    /// The match now as a standalone SVG document: the map, blocks where they lie, robots
    /// where they stand (with what they hold), the sequence.
    pub fn render_svg(&self) -> String {
        crate::render::svg(&self.game)
    }

    /// The match now as an RGB image at `scale` pixels per map unit (1 to 32).
    pub fn render_rgb(&self, scale: f32) -> crate::Rgb {
        crate::render::rgb(&self.game, scale)
    }

    /// The names of the learners' robots (`Agent1`, ...), in learner order.
    pub fn agent_names(&self) -> impl Iterator<Item = &str> + '_ {
        self.learners.iter().map(|l| l.name.as_str())
    }

    /// The match's digest: equal digests mean equal matches, bit for bit.
    pub fn digest(&self) -> u64 {
        self.game.digest()
    }

    /// Ticks simulated in this episode.
    pub fn tick(&self) -> u64 {
        self.game.tick()
    }

    /// The match's statistics.
    pub fn stats(&self) -> &MatchStats {
        self.game.stats()
    }

    /// The match, to try actions on directly.
    #[cfg(test)]
    pub(crate) fn game_mut(&mut self) -> &mut Match {
        &mut self.game
    }

    /// The match (read only).
    pub fn game(&self) -> &Match {
        &self.game
    }

    /// Learner `agent`'s robot.
    pub fn robot(&self, agent: usize) -> Option<RobotId> {
        self.learners.get(agent).map(|l| l.robot)
    }

    /// Every fact learner `agent`'s robot perceives now (for `infos`), built from scratch.
    pub fn percepts(&self, agent: usize) -> Option<Vec<Percept>> {
        self.game.perceived(self.robot(agent)?)
    }

    /// What became of each learner's last action.
    pub fn outcomes(&self) -> impl Iterator<Item = ActionOutcome> + '_ {
        self.learners.iter().map(|l| l.outcome)
    }

    /// The action index `action` of learner `agent` as the match's action (`None`: wait,
    /// masked out, or out of range).
    pub fn decode(&self, agent: usize, action: u32) -> Option<Action> {
        let n = self.spaces().n_actions();
        let learner = self.learners.get(agent)?;
        let allowed = (action as usize) < n && self.masks[agent * n + action as usize] == 1;
        allowed.then(|| self.codec.action(&learner.seen, &self.game, action as usize)).flatten()
    }
}

struct Drops {
    team: (u32, u32),
    own: Vec<(u32, u32)>,
}

/// Who acts at a boundary: built-in teammates through their [`Team`], learners with
/// the action of this step.
struct Seating<'a> {
    team: &'a mut Team,
    learners: &'a mut [Learner],
    intents: &'a mut Vec<Intent<u64>>,
}

enum Tag {
    Team(u64),
    Learner(usize),
}

impl Seats for Seating<'_> {
    type Tag = Tag;

    fn robots(&self, into: &mut Vec<RobotId>) {
        self.team.robots(into);
        into.extend(self.learners.iter().filter(|l| l.pending.is_some()).map(|l| l.robot));
        into.sort_unstable();
    }

    fn take(&mut self, robot: RobotId, into: &mut Vec<Intent<Tag>>) {
        if let Some(i) = self.learners.iter().position(|l| l.robot == robot) {
            if let Some(action) = self.learners[i].pending.take() {
                into.push(Intent::Act(Tag::Learner(i), action));
            }
            return;
        }
        self.team.take(robot, self.intents);
        into.extend(self.intents.drain(..).map(|intent| match intent {
            Intent::Act(n, action) => Intent::Act(Tag::Team(n), action),
            Intent::Stop => Intent::Stop,
        }));
    }

    fn answered(&mut self, robot: RobotId, tag: Tag, action: &Action, outcome: &Result<Accepted, Rejection>) {
        match tag {
            Tag::Team(n) => self.team.answered(robot, n, action, outcome),
            Tag::Learner(i) => {
                self.learners[i].outcome = match outcome {
                    Ok(_) => ActionOutcome::Accepted,
                    Err(e) => ActionOutcome::Rejected(e.code()),
                }
            }
        }
    }

    fn ended(&mut self, end: &OrderEnd, tick: u64) {
        self.team.ended(end, tick);
    }
}
