//! An episode played again from its seed and actions is the same episode; a vector's
//! matches snapshotted and restored go on alike; a partial reset starts only the marked
//! matches, on the seeds given; the global state accounts for every block.

use bw4t_map::SeededRng;
use bw4t_sim::BlockPlace;

use super::{Buffers, default_map};
use crate::bench::choose;
use crate::{Env, EnvConfig, VecBuffers, VecEnv};

fn random_steps(env: &mut Env, b: &mut Buffers, rng: &mut SeededRng, steps: usize) {
    let n_actions = env.spaces().n_actions();
    for _ in 0..steps {
        choose(rng, &b.masks, n_actions, &mut b.actions);
        b.step(env);
    }
}

#[test]
fn a_replayed_episode_is_the_same_episode_and_goes_on_alike() {
    let config = EnvConfig::parallel(default_map(), 2);
    let mut env = Env::new(config.clone()).expect("env");
    let mut b = Buffers::for_env(&env);
    b.reset(&mut env, 17);
    let mut rng = SeededRng::new(3);
    random_steps(&mut env, &mut b, &mut rng, 60);
    let (seed, played) = env.episode().expect("replayable");
    assert_eq!((seed, played.len()), (17, 120), "one action per learner and step");

    let mut twin = Env::new(config).expect("env");
    let mut tb = Buffers::for_env(&twin);
    twin.replay(seed, played, &mut tb.obs, &mut tb.masks).expect("replay");
    assert_eq!((twin.digest(), &tb.obs, &tb.masks), (env.digest(), &b.obs, &b.masks));
    let mut twin_rng = rng.clone();
    random_steps(&mut env, &mut b, &mut rng, 30);
    random_steps(&mut twin, &mut tb, &mut twin_rng, 30);
    assert_eq!((twin.digest(), &tb.obs, &tb.rewards), (env.digest(), &b.obs, &b.rewards));
    assert!(twin.replay(1, &[0], &mut tb.obs, &mut tb.masks).is_err(), "half a step is refused");
}

#[test]
fn the_match_s_own_actions_make_an_episode_unreplayable() {
    let mut env = Env::new(EnvConfig::parallel(default_map(), 1)).expect("env");
    let mut rewards = [0.0];
    env.step_actions(vec![None], &mut rewards);
    assert!(env.episode().is_none());
}

#[test]
fn a_restored_vector_goes_on_as_the_original() {
    let mut config = EnvConfig::parallel(default_map(), 2);
    config.setup.max_ticks = Some(200);
    let mut vec = VecEnv::new(config.clone(), 3, 5, 2).expect("vec");
    let mut out = VecBuffers::for_vec(&vec);
    out.reset(&mut vec).expect("reset");
    let n_actions = vec.spaces().n_actions();
    let mut actions = vec![0; 6];
    let mut rng = SeededRng::new(1);
    for _ in 0..30 {
        choose(&mut rng, &out.masks, n_actions, &mut actions);
        out.step(&mut vec, &actions).expect("step");
    }
    assert!((0..3).all(|i| vec.episodes(i) == 2 && vec.last_episode(i).is_some_and(|e| e.ticks == 200)));

    let mut twin = VecEnv::new(config, 3, 99, 1).expect("vec");
    let mut tout = VecBuffers::for_vec(&twin);
    for i in 0..3 {
        let state = vec.snapshot(i).expect("snapshot");
        twin.restore(i, &state, &mut tout.obs, &mut tout.masks).expect("restore");
        assert_eq!(twin.snapshot(i), Some(state));
    }
    assert_eq!((&tout.obs, &tout.masks), (&out.obs, &out.masks));
    for _ in 0..40 {
        choose(&mut rng, &out.masks, n_actions, &mut actions);
        out.step(&mut vec, &actions).expect("step");
        tout.step(&mut twin, &actions).expect("step");
        assert_eq!((&tout.obs, &tout.rewards, &tout.truncated), (&out.obs, &out.rewards, &out.truncated));
    }
    assert!((0..3).all(|i| twin.digest_of(i) == vec.digest_of(i) && vec.episodes(i) == 4));
}

impl VecEnv {
    fn digest_of(&self, i: usize) -> u64 {
        self.env(i).digest()
    }
}

#[test]
fn a_partial_reset_starts_only_the_marked_matches_on_the_seeds_given() {
    let config = EnvConfig::parallel(default_map(), 1);
    let mut vec = VecEnv::new(config.clone(), 2, 5, 1).expect("vec");
    let mut out = VecBuffers::for_vec(&vec);
    out.reset(&mut vec).expect("reset");
    out.step(&mut vec, &[0, 0]).expect("step");
    let (first, ticks) = (out.obs.clone(), vec.env(0).tick());
    vec.reset_some(&[false, true], &[None, Some(9)], &mut out.obs, &mut out.masks).expect("reset");
    let obs_len = vec.spaces().obs_len();
    assert_eq!(out.obs[..obs_len], first[..obs_len], "match 0 is left as it was");
    assert_eq!(vec.env(0).tick(), ticks);
    let mut single = Env::new(config).expect("env");
    let mut b = Buffers::for_env(&single);
    b.reset(&mut single, 9);
    assert_eq!(out.obs[obs_len..], b.obs[..], "match 1 plays seed 9");
    assert_eq!((vec.episodes(1), vec.snapshot(1).map(|s| s.stream)), (2, Some((9, 0))));
}

#[test]
fn the_state_accounts_for_every_block_and_robot() {
    let mut env = Env::new(EnvConfig::parallel(default_map(), 3)).expect("env");
    let mut b = Buffers::for_env(&env);
    b.reset(&mut env, 4);
    let mut rng = SeededRng::new(8);
    let space = env.state_space().clone();
    let mut state = vec![0.0; space.len()];
    let seg = |name: &str| space.layout().iter().find(|s| s.name == name).cloned().expect(name);
    for _ in 0..150 {
        random_steps(&mut env, &mut b, &mut rng, 1);
        env.write_state(&mut state);
        let lying = env.game().blocks().filter(|(_, _, p)| matches!(p, BlockPlace::Room { .. })).count();
        let held = env.game().blocks().filter(|(_, _, p)| matches!(p, BlockPlace::Held(_))).count();
        let (blocks, holding) = (seg("room_blocks"), seg("robot_holding"));
        assert_eq!(state[blocks.offset..blocks.offset + blocks.len].iter().sum::<f32>(), lying as f32);
        assert_eq!(state[holding.offset..holding.offset + holding.len].iter().sum::<f32>(), held as f32);
        let rooms = seg("robot_room");
        assert_eq!(state[rooms.offset..rooms.offset + rooms.len].iter().sum::<f32>(), 3.0);
    }
}
