"""Offline datasets from replays: ``bw4t replay trajectories --format env`` (or
``bw4t study export --trajectories --format env``) writes each robot's trajectory in the
single-learner environment's encoding; :func:`minari_dataset` makes a Minari dataset of
them, one episode per robot and replay, whose spaces are ``bw4t.env.single_env``'s.

Needs Minari with its HDF5 storage (``pip install "bw4t[datasets]"``, Python 3.11 or
newer, as Minari is). :func:`read_export` reads the files without Minari.

Command line: ``python -m bw4t.datasets DATASET_ID EXPORT_DIR...``.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Dict, Iterable, List, Optional, Sequence, Union

import numpy as np

from . import _spec

PathLike = Union[str, Path]


@dataclass
class Episode:
    """One robot's trajectory of one replay, as arrays."""

    #: The export directory it came from (one replay's).
    directory: Path
    #: The robot's player name.
    robot: str
    #: The replay's labels (a study trial's ``participant``, ``condition``, ``trial``).
    labels: Dict[str, str]
    #: ``(steps + 1, obs_len)`` float32: every observation, the last one's after the last step.
    observations: np.ndarray
    #: ``(steps + 1, n_actions)`` int8: the action mask with each observation.
    action_masks: np.ndarray
    #: ``(steps,)`` int64: the action index of each step.
    actions: np.ndarray
    #: ``(steps,)`` float32.
    rewards: np.ndarray
    #: ``(steps,)`` bool: the sequence was completed in the step.
    terminations: np.ndarray
    #: ``(steps,)`` bool: the episode ended otherwise (tick limit, the robot left, the replay ended).
    truncations: np.ndarray
    #: ``(steps + 1,)`` int64: the tick of each observation.
    ticks: np.ndarray
    #: ``(steps,)`` int32: actions the robot took in the step, and how many of them the action leaves out.
    taken: np.ndarray
    left_out: np.ndarray


@dataclass
class Export:
    """Every episode of some export directories, and the encoding they share."""

    #: ``meta.json``'s ``env``: ``obs_len``, ``n_actions``, layouts, rewards, ``ticks_per_step``, ...
    encoding: Dict[str, Any]
    episodes: List[Episode]

    def observation_space(self):
        """The environment's observation space for this encoding (``bw4t.env``'s)."""
        e = self.encoding
        layout = [(s["name"], s["offset"], s["len"]) for s in e["obs_layout"]]
        spec = SimpleNamespace(obs_len=e["obs_len"], n_actions=e["n_actions"], obs_layout=layout)
        return _spec.observation_space(spec)

    def action_space(self):
        """The environment's action space for this encoding."""
        return _spec.action_space(SimpleNamespace(n_actions=self.encoding["n_actions"]))


def _replay_dirs(paths: Iterable[PathLike]) -> List[Path]:
    """Each path is one replay's directory (with ``meta.json``) or a directory of them."""
    dirs: List[Path] = []
    for path in map(Path, paths):
        if (path / "meta.json").is_file():
            dirs.append(path)
        elif path.is_dir():
            found = sorted(p.parent for p in path.glob("*/meta.json"))
            if not found:
                raise ValueError(f"{path}: no meta.json in it or its subdirectories (not a trajectories export)")
            dirs.extend(found)
        else:
            raise ValueError(f"{path}: not a directory of exported trajectories")
    return dirs


def read_export(paths: Union[PathLike, Sequence[PathLike]]) -> Export:
    """Reads ``env`` trajectory exports: directories written by ``bw4t replay trajectories
    --format env`` (one per replay, or a directory holding them). Raises ``ValueError``
    naming the file for a symbolic export, exports with different encodings (another map,
    slot count or step length) or a malformed line."""
    if isinstance(paths, (str, Path)):
        paths = [paths]
    encoding: Optional[Dict[str, Any]] = None
    first: Optional[Path] = None
    episodes: List[Episode] = []
    for directory in _replay_dirs(paths):
        meta = json.loads((directory / "meta.json").read_text())
        if meta.get("kind") != "env" or not meta.get("env"):
            raise ValueError(
                f"{directory}/meta.json: a {meta.get('kind')!r} export; a dataset needs "
                "`bw4t replay trajectories --format env`"
            )
        env = meta["env"]
        shape = {k: env[k] for k in ("obs_len", "n_actions", "obs_layout", "action_layout")}
        if encoding is None:
            encoding, first = env, directory
        elif shape != {k: encoding[k] for k in shape}:
            raise ValueError(f"{directory}: its spaces differ from {first}'s (another map or slot count)")
        for robot in meta["robots"]:
            episodes.append(_episode(directory, robot, meta.get("labels") or {}, env))
    if encoding is None:
        raise ValueError("no exported trajectories given")
    return Export(encoding=encoding, episodes=episodes)


