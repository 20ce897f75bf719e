"""The learning environments from the wheel: PettingZoo's and Gymnasium's own checks,
whole-episode seeding (in this process and across processes), the vector against single
environments, rendering, and refusals of bad arguments."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys

import numpy as np
import pytest

import gymnasium
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test, parallel_seed_test

from bw4t.env import Bw4tEnv, Rewards, parallel_env, single_env, vector_env


def allowed(mask: np.ndarray, rng: np.random.Generator) -> int:
    """A uniformly random action the mask allows."""
    return int(rng.choice(np.flatnonzero(mask)))


# ---------------------------------------------------------------- the libraries' own tests


def test_pettingzoo_parallel_api_test() -> None:
    parallel_api_test(parallel_env(max_ticks=400), num_cycles=200)


def test_pettingzoo_parallel_api_test_beside_builtin_teammates() -> None:
    parallel_api_test(parallel_env(robots=2, teammates=1, max_ticks=300), num_cycles=100)


def test_pettingzoo_parallel_seed_test() -> None:
    parallel_seed_test(lambda: parallel_env(max_ticks=400), num_cycles=50)


# Counts (blocks of a colour in the room, messages heard in a step) have no upper bound.
@pytest.mark.filterwarnings("ignore:.*maximum value is infinity")
def test_gymnasium_check_env_on_the_single_agent_env() -> None:
    for strategy in ("coop", "baseline", "silent"):
        env = gymnasium.make("bw4t/Bw4t-v0", strategy=strategy, max_ticks=400).unwrapped
        check_env(env, skip_render_check=False)
        assert isinstance(env, Bw4tEnv)


# ---------------------------------------------------------------- seeding whole episodes

EPISODE_SCRIPT = r"""
import hashlib, json, sys
import numpy as np
from bw4t.env import parallel_env

def play(seed, steps):
    env = parallel_env(max_ticks=10**7)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed + 1)
    h = hashlib.sha256()
    total = {a: 0.0 for a in env.possible_agents}
    for _ in range(steps):
        actions = {a: int(rng.choice(np.flatnonzero(obs[a]["action_mask"]))) for a in env.agents}
        obs, rewards, term, trunc, _ = env.step(actions)
        for a in env.possible_agents:
            h.update(obs[a]["observation"].tobytes())
            h.update(obs[a]["action_mask"].tobytes())
            h.update(np.float32(rewards[a]).tobytes())
            total[a] += rewards[a]
        if not env.agents:
            break
    return {"hash": h.hexdigest(), "digest": env.digest(), "tick": env.tick, "total": total}

