"""The protocol logic shared by the blocking and the asyncio client (no I/O here).

:class:`ProtocolCore` turns server messages into state (welcome, belief base, action
answers, per-tick :class:`~bw4t.data.Update` objects) and builds the client's messages.
It also keeps the lockstep bookkeeping: which tick the client still has to answer with
``ready``. The I/O classes decide *when* to send that ``ready``.
"""

from __future__ import annotations

import json
import os
import time
from collections import deque
from dataclasses import dataclass, replace
from typing import Any, Callable, Deque, Dict, List, Optional, Tuple

from .beliefs import BeliefBase
from .data import Ack, ActId, Lobby, MatchEnd, Message, Result, Update, Welcome
from .errors import (
    ActionLost,
    ActionRejected,
    Bw4tError,
    ConnectionClosed,
    FatalServerError,
    ProtocolError,
    ServerError,
)

PROTOCOL = "bw4t"
#: Protocol versions this client speaks.
VERSIONS = (1,)
#: Actions whose order ends with a ``result`` after the ``ack``.
DURATIVE_ACTIONS = frozenset({"goTo", "goToBlock"})
DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 12300


def resolve_address(host: Optional[str], port: Optional[int]) -> Tuple[str, int]:
    """Fill a missing address from ``BW4T_HOST`` and ``BW4T_PORT`` (as set by ``bw4t
    run``), else the defaults ``127.0.0.1:12300``. Empty variables count as unset."""
    host = host or os.environ.get("BW4T_HOST") or DEFAULT_HOST
    if port is None:
        env_port = os.environ.get("BW4T_PORT")
        port = int(env_port) if env_port else DEFAULT_PORT
    return host, int(port)


def check_join(match: Optional[str], template: Optional[str]) -> None:
    """Refuse a ``hello`` that names both a match and a template (the server would
    answer ``bad_message``): a player joins one match, or is queued for a template."""
    if match and template:
        raise ValueError(
            f"give match= or template=, not both (match {match!r}, template {template!r}): "
            "match joins that live match, template queues for the next match of that template"
        )


@dataclass(frozen=True)
class JoinOptions:
    """How a player joins a match: what its ``hello`` asks for, and who hears of the
    ``lobby`` messages. One value for :meth:`bw4t.Client.connect`,
    :meth:`bw4t.AsyncClient.connect` and :class:`ProtocolCore`, whose keyword arguments
    of the same names are a shorthand for it.

    ``match`` joins the live match of that name; ``template`` queues for the next match
    of that template with a free seat; neither joins the server's default match. Giving
    both raises :class:`ValueError`.
    """

    #: The player name wanted; ``None``: the server picks ``PlayerN``.
    name: Optional[str] = None
    #: The server's shared secret (``--token``).
    token: Optional[str] = None
    #: A ``session`` of an earlier ``welcome``: take that robot back.
    session: Optional[str] = None
    #: A ``percepts`` (so an update) every tick.
    every_tick: bool = False
    #: The robot's situation in English with every ``percepts``.
    words: bool = False
    #: The name of a live match to join.
    match: Optional[str] = None
    #: The name of a template: queued into its next match with a free seat.
    template: Optional[str] = None
    #: The seat token a study's trial page gives: a template that seats only invited
    #: players (a study's condition) refuses a player without it (``not_invited``).
    seat: Optional[str] = None
    #: Called with each :class:`~bw4t.data.Lobby` as it is received.
    on_lobby: Optional[Callable[[Lobby], None]] = None

    def __post_init__(self) -> None:
        check_join(self.match, self.template)

    @classmethod
    def of(cls, options: Optional["JoinOptions"] = None, **keywords: Any) -> "JoinOptions":
        """``options``, or the options the keyword arguments name (those left at their
        defaults are not counted); not both."""
        given = {key: value for key, value in keywords.items() if value is not None and value is not False}
        if options is None:
            return cls(**given)
        if given:
            raise ValueError(f"give options= or its keyword arguments, not both (also given: {', '.join(given)})")
        return options

    def from_environment(self) -> "JoinOptions":
        """The name and token not given taken from ``BW4T_NAME`` and ``BW4T_TOKEN`` (as
        set by ``bw4t run``); empty variables count as unset."""
        return replace(
            self,
            name=self.name or os.environ.get("BW4T_NAME") or None,
            token=self.token or os.environ.get("BW4T_TOKEN") or None,
        )

    def resuming(self, session: str, match: Optional[str]) -> "JoinOptions":
        """The options that take the robot of ``session`` back: in ``match``, the match
        the session belongs to (else the one asked for), never by template."""
        return replace(self, session=session, match=match or self.match, template=None)

    def hello(self) -> Dict[str, Any]:
        """The ``hello`` message (a player's); fields left at their defaults are left out."""
        msg: Dict[str, Any] = {"type": "hello", "protocol": PROTOCOL, "versions": list(VERSIONS)}
        for key in ("name", "token", "session", "every_tick", "words", "match", "template", "seat"):
            value = getattr(self, key)
            if value:
                msg[key] = value
        return msg


