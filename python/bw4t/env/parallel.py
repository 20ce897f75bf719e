"""A PettingZoo ``ParallelEnv``: one agent per learning robot, all acting every step."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any, Dict, Optional, Tuple

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from .. import _native
from .. import _check, _spec
from ._copying import Replayable
from ._render import MatchViews, Renderer


class Bw4tParallelEnv(Replayable, MatchViews, ParallelEnv):
    """A PettingZoo ``ParallelEnv`` of ``robots`` learning robots (and ``teammates``
    built-in robots of ``strategy``) on ``map`` (a shipped map's name or a map file).
    ``symbolic=True`` adds each agent's percepts (in the protocol's own form), its new
    percepts and its last action's outcome to ``infos``. ``render_mode``: ``"rgb_array"``
    or ``"svg"``. The other arguments are described in :mod:`bw4t.env`.

    ``state()`` is the global state for centralised critics (``state_space``). ``pickle``
    and ``copy.deepcopy`` give an environment where this one is: same configuration,
    episode (played again from its seed and actions) and seed generator."""

    metadata = {"name": "bw4t_v0", "render_modes": ["rgb_array", "svg"], "is_parallelizable": True, "render_fps": 2}

    def __init__(
        self,
        map: str = "default",
        robots: int = 3,
        teammates: int = 0,
        strategy: str = "coop",
        ticks_per_step: int = 10,
        max_ticks: Optional[int] = None,
        slots: int = 10,
        rewards: Optional[_spec.Rewards] = None,
        render_mode: Optional[str] = None,
        symbolic: bool = False,
    ) -> None:
        self._args = dict(
            map=map,
            robots=robots,
            teammates=teammates,
            strategy=strategy,
            ticks_per_step=ticks_per_step,
            max_ticks=max_ticks,
            slots=slots,
            rewards=rewards,
            render_mode=render_mode,
            symbolic=symbolic,
        )
        self.spec_native = _spec.make_spec(
            map, _spec.seats(robots, teammates, strategy), ticks_per_step, max_ticks, slots, rewards
        )
        self._renderer = Renderer(render_mode, self.metadata["render_modes"])
        self._env = _native.Env(self.spec_native)
        self.possible_agents = list(self._env.agent_names())
        self._index = {name: i for i, name in enumerate(self.possible_agents)}
        self.agents: list = []
        # One space object each, shared by every agent; nothing outside this env holds it.
        self._obs_space = _spec.observation_space(self.spec_native)
        self._action_space = _spec.action_space(self.spec_native)
        self.state_space = _spec.state_space(self.spec_native)
        self.render_mode = render_mode
        self.symbolic = bool(symbolic)
        n = len(self.possible_agents)
        self._actions = np.zeros(n, dtype=np.uint32)
        self._rewards = np.zeros(n, dtype=np.float32)
        self._seeds: Optional[np.random.Generator] = None

    def observation_space(self, agent: str) -> spaces.Space:
        self._agent_index("agent", agent)
        return self._obs_space

    def action_space(self, agent: str) -> spaces.Space:
        self._agent_index("agent", agent)
        return self._action_space

    def state(self) -> np.ndarray:
        """The global state now (float32, ``state_space``): every robot's position, room,
        move state and held colour, the blocks lying in each room per colour, the goal
        sequence and progress, and the time (``spec_native.state_layout``)."""
        out = np.empty(self.spec_native.state_len, dtype=np.float32)
        self._env.state(out)
        return out

    def _agent_index(self, what: str, agent: Any) -> int:
        index = self._index.get(agent) if isinstance(agent, str) else None
        if index is None:
            raise ValueError(f"unknown agent {agent!r} in {what}: the agents are {', '.join(self.possible_agents)}")
        return index

    def _own_state(self) -> Dict[str, Any]:
        return {"agents": list(self.agents), "seeds": self._seeds}

    def _restore_own_state(self, state: Dict[str, Any]) -> None:
        self.agents = list(state["agents"])
        self._seeds = state["seeds"]

    # ------------------------------------------------------------------ episodes

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None) -> Tuple[Dict, Dict]:
        """A new episode. ``reset(seed=s)`` plays match seed ``s`` (the same blocks and
        sequence as ``bw4t run --seed s``); a later ``reset()`` plays the next seed of a
        generator seeded with ``s`` (or with fresh entropy if never seeded). ``s`` is an
        integer from 0 to 2**64 - 1; ``options`` (a dict) are accepted and ignored,
        as PettingZoo's own API test passes some."""
        _check.options(options)
        if seed is not None:
            match_seed = _check.seed(seed)
            self._seeds = np.random.default_rng(match_seed)
        else:
            if self._seeds is None:
                self._seeds = np.random.default_rng()
            match_seed = _spec.match_seed(self._seeds)
        n = len(self.possible_agents)
        obs = np.empty((n, self.spec_native.obs_len), dtype=np.float32)
        masks = np.empty((n, self.spec_native.n_actions), dtype=np.int8)
        self._env.reset(match_seed, obs, masks.view(np.uint8))
        self.agents = list(self.possible_agents)
        return self._observations(obs, masks), self._infos()

    def step(self, actions: Dict[str, Any]) -> Tuple[Dict, Dict, Dict, Dict, Dict]:
        """Every live agent's action, an integer from 0 to ``n_actions - 1`` (an agent left
        out waits). An unknown agent name or a malformed action raises ``ValueError`` (or
        ``TypeError`` for a value that is not an integer) before anything is played."""
        if not self.agents:
            raise RuntimeError("the episode is over: call reset() first")
        if not isinstance(actions, Mapping):
            raise TypeError(f"actions must be a dict of agent name to action, not {type(actions).__name__}")
        acts = np.zeros_like(self._actions)
        n_actions = self.spec_native.n_actions
        for name, action in actions.items():
            acts[self._agent_index("actions", name)] = _check.action(f"actions[{name!r}]", action, n_actions)
        self._actions[:] = acts
        acts = self._actions
        n = len(self.possible_agents)
        obs = np.empty((n, self.spec_native.obs_len), dtype=np.float32)
        masks = np.empty((n, self.spec_native.n_actions), dtype=np.int8)
        terminated, truncated = self._env.step(acts, obs, masks.view(np.uint8), self._rewards)
        names = self.possible_agents
        rewards = {name: float(r) for name, r in zip(names, self._rewards)}
        terminations = {name: terminated for name in names}
        truncations = {name: truncated for name in names}
        observations = self._observations(obs, masks)
        infos = self._infos()
        if terminated or truncated:
            self.agents = []
        return observations, rewards, terminations, truncations, infos

    def _observations(self, obs: np.ndarray, masks: np.ndarray) -> Dict[str, Dict[str, np.ndarray]]:
        return {
            name: {"observation": obs[i], "action_mask": masks[i]} for i, name in enumerate(self.possible_agents)
        }

    def _infos(self) -> Dict[str, Dict[str, Any]]:
        if not self.symbolic:
            return {name: {} for name in self.possible_agents}
        return _symbolic_infos(self._env, self.possible_agents)

    def describe(self, agent: str, action: int) -> Optional[list]:
        """Action ``action`` of ``agent`` as the protocol's ``[name, args]``, or ``None``
        (wait, or not allowed now)."""
        index = self._agent_index("describe", agent)
        text = self._env.describe(index, _check.action("action", action, self.spec_native.n_actions))
        return None if text is None else json.loads(text)

    def close(self) -> None:
        pass


def _symbolic_infos(env: "_native.Env", names: list) -> Dict[str, Dict[str, Any]]:
    """Each learner's percepts in the protocol's own form, and its last action's outcome."""
    outcomes = env.outcomes()
    infos = {}
    for i, name in enumerate(names):
        delta = env.delta_json(i)
        infos[name] = {
            "percepts": json.loads(env.percepts_json(i)),
            "delta": None if delta is None else json.loads(delta),
            "outcome": outcomes[i],
        }
    return infos
