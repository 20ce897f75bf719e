"""A Gymnasium environment for ad-hoc teamwork: one learning robot among built-in
teammates (cooperative, baseline, silent or ignoring)."""

from __future__ import annotations

from typing import Any, Dict, Optional, Tuple

import gymnasium
import numpy as np

from .. import _native
from .. import _check, _spec
from ._copying import Replayable
from ._render import MatchViews, Renderer
from .parallel import _symbolic_infos


class Bw4tEnv(Replayable, MatchViews, gymnasium.Env):
    """A Gymnasium ``Env``: one learning robot among ``teammates`` built-in robots of
    ``strategy`` (``coop``, ``baseline``, ``silent``, ``ignoring``); also
    ``gymnasium.make("bw4t/Bw4t-v0", ...)``. Arguments as in :mod:`bw4t.env`. ``pickle``
    and ``copy.deepcopy`` give an environment where this one is (its episode played again
    from its seed and actions, its ``np_random`` as it was)."""

    metadata = {"render_modes": ["rgb_array", "svg"], "render_fps": 2}

    def __init__(
        self,
        map: str = "default",
        teammates: int = 2,
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
            map, _spec.seats(1, teammates, strategy), ticks_per_step, max_ticks, slots, rewards
        )
        self._renderer = Renderer(render_mode, self.metadata["render_modes"])
        self._env = _native.Env(self.spec_native)
        self.observation_space = _spec.observation_space(self.spec_native)
        self.action_space = _spec.action_space(self.spec_native)
        self.render_mode = render_mode
        self.symbolic = bool(symbolic)
        self._action = np.zeros(1, dtype=np.uint32)
        self._reward = np.zeros(1, dtype=np.float32)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None) -> Tuple[Dict, Dict]:
        """A new episode. ``reset(seed=s)`` plays match seed ``s``; a later ``reset()``
        the next seed of Gymnasium's ``np_random``, seeded with ``s`` (an integer from 0 to
        2**64 - 1). ``options`` (a dict) are accepted and
        ignored (no option is known)."""
        _check.options(options)
        if seed is not None:
            seed = _check.seed(seed)
        super().reset(seed=seed)
        match_seed = seed if seed is not None else _spec.match_seed(self.np_random)
        obs, masks = self._buffers()
        self._env.reset(match_seed, obs, masks.view(np.uint8))
        return {"observation": obs[0], "action_mask": masks[0]}, self._info()

    def step(self, action: Any) -> Tuple[Dict, float, bool, bool, Dict]:
        """One step with ``action``, an integer from 0 to ``n_actions - 1`` (anything else
        raises ``ValueError``, or ``TypeError`` when it is not an integer)."""
        self._action[0] = _check.action("action", action, self.spec_native.n_actions)
        obs, masks = self._buffers()
        terminated, truncated = self._env.step(self._action, obs, masks.view(np.uint8), self._reward)
        observation = {"observation": obs[0], "action_mask": masks[0]}
        return observation, float(self._reward[0]), terminated, truncated, self._info()

    def _own_state(self) -> Dict[str, Any]:
        return {"np_random": self._np_random, "np_random_seed": self._np_random_seed}

    def _restore_own_state(self, state: Dict[str, Any]) -> None:
        self._np_random, self._np_random_seed = state["np_random"], state["np_random_seed"]

    def _buffers(self) -> Tuple[np.ndarray, np.ndarray]:
        # Fresh arrays each step: what was returned before is never overwritten.
        obs = np.empty((1, self.spec_native.obs_len), dtype=np.float32)
        masks = np.empty((1, self.spec_native.n_actions), dtype=np.int8)
        return obs, masks

    def _info(self) -> Dict[str, Any]:
        return _symbolic_infos(self._env, ["me"])["me"] if self.symbolic else {}
