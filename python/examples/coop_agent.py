#!/usr/bin/env python3
"""A cooperative BW4T agent built on the bw4t Python client.

Run a team of three on the default map, or one beside two built-in robots, with:

    bw4t run --map default --robots 3 \
        --agent "python3 python/examples/coop_agent.py"
    bw4t run --map default --robots 3 --team builtin \
        --agent "python3 python/examples/coop_agent.py"

It talks in the shared message language (protocol/PROTOCOL.md, "The message language"),
so built-in robots and other players understand it and it understands them. The strategy,
the same in every robot of the team:

1. Explore.  The team is every player's name, sorted. Robot number i of n explores the
   rooms i, i+n, i+2n, ... (of the sorted room names), nearest the drop zone first, then
   any room still unknown that nobody said they are going to. It says `going_to ROOM`
   when it sets off and reports what the room holds: `empty ROOM`, or one
   `contains_many ROOM COUNT COLOUR` per colour, all in one tick. It reads the same from
   teammates (a report replaces what was believed about that room).
2. Agree.  Once every room is known, each robot computes the same plan from the same
   knowledge: for each position k of the colour sequence, the room nearest the drop zone
   still holding that colour; position k is fetched by robot k mod n. No negotiation is
   needed because everyone decides from the same messages in the same way.
3. Fetch in order.  A robot fetches its positions in increasing order, one block at a
   time, then waits in the hall in front of the drop zone until the sequence index is
   its position and the drop zone is empty, enters, puts the block down and leaves.
   It claims each position as it goes (`getting_for COLOUR ROOM POSITION`, then
   `bringing COLOUR POSITION` with the block in hand; positions count from 0 as
   `sequenceIndex` does) and skips a position a teammate has claimed, so it plays beside
   robots that do not follow the plan (the built-in team fetches whatever is open). When
   two claim the same position, the smaller name keeps it, as the built-in team agrees.
   A room that no longer holds the colour is reported as it is now, and another is tried.
4. Help.  With its own positions done, a robot rests in the hall, and fetches the next
   position itself when nobody has claimed it for a while.

Robots never wait inside a room: waiting always happens in a hall. When entering a room
fails (another robot is inside: the order ends "collided"), the robot waits in the hall
until the room is free and tries again.
"""

from __future__ import annotations

import os
import sys
from collections import Counter
from typing import Any, Callable, Dict, List, Optional, Set, Tuple

try:
    import bw4t
except ImportError:  # running from the repository without installing the package
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    import bw4t

from bw4t import ActionLost, ActionRejected, Client, ConnectionClosed

DROP_ZONE = "DropZone"
FRONT = "FrontDropZone"  # the hall in front of the drop zone, where robots wait
# Ticks the next position may stay unclaimed before a robot done with its own positions
# fetches it (five seconds at 20 ticks a second: its owner claims it sooner).
HELP_TICKS = 100


class MatchOver(Exception):
    """Raised inside the agent when the match has ended."""


