"""The in-process match (bw4t.sim.Match) and the bw4t command from the wheel."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from bw4t.sim import Match, shipped_maps


def walk(m: Match, player: str, act: tuple, limit: int = 2000) -> str:
    """Gives ``act`` and ticks until the robot stops; returns its last state."""
    m.step({player: act})
    for _ in range(limit):
        m.step()
        if m.beliefs(player).state != "traveling":
            break
    return str(m.beliefs(player).state)


def test_a_robot_driven_by_protocol_actions_delivers_the_first_colour() -> None:
    m = Match(map="default", seed=7, players=1, teammates=0)
    me = "Agent1"
    b = m.beliefs(me)
    wanted = b.sequence[0]
    rooms = [p for p in b.places if p.startswith("Room")]
    found = None
    for room in rooms:
        if walk(m, me, ("goTo", [room])) != "arrived":
            continue
        found = next((blk for blk, colour in b.colors.items() if colour == wanted), None)
        if found is not None:
            break
    assert found is not None, f"some room holds a {wanted} block"
    assert walk(m, me, ("goToBlock", [found])) == "arrived"
    m.step({me: ("pickUp", [])})
    m.step()
    assert m.outcomes()[me] == "waited" and b.holding == found
    assert walk(m, me, ("goTo", ["DropZone"])) == "arrived"
    m.step({me: ["putDown"]})
    m.step()
    stats = m.stats()
    assert stats["sequence_index"] == 1 and stats["good_drops"] == 1
    assert stats["robots"][me]["good_drops"] == 1
    assert b.sequence_index == 1, "the robot's own beliefs say so too"


def test_a_refused_action_reports_the_protocols_code() -> None:
    m = Match(seed=1, players=1, teammates=0)
    m.step({"Agent1": ("pickUp", [])})
    assert m.outcomes()["Agent1"].startswith("rejected:")
    with pytest.raises(ValueError, match="goTo"):
        m.step({"Agent1": ("goTo", [])})
    with pytest.raises(KeyError, match="no such player: Nobody"):
        m.step({"Nobody": ("goTo", ["RoomA1"])})


def test_messages_reach_built_in_teammates_and_their_answers_come_back() -> None:
    m = Match(seed=3, players=1, teammates=2)
    said = {"kind": "what_in", "room": "RoomB2"}
    m.step({"Agent1": ("sendMessage", ["all", said])})
    heard = []
    for _ in range(200):
        heard += [msg for msg in m.step()["Agent1"]["messages"]]
        if heard:
            break
    assert heard, "a built-in teammate answered the question"
    assert heard[0].sender in ("Bot1", "Bot2")


def test_the_same_seed_and_actions_give_the_same_match() -> None:
    def play() -> tuple:
        m = Match(seed=9, players=1, teammates=2)
        m.step({"Agent1": ("goTo", ["RoomC3"])})
        m.run(3000)
        return m.digest(), m.tick, m.stats()

    first = play()
    assert first[1] > 0
    assert play() == first
    m = Match(seed=1, players=1, teammates=2)
    m.reset(9)
    m.step({"Agent1": ("goTo", ["RoomC3"])})
    m.run(3000)
    assert (m.digest(), m.tick) == first[:2], "reset(seed) starts the same match as a new one"
    assert "default" in shipped_maps()


def bw4t_script() -> str:
    """The `bw4t` command the wheel installed beside this Python."""
    script = Path(sys.executable).with_name("bw4t")
    found = str(script) if script.exists() else shutil.which("bw4t")
    if not found:
        pytest.fail(f"no bw4t command beside {sys.executable}: install the bw4t wheel")
    return found


def test_the_wheels_bw4t_command_plays_the_same_match_as_the_executable(bw4t_bin: str) -> None:
    script = bw4t_script()
    version = subprocess.run([script, "--version"], capture_output=True, text=True, timeout=60)
    assert version.returncode == 0 and version.stdout.startswith("bw4t ")
    args = ["run", "--seed", "5", "--map", "fixed", "--json"]
    ours = subprocess.run([script, *args], capture_output=True, text=True, timeout=300)
    theirs = subprocess.run([bw4t_bin, *args], capture_output=True, text=True, timeout=300)
    assert ours.returncode == theirs.returncode == 0, ours.stderr
    a, b = json.loads(ours.stdout), json.loads(theirs.stdout)
    assert a["digest"] == b["digest"] and a["completed_tick"] == b["completed_tick"]
    bad = subprocess.run([script, "run", "--no-such-flag"], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "--no-such-flag" in bad.stderr
    missing = subprocess.run([script, "run", "--map", "nowhere"], capture_output=True, text=True, timeout=60)
    assert missing.returncode == 1 and "nowhere" in missing.stderr


def test_python_dash_m_bw4t_is_the_same_command() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "bw4t", "map", "show", "fixed"],
        capture_output=True,
        text=True,
        timeout=60,
        env={**os.environ, "PYTHONSAFEPATH": "1"},
    )
    assert out.returncode == 0, out.stderr
    assert "DropZone" in out.stdout
