"""The API the blocking and the asyncio client have in common (no I/O here).

:class:`ClientBase` holds a client's :class:`~bw4t.core.ProtocolCore` and gives both
clients their information properties and their action methods, which send at once in
either client. :class:`ActionBase` is the same for the action handles. What waits for
the server (and so is blocking or a coroutine) stays in :mod:`bw4t.client` and
:mod:`bw4t.aio`; the transport is reached through :meth:`ClientBase._send` and
:attr:`ClientBase._is_open`.
"""

from __future__ import annotations

from typing import Any, Callable, Dict, Generic, List, Optional, Tuple, TypeVar

from .beliefs import BeliefBase
from .core import ActionRecord, JoinOptions, ProtocolCore
from .data import Lobby, MatchEnd, MatchInfo, Update, Welcome
from .errors import Bw4tError, ConnectionClosed, ServerError

#: The client type of an action handle.
C = TypeVar("C")
#: The action handle type of a client.
A = TypeVar("A")


class ActionBase(Generic[C]):
    """What :class:`~bw4t.Action` and :class:`~bw4t.AsyncAction` share: the record of
    one ``act`` (or ``say``) and what can be told about it without waiting."""

    def __init__(self, client: C, record: ActionRecord) -> None:
        self._client = client
        self._record = record

    @property
    def id(self) -> Any:
        """The id sent in the ``act``."""
        return self._record.id

    @property
    def action(self) -> str:
        """The action's name (``goTo``, ``pickUp``, ``sendMessage``, ...)."""
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

    def __repr__(self) -> str:
        r = self._record
        return f"<{type(self).__name__} {r.id} {r.action}{list(r.args)} ack={r.ack} result={r.result}>"


class ClientBase(Generic[A]):
    """What :class:`~bw4t.Client` and :class:`~bw4t.AsyncClient` share: the protocol
    state, the properties that read it, and the methods that only send.

    A subclass provides the transport (:meth:`_send`, :attr:`_is_open`) and wraps
    action records in its handle type (:meth:`_action_handle`).
    """

    def __init__(self, host: str, port: int, options: JoinOptions) -> None:
        self.host = host
        self.port = port
        self._options = options
        self._core = ProtocolCore()

    # ------------------------------------------------------------ transport

    def _send(self, msg: Dict[str, Any]) -> None:
        """Send one message now; raises when the connection is gone."""
        raise NotImplementedError

    @property
    def _is_open(self) -> bool:
        """Whether a connection is open to send on."""
        raise NotImplementedError

    def _action_handle(self, record: ActionRecord) -> A:
        """The handle returned for a sent action."""
        raise NotImplementedError

    # ------------------------------------------------------------ connecting

    def _send_hello(self, options: JoinOptions) -> Callable[[], bool]:
        """Send the ``hello`` of ``options`` on a new connection; returns the condition
        that ends the handshake (``welcome`` and the first full snapshot received)."""
        hello, joined = self._core.begin_handshake(options)
        self._send(hello)
        return joined

    def _resume_options(self) -> JoinOptions:
        """What ``reconnect`` says in its ``hello``: this client's options with its
        session, in the match the session belongs to (``welcome.match.name``), never a
        template."""
        session = self.session
        if session is None:
            raise Bw4tError("no session to reconnect with")
        return self._options.resuming(session, self._core.resume_match())

    def _send_action(self, msg: Dict[str, Any]) -> None:
        """Send an ``act`` or ``say``. Once the match is over, a failed send is no error of
        its own: waiting on the action's handle raises :class:`~bw4t.errors.ActionLost`,
        as for any action the end of a match leaves unanswered."""
        try:
            self._send(msg)
        except ConnectionClosed:
            if self._core.match_end is None:
                raise

    def _flush_ready(self) -> None:
        """Send the ``ready`` still owed in lockstep, if any (a failure is noticed by
        the next read)."""
        msg = self._core.take_ready()
        if msg is not None and self._is_open:
            try:
                self._send(msg)
            except ConnectionClosed:
                pass

    # ------------------------------------------------------------------ info

    @property
    def options(self) -> JoinOptions:
        """How this client joined (the name and token from ``BW4T_*`` filled in)."""
        return self._options

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
        """About the match: name, template, map, seed, mode, tick_hz, deadline_ms,
        players_needed, ..."""
        return self.welcome.match

    @property
    def lobby(self) -> Optional[Lobby]:
        """The latest ``lobby`` received: the match waiting for its players (who is
        there, how many are awaited, the start countdown) or, before ``welcome``, the
        place in a template's queue. ``None`` if none came; once the match has started
        it is the last one received before."""
        return self._core.lobby

    @property
    def beliefs(self) -> BeliefBase:
        """The belief base, updated as ``percepts`` arrive (latest state received)."""
        return self._core.beliefs

    @property
    def words(self) -> Optional[str]:
        """The robot's situation in a few short lines of English (``I am Ann (robot 0),
        in RoomC1. ...``), from the latest ``percepts``; ``None`` unless connected with
        ``words=True``. The same as ``beliefs.words``; each update has its own
        (``update.words``). Meant for people and language models: the wording may
        change between server releases."""
        return self._core.beliefs.words

    @property
    def errors(self) -> List[ServerError]:
        """Non-fatal ``error`` messages received so far."""
        return self._core.errors

    @property
    def match_end(self) -> Optional[MatchEnd]:
        """The ``match_end`` (reason and result) once the match is over, else ``None``."""
        return self._core.match_end

    @property
    def result(self) -> Optional[Dict[str, Any]]:
        """The match result object once the match is over, else ``None``."""
        return None if self._core.match_end is None else self._core.match_end.result

    @property
    def finished(self) -> bool:
        """Whether the match is over."""
        return self._core.finished

    @property
    def last_snapshot(self) -> Optional[Update]:
        """The full snapshot that answered the last ``resync()``."""
        return self._core.last_snapshot

    # --------------------------------------------------------------- actions

    def act(self, action: str, *args: Any) -> A:
        """Send ``act`` now and return its handle (no waiting; wait with its
        ``ack()``/``result()``).

        ``client.act("goTo", "RoomA1")``. In lockstep, acts sent before the tick's
        ``ready`` are applied at that tick's boundary.
        """
        msg, record = self._core.act(action, args)
        self._send_action(msg)
        return self._action_handle(record)

    def go_to(self, place: str) -> A:
        """``goTo(place)``: travel to a place (durative)."""
        return self.act("goTo", place)

    def go_to_block(self, block: int) -> A:
        """``goToBlock(block)``: travel to a block in the robot's room (durative)."""
        return self.act("goToBlock", block)

    def pick_up(self, block: Optional[int] = None) -> A:
        """``pickUp`` the block the robot is at, or the named block within reach."""
        return self.act("pickUp") if block is None else self.act("pickUp", block)

    def put_down(self) -> A:
        """``putDown`` the held block (delivered in the ``DropZone``)."""
        return self.act("putDown")

    def say(self, to: str, text: Optional[str] = None, *, said: Optional[Dict[str, Any]] = None) -> A:
        """Send a message to a player's name or ``"all"`` (a ``say``); acked as an action.

        Either free ``text`` or ``said``, a message of the shared language, e.g.
        ``client.say("all", said={"kind": "will_get", "colour": "Blue"})``; a match may
        allow only some kinds, or no free text (then the ack says ``not_allowed``).
        """
        msg, record = self._core.say(to, text, said)
        self._send_action(msg)
        return self._action_handle(record)

    def send_message(self, to: str, text: str) -> A:
        """``act`` ``sendMessage(to, text)``: the same as :meth:`say`."""
        return self.act("sendMessage", to, text)
