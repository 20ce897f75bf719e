//! `Env`: one match as an environment, stepped by action indices into caller-allocated
//! arrays, or by the match's own actions (the in-process match); with its percepts,
//! statistics, digest and drawings.

use bw4t_env::ActionOutcome;
use bw4t_protocol::{action_from_act, action_to_act, percept_to_fact};
use bw4t_sim::{Action, PerceptDelta};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyReadwriteArrayDyn};
use pyo3::exceptions::{PyIndexError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::{Value, json};
use std::sync::{Mutex, MutexGuard};

use crate::arrays::{readable, writable};
use crate::locked;
use crate::spec::EnvSpec;

/// One environment (see `bw4t.env` for the spaces and the step).
#[pyclass(module = "bw4t._native")]
pub(crate) struct Env {
    /// Used by one call at a time (see [`locked`]).
    env: Mutex<bw4t_env::Env>,
}

fn env_error(e: bw4t_env::EnvError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn outcome_name(outcome: ActionOutcome) -> String {
    match outcome {
        ActionOutcome::Waited => "waited".into(),
        ActionOutcome::Masked => "masked".into(),
        ActionOutcome::Accepted => "accepted".into(),
        ActionOutcome::Rejected(code) => format!("rejected:{code}"),
        ActionOutcome::Dropped => "dropped".into(),
    }
}

/// A percept delta as the protocol's `percepts` message carries it.
fn delta_json(delta: &PerceptDelta) -> Value {
    let facts =
        |ps: &[bw4t_sim::Percept]| ps.iter().map(|p| Value::from(percept_to_fact(p))).collect::<Vec<_>>();
    json!({"tick": delta.tick, "full": delta.full, "add": facts(&delta.add), "not": facts(&delta.not)})
}

impl Env {
    fn env(&self) -> PyResult<MutexGuard<'_, bw4t_env::Env>> {
        locked(&self.env, "environment")
    }
}

fn check_agent(env: &bw4t_env::Env, agent: usize) -> PyResult<usize> {
    if agent < env.agents() {
        Ok(agent)
    } else {
        Err(PyIndexError::new_err(format!("agent {agent} out of range (0..{})", env.agents())))
    }
}

fn shapes(env: &bw4t_env::Env) -> (usize, usize, usize) {
    let spaces = env.spaces();
    (env.agents(), spaces.obs_len(), spaces.n_actions())
}

#[pymethods]
impl Env {
    #[new]
    fn new(spec: &EnvSpec) -> PyResult<Env> {
        Ok(Env { env: Mutex::new(bw4t_env::Env::new(spec.config.clone()).map_err(env_error)?) })
    }

    /// A new episode on `seed`, written into `obs` (`agents × obs_len`, float32) and `masks`
    /// (`agents × n_actions`, uint8).
    fn reset(
        &self,
        py: Python<'_>,
        seed: u64,
        mut obs: PyReadwriteArrayDyn<'_, f32>,
        mut masks: PyReadwriteArrayDyn<'_, u8>,
    ) -> PyResult<()> {
        let mut env = self.env()?;
        let (a, o, n) = shapes(&env);
        let obs = writable(&mut obs, "obs", a * o, "agents x obs_len")?;
        let masks = writable(&mut masks, "masks", a * n, "agents x n_actions")?;
        let env = &mut *env;
        py.detach(|| env.reset(seed, obs, masks)).map_err(env_error)
    }

    /// One step with an action index per learner (uint32); writes `obs`, `masks` and
    /// `rewards` (float32, one per learner). Returns `(terminated, truncated)`.
    fn step(
        &self,
        py: Python<'_>,
        actions: PyReadonlyArrayDyn<'_, u32>,
        mut obs: PyReadwriteArrayDyn<'_, f32>,
        mut masks: PyReadwriteArrayDyn<'_, u8>,
        mut rewards: PyReadwriteArrayDyn<'_, f32>,
    ) -> PyResult<(bool, bool)> {
        let mut env = self.env()?;
        let (a, o, n) = shapes(&env);
        let actions = readable(&actions, "actions", a, "one per learner")?;
        let obs = writable(&mut obs, "obs", a * o, "agents x obs_len")?;
        let masks = writable(&mut masks, "masks", a * n, "agents x n_actions")?;
        let rewards = writable(&mut rewards, "rewards", a, "one per learner")?;
        let env = &mut *env;
        let end = py.detach(|| env.step(actions, obs, masks, rewards));
        Ok((end.terminated, end.truncated))
    }

    /// One step with each learner's action as the protocol names it (`None`: wait), as
    /// `(name, args)`: `("goTo", ["RoomA1"])`, `("pickUp", [])`. Returns
    /// `(rewards, terminated, truncated)`.
    fn step_acts(
        &self,
        py: Python<'_>,
        acts: Vec<Option<(String, Vec<Bound<'_, PyAny>>)>>,
    ) -> PyResult<(Vec<f32>, bool, bool)> {
        let mut env = self.env()?;
        let agents = env.agents();
        if acts.len() != agents {
            return Err(PyValueError::new_err(format!("{} actions given for {agents} learners", acts.len())));
        }
        let json = py.import("json")?;
        let mut actions: Vec<Option<Action>> = Vec::with_capacity(agents);
        for (agent, act) in acts.into_iter().enumerate() {
            let Some((name, args)) = act else {
                actions.push(None);
                continue;
            };
            let mut values = Vec::with_capacity(args.len());
            for arg in args {
                let text: String = json.call_method1("dumps", (arg,))?.extract()?;
                values.push(serde_json::from_str(&text).map_err(|e| PyValueError::new_err(e.to_string()))?);
            }
            let action = action_from_act(&name, &values)
                .map_err(|e| PyValueError::new_err(format!("agent {agent}: {name}: {e}")))?;
            actions.push(Some(action));
        }
        let mut rewards = vec![0.0; agents];
        let env = &mut *env;
        let end = py.detach(|| env.step_actions(actions, &mut rewards));
        Ok((rewards, end.terminated, end.truncated))
    }

    /// Writes the global state now (the whole world: every robot, every block, the goal)
    /// into `out` (float32, `state_len` values).
    fn state(&self, mut out: PyReadwriteArrayDyn<'_, f32>) -> PyResult<()> {
        let env = self.env()?;
        let out = writable(&mut out, "out", env.state_space().len(), "state_len")?;
        env.write_state(out);
        Ok(())
    }

    /// The seed this episode was reset on and every step's action indices since (uint32,
    /// learner after learner), or `None` after a step took the match's own actions.
    fn episode<'py>(&self, py: Python<'py>) -> PyResult<Option<(u64, Bound<'py, PyArray1<u32>>)>> {
        let env = self.env()?;
        Ok(env.episode().map(|(seed, played)| (seed, PyArray1::from_slice(py, played))))
    }

    /// Resets on `seed` and plays `played` (as `episode()` gives them) again, writing the
    /// last observations and masks: the same episode, bit for bit.
    fn replay(
        &self,
        py: Python<'_>,
        seed: u64,
        played: PyReadonlyArrayDyn<'_, u32>,
        mut obs: PyReadwriteArrayDyn<'_, f32>,
        mut masks: PyReadwriteArrayDyn<'_, u8>,
    ) -> PyResult<()> {
        let mut env = self.env()?;
        let (a, o, n) = shapes(&env);
        let played = played.as_slice().map_err(|e| PyValueError::new_err(format!("played: {e}")))?;
        let obs = writable(&mut obs, "obs", a * o, "agents x obs_len")?;
        let masks = writable(&mut masks, "masks", a * n, "agents x n_actions")?;
        let env = &mut *env;
        py.detach(|| env.replay(seed, played, obs, masks)).map_err(env_error)
    }

    /// The learners' names (`Agent1`, ...).
    fn agent_names(&self) -> PyResult<Vec<String>> {
        Ok(self.env()?.agent_names().map(str::to_string).collect())
    }

    /// Learner `agent`'s new percepts since the step before, as JSON text of the
    /// protocol's `percepts` message body (`tick`, `full`, `add`, `not`), or `None`.
    fn delta_json(&self, agent: usize) -> PyResult<Option<String>> {
        let env = self.env()?;
        let agent = check_agent(&env, agent)?;
        Ok(env.delta(agent).map(|d| delta_json(d).to_string()))
    }

    /// Every fact learner `agent` perceives now, as JSON text (a list of facts).
    fn percepts_json(&self, agent: usize) -> PyResult<String> {
        let env = self.env()?;
        let agent = check_agent(&env, agent)?;
        let facts: Vec<Value> =
            env.percepts(agent).unwrap_or_default().iter().map(|p| Value::from(percept_to_fact(p))).collect();
        Ok(Value::from(facts).to_string())
    }

    /// What became of each learner's last action: `waited`, `masked`, `accepted`,
    /// `rejected:CODE` or `dropped` (the episode ended first).
    fn outcomes(&self) -> PyResult<Vec<String>> {
        Ok(self.env()?.outcomes().map(outcome_name).collect())
    }

    /// Action index `action` of learner `agent` as the protocol's `[name, args]` JSON
    /// text, or `None` (wait, masked out, out of range).
    fn describe(&self, agent: usize, action: u32) -> PyResult<Option<String>> {
        let env = self.env()?;
        let agent = check_agent(&env, agent)?;
        Ok(env.decode(agent, action).map(|a| {
            let (name, args) = action_to_act(&a);
            json!([name, args]).to_string()
        }))
    }

    /// The match's digest: equal digests, equal matches.
    fn digest(&self) -> PyResult<u64> {
        Ok(self.env()?.digest())
    }

    /// Ticks simulated in this episode.
    fn tick(&self) -> PyResult<u64> {
        Ok(self.env()?.tick())
    }

    /// The match's statistics and each robot's, as a dict.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let env = self.env()?;
        let game = env.game();
        let s = game.stats();
        let d = PyDict::new(py);
        d.set_item("ticks", s.ticks)?;
        d.set_item("completed_at", s.completed_at)?;
        d.set_item("sequence_index", s.sequence_index)?;
        d.set_item("sequence_length", game.sequence().len())?;
        d.set_item("good_drops", s.good_drops)?;
        d.set_item("wrong_drops", s.wrong_drops)?;
        d.set_item("messages", s.messages)?;
        let robots = PyDict::new(py);
        for (_, name, r, _) in game.all_robot_stats() {
            let row = PyDict::new(py);
            row.set_item("good_drops", r.good_drops)?;
            row.set_item("wrong_drops", r.wrong_drops)?;
            row.set_item("messages_sent", r.messages_sent)?;
            row.set_item("idle_ticks", r.idle_ticks)?;
            row.set_item("rooms_entered", r.rooms_entered)?;
            row.set_item("distance", r.distance)?;
            robots.set_item(name, row)?;
        }
        d.set_item("robots", robots)?;
        Ok(d)
    }

    /// The match now as an SVG document.
    fn render_svg(&self) -> PyResult<String> {
        Ok(self.env()?.render_svg())
    }

    /// The match now as an RGB image (`height × width × 3`, uint8), `scale` pixels per map
    /// unit.
    fn render_rgb<'py>(&self, py: Python<'py>, scale: f32) -> PyResult<Bound<'py, numpy::PyArray3<u8>>> {
        let image = self.env()?.render_rgb(scale);
        PyArray1::from_vec(py, image.pixels).reshape([image.height, image.width, 3])
    }
}
