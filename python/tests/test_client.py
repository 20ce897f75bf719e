"""Tests of the client against the real bw4t server (started per test, killed after)."""

from __future__ import annotations

import asyncio
import json
import random
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Callable, Dict, List, Optional

import pytest

from bw4t import (
    ActionLost,
    ActionRejected,
    AsyncClient,
    Client,
    ConnectionClosed,
    FatalServerError,
    Timeout,
    Update,
)
from conftest import CLIENT_DIR, WAIT, Server, run_threads

ServeFn = Callable[..., Server]


def connect(server: Server, name: Optional[str] = "Ann", **kw: object) -> Client:
    return Client.connect(server.host, server.port, name=name, timeout=WAIT, **kw)  # type: ignore[arg-type]


def updates_until(client: Client, condition: Callable[[], bool]) -> List[Update]:
    """Take updates until the condition holds (bounded)."""
    seen: List[Update] = []
    while not condition():
        update = client.next_update(WAIT)
        assert update is not None, "the match ended first"
        seen.append(update)
    return seen


def assert_clean(client: Client) -> None:
    """No error: in particular no late_ready/bad_tick, so ready was answered exactly."""
    assert client.errors == [], [(e.code, e.message) for e in client.errors]


# --------------------------------------------------------------------- handshake


def test_handshake_welcome_snapshot_ping_bye(serve: ServeFn) -> None:
    server = serve("--max-ticks", "2000")
    client = connect(server)
    w = client.welcome
    assert (w.version, w.name, w.robot) == (1, "Ann", 0) and client.robot == 0
    assert isinstance(client.session, str) and client.session
    m = client.match
    assert (m.map, m.seed, m.mode, m.tick_hz, m.players_needed, m.max_ticks) == ("fixed", 1, "lockstep", 20, 1, 2000)
    assert m.lockstep and m.deadline_ms == 0 and m.every_tick is False
    b = client.beliefs
    assert b.name == "Ann" and b.robot == 0 and b.at == "FrontDropZone" and b.state == "arrived"
    assert b.sequence == ["Yellow", "Red", "Blue", "Green", "White", "Orange"] and b.sequence_index == 0
    assert "RoomC1" in b.places and "DropZone" in b.places and b.holding is None
    first = client.next_update(WAIT)
    assert first is not None and first.tick == 0 and first.full and not first.answered
    assert ("ownName", "Ann") in first.added
    assert client.ping(WAIT) >= 0
    client.close()
    assert client._core.bye_reason == "goodbye"
    assert_clean(client)


def test_connect_from_environment(serve: ServeFn, monkeypatch: pytest.MonkeyPatch) -> None:
    server = serve("--token", "s3cret")
    monkeypatch.setenv("BW4T_HOST", server.host)
    monkeypatch.setenv("BW4T_PORT", str(server.port))
    monkeypatch.setenv("BW4T_NAME", "Envy")
    monkeypatch.setenv("BW4T_TOKEN", "s3cret")
    client = Client.connect(timeout=WAIT)
    assert client.name == "Envy" and client.beliefs.name == "Envy"
    client.close()


@pytest.mark.parametrize(
    "kwargs, code",
    [
        ({"name": "9lives"}, "invalid_name"),
        ({"name": "Ann", "token": "wrong"}, "bad_token"),
        ({"name": "Bob", "session": "00000000deadbeef00000099"}, "bad_session"),
    ],
)
def test_refused_hello_raises_fatal_error(serve: ServeFn, kwargs: Dict[str, str], code: str) -> None:
    server = serve("--token", "tok") if code == "bad_token" else serve()
    with pytest.raises(FatalServerError) as info:
        Client.connect(server.host, server.port, timeout=WAIT, **kwargs)  # type: ignore[arg-type]
    assert info.value.code == code and info.value.fatal and info.value.message


def test_name_taken(serve: ServeFn) -> None:
    server = serve("--robots", "2")
    ann = connect(server)
    with pytest.raises(FatalServerError) as info:
        connect(server, "Ann")
    assert info.value.code == "name_taken"
    ann.close()


# ----------------------------------------------------------------------- acting


