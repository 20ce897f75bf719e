//! Trajectories: a replay re-simulated (the verification path, [`Match::reapply`]) into
//! what each robot was told and did, for learners to load. Each robot's percepts are
//! polled after every tick, as a lockstep player is sent them, and after its joining.
//! Two kinds (the line shapes are `bw4t-protocol`'s, see its `trajectory` module):
//! `symbolic`, one line per tick the robot was told something or acted (percepts, words,
//! actions, messages), and `env`, the single-learner environment's encoding (observation,
//! mask, action index, reward, episode end) step by step. A replay that does not verify is
//! refused.

use std::collections::BTreeMap;
use std::path::Path;

use bw4t_env::{RecordedView, RewardMode, Rewards};
use bw4t_protocol::{
    EnvEncoding, EnvStep, EnvStepTaken, Knowledge, LayoutSegment, Percepts, ReplayEvent, RobotTick, Said,
    TRAJECTORY_FORMAT, TrajectoryAction, TrajectoryMessage, TrajectoryMeta, TrajectoryRobot, percept_to_fact,
};
use bw4t_sim::{Action, Match, Percept, PerceptDelta, Receiver, RobotId};

use crate::replay::{ReplayError, Verdict, Watch, read_replay, resimulate, start};

/// What to export.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrajectoryKind {
    /// `NAME.jsonl`: percepts, words, actions and messages ([`RobotTick`] lines).
    Symbolic,
    /// `NAME.env.jsonl`: the single-learner environment's encoding ([`EnvStep`] lines).
    Env,
}

impl TrajectoryKind {
    /// Its name, as `meta.json` and the command line say it.
    pub fn as_str(self) -> &'static str {
        match self {
            TrajectoryKind::Symbolic => "symbolic",
            TrajectoryKind::Env => "env",
        }
    }
}

/// How to export.
#[derive(Clone, Copy, Debug)]
pub struct TrajectoryOptions {
    /// Which files.
    pub kind: TrajectoryKind,
    /// `env`: ticks per step (at least 1).
    pub ticks_per_step: u32,
    /// `env`: visible-block slots.
    pub slots: usize,
    /// `env`: the rewards.
    pub rewards: Rewards,
    /// Export a replay without its end record (its writer was stopped) up to its last tick.
    pub allow_incomplete: bool,
}

impl Default for TrajectoryOptions {
    /// Symbolic, with the environment's defaults for the rest; incomplete replays refused.
    fn default() -> Self {
        TrajectoryOptions {
            kind: TrajectoryKind::Symbolic,
            ticks_per_step: bw4t_env::DEFAULT_TICKS_PER_STEP,
            slots: bw4t_env::DEFAULT_SLOTS,
            rewards: Rewards::default(),
            allow_incomplete: false,
        }
    }
}

/// Why a replay cannot be exported.
#[derive(Debug, thiserror::Error)]
pub enum TrajectoryError {
    /// It cannot be read.
    #[error(transparent)]
    Replay(#[from] ReplayError),
    /// Re-simulating it does not give what was recorded.
    #[error(
        "the replay does not verify: it differs at tick {tick}: recorded {expected}, re-simulated {found}"
    )]
    Differs {
        /// The first tick that differs.
        tick: u64,
        /// What was recorded.
        expected: String,
        /// What re-simulation gave.
        found: String,
    },
    /// It has no end record and incomplete replays were not allowed.
    #[error("the replay is {0}; export it anyway with --incomplete")]
    Incomplete(String),
    /// An option is out of range.
    #[error("{0}")]
    Options(&'static str),
}

/// One replay's trajectories, ready to write.
#[derive(Clone, Debug)]
pub struct Trajectories {
    /// `meta.json`.
    pub meta: TrajectoryMeta,
    /// `map.toml`: the replay's map.
    pub map_native: String,
    /// Per robot, in joining order: its file name and its lines (JSON, one per line).
    pub files: Vec<(String, Vec<String>)>,
}

impl Trajectories {
    /// Writes `meta.json`, `map.toml` and every robot's file into `dir` (made if missing).
    pub fn write(&self, dir: &Path) -> std::io::Result<()> {
        std::fs::create_dir_all(dir)?;
        let meta = serde_json::to_string_pretty(&self.meta).map_err(std::io::Error::other)?;
        std::fs::write(dir.join("meta.json"), meta + "\n")?;
        std::fs::write(dir.join("map.toml"), &self.map_native)?;
        for (name, lines) in &self.files {
            let mut text = String::with_capacity(lines.iter().map(|l| l.len() + 1).sum());
            for line in lines {
                text.push_str(line);
                text.push('\n');
            }
            std::fs::write(dir.join(name), text)?;
        }
        Ok(())
    }
}

