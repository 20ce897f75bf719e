"""Joining a named match or a template, ``lobby`` messages and reconnecting to the
session's match: first against a scripted server (see ``fake_server.py``), which checks
exactly what the client sends and what it makes of the answers, then against the real
server."""

from __future__ import annotations

import asyncio
import threading
import time
from pathlib import Path
from typing import Callable, List

import pytest

from bw4t import AsyncClient, Client, FatalServerError, JoinOptions, Lobby, ProtocolCore, Timeout
from fake_server import FakeConnection, FakeServer, fatal, lobby, snapshot, welcome
from conftest import WAIT, Server, run_threads

FakeFn = Callable[[Callable[[FakeConnection], None]], FakeServer]
ServeFn = Callable[..., Server]


def seat(conn: FakeConnection, **welcome_fields: object) -> dict:
    """Answer the client's ``hello`` with ``welcome`` and a snapshot, then wait until the
    client closes; returns the ``hello``."""
    hello = conn.expect("hello")
    conn.send(welcome(**welcome_fields), snapshot())  # type: ignore[arg-type]
    conn.wait_closed()
    return hello


def test_hello_names_the_match(fake_server: FakeFn) -> None:
    server = fake_server(lambda conn: seat(conn, match="team-a"))
    client = Client.connect(server.host, server.port, name="Ann", match="team-a", timeout=WAIT)
    client.close(bye=False)
    hello = server.next_connection().received[0]
    assert hello["match"] == "team-a" and "template" not in hello
    assert (hello["name"], hello["protocol"], hello["versions"]) == ("Ann", "bw4t", [1])
    assert client.match.name == "team-a" and client.match.template is None


def test_hello_names_the_template(fake_server: FakeFn) -> None:
    server = fake_server(lambda conn: seat(conn, match="ladder-3", template="ladder"))
    client = Client.connect(server.host, server.port, name="Ann", template="ladder", timeout=WAIT)
    client.close(bye=False)
    hello = server.next_connection().received[0]
    assert hello["template"] == "ladder" and "match" not in hello
    assert (client.match.name, client.match.template) == ("ladder-3", "ladder")
    assert client.match.raw["name"] == "ladder-3"


def test_hello_without_match_or_template_joins_the_default_match(fake_server: FakeFn) -> None:
    server = fake_server(lambda conn: seat(conn, match=None))
    client = Client.connect(server.host, server.port, name="Ann", timeout=WAIT)
    client.close(bye=False)
    hello = server.next_connection().received[0]
    assert "match" not in hello and "template" not in hello
    assert client.match.name is None  # a server of one unnamed match


def test_match_and_template_together_are_refused_before_sending(fake_server: FakeFn) -> None:
    server = fake_server(lambda conn: seat(conn))
    with pytest.raises(ValueError, match="not both"):
        Client.connect(server.host, server.port, name="Ann", match="team-a", template="ladder", timeout=WAIT)

    async def main() -> None:
        await AsyncClient.connect(server.host, server.port, match="team-a", template="ladder", timeout=WAIT)

    with pytest.raises(ValueError, match="not both"):
        asyncio.run(main())
    with pytest.raises(ValueError):
        ProtocolCore().hello("Ann", match="team-a", template="ladder")
    # Neither attempt connected: the first connection the server sees is this one.
    Client.connect(server.host, server.port, name="Bob", timeout=WAIT).close(bye=False)
    assert server.next_connection().received[0]["name"] == "Bob"


def test_reconnect_names_the_sessions_match(fake_server: FakeFn) -> None:
    session = "00112233445566778899aabb"

    def script(conn: FakeConnection) -> None:
        hello = conn.expect("hello")
        if "session" in hello:  # taking the robot back
            assert hello["session"] == session
        conn.send(welcome(match="ladder-3", template="ladder", session=session), snapshot())
        conn.wait_closed()

    server = fake_server(script)
    client = Client.connect(server.host, server.port, name="Ann", template="ladder", timeout=WAIT)
    client.close(bye=False)
    again = client.reconnect(WAIT)
    client.close(bye=False)
    first, second = server.next_connection().received[0], server.next_connection().received[0]
    assert first["template"] == "ladder" and "match" not in first and "session" not in first
    assert second["match"] == "ladder-3" and second["session"] == session and "template" not in second
    assert again.match.name == "ladder-3"


