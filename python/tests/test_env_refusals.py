"""Malformed actions and arguments are refused before anything is played: ``ValueError``
naming the argument (``TypeError`` for a value of the wrong type), never a silent
broadcast, wrap-around, truncation or ``wait``, nor an ``OverflowError``."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from bw4t.env import Rewards, parallel_env, single_env, vector_env

N_ACTIONS = 70  # on the default map


# ---------------------------------------------------------------- the vector's actions


@pytest.mark.parametrize(
    "actions, error, message",
    [
        (0, ValueError, r"one action per row, shape \(4,\)"),
        (np.int64(3), ValueError, "not broadcast"),
        ([0, 0, 0], ValueError, r"shape \(4,\) \(one per row\), not \(3,\)"),
        (np.zeros((4, 1), dtype=np.int64), ValueError, r"not \(4, 1\)"),
        ([0, -1, 0, 0], ValueError, r"actions\[1\] is -1: an action is from 0 to 69"),
        ([0, 0, N_ACTIONS, 0], ValueError, r"actions\[2\] is 70"),
        ([0, 0, 0, 2**40], ValueError, r"actions\[3\] is 1099511627776"),
        ([0.0, 1.5, 0.0, 0.0], TypeError, "actions must be integers, not float64"),
        (np.zeros(4, dtype=np.float32), TypeError, "not float32"),
        (np.zeros(4, dtype=np.bool_), TypeError, "not bool"),
        (["0", "1", "2", "3"], TypeError, "must be integers"),
    ],
)
def test_the_vector_refuses_malformed_actions(actions: Any, error: type, message: str) -> None:
    vec = vector_env(num_matches=2, robots=2, max_ticks=100, threads=1)
    vec.reset(seed=0)
    digests = [vec.digest(i) for i in range(2)]
    with pytest.raises(error, match=message):
        vec.step(actions)
    assert [vec.digest(i) for i in range(2)] == digests and vec.match_tick(0) == 0


def test_the_vector_takes_any_integer_dtype_and_lists() -> None:
    vec = vector_env(num_matches=2, robots=1, max_ticks=100, threads=1)
    vec.reset(seed=0)
    for actions in ([0, 0], np.zeros(2, dtype=np.uint8), np.zeros(2, dtype=np.int32)):
        vec.step(actions)
    assert vec.match_tick(0) == 30


# ---------------------------------------------------------------- the parallel env's actions


@pytest.mark.parametrize(
    "actions, error, message",
    [
        ({"agent1": 1}, ValueError, "unknown agent 'agent1' in actions: the agents are Agent1, Agent2"),
        ({"Agent3": 1}, ValueError, "unknown agent 'Agent3'"),
        ({1: 1}, ValueError, "unknown agent 1"),
        ({"Agent1": -1}, ValueError, r"actions\['Agent1'\] must be from 0 to 69, not -1"),
        ({"Agent1": N_ACTIONS}, ValueError, r"actions\['Agent1'\] must be from 0 to 69, not 70"),
        ({"Agent2": 2**64}, ValueError, "not 18446744073709551616"),
        ({"Agent1": 1.0}, TypeError, r"actions\['Agent1'\] must be an integer, not float"),
        ({"Agent1": np.float32(2)}, TypeError, "not float32"),
        ({"Agent1": True}, TypeError, "not bool"),
        ({"Agent1": None}, TypeError, "not NoneType"),
        ({"Agent1": "1"}, TypeError, "not str"),
        ({"Agent1": np.array([1, 2])}, TypeError, "not ndarray"),
        ([1, 2], TypeError, "actions must be a dict of agent name to action, not list"),
    ],
)
def test_the_parallel_env_refuses_malformed_actions(actions: Any, error: type, message: str) -> None:
    env = parallel_env(robots=2)
    env.reset(seed=0)
    before = (env.digest(), env.tick)
    with pytest.raises(error, match=message):
        env.step(actions)
    assert (env.digest(), env.tick) == before, "nothing was played"


def test_the_parallel_env_takes_numpy_integers_and_zero_dimensional_arrays() -> None:
    env = parallel_env(robots=2)
    env.reset(seed=0)
    _, rewards, *_ = env.step({"Agent1": np.int64(0), "Agent2": np.array(0, dtype=np.uint32)})
    assert set(rewards) == {"Agent1", "Agent2"} and env.tick == 10


def test_describe_refuses_unknown_agents_and_bad_actions() -> None:
    env = parallel_env(robots=2)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="unknown agent 'Agent9' in describe"):
        env.describe("Agent9", 1)
    with pytest.raises(ValueError, match="action must be from 0 to 69, not -1"):
        env.describe("Agent1", -1)
    with pytest.raises(ValueError, match="unknown agent 'agent1' in agent"):
        env.observation_space("agent1")


# ---------------------------------------------------------------- the single env's actions


@pytest.mark.parametrize(
    "action, error, message",
    [
        (-1, ValueError, "action must be from 0 to 69, not -1"),
        (N_ACTIONS, ValueError, "not 70"),
        (2**70, ValueError, "not 1180591620717411303424"),
        (1.0, TypeError, "action must be an integer, not float"),
        (np.float64(3.7), TypeError, "not float64"),
        (False, TypeError, "not bool"),
        ([1], TypeError, "not list"),
        (None, TypeError, "not NoneType"),
    ],
)
def test_the_single_env_refuses_malformed_actions(action: Any, error: type, message: str) -> None:
    env = single_env()
    env.reset(seed=0)
    with pytest.raises(error, match=message):
        env.step(action)
    assert env.tick == 0


# ---------------------------------------------------------------- seeds and arguments


@pytest.mark.parametrize(
    "seed, error, message",
    [
        (-1, ValueError, "seed must be from 0 to 18446744073709551615, not -1"),
        (2**64, ValueError, "not 18446744073709551616"),
        (1.5, TypeError, "seed must be an integer, not float"),
        ("7", TypeError, "not str"),
        (True, TypeError, "not bool"),
    ],
)
def test_bad_seeds_are_refused_everywhere(seed: Any, error: type, message: str) -> None:
    for env in (parallel_env(), single_env()):
        with pytest.raises(error, match=message):
            env.reset(seed=seed)
    vec = vector_env(num_matches=2, robots=1)
    with pytest.raises(error, match=message):
        vec.reset(seed=seed)
    with pytest.raises(error, match=message.replace("seed must", r"seed\[1\] must")):
        vec.reset(seed=[0, seed])
    with pytest.raises(error, match=message):
        vector_env(num_matches=2, seed=seed)


def test_the_largest_seed_is_accepted() -> None:
    env = parallel_env()
    env.reset(seed=2**64 - 1)
    env.reset()  # the next seed of the generator seeded with it


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"max_ticks": -1}, ValueError, "max_ticks must be from 1 to"),
        ({"max_ticks": 2**64}, ValueError, "max_ticks must be from 1"),
        ({"max_ticks": 10.5}, TypeError, "max_ticks must be an integer, not float"),
        ({"ticks_per_step": 2**32}, ValueError, "ticks_per_step must be from 1 to 4294967295"),
        ({"ticks_per_step": -3}, ValueError, "ticks_per_step must be from 1"),
        ({"ticks_per_step": 2.5}, TypeError, "ticks_per_step must be an integer"),
        ({"slots": -1}, ValueError, "slots must be from 1 to 64, not -1"),
        ({"slots": 65}, ValueError, "slots must be from 1 to 64"),
        ({"robots": 2.0}, TypeError, "robots must be an integer, not float"),
        ({"robots": "3"}, TypeError, "robots must be an integer, not str"),
        ({"robots": 10**30}, ValueError, "robots must be from"),
        ({"robots": 5000}, ValueError, "spawn points"),
        ({"teammates": -1}, ValueError, "teammates cannot be negative"),
        ({"teammates": 1.0}, TypeError, "teammates must be an integer"),
        ({"strategy": 3}, TypeError, "strategy must be a string"),
        ({"map": 7}, TypeError, "map must be a string"),
        ({"rewards": {"delivery": 1}}, TypeError, "rewards must be a bw4t.env.Rewards, not dict"),
        ({"rewards": Rewards(delivery="1")}, TypeError, "rewards.delivery must be a number, not str"),
        ({"rewards": Rewards(step_cost=float("nan"))}, ValueError, "rewards.step_cost must be a finite number"),
        ({"rewards": Rewards(mode=1)}, TypeError, "rewards.mode must be a string"),
    ],
)
def test_bad_arguments_raise_value_or_type_errors_naming_them(kwargs: dict, error: type, message: str) -> None:
    with pytest.raises(error, match=message):
        parallel_env(**kwargs)


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"num_matches": 0}, ValueError, "num_matches must be from 1"),
        ({"num_matches": -2}, ValueError, "num_matches must be from 1"),
        ({"num_matches": 2.0}, TypeError, "num_matches must be an integer"),
        ({"threads": 0}, ValueError, "threads must be from 1"),
        ({"threads": -1}, ValueError, "threads must be from 1"),
        ({"threads": 1.5}, TypeError, "threads must be an integer"),
    ],
)
def test_bad_vector_arguments_are_refused(kwargs: dict, error: type, message: str) -> None:
    with pytest.raises(error, match=message):
        vector_env(**kwargs)


def test_bad_match_indices_and_options_are_refused() -> None:
    vec = vector_env(num_matches=2, robots=1)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="match must be from 0 to 1, not -1"):
        vec.digest(-1)
    with pytest.raises(ValueError, match="match must be from 0 to 1, not 2"):
        vec.episodes(2)
    with pytest.raises(TypeError, match="match must be an integer"):
        vec.match_tick(0.0)
    with pytest.raises(ValueError, match="unknown option 'reset_masks'"):
        vec.reset(options={"reset_masks": np.ones(2, dtype=bool)})
    with pytest.raises(TypeError, match="options must be a dict"):
        vec.reset(options=[1])
    for env in (parallel_env(), single_env()):
        with pytest.raises(TypeError, match="options must be a dict, not str"):
            env.reset(options="reset_mask")
