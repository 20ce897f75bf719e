"""Plain data objects built from the server's messages."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple, Union

from .errors import ServerError

#: An ``act``/``say`` id: a non-negative integer or a string.
ActId = Union[int, str]

#: A fact (percept) as a tuple ``(name, arg, ...)``; JSON arrays inside become tuples,
#: e.g. ``("color", 11, "Yellow")`` or ``("sequence", ("Yellow", "Red"))``.
Fact = Tuple[Any, ...]


@dataclass(frozen=True)
class MatchInfo:
    """The ``match`` object of ``welcome``: what match the client joined."""

    map: str
    seed: int
    mode: str
    tick_hz: int
    players_needed: int
    every_tick: bool
    deadline_ms: Optional[int] = None
    max_ticks: Optional[int] = None
    #: The match's name on the server (what ``match=`` names, and what a reconnecting
    #: client sends); ``None`` from a server that hosts a single unnamed match.
    name: Optional[str] = None
    #: The template the match was made from, if any.
    template: Optional[str] = None
    #: The message kinds of the shared language the match allows (``None``: every kind).
    kinds: Optional[List[str]] = None
    #: Whether the match allows free text besides the language.
    free_text: bool = True
    raw: Dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @property
    def lockstep(self) -> bool:
        """Whether the match is paced in lockstep (the client must answer ``ready``)."""
        return self.mode == "lockstep"

    @classmethod
    def from_json(cls, obj: Dict[str, Any]) -> "MatchInfo":
        """Build from the JSON object of ``welcome.match``."""
        return cls(
            map=str(obj.get("map", "")),
            seed=int(obj.get("seed", 0)),
            mode=str(obj.get("mode", "realtime")),
            tick_hz=int(obj.get("tick_hz", 20)),
            players_needed=int(obj.get("players_needed", 1)),
            every_tick=bool(obj.get("every_tick", False)),
            deadline_ms=obj.get("deadline_ms"),
            max_ticks=obj.get("max_ticks"),
            name=obj.get("name") or None,
            template=obj.get("template") or None,
            kinds=(obj.get("language") or {}).get("kinds"),
            free_text=bool((obj.get("language") or {}).get("free_text", True)),
            raw=dict(obj),
        )


@dataclass(frozen=True)
class Lobby:
    """A ``lobby`` message: a match waiting for its players, or a place in a template's queue.

    Before ``welcome`` (the player is queued for a template whose matches are full),
    ``match`` is ``None`` and ``queued`` is the player's place in the queue (1: next).
    After ``welcome`` and until the first tick it tells who is in the match; the last
    one, sent as the match starts, has ``started`` set.

    Attributes:
        match: the match's name (``None`` while queued).
        template: the template the match comes from, or the one queued for.
        players: names of the players in the match now (built-in agents included), in
            robot order.
        awaited: how many more players the match waits for before it starts.
        start_in_ms: the match starts anyway in this many milliseconds, if set.
        queued: the place in the template's queue, before ``welcome``.
        started: the match has started (the last ``lobby`` of the connection).
    """

    match: Optional[str]
    template: Optional[str]
    players: Tuple[str, ...]
    awaited: int
    start_in_ms: Optional[int] = None
    queued: Optional[int] = None
    started: bool = False
    raw: Dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @property
    def in_queue(self) -> bool:
        """Whether the player is waiting in a template's queue (no seat yet)."""
        return self.queued is not None

    @classmethod
    def from_json(cls, obj: Dict[str, Any]) -> "Lobby":
        """Build from a ``lobby`` message."""
        start_in_ms = obj.get("start_in_ms")
        queued = obj.get("queued")
        return cls(
            match=obj.get("match") or None,
            template=obj.get("template") or None,
            players=tuple(str(p) for p in obj.get("players") or ()),
            awaited=int(obj.get("awaited", 0)),
            start_in_ms=None if start_in_ms is None else int(start_in_ms),
            queued=None if queued is None else int(queued),
            started=bool(obj.get("started", False)),
            raw=dict(obj),
        )


