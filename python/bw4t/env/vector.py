"""N matches stepped together in Rust, without holding the interpreter, into arrays
allocated once: a Gymnasium ``VectorEnv`` whose rows are learning robots."""

from __future__ import annotations

import os
from typing import Any, Dict, Optional, Tuple

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from .. import _native
from . import _spec


class Bw4tVectorEnv(gymnasium.vector.VectorEnv):
    """A Gymnasium ``VectorEnv`` of ``num_matches`` matches of ``robots`` learners (the
    parallel setting) or of one learner among ``teammates`` (``robots=1``, the single
    setting); ``num_envs`` is ``num_matches × robots``, one row per learner, match after
    match. ``threads`` defaults to the machine's cores; ``copy=False`` returns the
    vector's own arrays (overwritten by the next step) instead of copies."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(
        self,
        num_matches: int = 64,
        map: str = "default",
        robots: int = 3,
        teammates: int = 0,
        strategy: str = "coop",
        ticks_per_step: int = 10,
        max_ticks: Optional[int] = None,
        slots: int = 10,
        rewards: Optional[_spec.Rewards] = None,
        threads: Optional[int] = None,
        seed: int = 0,
        copy: bool = True,
    ) -> None:
        self.spec_native = _spec.make_spec(
            map, _spec.seats(robots, teammates, strategy), ticks_per_step, max_ticks, slots, rewards
        )
        if num_matches < 1:
            raise ValueError("num_matches must be at least 1")
        self.num_matches = int(num_matches)
        self.learners = int(robots)
        self.threads = int(threads) if threads is not None else max(1, min(os.cpu_count() or 1, num_matches))
        if self.threads < 1:
            raise ValueError("threads must be at least 1")
        self.copy = copy
        self.num_envs = self.num_matches * self.learners
        self.single_observation_space = _spec.observation_space(self.spec_native)
        self.single_action_space = _spec.action_space(self.spec_native)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        rows, o, n = self.num_envs, self.spec_native.obs_len, self.spec_native.n_actions
        # Every array is allocated here, once; each step writes into them.
        self.obs = np.zeros((rows, o), dtype=np.float32)
        self.masks = np.zeros((rows, n), dtype=np.int8)
        self.rewards = np.zeros(rows, dtype=np.float32)
        self.terminations = np.zeros(rows, dtype=np.bool_)
        self.truncations = np.zeros(rows, dtype=np.bool_)
        self.final_obs = np.zeros((rows, o), dtype=np.float32)
        self._masks_u8 = self.masks.view(np.uint8)
        self._no_actions = np.zeros(n, dtype=np.int8)
        self._actions = np.zeros(rows, dtype=np.uint32)
        self._seed = int(seed)
        self._vec = _native.VecEnv(self.spec_native, self.num_matches, self._seed, self.threads)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None) -> Tuple[Dict, Dict]:
        """Starts every match anew. With ``seed``, match ``i`` plays the seeds of stream
        ``i`` of ``seed`` from the start (independent of threads and of when others end)."""
        if seed is not None:
            if not isinstance(seed, (int, np.integer)):
                raise TypeError("seed must be one int: match i's seeds are drawn from stream i of it")
            self._seed = int(seed)
            self._vec = _native.VecEnv(self.spec_native, self.num_matches, self._seed, self.threads)
        self._vec.reset(self.obs, self._masks_u8)
        return self._observation(), {}

    def step(self, actions: Any) -> Tuple[Dict, np.ndarray, np.ndarray, np.ndarray, Dict]:
        """One step of every match, one action per row. A match whose episode ends is reset
        at once (same-step): its rows hold the new episode, and ``infos["final_obs"]``
        the ended episode's last observation where ``infos["_final_obs"]`` is true."""
        np.copyto(self._actions, actions, casting="unsafe")
        self._vec.step(
            self._actions, self.obs, self._masks_u8, self.rewards, self.terminations, self.truncations, self.final_obs
        )
        infos: Dict[str, Any] = {}
        ended = self.terminations | self.truncations
        if ended.any():
            finals = np.empty(self.num_envs, dtype=object)
            for row in np.flatnonzero(ended):
                # The episode is over: no action is allowed in its last state.
                finals[row] = {"observation": self.final_obs[row].copy(), "action_mask": self._no_actions}
            infos["final_obs"] = finals
            infos["_final_obs"] = ended
        if self.copy:
            return (
                self._observation(),
                self.rewards.copy(),
                self.terminations.copy(),
                self.truncations.copy(),
                infos,
            )
        return self._observation(), self.rewards, self.terminations, self.truncations, infos

    def _observation(self) -> Dict[str, np.ndarray]:
        if self.copy:
            return {"observation": self.obs.copy(), "action_mask": self.masks.copy()}
        return {"observation": self.obs, "action_mask": self.masks}

    def digest(self, match: int) -> int:
        """Match ``match``'s digest now."""
        return self._vec.digest(match)

    def episodes(self, match: int) -> int:
        """Episodes match ``match`` has begun."""
        return self._vec.episodes(match)

    def match_tick(self, match: int) -> int:
        """Ticks match ``match``'s episode has run."""
        return self._vec.tick(match)

    def close_extras(self, **kwargs: Any) -> None:
        pass