def test_fetch_and_deliver_with_acks_and_results(serve: ServeFn) -> None:
    """The fetch-and-deliver transcript, through the client API: same ticks."""
    server = serve("--max-ticks", "2000")
    client = connect(server)
    go = client.go_to("RoomC1")
    ack = go.ack(WAIT)
    assert ack.ok and ack.tick == 0 and ack.id == go.id
    result = go.result(WAIT)
    assert result is not None and result.outcome == "arrived" and result.tick == 120
    # result() returns once that tick's percepts are applied
    b = client.beliefs
    assert b.tick == 120 and b.state == "arrived" and b.room == "RoomC1"
    assert b.colors == {11: "Yellow", 12: "Blue", 13: "Red"}
    assert b.holds("occupied", "RoomC1") and b.all("block") == [(11,), (12,), (13,)]

    assert client.go_to_block(11).result(WAIT).tick == 127  # type: ignore[union-attr]
    pick = client.pick_up()
    assert pick.result(WAIT) is None and pick.ack().ok  # not durative
    updates_until(client, lambda: b.holding == 11)
    assert not b.holds("color", 11, "Yellow")
    assert client.go_to("DropZone").result(WAIT).tick == 262  # type: ignore[union-attr]
    assert client.put_down().ack(WAIT).tick == 262
    seen = updates_until(client, lambda: b.sequence_index == 1)
    assert b.holding is None and seen[-1].tick == 263

    # the updates queued while blocked in result() come in tick order, one per tick
    ticks = [u.tick for u in seen]
    assert ticks == sorted(set(ticks)) and 212 in ticks and 252 in ticks
    client.close()
    assert_clean(client)


def test_updates_hold_acks_results_and_answer_flags(serve: ServeFn) -> None:
    server = serve()
    client = connect(server)
    first = client.next_update(WAIT)
    assert first is not None and first.tick == 0
    go = client.go_to("RoomC1")  # sent before the ready of tick 0
    update = client.next_update(WAIT)  # answers ready 0
    assert update is not None and update.tick == 1 and [a.id for a in update.acks] == [go.id]
    assert update.added == [("state", "traveling")] and not update.answered
    result = go.result(WAIT)  # blocks: answers tick 1 and the ticks that come
    assert result is not None and result.tick == 120
    client.close()
    assert_clean(client)


def test_updates_received_while_blocked_are_delivered(serve: ServeFn) -> None:
    server = serve()
    client = connect(server)
    assert client.next_update(WAIT).tick == 0  # type: ignore[union-attr]
    go = client.go_to("RoomC1")
    assert go.result(WAIT).tick == 120  # type: ignore[union-attr]
    queued = []
    while client._core.queue:
        queued.append(client.next_update(WAIT))
    assert [u.tick for u in queued] == [1, 31, 55, 90, 110, 112, 116, 120]
    assert all(u.answered for u in queued[:-1]) and not queued[-1].answered
    assert queued[0].acks[0].id == go.id and queued[-1].result_of(go.id).outcome == "arrived"
    # act at tick 120 (its ready is still pending): applied at boundary 120
    ack = client.go_to_block(11).ack(WAIT)
    assert ack.ok and ack.tick == 120
    client.close()
    assert_clean(client)


def test_rejections_and_superseded(serve: ServeFn) -> None:
    server = serve()
    client = connect(server)
    nowhere = client.go_to("Nowhere")
    fly = client.act("fly")
    bad = client.act("goToBlock", "Yellow")
    holding = client.put_down()
    first = client.go_to("RoomA1")
    second = client.go_to("RoomC1")  # replaces the first at the same boundary
    # immediate rejections arrive before the tick boundary
    assert (fly.ack(WAIT).ok, fly.ack().code) == (False, "unknown_action")
    assert bad.ack(WAIT).code == "bad_args"
    assert nowhere.ack(WAIT).code == "unknown_place" and nowhere.ack().reason
    with pytest.raises(ActionRejected) as info:
        nowhere.result(WAIT)
    assert info.value.code == "unknown_place"
    assert holding.ack(WAIT).code == "not_holding"
    assert first.result(WAIT).outcome == "superseded"  # type: ignore[union-attr]
    assert second.result(WAIT).outcome == "arrived"  # type: ignore[union-attr]
    client.close()
    assert_clean(client)


def test_every_tick_and_match_end(serve: ServeFn) -> None:
    server = serve("--max-ticks", "5")
    client = connect(server, every_tick=True)
    assert client.match.every_tick
    ticks = [u.tick for u in client.updates(WAIT)]
    assert ticks == [0, 1, 2, 3, 4, 5]
    end = client.match_end
    assert end is not None and end.reason == "max_ticks" and not end.completed
    assert client.result is not None and client.result["ticks"] == 5 and client.finished
    assert client.next_update(WAIT) is None
    assert_clean(client)


