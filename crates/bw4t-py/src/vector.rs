//! `VecEnv`: N environments of one spec stepped together in Rust, on one or more threads,
//! without the interpreter, into arrays the caller allocated once; same-step auto-reset.

use bw4t_env::{SlotState, StepBuffers};
use numpy::{PyArray1, PyReadonlyArrayDyn, PyReadwriteArrayDyn};
use pyo3::exceptions::{PyIndexError, PyValueError};
use pyo3::prelude::*;

use crate::arrays::{readable, writable};
use crate::locked;
use crate::spec::EnvSpec;
use std::sync::{Mutex, MutexGuard};

/// A vector of environments. Rows are environment after environment, learner after
/// learner: row `e * agents + a`.
#[pyclass(module = "bw4t._native")]
pub(crate) struct VecEnv {
    /// Used by one call at a time (see [`locked`]).
    vec: Mutex<bw4t_env::VecEnv>,
}

fn env_error(e: bw4t_env::EnvError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

impl VecEnv {
    fn vec(&self) -> PyResult<MutexGuard<'_, bw4t_env::VecEnv>> {
        locked(&self.vec, "vector environment")
    }

    /// Environment `i` of the vector, checked.
    fn with_env<T>(&self, i: usize, f: impl FnOnce(&bw4t_env::Env) -> T) -> PyResult<T> {
        let vec = self.vec()?;
        if i < vec.len() {
            Ok(f(vec.env(i)))
        } else {
            Err(PyIndexError::new_err(format!("environment {i} out of range (0..{})", vec.len())))
        }
    }
}

/// A match's snapshot as Python gets it: `(stream_origin, stream_drawn, episodes, seed,
/// played)`.
type Snapshot<'py> = (u64, u64, u64, u64, Bound<'py, PyArray1<u32>>);

fn rows(vec: &bw4t_env::VecEnv) -> usize {
    vec.len() * vec.agents()
}

#[pymethods]
impl VecEnv {
    /// `n` environments of `spec`; environment `i` plays the seeds of its own stream from
    /// `seed` (independent of thread count and of when others end); `threads` per step.
    #[new]
    fn new(spec: &EnvSpec, n: usize, seed: u64, threads: usize) -> PyResult<VecEnv> {
        if n == 0 {
            return Err(PyValueError::new_err("a vector needs at least one environment"));
        }
        if threads == 0 {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        let vec = bw4t_env::VecEnv::new(spec.config.clone(), n, seed, threads).map_err(env_error)?;
        Ok(VecEnv { vec: Mutex::new(vec) })
    }

    /// Environments in the vector.
    fn __len__(&self) -> PyResult<usize> {
        Ok(self.vec()?.len())
    }

    /// Starts every environment's next episode, written into `obs` (`rows × obs_len`,
    /// float32) and `masks` (`rows × n_actions`, uint8).
    fn reset(
        &self,
        py: Python<'_>,
        mut obs: PyReadwriteArrayDyn<'_, f32>,
        mut masks: PyReadwriteArrayDyn<'_, u8>,
    ) -> PyResult<()> {
        let mut vec = self.vec()?;
        let spaces = vec.spaces();
        let (rows, o, n) = (rows(&vec), spaces.obs_len(), spaces.n_actions());
        let obs = writable(&mut obs, "obs", rows * o, "rows x obs_len")?;
        let masks = writable(&mut masks, "masks", rows * n, "rows x n_actions")?;
        let vec = &mut *vec;
        py.detach(|| vec.reset(obs, masks)).map_err(env_error)
    }

    /// Starts the next episode of the environments `which` marks (bool, one per
    /// environment), leaving the others' rows of `obs` and `masks` as they are. `seeds`:
    /// one per environment or empty; a seed plays that match seed now and seeds the
    /// environment's stream with it, `None` takes the stream's next seed.
    fn reset_some(
        &self,
        py: Python<'_>,
        which: PyReadonlyArrayDyn<'_, bool>,
        seeds: Vec<Option<u64>>,
        mut obs: PyReadwriteArrayDyn<'_, f32>,
        mut masks: PyReadwriteArrayDyn<'_, u8>,
    ) -> PyResult<()> {
        let mut vec = self.vec()?;
        let spaces = vec.spaces();
        let (envs, rows, o, n) = (vec.len(), rows(&vec), spaces.obs_len(), spaces.n_actions());
        let which = readable(&which, "which", envs, "one per environment")?;
        if !seeds.is_empty() && seeds.len() != envs {
            return Err(PyValueError::new_err(format!(
                "seeds holds {} values; it must hold {envs} (one per environment) or none",
                seeds.len()
            )));
        }
        let obs = writable(&mut obs, "obs", rows * o, "rows x obs_len")?;
        let masks = writable(&mut masks, "masks", rows * n, "rows x n_actions")?;
        let vec = &mut *vec;
        py.detach(|| vec.reset_some(which, &seeds, obs, masks)).map_err(env_error)
    }

    /// How environment `i`'s last ended episode ended: `(ticks, sequence_index, digest)`,
    /// or `None` before any ended.
    fn last_episode(&self, i: usize) -> PyResult<Option<(u64, u32, u64)>> {
        self.with_env(i, |_| ())?;
        Ok(self.vec()?.last_episode(i).map(|e| (e.ticks, e.sequence_index, e.digest)))
    }

    /// Environment `i` where it stands: `(stream_origin, stream_drawn, episodes, seed,
    /// played)`, which `restore` takes back.
    fn snapshot<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Snapshot<'py>> {
        self.with_env(i, |_| ())?;
        let state = self.vec()?.snapshot(i).ok_or_else(|| {
            PyValueError::new_err(format!(
                "environment {i} took the match's own actions: it cannot be replayed"
            ))
        })?;
        Ok((state.stream.0, state.stream.1, state.episodes, state.seed, PyArray1::from_vec(py, state.played)))
    }

