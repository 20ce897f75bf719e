"""An in-process match: robots driven by the protocol's own actions (``goTo``,
``pickUp``, ``sendMessage`` ...) from Python, beside built-in teammates, one tick per step,
with each player's percepts, beliefs and statistics and the match's digest.

::

    from bw4t.sim import Match

    m = Match(map="default", seed=7, players=1, teammates=2)
    m.step({"Agent1": ("goTo", ["RoomA1"])})
    while m.beliefs("Agent1").state == "traveling":
        m.step()
    print(m.beliefs("Agent1").at, m.stats()["sequence_index"], m.digest())

The same map, seed and actions give the same match as ``bw4t run`` and ``bw4t serve``
would: the digest is the match's fingerprint.
"""

from __future__ import annotations

import json
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from .beliefs import BeliefBase
from . import _spec

#: An action as the protocol names it: ``("goTo", ["RoomA1"])``, ``("pickUp", [])``,
#: ``["putDown"]``, or ``None`` to leave the robot be.
Act = Union[None, str, Sequence[Any]]


def _act(act: Act) -> Optional[Tuple[str, List[Any]]]:
    if act is None:
        return None
    if isinstance(act, str):
        return act, []
    if not act or not isinstance(act[0], str):
        raise ValueError(f"an action is (name, [args]) or [name, args...]: got {act!r}")
    name, rest = act[0], list(act[1:])
    if len(rest) == 1 and isinstance(rest[0], (list, tuple)):
        rest = list(rest[0])
    return name, rest


class Match:
    """A match in this process. ``players`` robots are driven from Python (named
    ``Agent1`` ...), ``teammates`` built-in robots of ``strategy`` play beside them (named
    ``Bot1`` ...). Each :meth:`step` is one tick."""

    def __init__(
        self,
        map: str = "default",
        seed: int = 0,
        players: int = 1,
        teammates: int = 2,
        strategy: str = "coop",
        max_ticks: Optional[int] = None,
    ) -> None:
        self._spec = _spec.make_spec(map, _spec.seats(players, teammates, strategy), 1, max_ticks, 10, None)
        self.max_ticks = self._spec.max_ticks
        self._env = _native.Env(self._spec)
        self.players: List[str] = list(self._env.agent_names())
        self.reset(seed)

    def reset(self, seed: int) -> None:
        """Starts the match anew on ``seed`` (same map and robots); beliefs start empty."""
        self.seed = int(seed)
        n = len(self.players)
        obs = np.empty((n, self._spec.obs_len), dtype=np.float32)
        masks = np.empty((n, self._spec.n_actions), dtype=np.uint8)
        self._env.reset(self.seed, obs, masks)
        self._beliefs = {name: BeliefBase() for name in self.players}
        self.over = False
        self._take_deltas()

    def step(self, actions: Optional[Mapping[str, Act]] = None) -> Dict[str, Dict[str, Any]]:
        """One tick; ``actions`` maps a player to its action, applied at this tick's
        boundary as a remote player's would be (the others go on with what they do).
        Returns each player's news: ``added``/``removed`` facts and ``messages``."""
        if self.over:
            raise RuntimeError("the match is over (sequence complete or tick limit reached)")
        actions = dict(actions or {})
        unknown = set(actions) - set(self.players)
        if unknown:
            raise KeyError(f"no such player: {', '.join(sorted(unknown))} (players: {', '.join(self.players)})")
        acts = [_act(actions.get(name)) for name in self.players]
        _, terminated, truncated = self._env.step_acts(acts)
        self.over = terminated or truncated
        return self._take_deltas()

    def run(self, ticks: int) -> None:
        """``ticks`` ticks with no new actions (or until the match is over)."""
        for _ in range(ticks):
            if self.over:
                break
            self.step()

    def _take_deltas(self) -> Dict[str, Dict[str, Any]]:
        news = {}
        for i, name in enumerate(self.players):
            text = self._env.delta_json(i)
            if text is None:
                news[name] = {"added": [], "removed": [], "messages": []}
                continue
            delta = json.loads(text)
            added, removed, messages = self._beliefs[name].apply(
                delta["tick"], delta["add"], delta["not"], delta["full"]
            )
            news[name] = {"added": added, "removed": removed, "messages": messages}
        return news

    def beliefs(self, player: str) -> BeliefBase:
        """What ``player`` believes, kept from its percepts as the TCP client keeps it."""
        return self._beliefs[player]

    def percepts(self, player: str) -> List[list]:
        """Every fact ``player`` perceives now, in the protocol's own form."""
        return json.loads(self._env.percepts_json(self.players.index(player)))

    def outcomes(self) -> Dict[str, str]:
        """What became of each player's last action: ``waited``, ``accepted``,
        ``rejected:CODE`` (the protocol's error code) or ``dropped``."""
        return dict(zip(self.players, self._env.outcomes()))

    def stats(self) -> Dict[str, Any]:
        """The match's statistics (drops, messages, ticks, sequence index) and each robot's."""
        return self._env.stats()

    def digest(self) -> int:
        """The match's digest: equal digests mean equal matches, bit for bit."""
        return self._env.digest()

    @property
    def tick(self) -> int:
        """Ticks played."""
        return self._env.tick()

    @property
    def complete(self) -> bool:
        """Whether the whole sequence is delivered."""
        stats = self.stats()
        return stats["sequence_index"] >= stats["sequence_length"]

    def render_svg(self) -> str:
        """The match now as an SVG document."""
        return self._env.render_svg()

    def render_rgb(self, scale: float = 8.0) -> np.ndarray:
        """The match now as an RGB image (H × W × 3, uint8), ``scale`` pixels per map unit."""
        return self._env.render_rgb(scale)


def shipped_maps() -> List[str]:
    """The names of the maps shipped with bw4t."""
    return list(_native.shipped_maps())