/// Re-simulates the replay `text` (named `replay` in the meta) into its robots'
/// trajectories; refuses a replay that does not verify (or, unless allowed, is incomplete).
pub fn trajectories(
    text: &str,
    replay: &str,
    options: &TrajectoryOptions,
) -> Result<Trajectories, TrajectoryError> {
    if options.ticks_per_step == 0 {
        return Err(TrajectoryError::Options("ticks per step must be at least 1"));
    }
    if options.slots == 0 {
        return Err(TrajectoryError::Options("slots must be at least 1"));
    }
    let (header, lines) = read_replay(text)?;
    let (map, mut game) = start(&header)?;
    // The `time` segment divides by the tick limit; a replay without one by its last tick.
    let last_tick = lines.iter().map(|(_, l)| line_tick(l)).max().unwrap_or(0);
    let max_ticks = header.max_ticks.unwrap_or(last_tick).max(1);
    let mut follow = Follow {
        options: *options,
        max_ticks,
        map: &map,
        live: BTreeMap::new(),
        done: Vec::new(),
        sent: Vec::new(),
    };
    let walked = resimulate(&header, &lines, &mut game, &mut follow);
    match walked.verdict {
        Verdict::Differs { tick, expected, found } => {
            return Err(TrajectoryError::Differs { tick, expected, found });
        }
        Verdict::Incomplete { .. } if !options.allow_incomplete => {
            return Err(TrajectoryError::Incomplete(walked.verdict.incomplete_report().unwrap_or_default()));
        }
        _ => {}
    }
    let live = std::mem::take(&mut follow.live);
    for (_, mut follower) in live {
        follower.finish(&mut game, options);
        follow.done.push(follower);
    }
    follow.done.sort_by_key(|f| f.order);
    let robots_and_files = name_files(follow.done, options.kind);
    let spaces = RecordedView::new(&map, options.slots);
    let layout = |segments: &[bw4t_env::Segment]| {
        segments
            .iter()
            .map(|s| LayoutSegment { name: s.name.to_string(), offset: s.offset, len: s.len })
            .collect()
    };
    let env = (options.kind == TrajectoryKind::Env).then(|| EnvEncoding {
        ticks_per_step: options.ticks_per_step,
        slots: options.slots,
        max_ticks,
        obs_len: spaces.spaces().obs_len(),
        n_actions: spaces.spaces().n_actions(),
        obs_layout: layout(spaces.spaces().obs_layout()),
        action_layout: layout(spaces.spaces().action_layout()),
        delivery: options.rewards.delivery,
        wrong_drop: options.rewards.wrong_drop,
        step_cost: options.rewards.step_cost,
        reward_mode: match options.rewards.mode {
            RewardMode::Team => "team",
            RewardMode::Individual => "individual",
        }
        .to_string(),
    });
    let summary = walked.summary;
    let meta = TrajectoryMeta {
        format: TRAJECTORY_FORMAT,
        kind: options.kind.as_str().to_string(),
        replay: replay.to_string(),
        map: header.map.clone(),
        seed: header.seed,
        labels: header.labels.clone(),
        ticks: summary.game_ticks,
        max_ticks: header.max_ticks,
        end_reason: summary.reason,
        sequence_index: summary.sequence_index,
        sequence_length: summary.sequence.len(),
        good_drops: game.stats().good_drops,
        env,
        robots: robots_and_files.iter().map(|(robot, _)| robot.clone()).collect(),
    };
    let files = robots_and_files.into_iter().map(|(robot, lines)| (robot.file, lines)).collect();
    Ok(Trajectories { meta, map_native: header.map_native.clone(), files })
}

fn line_tick(line: &bw4t_protocol::ReplayLine) -> u64 {
    match line {
        bw4t_protocol::ReplayLine::Header(_) => 0,
        bw4t_protocol::ReplayLine::Tick { tick, .. }
        | bw4t_protocol::ReplayLine::Digest { tick, .. }
        | bw4t_protocol::ReplayLine::End { tick, .. } => *tick,
    }
}

