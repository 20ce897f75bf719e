#!/usr/bin/env python3
"""A cooperative BW4T agent built on the bw4t Python client.

Run a team of three on the default map with:

    bw4t run --map default --robots 3 \
        --agent "python3 protocol/clients/python/examples/coop_agent.py"

The strategy, the same in every robot of the team:

1. Explore.  The team is every player's name, sorted. Robot number i of n explores the
   rooms i, i+n, i+2n, ... (of the sorted room names), nearest the drop zone first, and
   tells everybody what each room holds: "room RoomC1 11:Yellow 12:Blue".
2. Agree.  Once every room is known, each robot computes the same plan from the same
   knowledge: for each position k of the colour sequence, the lowest-id free block of
   that colour; position k is fetched by robot k mod n. No negotiation is needed because
   everyone decides from the same messages in the same way.
3. Fetch in order.  A robot fetches its positions in increasing order, one block at a
   time, then waits in the hall in front of the drop zone until the sequence index is
   its position and the drop zone is empty, enters, puts the block down and leaves.

Robots never wait inside a room: waiting always happens in a hall. When entering a room
fails (another robot is inside: the order ends "collided"), the robot waits in the hall
until the room is free and tries again.
"""

from __future__ import annotations

import os
import sys
from typing import Callable, Dict, List, Set, Tuple

try:
    import bw4t
except ImportError:  # running from the repository without installing the package
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    import bw4t

from bw4t import ActionLost, ActionRejected, Client, ConnectionClosed

DROP_ZONE = "DropZone"
FRONT = "FrontDropZone"  # the hall in front of the drop zone, where robots wait


class MatchOver(Exception):
    """Raised inside the agent when the match has ended."""


class CoopAgent:
    """One robot of the cooperative team."""

    def __init__(self, client: Client) -> None:
        self.client = client
        self.beliefs = client.beliefs
        self.me = client.name or ""
        # Places whose name starts with "Room" are the rooms with blocks.
        self.rooms = sorted(p for p in self.beliefs.places if p.startswith("Room"))
        self.contents: Dict[str, Dict[int, str]] = {}  # room -> {block id: colour}
        self.read = 0  # how many received messages were handled already

    # ------------------------------------------------------------- waiting

    def handle_messages(self) -> None:
        """Learn room contents from teammates' "room" messages."""
        for message in self.beliefs.messages[self.read:]:
            words = message.text.split()
            if len(words) >= 2 and words[0] == "room":
                try:
                    pairs = (w.split(":") for w in words[2:])
                    self.contents[words[1]] = {int(b): colour for b, colour in pairs}
                except ValueError:
                    pass  # not our format: ignore
        self.read = len(self.beliefs.messages)

    def wait_until(self, condition: Callable[[], bool]) -> None:
        """Let ticks pass (answering them) until the condition holds."""
        self.handle_messages()
        while not condition():
            if self.client.next_update() is None:
                raise MatchOver()
            self.handle_messages()

    def travel(self, place: str) -> None:
        """Go to a place; if a room is busy, wait in the hall until it is free."""
        while True:
            if self.beliefs.holds("occupied", place) and self.beliefs.room != place:
                self.wait_until(lambda: not self.beliefs.holds("occupied", place))
            result = self.client.go_to(place).result()
            if result is not None and result.arrived:
                return
            # Collided: someone got into the room first. Wait for a tick and retry.
            if self.client.next_update() is None:
                raise MatchOver()

    # ------------------------------------------------------------- phases

    def team(self) -> List[str]:
        """Every player's name, sorted; waits until all expected players are in."""
        needed = self.client.match.players_needed
        self.wait_until(lambda: len(self.beliefs.players) + 1 >= needed)
        return sorted(self.beliefs.players + [self.me])

    def explore(self, my_rooms: List[str]) -> None:
        """Visit my rooms and broadcast what each one holds."""
        for room in my_rooms:
            self.travel(room)
            blocks = self.beliefs.colors
            self.contents[room] = dict(blocks)
            text = " ".join([f"room {room}"] + [f"{b}:{c}" for b, c in sorted(blocks.items())])
            self.client.say("all", text)
        # Never wait inside a room: go and wait in the hall.
        self.travel(FRONT)
        self.wait_until(lambda: all(room in self.contents for room in self.rooms))

    def plan(self) -> List[Tuple[int, str]]:
        """The block (and its room) for each position of the sequence; same for all."""
        used: Set[int] = set()
        plan: List[Tuple[int, str]] = []
        for colour in self.beliefs.sequence:
            choices = sorted(
                (block, room)
                for room, blocks in self.contents.items()
                for block, c in blocks.items()
                if c == colour and block not in used
            )
            block, room = choices[0] if choices else (-1, "")
            used.add(block)
            plan.append((block, room))
        return plan

    def fetch(self, block: int, room: str) -> bool:
        """Go to the room and pick the block up; True when holding it."""
        self.travel(room)
        if block not in self.beliefs.colors:
            return False
        try:
            result = self.client.go_to_block(block).result()
            if result is None or not result.arrived:
                return False
            self.client.pick_up(block).result()  # not durative: waits for the ack
        except ActionRejected:  # the ack refused it (e.g. block_not_visible)
            return False
        self.wait_until(lambda: self.beliefs.holding is not None or self.beliefs.room != room)
        return self.beliefs.holding == block

    def deliver(self, position: int) -> None:
        """Wait in front of the drop zone for our turn, then put the block down there."""
        self.travel(FRONT)
        self.wait_until(
            lambda: self.beliefs.sequence_index == position
            and not self.beliefs.holds("occupied", DROP_ZONE)
        )
        self.travel(DROP_ZONE)
        self.client.put_down().ack()
        self.wait_until(lambda: self.beliefs.holding is None)

    def play(self) -> None:
        """The whole strategy: explore, agree, fetch and deliver in order."""
        team = self.team()
        index, size = team.index(self.me), len(team)
        # My rooms, the ones nearest the drop zone first (on the default map the rooms
        # later in the alphabet, RoomC*, are next to the drop zone).
        self.explore(sorted(self.rooms[index::size], reverse=True))
        plan = self.plan()
        planned = {block for block, _ in plan}
        for position in range(index, len(plan), size):
            block, room = plan[position]
            while not self.fetch(block, room):
                # Cannot happen while everyone follows the plan; just in case, forget
                # that block and try another unplanned block of the same colour.
                self.contents.get(room, {}).pop(block, None)
                colour = self.beliefs.sequence[position]
                others = sorted(
                    (b, r) for r, blocks in self.contents.items()
                    for b, c in blocks.items() if c == colour and b not in planned
                )
                if not others:
                    self.travel(FRONT)
                    self.wait_until(lambda: False)  # nothing left to do
                block, room = others[0]
                planned.add(block)
            self.deliver(position)
        self.travel(FRONT)  # done: clear the drop zone and rest in the hall
        self.wait_until(lambda: False)  # answer ticks until the match ends


def main() -> int:
    client = Client.connect()
    try:
        CoopAgent(client).play()
    except (MatchOver, ActionLost):
        pass  # the match ended
    except ConnectionClosed as exc:
        if not client.finished:
            print(f"connection closed: {exc}", file=sys.stderr)
            return 1
    end = client.match_end
    print(f"{client.name}: match over: {end.reason if end else 'unknown'}")
    client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
