"""Copying environments: pickle and copy.deepcopy carry the running episode (the copy goes
on exactly as the original), SuperSuit's concat_vec_envs_v1 across processes, and
environments that are dropped are freed (memory stays bounded over thousands of them)."""

from __future__ import annotations

import copy
import gc
import os
import pickle
import weakref
from typing import Any, Callable, List

import gymnasium
import numpy as np
import pytest

from bw4t.env import parallel_env, single_env, vector_env


def allowed(mask: np.ndarray, rng: np.random.Generator) -> int:
    return int(rng.choice(np.flatnonzero(mask)))


def pickle_round_trip(env: Any) -> Any:
    return pickle.loads(pickle.dumps(env))


COPIERS: List[Callable[[Any], Any]] = [pickle_round_trip, copy.deepcopy]


# ---------------------------------------------------------------- the parallel env


def play_parallel(env: Any, obs: dict, rng: np.random.Generator, steps: int) -> list:
    """``steps`` steps of random allowed actions (resetting from the env's own seed
    generator when an episode ends): everything observed, bit for bit."""
    seen = []
    for _ in range(steps):
        if not env.agents:
            obs, _ = env.reset()
            seen.append(("reset", {a: obs[a]["observation"].tobytes() for a in obs}))
            continue
        actions = {a: allowed(obs[a]["action_mask"], rng) for a in env.agents}
        obs, rewards, term, trunc, _ = env.step(actions)
        seen.append(
            (
                {a: (obs[a]["observation"].tobytes(), obs[a]["action_mask"].tobytes()) for a in obs},
                rewards,
                term,
                trunc,
                env.digest(),
                env.state().tobytes(),
            )
        )
    return seen


@pytest.mark.parametrize("copier", COPIERS, ids=["pickle", "deepcopy"])
def test_a_copied_parallel_env_goes_on_exactly_as_the_original(copier: Callable) -> None:
    env = parallel_env(robots=2, teammates=1, max_ticks=400, symbolic=True)
    obs, _ = env.reset(seed=21)
    rng = np.random.default_rng(3)
    play_parallel(env, obs, rng, 25)
    twin = copier(env)
    assert twin is not env and twin._env is not env._env
    assert (twin.digest(), twin.tick, twin.agents) == (env.digest(), env.tick, env.agents)
    assert twin.state().tobytes() == env.state().tobytes()
    # The observation now (the one the next action is chosen from) is the same: step both
    # with "wait" and compare, then play on past the end of the episode (40 steps of 10
    # ticks: the env resets itself from its seed generator, which was copied too).
    o1, *_ = env.step({})
    o2, *_ = twin.step({})
    for a in env.possible_agents:
        np.testing.assert_array_equal(o1[a]["observation"], o2[a]["observation"])
        np.testing.assert_array_equal(o1[a]["action_mask"], o2[a]["action_mask"])
    ours = play_parallel(env, o1, np.random.default_rng(8), 60)
    theirs = play_parallel(twin, o2, np.random.default_rng(8), 60)
    assert any(step[0] == "reset" for step in ours), "the episode ended and a new one began"
    assert ours == theirs
    assert twin.symbolic and twin.spec_native.agents == 2


def test_a_copy_made_before_any_reset_or_after_the_end_is_where_the_original_was() -> None:
    fresh = parallel_env(robots=1)
    assert pickle_round_trip(fresh).digest() == fresh.digest()
    env = parallel_env(robots=1, max_ticks=50)
    env.reset(seed=1)
    while env.agents:
        env.step({"Agent1": 0})
    twin = pickle_round_trip(env)
    assert twin.agents == [] and twin.digest() == env.digest()
    with pytest.raises(RuntimeError, match="reset"):
        twin.step({})


def test_an_unpickled_parallel_env_plays_on_alike_in_another_process() -> None:
    import subprocess
    import sys

    env = parallel_env(robots=2, max_ticks=2000)
    obs, _ = env.reset(seed=5)
    play_parallel(env, obs, np.random.default_rng(1), 30)
    script = (
        "import pickle, sys\n"
        "env = pickle.loads(sys.stdin.buffer.read())\n"
        "for _ in range(20): env.step({'Agent1': 0, 'Agent2': 0})\n"
        "print(env.digest(), env.tick)\n"
    )
    other = subprocess.run(
        [sys.executable, "-c", script], input=pickle.dumps(env), capture_output=True, timeout=120
    )
    assert other.returncode == 0, other.stderr.decode()
    for _ in range(20):
        env.step({"Agent1": 0, "Agent2": 0})
    assert other.stdout.decode().split() == [str(env.digest()), str(env.tick)]


# ---------------------------------------------------------------- the single env