/// Each robot's file name: its player's name made safe for a file, numbered when a name
/// comes again (a player who left and joined anew).
fn name_files(done: Vec<Follower>, kind: TrajectoryKind) -> Vec<(TrajectoryRobot, Vec<String>)> {
    let extension = match kind {
        TrajectoryKind::Symbolic => "jsonl",
        TrajectoryKind::Env => "env.jsonl",
    };
    let mut used: BTreeMap<String, usize> = BTreeMap::new();
    done.into_iter()
        .map(|f| {
            let safe: String =
                f.name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
            let n = used.entry(safe.clone()).or_default();
            *n += 1;
            let stem = if *n == 1 { safe } else { format!("{safe}-{n}") };
            let robot = TrajectoryRobot {
                robot: f.robot.0,
                name: f.name.clone(),
                file: format!("{stem}.{extension}"),
                lines: f.lines.len(),
                actions: f.actions,
                joined: f.joined,
                left: f.left,
            };
            (robot, f.lines)
        })
        .collect()
}

/// Every robot followed through the re-simulation.
struct Follow<'a> {
    options: TrajectoryOptions,
    max_ticks: u64,
    map: &'a bw4t_map::Map,
    /// The robots in the match, by id.
    live: BTreeMap<u32, Follower>,
    /// Robots that left, in the order they left.
    done: Vec<Follower>,
    /// Messages sent at the last boundary, to name a received message's receiver.
    sent: Vec<TrajectoryMessage>,
}

impl Watch for Follow<'_> {
    fn ticked(&mut self, game: &mut Match) {
        for follower in self.live.values_mut() {
            follower.flush_line();
            let delta = game.poll_percepts(follower.robot);
            follower.told(game, delta.as_ref(), &self.sent, &self.options);
        }
        self.sent.clear();
    }

    fn before(&mut self, game: &mut Match, event: &ReplayEvent) {
        match event {
            ReplayEvent::Leave { robot } => {
                if let Some(mut follower) = self.live.remove(robot) {
                    follower.left = Some(game.tick());
                    follower.finish(game, &self.options);
                    self.done.push(follower);
                }
            }
            ReplayEvent::Act { robot, action, args, ok } => {
                let Some(follower) = self.live.get_mut(robot) else { return };
                follower.actions += 1;
                let parsed = event.action();
                if let Some(env) = &mut follower.env {
                    // An action this program cannot read has no index either.
                    env.acted(game, follower.robot, parsed.as_ref());
                    return;
                }
                let record = TrajectoryAction { action: action.clone(), args: args.clone(), ok: *ok };
                follower.line(game.tick()).actions.push(record);
                if let (true, Some(Action::SendMessage { to, text })) = (*ok, &parsed) {
                    let to = match to {
                        Receiver::All => "all".to_string(),
                        Receiver::Player(p) => p.clone(),
                    };
                    let message = message(&follower.name, to, text);
                    follower.line(game.tick()).sent.push(message.clone());
                    self.sent.push(message);
                }
            }
            ReplayEvent::Join { .. } | ReplayEvent::Stop { .. } => {}
        }
    }

    fn settled(&mut self, game: &mut Match) {
        for follower in self.live.values_mut() {
            if let Some(env) = &mut follower.env {
                env.begin(game, follower.robot);
            }
        }
    }

    fn after(&mut self, game: &mut Match, event: &ReplayEvent) {
        let ReplayEvent::Join { name, robot } = event else { return };
        let order = self.live.len() + self.done.len();
        let env = (self.options.kind == TrajectoryKind::Env)
            .then(|| EnvFollower::new(RecordedView::new(self.map, self.options.slots), self.max_ticks));
        let mut follower = Follower {
            order,
            robot: RobotId(*robot),
            name: name.clone(),
            joined: game.tick(),
            left: None,
            actions: 0,
            knowledge: Knowledge::for_map(self.map),
            pending: None,
            lines: Vec::new(),
            env,
        };
        // Its first percepts, a snapshot, come at its joining.
        let delta = game.poll_percepts(follower.robot);
        follower.told(game, delta.as_ref(), &[], &self.options);
        self.live.insert(*robot, follower);
    }
}

/// One robot's trajectory as it is made.
struct Follower {
    /// Joining order.
    order: usize,
    robot: RobotId,
    name: String,
    joined: u64,
    left: Option<u64>,
    actions: usize,
    /// What it knows, for its words.
    knowledge: Knowledge,
    /// The symbolic line of the current tick, while it may still get actions.
    pending: Option<RobotTick>,
    /// Lines written (JSON).
    lines: Vec<String>,
    env: Option<EnvFollower>,
}

