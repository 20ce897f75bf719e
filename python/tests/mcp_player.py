"""A scripted player of `bw4t mcp`, through the official MCP SDK's client.

It fetches the colour needed next: it goes from room to room (`go_to`) until it sees a
block of that colour, takes it (`go_to_block`, `pick_up`), carries it to the drop zone and
puts it down there. A block it holds that is no longer needed (a teammate delivered that
colour meanwhile) goes back into a room, not into a hall, where it would leave the world.
An occupied room is left for later; a door it collides with is tried again after a `wait`.
Everything it knows comes from the tool results' `structuredContent`.

:func:`play` is the player, for any initialized session; :func:`stdio_session` and
:func:`http_session` open one. Run as a program, it is an agent of `bw4t run`:

    bw4t run --map fixed --agent "python3 python/tests/mcp_player.py --bw4t /path/to/bw4t"

starts `bw4t mcp`, which joins the match named by the BW4T_* variables it inherits, and
plays until the tool results say the match is over; it prints a JSON line of what it did.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import re
import shutil
import sys
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, AsyncIterator, Dict, List, Optional, Sequence

from mcp import ClientSession, StdioServerParameters
from mcp.client.stdio import stdio_client
from mcp.client.streamable_http import streamable_http_client

#: Seconds any one tool call may take before the player gives up (a hang, not a slow match).
CALL_TIMEOUT = 60.0
DROP_ZONE = "DropZone"
#: Ticks to wait before trying a door again, or for news when no room can help.
RETRY_TICKS = 20
IDLE_TICKS = 200


@dataclass
class Call:
    """One tool call and its result (`structuredContent`, and the text)."""

    tool: str
    args: Dict[str, Any]
    result: Dict[str, Any]
    text: str


@dataclass
class Play:
    """What a :func:`play` did."""

    calls: List[Call] = field(default_factory=list)
    #: Blocks this player delivered (its own `put_down` moved the sequence on).
    delivered: int = 0
    #: Blocks it put back into a room because they were no longer needed.
    returned: int = 0
    #: The last state the tool results gave.
    state: Dict[str, Any] = field(default_factory=dict)
    #: Calls refused for their arguments (tool errors), made on purpose (`invalid_calls`).
    invalid: int = 0

    @property
    def ended(self) -> bool:
        return bool(self.state.get("ended"))

    def summary(self) -> Dict[str, Any]:
        return {
            "tool_calls": len(self.calls) + self.invalid,
            "invalid_calls": self.invalid,
            "delivered": self.delivered,
            "returned": self.returned,
            "ended": self.ended,
            "tick": self.state.get("tick"),
            "sequence_index": self.state.get("sequence_index"),
        }


class _Player:
    def __init__(
        self, session: ClientSession, rooms: Sequence[str], record: Play, max_calls: int, tokens_per_call: int
    ) -> None:
        self.session = session
        self.tokens_per_call = tokens_per_call
        self.rooms = list(rooms)
        self.record = record
        self.max_calls = max_calls
        #: Per room: the colours seen there on the last visit.
        self.seen: Dict[str, List[str]] = {}
        #: The room the held block came from.
        self.source: Optional[str] = None
        #: Rooms not to try again before this tick (their door stopped us).
        self.blocked: Dict[str, int] = {}

    def meta(self) -> Optional[Dict[str, Any]]:
        if not self.tokens_per_call:
            return None
        # Cumulative counts, as a model's driver reports them (here a stand-in: a fixed
        # number per call, so that a test can check they reach the match's result).
        n = len(self.record.calls) + self.record.invalid + 1
        return {"bw4t/usage": {"prompt_tokens": n * self.tokens_per_call, "completion_tokens": n}}

    async def invalid_call(self) -> None:
        """A call with a place that is not on the map: a tool error, which changes nothing."""
        res = await asyncio.wait_for(
            self.session.call_tool("go_to", {"place": "Nowhere"}, meta=self.meta()), CALL_TIMEOUT
        )
        if not res.is_error:
            raise RuntimeError(f"go_to(Nowhere) was not a tool error: {res}")
        self.record.invalid += 1

    async def call(self, tool: str, **args: Any) -> Dict[str, Any]:
        if len(self.record.calls) >= self.max_calls:
            raise RuntimeError(f"the player made {self.max_calls} tool calls without finishing")
        res = await asyncio.wait_for(self.session.call_tool(tool, args, meta=self.meta()), CALL_TIMEOUT)
        text = "".join(getattr(c, "text", "") for c in res.content)
        if res.is_error or res.structured_content is None:
            raise RuntimeError(f"{tool}({args}) failed: {text}")
        result = dict(res.structured_content)
        self.record.calls.append(Call(tool, args, result, text))
        self.record.state = result["state"]
        self.note_room(self.record.state)
        return result

    def note_room(self, state: Dict[str, Any]) -> None:
        room = state.get("in_room")
        if room and room != DROP_ZONE:
            self.seen[room] = [b["colour"] for b in state["visible_blocks"]]

    async def go_to(self, place: str) -> bool:
        """Travels to `place`; False if a door or another robot stopped it."""
        result = await self.call("go_to", place=place)
        if result["outcome"] == "arrived":
            return True
        if result["outcome"] == "collided" and place != DROP_ZONE:
            self.blocked[place] = result["tick"] + IDLE_TICKS
        return False

    def next_room(self, state: Dict[str, Any], colour: str) -> Optional[str]:
        """The room to look in next for `colour`: one where it was seen, else one not yet
        seen, starting from a place that depends on the robot (so that teammates running
        this same script spread out); None when every room was seen without it."""
        tick = state["tick"]
        start = (4 * (state.get("robot") or 0)) % len(self.rooms)
        order = self.rooms[start:] + self.rooms[:start]
        free = [
            r for r in order
            if r not in state["occupied_rooms"] and self.blocked.get(r, -1) <= tick and r != state.get("in_room")
        ]
        for room in free:
            if colour in self.seen.get(room, []):
                return room
        for room in free:
            if room not in self.seen:
                return room
        return None

    async def step(self) -> None:
        state = self.record.state
        held = state["holding"]
        need = state["next_colour"]
        colour = held and held["colour"]
        if held is not None and colour == need:
            if state["at"] != DROP_ZONE:
                if not await self.go_to(DROP_ZONE):
                    await self.call("wait", ticks=RETRY_TICKS)
                return
            before = state["sequence_index"]
            result = await self.call("put_down")
            if result["state"]["sequence_index"] > before:
                self.record.delivered += 1
                self.source = None
            return
        if held is not None:
            # Not needed now: back into a room (the one it came from), never into a hall.
            room = state["in_room"]
            if room and room != DROP_ZONE:
                await self.call("put_down")
                self.record.returned += 1
                self.source = None
                return
            target = self.source or self.rooms[0]
            if target in state["occupied_rooms"] or not await self.go_to(target):
                await self.call("wait", ticks=RETRY_TICKS)
            return
        if need is None:
            await self.call("wait", ticks=IDLE_TICKS)
            return
        room = state["in_room"]
        if room and room != DROP_ZONE:
            block = next((b["block"] for b in state["visible_blocks"] if b["colour"] == need), None)
            if block is not None:
                result = await self.call("go_to_block", block=block)
                if result["outcome"] == "arrived":
                    result = await self.call("pick_up", block=block)
                    if result["state"]["holding"] is not None:
                        self.source = room
                return
        target = self.next_room(state, need)
        if target is None:
            # Every free room was seen without it: a teammate holds one, or a room is
            # occupied. Wait for news, then look again everywhere.
            await self.call("wait", ticks=IDLE_TICKS)
            self.seen.clear()
            return
        if not await self.go_to(target):
            await self.call("wait", ticks=RETRY_TICKS)


async def rooms_of(session: ClientSession) -> List[str]:
    """The map's rooms (the drop zone aside), from the `bw4t://map` resource."""
    res = await asyncio.wait_for(session.read_resource("bw4t://map"), CALL_TIMEOUT)
    text = res.contents[0].text
    return [m.group(1) for m in re.finditer(r"^- (\S+) \(room\)", text, re.MULTILINE)]