@pytest.mark.parametrize("copier", COPIERS, ids=["pickle", "deepcopy"])
def test_a_copied_single_env_goes_on_exactly_as_the_original(copier: Callable) -> None:
    def play(env: Any, obs: dict, rng: np.random.Generator, steps: int) -> list:
        seen = []
        for _ in range(steps):
            obs, reward, term, trunc, _ = env.step(allowed(obs["action_mask"], rng))
            seen.append((obs["observation"].tobytes(), obs["action_mask"].tobytes(), reward, term, trunc))
            if term or trunc:
                obs, _ = env.reset()  # the next seed of np_random, copied with the env
                seen.append(("reset", obs["observation"].tobytes()))
        return seen

    for env in (single_env(max_ticks=300), gymnasium.make("bw4t/Bw4t-v0", max_ticks=300)):
        obs, _ = env.reset(seed=9)
        play(env, obs, np.random.default_rng(2), 12)
        twin = copier(env)
        o1, *_ = env.step(0)
        o2, *_ = twin.step(0)
        np.testing.assert_array_equal(o1["observation"], o2["observation"])
        ours = play(env, o1, np.random.default_rng(4), 50)
        assert any(s[0] == "reset" for s in ours)
        assert ours == play(twin, o2, np.random.default_rng(4), 50)


# ---------------------------------------------------------------- the vector


@pytest.mark.parametrize("copier", COPIERS, ids=["pickle", "deepcopy"])
def test_a_copied_vector_goes_on_exactly_as_the_original(copier: Callable) -> None:
    vec = vector_env(num_matches=3, robots=2, max_ticks=200, threads=2)
    obs, _ = vec.reset(seed=[4, 5, 6])
    rng = np.random.default_rng(0)
    for _ in range(25):  # episodes of 20 steps: every match has auto-reset once
        obs, *_ = vec.step(np.array([allowed(m, rng) for m in obs["action_mask"]]))
    twin = copier(vec)
    assert [twin.digest(i) for i in range(3)] == [vec.digest(i) for i in range(3)]
    episodes = [vec.episodes(i) for i in range(3)]
    assert min(episodes) >= 2 and [twin.episodes(i) for i in range(3)] == episodes
    np.testing.assert_array_equal(twin.obs, vec.obs)
    np.testing.assert_array_equal(twin.masks, vec.masks)
    for _ in range(50):
        actions = np.array([allowed(m, rng) for m in obs["action_mask"]])
        obs, r1, te1, tr1, i1 = vec.step(actions)
        o2, r2, te2, tr2, i2 = twin.step(actions)
        np.testing.assert_array_equal(obs["observation"], o2["observation"])
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(te1 | tr1, te2 | tr2)
        assert sorted(i1) == sorted(i2)
    assert [twin.digest(i) for i in range(3)] == [vec.digest(i) for i in range(3)]


# ---------------------------------------------------------------- SuperSuit


def test_supersuit_concat_vec_envs_across_two_processes_steps_and_auto_resets() -> None:
    supersuit = pytest.importorskip("supersuit")

    def run() -> list:
        env = parallel_env(robots=2, max_ticks=150)  # episodes of 15 steps
        markov = supersuit.pettingzoo_env_to_vec_env_v1(env)
        vec = supersuit.concat_vec_envs_v1(markov, 4, num_cpus=2, base_class="gymnasium")
        try:
            assert vec.num_envs == 8, "4 copies of 2 agents"
            obs, _ = vec.reset(seed=0)
            rng = np.random.default_rng(0)
            seen, ends = [], 0
            time = dict((n, o) for n, o, _ in env.spec_native.obs_layout)["time"]
            for _ in range(40):
                actions = np.array([allowed(m, rng) for m in obs["action_mask"]])
                obs, rewards, term, trunc, infos = vec.step(actions)
                done = term | trunc
                if done.any():
                    ends += int(done.sum())
                    # Auto-reset: the rows hold the new episode's first observation.
                    assert np.all(obs["observation"][done, time] == 0.0)
                seen.append((obs["observation"].tobytes(), rewards.tobytes(), done.tobytes()))
            assert ends >= 8 * 2, "every copy ended and was reset at least twice"
            return seen
        finally:
            vec.close()

    first = run()
    assert run() == first, "the same seed gives the same trajectories through SuperSuit"


# ---------------------------------------------------------------- memory


def rss_bytes() -> int:
    """Resident memory now, from /proc/self/statm (pages)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def query_spaces(env: Any) -> None:
    for agent in env.possible_agents:
        env.observation_space(agent)
        env.action_space(agent)
    env.state_space


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="needs /proc/self/statm")
def test_thousands_of_environments_whose_spaces_were_queried_are_freed() -> None:
    probe = parallel_env()
    query_spaces(probe)
    gone = weakref.ref(probe)
    del probe
    gc.collect()
    assert gone() is None, "nothing keeps a dropped environment alive"

    for _ in range(300):  # warm up allocators and caches that are bounded
        query_spaces(parallel_env())
    gc.collect()
    # What an environment costs while alive: kept, 300 of them.
    before_kept = rss_bytes()
    kept = [parallel_env() for _ in range(300)]
    for env in kept:
        query_spaces(env)
    per_env = (rss_bytes() - before_kept) / len(kept)
    del kept, env
    gc.collect()

    before = rss_bytes()
    for _ in range(3000):
        query_spaces(parallel_env())
    gc.collect()
    growth = rss_bytes() - before
    leaked = 3000 * per_env
    assert per_env > 20_000, "an environment holds its match and spaces while alive"
    assert growth < leaked / 10, f"3,000 dropped environments grew memory by {growth / 1e6:.1f} MB"
