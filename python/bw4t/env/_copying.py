"""``pickle`` and ``copy.deepcopy`` for the single-match environments: what is kept is the
constructor's arguments, the episode's match seed and every action index played since,
and the Python side's own state (the seed generator, the live agents). Unpickling makes
the environment anew and plays the episode again in Rust, so the copy is where the
original was, bit for bit (same observations, masks, digest), and goes on alike."""

from __future__ import annotations

from typing import Any, Dict

import numpy as np


class Replayable:
    """For environments holding one native match as ``_env`` and their constructor's
    arguments as ``_args``."""

    _env: Any
    _args: Dict[str, Any]

    def __getstate__(self) -> Dict[str, Any]:
        episode = self._env.episode()
        if episode is None:
            raise TypeError("this environment took the match's own actions (step_acts): it cannot be copied")
        seed, played = episode
        return {"args": dict(self._args), "seed": seed, "played": played, "own": self._own_state()}

    def __setstate__(self, state: Dict[str, Any]) -> None:
        self.__init__(**state["args"])  # type: ignore[misc]
        agents, spec = self._env.agent_names(), self.spec_native  # type: ignore[attr-defined]
        obs = np.empty((len(agents), spec.obs_len), dtype=np.float32)
        masks = np.empty((len(agents), spec.n_actions), dtype=np.uint8)
        self._env.replay(state["seed"], np.ascontiguousarray(state["played"], dtype=np.uint32), obs, masks)
        self._restore_own_state(state["own"])

    def _own_state(self) -> Dict[str, Any]:
        return {}

    def _restore_own_state(self, state: Dict[str, Any]) -> None:
        pass
