//! Rewards on a scripted episode, termination, truncation, and determinism over whole
//! episodes.

use bw4t_agents::Strategy;
use bw4t_map::{Colour, Map, SeededRng};
use bw4t_sim::{Digest, MoveState};

use super::{Buffers, default_map};
use crate::bench::choose;
use crate::{Env, EnvConfig, RewardMode, Spaces};

/// The workspace's two-room test map (two spawn points, a drop zone and RoomA) with a
/// sequence of two colours and a block of each colour used, plus one nobody wants.
fn small_map() -> Map {
    let text = include_str!("../../../../tests/fixtures/two-rooms.toml");
    let mut parts = Map::from_native(text).expect("the two-room fixture").parts().clone();
    parts.sequence = vec![Colour::Red, Colour::Blue];
    let room = parts.zones.iter_mut().find(|z| z.name == "RoomA").expect("RoomA");
    room.blocks = vec![Colour::Green, Colour::Red, Colour::Blue];
    Map::new(parts).expect("the small map")
}

fn small(learners: usize) -> EnvConfig {
    EnvConfig::parallel(small_map(), learners)
}

fn segment<'a>(spaces: &Spaces, obs: &'a [f32], name: &str) -> &'a [f32] {
    let s = spaces.obs_segment(name).expect("segment");
    &obs[s.offset..s.offset + s.len]
}

/// Learner 0 plays the script; the others wait.
struct Script {
    env: Env,
    b: Buffers,
    spaces: Spaces,
    /// Rewards of every step, per learner.
    rewards: Vec<Vec<f32>>,
    ended: Option<crate::StepEnd>,
}

impl Script {
    fn new(config: EnvConfig) -> Script {
        let mut env = Env::new(config).expect("env");
        let mut b = Buffers::for_env(&env);
        b.reset(&mut env, 1);
        let spaces = env.spaces().clone();
        Script { env, b, spaces, rewards: Vec::new(), ended: None }
    }

    fn action(&self, name: &str, index: usize) -> u32 {
        (self.spaces.action_segment(name).expect("segment").offset + index) as u32
    }

    fn step(&mut self, action: u32) {
        assert!(self.ended.is_none(), "the episode has ended");
        self.b.actions.fill(0);
        self.b.actions[0] = action;
        let end = self.b.step(&mut self.env);
        self.rewards.push(self.b.rewards.clone());
        self.ended = end.done().then_some(end);
    }

    /// Takes `action`, then waits until the robot has arrived.
    fn go(&mut self, action: u32) {
        self.step(action);
        for _ in 0..100 {
            let state = segment(&self.spaces, &self.b.obs, "move_state");
            if state[MoveState::Traveling as usize] == 0.0 {
                return;
            }
            self.step(0);
        }
        panic!("never arrived");
    }

    /// Fetches a block of `colour` from RoomA and puts it down in the drop zone; returns
    /// the put-down step's rewards.
    fn deliver(&mut self, colour: Colour) -> Vec<f32> {
        let map = self.env.game().map().clone();
        self.go(self.action("go_to", map.zone_named("RoomA").expect("room")));
        let slots = segment(&self.spaces, &self.b.obs, "slots");
        let slot = (0..self.spaces.dims.slots).find(|k| slots[k * 9 + colour as usize] == 1.0).expect("seen");
        self.go(self.action("go_to_block", slot));
        assert_eq!(segment(&self.spaces, &self.b.obs, "at_block"), [1.0]);
        self.step(self.action("pick_up", 0));
        assert_eq!(segment(&self.spaces, &self.b.obs, "held_colour")[colour as usize], 1.0);
        self.go(self.action("go_to", map.drop_zone()));
        assert_eq!(segment(&self.spaces, &self.b.obs, "in_room"), [1.0]);
        self.step(self.action("put_down", 0));
        self.rewards.last().expect("a step").clone()
    }
}

#[test]
fn deliveries_in_order_and_wrong_drops_are_rewarded_and_completion_terminates() {
    let mut script = Script::new(small(1));
    let cost = script.env.config().rewards.step_cost;
    let (good, wrong) = (1.0f32 - cost, -0.5f32 - cost);
    assert_eq!(script.deliver(Colour::Green), [wrong]);
    assert_eq!(script.env.stats().wrong_drops, 1);
    assert_eq!(script.deliver(Colour::Red), [good]);
    assert_eq!(segment(&script.spaces, &script.b.obs, "delivered"), [1.0, 0.0]);
    assert_eq!(script.ended, None);
    assert_eq!(script.deliver(Colour::Blue), [good]);
    let end = script.ended.expect("ended");
    assert!(end.terminated && !end.truncated);
    // Every other step cost only the step.
    let others = script.rewards.iter().filter(|r| r[0] == -cost).count();
    assert_eq!(others, script.rewards.len() - 3);
    assert_eq!(segment(&script.spaces, &script.b.obs, "sequence_index"), [0.0, 0.0, 1.0]);
}

#[test]
fn team_rewards_are_shared_and_individual_ones_are_not() {
    let cost = crate::Rewards::default().step_cost;
    let mut team = Script::new(small(2));
    assert_eq!(team.deliver(Colour::Green), [-0.5 - cost, -0.5 - cost]);
    let mut config = small(2);
    config.rewards.mode = RewardMode::Individual;
    let mut own = Script::new(config);
    assert_eq!(own.deliver(Colour::Green), [-0.5 - cost, -cost]);
}

#[test]
fn the_tick_limit_truncates() {
    let mut config = small(1);
    config.setup.max_ticks = Some(45);
    let mut script = Script::new(config);
    for step in 1..=4 {
        script.step(0);
        assert_eq!((script.env.tick(), script.ended), (step * 10, None));
    }
    script.step(0);
    assert_eq!(script.env.tick(), 45, "the last step stops at the limit");
    let end = script.ended.expect("ended");
    assert!(end.truncated && !end.terminated);
}

/// Digests of every step of `steps` random allowed steps from `reset(seed)`: the match's,
/// and one of the observations, masks and rewards' bits.
fn trace(env: &mut Env, seed: u64, steps: usize) -> Vec<(u64, u64)> {
    let mut b = Buffers::for_env(env);
    b.reset(env, seed);
    let n = env.spaces().n_actions();
    let mut rng = SeededRng::new(seed);
    let mut out = Vec::with_capacity(steps);
    for _ in 0..steps {
        choose(&mut rng, &b.masks, n, &mut b.actions);
        let end = b.step(env);
        let mut d = Digest::default();
        b.obs.iter().chain(&b.rewards).for_each(|&v| d.f32(v));
        b.masks.iter().for_each(|&m| d.u64(m.into()));
        d.u64(u64::from(end.terminated) << 1 | u64::from(end.truncated));
        out.push((env.digest(), d.finish()));
        if end.done() {
            b.reset(env, seed + 1);
        }
    }
    out
}

#[test]
fn whole_episodes_repeat_bit_for_bit() {
    let configs =
        [EnvConfig::parallel(default_map(), 3), EnvConfig::single(default_map(), 2, Strategy::Cooperative)];
    for config in configs {
        let mut env = Env::new(config.clone()).expect("env");
        let first = trace(&mut env, 11, 1000);
        assert_eq!(trace(&mut env, 11, 1000), first, "reset on the same seed");
        assert_eq!(trace(&mut Env::new(config).expect("env"), 11, 1000), first, "a fresh env");
        let distinct: std::collections::BTreeSet<u64> = first.iter().map(|t| t.0).collect();
        assert!(distinct.len() > 900, "the match moves on");
    }
}
