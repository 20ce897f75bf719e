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

Seeding: ``reset(seed=s)`` plays match seed ``s`` (an integer from 0 to 2**64 - 1); the
same seed and actions give the same observations, rewards and digests for whole episodes,
in every process.

Actions and arguments are checked: a malformed one (a float, a bool, a negative or too
large index, a scalar for the vector's row array, an unknown agent name) raises
``ValueError`` naming it (``TypeError`` for the wrong type) before anything is played.

The parallel env's ``state()`` (``state_space``) is the global state for centralised
critics: every robot's position, room, move state and held colour, the blocks lying in
each room, the goal and the time (``spec_native.state_layout``).

Every kind can be pickled and ``copy.deepcopy``'d: the copy is made from the same
arguments and plays the running episode's actions again from its seed, so it is where the
original was, bit for bit, and goes on alike (its seed generator is copied too).
``gymnasium.make_vec("bw4t/Bw4t-v0", n)`` gives the Rust vector of the single setting.
"""

from __future__ import annotations

try:
    import gymnasium
    import pettingzoo  # noqa: F401 (the parallel environment's base)
except ImportError as missing:
    raise ImportError(
        f"bw4t.env needs Gymnasium and PettingZoo ({missing.name} is not installed): pip install 'bw4t[rl]'"
    ) from missing

from .._spec import Rewards
from .parallel import Bw4tParallelEnv
from .single import Bw4tEnv
from .vector import Bw4tVectorEnv, single_vector_env

# `gymnasium.make("bw4t/Bw4t-v0", teammates=2, strategy="coop", ...)`: the single-agent env;
# `gymnasium.make_vec("bw4t/Bw4t-v0", n, ...)`: n of them as the Rust vector.
gymnasium.register(
    "bw4t/Bw4t-v0",
    entry_point="bw4t.env.single:Bw4tEnv",
    vector_entry_point="bw4t.env.vector:single_vector_env",
)

__all__ = [
    "Bw4tEnv",
    "Bw4tParallelEnv",
    "Bw4tVectorEnv",
    "Rewards",
    "parallel_env",
    "single_env",
    "single_vector_env",
    "vector_env",
]


#: ``parallel_env(map="default", robots=3, teammates=0, strategy="coop", ...)``: the
#: PettingZoo ``ParallelEnv`` (PettingZoo's naming for an environment's constructor).
parallel_env = Bw4tParallelEnv
#: ``single_env(map="default", teammates=2, strategy="coop", ...)``: the Gymnasium ``Env``.
single_env = Bw4tEnv
#: ``vector_env(num_matches=64, map="default", robots=3, ...)``: the ``VectorEnv``.
vector_env = Bw4tVectorEnv
