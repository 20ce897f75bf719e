"""bw4t, Blocks World for Teams, in Python.

- :mod:`bw4t.env`: PettingZoo (``parallel_env``) and Gymnasium (``single_env``)
  environments and a vector of matches stepped in Rust (``vector_env``).
- :mod:`bw4t.sim`: an in-process match driven by the protocol's own actions
  (:class:`bw4t.sim.Match`), with percepts, beliefs, statistics and the digest.
- The TCP client (below) for agents that play against ``bw4t serve`` or ``bw4t run``.
- The ``bw4t`` command itself (``python -m bw4t`` or the ``bw4t`` script).

The blocking client::

    from bw4t import Client

    client = Client.connect()            # address and name from BW4T_* or arguments
    for update in client.updates():      # one update per tick, until match_end
        ...                              # read client.beliefs, call client.go_to(...)

and the same with asyncio in :class:`AsyncClient`. Both keep a :class:`BeliefBase`
from the percept deltas and answer lockstep ``ready`` for the agent.
"""

from .aio import AsyncAction, AsyncClient
from .beliefs import BeliefBase
from .client import Action, Client
from .core import DURATIVE_ACTIONS, VERSIONS, JoinOptions, ProtocolCore
from .data import Ack, Fact, Lobby, MatchEnd, MatchInfo, Message, Result, Update, Welcome
from .errors import (
    ActionLost,
    ActionRejected,
    Bw4tError,
    ConnectionClosed,
    FatalServerError,
    ProtocolError,
    ServerError,
    Timeout,
)

try:  # the wheel's version; the client alone (no native module) still imports
    from importlib.metadata import version as _version

    __version__ = _version("bw4t")
except Exception:  # pragma: no cover - running from the source folder
    __version__ = "0+source"

__all__ = [
    "Ack",
    "Action",
    "ActionLost",
    "ActionRejected",
    "AsyncAction",
    "AsyncClient",
    "BeliefBase",
    "Bw4tError",
    "Client",
    "ConnectionClosed",
    "DURATIVE_ACTIONS",
    "Fact",
    "FatalServerError",
    "JoinOptions",
    "Lobby",
    "MatchEnd",
    "MatchInfo",
    "Message",
    "ProtocolCore",
    "ProtocolError",
    "Result",
    "ServerError",
    "Timeout",
    "Update",
    "VERSIONS",
    "Welcome",
]
