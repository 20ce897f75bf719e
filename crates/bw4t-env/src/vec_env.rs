//! Many environments stepped together into caller-provided arrays, on one or more
//! threads, each reset on the next seed of its own stream when its episode ends.

use std::sync::Arc;

use bw4t_map::SeededRng;

use crate::config::EnvConfig;
use crate::encode::Codec;
use crate::env::{Env, EnvError};
use crate::spaces::Spaces;

/// The seeds one environment of a [`VecEnv`] plays, episode after episode: SplitMix64
/// from `base` mixed with the environment's index, so they do not depend on the order in
/// which other environments end, nor on the number of threads.
#[derive(Clone, Debug)]
pub struct SeedStream {
    rng: SeededRng,
    /// The generator's seed and how many seeds were drawn: the stream's whole state.
    origin: u64,
    drawn: u64,
}

impl SeedStream {
    /// The stream of environment `index` of a vector seeded with `base`.
    pub fn new(base: u64, index: usize) -> SeedStream {
        let mut mix = SeededRng::new(base ^ (index as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
        SeedStream::resumed(mix.next_u64(), 0)
    }

    /// The stream whose generator was seeded with `origin` after `drawn` seeds (see
    /// [`SeedStream::position`]).
    pub fn resumed(origin: u64, drawn: u64) -> SeedStream {
        let mut rng = SeededRng::new(origin);
        for _ in 0..drawn {
            rng.next_u64();
        }
        SeedStream { rng, origin, drawn }
    }

    /// Where the stream is: its generator's seed and the seeds drawn so far.
    pub fn position(&self) -> (u64, u64) {
        (self.origin, self.drawn)
    }

    /// The next episode's seed.
    pub fn next_seed(&mut self) -> u64 {
        self.drawn += 1;
        self.rng.next_u64()
    }
}

/// How an environment's last episode ended, kept when it is reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EpisodeEnd {
    /// Ticks the episode ran.
    pub ticks: u64,
    /// The sequence index it reached (colours delivered in order).
    pub sequence_index: u32,
    /// The match's digest at its end.
    pub digest: u64,
}

impl EpisodeEnd {
    fn of(env: &Env) -> EpisodeEnd {
        EpisodeEnd { ticks: env.tick(), sequence_index: env.game().sequence_index(), digest: env.digest() }
    }
}

/// One environment of a vector where it stands: what [`VecEnv::snapshot`] gives and
/// [`VecEnv::restore`] takes back.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SlotState {
    /// Its seed stream's position ([`SeedStream::position`]).
    pub stream: (u64, u64),
    /// Episodes begun.
    pub episodes: u64,
    /// The episode's seed ([`Env::episode`]).
    pub seed: u64,
    /// The episode's action indices so far.
    pub played: Vec<u32>,
}

struct Slot {
    env: Env,
    seeds: SeedStream,
    episodes: u64,
    last: Option<EpisodeEnd>,
}

impl Slot {
    fn start(&mut self, seed: u64, obs: &mut [f32], masks: &mut [u8]) -> Result<(), EnvError> {
        self.episodes += 1;
        self.env.reset(seed, obs, masks)
    }
}

/// `N` environments of one config, stepped together. Arrays are laid out environment
/// after environment, learner after learner: `obs[(e * agents + a) * obs_len ..]`.
///
/// Auto-reset is *same-step*: when a step ends environment `e`'s episode, its rewards,
/// `terminated` and `truncated` are those of the final step, and the observation and mask
/// written are those of the new episode, reset on the next seed of its [`SeedStream`].
/// The final observation is written to [`StepBuffers::final_obs`] when the caller gives one.
pub struct VecEnv {
    slots: Vec<Slot>,
    codec: Arc<Codec>,
    threads: usize,
    agents: usize,
    obs_len: usize,
    n_actions: usize,
}

/// The arrays one step writes, each of `N × agents` rows.
pub struct StepBuffers<'a> {
    /// `N × agents × obs_len`.
    pub obs: &'a mut [f32],
    /// `N × agents × n_actions`.
    pub masks: &'a mut [u8],
    /// `N × agents`.
    pub rewards: &'a mut [f32],
    /// `N × agents`: true when the environment's episode ended by completing the sequence.
    pub terminated: &'a mut [bool],
    /// `N × agents`: true when it ended at the tick limit.
    pub truncated: &'a mut [bool],
    /// `N × agents × obs_len`, optional: for each environment whose episode ended, the last
    /// observation of that episode (the rows of the others are left as they were).
    pub final_obs: Option<&'a mut [f32]>,
}

/// The arrays of a vector's steps, owned and sized for it: for callers in Rust (bindings
/// pass arrays of their own as [`StepBuffers`]).
pub struct VecBuffers {
    /// `N × agents × obs_len`.
    pub obs: Vec<f32>,
    /// `N × agents × n_actions`.
    pub masks: Vec<u8>,
    /// `N × agents`.
    pub rewards: Vec<f32>,
    /// `N × agents`.
    pub terminated: Vec<bool>,
    /// `N × agents`.
    pub truncated: Vec<bool>,
}

