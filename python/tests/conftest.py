"""Fixtures: the real bw4t binary and servers started from it (always killed afterwards).

The binary is ``$BW4T_BIN``, else the newest of ``<repo>/target/release/bw4t`` and
``<repo>/target/debug/bw4t``. Without one, the tests fail with a clear message.
"""

from __future__ import annotations

import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable, Iterator, List, Tuple

import pytest

from fake_server import FakeConnection, FakeServer

CLIENT_DIR = Path(__file__).resolve().parents[1]  # python/: the package, its examples
REPO = Path(__file__).resolve().parents[2]

try:  # the installed package, else the one in this directory
    import bw4t  # noqa: F401
except ImportError:
    sys.path.insert(0, str(CLIENT_DIR))
    import bw4t  # noqa: F401

#: Seconds any single wait in the tests may take.
WAIT = 30.0


def find_binary() -> str:
    """The bw4t binary to test against."""
    env = os.environ.get("BW4T_BIN")
    if env:
        if not os.access(env, os.X_OK):
            pytest.fail(f"BW4T_BIN={env!r} is not an executable file")
        return env
    candidates = [REPO / "target" / kind / "bw4t" for kind in ("release", "debug")]
    present = [c for c in candidates if c.is_file() and os.access(c, os.X_OK)]
    if not present:
        pytest.fail(
            "no bw4t binary found: set BW4T_BIN, or build one with "
            f"`cd {REPO} && cargo build` (looked for {', '.join(map(str, candidates))})"
        )
    return str(max(present, key=lambda p: p.stat().st_mtime))


@pytest.fixture(scope="session")
def bw4t_bin() -> str:
    """Path of the bw4t binary."""
    return find_binary()


class Server:
    """A running ``bw4t serve`` process."""

    def __init__(self, proc: subprocess.Popen, host: str, port: int, log: Path) -> None:
        self.proc = proc
        self.host = host
        self.port = port
        self.log = log

    def stop(self) -> None:
        """Kill the server (if still running) and reap it."""
        if self.proc.poll() is None:
            self.proc.kill()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:  # pragma: no cover
            pass
        if self.proc.stdout is not None:
            self.proc.stdout.close()


@pytest.fixture
def serve(bw4t_bin: str, tmp_path: Path) -> Iterator[Callable[..., Server]]:
    """Start ``bw4t serve --port 0 ARGS...``; every server started is killed at the end.

    Defaults: ``--mode lockstep --map fixed --seed 1 --deadline-ms 0`` unless given; none
    with ``--config`` (its templates hold the settings).
    """
    servers: List[Server] = []

    def start(*args: str) -> Server:
        argv = list(args)
        defaults: List[Tuple[str, str]] = [
            ("--mode", "lockstep"), ("--map", "fixed"), ("--seed", "1"), ("--deadline-ms", "0"),
        ]
        if "--config" in argv:
            defaults = []
        for flag, value in defaults:
            if flag not in argv:
                argv += [flag, value]
        log = tmp_path / f"server{len(servers)}.log"
        with open(log, "wb") as err:
            proc = subprocess.Popen(
                [bw4t_bin, "serve", "--port", "0", *argv],
                stdout=subprocess.PIPE,
                stderr=err,
                stdin=subprocess.DEVNULL,
            )
        lines: "queue.Queue[bytes]" = queue.Queue()

        def pump() -> None:
            assert proc.stdout is not None
            for line in iter(proc.stdout.readline, b""):
                lines.put(line)

        threading.Thread(target=pump, daemon=True).start()
        server = Server(proc, "", 0, log)
        servers.append(server)
        try:
            line = lines.get(timeout=WAIT).decode()
        except queue.Empty:
            pytest.fail(f"bw4t serve printed no address; log: {log.read_text()}")
        if not line.startswith("listening on "):
            pytest.fail(f"unexpected first line from bw4t serve: {line!r}")
        host, port = line.split()[-1].rsplit(":", 1)
        server.host, server.port = host, int(port)
        return server

    yield start
    for server in servers:
        server.stop()


@pytest.fixture
def fake_server() -> Iterator[Callable[[Callable[[FakeConnection], None]], FakeServer]]:
    """Start a :class:`FakeServer` running a script per connection; each is stopped at
    the end, and an error in its scripts fails the test."""
    servers: List[FakeServer] = []

    def start(script: Callable[[FakeConnection], None]) -> FakeServer:
        server = FakeServer(script)
        servers.append(server)
        return server

    yield start
    for server in servers:
        server.stop()


def run_threads(*targets: Callable[[], object], timeout: float = 120.0) -> List[object]:
    """Run each function in its own thread; return their results, re-raising the first
    exception. Fails if any thread is still running after ``timeout`` seconds."""
    results: List[object] = [None] * len(targets)
    errors: List[BaseException] = []

    def wrap(i: int, fn: Callable[[], object]) -> None:
        try:
            results[i] = fn()
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=wrap, args=(i, fn), daemon=True) for i, fn in enumerate(targets)]
    for t in threads:
        t.start()
    deadline = time.monotonic() + timeout
    for t in threads:
        t.join(max(0.0, deadline - time.monotonic()))
    if errors:
        raise errors[0]
    if any(t.is_alive() for t in threads):
        pytest.fail(f"a client thread did not finish within {timeout} s")
    return results