    /// Puts environment `i` where a `snapshot` said (playing its episode again) and
    /// writes its rows of `obs` and `masks`.
    #[allow(clippy::too_many_arguments)] // A snapshot's parts and the arrays, each its own.
    fn restore(
        &self,
        py: Python<'_>,
        i: usize,
        stream: (u64, u64),
        episodes: u64,
        seed: u64,
        played: PyReadonlyArrayDyn<'_, u32>,
        mut obs: PyReadwriteArrayDyn<'_, f32>,
        mut masks: PyReadwriteArrayDyn<'_, u8>,
    ) -> PyResult<()> {
        self.with_env(i, |_| ())?;
        let mut vec = self.vec()?;
        let spaces = vec.spaces();
        let (rows, o, n) = (rows(&vec), spaces.obs_len(), spaces.n_actions());
        let played = played.as_slice().map_err(|e| PyValueError::new_err(format!("played: {e}")))?.to_vec();
        let obs = writable(&mut obs, "obs", rows * o, "rows x obs_len")?;
        let masks = writable(&mut masks, "masks", rows * n, "rows x n_actions")?;
        let state = SlotState { stream, episodes, seed, played };
        let vec = &mut *vec;
        py.detach(|| vec.restore(i, &state, obs, masks)).map_err(env_error)
    }

    /// One step of every environment: `actions` (uint32, one per row) in; observations,
    /// masks, rewards, `terminated` and `truncated` (bool, one per row) out. An ended
    /// environment is reset at once: its rows hold the new episode's observation, and
    /// `final_obs` (if given) the ended episode's last.
    #[pyo3(signature = (actions, obs, masks, rewards, terminated, truncated, final_obs=None))]
    #[allow(clippy::too_many_arguments)] // The arrays of one step, each its own.
    fn step(
        &self,
        py: Python<'_>,
        actions: PyReadonlyArrayDyn<'_, u32>,
        mut obs: PyReadwriteArrayDyn<'_, f32>,
        mut masks: PyReadwriteArrayDyn<'_, u8>,
        mut rewards: PyReadwriteArrayDyn<'_, f32>,
        mut terminated: PyReadwriteArrayDyn<'_, bool>,
        mut truncated: PyReadwriteArrayDyn<'_, bool>,
        mut final_obs: Option<PyReadwriteArrayDyn<'_, f32>>,
    ) -> PyResult<()> {
        let mut vec = self.vec()?;
        let spaces = vec.spaces();
        let (rows, o, n) = (rows(&vec), spaces.obs_len(), spaces.n_actions());
        let out = StepBuffers {
            obs: writable(&mut obs, "obs", rows * o, "rows x obs_len")?,
            masks: writable(&mut masks, "masks", rows * n, "rows x n_actions")?,
            rewards: writable(&mut rewards, "rewards", rows, "one per row")?,
            terminated: writable(&mut terminated, "terminated", rows, "one per row")?,
            truncated: writable(&mut truncated, "truncated", rows, "one per row")?,
            final_obs: match final_obs.as_mut() {
                Some(f) => Some(writable(f, "final_obs", rows * o, "rows x obs_len")?),
                None => None,
            },
        };
        let actions = readable(&actions, "actions", rows, "one per row")?;
        let vec = &mut *vec;
        py.detach(|| vec.step(actions, out)).map_err(env_error)
    }

    /// Episodes environment `i` has begun.
    fn episodes(&self, i: usize) -> PyResult<u64> {
        self.with_env(i, |_| ())?;
        Ok(self.vec()?.episodes(i))
    }

    /// Environment `i`'s match digest.
    fn digest(&self, i: usize) -> PyResult<u64> {
        self.with_env(i, bw4t_env::Env::digest)
    }

    /// Ticks environment `i`'s episode has run.
    fn tick(&self, i: usize) -> PyResult<u64> {
        self.with_env(i, bw4t_env::Env::tick)
    }

    /// Environment `i`'s match now as SVG.
    fn render_svg(&self, i: usize) -> PyResult<String> {
        self.with_env(i, bw4t_env::Env::render_svg)
    }
}
