"""The robot's situation in words: ``connect(words=True)`` against the real server."""

from __future__ import annotations

import asyncio
from typing import Callable, List, Optional

from bw4t import AsyncClient, Client, Update
from bw4t.core import ProtocolCore
from conftest import WAIT, Server

ServeFn = Callable[..., Server]


def connect(server: Server, name: Optional[str] = "Ann", **kw: object) -> Client:
    return Client.connect(server.host, server.port, name=name, timeout=WAIT, **kw)  # type: ignore[arg-type]


def test_hello_asks_for_words_only_when_told() -> None:
    core = ProtocolCore()
    assert core.hello("Ann", words=True)["words"] is True
    assert "words" not in core.hello("Ann")


def test_every_update_carries_the_situation_in_words(serve: ServeFn) -> None:
    server = serve("--max-ticks", "400")
    client = connect(server, words=True)
    first = client.next_update(WAIT)
    assert first is not None and first.full
    assert first.words is not None
    assert first.words.startswith("I am Ann (robot 0), at FrontDropZone, not in a room."), first.words
    assert client.words == client.beliefs.words == first.words
    assert client.go_to("RoomC1").result(WAIT).arrived  # type: ignore[union-attr]
    updates: List[Update] = []
    while client._core.queue:
        update = client.next_update(WAIT)
        assert update is not None
        updates.append(update)
    assert updates and all(u.words and u.words.startswith("I am Ann (robot 0)") for u in updates)
    assert client.words == updates[-1].words
    assert client.words is not None and client.words.startswith("I am Ann (robot 0), in RoomC1."), client.words
    client.resync(WAIT)
    snapshot = client.last_snapshot
    assert snapshot is not None and snapshot.words == client.words
    client.close()
    assert client.errors == []


def test_no_words_unless_asked(serve: ServeFn) -> None:
    server = serve("--max-ticks", "5")
    client = connect(server, every_tick=True)
    updates = list(client.updates(WAIT))
    assert [u.tick for u in updates] == [0, 1, 2, 3, 4, 5]
    assert all(u.words is None for u in updates)
    assert client.words is None and client.beliefs.words is None
    assert client.errors == []


def test_async_client_asks_again_when_it_reconnects(serve: ServeFn) -> None:
    server = serve("--grace-s", "30")

    async def main() -> None:
        client = await AsyncClient.connect(server.host, server.port, name="Ann", timeout=WAIT, words=True)
        first = await client.next_update(WAIT)
        assert first is not None and first.words is not None
        assert first.words.startswith("I am Ann (robot 0)"), first.words
        await client.close(bye=False)
        await client.reconnect(WAIT)
        snapshot: Optional[Update] = None
        while client._core.queue:
            snapshot = await client.next_update(WAIT)
        assert snapshot is not None and snapshot.full and snapshot.words == client.words
        assert client.words is not None and client.words.startswith("I am Ann (robot 0)")
        await client.close()
        assert client.errors == []

    asyncio.run(asyncio.wait_for(main(), 60))