print(json.dumps(play(int(sys.argv[1]), int(sys.argv[2]))))
"""


def play_in_process(seed: int, steps: int) -> dict:
    namespace: dict = {}
    exec(compile(EPISODE_SCRIPT.split("print(json.dumps")[0], "episode", "exec"), namespace)
    return json.loads(json.dumps(namespace["play"](seed, steps)))


def test_a_seed_reproduces_a_whole_1000_step_episode_here_and_in_another_process() -> None:
    first = play_in_process(11, 1000)
    assert first["tick"] == 10_000, "1,000 steps of 10 ticks were played"
    assert play_in_process(11, 1000) == first
    other = subprocess.run(
        [sys.executable, "-c", EPISODE_SCRIPT, "11", "1000"], capture_output=True, text=True, timeout=300
    )
    assert other.returncode == 0, other.stderr
    assert json.loads(other.stdout) == first
    assert play_in_process(12, 1000)["hash"] != first["hash"], "another seed plays another episode"


def test_the_single_env_reproduces_whole_episodes_and_its_reset_sequence() -> None:
    def run(seed: int) -> tuple:
        env = single_env(max_ticks=3000)
        digests, h = [], hashlib.sha256()
        obs, _ = env.reset(seed=seed)
        rng = np.random.default_rng(0)
        for _ in range(1000):
            obs, reward, term, trunc, _ = env.step(allowed(obs["action_mask"], rng))
            h.update(obs["observation"].tobytes() + np.float32(reward).tobytes())
            if term or trunc:
                digests.append(env.digest())
                obs, _ = env.reset()  # the next seed of the generator seeded above
        return h.hexdigest(), digests, env.digest()

    first = run(5)
    assert len(first[1]) >= 2, "episodes ended and the env reset itself from its generator"
    assert run(5) == first


# ---------------------------------------------------------------- the vector


def test_the_vector_equals_single_envs_with_auto_reset_and_final_observations() -> None:
    matches, robots = 4, 2
    vec = vector_env(num_matches=matches, robots=robots, max_ticks=250, threads=2, seed=3)
    obs, _ = vec.reset(seed=3)
    # Single environments on the seeds the vector's match i plays: its stream from seed 3.
    singles = [parallel_env(robots=robots, max_ticks=250) for _ in range(matches)]
    streams = [_VectorSeeds(3, i) for i in range(matches)]
    single_obs = [env.reset(seed=stream.next())[0] for env, stream in zip(singles, streams)]
    rng = np.random.default_rng(9)
    ended_total = 0
    for step in range(120):
        for i, env in enumerate(singles):
            for a, name in enumerate(env.possible_agents):
                row = i * robots + a
                np.testing.assert_array_equal(obs["observation"][row], single_obs[i][name]["observation"])
                np.testing.assert_array_equal(obs["action_mask"][row], single_obs[i][name]["action_mask"])
            assert vec.digest(i) == env.digest(), f"match {i} step {step}"
        actions = np.array([allowed(m, rng) for m in obs["action_mask"]], dtype=np.int64)
        obs, rewards, term, trunc, infos = vec.step(actions)
        for i, env in enumerate(singles):
            names = env.possible_agents
            o, r, te, tr, _ = env.step({name: int(actions[i * robots + a]) for a, name in enumerate(names)})
            for a, name in enumerate(names):
                row = i * robots + a
                assert rewards[row] == np.float32(r[name])
                assert (term[row], trunc[row]) == (te[name], tr[name])
            if te[names[0]] or tr[names[0]]:
                ended_total += 1
                for a, name in enumerate(names):
                    row = i * robots + a
                    assert infos["_final_obs"][row]
                    np.testing.assert_array_equal(infos["final_obs"][row]["observation"], o[name]["observation"])
                o, _ = env.reset(seed=streams[i].next())
            single_obs[i] = o
    assert ended_total >= matches, "every match ended and was reset at least once"


class _VectorSeeds:
    """The seeds match ``index`` of a vector seeded with ``base`` plays (SplitMix64, as in
    the Rust crate's SeedStream): checked here against the vector itself."""

    MASK = (1 << 64) - 1

    def __init__(self, base: int, index: int) -> None:
        mixed = self._splitmix(base ^ ((index * 0xD1B54A32D192ED03) & self.MASK))[1]
        self.state = mixed

    @classmethod
    def _splitmix(cls, state: int) -> tuple:
        state = (state + 0x9E3779B97F4A7C15) & cls.MASK
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & cls.MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & cls.MASK
        return state, z ^ (z >> 31)

    def next(self) -> int:
        self.state, value = self._splitmix(self.state)
        return value


def test_the_vector_of_one_learner_among_teammates_has_one_row_per_match() -> None:
    vec = vector_env(num_matches=3, robots=1, teammates=2, strategy="baseline", max_ticks=500)
    obs, _ = vec.reset(seed=1)
    assert vec.num_envs == 3
    assert obs["observation"].shape == (3, vec.single_observation_space["observation"].shape[0])
    assert vec.observation_space.contains(obs)
    for _ in range(60):
        obs, rewards, term, trunc, _ = vec.step(vec.action_space.sample())
    assert rewards.dtype == np.float32 and term.dtype == np.bool_


def test_the_vector_copies_unless_asked_not_to() -> None:
    copying = vector_env(num_matches=2)
    obs, _ = copying.reset(seed=0)
    obs2, *_ = copying.step(np.zeros(copying.num_envs, dtype=np.int64))
    assert obs["observation"] is not obs2["observation"]
    shared = vector_env(num_matches=2, copy=False)
    obs, _ = shared.reset(seed=0)
    obs2, *_ = shared.step(np.zeros(shared.num_envs, dtype=np.int64))
    assert obs2["observation"] is shared.obs, "copy=False returns the vector's own arrays"


# ---------------------------------------------------------------- encoding, rewards, render


def test_spaces_follow_the_documented_layout() -> None:
    env = parallel_env()
    spec = env.spec_native
    assert spec.obs_len == 251 and spec.n_actions == 70
    layout = {name: (offset, length) for name, offset, length in spec.obs_layout}
    assert layout["at"] == (0, 28) and layout["messages"] == (219, 31) and layout["time"] == (250, 1)
    actions = {name: (first, count) for name, first, count in spec.action_layout}
    assert actions["go_to"] == (1, 28) and actions["say_going_to"] == (60, 10)
    obs, _ = env.reset(seed=2)
    o = obs["Agent1"]["observation"]
    assert o[0:28].sum() == 1, "at: one place, one-hot"
    at = spec.places[int(np.argmax(o[0:28]))]
    assert at in spec.places


def test_a_message_sent_is_counted_in_the_receivers_observation() -> None:
    env = parallel_env(robots=2, symbolic=True)
    obs, _ = env.reset(seed=4)
    spec = env.spec_native
    first, _ = {n: (f, c) for n, f, c in spec.action_layout}["say_going_to"]
    offset, _ = {n: (o, c) for n, o, c in spec.obs_layout}["messages"]
    kind = spec.message_kinds.index("going_to")
    obs, _, _, _, infos = env.step({"Agent1": first, "Agent2": 0})
    assert obs["Agent2"]["observation"][offset + kind] == 1.0
    assert obs["Agent1"]["observation"][offset + kind] == 0.0
    assert infos["Agent1"]["outcome"] == "accepted"
    heard = [f for f in infos["Agent2"]["delta"]["add"] if f[0] == "message"]
    assert heard and heard[0][1] == "Agent1" and heard[0][3]["kind"] == "going_to"
    assert any(f[0] == "at" for f in infos["Agent2"]["percepts"])


def test_rewards_are_configurable() -> None:
    env = parallel_env(rewards=Rewards(step_cost=0.25, mode="individual"))
    env.reset(seed=0)
    _, rewards, *_ = env.step({})
    assert all(r == pytest.approx(-0.25) for r in rewards.values())


def test_render_gives_an_rgb_array_and_the_svg() -> None:
    env = parallel_env(render_mode="rgb_array")
    env.reset(seed=0)
    image = env.render()
    assert image.dtype == np.uint8 and image.ndim == 3 and image.shape[2] == 3
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 5, "zones, walls, blocks and robots in colours"
    svg = env.render_svg()
    assert svg.startswith("<svg") and svg.count('class="robot"') == 3
    svg_env = parallel_env(render_mode="svg")
    svg_env.reset(seed=0)
    assert svg_env.render() == svg


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"map": "no-such-map"}, "no-such-map"),
        ({"strategy": "chaos"}, "unknown strategy 'chaos'"),
        ({"robots": 0}, "at least one learning robot"),
        ({"robots": 40}, "spawn points"),
        ({"ticks_per_step": 0}, "ticks_per_step"),
        ({"max_ticks": 0}, "max_ticks"),
        ({"rewards": Rewards(mode="everyone")}, "reward_mode"),
        ({"render_mode": "human"}, "render_mode 'human'"),
    ],
)
def test_bad_arguments_are_refused_naming_the_problem(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        parallel_env(**kwargs)


def test_wrong_arrays_to_the_native_vector_are_refused() -> None:
    vec = vector_env(num_matches=2, copy=False)
    vec.reset(seed=0)
    native = vec._vec
    rows = vec.num_envs
    good = dict(
        actions=np.zeros(rows, dtype=np.uint32),
        obs=vec.obs,
        masks=vec._masks_u8,
        rewards=vec.rewards,
        terminated=vec.terminations,
        truncated=vec.truncations,
    )
    native.step(*good.values())
    with pytest.raises(ValueError, match="actions holds 5 values"):
        native.step(np.zeros(5, dtype=np.uint32), *list(good.values())[1:])
    with pytest.raises(ValueError, match="C-contiguous"):
        strided = np.zeros((rows, vec.obs.shape[1] * 2), dtype=np.float32)[:, ::2]
        native.step(good["actions"], strided, *list(good.values())[2:])
    with pytest.raises(TypeError):
        native.step(good["actions"], vec.obs.astype(np.float64), *list(good.values())[2:])
