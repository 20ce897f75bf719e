"""One environment configuration, shared by every kind of environment: the map, who sits
in each seat, the step's length, the limits and the rewards; and the spaces it implies."""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np
from gymnasium import spaces

from .. import _native

#: Segments whose values are counts (unbounded above); every other one is 0/1 or [0, 1].
COUNT_SEGMENTS = ("room_colours", "messages")


@dataclass(frozen=True)
class Rewards:
    """The reward of one step, per learner (the defaults are documented in ``bw4t.env``)."""

    #: For each block delivered in order.
    delivery: float = 1.0
    #: For each block of the wrong colour dropped in the drop zone.
    wrong_drop: float = -0.5
    #: Taken from every learner every step.
    step_cost: float = 0.001
    #: ``"team"``: every learner is rewarded for every drop in the match (built-in
    #: teammates' included); ``"individual"``: for its own.
    mode: str = "team"


def make_spec(
    map: str,
    seats: Sequence[str],
    ticks_per_step: int,
    max_ticks: Optional[int],
    slots: int,
    rewards: Optional[Rewards],
) -> "_native.EnvSpec":
    """The native spec (checked: a bad value raises ``ValueError`` naming it)."""
    r = rewards or Rewards()
    if not isinstance(r, Rewards):
        raise TypeError("rewards must be a bw4t.env.Rewards")
    return _native.EnvSpec(
        str(map),
        list(seats),
        int(ticks_per_step),
        None if max_ticks is None else int(max_ticks),
        int(slots),
        float(r.delivery),
        float(r.wrong_drop),
        float(r.step_cost),
        str(r.mode),
    )


def seats(learners: int, teammates: int, strategy: str) -> List[str]:
    """Learners first (robots ``Agent1`` ...), then built-in teammates (``Bot1`` ...)."""
    if learners < 1:
        raise ValueError("there must be at least one learning robot")
    if teammates < 0:
        raise ValueError("teammates cannot be negative")
    if strategy not in _native.strategies():
        raise ValueError(f"unknown strategy {strategy!r}: one of {', '.join(_native.strategies())}")
    return ["learner"] * learners + [strategy] * teammates


def observation_space(spec: "_native.EnvSpec") -> spaces.Dict:
    """``{"observation": Box(obs_len), "action_mask": Box(n_actions, int8)}``."""
    high = np.ones(spec.obs_len, dtype=np.float32)
    for name, offset, length in spec.obs_layout:
        if name in COUNT_SEGMENTS:
            high[offset : offset + length] = np.inf
    return spaces.Dict(
        {
            "observation": spaces.Box(0.0, high, dtype=np.float32),
            "action_mask": spaces.Box(0, 1, shape=(spec.n_actions,), dtype=np.int8),
        }
    )


def action_space(spec: "_native.EnvSpec") -> spaces.Discrete:
    """One of ``n_actions`` (``bw4t.env`` documents the segments)."""
    return spaces.Discrete(spec.n_actions)


def match_seed(rng: np.random.Generator) -> int:
    """A match seed drawn from an episode-seeding generator."""
    return int(rng.integers(0, 2**63 - 1))
