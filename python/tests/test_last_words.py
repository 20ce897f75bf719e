"""A match's last words reach the client even when its close arrives as a reset.

A server that ends a match sends ``match_end`` and ``bye`` and closes. A line the client
sends after that close makes the server's side answer with a reset, so the client's next
send fails while those last words are still unread; the client must read them first, so
``match_end`` is set and a pending action is lost to the match's end, not to a drop."""

from __future__ import annotations

import threading
from typing import Callable

import pytest
from bw4t import ActionLost, Client
from fake_server import WAIT, FakeConnection, FakeServer, snapshot, welcome

FakeFn = Callable[[Callable[[FakeConnection], None]], FakeServer]


def test_match_end_is_read_when_a_send_fails_after_the_close(fake_server: FakeFn) -> None:
    tick_read = threading.Event()
    server_closed = threading.Event()

    def last_words(conn: FakeConnection) -> None:
        conn.expect("hello")
        conn.send(welcome(mode="lockstep"), snapshot())
        assert conn.expect("ready")["tick"] == 0
        conn.send({"type": "percepts", "tick": 1, "add": [], "not": []})
        assert tick_read.wait(WAIT), "the client did not read tick 1"
        conn.send(
            {"type": "match_end", "reason": "completed", "result": {"completed": True}},
            {"type": "bye", "reason": "match_over"},
        )
        conn.close()  # nothing of the client's is unread yet: a clean close
        server_closed.set()

    server = fake_server(last_words)
    client = Client.connect(server.host, server.port, name="Ann", timeout=WAIT)
    assert [client.next_update(WAIT).tick for _ in range(2)] == [0, 1]  # type: ignore[union-attr]
    tick_read.set()  # the client now owes this tick's `ready`
    assert server_closed.wait(WAIT), "the fake server did not close"
    going = client.go_to("RoomA1")  # reaches a closed socket, which answers with a reset
    with pytest.raises(ActionLost, match="match ended"):
        going.ack(WAIT)  # sends the owed `ready` first: that send fails
    assert client.match_end is not None and client.match_end.reason == "completed"
    # The connection is gone and the match over: a later action is lost too, not an error.
    with pytest.raises(ActionLost):
        client.pick_up().ack(WAIT)
