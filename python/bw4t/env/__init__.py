"""BW4T as learning environments: PettingZoo, Gymnasium, and a vector stepped in Rust.

- :func:`parallel_env`: a PettingZoo ``ParallelEnv``, one agent per learning robot
  (``Agent1``, ``Agent2``, ...), optionally beside built-in teammates.
- :func:`single_env`: a Gymnasium ``Env`` for ad-hoc teamwork, one learning robot among
  built-in teammates (``coop``, ``baseline``, ``silent`` or ``ignoring``).
- :func:`vector_env`: a Gymnasium ``VectorEnv`` of N matches stepped together in Rust on
  several threads without the interpreter, into arrays allocated once, auto-resetting.

Every kind shares one encoding (the Rust crate ``bw4t-env`` is its one source; the
layout of a given configuration is ``env.spec_native.obs_layout`` / ``.action_layout``):

Observation: ``{"observation": float32[obs_len], "action_mask": int8[n_actions]}``. With
``P`` places, ``R`` rooms (drop zone included), ``C = 9`` colours, ``K`` slots (default
10), ``L`` sequence length and ``M = 30`` message kinds, the observation's segments are
``at`` (P, one-hot place), ``in_room`` (1), ``holding`` (1), ``held_colour`` (C),
``room_colours`` (C, counts of visible blocks per colour), ``slots`` (K*C, the colour of
the k-th visible block), ``at_block`` (1), ``sequence`` (L*C), ``sequence_index``
(L+1, one-hot), ``delivered`` (L), ``occupied`` (R), ``move_state`` (3: arrived,
traveling, collided), ``messages`` (M+1: messages received in the step per kind of the
message language, last free text) and ``time`` (1: tick over the tick limit). The
default map gives 251 values.

Actions (``Discrete(n_actions)``, 70 on the default map): ``wait`` (1), ``go_to`` (P),
``go_to_block`` (K, the k-th visible block), ``pick_up`` (1), ``put_down`` (1),
``say_will_get`` (C), ``say_contains`` (C), ``say_empty`` (1), ``say_going_to`` (R). The
mask is 1 exactly for the actions valid now; a masked-out action does nothing.

Rewards (:class:`Rewards`; per learner and step): ``+1`` per block delivered in order,
``-0.5`` per wrong-colour drop, ``-0.001`` per step; shared by the team by default
(``mode="individual"``: one's own drops only). An episode *terminates* when the sequence
is delivered and is *truncated* at ``max_ticks`` (default: the map's own limit, as in
``bw4t run``). A step is ``ticks_per_step`` simulated ticks (default 10: half a simulated
second).

Seeding: ``reset(seed=s)`` plays match seed ``s``; the same seed and actions give the same
observations, rewards and digests for whole episodes, in every process.
"""

from __future__ import annotations

from typing import Optional

import gymnasium

from ._spec import Rewards
from .parallel import Bw4tParallelEnv
from .single import Bw4tEnv
from .vector import Bw4tVectorEnv

# `gymnasium.make("bw4t/Bw4t-v0", teammates=2, strategy="coop", ...)`: the single-agent env.
gymnasium.register("bw4t/Bw4t-v0", entry_point="bw4t.env.single:Bw4tEnv")

__all__ = ["Bw4tEnv", "Bw4tParallelEnv", "Bw4tVectorEnv", "Rewards", "parallel_env", "single_env", "vector_env"]


def parallel_env(
    map: str = "default",
    robots: int = 3,
    teammates: int = 0,
    strategy: str = "coop",
    ticks_per_step: int = 10,
    max_ticks: Optional[int] = None,
    slots: int = 10,
    rewards: Optional[Rewards] = None,
    render_mode: Optional[str] = None,
    symbolic: bool = False,
) -> Bw4tParallelEnv:
    """A PettingZoo ``ParallelEnv`` of ``robots`` learning robots (and ``teammates``
    built-in robots of ``strategy``) on ``map`` (a shipped map's name or a map file).
    ``symbolic=True`` adds each agent's percepts (in the protocol's own form), its new
    percepts and its last action's outcome to ``infos``. ``render_mode``: ``"rgb_array"``
    or ``"svg"``."""
    return Bw4tParallelEnv(
        map, robots, teammates, strategy, ticks_per_step, max_ticks, slots, rewards, render_mode, symbolic
    )


def single_env(
    map: str = "default",
    teammates: int = 2,
    strategy: str = "coop",
    ticks_per_step: int = 10,
    max_ticks: Optional[int] = None,
    slots: int = 10,
    rewards: Optional[Rewards] = None,
    render_mode: Optional[str] = None,
    symbolic: bool = False,
) -> Bw4tEnv:
    """A Gymnasium ``Env``: one learning robot among ``teammates`` built-in robots of
    ``strategy`` (``coop``, ``baseline``, ``silent``, ``ignoring``)."""
    return Bw4tEnv(map, teammates, strategy, ticks_per_step, max_ticks, slots, rewards, render_mode, symbolic)


def vector_env(
    num_matches: int = 64,
    map: str = "default",
    robots: int = 3,
    teammates: int = 0,
    strategy: str = "coop",
    ticks_per_step: int = 10,
    max_ticks: Optional[int] = None,
    slots: int = 10,
    rewards: Optional[Rewards] = None,
    threads: Optional[int] = None,
    seed: int = 0,
    copy: bool = True,
) -> Bw4tVectorEnv:
    """A Gymnasium ``VectorEnv`` of ``num_matches`` matches of ``robots`` learners (the
    parallel setting) or of one learner among ``teammates`` (``robots=1``, the single
    setting); ``num_envs`` is ``num_matches × robots``, one row per learner. ``threads``
    defaults to the machine's cores; ``copy=False`` returns the vector's own arrays
    (overwritten by the next step) instead of copies."""
    return Bw4tVectorEnv(
        num_matches, map, robots, teammates, strategy, ticks_per_step, max_ticks, slots, rewards, threads, seed, copy
    )
