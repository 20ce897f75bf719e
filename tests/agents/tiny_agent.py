"""A tiny BW4T agent in plain Python, for the tests: explores rooms, remembers blocks,
fetches the colour needed now and delivers it. Connects to the address `bw4t run` gives.
With TINY_AGENT_RECORD set to a file name, it writes there what it saw: each percepts tick
with the sequence index it then believed, and the `match_end` result."""
import json
import os
import socket

sock = socket.create_connection((os.environ["BW4T_HOST"], int(os.environ["BW4T_PORT"])))
# One file to read and one to write: a text file that does both drops the lines it has
# read ahead whenever it is written to.
incoming = sock.makefile("r", encoding="utf-8", newline="\n")
outgoing = sock.makefile("w", encoding="utf-8", newline="\n")


def send(message):
    outgoing.write(json.dumps(message) + "\n")
    outgoing.flush()


send({"type": "hello", "protocol": "bw4t", "versions": [1],
      "name": os.environ["BW4T_NAME"], "token": os.environ.get("BW4T_TOKEN")})

facts = set()        # facts as JSON strings, e.g. '["in", "RoomA1"]'
single = {}          # single-valued facts: at, state, sequenceIndex
known = {}           # block id -> (room, colour)
explored = set()
next_id = 0
busy = False         # a goTo/goToBlock is under way
seen = []            # [tick, sequenceIndex] per percepts, for TINY_AGENT_RECORD


def holds(*fact):
    return json.dumps(list(fact)) in facts


def values(name):
    return [json.loads(f)[1:] for f in facts if json.loads(f)[0] == name]


def act(action, *args):
    global next_id, busy
    next_id += 1
    busy = action in ("goTo", "goToBlock")
    send({"type": "act", "id": next_id, "action": action, "args": list(args)})


def decide():
    sequence = values("sequence")[0][0] if values("sequence") else []
    index = single.get("sequenceIndex", 0)
    if busy or index >= len(sequence):
        return
    room = values("in")[0][0] if values("in") else None
    holding = values("holding")[0][0] if values("holding") else None
    if room and room != "DropZone":
        explored.add(room)
        for block, (r, _) in list(known.items()):
            if r == room:
                del known[block]
        for block, colour in values("color"):
            known[block] = (room, colour)
    if holding is not None:
        if room == "DropZone":
            act("putDown")
        else:
            act("goTo", "DropZone")
        return
    wanted = [b for b, (r, c) in sorted(known.items()) if c == sequence[index]]
    if wanted:
        block = wanted[0]
        if room == known[block][0]:
            if holds("atBlock", block):
                known.pop(block)
                act("pickUp")
            else:
                act("goToBlock", block)
        else:
            act("goTo", known[block][0])
        return
    rooms = sorted(p[0] for p in values("place") if p[0].startswith("Room"))
    todo = [r for r in rooms if r not in explored]
    if not todo:
        explored.clear()
        todo = rooms
    act("goTo", todo[0])


for line in incoming:
    message = json.loads(line)
    kind = message["type"]
    if kind == "percepts":
        if message.get("full"):
            facts.clear()
        for fact in message["not"]:
            facts.discard(json.dumps(fact))
        for fact in message["add"]:
            if fact[0] in ("at", "state", "sequenceIndex"):
                single[fact[0]] = fact[1]
            elif fact[0] != "message":
                facts.add(json.dumps(fact))
        seen.append([message["tick"], single.get("sequenceIndex", 0)])
        decide()
        send({"type": "ready", "tick": message["tick"]})
    elif kind == "result":
        busy = False
    elif kind == "ack" and not message["ok"]:
        busy = False
    elif kind in ("match_end", "bye"):
        if kind == "match_end" and os.environ.get("TINY_AGENT_RECORD"):
            with open(os.environ["TINY_AGENT_RECORD"], "w", encoding="utf-8") as out:
                json.dump({"percepts": seen, "result": message["result"]}, out)
        break