def test_async_reconnect_names_the_sessions_match(fake_server: FakeFn) -> None:
    server = fake_server(lambda conn: seat(conn, match="ladder-4", template="ladder"))

    async def main() -> None:
        client = await AsyncClient.connect(server.host, server.port, name="Ann", template="ladder", timeout=WAIT)
        await client.close(bye=False)
        await client.reconnect(WAIT)
        await client.close(bye=False)

    asyncio.run(asyncio.wait_for(main(), WAIT))
    first, second = server.next_connection().received[0], server.next_connection().received[0]
    assert first["template"] == "ladder" and "match" not in first
    assert second["match"] == "ladder-4" and "template" not in second and second["session"]


def test_join_options_say_what_the_keyword_arguments_say(fake_server: FakeFn) -> None:
    server = fake_server(lambda conn: seat(conn, match="ladder-3", template="ladder"))
    seen: List[Lobby] = []
    options = JoinOptions(name="Ann", template="ladder", words=True, every_tick=True, on_lobby=seen.append)
    client = Client.connect(server.host, server.port, options=options, timeout=WAIT)
    client.close(bye=False)
    by_keywords = Client.connect(
        server.host, server.port, name="Ann", template="ladder", words=True, every_tick=True, timeout=WAIT
    )
    by_keywords.close(bye=False)
    first, second = server.next_connection().received[0], server.next_connection().received[0]
    assert first == second == options.hello()
    assert first["template"] == "ladder" and first["words"] is True and first["every_tick"] is True
    assert client.options == options and by_keywords.options == JoinOptions(
        name="Ann", template="ladder", words=True, every_tick=True
    )
    assert ProtocolCore().hello(options=options) == ProtocolCore().hello("Ann", every_tick=True, template="ladder", words=True)


def test_join_options_refuse_what_cannot_go_together(fake_server: FakeFn) -> None:
    with pytest.raises(ValueError, match="not both"):
        JoinOptions(match="team-a", template="ladder")
    server = fake_server(lambda conn: seat(conn))
    with pytest.raises(ValueError, match="options= or its keyword arguments"):
        Client.connect(server.host, server.port, name="Bob", options=JoinOptions(name="Ann"), timeout=WAIT)

    async def main() -> None:
        await AsyncClient.connect(server.host, server.port, words=True, options=JoinOptions(), timeout=WAIT)

    with pytest.raises(ValueError, match="options= or its keyword arguments"):
        asyncio.run(main())
    # Neither attempt connected: the first connection the server sees is this one.
    Client.connect(server.host, server.port, options=JoinOptions(name="Cy"), timeout=WAIT).close(bye=False)
    assert server.next_connection().received[0]["name"] == "Cy"


def test_join_options_resuming_keep_all_but_the_template() -> None:
    options = JoinOptions(name="Ann", token="secret", template="ladder", words=True)
    resumed = options.resuming("00112233445566778899aabb", "ladder-3")
    assert resumed == JoinOptions(
        name="Ann", token="secret", session="00112233445566778899aabb", match="ladder-3", words=True
    )
    assert JoinOptions(match="team-a").resuming("s", None).match == "team-a"


