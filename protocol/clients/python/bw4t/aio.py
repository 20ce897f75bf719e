"""The asyncio client: the same protocol logic as :mod:`bw4t.client`, with awaitables.

Example::

    import asyncio
    from bw4t import AsyncClient

    async def main() -> None:
        client = await AsyncClient.connect()
        async for update in client.updates():
            if client.beliefs.room is None and client.beliefs.state == "arrived":
                result = await client.go_to("RoomA1")    # waits for the result
        print(client.match_end)

    asyncio.run(main())

A background task reads the connection, so the belief base stays current while the
agent awaits anything. Awaiting an action's ``ack()``/``result()`` (or the action itself)
means the agent is done with the current tick: in lockstep the client answers ``ready``
for it and for the ticks that arrive while it waits.
"""

from __future__ import annotations

import asyncio
import time
from typing import Any, AsyncIterator, Callable, Dict, Generator, List, Optional, Tuple

from .beliefs import BeliefBase
from .core import ActionRecord, ProtocolCore, decode, encode, resolve_address
from .data import Ack, MatchEnd, MatchInfo, Result, Update, Welcome
from .errors import ActionRejected, Bw4tError, FatalServerError, ServerError, Timeout

_LINE_LIMIT = 64 * 1024 * 1024


class AsyncAction:
    """A handle on one ``act`` (or ``say``) sent by an :class:`AsyncClient`.

    ``await action`` is ``await action.result()`` (the ack only, for actions that are not
    durative).
    """

    def __init__(self, client: "AsyncClient", record: ActionRecord) -> None:
        self._client = client
        self._record = record

    @property
    def id(self) -> Any:
        """The id sent in the ``act``."""
        return self._record.id

    @property
    def action(self) -> str:
        """The action's name."""
        return self._record.action

    @property
    def args(self) -> Tuple[Any, ...]:
        """The action's arguments."""
        return self._record.args

    @property
    def acked(self) -> bool:
        """Whether the ``ack`` arrived (no waiting)."""
        return self._record.ack is not None

    @property
    def done(self) -> bool:
        """Whether nothing more will arrive for this action (no waiting)."""
        return self._record.done

    async def ack(self, timeout: Optional[float] = None) -> Ack:
        """Wait for the ``ack`` and return it. See :meth:`bw4t.client.Action.ack`."""
        record = self._record
        if record.ack is None and record.lost is None:
            await self._client._wait(lambda: record.acked, timeout, blocking=True)
        if record.ack is None:
            assert record.lost is not None
            raise record.lost
        return record.ack

    async def result(self, timeout: Optional[float] = None) -> Optional[Result]:
        """Wait until a durative order ended; see :meth:`bw4t.client.Action.result`."""
        start = time.monotonic()
        ack = await self.ack(timeout)
        if not ack.ok:
            raise ActionRejected(self._record.action, ack)
        record = self._record
        if not record.durative:
            return None
        if not record.done:
            remaining = None if timeout is None else max(0.0, timeout - (time.monotonic() - start))
            await self._client._wait(lambda: record.done, remaining, blocking=True)
        if record.result is None or not record.settled:
            assert record.lost is not None
            raise record.lost
        return record.result

    def __await__(self) -> Generator[Any, None, Optional[Result]]:
        return self.result().__await__()

    def __repr__(self) -> str:
        r = self._record
        return f"<AsyncAction {r.id} {r.action}{list(r.args)} ack={r.ack} result={r.result}>"


