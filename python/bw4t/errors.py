"""Exceptions raised by the bw4t client.

Every exception of this package derives from :class:`Bw4tError`.
"""

from __future__ import annotations

from typing import Any, Optional


class Bw4tError(Exception):
    """Base class of every error raised by the bw4t client."""


class ServerError(Bw4tError):
    """An ``error`` message sent by the server.

    Non-fatal ones are not raised: they are collected in ``client.errors`` and in
    ``Update.errors``. Fatal ones are raised as :class:`FatalServerError`.

    Attributes:
        code: the stable error code (for example ``"name_taken"``).
        message: the server's explanation in words.
        fatal: whether the server closes the connection after it.
    """

    def __init__(self, code: str, message: str, fatal: bool = False) -> None:
        super().__init__(f"{code}: {message}")
        self.code = code
        self.message = message
        self.fatal = fatal


class FatalServerError(ServerError):
    """A fatal ``error`` from the server; the server closes the connection after it.

    Raised, for example, by ``Client.connect`` for ``name_taken``, ``bad_session``,
    ``unknown_match`` (no live match of the name given as ``match=``) or
    ``unknown_template``, or while playing for ``replaced``, ``too_slow`` or
    ``unresponsive``.
    """


class ConnectionClosed(Bw4tError):
    """The connection closed while the client still expected messages.

    Attributes:
        reason: the reason of the server's ``bye`` if one was received, else ``None``
            (the connection simply dropped). After a drop, ``client.reconnect()``
            takes the robot back with the session token.
    """

    def __init__(self, message: str, reason: Optional[str] = None) -> None:
        super().__init__(message)
        self.reason = reason


class ProtocolError(Bw4tError):
    """The server sent something this client cannot understand (not JSON, not an object)."""


class Timeout(Bw4tError, TimeoutError):
    """A bounded wait (``timeout=...``) ran out before the awaited message arrived."""


class ActionRejected(Bw4tError):
    """``result()`` was asked for an action whose ``ack`` refused it.

    Attributes:
        ack: the refusing :class:`~bw4t.data.Ack` (with ``code`` and ``reason``).
        code: the ack's code, for example ``"unknown_place"``.
        reason: the ack's reason in words.
    """

    def __init__(self, action: str, ack: Any) -> None:
        super().__init__(f"{action} rejected: {ack.code}: {ack.reason}")
        self.ack = ack
        self.code: Optional[str] = ack.code
        self.reason: Optional[str] = ack.reason


class ActionLost(Bw4tError):
    """The answer to an action will never come.

    This happens when the connection dropped before the action's ``ack`` or ``result``
    (the server drops unapplied actions and does not deliver results of a dropped
    player), or when the match ended first.
    """
