#!/usr/bin/env node
// An example bw4t agent: explore rooms, remember blocks by colour, fetch the colour the
// sequence needs, deliver it. Alone it works through the sequence in order; in a team
// the players share what they see and claim sequence positions by message, so several
// robots fetch at once and take turns at the drop zone.
//
//   bw4t run --map fixed --agent "node protocol/clients/js/examples/agent.js"
//   bw4t run --robots 3 --agent "node protocol/clients/js/examples/agent.js"
//   bw4t run --robots 3 --team builtin --agent "node protocol/clients/js/examples/agent.js"
//
// The team talks in the shared message language (protocol/PROTOCOL.md, "The message
// language"), all to `all`, so the built-in team understands this agent and it them:
//   going_to ROOM                      I am exploring ROOM
//   empty ROOM / contains_many ROOM COUNT COLOUR (one per colour, in one tick)
//                                      what ROOM holds now (sent when it differs from what
//                                      the team knew; a report replaces what was believed)
//   getting_for COLOUR ROOM POSITION   I fetch sequence position POSITION (from 0, as
//                                      sequenceIndex) from ROOM
//   bringing COLOUR POSITION           ... with the block in my hand
//   giving_up POSITION                 I gave that position up
// A claim replaces the sender's previous one; a robot claims a position once it knows
// where to get the block, and explores until then. Two players claiming the same
// position: the smaller name keeps it (as the built-in team agrees). A robot without a
// block moves to a lower free position when one appears; if nobody claims the position
// needed now for a while, while others wait with blocks for later positions, a waiting
// robot leaves its block in a room and fetches it.
//
// The agent decides when an update arrives and acts before that tick's `ready`, so
// matches are reproducible (the one exception: a refused action, whose ack comes without
// an update, is replaced as soon as the refusal arrives).

import { connect, BW4TError } from '../index.js';

let client;
try {
  client = await connect(); // host, port, name and token from BW4T_* (set by `bw4t run`)
} catch (err) {
  console.error(`agent: cannot join: ${err instanceof Error ? err.message : err}`);
  process.exit(1);
}
const me = /** @type {string} */ (client.name);
const log = (...words) => console.error(`[${me} t=${client.tick}]`, ...words);
const isRoom = (/** @type {string} */ place) => place.startsWith('Room');

// ---- what this player knows -------------------------------------------------------

/** Ticks the position needed now may stay unclaimed before a robot waiting with a block
 * for a later one leaves it to fetch that position (ten seconds at 20 ticks a second). */
const LEAVE_TICKS = 200;

/** Rooms (places named Room...), in map order. @type {string[]} */
let rooms = [];
/** Room -> (colour -> count), as last seen or reported by anyone in the team. */
const contents = new Map();
/** Room -> the tick its contents were last seen. */
const seenAt = new Map();
/** Block -> colour, for every block this robot has seen. */
const colourOf = new Map();
/** Sequence index -> {by, colour, room, held}: other players' claims (room null when held). */
const claims = new Map();
/** Player -> the room it said it is exploring. */
const exploring = new Map();
/** My claim: the sequence index I fetch and the room I fetch from (null: in hand). @type {{index: number, room: string|null} | null} */
let mine = null;
/** The action in flight. @type {import('../index.js').ActionHandle | null} */
let order = null;
/** The last goTo sent. @type {import('../index.js').ActionHandle | null} */
let travel = null;
/** Rooms where a putDown found no space. */
const fullRooms = new Set();
/** Whether to drop the block in hand in the next hall (all rooms around are full). */
let dropInHall = false;
/** The block the last goToBlock reached. */
let reachedBlock = null;
/** The last hall the robot was in: where to go to get out of a room. */
let lastHall = null;
/** Other players now in the match. @type {Set<string>} */
let others = new Set();
/** The tick since which the position needed now has been unclaimed. @type {number|null} */
let openSince = null;
/** A block in hand this robot decided to put back (not to claim again). */
let abandoned = null;

// ---- the loop ----------------------------------------------------------------------

try {
  for await (const update of client.updates()) {
    observe(update);
    if (!client.ended && (order === null || order.done)) decide(update.beliefs);
  }
} catch (err) {
  if (err instanceof BW4TError) {
    console.error(`agent: the server ended the connection: ${err.message}`);
    process.exit(1);
  }
  throw err;
}
const result = client.result;
log(`match over (${client.endReason}): sequence ${result?.sequence_index}/${result?.sequence.length} in ${result?.ticks} ticks`);
process.exit(0);

// ---- perceiving --------------------------------------------------------------------

