"""The ecosystems' APIs beyond the basic loop: ``gymnasium.make_vec`` giving the Rust
vector, Gymnasium's seed lists, ``reset_mask`` and same-step ``final_obs``/``final_info``,
PettingZoo's AEC API test through ``parallel_to_aec``, and ``state()`` for centralised
critics with PettingZoo's ``state_test``."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from pettingzoo.test import api_test, state_test
from pettingzoo.utils.conversions import parallel_to_aec

from bw4t.env import Bw4tVectorEnv, parallel_env, single_env, vector_env

MASK64 = (1 << 64) - 1


def allowed(mask: np.ndarray, rng: np.random.Generator) -> int:
    return int(rng.choice(np.flatnonzero(mask)))


class SeedStream:
    """The seeds of a stream seeded with ``seed`` (SplitMix64, as the Rust SeedStream)."""

    def __init__(self, seed: int) -> None:
        self.state = seed

    def next(self) -> int:
        self.state = (self.state + 0x9E3779B97F4A7C15) & MASK64
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
        return z ^ (z >> 31)


# ---------------------------------------------------------------- gymnasium.make_vec


def test_make_vec_gives_the_rust_vector_of_the_single_agent_setting() -> None:
    vec = gymnasium.make_vec("bw4t/Bw4t-v0", 3, max_ticks=200, strategy="baseline", threads=2)
    assert isinstance(vec.unwrapped, Bw4tVectorEnv), "the vector entry point, not N Python envs"
    assert vec.num_envs == 3 and vec.unwrapped.num_matches == 3
    assert vec.spec is not None and vec.spec.kwargs["vectorization_mode"] == "vector_entry_point"
    assert vec.single_observation_space == gymnasium.make("bw4t/Bw4t-v0").observation_space
    assert len(vec.unwrapped.spec_native.rooms) > 0 and vec.unwrapped.spec_native.agents == 1
    with pytest.raises(ValueError, match="render_mode: the vector does not render"):
        gymnasium.make_vec("bw4t/Bw4t-v0", 2, render_mode="rgb_array")
    with pytest.raises(ValueError, match="robots: make_vec's vector has one learner"):
        gymnasium.make_vec("bw4t/Bw4t-v0", 2, robots=2)


def test_seed_lists_and_final_info_match_single_envs_episode_after_episode() -> None:
    seeds = [11, 12, 13]
    vec = gymnasium.make_vec("bw4t/Bw4t-v0", 3, max_ticks=150, threads=2)
    singles = [single_env(max_ticks=150) for _ in seeds]
    obs, _ = vec.reset(seed=seeds)
    single_obs = [env.reset(seed=s)[0] for env, s in zip(singles, seeds)]
    streams = [SeedStream(s) for s in seeds]
    rng = np.random.default_rng(1)
    ended = 0
    for _ in range(40):  # episodes of 15 steps
        for i, o in enumerate(single_obs):
            np.testing.assert_array_equal(obs["observation"][i], o["observation"])
            np.testing.assert_array_equal(obs["action_mask"][i], o["action_mask"])
        actions = np.array([allowed(m, rng) for m in obs["action_mask"]])
        obs, rewards, term, trunc, infos = vec.step(actions)
        for i, env in enumerate(singles):
            o, r, te, tr, _ = env.step(int(actions[i]))
            assert (rewards[i], term[i], trunc[i]) == (np.float32(r), te, tr)
            if te or tr:
                ended += 1
                assert infos["_final_obs"][i] and infos["_final_info"][i]
                np.testing.assert_array_equal(infos["final_obs"][i]["observation"], o["observation"])
                final = infos["final_info"]
                assert final["_ticks"][i] and final["ticks"][i] == env.tick == 150
                assert final["sequence_index"][i] == env.stats()["sequence_index"]
                assert final["digest"][i] == env.digest()
                # Later episodes: the stream seeded with the list's seed.
                o, _ = env.reset(seed=streams[i].next())
            elif "_final_obs" in infos:
                assert not infos["_final_obs"][i] and not infos["_final_info"][i]
            single_obs[i] = o
    assert ended >= 6, "every match ended twice and was reset from its seed's stream"


def test_reset_mask_starts_only_the_marked_matches_anew() -> None:
    vec = vector_env(num_matches=3, robots=2, max_ticks=400, threads=1)
    obs, _ = vec.reset(seed=[1, 2, 3])
    for _ in range(5):
        obs, *_ = vec.step(np.zeros(vec.num_envs, dtype=np.int64))
    digests = [vec.digest(i) for i in range(3)]
    mask = np.array([False, False, True, True, False, False])  # match 1's two rows
    again, infos = vec.reset(seed=[None, None, 77, 77, 5, 5], options={"reset_mask": mask})
    assert infos == {}
    np.testing.assert_array_equal(again["observation"][~mask], obs["observation"][~mask])
    assert [vec.digest(0), vec.digest(2)] == [digests[0], digests[2]]
    assert vec.match_tick(0) == 50 and vec.match_tick(1) == 0 and vec.episodes(1) == 2
    fresh, _ = parallel_env(robots=2, max_ticks=400).reset(seed=77)
    np.testing.assert_array_equal(again["observation"][2], fresh["Agent1"]["observation"])
    np.testing.assert_array_equal(again["observation"][3], fresh["Agent2"]["observation"])
    # One flag per match is taken too; without a seed the match takes its stream's next.
    vec.reset(options={"reset_mask": np.array([True, False, False])})
    assert vec.match_tick(0) == 0 and vec.match_tick(2) == 50 and vec.episodes(0) == 2
    with pytest.raises(ValueError, match="rows of match 0 must be alike"):
        vec.reset(options={"reset_mask": np.array([True, False, False, False, False, False])})
    with pytest.raises(ValueError, match="at least one match"):
        vec.reset(options={"reset_mask": np.zeros(6, dtype=bool)})
    with pytest.raises(TypeError, match="dtype bool"):
        vec.reset(options={"reset_mask": np.ones(6, dtype=np.int8)})
    with pytest.raises(TypeError, match="must be a NumPy array"):
        vec.reset(options={"reset_mask": [True] * 6})
    with pytest.raises(ValueError, match="reset_mask'] holds 4 values; it must hold 6"):
        vec.reset(options={"reset_mask": np.ones(4, dtype=bool)})
    with pytest.raises(ValueError, match="give seed as a list"):
        vec.reset(seed=3, options={"reset_mask": np.ones(3, dtype=bool)})
    with pytest.raises(ValueError, match="seed holds 2 values"):
        vec.reset(seed=[1, 2])


def test_gymnasium_vector_wrappers_run_on_the_vector() -> None:
    from gymnasium.wrappers.vector import RecordEpisodeStatistics

    vec = RecordEpisodeStatistics(gymnasium.make_vec("bw4t/Bw4t-v0", 2, max_ticks=100))
    obs, _ = vec.reset(seed=[0, 1])
    episodes = 0
    for _ in range(25):
        obs, _, term, trunc, infos = vec.step(np.zeros(2, dtype=np.int64))
        if "episode" in infos:
            episodes += int(infos["_episode"].sum())
            assert np.all(infos["episode"]["l"][infos["_episode"]] == 10)
    assert episodes == 4


# ---------------------------------------------------------------- PettingZoo: AEC and state


def test_pettingzoo_aec_api_test_through_parallel_to_aec() -> None:
    api_test(parallel_to_aec(parallel_env(robots=2, max_ticks=300)), num_cycles=60)


@pytest.mark.filterwarnings("ignore:.*maximum state space value is infinity")
def test_pettingzoo_state_test() -> None:
    env = parallel_env(robots=2, teammates=1, max_ticks=300)
    state_test(parallel_to_aec(env), env, num_cycles=40)


def test_the_state_is_the_whole_world_laid_out_as_documented() -> None:
    env = parallel_env(robots=2, teammates=1, max_ticks=2000)
    spec = env.spec_native
    assert env.state_space.shape == (spec.state_len,)
    layout = {name: (offset, length) for name, offset, length in spec.state_layout}
    n, r, c, length = 3, len(spec.rooms), len(spec.colours), 6
    expected = {
        "robot_position": n * 2,
        "robot_room": n * (r + 1),
        "robot_state": n * 3,
        "robot_holding": n * c,
        "room_blocks": r * c,
        "sequence": length * c,
        "sequence_index": length + 1,
        "delivered": length,
        "time": 1,
    }
    assert {k: v[1] for k, v in layout.items()} == expected
    assert sum(expected.values()) == spec.state_len
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(2)
    for step in range(120):
        state = env.state()
        assert env.state_space.contains(state)
        seg = {k: state[o : o + ln] for k, (o, ln) in layout.items()}
        assert np.all(seg["robot_room"].reshape(n, r + 1).sum(axis=1) == 1), "each robot in one room or none"
        assert np.all(seg["robot_state"].reshape(n, 3).sum(axis=1) == 1)
        assert np.all(seg["robot_holding"].reshape(n, c).sum(axis=1) <= 1)
        assert np.all((seg["robot_position"] >= 0) & (seg["robot_position"] <= 1))
        assert seg["sequence_index"].argmax() == env.stats()["sequence_index"]
        assert seg["time"][0] == pytest.approx(env.tick / 2000)
        # The learners' own observations agree with the state: the sequence, and the
        # block colours a learner sees in its room are lying in that room.
        o = obs["Agent1"]["observation"]
        obs_layout = {name: (off, ln) for name, off, ln in spec.obs_layout}
        so, sl = obs_layout["sequence"]
        np.testing.assert_array_equal(o[so : so + sl], seg["sequence"])
        room = seg["robot_room"].reshape(n, r + 1)[0].argmax()
        if room < r and step > 0:
            co, cl = obs_layout["room_colours"]
            assert np.all(seg["room_blocks"].reshape(r, c)[room] >= o[co : co + cl])
        if not env.agents:
            break
        obs, *_ = env.step({a: allowed(obs[a]["action_mask"], rng) for a in env.agents})
    assert step > 100, "the episode was played"
