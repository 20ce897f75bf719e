"""A Python policy on a tier of the bw4t suite, played through the learning environment and
scored by ``bw4t eval score`` against the built-in team on the same tasks.

    python -m bw4t.eval TIER --policy examples/my_policy.py:act [--split dev] [--out DIR]

A policy is a callable ``policy(observations) -> actions`` over the PettingZoo parallel
environment's dicts: ``observations[agent] = {"observation": ..., "action_mask": ...}``
for every robot the agent plays, ``actions[agent] = index``. An object with a ``reset(seed)``
method is told each match's seed first. The tasks (maps, seeds, teammates, tick limits)
come from ``bw4t eval tasks``, the row from ``bw4t eval score``: one source for both, the
command line's. Where a tier allows no messages the ``say_*`` actions are masked out and a
policy that picks one is an error.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import json
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional

import numpy as np

from . import _native
from . import _spec

Policy = Callable[[Dict[str, Dict[str, np.ndarray]]], Dict[str, int]]

#: Visible-block slots: the environments' default, which a policy trained on them expects.
SLOTS = 10


def _bw4t(*args: str) -> str:
    """Runs this package's ``bw4t`` command; its standard output, or ``RuntimeError``. It
    runs from the folder holding this package, so ``-m bw4t`` is this same package whatever
    the caller's working directory holds (paths in ``args`` are absolute)."""
    home = Path(__file__).resolve().parent.parent
    done = subprocess.run([sys.executable, "-m", "bw4t", *args], capture_output=True, text=True, cwd=home)
    if done.returncode != 0:
        raise RuntimeError(f"bw4t {' '.join(args)}: {done.stderr.strip()}")
    return done.stdout


def tasks(tier: str, split: str = "dev", repetitions: int = 1) -> List[Dict[str, Any]]:
    """Every match of ``tier``'s ``split``: key, map, seed, seats, tick limit, messages."""
    text = _bw4t("eval", "tasks", tier, "--split", split, "--repetitions", str(int(repetitions)))
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def play(task: Dict[str, Any], policy: Policy, ticks_per_step: int = 10) -> Dict[str, Any]:
    """One task played by ``policy`` in the agent's seats; its outcome line."""
    seats = ["learner" if s == "agent" else s.split(":", 1)[1] for s in task["seats"]]
    spec = _spec.make_spec(task["map"], seats, ticks_per_step, task["max_ticks"], SLOTS, None)
    env = _native.Env(spec)
    names = list(env.agent_names())
    n = len(names)
    obs = np.empty((n, spec.obs_len), dtype=np.float32)
    masks = np.empty((n, spec.n_actions), dtype=np.int8)
    rewards = np.zeros(n, dtype=np.float32)
    actions = np.zeros(n, dtype=np.uint32)
    silent = np.zeros(spec.n_actions, dtype=bool)
    if not task["messages"]:
        for name, first, count in spec.action_layout:
            if name.startswith("say_"):
                silent[first : first + count] = True
    if hasattr(policy, "reset"):
        policy.reset(task["seed"])
    env.reset(int(task["seed"]), obs, masks.view(np.uint8))
    terminated = truncated = False
    while not (terminated or truncated):
        masks[:, silent] = 0
        chosen = policy({name: {"observation": obs[i], "action_mask": masks[i]} for i, name in enumerate(names)})
        for i, name in enumerate(names):
            action = int(chosen.get(name, 0))
            if silent[action]:
                raise ValueError(f"tier allows no messages, and {name} chose action {action} (a say_ action)")
            actions[i] = action
        terminated, truncated = env.step(actions, obs, masks.view(np.uint8), rewards)
    return {"key": task["key"], "completed": bool(terminated), "ticks": int(env.tick()), "digest": f"{env.digest():016x}"}


def evaluate(
    policy: Policy,
    tier: str,
    *,
    agent: str,
    split: str = "dev",
    repetitions: int = 1,
    ticks_per_step: int = 10,
    out: Optional[str] = None,
    meta: Optional[Dict[str, Any]] = None,
    progress: Callable[[str], None] = lambda line: None,
) -> Dict[str, Any]:
    """Plays every task of ``tier``'s ``split`` with ``policy`` and returns the leaderboard
    row (``agent`` is the row's ``agent.command``; ``meta`` may give ``name``, ``model``,
    ``provider``, ``temperature``, ``harness``). The outcomes and the row go to ``out``.

    A step is ``ticks_per_step`` ticks, so a completion is seen at the end of its step:
    the ticks a row counts are rounded up to a step (1 gives exact ticks)."""
    out_dir = Path(out or f"runs/eval-{tier}-{split}-python").resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    outcomes = out_dir / "outcomes.jsonl"
    with outcomes.open("w") as file:
        for i, task in enumerate(tasks(tier, split, repetitions)):
            line = play(task, policy, ticks_per_step)
            file.write(json.dumps(line) + "\n")
            progress(f"[{i + 1}] {task['key']}: {'completed' if line['completed'] else 'not completed'} at tick {line['ticks']}")
    args = ["eval", "score", tier, "--outcomes", str(outcomes), "--agent", agent, "--split", split]
    args += ["--repetitions", str(int(repetitions)), "--out", str(out_dir)]
    for key, value in (meta or {}).items():
        if value is not None:
            args += [f"--{key}", str(Path(value).resolve()) if key == "leaderboard" else str(value)]
    return json.loads(_bw4t(*args))


def load_policy(text: str) -> Policy:
    """``MODULE:NAME`` or ``path/to/file.py:NAME``: the callable (or a class, made with no
    arguments)."""
    where, _, name = text.rpartition(":")
    if not where or not name:
        raise ValueError(f"--policy {text!r}: give MODULE:NAME or FILE.py:NAME")
    if where.endswith(".py"):
        spec = importlib.util.spec_from_file_location(Path(where).stem, where)
        if spec is None or spec.loader is None:
            raise ValueError(f"--policy {text!r}: cannot load {where}")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    else:
        module = importlib.import_module(where)
    found = getattr(module, name, None)
    if found is None:
        raise ValueError(f"--policy {text!r}: {where} has no {name}")
    return found() if isinstance(found, type) else found


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bw4t.eval", description=__doc__.splitlines()[0])
    parser.add_argument("tier")
    parser.add_argument("--policy", required=True, help="MODULE:NAME or FILE.py:NAME")
    parser.add_argument("--split", default="dev", choices=["dev", "test"])
    parser.add_argument("--repetitions", type=int, default=1)
    parser.add_argument("--ticks-per-step", type=int, default=10)
    parser.add_argument("--out")
    for key in ("name", "model", "provider", "temperature", "harness", "leaderboard"):
        parser.add_argument(f"--{key}")
    args = parser.parse_args(argv)
    try:
        policy = load_policy(args.policy)
        meta = {k: getattr(args, k) for k in ("name", "model", "provider", "temperature", "harness", "leaderboard")}
        row = evaluate(
            policy,
            args.tier,
            agent=f"python:{args.policy}",
            split=args.split,
            repetitions=args.repetitions,
            ticks_per_step=args.ticks_per_step,
            out=args.out,
            meta=meta,
            progress=lambda line: print(line, file=sys.stderr),
        )
    except (ValueError, RuntimeError) as e:
        print(f"python -m bw4t.eval: error: {e}", file=sys.stderr)
        return 1
    print(json.dumps(row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