/** Take in one update: the team's messages, the robot's room, the players. */
function observe(update) {
  const b = update.beliefs;
  if (rooms.length === 0) rooms = b.all('place').map(([p]) => p).filter(isRoom);
  others = new Set(b.all('player').map(([p]) => p));
  const reports = new Set(); // "sender room" of the reports begun in this update
  for (const { from, said } of update.messages) if (said) hear(from, said, update.tick, reports);

  const index = b.get('sequenceIndex');
  for (const [i, claim] of claims) if (i < index || !others.has(claim.by)) claims.delete(i);
  for (const player of exploring.keys()) if (!others.has(player)) exploring.delete(player);
  if (mine && mine.index < index) mine = null;
  if (claims.has(index) || mine?.index === index) openSince = null;
  else openSince ??= update.tick;
  if (!b.holds('holding')) abandoned = null;

  if (order?.outcome?.outcome === 'arrived' && order.action === 'goToBlock') reachedBlock = order.args[0];
  if (!b.holds('in')) lastHall = b.get('at');

  const here = b.get('in');
  if (here && isRoom(here)) {
    const blocks = b.all('color');
    for (const [block, colour] of blocks) colourOf.set(block, colour);
    const now = new Map();
    for (const [, colour] of blocks) now.set(colour, (now.get(colour) ?? 0) + 1);
    if (!sameCounts(now, contents.get(here))) report(here, now);
    contents.set(here, now);
    seenAt.set(here, update.tick);
  }
}

function sameCounts(a, b) {
  return b !== undefined && a.size === b.size && [...a].every(([colour, n]) => b.get(colour) === n);
}

/** Take in a team message of the language (`said`); `reports` holds the "sender room"
 * pairs whose report has begun in this update: its first message forgets the room. */
function hear(from, said, tick, reports) {
  const { kind, room, colour, position } = said;
  if (kind === 'empty' || kind === 'contains_many') {
    if (!reports.has(`${from} ${room}`)) {
      reports.add(`${from} ${room}`);
      contents.set(room, new Map());
      seenAt.set(room, tick);
      if (exploring.get(from) === room) exploring.delete(from);
    }
    if (kind === 'contains_many' && said.count > 0) contents.get(room).set(colour, said.count);
  } else if (kind === 'getting_for' || kind === 'bringing') {
    exploring.delete(from); // busy fetching
    for (const [i, claim] of claims) if (claim.by === from) claims.delete(i);
    const earlier = claims.get(position);
    if (!earlier || from < earlier.by) {
      claims.set(position, { by: from, colour, room: room ?? null, held: kind === 'bringing' });
    }
    if (mine?.index === position && from < me) {
      log(`${from} takes position ${position}; I choose again`);
      mine = null;
      order = null; // replan now; a new order supersedes the current one
    }
  } else if (kind === 'giving_up') {
    if (claims.get(position)?.by === from) claims.delete(position);
  } else if (kind === 'going_to') {
    exploring.set(from, room);
  }
}

// ---- deciding ----------------------------------------------------------------------

/** Choose the next action. */
function decide(b) {
  const sequence = b.get('sequence');
  const index = b.get('sequenceIndex');
  if (index >= sequence.length) return leaveRoom(b);
  const holding = b.get('holding');
  if (holding !== undefined && keep(holding, sequence, index)) return deliver(b, sequence, index);
  return fetch(b, sequence, index, holding);
}

/** Whether to keep the block in hand (for the position `mine` then names). */
function keep(block, sequence, index) {
  if (block === abandoned) return false;
  const colour = colourOf.get(block);
  if (!mine || sequence[mine.index] !== colour) {
    const position = freePosition(sequence, index, colour);
    if (position === undefined) {
      unclaim(); // nobody needs it
      return false;
    }
    claim(position, null);
  } else {
    claim(mine.index, null); // tells the team the block is in hand
  }
  const someoneFirst = [...claims.values()].some((c) => c.held && c.by < me);
  const stalled = openSince !== null && client.tick - openSince >= LEAVE_TICKS;
  if (mine.index > index && stalled && !someoneFirst) {
    // Nobody fetches the colour needed now while blocks for later positions wait: leave
    // this block in a room and fetch that one (else the team could wait forever).
    log(`nobody fetches position ${index}: I leave my ${colour} block and take it`);
    unclaim();
    abandoned = block;
    return false;
  }
  return true;
}

/** Holding the block for my position: deliver it when it is needed now. */
function deliver(b, sequence, index) {
  const here = b.get('in');
  if (mine.index === index) {
    if (here === 'DropZone') return start(client.putDown(), `deliver ${sequence[index]} (position ${index})`);
    if (!b.holds('occupied', 'DropZone')) return go(b, 'DropZone');
  }
  // Not my turn yet, or the drop zone is busy: wait in front of it.
  const waitingPlace = b.holds('place', 'FrontDropZone') ? 'FrontDropZone' : lastHall;
  if (here || b.get('at') !== waitingPlace) return go(b, waitingPlace);
}

/** Fetch a block for my position, or explore to find one. A block in hand that is not
 * wanted is first put down in a room (in the drop zone it would be a wrong drop). */