def deadline_after(timeout: Optional[float]) -> Optional[float]:
    """The :func:`time.monotonic` instant ``timeout`` seconds from now (``None``: never)."""
    return None if timeout is None else time.monotonic() + timeout


def time_left(deadline: Optional[float]) -> Optional[float]:
    """Seconds until ``deadline`` (at least 0), ``None`` without one."""
    return None if deadline is None else max(0.0, deadline - time.monotonic())


def encode(msg: Dict[str, Any]) -> bytes:
    """One message as a compact JSON line."""
    return (json.dumps(msg, separators=(",", ":"), ensure_ascii=False) + "\n").encode("utf-8")


def decode(line: bytes) -> Optional[Dict[str, Any]]:
    """Parse one line from the server; ``None`` for blank lines."""
    text = line.decode("utf-8").rstrip("\r\n")
    if not text.strip():
        return None
    try:
        msg = json.loads(text)
    except ValueError as exc:
        raise ProtocolError(f"server sent a line that is not JSON: {text[:200]!r}") from exc
    if not isinstance(msg, dict) or not isinstance(msg.get("type"), str):
        raise ProtocolError(f"server sent a line that is not a message: {text[:200]!r}")
    return msg


@dataclass
class ActionRecord:
    """The client's bookkeeping for one ``act`` or ``say``."""

    id: ActId
    action: str
    args: Tuple[Any, ...]
    ack: Optional[Ack] = None
    result: Optional[Result] = None
    #: True once the ``percepts`` of the tick the result arrived in was processed, so
    #: that the belief base already shows the state the order ended in.
    settled: bool = False
    lost: Optional[Bw4tError] = None

    @property
    def durative(self) -> bool:
        """Whether a ``result`` follows an accepting ``ack``."""
        return self.action in DURATIVE_ACTIONS

    @property
    def acked(self) -> bool:
        """Whether the ack arrived, or it never will."""
        return self.ack is not None or self.lost is not None

    @property
    def done(self) -> bool:
        """Whether nothing more will arrive for this action."""
        if self.lost is not None:
            return True
        if self.ack is None:
            return False
        if not self.ack.ok or not self.durative:
            return True
        return self.settled

    # The answers for the action handles, once the client waited for them.

    def answered_ack(self) -> Ack:
        """The ``ack``; raises the :class:`~bw4t.errors.ActionLost` if it never came."""
        if self.ack is None:
            assert self.lost is not None
            raise self.lost
        return self.ack

    def expects_result(self, ack: Ack) -> bool:
        """After ``ack``: whether a ``result`` is to be waited for (durative actions).

        Raises :class:`~bw4t.errors.ActionRejected` if the ack refused the action.
        """
        if not ack.ok:
            raise ActionRejected(self.action, ack)
        return self.durative

    def settled_result(self) -> Result:
        """The ``result`` of a finished durative order (its tick's ``percepts`` applied);
        raises the :class:`~bw4t.errors.ActionLost` if it never came."""
        if self.result is None or not self.settled:
            assert self.lost is not None
            raise self.lost
        return self.result