async def play(
    session: ClientSession,
    *,
    deliveries: Optional[int] = None,
    max_calls: int = 5000,
    tokens_per_call: int = 0,
    invalid_calls: int = 0,
) -> Play:
    """Plays the robot behind `session` until it has delivered `deliveries` blocks (None:
    until the match is over); returns every call made and what came of it. With
    `tokens_per_call`, each call reports made-up token counts in its `_meta`; with
    `invalid_calls`, it first makes that many calls refused for their arguments."""
    record = Play()
    player = _Player(session, await rooms_of(session), record, max_calls, tokens_per_call)
    for _ in range(invalid_calls):
        await player.invalid_call()
    await player.call("look")
    while not record.ended and (deliveries is None or record.delivered < deliveries):
        await player.step()
    return record


@asynccontextmanager
async def stdio_session(command: Sequence[str], env: Optional[Dict[str, str]] = None) -> AsyncIterator[ClientSession]:
    """An initialized session of the MCP server `command` (program and arguments) over
    stdio. The SDK passes the server only a few safe variables; `env` adds to them."""
    params = StdioServerParameters(command=command[0], args=list(command[1:]), env=env)
    async with stdio_client(params) as (read, write):
        async with ClientSession(read, write) as session:
            await asyncio.wait_for(session.initialize(), CALL_TIMEOUT)
            yield session


