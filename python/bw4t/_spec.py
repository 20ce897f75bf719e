"""One environment configuration, shared by every kind of environment: the map, who sits
in each seat, the step's length, the limits and the rewards; and the spaces it implies."""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence

from typing import TYPE_CHECKING

import numpy as np

from . import _check, _native

if TYPE_CHECKING:
    from gymnasium import spaces

#: Segments whose values are counts (unbounded above); every other one is 0/1 or [0, 1].
COUNT_SEGMENTS = ("room_colours", "messages")
#: More robots than any map has spawn points for (the map's own count is checked in Rust).
MAX_ROBOTS = 1024


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
    """The native spec (checked: a bad value raises ``ValueError`` naming it, a value of
    the wrong type ``TypeError``)."""
    r = Rewards() if rewards is None else rewards
    if not isinstance(r, Rewards):
        raise TypeError(f"rewards must be a bw4t.env.Rewards, not {type(r).__name__}")
    return _native.EnvSpec(
        _check.map_name(map),
        list(seats),
        _check.integer("ticks_per_step", ticks_per_step, 1, 2**32 - 1),
        _check.optional_integer("max_ticks", max_ticks, 1, 2**64 - 1),
        _check.integer("slots", slots, 1, 64),
        _check.number("rewards.delivery", r.delivery),
        _check.number("rewards.wrong_drop", r.wrong_drop),
        _check.number("rewards.step_cost", r.step_cost),
        _check.text("rewards.mode", r.mode),
    )


def seats(learners: int, teammates: int, strategy: str) -> List[str]:
    """Learners first (robots ``Agent1`` ...), then built-in teammates (``Bot1`` ...)."""
    if _check.integer("robots", learners, -(2**63), 2**63) < 1:
        raise ValueError("there must be at least one learning robot (robots >= 1)")
    if _check.integer("teammates", teammates, -(2**63), 2**63) < 0:
        raise ValueError("teammates cannot be negative")
    if _check.text("strategy", strategy) not in _native.strategies():
        raise ValueError(f"unknown strategy {strategy!r}: one of {', '.join(_native.strategies())}")
    if learners + teammates > MAX_ROBOTS:
        raise ValueError(f"{learners + teammates} robots asked for: a map has at most {MAX_ROBOTS} spawn points")
    return ["learner"] * learners + [strategy] * teammates


def observation_space(spec: "_native.EnvSpec") -> "spaces.Dict":
    """``{"observation": Box(obs_len), "action_mask": Box(n_actions, int8)}``."""
    from gymnasium import spaces

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


def state_space(spec: "_native.EnvSpec") -> "spaces.Box":
    """The global state (``state_layout``): 0/1 or [0, 1], counts unbounded above."""
    from gymnasium import spaces

    high = np.ones(spec.state_len, dtype=np.float32)
    for name, offset, length in spec.state_layout:
        if name in spec.state_count_segments:
            high[offset : offset + length] = np.inf
    return spaces.Box(0.0, high, dtype=np.float32)


def action_space(spec: "_native.EnvSpec") -> "spaces.Discrete":
    """One of ``n_actions`` (``bw4t.env`` documents the segments)."""
    from gymnasium import spaces

    return spaces.Discrete(spec.n_actions)


def match_seed(rng: np.random.Generator) -> int:
    """A match seed drawn from an episode-seeding generator."""
    return int(rng.integers(0, 2**63 - 1))
