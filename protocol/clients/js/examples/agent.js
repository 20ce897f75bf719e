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
// Team messages (plain text, to `all`):
//   seen ROOM ID:COLOUR ...   what is in ROOM now (sent when it differs from what the team knew)
//   claim INDEX BLOCK|- [held] I fetch sequence position INDEX (with that block, if chosen;
//                             `held`: it is in my hand)
//   unclaim INDEX             I gave position INDEX up
//   going ROOM                I am exploring ROOM
// Two players claiming the same position (or block): the one holding the block keeps it,
// else the smaller name. A robot without a block moves to a lower free position when one
// appears; if nobody fetches the colour needed now while others wait with blocks for
// later positions, a waiting robot leaves its block in a room and fetches it. The agent
// also understands the built-in team's words (`room` for `seen`, `explore` for `going`),
// so it can play with `--team builtin` teammates.
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

/** The built-in team (`bw4t run --team builtin`) says `room` and `explore` for `seen`
 * and `going`; its `claim INDEX BLOCK` is ours. */
const SYNONYMS = { room: 'seen', explore: 'going' };

/** Rooms (places named Room...), in map order. @type {string[]} */
let rooms = [];
/** Room -> (block -> colour), as last seen by anyone in the team. */
const contents = new Map();
/** Room -> the tick its contents were last seen. */
const seenAt = new Map();
/** Block -> colour, for every block ever seen. */
const colourOf = new Map();
/** Sequence index -> {by, block, held}: other players' claims. */
const claims = new Map();
/** Player -> the room it said it is exploring. */
const exploring = new Map();
/** My claim: the sequence index I fetch, the block I chose, whether it is in hand. @type {{index: number, block: number|null, held: boolean} | null} */
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
  for (const { from, text } of update.messages) hear(from, text, update.tick);

  const index = b.get('sequenceIndex');
  for (const [i, claim] of claims) if (i < index || !others.has(claim.by)) claims.delete(i);
  for (const player of exploring.keys()) if (!others.has(player)) exploring.delete(player);
  if (mine && mine.index < index) mine = null;

  if (order?.outcome?.outcome === 'arrived' && order.action === 'goToBlock') reachedBlock = order.args[0];
  if (!b.holds('in')) lastHall = b.get('at');

  const here = b.get('in');
  if (here && isRoom(here)) {
    const now = new Map(b.all('color').map(([block, colour]) => [block, colour]));
    if (describe(here, now) !== describe(here, contents.get(here))) tell(describe(here, now));
    remember(here, now, update.tick);
  }
}

/** A `seen` message for a room's contents. */
function describe(room, blocks) {
  if (!blocks) return '';
  const items = [...blocks].sort((a, b) => a[0] - b[0]).map(([block, colour]) => `${block}:${colour}`);
  return ['seen', room, ...items].join(' ');
}

function remember(room, blocks, tick) {
  contents.set(room, blocks);
  seenAt.set(room, tick);
  for (const [block, colour] of blocks) colourOf.set(block, colour);
}

/** Take in a team message. */
function hear(from, text, tick) {
  let [kind, ...words] = text.split(' ');
  kind = SYNONYMS[kind] ?? kind;
  if (kind === 'seen' && words.length >= 1) {
    const blocks = new Map(words.slice(1).map((w) => {
      const [block, colour] = w.split(':');
      return [Number(block), colour];
    }));
    remember(words[0], blocks, tick);
    if (exploring.get(from) === words[0]) exploring.delete(from);
  } else if (kind === 'claim') {
    const index = Number(words[0]);
    const theirs = { by: from, block: words[1] === '-' ? null : Number(words[1]), held: words[2] === 'held' };
    for (const [i, claim] of claims) if (claim.by === from) claims.delete(i);
    const earlier = claims.get(index);
    if (!earlier || beats(theirs, earlier)) claims.set(index, theirs);
    if (!mine) return;
    const holding = client.beliefs.get('holding');
    const ours = { by: me, block: mine.block, held: holding !== undefined && holding === mine.block };
    const sameIndex = mine.index === index;
    const sameBlock = theirs.block !== null && theirs.block === mine.block && !ours.held;
    if ((sameIndex || sameBlock) && beats(theirs, ours)) {
      log(`${from} takes ${sameIndex ? `position ${index}` : `block ${theirs.block}`}; I choose again`);
      mine = null;
      order = null; // replan now; a new order supersedes the current one
    }
  } else if (kind === 'unclaim') {
    const index = Number(words[0]);
    if (claims.get(index)?.by === from) claims.delete(index);
  } else if (kind === 'going') {
    exploring.set(from, words[0]);
  }
}

/** Whether claim `a` wins over claim `b` for the same position or block: a block in hand
 * wins, else the smaller name. */
function beats(a, b) {
  if (a.held !== b.held) return a.held;
  return a.by < b.by;
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
  const colour = colourOf.get(block);
  if (!mine || sequence[mine.index] !== colour) {
    const position = freePosition(sequence, index, colour);
    if (position === undefined) {
      unclaim(); // nobody needs it
      return false;
    }
    claim(position, block);
  } else {
    claim(mine.index, block); // tells the team the block is in hand
  }
  const someoneFirst = [...claims.values()].some((c) => c.held && c.by < me);
  if (mine.index > index && !claims.has(index) && !someoneFirst) {
    // Nobody fetches the colour needed now while blocks for later positions wait: leave
    // this block in a room and fetch that one (else the team could wait forever).
    log(`nobody fetches position ${index}: I leave my ${colour} block and take it`);
    claim(index, null);
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
  if (!mine || (position !== undefined && position < mine.index)) {
    if (position === undefined) return explore(b) ?? leaveRoom(b); // every position is taken
    claim(position, null);
  }
  const colour = sequence[mine.index];
  const found = findBlock(b, colour, here);
  if (!found) {
    claim(mine.index, null);
    return explore(b) ?? leaveRoom(b);
  }
  claim(mine.index, found.block);
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

/** A known block of this colour nobody else claims: in this room first, then in rooms nobody is in. */
function findBlock(b, colour, here) {
  const taken = new Set([...claims.values()].map((c) => c.block));
  for (const room of myRoomOrder(here)) {
    if (room !== here && b.holds('occupied', room)) continue;
    for (const [block, c] of contents.get(room) ?? []) {
      if (c === colour && !taken.has(block)) return { block, room };
    }
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
  if (others.size > 0) client.say('all', `going ${target}`);
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

function tell(text) {
  if (others.size > 0) client.say('all', text);
}

function claim(index, block) {
  const held = block !== null && client.beliefs.get('holding') === block;
  if (mine && mine.index === index && mine.block === block && mine.held === held) return;
  if (mine && mine.index !== index) tell(`unclaim ${mine.index}`);
  mine = { index, block, held };
  tell(`claim ${index} ${block ?? '-'}${held ? ' held' : ''}`);
}

function unclaim() {
  if (mine) tell(`unclaim ${mine.index}`);
  mine = null;
}
