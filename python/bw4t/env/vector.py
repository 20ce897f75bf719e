"""N matches stepped together in Rust, without holding the interpreter, into arrays
allocated once: a Gymnasium ``VectorEnv`` whose rows are learning robots."""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from .. import _native
from .. import _check, _spec


class Bw4tVectorEnv(gymnasium.vector.VectorEnv):
    """A Gymnasium ``VectorEnv`` of ``num_matches`` matches of ``robots`` learners (the
    parallel setting) or of one learner among ``teammates`` (``robots=1``, the single
    setting); ``num_envs`` is ``num_matches × robots``, one row per learner, match after
    match. ``threads`` defaults to the machine's cores; ``copy=False`` returns the
    vector's own arrays (overwritten by the next step) instead of copies. ``pickle`` and
    ``copy.deepcopy`` give a vector where this one is: every match's episode is played
    again from its seed and actions, and its seed stream resumed."""

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
        self._args = dict(
            num_matches=num_matches,
            map=map,
            robots=robots,
            teammates=teammates,
            strategy=strategy,
            ticks_per_step=ticks_per_step,
            max_ticks=max_ticks,
            slots=slots,
            rewards=rewards,
            threads=threads,
            seed=seed,
            copy=copy,
        )
        self.num_matches = _check.integer("num_matches", num_matches, 1, 2**20)
        self.spec_native = _spec.make_spec(
            map, _spec.seats(robots, teammates, strategy), ticks_per_step, max_ticks, slots, rewards
        )
        self.learners = int(robots)
        if threads is None:
            self.threads = max(1, min(os.cpu_count() or 1, self.num_matches))
        else:
            self.threads = _check.integer("threads", threads, 1, 4096)
        self.copy = bool(copy)
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
        self._seed = _check.seed(seed)
        self._vec = _native.VecEnv(self.spec_native, self.num_matches, self._seed, self.threads)

    # ------------------------------------------------------------------ reset

    def reset(self, *, seed: Any = None, options: Optional[dict] = None) -> Tuple[Dict, Dict]:
        """Starts matches anew.

        - ``seed=None``: each match plays the next seed of its stream.
        - ``seed=s`` (an int): match ``i`` plays the seeds of stream ``i`` of ``s`` from
          the start (independent of threads and of when others end).
        - ``seed=[s0, s1, ...]`` (one per row, a match's rows alike, or one per match;
          ``None`` items allowed): match ``i`` plays match seed ``s_i`` now, as
          ``single_env().reset(seed=s_i)`` does, and later episodes from a stream seeded
          with ``s_i``; a ``None`` match the next seed of its stream.
        - ``options={"reset_mask": mask}`` (a bool array, one per row as Gymnasium has it,
          a match's rows alike, or one per match): only the marked matches start anew;
          the others' rows are returned as they are. ``seed`` must then be ``None`` or a
          list (its items for unmarked matches are not used).
        """
        opts = _check.options(options, ("reset_mask",))
        which = None
        if "reset_mask" in opts:
            which = self._per_match_mask(opts["reset_mask"])
        if seed is None or isinstance(seed, (list, tuple, np.ndarray)):
            seeds = [] if seed is None else self._per_match_seeds(seed)
            mask = np.ones(self.num_matches, dtype=np.bool_) if which is None else which
            self._vec.reset_some(mask, seeds, self.obs, self._masks_u8)
        else:
            if which is not None:
                raise ValueError("with options['reset_mask'], give seed as a list (one per match) or None, not one int")
            self._seed = _check.seed(seed)
            self._vec = _native.VecEnv(self.spec_native, self.num_matches, self._seed, self.threads)
            self._vec.reset(self.obs, self._masks_u8)
        if which is not None:
            rows = np.repeat(which, self.learners)
            self.terminations[rows] = False
            self.truncations[rows] = False
        else:
            self.terminations[:] = False
            self.truncations[:] = False
        return self._observation(), {}

    def _per_match(self, name: str, values: Sequence[Any]) -> List[Any]:
        """One value per match from one per row (a match's rows alike) or one per match."""
        values = list(values)
        if len(values) == self.num_matches:
            return values
        if len(values) == self.num_envs:
            per_match = values[:: self.learners]
            for i in range(self.num_matches):
                row = values[i * self.learners : (i + 1) * self.learners]
                if any(v is not row[0] and v != row[0] for v in row):
                    raise ValueError(f"{name}: the {self.learners} rows of match {i} must be alike, not {row}")
            return per_match
        counts = f"{self.num_envs} (one per row)" + (
            f" or {self.num_matches} (one per match)" if self.num_matches != self.num_envs else ""
        )
        raise ValueError(f"{name} holds {len(values)} values; it must hold {counts}")

    def _per_match_seeds(self, seed: Any) -> List[Optional[int]]:
        if isinstance(seed, np.ndarray) and seed.ndim != 1:
            raise ValueError(f"seed must be one int or a list of them, not an array of shape {seed.shape}")
        seeds = [None if s is None else _check.seed(s, f"seed[{i}]") for i, s in enumerate(seed)]
        return self._per_match("seed", seeds)

    def _per_match_mask(self, mask: Any) -> np.ndarray:
        if not isinstance(mask, np.ndarray):
            raise TypeError(f"options['reset_mask'] must be a NumPy array, not {type(mask).__name__}")
        if mask.dtype != np.bool_:
            raise TypeError(f"options['reset_mask'] must have dtype bool, not {mask.dtype}")
        if mask.ndim != 1:
            raise ValueError(f"options['reset_mask'] must have shape ({self.num_envs},), not {mask.shape}")
        which = np.array(self._per_match("options['reset_mask']", mask.tolist()), dtype=np.bool_)
        if not which.any():
            raise ValueError("options['reset_mask'] must mark at least one match")
        return which

    # ------------------------------------------------------------------ step

    def step(self, actions: Any) -> Tuple[Dict, np.ndarray, np.ndarray, np.ndarray, Dict]:
        """One step of every match, one integer action per row (shape ``(num_envs,)``,
        each from 0 to ``n_actions - 1``; anything else raises before anything is played).
        A match whose episode ends is reset at once (same-step): its rows hold the new
        episode; where ``infos["_final_obs"]`` is true, ``infos["final_obs"]`` has the
        ended episode's last observation and ``infos["final_info"]`` its ``ticks``,
        ``sequence_index`` and ``digest``."""
        checked = _check.action_array(actions, self.num_envs, self.spec_native.n_actions)
        np.copyto(self._actions, checked, casting="unsafe")
        self._vec.step(
            self._actions, self.obs, self._masks_u8, self.rewards, self.terminations, self.truncations, self.final_obs
        )
        infos: Dict[str, Any] = {}
        ended = self.terminations | self.truncations
        if ended.any():
            infos.update(self._final_infos(ended))
        if self.copy:
            return (
                self._observation(),
                self.rewards.copy(),
                self.terminations.copy(),
                self.truncations.copy(),
                infos,
            )
        return self._observation(), self.rewards, self.terminations, self.truncations, infos

    def _final_infos(self, ended: np.ndarray) -> Dict[str, Any]:
        """Gymnasium's same-step ``final_obs`` and ``final_info`` (with ``_`` masks)."""
        finals = np.full(self.num_envs, None, dtype=object)
        ticks = np.zeros(self.num_envs, dtype=np.int64)
        index = np.zeros(self.num_envs, dtype=np.int64)
        digests = np.zeros(self.num_envs, dtype=np.uint64)
        for row in np.flatnonzero(ended):
            # The episode is over: no action is allowed in its last state.
            finals[row] = {"observation": self.final_obs[row].copy(), "action_mask": self._no_actions}
            end = self._vec.last_episode(int(row) // self.learners)
            ticks[row], index[row], digests[row] = end
        mask = ended.copy()
        final_info = {
            "ticks": ticks,
            "_ticks": mask,
            "sequence_index": index,
            "_sequence_index": mask,
            "digest": digests,
            "_digest": mask,
        }
        return {"final_obs": finals, "_final_obs": mask, "final_info": final_info, "_final_info": mask}

    def _observation(self) -> Dict[str, np.ndarray]:
        if self.copy:
            return {"observation": self.obs.copy(), "action_mask": self.masks.copy()}
        return {"observation": self.obs, "action_mask": self.masks}

    # ------------------------------------------------------------------ matches

    def _match(self, match: Any) -> int:
        return _check.integer("match", match, 0, self.num_matches - 1)

    def digest(self, match: int) -> int:
        """Match ``match``'s digest now."""
        return self._vec.digest(self._match(match))

    def episodes(self, match: int) -> int:
        """Episodes match ``match`` has begun."""
        return self._vec.episodes(self._match(match))

    def match_tick(self, match: int) -> int:
        """Ticks match ``match``'s episode has run."""
        return self._vec.tick(self._match(match))

    def close_extras(self, **kwargs: Any) -> None:
        pass

    # ------------------------------------------------------------------ pickle, copy

    def __getstate__(self) -> Dict[str, Any]:
        return {
            "args": dict(self._args),
            "seed": self._seed,
            "matches": [self._vec.snapshot(i) for i in range(self.num_matches)],
        }

    def __setstate__(self, state: Dict[str, Any]) -> None:
        self.__init__(**state["args"])  # type: ignore[misc]
        self._seed = state["seed"]
        for i, (origin, drawn, episodes, seed, played) in enumerate(state["matches"]):
            played = np.ascontiguousarray(played, dtype=np.uint32)
            self._vec.restore(i, (origin, drawn), episodes, seed, played, self.obs, self._masks_u8)


def single_vector_env(num_envs: int = 1, **kwargs: Any) -> Bw4tVectorEnv:
    """``gymnasium.make_vec("bw4t/Bw4t-v0", num_envs, ...)``: the Rust vector of the
    single-agent setting, ``num_envs`` matches of one learner among built-in teammates
    (``teammates=2`` of ``strategy="coop"`` by default, as ``gymnasium.make``), taking the
    single environment's arguments and the vector's ``threads``, ``seed`` and ``copy``."""
    if kwargs.pop("render_mode", None) is not None:
        raise ValueError("render_mode: the vector does not render; render a single_env instead")
    if kwargs.pop("symbolic", False):
        raise ValueError("symbolic: the vector has no symbolic infos; use single_env(symbolic=True)")
    for name in ("robots", "num_matches"):
        if name in kwargs:
            raise ValueError(f"{name}: make_vec's vector has one learner per match and num_envs matches")
    kwargs.setdefault("teammates", 2)
    return Bw4tVectorEnv(num_matches=num_envs, robots=1, **kwargs)
