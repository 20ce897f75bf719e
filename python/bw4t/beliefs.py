"""The belief base: the robot's percepts, kept from the server's deltas.

The rules are those of protocol/README.md ("Keeping the state"): for each ``percepts``
in order, if ``full``, clear; remove every fact in ``not``; for each fact in ``add``, a
``message`` is an event (recorded in :attr:`BeliefBase.messages`, not stored as a fact),
an on-change fact (``at``, ``state``, ``sequenceIndex``) replaces the stored fact of the
same name, and anything else is stored. The result equals the snapshot of that tick.
"""

from __future__ import annotations

from typing import Any, Dict, FrozenSet, Iterable, Iterator, List, Optional, Sequence, Tuple, cast

from .data import Fact, Message

#: Facts that hold one value at a time: a new one replaces the old one of the same name.
SINGLE_VALUED = frozenset({"at", "state", "sequenceIndex"})

#: Facts that are events: delivered once, never part of the state.
EVENTS = frozenset({"message"})

_MISSING: Any = object()


def freeze(value: Any) -> Any:
    """Turn JSON arrays (lists) into tuples, recursively, so facts are hashable."""
    if isinstance(value, list):
        return tuple(freeze(v) for v in value)
    return value


def to_fact(raw: Sequence[Any]) -> Fact:
    """Convert a JSON fact ``[name, arg, ...]`` to a tuple ``(name, arg, ...)``."""
    if not isinstance(raw, (list, tuple)) or not raw or not isinstance(raw[0], str):
        raise ValueError(f"not a fact: {raw!r}")
    return tuple(freeze(v) for v in raw)


