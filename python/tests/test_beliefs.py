"""Unit tests of the belief base and the protocol core, without a server.

The transcripts of protocol/examples/ are replayed through :class:`bw4t.ProtocolCore`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Dict, List

import pytest

from bw4t import BeliefBase, ProtocolCore
from bw4t.errors import FatalServerError

EXAMPLES = Path(__file__).resolve().parents[2] / "protocol" / "examples"


def transcript(name: str) -> List[Dict[str, Any]]:
    """The lines of one example transcript."""
    path = EXAMPLES / name
    assert path.is_file(), f"missing example transcript {path}"
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_full_clears_not_before_add_and_single_valued_replace() -> None:
    b = BeliefBase()
    b.apply(0, [["at", "A"], ["state", "arrived"], ["in", "R"], ["sequenceIndex", 0]], [], full=True)
    assert b.get("at") == "A" and b.holds("in", "R")
    # not is applied before add: a fact both removed and added holds afterwards
    b.apply(1, [["in", "R"], ["at", "B"], ["sequenceIndex", 1]], [["in", "R"]])
    assert b.holds("in", "R")
    assert b.all("at") == [("B",)] and b.get("sequenceIndex") == 1
    b.apply(2, [["color", 11, "Yellow"], ["color", 12, "Blue"]], [])
    assert b.all("color") == [(11, "Yellow"), (12, "Blue")]
    with pytest.raises(ValueError):
        b.get("color")
    b.apply(3, [["message", "Bob", "hi"]], [["color", 11, "Yellow"]])
    assert b.all("color") == [(12, "Blue")]
    assert not b.all("message") and [(m.sender, m.text, m.tick) for m in b.messages] == [("Bob", "hi", 3)]
    b.apply(4, [["at", "C"]], [], full=True)
    assert b.facts() == {("at", "C")}
    assert len(b.messages) == 1  # the message log survives a snapshot
    said = {"kind": "contains", "room": "RoomB2", "colour": "Red"}
    _, _, heard = b.apply(5, [["message", "Ann", "RoomB2 contains Red.", said]], [])
    assert [(m.sender, m.text, m.said) for m in heard] == [("Ann", "RoomB2 contains Red.", said)]
    assert b.messages[0].said is None  # free text has no structure


def test_sequence_fact_and_views() -> None:
    b = BeliefBase()
    b.apply(0, [["sequence", ["Red", "Blue"]], ["ownName", "Ann"], ["bot", 0], ["holding", 3]], [], True)
    assert b.holds("sequence", ["Red", "Blue"]) and b.holds("sequence", ("Red", "Blue"))
    assert b.sequence == ["Red", "Blue"] and b.name == "Ann" and b.robot == 0 and b.holding == 3
    assert ("holding", 3) in b and ("holding", 4) not in b
    assert b.get("in") is None and b.get("in", "none") == "none"


@pytest.mark.parametrize(
    "name",
    [
        "handshake.jsonl", "fetch-and-deliver.jsonl", "rejections.jsonl", "every-tick.jsonl", "bad-input.jsonl",
        "named-match.jsonl",
    ],
)
def test_transcripts_replay(name: str) -> None:
    """Feeding the server side of each transcript keeps a consistent state."""
    core = ProtocolCore()
    sent: Dict[Any, Dict[str, Any]] = {}
    for line in transcript(name):
        if "send" in line:
            msg = line["send"]
            if msg.get("type") == "act" and "id" in msg:
                _, record = core.act(msg["action"], tuple(msg.get("args", [])))
                sent[msg["id"]] = {"record": record}
            continue
        if "recv" in line:
            update = core.handle(line["recv"])
            if update is not None:
                # every tick's percepts needs a ready in lockstep
                assert core.pending_ready == update.tick
                assert core.take_ready() == {"type": "ready", "tick": update.tick}
    if name == "fetch-and-deliver.jsonl":
        b = core.beliefs
        assert b.sequence_index == 1 and b.holding is None and b.at == "DropZone"
        assert b.holds("in", "DropZone") and b.state == "arrived"
        ticks = [u.tick for u in core.queue]
        assert ticks[0] == 0 and ticks[-1] == 263
        with_results = [u for u in core.queue if u.results]
        assert [(u.tick, u.results[0].outcome) for u in with_results] == [
            (120, "arrived"), (127, "arrived"), (262, "arrived")
        ]
    if name == "every-tick.jsonl":
        assert core.finished and core.match_end is not None
        assert core.match_end.reason == "max_ticks"
        assert core.take_ready() is None  # no ready is expected after the last tick
    if name == "named-match.jsonl":
        assert core.welcome is not None and core.welcome.match.name == "default"
        assert core.resume_match() == "default"
        lobby = core.lobby
        assert lobby is not None and (lobby.match, lobby.players, lobby.awaited, lobby.started) == (
            "default", ("Ann",), 0, True
        )
        assert [u.tick for u in core.queue] == [0]  # a lobby is not an update
    if name == "bad-input.jsonl":
        assert [e.code for e in core.errors] == [
            "no_hello", "bad_json", "unknown_type", "bad_message", "bad_message", "already_joined"
        ]


def test_fatal_error_raises_with_code() -> None:
    core = ProtocolCore()
    with pytest.raises(FatalServerError) as info:
        core.handle({"type": "error", "code": "name_taken", "message": "the name 'Ann' is taken", "fatal": True})
    assert info.value.code == "name_taken" and "taken" in info.value.message and info.value.fatal
