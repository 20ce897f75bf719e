"""`python -m bw4t.bench` prints one JSON line per case with consistent counts (its speed
is measured, not tested)."""

from __future__ import annotations

import json
import subprocess
import sys


def test_the_bench_reports_every_path_with_consistent_counts() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "bw4t.bench", "--steps", "200", "--vector-steps", "5", "--tcp-ticks", "50"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr
    rows = [json.loads(line) for line in out.stdout.splitlines()]
    cases = [(r["case"], r.get("envs"), r.get("ticks_per_step")) for r in rows]
    for tps in (1, 10):
        assert ("single", 1, tps) in cases and ("vector", 64, tps) in cases and ("vector", 256, tps) in cases
    assert ("tcp", 1, 1) in cases and any(r["case"] == "vector_memory" for r in rows)
    for r in rows:
        if "agent_steps" in r:
            assert r["agent_steps"] == r["steps"] * r["envs"] * r["agents"]
            assert r["agent_steps_per_s"] > 0
    assert next(r for r in rows if r["case"] == "vector_memory")["kb_per_match"] > 0


def test_the_bench_refuses_an_unknown_case() -> None:
    out = subprocess.run([sys.executable, "-m", "bw4t.bench", "--cases", "warp"], capture_output=True, text=True)
    assert out.returncode == 2 and "unknown case(s): warp" in out.stderr