class AsyncClient:
    """A player connected to a bw4t server, with an asyncio API.

    Create it with ``await AsyncClient.connect(...)`` (same arguments as
    :meth:`bw4t.Client.connect`). Use it as ``async with`` to close it at the end.
    """

    def __init__(
        self,
        host: str,
        port: int,
        name: Optional[str],
        token: Optional[str],
        every_tick: bool,
    ) -> None:
        self.host = host
        self.port = port
        self._name = name
        self._token = token
        self._every_tick = every_tick
        self._core = ProtocolCore()
        self._reader: Optional[asyncio.StreamReader] = None
        self._writer: Optional[asyncio.StreamWriter] = None
        self._task: Optional["asyncio.Task[None]"] = None
        self._open = False
        self._cond = asyncio.Condition()
        self._waiters: List[Callable[[], bool]] = []
        self._failure: Optional[BaseException] = None

    # ------------------------------------------------------------ connecting

    @classmethod
    async def connect(
        cls,
        host: Optional[str] = None,
        port: Optional[int] = None,
        name: Optional[str] = None,
        token: Optional[str] = None,
        every_tick: bool = False,
        *,
        session: Optional[str] = None,
        timeout: Optional[float] = 30.0,
    ) -> "AsyncClient":
        """Connect and join the match; see :meth:`bw4t.Client.connect`."""
        host, port, name, token = resolve_address(host, port, name, token)
        client = cls(host, port, name, token, every_tick)
        await client._handshake(session, timeout)
        return client

    async def _handshake(self, session: Optional[str], timeout: Optional[float]) -> None:
        start = time.monotonic()
        opening = asyncio.open_connection(self.host, self.port, limit=_LINE_LIMIT)
        reader, self._writer = await asyncio.wait_for(opening, timeout)
        self._reader = reader
        self._open = True
        self._failure = None
        core = self._core
        core.welcome = None
        core.fatal = None
        first = len(core.queue)
        self._task = asyncio.ensure_future(self._read_loop(reader))
        self._send(core.hello(self._name, self._token, session, self._every_tick))
        remaining = None if timeout is None else max(0.0, timeout - (time.monotonic() - start))
        try:
            await self._wait(lambda: core.welcome is not None and len(core.queue) > first, remaining, False)
        except BaseException:
            await self._close_transport()
            raise

    async def reconnect(self, timeout: Optional[float] = 30.0) -> Welcome:
        """Take the robot back after a drop; see :meth:`bw4t.Client.reconnect`."""
        session = self.session
        if session is None:
            raise Bw4tError("no session to reconnect with")
        await self._close_transport()
        self._core.connection_lost("the connection was replaced before the action's answer")
        self._core.bye_reason = None
        await self._handshake(session, timeout)
        assert self._core.welcome is not None
        return self._core.welcome

    async def close(self, bye: bool = True, timeout: float = 5.0) -> None:
        """Leave (``bye``) and close; ``bye=False`` keeps the robot for the grace period."""
        if self._open and bye and not self._core.finished:
            try:
                self._send({"type": "bye"})
                await self._wait(lambda: self._core.bye_reason is not None, timeout, False)
            except Bw4tError:
                pass
        await self._close_transport()
        self._core.connection_lost("the client closed the connection")

    async def __aenter__(self) -> "AsyncClient":
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.close()

    # ------------------------------------------------------------------ info

    @property
    def welcome(self) -> Welcome:
        """The ``welcome`` of the current connection."""
        assert self._core.welcome is not None
        return self._core.welcome

    @property
    def name(self) -> Optional[str]:
        """This player's name."""
        return self.welcome.name

    @property
    def robot(self) -> Optional[int]:
        """This robot's id."""
        return self.welcome.robot

    @property
    def session(self) -> Optional[str]:
        """The session token to take the robot back after a drop."""
        return None if self._core.welcome is None else self._core.welcome.session

    @property
    def match(self) -> MatchInfo:
        """About the match (map, seed, mode, ...)."""
        return self.welcome.match

    @property
    def beliefs(self) -> BeliefBase:
        """The belief base (latest state received)."""
        return self._core.beliefs

    @property
    def errors(self) -> List[ServerError]:
        """Non-fatal ``error`` messages received so far."""
        return self._core.errors

    @property
    def match_end(self) -> Optional[MatchEnd]:
        """The ``match_end`` once the match is over, else ``None``."""
        return self._core.match_end

    @property
    def result(self) -> Optional[Dict[str, Any]]:
        """The match result object once the match is over, else ``None``."""
        return None if self._core.match_end is None else self._core.match_end.result

    @property
    def finished(self) -> bool:
        """Whether the match is over."""
        return self._core.finished

    # --------------------------------------------------------------- actions

    def act(self, action: str, *args: Any) -> AsyncAction:
        """Send ``act`` now and return its handle (await it, or its ``ack()``/``result()``)."""
        msg, record = self._core.act(action, args)
        self._send(msg)
        return AsyncAction(self, record)

    def go_to(self, place: str) -> AsyncAction:
        """``goTo(place)`` (durative)."""
        return self.act("goTo", place)

    def go_to_block(self, block: int) -> AsyncAction:
        """``goToBlock(block)`` (durative)."""
        return self.act("goToBlock", block)

    def pick_up(self, block: Optional[int] = None) -> AsyncAction:
        """``pickUp`` the block the robot is at, or the named one."""
        return self.act("pickUp") if block is None else self.act("pickUp", block)

    def put_down(self) -> AsyncAction:
        """``putDown`` the held block."""
        return self.act("putDown")

    def say(self, to: str, text: str) -> AsyncAction:
        """Send a message to a player's name or ``"all"`` (a ``say``)."""
        msg, record = self._core.say(to, text)
        self._send(msg)
        return AsyncAction(self, record)

    def send_message(self, to: str, text: str) -> AsyncAction:
        """``act`` ``sendMessage(to, text)``."""
        return self.act("sendMessage", to, text)

    # --------------------------------------------------------------- updates

    async def next_update(self, timeout: Optional[float] = None) -> Optional[Update]:
        """The next tick's update, or ``None`` once the match is over; see
        :meth:`bw4t.Client.next_update`."""
        core = self._core
        if not core.queue:
            self._flush_ready()
            await self._wait(lambda: bool(core.queue), timeout, False, stop_at_end=True)
        if core.queue:
            core.forget_done()
            return core.queue.popleft()
        return None

    async def updates(self, timeout: Optional[float] = None) -> AsyncIterator[Update]:
        """``async for update in client.updates(): ...`` until the match ends."""
        while True:
            update = await self.next_update(timeout)
            if update is None:
                return
            yield update

    async def resync(self, timeout: Optional[float] = None) -> BeliefBase:
        """Ask for a full snapshot and rebuild the belief base; see :meth:`bw4t.Client.resync`."""
        core = self._core
        core.awaiting_snapshot = True
        self._send({"type": "resync"})
        await self._wait(lambda: not core.awaiting_snapshot, timeout, False)
        return core.beliefs

    @property
    def last_snapshot(self) -> Optional[Update]:
        """The full snapshot that answered the last :meth:`resync`."""
        return self._core.last_snapshot

    async def ping(self, timeout: Optional[float] = 10.0) -> float:
        """Send ``ping`` and wait for the ``pong``; returns the round trip in seconds."""
        msg, ping_id = self._core.ping()
        start = time.monotonic()
        self._send(msg)
        await self._wait(lambda: ping_id in self._core.pongs, timeout, False)
        return time.monotonic() - start

    # --------------------------------------------------------------- plumbing

    def _send(self, msg: Dict[str, Any]) -> None:
        if not self._open or self._writer is None:
            raise self._failure if isinstance(self._failure, Bw4tError) else self._core.closed_error()
        self._writer.write(encode(msg))

    def _flush_ready(self) -> None:
        msg = self._core.take_ready()
        if msg is not None and self._open and self._writer is not None:
            self._writer.write(encode(msg))

    async def _close_transport(self) -> None:
        self._open = False
        task, self._task = self._task, None
        writer, self._writer = self._writer, None
        if writer is not None:
            try:
                writer.close()
                await asyncio.wait_for(writer.wait_closed(), 2.0)
            except (OSError, asyncio.TimeoutError):
                pass
        if task is not None and not task.done():
            task.cancel()
            try:
                await task
            except (asyncio.CancelledError, Exception):
                pass

    async def _read_loop(self, reader: asyncio.StreamReader) -> None:
        """Read and handle messages until the connection closes."""
        core = self._core
        try:
            while True:
                try:
                    line = await reader.readline()
                except (OSError, ValueError):
                    line = b""
                if not line:
                    break
                msg = decode(line)
                if msg is None:
                    continue
                try:
                    update = core.handle(msg)
                except FatalServerError:
                    update = None  # kept in core.fatal; the bye and the close follow
                if update is not None and self._waiters and not any(w() for w in self._waiters):
                    self._flush_ready()
                async with self._cond:
                    self._cond.notify_all()
                if self._writer is not None:
                    try:
                        await self._writer.drain()
                    except OSError:
                        pass  # the read side notices the close
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # a protocol error: stop reading, report it to waiters
            self._failure = exc
        if self._reader is reader:
            self._open = False
            core.connection_lost()
            if self._writer is not None:
                self._writer.close()  # the server closed: release the transport
            async with self._cond:
                self._cond.notify_all()

    async def _wait(
        self,
        done: Callable[[], bool],
        timeout: Optional[float],
        blocking: bool,
        stop_at_end: bool = False,
    ) -> None:
        """Wait until ``done()``; see :meth:`bw4t.Client._wait`."""
        core = self._core

        def ready() -> bool:
            return done() or core.fatal is not None or self._failure is not None or not self._open

        if blocking:
            self._flush_ready()
            self._waiters.append(done)
        try:
            async with self._cond:
                try:
                    await asyncio.wait_for(self._cond.wait_for(ready), timeout)
                except asyncio.TimeoutError:
                    raise Timeout("timed out waiting for the server") from None
        finally:
            if blocking:
                self._waiters.remove(done)
        if done():
            return
        if core.fatal is not None:
            raise core.fatal
        if self._failure is not None:
            raise self._failure
        if stop_at_end and (core.finished or core.bye_reason == "goodbye"):
            return
        raise core.closed_error()