class CoopAgent:
    """One robot of the cooperative team."""

    def __init__(self, client: Client) -> None:
        self.client = client
        self.beliefs = client.beliefs
        self.me = client.name or ""
        # Places whose name starts with "Room" are the rooms with blocks; on the default
        # map the rooms later in the alphabet (RoomC*) are the nearest to the drop zone.
        self.rooms = sorted(p for p in self.beliefs.places if p.startswith("Room"))
        self.nearest_first = sorted(self.rooms, reverse=True)
        self.contents: Dict[str, Dict[str, int]] = {}  # room -> {colour: count}
        self.exploring: Dict[str, str] = {}  # teammate -> the room it said it is going to
        self.claims: Dict[int, str] = {}  # position -> the player fetching it (me included)
        self.read = 0  # how many received messages were handled already

    # ------------------------------------------------------------- talking

    def say(self, kind: str, **arguments: Any) -> None:
        self.client.say("all", said={"kind": kind, **arguments})

    def report(self, room: str, counts: Dict[str, int]) -> None:
        """What a room holds, as one report (all its messages go out in this tick)."""
        if not counts:
            self.say("empty", room=room)
        for colour, count in sorted(counts.items()):
            self.say("contains_many", room=room, count=count, colour=colour)

    def claim(self, position: int, colour: str, room: Optional[str] = None) -> None:
        """Claim a position (replacing my previous claim): a fetch from `room`, or for the
        block in hand."""
        self.claims = {p: who for p, who in self.claims.items() if who != self.me}
        self.claims[position] = self.me
        if room is None:
            self.say("bringing", colour=colour, position=position)
        else:
            self.say("getting_for", colour=colour, room=room, position=position)

    def give_up(self, position: int) -> None:
        if self.claims.get(position) == self.me:
            del self.claims[position]
            self.say("giving_up", position=position)

    def handle_messages(self) -> None:
        """Learn rooms, explorations and claims from what teammates say."""
        reports: Set[Tuple[str, int, str]] = set()  # (sender, tick, room) reports begun
        for message in self.beliefs.messages[self.read:]:
            said, sender = message.said or {}, message.sender
            kind, room, position = said.get("kind"), said.get("room"), said.get("position")
            if kind in ("empty", "contains_many") and room:
                if (sender, message.tick, room) not in reports:  # a new report: forget the room
                    reports.add((sender, message.tick, room))
                    self.contents[room] = {}
                    if self.exploring.get(sender) == room:
                        del self.exploring[sender]
                if kind == "contains_many" and said.get("count", 0) > 0:
                    self.contents[room][said["colour"]] = said["count"]
            elif kind == "going_to" and room:
                self.exploring[sender] = room
            elif kind in ("getting_for", "bringing") and isinstance(position, int):
                self.exploring.pop(sender, None)  # busy fetching: not exploring any more
                self.claims = {p: who for p, who in self.claims.items() if who != sender}
                holder = self.claims.get(position)
                if holder is None or sender < holder:  # the smaller name keeps a position
                    self.claims[position] = sender
            elif kind == "giving_up" and self.claims.get(position) == sender:
                del self.claims[position]
        self.read = len(self.beliefs.messages)

    # ------------------------------------------------------------- waiting

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

    def look(self, room: str) -> None:
        """Record what the room I am in holds; report it when the team believed otherwise."""
        seen = dict(Counter(self.beliefs.colors.values()))
        self.handle_messages()
        if self.contents.get(room) != seen:
            self.report(room, seen)
        self.contents[room] = seen

    # ------------------------------------------------------------- phases

    def team(self) -> List[str]:
        """Every player's name, sorted; waits until all expected players are in."""
        needed = self.client.match.players_needed
        self.wait_until(lambda: len(self.beliefs.players) + 1 >= needed)
        return sorted(self.beliefs.players + [self.me])

    def room_to_explore(self, my_rooms: List[str]) -> Optional[str]:
        """My next unknown room, else any unknown room; none a teammate is going to."""
        announced = set(self.exploring.values())
        for room in my_rooms + self.nearest_first:
            if room not in self.contents and room not in announced:
                return room
        return None

    def explore(self, my_rooms: List[str]) -> None:
        """Visit rooms and report what each one holds, until every room is known."""
        while True:
            self.handle_messages()
            if all(room in self.contents for room in self.rooms):
                return
            room = self.room_to_explore(my_rooms)
            if room is None:
                # Teammates are looking into the rest. Never wait inside a room.
                self.travel(FRONT)
                self.wait_until(
                    lambda: all(r in self.contents for r in self.rooms)
                    or self.room_to_explore(my_rooms) is not None
                )
                continue
            self.say("going_to", room=room)
            self.travel(room)
            self.look(room)

    def plan(self) -> List[Optional[str]]:
        """The room to fetch each position of the sequence from; the same for all."""
        left = {room: dict(counts) for room, counts in self.contents.items()}
        plan: List[Optional[str]] = []
        for colour in self.beliefs.sequence:
            room = self.room_with(colour, left)
            if room is not None:
                left[room][colour] -= 1
            plan.append(room)
        return plan

    def room_with(self, colour: str, contents: Dict[str, Dict[str, int]]) -> Optional[str]:
        """The room nearest the drop zone believed to hold a block of the colour."""
        return next((r for r in self.nearest_first if contents.get(r, {}).get(colour, 0) > 0), None)

    def fetch(self, colour: str, room: str) -> bool:
        """Go to the room and pick up a block of the colour; True when holding it."""
        self.travel(room)
        self.look(room)
        blocks = sorted(b for b, c in self.beliefs.colors.items() if c == colour)
        if not blocks:
            return False
        try:
            result = self.client.go_to_block(blocks[0]).result()
            if result is None or not result.arrived:
                return False
            self.client.pick_up(blocks[0]).result()  # not durative: waits for the ack
        except ActionRejected:  # the ack refused it (e.g. block_not_visible)
            return False
        self.wait_until(lambda: self.beliefs.holding is not None or self.beliefs.room != room)
        return self.beliefs.holding == blocks[0]

    def get_block(self, position: int, room: Optional[str]) -> bool:
        """Claim the position and fetch a block for it, from the planned room first;
        True when holding it under my claim."""
        colour = self.beliefs.sequence[position]
        while True:
            if room is None:
                self.give_up(position)  # nobody knows of such a block: leave it open
                return False
            self.claim(position, colour, room)
            got = self.fetch(colour, room)
            self.handle_messages()
            if self.claims.get(position) != self.me:
                # A teammate with a smaller name claimed it at the same time: theirs.
                if got:
                    self.client.put_down().ack()  # back into the room
                    self.wait_until(lambda: self.beliefs.holding is None)
                return False
            if got:
                self.claim(position, colour)  # now "bringing"
                return True
            # Not there (look() reported the room as it is): try the next room.
            self.contents.get(room, {}).pop(colour, None)
            room = self.room_with(colour, self.contents)

    def deliver(self, position: int) -> None:
        """Wait in front of the drop zone for our turn, then put the block down there."""
        self.travel(FRONT)
        self.wait_until(
            lambda: self.beliefs.sequence_index > position
            or (self.beliefs.sequence_index == position
                and not self.beliefs.holds("occupied", DROP_ZONE))
        )
        if self.beliefs.sequence_index > position:
            # Someone delivered it after all: a block put down in a hall leaves the world.
            self.client.put_down().ack()
        else:
            self.travel(DROP_ZONE)
            self.client.put_down().ack()
        self.wait_until(lambda: self.beliefs.holding is None)

    def play(self) -> None:
        """The whole strategy: explore, agree, fetch and deliver in order."""
        team = self.team()
        index, size = team.index(self.me), len(team)
        self.explore([r for r in self.nearest_first if r in self.rooms[index::size]])
        plan = self.plan()
        for position in range(index, len(plan), size):
            self.handle_messages()
            if self.beliefs.sequence_index > position:
                continue  # delivered by someone else
            if self.claims.get(position, self.me) != self.me:
                continue  # a teammate fetches it
            if self.get_block(position, plan[position]):
                self.deliver(position)
        self.help()

    def help(self) -> None:
        """My positions are done: rest in the hall, and fetch the next position whenever
        nobody has claimed it for a while (a teammate that does not follow the plan, such
        as a built-in robot, may leave it open)."""
        open_since: Dict[int, int] = {}

        def left_open() -> bool:
            self.handle_messages()
            index, now = self.beliefs.sequence_index, self.beliefs.tick or 0
            if index >= len(self.beliefs.sequence) or index in self.claims:
                return False
            return now - open_since.setdefault(index, now) >= HELP_TICKS

        while True:
            left_open()  # the walk to the hall counts as waiting
            self.travel(FRONT)  # clear the drop zone and wait in the hall
            self.wait_until(left_open)  # answers ticks until the match ends
            index = self.beliefs.sequence_index
            if self.get_block(index, self.room_with(self.beliefs.sequence[index], self.contents)):
                self.deliver(index)


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