def test_realtime_mode(serve: ServeFn) -> None:
    server = serve("--mode", "realtime", "--deadline-ms", "1000")
    client = connect(server)
    assert not client.match.lockstep
    result = client.go_to("DropZone").result(WAIT)
    assert result is not None and result.arrived and client.beliefs.room == "DropZone"
    client.close()
    assert_clean(client)


def test_timeout_is_raised(serve: ServeFn) -> None:
    server = serve("--robots", "2")  # the match never starts: nothing more comes
    client = connect(server)
    assert client.next_update(WAIT).tick == 0  # type: ignore[union-attr]
    with pytest.raises(Timeout):
        client.next_update(0.3)
    client.close()


# --------------------------------------------------------------------- messages


def test_messages_between_two_clients(serve: ServeFn) -> None:
    server = serve("--robots", "2", "--max-ticks", "400")
    # Ann gets percepts every tick, so the match always waits for her: an act she sends
    # after an ack (when she is otherwise not waited for) cannot be outrun by the ticks.
    ann = connect(server, "Ann", every_tick=True)
    bob = connect(server, "Bob")

    def play_ann() -> None:
        updates_until(ann, lambda: "Bob" in ann.beliefs.players)
        assert ann.say("Bob", "hello Bob").ack(WAIT).ok
        assert ann.send_message("all", "hello all").ack(WAIT).ok
        refused = ann.say("Carol", "anyone?").ack(WAIT)
        assert (refused.ok, refused.code) == (False, "unknown_receiver")
        updates_until(ann, lambda: any(m.text == "OK." for m in ann.beliefs.messages))
        # A message of the shared language comes as its sentence and its structure.
        answer = next(m for m in ann.beliefs.messages if m.sender == "Bob")
        assert (answer.text, answer.said) == ("OK.", {"kind": "ok"})
        bad = ann.say("Bob", said={"kind": "will_get"}).ack(WAIT)
        assert (bad.ok, bad.code) == (False, "bad_args") and "colour" in (bad.reason or "")
        for _ in ann.updates(WAIT):
            pass

    def play_bob() -> List[Update]:
        got: List[Update] = []
        for update in bob.updates(WAIT):
            if update.messages:
                got.append(update)
            if any(m.text == "hello Bob" for m in update.messages):
                bob.say("Ann", said={"kind": "ok"})
        return got

    _, bob_updates = run_threads(play_ann, play_bob)
    texts = [(m.sender, m.text) for u in bob_updates for m in u.messages]  # type: ignore[union-attr]
    assert texts == [("Ann", "hello Bob"), ("Ann", "hello all")]
    assert all(m.said is None for u in bob_updates for m in u.messages)  # type: ignore[union-attr]
    assert [(m.sender, m.text) for m in bob.beliefs.messages] == texts
    assert not bob.beliefs.all("message")  # events, not state
    assert ann.match_end is not None and bob.match_end is not None
    assert_clean(ann)
    assert_clean(bob)


# ---------------------------------------------------------- beliefs vs snapshot


def random_player(client: Client, seed: int, until_tick: int, checks: List[int]) -> Dict[str, int]:
    """Play randomly (moving, picking up, putting down) and compare the belief base
    with a fresh full snapshot (resync) at the given ticks and at the end."""
    rng = random.Random(seed)
    b = client.beliefs
    rooms = [p for p in b.places if p.startswith("Room")] + ["DropZone"]
    places = b.places
    stats = {"moves": 0, "picks": 0, "drops": 0, "resyncs": 0}
    busy = None
    pending = list(checks)
    for update in client.updates(WAIT):
        if pending and update.tick >= pending[0]:
            while pending and update.tick >= pending[0]:
                pending.pop(0)
            before = b.facts()
            client.resync(WAIT)
            snapshot = client.last_snapshot
            assert snapshot is not None and snapshot.full and snapshot.tick == update.tick
            assert b.facts() == before, f"{client.name} tick {update.tick}: {before ^ b.facts()}"
            stats["resyncs"] += 1
        if update.tick >= until_tick:
            break
        if busy is not None and not busy.done:
            continue
        busy = None
        if b.holding is not None and (b.room is None or rng.random() < 0.3):
            client.put_down()
            stats["drops"] += 1
        elif b.room and b.holding is None and b.colors and rng.random() < 0.7:
            block = rng.choice(sorted(b.colors))
            if b.holds("atBlock", block):
                client.pick_up()
                stats["picks"] += 1
            else:
                busy = client.go_to_block(block)
        else:
            busy = client.go_to(rng.choice(rooms if rng.random() < 0.8 else places))
            stats["moves"] += 1
    client.close()
    return stats


