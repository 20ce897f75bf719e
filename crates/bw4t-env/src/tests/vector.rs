//! A vector of environments equals as many single environments stepped alike, auto-reset
//! (and the final observations it keeps) included, whatever the number of threads.

use bw4t_agents::Strategy;
use bw4t_map::SeededRng;

use super::{Buffers, default_map};
use crate::bench::choose;
use crate::{Env, EnvConfig, SeedStream, StepBuffers, VecBuffers, VecEnv};

fn check_vector_equals_singles(config: EnvConfig, n: usize, threads: usize, steps: usize) {
    let seed = 42;
    let mut vec_env = VecEnv::new(config.clone(), n, seed, threads).expect("vec env");
    let (a, obs_len, n_actions) =
        (vec_env.agents(), vec_env.spaces().obs_len(), vec_env.spaces().n_actions());
    let mut actions = vec![0; n * a];
    let mut out = VecBuffers::for_vec(&vec_env);
    out.reset(&mut vec_env).expect("reset");
    let mut final_obs = vec![f32::NAN; out.obs.len()];

    let mut singles: Vec<(Env, Buffers, SeedStream)> = (0..n)
        .map(|i| {
            let mut env = Env::new(config.clone()).expect("env");
            let mut b = Buffers::for_env(&env);
            let mut seeds = SeedStream::new(seed, i);
            b.reset(&mut env, seeds.next_seed());
            (env, b, seeds)
        })
        .collect();
    let mut rng = SeededRng::new(7);
    let mut resets = 0;
    for step in 0..steps {
        for (i, (env, b, _)) in singles.iter().enumerate() {
            assert_eq!(b.obs[..], out.obs[i * a * obs_len..(i + 1) * a * obs_len], "env {i} step {step}");
            assert_eq!(
                b.masks[..],
                out.masks[i * a * n_actions..(i + 1) * a * n_actions],
                "env {i} step {step}"
            );
            assert_eq!(env.digest(), vec_env.env(i).digest(), "env {i} step {step}");
        }
        choose(&mut rng, &out.masks, n_actions, &mut actions);
        let buffers = StepBuffers {
            obs: &mut out.obs,
            masks: &mut out.masks,
            rewards: &mut out.rewards,
            terminated: &mut out.terminated,
            truncated: &mut out.truncated,
            final_obs: Some(&mut final_obs),
        };
        vec_env.step(&actions, buffers).expect("step");
        for (i, (env, b, seeds)) in singles.iter_mut().enumerate() {
            b.actions.copy_from_slice(&actions[i * a..(i + 1) * a]);
            let end = b.step(env);
            assert_eq!(b.rewards[..], out.rewards[i * a..(i + 1) * a], "env {i} step {step}");
            for agent in 0..a {
                let row = i * a + agent;
                assert_eq!((out.terminated[row], out.truncated[row]), (end.terminated, end.truncated));
            }
            if end.done() {
                let rows = i * a * obs_len..(i + 1) * a * obs_len;
                assert_eq!(b.obs[..], final_obs[rows], "env {i} step {step}: the final observation");
                resets += 1;
                b.reset(env, seeds.next_seed());
            }
        }
    }
    assert!(resets >= n, "every environment reset at least once ({resets})");
    let begun: u64 = (0..n).map(|i| vec_env.episodes(i)).sum();
    assert_eq!(begun, (n + resets) as u64);
}

#[test]
fn a_vector_equals_single_envs_with_auto_reset() {
    let mut config = EnvConfig::parallel(default_map(), 2);
    config.setup.max_ticks = Some(300);
    check_vector_equals_singles(config.clone(), 3, 1, 70);
    check_vector_equals_singles(config, 5, 2, 70);
}

#[test]
fn a_vector_of_one_learner_among_teammates_equals_single_envs() {
    let mut config = EnvConfig::single(default_map(), 2, Strategy::Cooperative);
    config.setup.max_ticks = Some(400);
    check_vector_equals_singles(config, 3, 2, 90);
}
