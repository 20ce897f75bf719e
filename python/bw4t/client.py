"""The blocking client: one TCP connection, read and written by the calling thread.

Example::

    from bw4t import Client

    client = Client.connect()                     # BW4T_HOST/PORT/NAME/TOKEN or defaults
    for update in client.updates():               # one update per tick, until match_end
        if client.beliefs.state == "arrived" and not client.beliefs.room:
            client.go_to("RoomA1")
    print(client.match_end)
"""

from __future__ import annotations

import socket
import time
from typing import Any, Callable, Dict, Iterator, Optional

from ._base import ActionBase, ClientBase
from .beliefs import BeliefBase
from .core import (
    ActionRecord,
    JoinOptions,
    deadline_after,
    decode,
    encode,
    resolve_address,
    time_left,
)
from .data import Ack, Lobby, Result, Update, Welcome
from .errors import Bw4tError, ConnectionClosed, FatalServerError, Timeout


class Action(ActionBase["Client"]):
    """A handle on one ``act`` (or ``say``) sent by a :class:`Client`.

    ``ack()`` waits for the server's ``ack``; ``result()`` waits for the ``result`` of a
    durative action (``goTo``, ``goToBlock``). Waiting means the agent is done with the
    current tick: in lockstep the client first answers ``ready`` for it, and answers the
    ticks that arrive while it waits (they are still delivered by ``updates()``).
    """

    def ack(self, timeout: Optional[float] = None) -> Ack:
        """Wait for the ``ack`` and return it (``ok``, ``code``, ``reason``, ``tick``).

        Raises :class:`~bw4t.errors.ActionLost` if it will never come,
        :class:`~bw4t.errors.Timeout` if ``timeout`` seconds pass first.
        """
        record = self._record
        if not record.acked:
            self._client._wait(lambda: record.acked, timeout, blocking=True)
        return record.answered_ack()

    def result(self, timeout: Optional[float] = None) -> Optional[Result]:
        """Wait until a durative order ended; return its ``result``.

        Returns after the ``percepts`` of the tick it ended at was applied, so the belief
        base shows that tick; the ``ready`` for that tick is left to the agent, which can
        still act at it. Returns ``None`` at once (after the ack) for actions that are not
        durative. Raises :class:`~bw4t.errors.ActionRejected` if the ack refused it.
        """
        deadline = deadline_after(timeout)
        record = self._record
        if not record.expects_result(self.ack(timeout)):
            return None
        if not record.done:
            self._client._wait(lambda: record.done, time_left(deadline), blocking=True)
        return record.settled_result()

    def wait(self, timeout: Optional[float] = None) -> Optional[Result]:
        """``result()`` for durative actions; for others, the ack (raising if refused)."""
        return self.result(timeout)