def lobby_script(conn: FakeConnection) -> None:
    """Queued twice, seated, a lobby before and after the tick-0 snapshot, then two
    lockstep ticks and the end."""
    hello = conn.expect("hello")
    assert hello["template"] == "ladder"
    conn.send(
        lobby(template="ladder", players=[], awaited=0, queued=2),
        lobby(template="ladder", players=[], awaited=0, queued=1),
        welcome(match="ladder-3", template="ladder", mode="lockstep"),
        lobby(match="ladder-3", template="ladder", players=["Ann"], awaited=1, start_in_ms=25000),
        snapshot(0),
        lobby(match="ladder-3", template="ladder", players=["Ann", "Bot1"], awaited=0, started=True),
    )
    # One ready answers tick 0: the lobby after the snapshot asks for none.
    assert conn.expect("ready")["tick"] == 0
    conn.send({"type": "percepts", "tick": 1, "add": [["state", "traveling"]], "not": [["state", "arrived"]]})
    assert conn.expect("ready")["tick"] == 1
    conn.send({"type": "match_end", "reason": "interrupted", "result": {"completed": False}},
              {"type": "bye", "reason": "match_over"})  # then the server closes


def check_lobbies(seen: List[Lobby]) -> None:
    assert [(l.match, l.queued, l.in_queue) for l in seen] == [
        (None, 2, True), (None, 1, True), ("ladder-3", None, False), ("ladder-3", None, False),
    ]
    assert all(l.template == "ladder" for l in seen)
    assert (seen[2].players, seen[2].awaited, seen[2].start_in_ms) == (("Ann",), 1, 25000)
    assert (seen[3].players, seen[3].awaited, seen[3].start_in_ms) == (("Ann", "Bot1"), 0, None)
    assert [l.started for l in seen] == [False, False, False, True]


def test_lobby_messages_before_and_after_welcome(fake_server: FakeFn) -> None:
    server = fake_server(lobby_script)
    seen: List[Lobby] = []
    client = Client.connect(server.host, server.port, name="Ann", template="ladder", on_lobby=seen.append, timeout=WAIT)
    assert [l.queued for l in seen[:2]] == [2, 1] and client.match.name == "ladder-3"
    ticks = [u.tick for u in client.updates(WAIT)]
    assert ticks == [0, 1] and client.match_end is not None
    check_lobbies(seen)
    assert client.lobby is seen[-1]
    assert client.errors == []
    server.stop()
    assert [m["type"] for m in server.next_connection().received] == ["hello", "ready", "ready"]


def test_async_lobby_messages(fake_server: FakeFn) -> None:
    server = fake_server(lobby_script)
    seen: List[Lobby] = []

    async def main() -> List[int]:
        client = await AsyncClient.connect(
            server.host, server.port, name="Ann", template="ladder", on_lobby=seen.append, timeout=WAIT
        )
        ticks = [u.tick async for u in client.updates(WAIT)]
        assert client.lobby is seen[-1] and client.finished
        return ticks

    assert asyncio.run(asyncio.wait_for(main(), WAIT)) == [0, 1]
    check_lobbies(seen)


def test_time_in_a_templates_queue_is_not_bounded_by_the_timeout(fake_server: FakeFn) -> None:
    timeout = 0.3

    def script(conn: FakeConnection) -> None:
        conn.expect("hello")
        conn.send(lobby(template="ladder", players=[], awaited=0, queued=1))
        time.sleep(3 * timeout)  # the queue moves slowly: longer than the handshake timeout
        conn.send(welcome(match="ladder-1", template="ladder"), snapshot())
        conn.wait_closed()

    server = fake_server(script)
    client = Client.connect(server.host, server.port, template="ladder", timeout=timeout)
    assert client.match.name == "ladder-1" and client.lobby is not None and client.lobby.queued == 1
    client.close(bye=False)


def test_a_silent_server_still_times_out(fake_server: FakeFn) -> None:
    server = fake_server(lambda conn: conn.wait_closed())
    with pytest.raises(Timeout):
        Client.connect(server.host, server.port, template="ladder", timeout=0.3)


def test_on_lobby_raising_gives_up_the_wait(fake_server: FakeFn) -> None:
    def script(conn: FakeConnection) -> None:
        conn.expect("hello")
        conn.send(lobby(template="ladder", players=[], awaited=0, queued=7))
        conn.wait_closed()  # the client leaves the queue by closing

    server = fake_server(script)

    def too_far(entry: Lobby) -> None:
        if entry.queued is not None and entry.queued > 3:
            raise RuntimeError(f"place {entry.queued} in the queue")

    with pytest.raises(RuntimeError, match="place 7"):
        Client.connect(server.host, server.port, template="ladder", on_lobby=too_far, timeout=WAIT)


