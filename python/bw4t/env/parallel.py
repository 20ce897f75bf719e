"""A PettingZoo ``ParallelEnv``: one agent per learning robot, all acting every step."""

from __future__ import annotations

import functools
import json
from typing import Any, Dict, Optional, Tuple

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from .. import _native
from . import _spec
from ._render import MatchViews, Renderer


class Bw4tParallelEnv(MatchViews, ParallelEnv):
    """A PettingZoo ``ParallelEnv`` of ``robots`` learning robots (and ``teammates``
    built-in robots of ``strategy``) on ``map`` (a shipped map's name or a map file).
    ``symbolic=True`` adds each agent's percepts (in the protocol's own form), its new
    percepts and its last action's outcome to ``infos``. ``render_mode``: ``"rgb_array"``
    or ``"svg"``. The other arguments are described in :mod:`bw4t.env`."""

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
        self.spec_native = _spec.make_spec(
            map, _spec.seats(robots, teammates, strategy), ticks_per_step, max_ticks, slots, rewards
        )
        self._env = _native.Env(self.spec_native)
        self.possible_agents = list(self._env.agent_names())
        self.agents: list = []
        self._obs_space = _spec.observation_space(self.spec_native)
        self._action_space = _spec.action_space(self.spec_native)
        self._renderer = Renderer(render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.symbolic = symbolic
        n = len(self.possible_agents)
        self._actions = np.zeros(n, dtype=np.uint32)
        self._rewards = np.zeros(n, dtype=np.float32)
        self._seeds: Optional[np.random.Generator] = None

    @functools.lru_cache(maxsize=None)
    def observation_space(self, agent: str) -> spaces.Space:
        return self._obs_space

    @functools.lru_cache(maxsize=None)
    def action_space(self, agent: str) -> spaces.Space:
        return self._action_space

    # ------------------------------------------------------------------ episodes

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None) -> Tuple[Dict, Dict]:
        """A new episode. ``reset(seed=s)`` plays match seed ``s`` (the same blocks and
        sequence as ``bw4t run --seed s``); a later ``reset()`` plays the next seed of a
        generator seeded with ``s`` (or with fresh entropy if never seeded)."""
        if seed is not None:
            self._seeds = np.random.default_rng(seed)
            match_seed = int(seed)
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
        """Every live agent's action (an agent left out waits)."""
        if not self.agents:
            raise RuntimeError("the episode is over: call reset() first")
        acts = self._actions
        for i, name in enumerate(self.possible_agents):
            acts[i] = actions.get(name, 0)
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
        text = self._env.describe(self.possible_agents.index(agent), int(action))
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