impl Follower {
    /// The symbolic line of `tick`, made if the robot has none yet.
    fn line(&mut self, tick: u64) -> &mut RobotTick {
        let (robot, name) = (self.robot.0, &self.name);
        self.pending.get_or_insert_with(|| RobotTick {
            tick,
            robot,
            name: name.clone(),
            percepts: None,
            changes: Vec::new(),
            actions: Vec::new(),
            sent: Vec::new(),
            received: Vec::new(),
        })
    }

    /// Writes the pending symbolic line, if any.
    fn flush_line(&mut self) {
        if let Some(line) = self.pending.take() {
            self.lines.push(serde_json::to_string(&line).unwrap_or_default());
        }
    }

    /// The robot was told `delta` (polled at `game`'s tick).
    fn told(
        &mut self,
        game: &mut Match,
        delta: Option<&PerceptDelta>,
        sent: &[TrajectoryMessage],
        options: &TrajectoryOptions,
    ) {
        if let Some(env) = &mut self.env {
            if let Some(delta) = delta {
                env.view.apply(delta);
            }
            // At its joining the robot waits for its teammates joining with it (`begin`).
            if game.tick() > self.joined {
                env.ticked(game, self.robot, options);
            }
            return;
        }
        let Some(delta) = delta.filter(|d| !d.is_empty()) else { return };
        let before = self.knowledge.snapshot();
        self.knowledge.apply(delta.tick, delta);
        let received = delta
            .add
            .iter()
            .filter_map(|p| match p {
                Percept::Message { from, text } => {
                    // The receiver as the sender named it; a message always comes one tick on.
                    let to = sent
                        .iter()
                        .find(|m| m.from == **from && m.text == **text)
                        .map_or_else(|| self.name.clone(), |m| m.to.clone());
                    Some(message(from, to, text))
                }
                _ => None,
            })
            .collect();
        let percepts = Percepts {
            tick: delta.tick,
            add: delta.add.iter().map(percept_to_fact).collect(),
            not: delta.not.iter().map(percept_to_fact).collect(),
            full: delta.full,
            words: Some(self.knowledge.describe()),
        };
        let changes = self.knowledge.changes_since(&before);
        let line = self.line(delta.tick);
        line.percepts = Some(percepts);
        line.changes = changes;
        line.received = received;
    }

    /// The replay ends for this robot (its end, or the robot leaving).
    fn finish(&mut self, game: &mut Match, options: &TrajectoryOptions) {
        self.flush_line();
        if let Some(env) = &mut self.env {
            env.finish(game, self.robot, options);
            self.lines = env.steps.iter().map(|s| serde_json::to_string(s).unwrap_or_default()).collect();
        }
    }
}

/// A message as the trajectory writes it.
fn message(from: &str, to: String, text: &str) -> TrajectoryMessage {
    let said = Said::from_text(text);
    let sentence = said.as_ref().and_then(|s| s.sentence().ok()).unwrap_or_else(|| text.to_string());
    TrajectoryMessage { from: from.to_string(), to, text: text.to_string(), said, sentence }
}

/// One robot in the environment's encoding, step by step.
struct EnvFollower {
    view: RecordedView,
    max_ticks: u64,
    /// Observation lines; the last one's step is under way (`then` is `None`).
    steps: Vec<EnvStep>,
    /// The actions of the step under way: each with whether it moves or handles a block,
    /// and its index, if one stands for it.
    taken: Vec<(bool, Option<u32>)>,
    /// Drops when the step started: the match's and the robot's (good, wrong).
    drops: [(u32, u32); 2],
    /// The episode is over (the sequence was completed).
    over: bool,
    mask: Vec<u8>,
}

impl EnvFollower {
    fn new(view: RecordedView, max_ticks: u64) -> EnvFollower {
        let mask = vec![0; view.spaces().n_actions()];
        EnvFollower {
            view,
            max_ticks,
            steps: Vec::new(),
            taken: Vec::new(),
            drops: [(0, 0); 2],
            over: false,
            mask,
        }
    }

    /// The observation now, as a line whose step is yet to come.
    fn observe(&mut self, game: &Match) -> EnvStep {
        let spaces = self.view.spaces();
        let mut observation = vec![0.0; spaces.obs_len()];
        self.view.observe(game, self.max_ticks, &mut observation);
        self.view.mask(others(game), &mut self.mask);
        EnvStep {
            step: self.steps.len() as u64,
            tick: game.tick(),
            observation,
            action_mask: self.mask.clone(),
            then: None,
        }
    }