class Client(ClientBase[Action]):
    """A player connected to a bw4t server, with a blocking API.

    Create it with :meth:`connect`. Attributes: ``welcome``, ``beliefs``, ``errors``
    (non-fatal server errors), ``match_end`` (set when the match is over).
    """

    def __init__(self, host: str, port: int, options: JoinOptions, timeout: Optional[float]) -> None:
        super().__init__(host, port, options)
        self._timeout = timeout
        self._sock: Optional[socket.socket] = None
        self._buffer = b""

    # ------------------------------------------------------------ connecting

    @classmethod
    def connect(
        cls,
        host: Optional[str] = None,
        port: Optional[int] = None,
        name: Optional[str] = None,
        token: Optional[str] = None,
        every_tick: bool = False,
        *,
        words: bool = False,
        session: Optional[str] = None,
        timeout: Optional[float] = 30.0,
        match: Optional[str] = None,
        template: Optional[str] = None,
        on_lobby: Optional[Callable[[Lobby], None]] = None,
        options: Optional[JoinOptions] = None,
    ) -> "Client":
        """Connect and join a match as a player.

        Missing ``host``/``port``/``name``/``token`` come from ``BW4T_HOST``,
        ``BW4T_PORT``, ``BW4T_NAME`` and ``BW4T_TOKEN`` (set by ``bw4t run``), else
        ``127.0.0.1:12300`` and no name (the server picks ``PlayerN``). ``session``
        takes back the robot of an earlier connection. ``every_tick`` asks for a
        ``percepts`` (so an update) every tick; ``words`` asks for the robot's situation
        in English with each one (``update.words``, ``client.words``). Returns after
        ``welcome`` and the first full snapshot (the first update of ``updates()``).
        ``timeout`` bounds the handshake, except the time spent waiting in a template's
        queue; raises :class:`~bw4t.errors.FatalServerError` when refused.

        ``match`` joins the live match of that name; ``template`` queues for the next
        match of that template with a free seat; neither joins the server's default
        match. Giving both raises :class:`ValueError` before connecting. ``on_lobby`` is
        called with every :class:`~bw4t.data.Lobby` received (also during ``connect``,
        while queued); an exception it raises ends the wait and closes the connection.

        ``options``: all of ``name`` to ``on_lobby`` as one :class:`~bw4t.core.JoinOptions`
        (then none of those arguments may be given).
        """
        join = JoinOptions.of(
            options, name=name, token=token, session=session, every_tick=every_tick,
            words=words, match=match, template=template, on_lobby=on_lobby,
        ).from_environment()
        client = cls(*resolve_address(host, port), join, timeout)
        client._handshake(join, timeout)
        return client

    def _handshake(self, options: JoinOptions, timeout: Optional[float]) -> None:
        deadline = deadline_after(timeout)
        self._buffer = b""
        self._sock = socket.create_connection((self.host, self.port), timeout=timeout)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        core = self._core
        try:
            joined = self._send_hello(options)
            self._wait(core.seated_or_queued, time_left(deadline), False)
            if core.welcome is None:  # queued for a template: wait for a seat, unbounded
                self._wait(lambda: core.welcome is not None, None, False)
                deadline = deadline_after(timeout)
            self._wait(joined, time_left(deadline), False)
        except BaseException:
            self._close_socket()
            raise

    def reconnect(self, timeout: Optional[float] = 30.0) -> Welcome:
        """Take the robot back after the connection dropped (``hello`` with ``session``).

        Closes the current connection if it is still open (without ``bye``, which would
        make the robot leave), connects again and waits for ``welcome`` and the full
        snapshot (queued as the next update). Actions without answers are lost
        (:class:`~bw4t.errors.ActionLost`). The ``hello`` names the match the session
        belongs to (``match.name``), also when the client joined by template. Raises
        :class:`~bw4t.errors.FatalServerError` with ``bad_session`` when the grace
        period has passed.
        """
        options = self._resume_options()
        self._close_socket()
        self._core.connection_replaced()
        self._handshake(options, timeout)
        return self.welcome

    def close(self, bye: bool = True, timeout: float = 5.0) -> None:
        """Leave: send ``bye`` (the robot leaves the match) and close the connection.

        ``bye=False`` only closes the socket: the server keeps the robot for its grace
        period, to be taken back with :meth:`reconnect` or ``connect(session=...)``.
        """
        core = self._core
        if self._is_open and bye and not core.finished:
            try:
                self._send(core.bye())
                self._wait(lambda: core.bye_reason is not None, timeout, False)
            except Bw4tError:
                pass
        self._close_socket()
        core.client_closed()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # --------------------------------------------------------------- updates

    def next_update(self, timeout: Optional[float] = None) -> Optional[Update]:
        """The next tick's :class:`~bw4t.data.Update`, or ``None`` once the match is over.

        Asking for the next update means the agent is done with the previous one: when
        every received update was handed out, the client answers the pending lockstep
        ``ready`` before waiting for more.
        """
        core = self._core
        if not core.queue:
            self._flush_ready()
            self._wait(lambda: bool(core.queue), timeout, False, stop_at_end=True)
        return core.pop_update()

    def updates(self, timeout: Optional[float] = None) -> Iterator[Update]:
        """Iterate over updates, one per tick the server sent something for, until the
        match ends (then :attr:`match_end` is set). ``timeout`` bounds each wait."""
        while True:
            update = self.next_update(timeout)
            if update is None:
                return
            yield update

    def resync(self, timeout: Optional[float] = None) -> BeliefBase:
        """Ask for a full snapshot and rebuild the belief base from it.

        Does not answer ``ready`` (the agent can still act at the current tick). The
        snapshot is not a new update; undelivered messages it carries come with the next
        update. Returns the belief base.
        """
        core = self._core
        self._send(core.resync())
        self._wait(lambda: not core.awaiting_snapshot, timeout, False)
        return core.beliefs

    def ping(self, timeout: Optional[float] = 10.0) -> float:
        """Send ``ping`` and wait for the ``pong``; returns the round trip in seconds."""
        msg, ping_id = self._core.ping()
        start = time.monotonic()
        self._send(msg)
        self._wait(lambda: ping_id in self._core.pongs, timeout, False)
        return time.monotonic() - start

    # --------------------------------------------------------------- plumbing

    def _action_handle(self, record: ActionRecord) -> Action:
        return Action(self, record)

    @property
    def _is_open(self) -> bool:
        return self._sock is not None

    def _send(self, msg: Dict[str, Any]) -> None:
        if self._sock is None:
            raise self._core.closed_error()
        try:
            self._sock.sendall(encode(msg))
        except OSError as exc:
            self._handle_what_is_left()
            self._close_socket()
            self._core.connection_lost()
            raise self._core.closed_error() if self._core.bye_reason else ConnectionClosed(
                f"sending failed: {exc}"
            ) from exc

    def _handle_what_is_left(self) -> None:
        """After a failed send, handle what the server sent before it closed, without
        waiting for more. A server that ends the match sends ``match_end`` and ``bye``,
        then closes; a line the client sent meanwhile makes that close a reset, and the
        next send fails while those last words are still unread."""
        sock = self._sock
        if sock is None:
            return
        sock.setblocking(False)
        while True:
            try:
                data = sock.recv(1 << 16)
            except OSError:  # nothing more now (BlockingIOError), or the reset itself
                break
            if not data:
                break
            self._buffer += data
        *lines, self._buffer = self._buffer.split(b"\n")
        for line in lines:
            msg = decode(line)
            if msg is None:
                continue
            try:
                self._core.handle(msg)
            except FatalServerError:
                pass  # kept in core.fatal, raised by the next wait

    def _close_socket(self) -> None:
        if self._sock is not None:
            try:
                self._sock.close()
            except OSError:
                pass
            self._sock = None
        self._buffer = b""

    def _read_message(self, deadline: Optional[float]) -> Optional[Dict[str, Any]]:
        """Read one message; ``None`` when the server closed the connection."""
        sock = self._sock
        if sock is None:
            return None
        while True:
            newline = self._buffer.find(b"\n")
            if newline >= 0:
                line, self._buffer = self._buffer[:newline], self._buffer[newline + 1 :]
                msg = decode(line)
                if msg is None:
                    continue
                return msg
            if deadline is None:
                sock.settimeout(None)
            else:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise Timeout("timed out waiting for the server")
                sock.settimeout(remaining)
            try:
                data = sock.recv(1 << 16)
            except socket.timeout:
                raise Timeout("timed out waiting for the server") from None
            except OSError:
                data = b""
            if not data:
                self._close_socket()
                return None
            self._buffer += data

    def _wait(
        self,
        done: Callable[[], bool],
        timeout: Optional[float],
        blocking: bool,
        stop_at_end: bool = False,
    ) -> None:
        """Process messages until ``done()``.

        ``blocking``: the agent waits for an answer, so it is done with the current tick:
        answer ``ready`` now and for every tick that arrives without making ``done()``
        true. ``stop_at_end``: return quietly when the match is over or the server
        closed the connection normally; otherwise that raises.
        """
        core = self._core
        deadline = deadline_after(timeout)
        if blocking:
            self._flush_ready()
        while not done():
            if stop_at_end and core.finished and self._sock is None:
                return
            if core.fatal is not None:
                raise core.fatal
            msg = self._read_message(deadline)
            if msg is None:  # the connection closed
                core.connection_lost()
                core.end_wait(done, stop_at_end)
                return
            try:
                update = core.handle(msg)
            except FatalServerError:
                self._close_socket()  # the server closes it after its bye anyway
                raise
            if update is not None and blocking and not done():
                self._flush_ready()
