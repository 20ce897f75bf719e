"""Datasets from replays: a headless match's replay exported with ``bw4t replay
trajectories --format env``, made a Minari dataset by ``bw4t.datasets`` and loaded back
with ``minari.load_dataset``: episodes, rewards and spaces as the environment's."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from bw4t.datasets import minari_dataset, read_export
from bw4t.env import single_env

minari = pytest.importorskip(
    "minari", reason='Minari is not installed (pip install "bw4t[datasets]"; it needs Python 3.11 or newer)'
)
pytest.importorskip("h5py", reason="Minari's HDF5 storage needs h5py (minari[hdf5])")


def _run(args: list) -> subprocess.CompletedProcess:
    done = subprocess.run(args, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done


@pytest.fixture(scope="module")
def exported(bw4t_bin: str, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Seed 5 of the default map by three built-in robots, exported one tick per step."""
    tmp = tmp_path_factory.mktemp("datasets")
    replay = tmp / "match.jsonl"
    run = _run([bw4t_bin, "run", "--map", "default", "--robots", "3", "--seed", "5", "--json", "--replay", str(replay)])
    (tmp / "result.json").write_text(run.stdout)
    out = tmp / "export"
    _run([bw4t_bin, "replay", "trajectories", str(replay), "--out", str(out), "--format", "env", "--ticks-per-step", "1"])
    return out


def test_an_exported_replay_is_a_minari_dataset_with_the_environments_spaces(
    exported: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    result = json.loads((exported.parent / "result.json").read_text())
    made = minari_dataset(exported, "bw4t/coop-default-v0")
    loaded = minari.load_dataset("bw4t/coop-default-v0")
    env = single_env(map=str(exported / "match" / "map.toml"), teammates=2, ticks_per_step=1)
    for dataset in (made, loaded):
        assert dataset.observation_space == env.observation_space
        assert dataset.action_space == env.action_space
        assert dataset.total_episodes == 3
        assert dataset.total_steps == 3 * result["ticks"]
    export = read_export(exported)
    first_obs, _ = env.reset(seed=5)
    for episode, expected in zip(loaded.iterate_episodes(), export.episodes):
        assert episode.actions.shape == (result["ticks"],)
        np.testing.assert_array_equal(episode.observations["observation"], expected.observations)
        np.testing.assert_array_equal(episode.observations["action_mask"], expected.action_masks)
        np.testing.assert_array_equal(episode.actions, expected.actions)
        # The match completed: the last step terminates, and the team's rewards add up to
        # its deliveries less the cost of every step.
        assert episode.terminations[-1] and not episode.truncations.any()
        assert not episode.terminations[:-1].any()
        expected_return = result["good_drops"] - 0.5 * result["wrong_drops"] - 0.001 * result["ticks"]
        assert float(np.sum(episode.rewards)) == pytest.approx(expected_return, abs=1e-3)
        # Every chosen action was allowed by the mask of its observation.
        masks = episode.observations["action_mask"][:-1]
        assert (masks[np.arange(len(episode.actions)), episode.actions] == 1).all()
    # Robot 0's first observation is the environment's own at reset on the same seed.
    np.testing.assert_array_equal(export.episodes[0].observations[0], first_obs["observation"])
    np.testing.assert_array_equal(export.episodes[0].action_masks[0], first_obs["action_mask"])


def test_a_symbolic_export_or_a_wrong_directory_is_refused_by_name(
    bw4t_bin: str, exported: Path, tmp_path: Path
) -> None:
    symbolic = tmp_path / "symbolic"
    _run([bw4t_bin, "replay", "trajectories", str(exported.parent / "match.jsonl"), "--out", str(symbolic)])
    with pytest.raises(ValueError, match="--format env"):
        read_export(symbolic)
    with pytest.raises(ValueError, match="not a trajectories export"):
        read_export(tmp_path)