impl VecBuffers {
    /// Zeroed buffers for `vec_env`.
    pub fn for_vec(vec_env: &VecEnv) -> VecBuffers {
        let rows = vec_env.len() * vec_env.agents();
        let spaces = vec_env.spaces();
        VecBuffers {
            obs: vec![0.0; rows * spaces.obs_len()],
            masks: vec![0; rows * spaces.n_actions()],
            rewards: vec![0.0; rows],
            terminated: vec![false; rows],
            truncated: vec![false; rows],
        }
    }

    /// Resets `vec_env` into these buffers.
    pub fn reset(&mut self, vec_env: &mut VecEnv) -> Result<(), EnvError> {
        vec_env.reset(&mut self.obs, &mut self.masks)
    }

    /// Steps `vec_env` with `actions` into these buffers.
    pub fn step(&mut self, vec_env: &mut VecEnv, actions: &[u32]) -> Result<(), EnvError> {
        let out = StepBuffers {
            obs: &mut self.obs,
            masks: &mut self.masks,
            rewards: &mut self.rewards,
            terminated: &mut self.terminated,
            truncated: &mut self.truncated,
            final_obs: None,
        };
        vec_env.step(actions, out)
    }
}

impl VecEnv {
    /// `n` environments of `config`, seeded from `seed`, stepped on `threads` threads (the
    /// caller's own and `threads - 1` more, per step). Not reset yet: call
    /// [`VecEnv::reset`] first.
    pub fn new(config: EnvConfig, n: usize, seed: u64, threads: usize) -> Result<VecEnv, EnvError> {
        let first = Env::new(config)?;
        let (config, codec, state) =
            (first.config().clone(), first.codec().clone(), first.state_space().clone());
        let agents = first.agents();
        let mut envs = vec![first];
        for _ in 1..n {
            envs.push(Env::shared(Arc::clone(&config), Arc::clone(&codec), Arc::clone(&state))?);
        }
        let (obs_len, n_actions) = (codec.spaces().obs_len(), codec.spaces().n_actions());
        let slots = envs
            .into_iter()
            .enumerate()
            .map(|(i, env)| Slot { env, seeds: SeedStream::new(seed, i), episodes: 0, last: None })
            .take(n)
            .collect();
        Ok(VecEnv { slots, codec, threads: threads.max(1), agents, obs_len, n_actions })
    }

    /// The number of environments.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Learners per environment.
    pub fn agents(&self) -> usize {
        self.agents
    }

    /// The spaces (the same for every environment).
    pub fn spaces(&self) -> &Spaces {
        self.codec.spaces()
    }

    /// Environment `i`.
    pub fn env(&self, i: usize) -> &Env {
        &self.slots[i].env
    }

    /// Episodes environment `i` has begun (resets, the first included).
    pub fn episodes(&self, i: usize) -> u64 {
        self.slots[i].episodes
    }

    /// Resets every environment on the next seed of its stream.
    pub fn reset(&mut self, obs: &mut [f32], masks: &mut [u8]) -> Result<(), EnvError> {
        let (o, m) = (self.agents * self.obs_len, self.agents * self.n_actions);
        assert_eq!(obs.len(), self.slots.len() * o, "obs is N x agents x obs_len");
        assert_eq!(masks.len(), self.slots.len() * m, "masks is N x agents x n_actions");
        for ((slot, obs), masks) in self.slots.iter_mut().zip(obs.chunks_mut(o)).zip(masks.chunks_mut(m)) {
            let seed = slot.seeds.next_seed();
            slot.start(seed, obs, masks)?;
        }
        Ok(())
    }

    /// Resets the environments `which` marks (one flag each), leaving the others' rows of
    /// `obs` and `masks` as they are. `seeds` (one per environment, or empty): `Some(s)`
    /// plays match seed `s` now and seeds the environment's stream with `s` for its later
    /// episodes; `None` takes the stream's next seed.
    pub fn reset_some(
        &mut self,
        which: &[bool],
        seeds: &[Option<u64>],
        obs: &mut [f32],
        masks: &mut [u8],
    ) -> Result<(), EnvError> {
        let (o, m) = (self.agents * self.obs_len, self.agents * self.n_actions);
        assert_eq!(which.len(), self.slots.len(), "one flag per environment");
        assert!(seeds.is_empty() || seeds.len() == self.slots.len(), "one seed per environment, or none");
        assert_eq!(obs.len(), self.slots.len() * o, "obs is N x agents x obs_len");
        assert_eq!(masks.len(), self.slots.len() * m, "masks is N x agents x n_actions");
        let rows = self.slots.iter_mut().zip(obs.chunks_mut(o)).zip(masks.chunks_mut(m)).enumerate();
        for (i, ((slot, obs), masks)) in rows {
            if !which[i] {
                continue;
            }
            let seed = match seeds.get(i).copied().flatten() {
                Some(seed) => {
                    slot.seeds = SeedStream::resumed(seed, 0);
                    seed
                }
                None => slot.seeds.next_seed(),
            };
            slot.start(seed, obs, masks)?;
        }
        Ok(())
    }

