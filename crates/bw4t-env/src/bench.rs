//! Throughput figures: learner steps per second of one environment and of a [`VecEnv`],
//! every learner choosing uniformly among its allowed actions.

use std::time::Instant;

use bw4t_map::SeededRng;

use crate::config::EnvConfig;
use crate::env::{Env, EnvError};
use crate::vec_env::{VecBuffers, VecEnv};

/// What one measurement found.
#[derive(Clone, Debug, PartialEq)]
pub struct Figures {
    /// Environments stepped together (1: a lone [`Env`]).
    pub envs: usize,
    /// Threads.
    pub threads: usize,
    /// Learners per environment.
    pub agents: usize,
    /// Steps of each environment.
    pub steps: u64,
    /// Learner steps in all: `envs × agents × steps`.
    pub agent_steps: u64,
    /// Episodes that ended.
    pub episodes_ended: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
}

impl Figures {
    /// Learner steps per second.
    pub fn agent_steps_per_s(&self) -> f64 {
        self.agent_steps as f64 / self.seconds.max(f64::MIN_POSITIVE)
    }
}

/// Picks, per learner, a uniformly random action its mask allows.
pub(crate) fn choose(rng: &mut SeededRng, masks: &[u8], n_actions: usize, actions: &mut [u32]) {
    for (mask, action) in masks.chunks(n_actions).zip(actions.iter_mut()) {
        let allowed = mask.iter().filter(|&&m| m == 1).count() as u64;
        let mut pick = rng.below(allowed.max(1));
        *action = 0;
        for (i, &m) in mask.iter().enumerate() {
            if m == 1 {
                if pick == 0 {
                    *action = i as u32;
                    break;
                }
                pick -= 1;
            }
        }
    }
}

/// `steps` steps of one environment, reset on the next seed whenever an episode ends.
pub fn single(config: EnvConfig, steps: u64, seed: u64) -> Result<Figures, EnvError> {
    let mut env = Env::new(config)?;
    let (agents, obs_len, n) = (env.agents(), env.spaces().obs_len(), env.spaces().n_actions());
    let (mut obs, mut masks) = (vec![0.0; agents * obs_len], vec![0; agents * n]);
    let (mut rewards, mut actions) = (vec![0.0; agents], vec![0; agents]);
    let mut rng = SeededRng::new(seed);
    let mut episode_seed = seed;
    env.reset(episode_seed, &mut obs, &mut masks)?;
    let mut ended = 0;
    let started = Instant::now();
    for _ in 0..steps {
        choose(&mut rng, &masks, n, &mut actions);
        if env.step(&actions, &mut obs, &mut masks, &mut rewards).done() {
            ended += 1;
            episode_seed += 1;
            env.reset(episode_seed, &mut obs, &mut masks)?;
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    Ok(Figures {
        envs: 1,
        threads: 1,
        agents,
        steps,
        agent_steps: steps * agents as u64,
        episodes_ended: ended,
        seconds,
    })
}

/// `steps` steps of a [`VecEnv`] of `envs` environments on `threads` threads.
pub fn vector(
    config: EnvConfig,
    envs: usize,
    threads: usize,
    steps: u64,
    seed: u64,
) -> Result<Figures, EnvError> {
    let mut vec_env = VecEnv::new(config, envs, seed, threads)?;
    let (agents, n) = (vec_env.agents(), vec_env.spaces().n_actions());
    let rows = envs * agents;
    let mut buffers = VecBuffers::for_vec(&vec_env);
    let mut actions = vec![0; rows];
    let mut rng = SeededRng::new(seed);
    buffers.reset(&mut vec_env)?;
    let started = Instant::now();
    for _ in 0..steps {
        choose(&mut rng, &buffers.masks, n, &mut actions);
        buffers.step(&mut vec_env, &actions)?;
    }
    let seconds = started.elapsed().as_secs_f64();
    let ended = (0..envs).map(|i| vec_env.episodes(i) - 1).sum();
    Ok(Figures {
        envs,
        threads,
        agents,
        steps,
        agent_steps: steps * rows as u64,
        episodes_ended: ended,
        seconds,
    })
}
