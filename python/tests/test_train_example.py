"""The training example (examples/train_ppo.py) runs its smoke run: two tiny PPO updates.

Skipped where JAX or optax is not installed (``pip install "bw4t[train]"``).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("jax")
pytest.importorskip("optax")

PYTHON_DIR = Path(__file__).resolve().parents[1]
SCRIPT = PYTHON_DIR / "examples" / "train_ppo.py"


def numbers(value):
    """Every number inside a JSON value."""
    if isinstance(value, bool):
        return
    if isinstance(value, (int, float)):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from numbers(item)
    elif isinstance(value, list):
        for item in value:
            yield from numbers(item)


def test_smoke_run_prints_finite_json_lines():
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--smoke"],
        cwd=PYTHON_DIR,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, f"exit {done.returncode}\nstdout:\n{done.stdout}\nstderr:\n{done.stderr}"
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.strip()]
    updates = [line for line in lines if "update" in line]
    summaries = [line for line in lines if line.get("summary")]
    assert [line["update"] for line in updates] == [1, 2]
    assert len(summaries) == 1 and lines[-1] is summaries[0]
    for line in updates:
        for key in ("global_step", "episodes_ended", "mean_episode_return", "mean_delivered", "sps"):
            assert key in line, key
        assert line["global_step"] > 0
    assert summaries[0]["episodes_ended"] > 0
    for line in lines:
        for x in numbers(line):
            assert math.isfinite(x), line


def test_smoke_run_evaluates_its_policy_on_the_learn_tier(tmp_path):
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--smoke", "--eval-tier", "learn", "--eval-out", str(tmp_path)],
        cwd=PYTHON_DIR,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, f"exit {done.returncode}\nstderr:\n{done.stderr}"
    row = json.loads(done.stdout.splitlines()[-1])["eval"]
    assert (row["tier"], row["split"], row["agent"]["name"]) == ("learn", "dev", "ppo-example")
    assert row["matches"] == row["tasks"] > 0
    assert (tmp_path / "dev" / "row.json").exists()


REFERENCE = PYTHON_DIR.parent / "eval" / "reference.jsonl"


@pytest.mark.skipif(
    not os.environ.get("BW4T_SLOW_TESTS"),
    reason="trains the default run (about 2 minutes); set BW4T_SLOW_TESTS=1 to check the committed PPO rows",
)
def test_the_default_run_reproduces_its_reference_rows(tmp_path):
    committed = [json.loads(l) for l in REFERENCE.read_text().splitlines()]
    committed = [r for r in committed if r["agent"]["name"] == "ppo-example"]
    assert {r["split"] for r in committed} == {"dev", "test"}
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--eval-tier", "learn", "--eval-split", "dev,test", "--eval-out", str(tmp_path)],
        cwd=PYTHON_DIR,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert done.returncode == 0, done.stderr
    rows = [json.loads(l)["eval"] for l in done.stdout.splitlines() if l.startswith('{"eval"')]
    strip = lambda r: {k: v for k, v in r.items() if k != "bw4t_version"}
    assert [strip(r) for r in rows] == [strip(r) for r in committed]