@pytest.mark.parametrize(
    "kwargs, code",
    [({"match": "nope"}, "unknown_match"), ({"template": "nope"}, "unknown_template")],
)
def test_unknown_match_or_template_is_a_fatal_error(fake_server: FakeFn, kwargs: dict, code: str) -> None:
    def script(conn: FakeConnection) -> None:
        conn.expect("hello")
        conn.send(*fatal(code, "no live match named 'nope'"))

    server = fake_server(script)
    with pytest.raises(FatalServerError) as info:
        Client.connect(server.host, server.port, timeout=WAIT, **kwargs)
    assert info.value.code == code and info.value.fatal and "nope" in info.value.message


def test_lobby_from_json() -> None:
    full = Lobby.from_json(
        {"type": "lobby", "match": "ladder-3", "template": "ladder", "players": ["Ann", "Bot1"],
         "awaited": 1, "start_in_ms": 25000}
    )
    assert (full.match, full.template, full.players, full.awaited, full.start_in_ms, full.queued) == (
        "ladder-3", "ladder", ("Ann", "Bot1"), 1, 25000, None
    )
    queued = Lobby.from_json({"type": "lobby", "template": "ladder", "players": [], "awaited": 0, "queued": 2})
    assert queued.in_queue and queued.match is None and queued.queued == 2 and queued.players == ()
    bare = Lobby.from_json({"type": "lobby"})
    assert (bare.match, bare.template, bare.players, bare.awaited, bare.started) == (None, None, (), 0, False)


# ------------------------------------------------------------- the real server
# Joining the default match by its name, lobby messages, reconnecting and unknown names
# need only `bw4t serve`; templates and named matches need `bw4t serve --config`.


def test_lobby_and_reconnect_in_the_named_default_match(serve: ServeFn) -> None:
    server = serve("--mode", "realtime", "--robots", "2", "--grace-s", "30", "--max-ticks", "2000")
    ann_lobbies: List[Lobby] = []
    ann = Client.connect(
        server.host, server.port, name="Ann", match="default", every_tick=True,
        on_lobby=ann_lobbies.append, timeout=WAIT,
    )
    assert ann.match.name == "default"
    bob = Client.connect(server.host, server.port, name="Bob", match="default", timeout=WAIT)
    # The match started with Bob: every lobby came before the percepts of tick 1.
    while ann.beliefs.tick < 1:
        assert ann.next_update(WAIT) is not None
    assert ann_lobbies, "no lobby after welcome"
    first, last = ann_lobbies[0], ann_lobbies[-1]
    assert (first.match, first.players, first.awaited) == ("default", ("Ann",), 1)
    assert (last.match, last.players, last.awaited, last.started) == ("default", ("Ann", "Bob"), 0, True)
    assert not any(l.started for l in ann_lobbies[:-1])
    assert ann.lobby is last and not any(l.in_queue for l in ann_lobbies)

    ann.close(bye=False)
    welcome = ann.reconnect(WAIT)
    assert (welcome.robot, welcome.match.name) == (0, "default")
    assert ann.next_update(WAIT).full  # type: ignore[union-attr]
    for client in (ann, bob):
        client.close()
        assert client.errors == []


@pytest.mark.parametrize(
    "kwargs, code",
    [({"match": "nope"}, "unknown_match"), ({"template": "nope"}, "unknown_template")],
)
def test_unknown_names_are_refused_by_the_real_server(serve: ServeFn, kwargs: dict, code: str) -> None:
    server = serve()
    with pytest.raises(FatalServerError) as info:
        Client.connect(server.host, server.port, name="Ann", timeout=WAIT, **kwargs)
    assert info.value.code == code and info.value.fatal and "nope" in info.value.message