class ProtocolCore:
    """State of one player's protocol session, independent of the transport.

    Feed every server message to :meth:`handle`; send what :meth:`hello`, :meth:`act`,
    :meth:`say` and :meth:`take_ready` return.
    """

    def __init__(self) -> None:
        self.beliefs = BeliefBase()
        self.welcome: Optional[Welcome] = None
        #: Completed per-tick updates not yet handed to the agent, oldest first.
        self.queue: Deque[Update] = deque()
        #: Non-fatal errors received, oldest first.
        self.errors: List[ServerError] = []
        self.fatal: Optional[FatalServerError] = None
        self.match_end: Optional[MatchEnd] = None
        self.bye_reason: Optional[str] = None
        #: The tick of the last ``percepts`` not yet answered with ``ready`` (lockstep).
        self.pending_ready: Optional[int] = None
        self.awaiting_snapshot = False
        self.last_snapshot: Optional[Update] = None
        self.pongs: Dict[Any, int] = {}
        #: The latest ``lobby`` received (``None`` before any).
        self.lobby: Optional[Lobby] = None
        #: Whether the operator has paused the match (the latest ``pause``).
        self.paused = False
        #: Called with each ``lobby`` as it is received.
        self.on_lobby: Optional[Callable[[Lobby], None]] = None
        #: True from a ``lobby`` with a queue place until ``welcome`` (no seat yet).
        self.in_queue = False
        self._actions: Dict[ActId, ActionRecord] = {}
        self._next_id = 1
        self._acks: List[Ack] = []
        self._results: List[Result] = []
        self._errors: List[ServerError] = []
        self._carried: List[Message] = []

    # ------------------------------------------------------------- properties

    @property
    def lockstep(self) -> bool:
        """Whether ``ready`` must be answered (known after ``welcome``)."""
        return self.welcome is not None and self.welcome.match.lockstep

    @property
    def finished(self) -> bool:
        """Whether the match ended (``match_end`` received)."""
        return self.match_end is not None

    # --------------------------------------------------------- client messages

    def hello(
        self,
        name: Optional[str] = None,
        token: Optional[str] = None,
        session: Optional[str] = None,
        every_tick: bool = False,
        match: Optional[str] = None,
        template: Optional[str] = None,
        words: bool = False,
        *,
        options: Optional[JoinOptions] = None,
    ) -> Dict[str, Any]:
        """The ``hello`` message (a player's) of ``options``, or of the
        :class:`JoinOptions` the other arguments name.

        Raises :class:`ValueError` if both ``match`` and ``template`` are given.
        """
        return JoinOptions.of(
            options, name=name, token=token, session=session, every_tick=every_tick,
            match=match, template=template, words=words,
        ).hello()

    def begin_handshake(self, options: JoinOptions) -> Tuple[Dict[str, Any], Callable[[], bool]]:
        """Start over on a new connection: the ``hello`` to send, and the condition the
        handshake waits for (``welcome`` and the first full snapshot received)."""
        hello = options.hello()
        self.on_lobby = options.on_lobby
        self.welcome = None
        self.fatal = None
        self.in_queue = False
        first = len(self.queue)

        def joined() -> bool:
            return self.welcome is not None and len(self.queue) > first

        return hello, joined

    def seated_or_queued(self) -> bool:
        """During the handshake: ``welcome`` arrived, or the player waits in a template's
        queue (then the wait for a seat has no time limit)."""
        return self.welcome is not None or self.in_queue

    def resume_match(self) -> Optional[str]:
        """The name of the match this connection's session belongs to (sent as ``match``
        when taking the robot back), if the server named it."""
        return None if self.welcome is None else self.welcome.match.name

    def _new_id(self) -> int:
        action_id = self._next_id
        self._next_id += 1
        return action_id

    def act(self, action: str, args: Tuple[Any, ...]) -> Tuple[Dict[str, Any], ActionRecord]:
        """An ``act`` message with a fresh id, and its record."""
        record = ActionRecord(self._new_id(), action, tuple(args))
        self._actions[record.id] = record
        msg = {"type": "act", "id": record.id, "action": action, "args": list(args)}
        return msg, record

    def say(
        self, to: str, text: Optional[str] = None, said: Optional[Dict[str, Any]] = None
    ) -> Tuple[Dict[str, Any], ActionRecord]:
        """A ``say`` message with a fresh id, and its record: free ``text``, or ``said``, a
        message of the shared language (``{"kind": ..., "room": ..., ...}``)."""
        if (text is None) == (said is None):
            raise ValueError("say takes text or said, exactly one")
        record = ActionRecord(self._new_id(), "sendMessage", (to, text if said is None else said))
        self._actions[record.id] = record
        msg: Dict[str, Any] = {"type": "say", "id": record.id, "to": to}
        if said is None:
            msg["text"] = text
        else:
            msg["said"] = said
        return msg, record

    def ping(self) -> Tuple[Dict[str, Any], Any]:
        """A ``ping`` message with a fresh id, and that id."""
        ping_id = f"ping-{self._new_id()}"
        return {"type": "ping", "id": ping_id}, ping_id

    def resync(self) -> Dict[str, Any]:
        """The ``resync`` message; :attr:`awaiting_snapshot` is true until its answer."""
        self.awaiting_snapshot = True
        return {"type": "resync"}

    def bye(self) -> Dict[str, Any]:
        """The ``bye`` message (the robot leaves the match)."""
        return {"type": "bye"}

    def take_ready(self) -> Optional[Dict[str, Any]]:
        """The ``ready`` still owed to the server, if any (then it counts as sent).

        In lockstep every ``percepts`` (including the snapshots after ``welcome`` and
        ``resync``) is answered once with its tick; a ``ready`` covers every tick
        received so far, so only the latest one is sent.
        """
        if self.pending_ready is None or self.finished:
            return None
        tick = self.pending_ready
        self.pending_ready = None
        for update in self.queue:
            if update.tick <= tick:
                update.answered = True
        return {"type": "ready", "tick": tick}

    # --------------------------------------------------------- server messages

    def handle(self, msg: Dict[str, Any]) -> Optional[Update]:
        """Process one server message. Returns the tick's :class:`Update` when ``msg`` is
        a ``percepts`` that ends a tick (it is then also in :attr:`queue`).

        Raises :class:`FatalServerError` for a fatal ``error``.
        """
        kind = msg.get("type")
        if kind == "percepts":
            return self._percepts(msg)
        if kind == "ack":
            ack = Ack.from_json(msg)
            self._acks.append(ack)
            record = self._actions.get(ack.id) if ack.id is not None else None
            if record is not None and record.ack is None:
                record.ack = ack
        elif kind == "result":
            result = Result.from_json(msg)
            self._results.append(result)
            record = self._actions.get(result.id)
            if record is not None and record.result is None:
                record.result = result
        elif kind == "error":
            fatal = bool(msg.get("fatal"))
            code = str(msg.get("code", "unknown"))
            text = str(msg.get("message", ""))
            if fatal:
                self.fatal = FatalServerError(code, text, True)
                self._lose_all(self.fatal)
                raise self.fatal
            error = ServerError(code, text, False)
            self.errors.append(error)
            self._errors.append(error)
        elif kind == "welcome":
            self.welcome = Welcome.from_json(msg)
            self.in_queue = False
        elif kind == "lobby":
            # Before the first tick only (and before welcome while queued); it changes no
            # tick state, so it is not part of any update.
            self.lobby = Lobby.from_json(msg)
            if self.welcome is None and self.lobby.in_queue:
                self.in_queue = True
            if self.on_lobby is not None:
                self.on_lobby(self.lobby)
        elif kind == "pause":
            # The operator paused (or resumed) the match; no tick comes while paused.
            self.paused = bool(msg.get("paused"))
        elif kind == "pong":
            key = msg.get("id")
            self.pongs[key] = self.pongs.get(key, 0) + 1
        elif kind == "match_end":
            self.match_end = MatchEnd(str(msg.get("reason", "")), dict(msg.get("result") or {}))
            self.pending_ready = None  # no ready is expected for the last tick
            self._lose_all(ActionLost("the match ended before the action's answer"))
        elif kind == "bye":
            self.bye_reason = str(msg.get("reason", ""))
        # Unknown types (and spectator frames) are ignored, as the protocol asks.
        return None

    def _percepts(self, msg: Dict[str, Any]) -> Optional[Update]:
        tick = int(msg.get("tick", 0))
        full = bool(msg.get("full", False))
        words = msg.get("words")
        if not isinstance(words, str):
            words = None
        added, removed, messages = self.beliefs.apply(
            tick, msg.get("add") or [], msg.get("not") or [], full, words
        )
        if self.lockstep:
            self.pending_ready = tick
        if self.awaiting_snapshot and full:
            # The answer to resync: not a new tick for the agent. Its messages (if any
            # were undelivered) are handed over with the next update.
            self.awaiting_snapshot = False
            self.last_snapshot = Update(
                tick, True, added, removed, messages=messages, answered=not self.lockstep, words=words
            )
            self._carried.extend(messages)
            return None
        update = Update(
            tick=tick,
            full=full,
            added=added,
            removed=removed,
            acks=self._acks,
            results=self._results,
            messages=self._carried + messages,
            errors=self._errors,
            answered=not self.lockstep,
            words=words,
        )
        for result in self._results:
            record = self._actions.get(result.id)
            if record is not None and record.result is result:
                record.settled = True
        self._acks, self._results, self._errors, self._carried = [], [], [], []
        self.queue.append(update)
        return update

    # --------------------------------------------------------------- endings

    def _lose_all(self, error: Bw4tError) -> None:
        for record in self._actions.values():
            if not record.done:
                record.lost = error
        self._actions = {k: r for k, r in self._actions.items() if not r.done}

    def connection_lost(self, reason: Optional[str] = None) -> None:
        """The transport closed: unanswered actions will never be answered."""
        self.pending_ready = None
        self.awaiting_snapshot = False
        self._lose_all(ActionLost(reason or "the connection closed before the action's answer"))

    def connection_replaced(self) -> None:
        """The client drops its connection to connect again (``reconnect``)."""
        self.connection_lost("the connection was replaced before the action's answer")
        self.bye_reason = None

    def client_closed(self) -> None:
        """The client closed the connection (``close``)."""
        self.connection_lost("the client closed the connection")

    def closed_error(self) -> Bw4tError:
        """The exception describing why the connection is gone."""
        if self.fatal is not None:
            return self.fatal
        if self.bye_reason is not None:
            return ConnectionClosed(f"the server said bye ({self.bye_reason})", self.bye_reason)
        return ConnectionClosed("the connection to the server dropped")

    def end_wait(
        self,
        done: Callable[[], bool],
        stop_at_end: bool,
        failure: Optional[BaseException] = None,
    ) -> None:
        """A client's wait for ``done()`` stopped: return if ``done()`` holds, raise the
        fatal error or the transport's ``failure`` if any, return quietly with
        ``stop_at_end`` when the match is over or the server said ``goodbye``, and raise
        :meth:`closed_error` otherwise (the connection is gone)."""
        if done():
            return
        if self.fatal is not None:
            raise self.fatal
        if failure is not None:
            raise failure
        if stop_at_end and (self.finished or self.bye_reason == "goodbye"):
            return
        raise self.closed_error()

    def forget_done(self) -> None:
        """Drop finished action records (called now and then to bound memory)."""
        if len(self._actions) > 256:
            self._actions = {k: r for k, r in self._actions.items() if not r.done}

    def pop_update(self) -> Optional[Update]:
        """Hand out the oldest queued update (``None`` if there is none)."""
        if not self.queue:
            return None
        self.forget_done()
        return self.queue.popleft()