function fetch(b, sequence, index, holding) {
  const here = b.get('in');
  if (holding !== undefined) {
    if (here && here !== 'DropZone' && !fullRooms.has(here)) {
      return start(client.putDown(), `put down block ${holding} in ${here}`);
    }
    if (here && fullRooms.has(here)) {
      dropInHall = true;
      return go(b, lastHall);
    }
    if (!here && dropInHall) {
      dropInHall = false;
      return start(client.putDown(), `put down block ${holding} in a hall (it leaves the world)`);
    }
  }
  const position = freePosition(sequence, index);
  let target = mine?.index;
  if (!mine || (position !== undefined && position < mine.index)) {
    if (position === undefined) return explore(b) ?? leaveRoom(b); // every position is taken
    target = position;
  }
  const colour = sequence[target];
  const found = findBlock(b, colour, here);
  if (!found) {
    unclaim(); // claim it once I know where its block is
    return explore(b) ?? leaveRoom(b);
  }
  claim(target, found.room);
  if (found.room !== here || holding !== undefined) return go(b, found.room);
  if (reachedBlock === found.block || b.holds('atBlock', found.block)) {
    return start(client.pickUp(found.block), `pick up ${colour} block ${found.block}`);
  }
  return start(client.goToBlock(found.block), `go to ${colour} block ${found.block}`);
}

/** The lowest sequence position from `index` on that nobody else claims (of `colour`, if given). */
function freePosition(sequence, index, colour) {
  for (let i = index; i < sequence.length; i++) {
    if (claims.has(i)) continue;
    if (colour === undefined || sequence[i] === colour) return i;
  }
  return undefined;
}

/** Where to get a block of this colour: a block in sight in this room first, else a room
 * nobody is in believed to hold more of it than others are fetching from there. */
function findBlock(b, colour, here) {
  if (here && isRoom(here)) {
    const inSight = b.all('color').filter(([, c]) => c === colour).map(([block]) => block);
    if (inSight.length > 0) return { room: here, block: Math.min(...inSight) };
  }
  for (const room of myRoomOrder(here)) {
    if (room === here || b.holds('occupied', room)) continue;
    const fetching = [...claims.values()].filter((c) => c.room === room && c.colour === colour).length;
    if ((contents.get(room)?.get(colour) ?? 0) > fetching) return { room };
  }
  return null;
}

/** Go to a room nobody has looked into, else the one seen longest ago. */
function explore(b) {
  const here = b.get('in');
  const targeted = new Set(exploring.values());
  const candidates = myRoomOrder(here).filter((r) => r !== here && !b.holds('occupied', r) && !targeted.has(r));
  const unknown = candidates.filter((r) => !contents.has(r));
  const target = unknown[0] ?? candidates.sort((x, y) => (seenAt.get(x) ?? 0) - (seenAt.get(y) ?? 0))[0];
  if (!target) return undefined;
  tell({ kind: 'going_to', room: target });
  return go(b, target) ?? true;
}

/** Rooms in this player's order: the current room first, then starting at a place that
 * depends on the player's rank among the names, so that a team spreads out. */
function myRoomOrder(here) {
  const names = [me, ...others].sort();
  const offset = Math.floor((names.indexOf(me) * rooms.length) / names.length);
  const order = [...rooms.slice(offset), ...rooms.slice(0, offset)];
  return here && isRoom(here) ? [here, ...order.filter((r) => r !== here)] : order;
}

/** Nothing to do: do not block a room. */
function leaveRoom(b) {
  if (b.holds('in') && lastHall) return go(b, lastHall);
}

/** Start travelling, unless already there. */
function go(b, place) {
  if (b.get('at') === place && b.get('state') !== 'traveling') return undefined;
  if (travel && !travel.done && travel.action === 'goTo' && travel.args[0] === place) {
    order = travel; // already on the way
    return true;
  }
  travel = start(client.goTo(place), `go to ${place}`);
  return true;
}

/** Remember an action as the one in flight; choose again at once if it is refused. */
function start(handle, what) {
  log(what);
  order = handle;
  if (handle.action !== 'goToBlock') reachedBlock = null;
  handle.ack.then(
    (ack) => {
      if (ack.ok) return;
      log(`${what}: refused (${ack.code}: ${ack.reason})`);
      if (ack.code === 'no_space') fullRooms.add(client.beliefs.get('in'));
      // A refusal may come without a percepts (so without an update): decide now.
      if (order === handle && !client.ended) {
        order = null;
        decide(client.beliefs);
      }
    },
    () => {},
  );
  return true;
}

// ---- talking -----------------------------------------------------------------------

/** Say a message of the language to the team (if there is one). */
function tell(said) {
  if (others.size > 0) client.say('all', said);
}

/** What a room holds, as one report: all its messages go out in this tick. */
function report(room, counts) {
  if (counts.size === 0) tell({ kind: 'empty', room });
  for (const [colour, count] of [...counts].sort()) tell({ kind: 'contains_many', room, count, colour });
}

/** Claim a position (replacing my previous claim): fetching from `room`, or (null) for the block in hand. */
function claim(index, room) {
  if (mine && mine.index === index && mine.room === room) return;
  mine = { index, room };
  const colour = client.beliefs.get('sequence')[index];
  tell(room === null ? { kind: 'bringing', colour, position: index } : { kind: 'getting_for', colour, room, position: index });
}

function unclaim() {
  if (mine) tell({ kind: 'giving_up', position: mine.index });
  mine = null;
}