    /// How environment `i`'s last ended episode ended (`None` before any ended).
    pub fn last_episode(&self, i: usize) -> Option<EpisodeEnd> {
        self.slots[i].last
    }

    /// Environment `i` where it stands (`None` when one of its steps took the match's
    /// own actions, which a vector never does).
    pub fn snapshot(&self, i: usize) -> Option<SlotState> {
        let slot = &self.slots[i];
        let (seed, played) = slot.env.episode()?;
        Some(SlotState {
            stream: slot.seeds.position(),
            episodes: slot.episodes,
            seed,
            played: played.to_vec(),
        })
    }

    /// Puts environment `i` where `state` says, playing its episode again; writes its rows
    /// of `obs` and `masks` (those of the whole vector).
    pub fn restore(
        &mut self,
        i: usize,
        state: &SlotState,
        obs: &mut [f32],
        masks: &mut [u8],
    ) -> Result<(), EnvError> {
        let (o, m) = (self.agents * self.obs_len, self.agents * self.n_actions);
        let slot = &mut self.slots[i];
        slot.env.replay(
            state.seed,
            &state.played,
            &mut obs[i * o..(i + 1) * o],
            &mut masks[i * m..(i + 1) * m],
        )?;
        slot.seeds = SeedStream::resumed(state.stream.0, state.stream.1);
        slot.episodes = state.episodes;
        slot.last = None;
        Ok(())
    }

    /// Steps every environment with its learners' actions (`N × agents`), resetting those
    /// whose episode ended (same-step, see [`VecEnv`]).
    pub fn step(&mut self, actions: &[u32], out: StepBuffers<'_>) -> Result<(), EnvError> {
        let (n, a) = (self.slots.len(), self.agents);
        assert_eq!(actions.len(), n * a, "actions is N x agents");
        assert_eq!(out.obs.len(), n * a * self.obs_len, "obs is N x agents x obs_len");
        assert_eq!(out.masks.len(), n * a * self.n_actions, "masks is N x agents x n_actions");
        assert_eq!(out.rewards.len(), n * a, "rewards is N x agents");
        assert_eq!(out.terminated.len(), n * a, "terminated is N x agents");
        assert_eq!(out.truncated.len(), n * a, "truncated is N x agents");
        if let Some(finals) = &out.final_obs {
            assert_eq!(finals.len(), out.obs.len(), "final_obs is N x agents x obs_len");
        }
        if n == 0 {
            return Ok(());
        }
        let per = n.div_ceil(self.threads.min(n));
        let (o, m) = (a * self.obs_len, a * self.n_actions);
        let mut finals = out.final_obs.map(|f| f.chunks_mut(per * o));
        let chunks = self
            .slots
            .chunks_mut(per)
            .zip(actions.chunks(per * a))
            .zip(out.obs.chunks_mut(per * o))
            .zip(out.masks.chunks_mut(per * m))
            .zip(out.rewards.chunks_mut(per * a))
            .zip(out.terminated.chunks_mut(per * a))
            .zip(out.truncated.chunks_mut(per * a))
            .map(|((((((slots, actions), obs), masks), rewards), terminated), truncated)| Chunk {
                slots,
                actions,
                out: StepBuffers {
                    obs,
                    masks,
                    rewards,
                    terminated,
                    truncated,
                    final_obs: finals.as_mut().and_then(Iterator::next),
                },
            });
        let mut chunks: Vec<Chunk<'_>> = chunks.collect();
        let own = chunks.remove(0);
        std::thread::scope(|scope| {
            let others: Vec<_> = chunks.into_iter().map(|chunk| scope.spawn(move || chunk.step(a))).collect();
            let mut result = own.step(a);
            for handle in others {
                let theirs = handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic));
                result = result.and(theirs);
            }
            result
        })
    }
}

/// The environments one thread steps, and their part of the arrays.
struct Chunk<'a> {
    slots: &'a mut [Slot],
    actions: &'a [u32],
    out: StepBuffers<'a>,
}

impl Chunk<'_> {
    fn step(self, agents: usize) -> Result<(), EnvError> {
        let Chunk { slots, actions, out } = self;
        let o = out.obs.len() / slots.len();
        let mut finals = out.final_obs.map(|f| f.chunks_mut(o));
        let m = out.masks.len() / slots.len();
        let rows = slots
            .iter_mut()
            .zip(actions.chunks(agents))
            .zip(out.obs.chunks_mut(o))
            .zip(out.masks.chunks_mut(m))
            .zip(out.rewards.chunks_mut(agents))
            .zip(out.terminated.chunks_mut(agents))
            .zip(out.truncated.chunks_mut(agents));
        for ((((((slot, actions), obs), masks), rewards), terminated), truncated) in rows {
            let end = slot.env.step(actions, obs, masks, rewards);
            terminated.fill(end.terminated);
            truncated.fill(end.truncated);
            let last = finals.as_mut().and_then(Iterator::next);
            if end.done() {
                if let Some(last) = last {
                    last.copy_from_slice(obs);
                }
                slot.last = Some(EpisodeEnd::of(&slot.env));
                let seed = slot.seeds.next_seed();
                slot.start(seed, obs, masks)?;
            }
        }
        Ok(())
    }
}