class BeliefBase:
    """The facts the robot holds true now, plus the log of messages received.

    Queries::

        beliefs.holds("in", "RoomA1")     # is this exact fact held?
        beliefs.all("color")              # [(11, "Yellow"), (12, "Blue"), ...]
        beliefs.get("at")                 # "FrontDropZone" (single-valued facts)
        beliefs.messages                  # [Message(sender, text, tick), ...]

    Facts are tuples ``(name, arg, ...)``; JSON arrays inside them become tuples.
    """

    def __init__(self) -> None:
        # name -> ordered set (dict with None values) of argument tuples
        self._facts: Dict[str, Dict[Tuple[Any, ...], None]] = {}
        #: Every message received so far, oldest first (events, not state).
        self.messages: List[Message] = []
        #: The tick of the last ``percepts`` applied, or ``None`` before the first.
        self.tick: Optional[int] = None
        #: The ``words`` of the last ``percepts`` applied: the robot's situation in a few
        #: short lines of English (sent only to a client that connected with
        #: ``words=True``), else ``None``.
        self.words: Optional[str] = None

    # ----------------------------------------------------------------- updating

    def clear(self) -> None:
        """Forget every fact (the message log is kept)."""
        self._facts.clear()

    def apply(
        self,
        tick: int,
        add: Iterable[Sequence[Any]],
        remove: Iterable[Sequence[Any]],
        full: bool = False,
        words: Optional[str] = None,
    ) -> Tuple[List[Fact], List[Fact], List[Message]]:
        """Apply one ``percepts`` message; ``words`` is its ``words`` (kept as
        :attr:`words`), ``None`` if it had none.

        Returns ``(added, removed, messages)``: the state facts of ``add``, the facts of
        ``not`` and the new messages, in the order received.
        """
        if full:
            self.clear()
        removed: List[Fact] = []
        for raw in remove:
            fact = to_fact(raw)
            removed.append(fact)
            facts = self._facts.get(fact[0])
            if facts is not None:
                facts.pop(fact[1:], None)
                if not facts:
                    del self._facts[fact[0]]
        added: List[Fact] = []
        messages: List[Message] = []
        for raw in add:
            fact = to_fact(raw)
            name = fact[0]
            if name in EVENTS:
                sender = fact[1] if len(fact) > 1 else ""
                text = fact[2] if len(fact) > 2 else ""
                said = raw[3] if len(raw) > 3 and isinstance(raw[3], dict) else None
                messages.append(Message(str(sender), str(text), tick, said))
                continue
            added.append(fact)
            if name in SINGLE_VALUED:
                self._facts[name] = {fact[1:]: None}
            else:
                self._facts.setdefault(name, {})[fact[1:]] = None
        self.messages.extend(messages)
        self.tick = tick
        self.words = words
        return added, removed, messages

    # ----------------------------------------------------------------- queries

    def holds(self, name: str, *args: Any) -> bool:
        """Whether the fact ``(name, *args)`` is held. Lists in ``args`` match tuples."""
        facts = self._facts.get(name)
        return facts is not None and tuple(freeze(a) for a in args) in facts

    def all(self, name: str) -> List[Tuple[Any, ...]]:
        """The argument tuples of every held fact with this name, in arrival order.

        ``beliefs.all("color")`` gives ``[(11, "Yellow"), (12, "Blue")]``.
        """
        return list(self._facts.get(name, ()))

    def get(self, name: str, default: Any = None) -> Any:
        """The value of a fact that holds at most once (``at``, ``state``, ``holding``...).

        Returns the only argument for one-argument facts (``get("at")`` gives
        ``"RoomA1"``), the argument tuple otherwise, and ``default`` when no such fact
        is held. Raises ``ValueError`` if several facts with this name are held.
        """
        facts = self._facts.get(name)
        if not facts:
            return default
        if len(facts) > 1:
            raise ValueError(f"{len(facts)} facts named {name!r} are held; use all()")
        args = next(iter(facts))
        return args[0] if len(args) == 1 else args

    def facts(self) -> FrozenSet[Fact]:
        """Every held fact as a set of tuples ``(name, arg, ...)`` (a copy)."""
        return frozenset((name,) + args for name, facts in self._facts.items() for args in facts)

    def __contains__(self, fact: object) -> bool:
        if not isinstance(fact, (tuple, list)) or not fact:
            return False
        return self.holds(fact[0], *fact[1:])

    def __iter__(self) -> Iterator[Fact]:
        for name, facts in list(self._facts.items()):
            for args in list(facts):
                yield (name,) + args

    def __len__(self) -> int:
        return sum(len(f) for f in self._facts.values())

    def __repr__(self) -> str:
        return f"<BeliefBase tick={self.tick} facts={len(self)} messages={len(self.messages)}>"

    # ------------------------------------------------------- convenience views

    @property
    def name(self) -> Optional[str]:
        """This player's name (``ownName``)."""
        return cast(Optional[str], self.get("ownName"))

    @property
    def robot(self) -> Optional[int]:
        """This robot's id (``bot``)."""
        return cast(Optional[int], self.get("bot"))

    @property
    def at(self) -> Optional[str]:
        """The place the robot is at (``at``)."""
        return cast(Optional[str], self.get("at"))

    @property
    def state(self) -> Optional[str]:
        """``"arrived"``, ``"traveling"`` or ``"collided"`` (``state``)."""
        return cast(Optional[str], self.get("state"))

    @property
    def room(self) -> Optional[str]:
        """The room the robot is in (``in``), or ``None`` outside rooms."""
        return cast(Optional[str], self.get("in"))

    @property
    def holding(self) -> Optional[int]:
        """The id of the block held (``holding``), or ``None``."""
        return cast(Optional[int], self.get("holding"))

    @property
    def sequence(self) -> List[str]:
        """The goal colours, in delivery order (``sequence``)."""
        return list(self.get("sequence", ()))

    @property
    def sequence_index(self) -> int:
        """Index of the next colour needed (``sequenceIndex``)."""
        return int(self.get("sequenceIndex", 0))

    @property
    def places(self) -> List[str]:
        """Every place of the map (``place``)."""
        return [a[0] for a in self.all("place")]

    @property
    def players(self) -> List[str]:
        """The other players in the match (``player``)."""
        return [a[0] for a in self.all("player")]

    @property
    def occupied(self) -> List[str]:
        """The rooms some robot is in (``occupied``)."""
        return [a[0] for a in self.all("occupied")]

    @property
    def colors(self) -> Dict[int, str]:
        """The blocks in the robot's room and their colours (``color``)."""
        return {a[0]: a[1] for a in self.all("color")}
