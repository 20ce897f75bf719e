//! The crate's tests: spaces against the docs, masks against the match, rewards, episode
//! ends, determinism and the vector against single environments.

mod copying;
mod episodes;
mod masks;
mod recorded;
mod spaces;
mod symbolic;
mod vector;

use bw4t_map::Map;

use crate::Env;

/// The shipped default map.
pub(crate) fn default_map() -> Map {
    Map::from_native(include_str!("../../../../maps/default.toml")).expect("the shipped map")
}

/// One environment's arrays.
pub(crate) struct Buffers {
    pub(crate) obs: Vec<f32>,
    pub(crate) masks: Vec<u8>,
    pub(crate) rewards: Vec<f32>,
    pub(crate) actions: Vec<u32>,
}

impl Buffers {
    pub(crate) fn for_env(env: &Env) -> Buffers {
        let (a, s) = (env.agents(), env.spaces());
        Buffers {
            obs: vec![0.0; a * s.obs_len()],
            masks: vec![0; a * s.n_actions()],
            rewards: vec![0.0; a],
            actions: vec![0; a],
        }
    }

    pub(crate) fn reset(&mut self, env: &mut Env, seed: u64) {
        env.reset(seed, &mut self.obs, &mut self.masks).expect("reset");
    }

    pub(crate) fn step(&mut self, env: &mut Env) -> crate::StepEnd {
        env.step(&self.actions, &mut self.obs, &mut self.masks, &mut self.rewards)
    }
}
