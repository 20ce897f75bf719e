"""A scripted bw4t server in the test process, for what the client sends and parses.

Each accepted connection runs ``script(conn)`` in its own thread; the script reads the
client's messages with ``conn.recv()`` and answers with ``conn.send(...)``. An exception
in a script (a failed assertion included) is kept and raised again by :meth:`FakeServer.stop`,
so the test fails with it. Every read is bounded.
"""

from __future__ import annotations

import json
import queue
import socket
import threading
from typing import Any, Callable, Dict, List, Optional

#: Seconds a fake server waits for a client's message or connection.
WAIT = 30.0

Message = Dict[str, Any]


class FakeConnection:
    """One client connection seen by the fake server."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.received: List[Message] = []
        self._buffer = b""

    def send(self, *messages: Message) -> None:
        """Send messages, one JSON line each."""
        data = b"".join(json.dumps(m).encode() + b"\n" for m in messages)
        self.sock.sendall(data)

    def recv(self, timeout: float = WAIT) -> Optional[Message]:
        """The client's next message; ``None`` once the client closed the connection."""
        self.sock.settimeout(timeout)
        while b"\n" not in self._buffer:
            try:
                data = self.sock.recv(65536)
            except ConnectionResetError:
                data = b""
            if not data:
                return None
            self._buffer += data
        line, self._buffer = self._buffer.split(b"\n", 1)
        msg = json.loads(line)
        self.received.append(msg)
        return msg

    def expect(self, kind: str, timeout: float = WAIT) -> Message:
        """The client's next message, which must be of type ``kind``."""
        msg = self.recv(timeout)
        assert msg is not None, f"the client closed the connection; expected {kind!r}"
        assert msg["type"] == kind, f"expected {kind!r}, got {msg}"
        return msg

    def wait_closed(self, timeout: float = WAIT) -> None:
        """Read (and keep) what the client still sends until it closes the connection."""
        while self.recv(timeout) is not None:
            pass

    def close(self) -> None:
        try:
            self.sock.close()
        except OSError:
            pass


class FakeServer:
    """Listens on a free port of 127.0.0.1; see the module's description."""

    def __init__(self, script: Callable[[FakeConnection], None]) -> None:
        self.script = script
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.host, self.port = "127.0.0.1", self.listener.getsockname()[1]
        #: Every accepted connection, in order.
        self.connections: "queue.Queue[FakeConnection]" = queue.Queue()
        self.errors: List[BaseException] = []
        self._threads: List[threading.Thread] = []
        self._stopping = False
        accept = threading.Thread(target=self._accept, daemon=True)
        accept.start()
        self._threads.append(accept)

    def _accept(self) -> None:
        while True:
            try:
                sock, _ = self.listener.accept()
            except OSError:
                return  # the listener was closed
            conn = FakeConnection(sock)
            self.connections.put(conn)
            thread = threading.Thread(target=self._run, args=(conn,), daemon=True)
            thread.start()
            self._threads.append(thread)

    def _run(self, conn: FakeConnection) -> None:
        try:
            self.script(conn)
        except BaseException as exc:  # noqa: BLE001 - raised again by stop()
            if not self._stopping:
                self.errors.append(exc)
        finally:
            conn.close()

    def next_connection(self, timeout: float = WAIT) -> FakeConnection:
        """The next connection accepted (in order), waiting for it."""
        return self.connections.get(timeout=timeout)

    def stop(self) -> None:
        """Stop listening, wait for the scripts, and raise the first error of one."""
        try:
            self.listener.shutdown(socket.SHUT_RDWR)  # wakes the blocked accept (Linux)
        except OSError:
            pass
        self.listener.close()
        for thread in self._threads:
            thread.join(WAIT)
        if self.errors:
            raise self.errors[0]
        assert not any(t.is_alive() for t in self._threads), "a fake server script did not finish"


# ------------------------------------------------------------- server messages


def welcome(
    name: str = "Ann",
    match: Optional[str] = "default",
    template: Optional[str] = None,
    session: str = "0123456789abcdef01234567",
    mode: str = "realtime",
    robot: int = 0,
) -> Message:
    """A ``welcome`` from a many-match server."""
    info: Message = {
        "map": "fixed", "seed": 1, "mode": mode, "tick_hz": 20, "players_needed": 2,
        "every_tick": False,
    }
    if mode == "lockstep":
        info["deadline_ms"] = 0
    if match is not None:
        info["name"] = match
    if template is not None:
        info["template"] = template
    return {"type": "welcome", "version": 1, "name": name, "robot": robot, "session": session, "match": info}


def snapshot(tick: int = 0, name: str = "Ann") -> Message:
    """A small full snapshot."""
    add = [["ownName", name], ["bot", 0], ["at", "FrontDropZone"], ["state", "arrived"], ["player", name]]
    return {"type": "percepts", "tick": tick, "add": add, "not": [], "full": True}


def lobby(**fields: Any) -> Message:
    """A ``lobby`` message with these fields."""
    return {"type": "lobby", **fields}


def fatal(code: str, message: str) -> List[Message]:
    """A fatal ``error`` and the ``bye`` that follows it."""
    return [
        {"type": "error", "code": code, "message": message, "fatal": True},
        {"type": "bye", "reason": code},
    ]