def _episode(directory: Path, robot: Dict[str, Any], labels: Dict[str, str], env: Dict[str, Any]) -> Episode:
    path = directory / robot["file"]
    lines = []
    with path.open() as f:
        for number, text in enumerate(f, 1):
            try:
                lines.append(json.loads(text))
            except json.JSONDecodeError as e:
                raise ValueError(f"{path}:{number}: not a JSON line: {e}") from None
    steps = [line["then"] for line in lines[:-1]]
    if not lines or lines[-1]["then"] is not None or any(s is None for s in steps):
        raise ValueError(f"{path}: every line but the last must hold a step, and the last none")
    observations = np.asarray([line["observation"] for line in lines], dtype=np.float32)
    masks = np.asarray([line["action_mask"] for line in lines], dtype=np.int8)
    if observations.shape[1:] != (env["obs_len"],) or masks.shape[1:] != (env["n_actions"],):
        raise ValueError(f"{path}: observations or masks not of the meta's lengths")
    return Episode(
        directory=directory,
        robot=robot["name"],
        labels=dict(labels),
        observations=observations,
        action_masks=masks,
        actions=np.asarray([s["action"] for s in steps], dtype=np.int64),
        rewards=np.asarray([s["reward"] for s in steps], dtype=np.float32),
        terminations=np.asarray([s["terminated"] for s in steps], dtype=bool),
        truncations=np.asarray([s["truncated"] for s in steps], dtype=bool),
        ticks=np.asarray([line["tick"] for line in lines], dtype=np.int64),
        taken=np.asarray([s["taken"] for s in steps], dtype=np.int32),
        left_out=np.asarray([s["left_out"] for s in steps], dtype=np.int32),
    )


def minari_dataset(
    paths: Union[PathLike, Sequence[PathLike]],
    dataset_id: str,
    *,
    description: Optional[str] = None,
    author: Optional[str] = None,
    **kwargs: Any,
):
    """A Minari dataset (``minari.create_dataset_from_buffers``) of ``env`` trajectory
    exports: one episode per robot and replay with at least one step, observations as the
    environment's ``{"observation", "action_mask"}``, the environment's spaces; each
    episode's ``options`` hold the replay directory, the robot and the replay's labels, its
    infos the tick of each observation and the actions taken and left out per step.
    Returns the dataset (``minari.load_dataset(dataset_id)`` reads it again). Other keyword
    arguments go to ``create_dataset_from_buffers``."""
    try:
        import minari
        from minari.data_collector import EpisodeBuffer
    except ImportError as e:
        raise ImportError(f'bw4t.datasets needs Minari: pip install "bw4t[datasets]" ({e})') from None
    export = read_export(paths)
    buffers = []
    for episode in export.episodes:
        if len(episode.actions) == 0:
            continue
        last = np.zeros(1, dtype=np.int32)
        buffers.append(
            EpisodeBuffer(
                id=len(buffers),
                options={"replay": str(episode.directory), "robot": episode.robot, **episode.labels},
                observations={"observation": episode.observations, "action_mask": episode.action_masks},
                actions=episode.actions,
                rewards=episode.rewards,
                terminations=episode.terminations,
                truncations=episode.truncations,
                infos={
                    "tick": episode.ticks,
                    # One per observation, as infos are: the last observation took no step.
                    "taken": np.concatenate([episode.taken, last]),
                    "left_out": np.concatenate([episode.left_out, last]),
                },
            )
        )
    if not buffers:
        raise ValueError("the exports hold no episode with a step")
    return minari.create_dataset_from_buffers(
        dataset_id,
        buffers,
        observation_space=export.observation_space(),
        action_space=export.action_space(),
        description=description
        or "BW4T robots' trajectories re-simulated from replays, in the single-learner environment's encoding",
        author=author,
        **{"algorithm_name": "bw4t replay trajectories", **kwargs},
    )


def main(argv: Optional[List[str]] = None) -> int:
    """``python -m bw4t.datasets DATASET_ID EXPORT_DIR...``."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m bw4t.datasets",
        description="Make a Minari dataset of `bw4t replay trajectories --format env` exports.",
    )
    parser.add_argument("dataset_id", help="the Minari dataset id, e.g. bw4t/coop/default-v0")
    parser.add_argument("exports", nargs="+", help="export directories (one replay's, or one holding them)")
    args = parser.parse_args(argv)
    try:
        dataset = minari_dataset(args.exports, args.dataset_id)
    except (ValueError, ImportError) as e:
        print(f"bw4t.datasets: error: {e}", file=sys.stderr)
        return 1
    print(f"{args.dataset_id}: {dataset.total_episodes} episodes, {dataset.total_steps} steps")
    return 0


if __name__ == "__main__":
    sys.exit(main())
