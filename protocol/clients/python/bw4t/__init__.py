"""Reference Python client for bw4t, Blocks World for Teams over TCP (protocol version 1).

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
from .core import DURATIVE_ACTIONS, VERSIONS, ProtocolCore
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

__version__ = "1.0.0"

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