def test_beliefs_equal_full_snapshot_after_play(serve: ServeFn) -> None:
    server = serve("--map", "default", "--seed", "7", "--robots", "3", "--max-ticks", "2000")
    clients = [connect(server, name) for name in ("Ann", "Bob", "Cid")]
    checks = list(range(40, 900, 60))

    def player(i: int) -> Callable[[], Dict[str, int]]:
        return lambda: random_player(clients[i], 100 + i, 900, checks)

    stats = run_threads(*(player(i) for i in range(3)))
    for client, s in zip(clients, stats):
        assert isinstance(s, dict) and s["resyncs"] >= 10 and s["moves"] >= 4, s
        assert_clean(client)
    assert sum(s["picks"] for s in stats) >= 2, stats  # type: ignore[index]


# -------------------------------------------------------------------- reconnect


def test_reconnect_keeps_the_robot_and_its_block(serve: ServeFn) -> None:
    server = serve("--grace-s", "30")
    client = connect(server)
    session = client.session
    client.go_to("RoomC1").result(WAIT)
    client.go_to_block(11).result(WAIT)
    client.pick_up().ack(WAIT)
    updates_until(client, lambda: client.beliefs.holding == 11)
    client.close(bye=False)  # a dropped connection: the robot waits for its session
    with pytest.raises(FatalServerError) as info:
        connect(server, "Ann")
    assert info.value.code == "name_taken"
    welcome = client.reconnect(WAIT)
    assert (welcome.name, welcome.robot, welcome.session) == ("Ann", 0, session)
    snapshot = None
    while client._core.queue:
        snapshot = client.next_update(WAIT)
    assert snapshot is not None and snapshot.full
    assert client.beliefs.holding == 11 and client.beliefs.room == "RoomC1"
    # and it plays on
    assert client.go_to("DropZone").result(WAIT).arrived  # type: ignore[union-attr]
    client.put_down().ack(WAIT)
    updates_until(client, lambda: client.beliefs.sequence_index == 1)
    client.close()
    assert_clean(client)


def test_second_connection_with_session_replaces_the_first(serve: ServeFn) -> None:
    server = serve()
    first = connect(server)
    second = Client.connect(server.host, server.port, session=first.session, timeout=WAIT)
    assert second.robot == first.robot and second.name == "Ann"
    with pytest.raises(FatalServerError) as info:
        first.ping(WAIT)
    assert info.value.code == "replaced"
    second.close()
    # after bye the robot has left: the session is refused
    with pytest.raises(FatalServerError) as info:
        Client.connect(server.host, server.port, session=first.session, timeout=WAIT)
    assert info.value.code == "bad_session"


def test_server_gone_raises_connection_closed(serve: ServeFn) -> None:
    server = serve()
    client = connect(server)
    assert client.next_update(WAIT).tick == 0  # type: ignore[union-attr]
    go = client.go_to("RoomC1")
    server.stop()
    with pytest.raises(ActionLost):
        go.result(WAIT)
    with pytest.raises(ConnectionClosed) as info:
        client.next_update(WAIT)
    assert info.value.reason is None


# ---------------------------------------------------------------------- asyncio


def test_async_reconnect(serve: ServeFn) -> None:
    server = serve()

    async def main() -> None:
        client = await AsyncClient.connect(server.host, server.port, name="Ann", timeout=WAIT)
        await client.go_to("RoomC1").result(WAIT)
        await client.go_to_block(11).result(WAIT)
        await client.pick_up().ack(WAIT)
        async for _ in client.updates(WAIT):
            if client.beliefs.holding == 11:
                break
        session = client.session
        await client.close(bye=False)
        welcome = await client.reconnect(WAIT)
        assert welcome.session == session and welcome.robot == 0
        assert client.beliefs.holding == 11 and client.beliefs.room == "RoomC1"
        assert (await client.go_to("DropZone").result(WAIT)).arrived  # type: ignore[union-attr]
        await client.close()
        assert client.errors == []

    asyncio.run(asyncio.wait_for(main(), 60))



