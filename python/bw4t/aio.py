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
from typing import Any, AsyncIterator, Callable, Dict, Generator, List, Optional

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
from .errors import Bw4tError, FatalServerError, Timeout

_LINE_LIMIT = 64 * 1024 * 1024


class AsyncAction(ActionBase["AsyncClient"]):
    """A handle on one ``act`` (or ``say``) sent by an :class:`AsyncClient`.

    ``await action`` is ``await action.result()`` (the ack only, for actions that are not
    durative).
    """

    async def ack(self, timeout: Optional[float] = None) -> Ack:
        """Wait for the ``ack`` and return it. See :meth:`bw4t.client.Action.ack`."""
        record = self._record
        if not record.acked:
            await self._client._wait(lambda: record.acked, timeout, blocking=True)
        return record.answered_ack()

    async def result(self, timeout: Optional[float] = None) -> Optional[Result]:
        """Wait until a durative order ended; see :meth:`bw4t.client.Action.result`."""
        deadline = deadline_after(timeout)
        record = self._record
        if not record.expects_result(await self.ack(timeout)):
            return None
        if not record.done:
            await self._client._wait(lambda: record.done, time_left(deadline), blocking=True)
        return record.settled_result()

    def __await__(self) -> Generator[Any, None, Optional[Result]]:
        return self.result().__await__()


class AsyncClient(ClientBase[AsyncAction]):
    """A player connected to a bw4t server, with an asyncio API.

    Create it with ``await AsyncClient.connect(...)`` (same arguments as
    :meth:`bw4t.Client.connect`). Use it as ``async with`` to close it at the end.
    """

    def __init__(self, host: str, port: int, options: JoinOptions) -> None:
        super().__init__(host, port, options)
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
        words: bool = False,
        session: Optional[str] = None,
        timeout: Optional[float] = 30.0,
        match: Optional[str] = None,
        template: Optional[str] = None,
        on_lobby: Optional[Callable[[Lobby], None]] = None,
        options: Optional[JoinOptions] = None,
    ) -> "AsyncClient":
        """Connect and join a match; see :meth:`bw4t.Client.connect` (``on_lobby`` is a
        plain function, called from the task that reads the connection)."""
        join = JoinOptions.of(
            options, name=name, token=token, session=session, every_tick=every_tick,
            words=words, match=match, template=template, on_lobby=on_lobby,
        ).from_environment()
        client = cls(*resolve_address(host, port), join)
        await client._handshake(join, timeout)
        return client

    async def _handshake(self, options: JoinOptions, timeout: Optional[float]) -> None:
        deadline = deadline_after(timeout)
        opening = asyncio.open_connection(self.host, self.port, limit=_LINE_LIMIT)
        reader, self._writer = await asyncio.wait_for(opening, timeout)
        self._reader = reader
        self._open = True
        self._failure = None
        self._task = asyncio.ensure_future(self._read_loop(reader))
        core = self._core
        try:
            joined = self._send_hello(options)  # before the read task first runs
            await self._wait(core.seated_or_queued, time_left(deadline), False)
            if core.welcome is None:  # queued for a template: wait for a seat, unbounded
                await self._wait(lambda: core.welcome is not None, None, False)
                deadline = deadline_after(timeout)
            await self._wait(joined, time_left(deadline), False)
        except BaseException:
            await self._close_transport()
            raise

    async def reconnect(self, timeout: Optional[float] = 30.0) -> Welcome:
        """Take the robot back after a drop; see :meth:`bw4t.Client.reconnect`."""
        options = self._resume_options()
        await self._close_transport()
        self._core.connection_replaced()
        await self._handshake(options, timeout)
        return self.welcome

    async def close(self, bye: bool = True, timeout: float = 5.0) -> None:
        """Leave (``bye``) and close; ``bye=False`` keeps the robot for the grace period."""
        core = self._core
        if self._is_open and bye and not core.finished:
            try:
                self._send(core.bye())
                await self._wait(lambda: core.bye_reason is not None, timeout, False)
            except Bw4tError:
                pass
        await self._close_transport()
        core.client_closed()

    async def __aenter__(self) -> "AsyncClient":
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.close()

    # --------------------------------------------------------------- updates

    async def next_update(self, timeout: Optional[float] = None) -> Optional[Update]:
        """The next tick's update, or ``None`` once the match is over; see
        :meth:`bw4t.Client.next_update`."""
        core = self._core
        if not core.queue:
            self._flush_ready()
            await self._wait(lambda: bool(core.queue), timeout, False, stop_at_end=True)
        return core.pop_update()

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
        self._send(core.resync())
        await self._wait(lambda: not core.awaiting_snapshot, timeout, False)
        return core.beliefs

    async def ping(self, timeout: Optional[float] = 10.0) -> float:
        """Send ``ping`` and wait for the ``pong``; returns the round trip in seconds."""
        msg, ping_id = self._core.ping()
        start = time.monotonic()
        self._send(msg)
        await self._wait(lambda: ping_id in self._core.pongs, timeout, False)
        return time.monotonic() - start

    # --------------------------------------------------------------- plumbing

    def _action_handle(self, record: ActionRecord) -> AsyncAction:
        return AsyncAction(self, record)

    @property
    def _is_open(self) -> bool:
        return self._open and self._writer is not None

    def _send(self, msg: Dict[str, Any]) -> None:
        if not self._is_open:
            raise self._failure if isinstance(self._failure, Bw4tError) else self._core.closed_error()
        assert self._writer is not None
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
        core.end_wait(done, stop_at_end, self._failure)