@dataclass(frozen=True)
class Welcome:
    """The server's ``welcome``: the player's name, robot id, session token and match."""

    version: int
    name: Optional[str]
    robot: Optional[int]
    session: Optional[str]
    match: MatchInfo
    raw: Dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def from_json(cls, obj: Dict[str, Any]) -> "Welcome":
        """Build from a ``welcome`` message."""
        return cls(
            version=int(obj.get("version", 1)),
            name=obj.get("name"),
            robot=obj.get("robot"),
            session=obj.get("session"),
            match=MatchInfo.from_json(obj.get("match") or {}),
            raw=dict(obj),
        )


@dataclass(frozen=True)
class Ack:
    """An ``ack``: whether an action (or message) was accepted.

    ``tick`` is the tick after which it was applied; ``code`` and ``reason`` are set
    when ``ok`` is false.
    """

    id: Optional[ActId]
    ok: bool
    tick: int
    code: Optional[str] = None
    reason: Optional[str] = None

    @classmethod
    def from_json(cls, obj: Dict[str, Any]) -> "Ack":
        """Build from an ``ack`` message."""
        return cls(
            id=obj.get("id"),
            ok=bool(obj.get("ok")),
            tick=int(obj.get("tick", 0)),
            code=obj.get("code"),
            reason=obj.get("reason"),
        )


@dataclass(frozen=True)
class Result:
    """A ``result``: how a durative order (``goTo``, ``goToBlock``) ended.

    ``outcome`` is ``"arrived"``, ``"collided"`` or ``"superseded"``.
    """

    id: ActId
    outcome: str
    tick: int

    @property
    def arrived(self) -> bool:
        """True when the order ended with ``arrived``."""
        return self.outcome == "arrived"

    @classmethod
    def from_json(cls, obj: Dict[str, Any]) -> "Result":
        """Build from a ``result`` message."""
        action_id: ActId = obj.get("id", "")
        return cls(id=action_id, outcome=str(obj.get("outcome")), tick=int(obj.get("tick", 0)))


@dataclass(frozen=True)
class Message:
    """A message from another player and its tick: free text (a ``["message", From, Text]``
    fact), or a message of the shared language (``["message", From, Sentence, Said]``),
    whose ``text`` is its English sentence and ``said`` its structured form, e.g.
    ``{"kind": "contains", "room": "RoomB2", "colour": "Red"}``."""

    sender: str
    text: str
    tick: int
    said: Optional[Dict[str, Any]] = None


@dataclass(frozen=True)
class MatchEnd:
    """The ``match_end`` message: why the match ended and its result object.

    ``result`` is the JSON object described in PROTOCOL.md (``completed``, ``ticks``,
    ``sequence_index``, ``digest``, ``per_robot``, ...).
    """

    reason: str
    result: Dict[str, Any]

    @property
    def completed(self) -> bool:
        """Whether the whole sequence was delivered."""
        return bool(self.result.get("completed"))


@dataclass
class Update:
    """Everything the client received for one tick, ending with that tick's ``percepts``.

    Attributes:
        tick: the tick of the ``percepts``.
        full: whether the ``percepts`` was a full snapshot (the belief base was cleared).
        added: the facts of ``add`` other than messages.
        removed: the facts of ``not``.
        acks: ``ack`` messages received since the previous update.
        results: ``result`` messages received since the previous update.
        messages: messages from other players received since the previous update.
        errors: non-fatal ``error`` messages received since the previous update.
        answered: whether, when the update was handed to the agent, the client had
            already told the server it is ``ready`` after this tick (always true
            outside lockstep). Updates that arrived while the agent was blocked in
            ``ack()``/``result()`` are answered at once and still delivered afterwards,
            in order; then acting on them lands at a later tick boundary.
        words: the ``words`` of the ``percepts``: the robot's situation after it, in a
            few short lines of English, for people and language models (its wording
            may change between releases). ``None`` unless the client connected with
            ``words=True``.
    """

    tick: int
    full: bool = False
    added: List[Fact] = field(default_factory=list)
    removed: List[Fact] = field(default_factory=list)
    acks: List[Ack] = field(default_factory=list)
    results: List[Result] = field(default_factory=list)
    messages: List[Message] = field(default_factory=list)
    errors: List[ServerError] = field(default_factory=list)
    answered: bool = False
    words: Optional[str] = None

    def result_of(self, action_id: ActId) -> Optional[Result]:
        """The result with this id in this update, if any."""
        for r in self.results:
            if r.id == action_id:
                return r
        return None