# Templates and named matches (`bw4t serve --config`). The default match is `team-a`, so a
# reconnect that did not name its match would land there and be refused.
ARENA = """
default = "team-a"

[[template]]
name = "classroom"
map = "fixed"
robots = 2
names = ["team-a", "team-b"]

[[template]]
name = "ladder"
map = "fixed"
robots = 2
max_ticks = 2000

[[template]]
name = "solo"
map = "fixed"
robots = 1
max_running = 1
mode = "lockstep"
deadline_ms = 0
max_ticks = 5
"""


@pytest.fixture
def arena(serve: ServeFn, tmp_path: Path) -> Server:
    """``bw4t serve --config`` with the templates of :data:`ARENA`."""
    config = tmp_path / "arena.toml"
    config.write_text(ARENA)
    return serve("--config", str(config))


def test_a_named_match_of_a_template(arena: Server) -> None:
    ann = Client.connect(arena.host, arena.port, name="Ann", match="team-b", timeout=WAIT)
    assert (ann.match.name, ann.match.template, ann.match.players_needed) == ("team-b", "classroom", 2)
    bob = Client.connect(arena.host, arena.port, name="Bob", timeout=WAIT)  # the default match
    assert (bob.match.name, bob.robot) == ("team-a", 0)
    ann.close()
    bob.close()


def test_template_lobby_and_reconnect_into_its_match(arena: Server) -> None:
    ann_lobbies: List[Lobby] = []
    ann = Client.connect(
        arena.host, arena.port, name="Ann", template="ladder", every_tick=True,
        on_lobby=ann_lobbies.append, timeout=WAIT,
    )
    name = ann.match.name
    assert ann.match.template == "ladder" and name and name.startswith("ladder")
    session = ann.session

    bob = Client.connect(arena.host, arena.port, name="Bob", template="ladder", timeout=WAIT)
    assert (bob.match.name, bob.robot) == (name, 1)  # the match with a free seat
    while ann.beliefs.tick < 1:  # every lobby comes before the percepts of tick 1
        assert ann.next_update(WAIT) is not None
    assert (ann_lobbies[0].match, ann_lobbies[0].template, ann_lobbies[0].players) == (name, "ladder", ("Ann",))
    last = ann_lobbies[-1]
    assert (last.match, last.players, last.awaited, last.started) == (name, ("Ann", "Bob"), 0, True)

    # Once the match has started, a dropped player's robot waits for it (before the start
    # a seat left is free again at once).
    ann.close(bye=False)
    welcome = ann.reconnect(WAIT)  # names the match: the default one would refuse the session
    assert (welcome.robot, welcome.session, welcome.match.name) == (0, session, name)
    for client in (ann, bob):
        client.close()
        assert client.errors == []


def test_queued_for_a_template_then_seated(arena: Server) -> None:
    ann = Client.connect(arena.host, arena.port, name="Ann", template="solo", timeout=WAIT)
    assert ann.match.template == "solo"
    queued = threading.Event()
    bob_lobbies: List[Lobby] = []

    def on_bob_lobby(entry: Lobby) -> None:
        bob_lobbies.append(entry)
        if entry.in_queue:
            queued.set()

    def bob_joins() -> Client:
        return Client.connect(arena.host, arena.port, name="Bob", template="solo", on_lobby=on_bob_lobby, timeout=WAIT)

    def ann_plays() -> None:
        # The only match of solo is Ann's (max_running = 1): Bob waits in the queue until
        # it ends, which it does once Ann has answered its 5 ticks.
        assert queued.wait(WAIT), "Bob was not queued"
        for _ in ann.updates(WAIT):
            pass

    bob, _ = run_threads(bob_joins, ann_plays, timeout=WAIT)
    assert ann.match_end is not None and ann.match_end.reason == "max_ticks"
    assert isinstance(bob, Client)
    assert bob.match.template == "solo" and bob.match.name not in (None, ann.match.name)
    assert (bob_lobbies[0].queued, bob_lobbies[0].template, bob_lobbies[0].match) == (1, "solo", None)
    bob.close()
