"""`python -m bw4t.bench` prints one JSON line per case with consistent counts (its speed
is measured, not tested)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest


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


def test_the_bench_mcp_case_reports_round_trips_and_both_clients_matches() -> None:
    pytest.importorskip("mcp", reason="the MCP SDK (mcp) is not installed; it needs Python 3.10 or newer")
    out = subprocess.run(
        [sys.executable, "-m", "bw4t.bench", "--cases", "mcp", "--mcp-calls", "20", "--mcp-ticks", "2000"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    rows = [json.loads(line) for line in out.stdout.splitlines()]
    trips = [r for r in rows if r["case"] == "mcp_round_trip"]
    assert len(trips) == 2 and trips[0]["transport"] == "stdio" and "HTTP" in trips[1]["transport"]
    for r in trips:
        assert {"calls", "look_p50_ms", "look_p99_ms", "wait_tick_p50_ms", "wait_tick_p99_ms"} <= set(r)
    matches = {r["client"]: r for r in rows if r["case"] == "mcp_match"}
    assert sorted(matches) == ["mcp", "tcp"]
    for r in matches.values():
        assert {"ticks", "seconds", "ticks_per_s", "path"} <= set(r)
    assert "tool_calls" in matches["mcp"] and "actions" in matches["tcp"]
    assert len(rows) == 4