    /// After the robot's percepts of a tick were applied: the first observation, or the
    /// end of a step when its ticks are up or the sequence is complete.
    fn ticked(&mut self, game: &Match, robot: RobotId, options: &TrajectoryOptions) {
        if self.over {
            return;
        }
        let Some(last) = self.steps.last() else {
            self.begin(game, robot);
            return;
        };
        let complete = game.is_complete();
        if game.tick() - last.tick >= u64::from(options.ticks_per_step) || complete {
            self.close_step(game, robot, options, complete, false);
        }
    }

    /// The first observation, unless made: once everyone joining with the robot has
    /// joined (the tick's events are applied) or when the robot first acts, whichever
    /// comes first, as an environment's reset observes after every seat has joined.
    fn begin(&mut self, game: &Match, robot: RobotId) {
        if self.steps.is_empty() {
            let first = self.observe(game);
            self.steps.push(first);
            self.start_step(game, robot);
        }
    }

    fn start_step(&mut self, game: &Match, robot: RobotId) {
        self.view.start_step();
        self.taken.clear();
        self.drops = drops(game, robot);
    }

    /// Ends the step under way with the observation now; `truncated`: the episode ends here.
    fn close_step(
        &mut self,
        game: &Match,
        robot: RobotId,
        options: &TrajectoryOptions,
        terminated: bool,
        truncated: bool,
    ) {
        let [(good, wrong), (own_good, own_wrong)] = drops(game, robot);
        let [(good0, wrong0), (own_good0, own_wrong0)] = self.drops;
        let reward = match options.rewards.mode {
            RewardMode::Team => options.rewards.of_step(good - good0, wrong - wrong0),
            RewardMode::Individual => options.rewards.of_step(own_good - own_good0, own_wrong - own_wrong0),
        };
        // Moves and block actions before messages: what a learner most needs to copy.
        let chosen = self
            .taken
            .iter()
            .find(|(physical, index)| *physical && index.is_some())
            .or_else(|| self.taken.iter().find(|(_, index)| index.is_some()))
            .and_then(|(_, index)| *index);
        let taken = self.taken.len() as u32;
        let then = EnvStepTaken {
            action: chosen.unwrap_or(0),
            reward,
            terminated,
            truncated: truncated && !terminated,
            taken,
            left_out: taken - u32::from(chosen.is_some()),
        };
        if let Some(last) = self.steps.last_mut() {
            last.then = Some(then);
        }
        let next = self.observe(game);
        self.steps.push(next);
        self.over = terminated || truncated;
        self.start_step(game, robot);
    }

    /// The robot took `action` in the step under way.
    fn acted(&mut self, game: &Match, robot: RobotId, action: Option<&Action>) {
        if self.over {
            return;
        }
        self.begin(game, robot);
        // The index as the robot's view and mask stand now (with one tick per step, those
        // of the step's observation).
        self.view.mask(others(game), &mut self.mask);
        let index = action.and_then(|action| self.view.index_of(game, &self.mask, action));
        let physical = action.is_some_and(|a| !matches!(a, Action::SendMessage { .. }));
        self.taken.push((physical, index));
    }

    /// The replay ends for the robot: a step under way ends there, truncated; one that
    /// ended just now without ending the episode is marked truncated.
    fn finish(&mut self, game: &Match, robot: RobotId, options: &TrajectoryOptions) {
        if self.over {
            return;
        }
        let Some(last) = self.steps.last() else { return };
        // Actions at the very tick the replay ends for the robot changed nothing it saw.
        if game.tick() > last.tick {
            self.close_step(game, robot, options, game.is_complete(), true);
        } else if let Some(previous) = self.steps.iter_mut().rev().nth(1).and_then(|s| s.then.as_mut()) {
            previous.truncated = !previous.terminated;
        }
        self.over = true;
    }
}

/// Whether another robot is in the match (messages need someone to hear them).
fn others(game: &Match) -> bool {
    game.robots().nth(1).is_some()
}

/// The match's drops and the robot's, (good, wrong) each.
fn drops(game: &Match, robot: RobotId) -> [(u32, u32); 2] {
    let stats = game.stats();
    let own = game.robot_stats(robot).map_or((0, 0), |s| (s.good_drops, s.wrong_drops));
    [(stats.good_drops, stats.wrong_drops), own]
}

#[cfg(test)]
mod tests;
