//! `EnvSpec`: one environment configuration (map, seats, step, limits, rewards), checked
//! once and shared by single and vector environments, with the spaces it implies.

use bw4t_agents::{Player, Strategy};
use bw4t_env::{EnvConfig, RewardMode, Rewards, STATE_SEGMENTS, Segment, Spaces, StateSpace};
use bw4t_map::{Colour, ZoneKind};
use bw4t_protocol::KINDS;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// An environment's configuration and the spaces it implies.
#[pyclass(module = "bw4t._native", frozen)]
pub(crate) struct EnvSpec {
    pub(crate) config: EnvConfig,
    pub(crate) spaces: Spaces,
    pub(crate) state: StateSpace,
}

/// A seat named as the Python side names it: `learner`, or a built-in strategy's name.
fn seat(name: &str) -> PyResult<Player> {
    if name == "learner" {
        return Ok(Player::Learner);
    }
    Strategy::named(name).map(Player::Builtin).ok_or_else(|| {
        let known: Vec<&str> = Strategy::ALL.iter().map(|s| s.name()).collect();
        PyValueError::new_err(format!(
            "unknown seat {name:?}: use \"learner\" or a built-in strategy ({})",
            known.join(", ")
        ))
    })
}

fn layout(segments: &[Segment]) -> Vec<(&'static str, usize, usize)> {
    segments.iter().map(|s| (s.name, s.offset, s.len)).collect()
}

#[pymethods]
impl EnvSpec {
    /// `map`: a shipped map's name or a map file; `seats`: one per robot in robot-id order,
    /// `"learner"` or a built-in strategy; `max_ticks`: `None` for the map's own limit
    /// (that of `bw4t run`); `reward_mode`: `"team"` or `"individual"`.
    #[new]
    #[pyo3(signature = (map, seats, ticks_per_step, max_ticks, slots, delivery, wrong_drop, step_cost, reward_mode))]
    #[allow(clippy::too_many_arguments)] // The Python constructor's keywords, one each.
    fn new(
        map: &str,
        seats: Vec<String>,
        ticks_per_step: u32,
        max_ticks: Option<u64>,
        slots: usize,
        delivery: f32,
        wrong_drop: f32,
        step_cost: f32,
        reward_mode: &str,
    ) -> PyResult<EnvSpec> {
        let map = bw4t_cli::load_map(map).map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
        let seats = seats.iter().map(|s| seat(s)).collect::<PyResult<Vec<Player>>>()?;
        if !seats.iter().any(|s| matches!(s, Player::Learner)) {
            return Err(PyValueError::new_err("at least one seat must be \"learner\""));
        }
        if seats.len() > map.spawns().len() {
            return Err(PyValueError::new_err(format!(
                "{} robots asked for, but map {:?} has {} spawn points",
                seats.len(),
                map.name(),
                map.spawns().len()
            )));
        }
        if ticks_per_step == 0 {
            return Err(PyValueError::new_err("ticks_per_step must be at least 1"));
        }
        if !(1..=64).contains(&slots) {
            return Err(PyValueError::new_err("slots must be from 1 to 64"));
        }
        let mode = match reward_mode {
            "team" => RewardMode::Team,
            "individual" => RewardMode::Individual,
            other => {
                return Err(PyValueError::new_err(format!(
                    "unknown reward_mode {other:?}: use \"team\" or \"individual\""
                )));
            }
        };
        for (name, value) in [("delivery", delivery), ("wrong_drop", wrong_drop), ("step_cost", step_cost)] {
            if !value.is_finite() {
                return Err(PyValueError::new_err(format!("{name} must be a finite number")));
            }
        }
        let mut config = EnvConfig::with_players(map, seats);
        config.ticks_per_step = ticks_per_step;
        let setup = &mut config.setup;
        setup.max_ticks = Some(match max_ticks {
            Some(0) => return Err(PyValueError::new_err("max_ticks must be at least 1")),
            Some(ticks) => ticks,
            None => bw4t_runner::TickLimit::for_map(&setup.map, &setup.game).ticks,
        });
        config.slots = slots;
        config.rewards = Rewards { delivery, wrong_drop, step_cost, mode };
        let spaces = Spaces::new(bw4t_env::Dims::of(&config.setup.map, slots));
        let state = StateSpace::new(&config.setup.map, config.setup.seats.len());
        Ok(EnvSpec { config, spaces, state })
    }

    /// Length of one observation.
    #[getter]
    fn obs_len(&self) -> usize {
        self.spaces.obs_len()
    }

    /// Number of discrete actions.
    #[getter]
    fn n_actions(&self) -> usize {
        self.spaces.n_actions()
    }

    /// Learning robots per environment.
    #[getter]
    fn agents(&self) -> usize {
        self.config.learners()
    }

    /// The tick limit (truncation).
    #[getter]
    fn max_ticks(&self) -> u64 {
        self.config.setup.max_ticks.unwrap_or(u64::MAX)
    }

    /// Ticks per step.
    #[getter]
    fn ticks_per_step(&self) -> u32 {
        self.config.ticks_per_step
    }

    /// The map's name.
    #[getter]
    fn map_name(&self) -> String {
        self.config.setup.map.name().to_string()
    }

    /// The observation's segments: `(name, offset, length)`.
    #[getter]
    fn obs_layout(&self) -> Vec<(&'static str, usize, usize)> {
        layout(self.spaces.obs_layout())
    }

    /// Length of the global state (`state()` of the parallel environment).
    #[getter]
    fn state_len(&self) -> usize {
        self.state.len()
    }

    /// The global state's segments: `(name, offset, length)`.
    #[getter]
    fn state_layout(&self) -> Vec<(&'static str, usize, usize)> {
        layout(self.state.layout())
    }

    /// The global state's segments whose values are counts (unbounded above).
    #[getter]
    fn state_count_segments(&self) -> Vec<&'static str> {
        STATE_SEGMENTS.iter().filter(|r| r.counts).map(|r| r.name).collect()
    }

    /// The action space's segments: `(name, first action, count)`.
    #[getter]
    fn action_layout(&self) -> Vec<(&'static str, usize, usize)> {
        layout(self.spaces.action_layout())
    }

    /// Every place (zone) of the map, in map order (`P`).
    #[getter]
    fn places(&self) -> Vec<String> {
        self.config.setup.map.zones().iter().map(|z| z.name.to_string()).collect()
    }

    /// The rooms, the drop zone included, in map order (`R`).
    #[getter]
    fn rooms(&self) -> Vec<String> {
        let rooms = self.config.setup.map.zones().iter().filter(|z| z.kind == ZoneKind::Room);
        rooms.map(|z| z.name.to_string()).collect()
    }

    /// The block colours in the observation's order (`C`).
    #[getter]
    fn colours(&self) -> Vec<&'static str> {
        Colour::ALL.iter().map(|c| c.name()).collect()
    }

    /// The message language's kinds in the observation's order (`M`).
    #[getter]
    fn message_kinds(&self) -> Vec<&'static str> {
        KINDS.iter().map(|k| k.word).collect()
    }
}