@asynccontextmanager
async def http_session(url: str, token: Optional[str]) -> AsyncIterator[ClientSession]:
    """An initialized session of the MCP server at `url` (streamable HTTP), whose every
    request carries the bearer token `bw4t mcp --http` printed (none: `None`)."""
    try:  # the HTTP client the MCP SDK is built on: httpx2 from SDK 2.x, httpx before
        import httpx2 as httpx  # type: ignore[import-not-found]
    except ImportError:
        import httpx  # type: ignore[no-redef]
    # The SDK's own timeouts: a response stream may stay open while a tool runs.
    headers = {"Authorization": f"Bearer {token}"} if token is not None else {}
    client = httpx.AsyncClient(headers=headers, timeout=httpx.Timeout(30.0, read=300.0))
    async with client:
        async with streamable_http_client(url, http_client=client) as (read, write):
            async with ClientSession(read, write) as session:
                await asyncio.wait_for(session.initialize(), CALL_TIMEOUT)
                yield session


def default_bw4t() -> List[str]:
    """`$BW4T_BIN`, else the `bw4t` command beside this Python, else `bw4t` on PATH."""
    if os.environ.get("BW4T_BIN"):
        return [os.environ["BW4T_BIN"]]
    beside = Path(sys.executable).with_name("bw4t")
    if beside.exists():
        return [str(beside)]
    return [shutil.which("bw4t") or "bw4t"]


async def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bw4t", help="the bw4t command (default: $BW4T_BIN, else bw4t beside this Python or on PATH)")
    parser.add_argument("--max-calls", type=int, default=5000)
    parser.add_argument("--tokens-per-call", type=int, default=0, help="report made-up token counts (for tests)")
    parser.add_argument("--invalid-calls", type=int, default=0, help="first make this many invalid calls (for tests)")
    parser.add_argument("mcp_args", nargs="*", help="more arguments of `bw4t mcp` (after --)")
    args = parser.parse_args(argv)
    command = [args.bw4t] if args.bw4t else default_bw4t()
    # The whole environment: `bw4t mcp` finds its match in the BW4T_* variables, and with
    # --served fails at once, naming them, should they be missing.
    async with stdio_session([*command, "mcp", "--served", *args.mcp_args], env=dict(os.environ)) as session:
        record = await play(
            session, max_calls=args.max_calls, tokens_per_call=args.tokens_per_call, invalid_calls=args.invalid_calls
        )
    print(json.dumps(record.summary()), flush=True)
    return 0 if record.ended else 1


if __name__ == "__main__":
    sys.exit(asyncio.run(main()))