def test_async_client_scenario(serve: ServeFn) -> None:
    server = serve("--robots", "2", "--max-ticks", "600")

    async def fetcher(client: AsyncClient) -> List[int]:
        b = client.beliefs
        go = client.go_to("RoomC1")
        ack = await go.ack(WAIT)
        assert ack.ok and ack.tick == 0
        result = await asyncio.wait_for(go, WAIT)
        assert result is not None and result.tick == 120 and b.room == "RoomC1"
        assert (await client.go_to_block(11).result(WAIT)).arrived  # type: ignore[union-attr]
        await client.pick_up().ack(WAIT)
        async for _ in client.updates(WAIT):
            if b.holding == 11:
                break
        said = client.say("Bob", "got Yellow")  # sent in the same tick as the goTo
        assert (await client.go_to("DropZone")).arrived  # type: ignore[union-attr]
        assert said.acked and (await said.ack()).ok
        await client.put_down().ack(WAIT)
        ticks = []
        async for update in client.updates(WAIT):
            ticks.append(update.tick)
            if b.sequence_index == 1 and len(b.facts()) > 0:
                before = b.facts()
                await client.resync(WAIT)
                assert b.facts() == before
                break
        assert await client.ping(WAIT) >= 0
        async for _ in client.updates(WAIT):
            pass
        assert client.match_end is not None and client.match_end.result["sequence_index"] == 1
        assert client.errors == []
        return ticks

    async def listener(client: AsyncClient) -> List[str]:
        texts = []
        async for update in client.updates(WAIT):
            texts += [m.text for m in update.messages]
        assert client.errors == [] and client.finished
        return texts

    async def main() -> None:
        # connect in a fixed order: robot ids and spawn points follow the joining order
        ann = await AsyncClient.connect(server.host, server.port, name="Ann", timeout=WAIT)
        bob = await AsyncClient.connect(server.host, server.port, name="Bob", timeout=WAIT)
        ticks, texts = await asyncio.wait_for(asyncio.gather(fetcher(ann), listener(bob)), 60)
        assert texts == ["got Yellow"]

    asyncio.run(main())


# ----------------------------------------------------------------- example team


def test_example_team_completes_a_match(bw4t_bin: str, tmp_path: Path) -> None:
    agent = f"{shlex.quote(sys.executable)} {shlex.quote(str(CLIENT_DIR / 'examples' / 'coop_agent.py'))}"
    argv = [
        bw4t_bin, "run", "--map", "default", "--seed", "11", "--robots", "3",
        "--agent", agent, "--json", "--log-dir", str(tmp_path / "logs"),
    ]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    logs = "\n".join(p.read_text() for p in (tmp_path / "logs").glob("*.log"))
    assert result["completed"], f"not completed: {result}\n{logs}"
    assert result["sequence_index"] == len(result["sequence"]) and result["wrong_drops"] == 0
    assert len(result["agents"]) == 3
    assert all(a["status"] == "ok" for a in result["agents"]), result["agents"]


def test_example_plays_with_built_in_teammates_in_the_language(bw4t_bin: str, tmp_path: Path) -> None:
    agent = f"{shlex.quote(sys.executable)} {shlex.quote(str(CLIENT_DIR / 'examples' / 'coop_agent.py'))}"
    replay = tmp_path / "replay.jsonl"
    argv = [
        bw4t_bin, "run", "--map", "default", "--seed", "3", "--robots", "3", "--team", "builtin",
        "--agent", agent, "--json", "--log-dir", str(tmp_path / "logs"), "--replay", str(replay),
    ]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert result["completed"] and result["wrong_drops"] == 0, result
    [mine] = [a for a in result["agents"] if a["kind"] == "external"]
    assert mine["status"] == "ok", result["agents"]
    # It takes part: the built-in robots understand its claims and reports, and it theirs.
    [robot] = [r for r in result["per_robot"] if r["name"] == mine["name"]]
    assert robot["good_drops"] >= 1, result["per_robot"]
    kinds = set()
    for line in replay.read_text().splitlines():
        for event in json.loads(line).get("events", []):
            if event.get("kind") == "act" and event.get("robot") == robot["id"] \
                    and event.get("action") == "sendMessage":
                assert isinstance(event["args"][1], dict), event  # a message of the language
                kinds.add(event["args"][1]["kind"])
    assert {"going_to", "contains_many", "getting_for", "bringing"} <= kinds, kinds
