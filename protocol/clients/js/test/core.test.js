// The protocol session without I/O (src/core.js): scripted server lines in, the lines it
// would send and the events it reports out. No server, no sockets, no timers.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PlayerSession, helloOf, joinConflict, MAX_LINE_BYTES } from '../src/core.js';
import { fake } from './helpers.js';

/** The lines a session queued, parsed. @param {PlayerSession} session */
function sent(session) {
  return session.takeLines().map((line) => JSON.parse(line));
}

/** The events of some server messages, in order. @param {PlayerSession} session @param {...object} messages */
function feed(session, ...messages) {
  return messages.flatMap((message) => session.receive(message));
}

/** The types of events, `server` left out. @param {Array<{type: string}>} events */
function kinds(events) {
  return events.filter((e) => e.type !== 'server').map((e) => e.type);
}

/** A session seated in a match and given its first snapshot; its lines so far taken. */
function seated(mode = 'lockstep', options = { name: 'Ann' }) {
  const session = new PlayerSession(options);
  session.start();
  session.takeLines();
  feed(session, fake.welcome({ mode }), fake.snapshot(0));
  return session;
}

const percepts = (tick, fields = {}) => ({ type: 'percepts', tick, add: [], not: [], ...fields });

test('the hello says what the options say and nothing else', () => {
  const session = new PlayerSession({ name: 'Ann', token: 't', everyTick: true, words: true, template: 'ladder', host: 'ignored' });
  session.start();
  assert.deepEqual(sent(session), [
    { type: 'hello', protocol: 'bw4t', versions: [1], name: 'Ann', token: 't', every_tick: true, words: true, template: 'ladder' },
  ]);
  assert.deepEqual(helloOf({}), { type: 'hello', protocol: 'bw4t', versions: [1] });
  assert.deepEqual(helloOf({ session: 's', match: 'm', everyTick: false, words: false, template: '' }), {
    type: 'hello',
    protocol: 'bw4t',
    versions: [1],
    session: 's',
    match: 'm',
  });
  // More fields (the study page's) go as they are; the protocol's own are not overridden.
  assert.deepEqual(helloOf({ name: 'Ann', fields: { condition: 'a', type: 'bogus' } }), {
    condition: 'a',
    type: 'hello',
    protocol: 'bw4t',
    versions: [1],
    name: 'Ann',
  });
  assert.match(joinConflict({ match: 'm', template: 't' }) ?? '', /not both/);
  assert.equal(joinConflict({ match: 'm' }), null);
});

test('acts are numbered, and acks and results find their request', () => {
  const session = seated();
  const go = session.act('goTo', ['RoomC1'], 'go');
  const pick = session.act('pickUp', [], 'pick');
  const tell = session.say('all', { kind: 'will_get', colour: 'Blue' }, 'tell');
  assert.deepEqual(sent(session), [
    { type: 'act', action: 'goTo', args: ['RoomC1'], id: 1 },
    { type: 'act', action: 'pickUp', args: [], id: 2 },
    { type: 'say', to: 'all', said: { kind: 'will_get', colour: 'Blue' }, id: 3 },
  ]);
  assert.equal(go.durative, true);
  assert.equal(pick.durative, false);

  let events = feed(
    session,
    { type: 'ack', id: 1, ok: true, tick: 0 },
    { type: 'ack', id: 2, ok: false, tick: 0, code: 'not_at_block' },
    { type: 'ack', id: 3, ok: true, tick: 0 },
    { type: 'ack', id: 99, ok: true, tick: 0 },
  );
  assert.deepEqual(kinds(events), ['ack', 'ack', 'ack', 'settled', 'ack']);
  assert.deepEqual(
    events.filter((e) => e.type === 'ack').map((e) => e.request?.tag ?? null),
    ['go', 'pick', 'tell', null],
  );
  // A message changes nothing for its sender: settled at its ack.
  assert.deepEqual(events.find((e) => e.type === 'settled'), { type: 'settled', request: tell, result: null });

  // A durative order's result settles once the tick's percepts is applied.
  events = feed(session, { type: 'result', id: 1, outcome: 'arrived', tick: 5 });
  assert.deepEqual(kinds(events), ['result']);
  assert.equal(events[1].request, go);
  events = feed(session, percepts(5, { add: [['at', 'RoomC1']], not: [['at', 'FrontDropZone']] }));
  assert.deepEqual(kinds(events), ['settled', 'percepts']);
  assert.equal(events[1].request, go);
  assert.equal(events[1].result.outcome, 'arrived');
  assert.equal(session.beliefs.get('at'), 'RoomC1', 'the beliefs show the tick when it settles');
  const update = events[2].update;
  assert.deepEqual(
    update.acks.map((a) => a.id),
    [1, 2, 3, 99],
  );
  assert.deepEqual(
    update.results.map((r) => r.id),
    [1],
  );
  // Answered requests are forgotten: a second result for id 1 or 2 matches nothing.
  events = feed(session, { type: 'result', id: 1, outcome: 'arrived', tick: 6 }, { type: 'result', id: 2, outcome: 'arrived', tick: 6 });
  assert.deepEqual(
    events.filter((e) => e.type === 'result').map((e) => e.request),
    [null, null],
  );
});

test('an accepted pickUp settles with the percepts that shows it', () => {
  const session = seated();
  const pick = session.act('pickUp', [11]);
  sent(session);
  let events = feed(session, { type: 'ack', id: pick.id, ok: true, tick: 3 });
  assert.deepEqual(kinds(events), ['ack']);
  events = feed(session, percepts(4, { add: [['holding', 11]] }));
  assert.deepEqual(kinds(events), ['settled', 'percepts']);
  assert.equal(events[1].request, pick);
  assert.equal(events[1].result, null);
});

test('lockstep ready: once per percepts, for the latest tick only', () => {
  const session = seated();
  assert.equal(session.ready(0), true);
  assert.equal(session.ready(0), false, 'tick 0 is answered');
  feed(session, percepts(0, { add: [['player', 'Bob']] })); // a later player named in tick 0
  assert.equal(session.ready(), true, 'a percepts after the ready gets its own');
  feed(session, percepts(3));
  assert.equal(session.ready(2), false, 'an older tick is over (late_ready)');
  assert.equal(session.ready(4), false, 'a tick that has not come (bad_tick)');
  assert.equal(session.ready(3), true);
  assert.deepEqual(sent(session), [
    { type: 'ready', tick: 0 },
    { type: 'ready', tick: 0 },
    { type: 'ready', tick: 3 },
  ]);
  feed(session, percepts(7), { type: 'match_end', reason: 'max_ticks', result: { ticks: 7 } });
  assert.equal(session.ready(7), false, 'no ready once the match is over');
  assert.deepEqual(sent(session), []);
});

test('no ready in realtime, nor before welcome', () => {
  const early = new PlayerSession({ name: 'Ann' });
  early.start();
  early.takeLines();
  feed(early, percepts(0, { full: true }));
  assert.equal(early.ready(0), false);
  const session = seated('realtime');
  feed(session, percepts(1));
  assert.equal(session.ready(1), false);
  assert.deepEqual(sent(session), []);
});

test('a resync is answered by the next full snapshot, and one ready answers both', () => {
  const session = seated();
  feed(session, percepts(2, { add: [['in', 'RoomC1']] }));
  assert.equal(session.resync('first'), null);
  assert.equal(session.resync('second'), null);
  assert.equal(session.resyncsPending, 2);
  let events = feed(session, percepts(2, { add: [['state', 'arrived']] }));
  assert.deepEqual(events.find((e) => e.type === 'percepts')?.resynced, [], 'a delta answers no resync');
  events = feed(session, { ...fake.snapshot(2), add: [['at', 'RoomC1']] });
  assert.deepEqual(events.find((e) => e.type === 'percepts')?.resynced, ['first', 'second']);
  assert.equal(session.resyncsPending, 0);
  assert.deepEqual(session.beliefs.facts(), [['at', 'RoomC1']], 'the snapshot replaced the beliefs');
  assert.equal(session.ready(2), true);
  assert.deepEqual(sent(session), [{ type: 'resync' }, { type: 'resync' }, { type: 'ready', tick: 2 }]);
});

test('welcome, the queue and the first snapshot', () => {
  const session = new PlayerSession({ name: 'Ann', template: 'ladder' });
  const events = feed(
    session,
    fake.lobby({ template: 'ladder', queued: 2 }),
    fake.lobby({ template: 'ladder', queued: 1 }),
    fake.welcome({ match: 'ladder-3', template: 'ladder', mode: 'lockstep' }),
    fake.lobby({ match: 'ladder-3', players: ['Ann'], awaited: 1 }),
    fake.snapshot(0),
    percepts(0),
  );
  assert.deepEqual(kinds(events), ['queued', 'lobby', 'lobby', 'welcome', 'lobby', 'percepts', 'joined', 'percepts']);
  assert.equal(events.find((e) => e.type === 'welcome')?.afterQueue, true);
  assert.deepEqual(session.lobby, { type: 'lobby', match: 'ladder-3', players: ['Ann'], awaited: 1, started: false });
  assert.equal(session.queued, false);
  assert.equal(session.joined, true);
  assert.equal(session.name, 'Ann');
  assert.equal(session.match.name, 'ladder-3');
});

test('taking the robot back: the session, in its match, never by template', () => {
  const session = new PlayerSession({ name: 'Ann', template: 'ladder', words: true, timeoutMs: 500 });
  feed(session, fake.welcome({ match: 'ladder-3', template: 'ladder', session: 'abc' }), fake.snapshot(0));
  assert.deepEqual(session.reconnectOptions({ timeoutMs: 900 }), {
    name: 'Ann',
    words: true,
    timeoutMs: 900,
    session: 'abc',
    match: 'ladder-3',
  });
  const again = new PlayerSession(session.reconnectOptions());
  again.start();
  assert.deepEqual(sent(again), [{ type: 'hello', protocol: 'bw4t', versions: [1], name: 'Ann', session: 'abc', words: true, match: 'ladder-3' }]);
});

test('lines from a stream: split across chunks, CRLF, blank and bad lines', () => {
  const session = new PlayerSession({ name: 'Ann' });
  const welcome = JSON.stringify(fake.welcome());
  const events = [
    ...session.receiveChunk(welcome.slice(0, 10)),
    ...session.receiveChunk(welcome.slice(10) + '\r\n\n{not json}\n[1]\n'),
    ...session.receiveChunk(JSON.stringify(fake.snapshot(0)).slice(0, 5)),
  ];
  assert.deepEqual(kinds(events), ['welcome', 'bad_line']);
  assert.equal(events.find((e) => e.type === 'bad_line')?.line, '{not json}');
  assert.equal(session.joined, false, 'the snapshot is not complete yet');
  assert.deepEqual(kinds([...session.receiveChunk(JSON.stringify(fake.snapshot(0)).slice(5) + '\n')]), ['percepts', 'joined']);
  assert.deepEqual(kinds(session.receiveLine(JSON.stringify({ type: 'pong', id: 'x' }))), ['pong']);
});

test('pings find their tag by id', () => {
  const session = seated();
  assert.equal(session.ping(undefined, 'auto'), null);
  assert.equal(session.ping('mine', 'given'), null);
  const [auto, mine] = sent(session);
  assert.equal(mine.id, 'mine');
  let events = feed(session, { type: 'pong', id: 'mine' }, { type: 'pong', id: auto.id });
  assert.deepEqual(
    events.filter((e) => e.type === 'pong').map((e) => e.tag),
    ['given', 'auto'],
  );
  events = feed(session, { type: 'pong', id: 'mine' });
  assert.equal(events[1].matched, false);
});

test('the end of the match abandons what is unanswered and refuses new requests', () => {
  const session = seated();
  session.act('goTo', ['RoomC1'], 'go');
  session.act('putDown', [], 'put');
  session.resync('resync');
  session.ping('p', 'ping');
  sent(session);
  feed(session, { type: 'ack', id: 2, ok: true, tick: 1 }); // put settles with the next percepts
  const events = feed(session, { type: 'match_end', reason: 'completed', result: { ticks: 9 } });
  assert.deepEqual(kinds(events), ['settled', 'abandoned', 'match_end']);
  const abandoned = events.find((e) => e.type === 'abandoned');
  assert.deepEqual(abandoned.error, { code: 'match_over', message: 'the match ended (completed)', fatal: false });
  assert.deepEqual(
    abandoned.requests.map((r) => r.tag),
    ['go'],
  );
  assert.deepEqual([abandoned.resyncs, abandoned.pings], [['resync'], ['ping']]);
  assert.equal(session.ended, true);
  assert.equal(session.error, null);
  const late = session.act('goTo', ['RoomC2']);
  assert.equal(late.failure?.code, 'match_over');
  assert.equal(session.resync()?.code, 'match_over');
  assert.equal(session.bye(), false);
  assert.deepEqual(sent(session), []);
});

test('a fatal error ends the session with that error', () => {
  const session = seated();
  session.act('goTo', ['RoomC1'], 'go');
  const events = feed(session, ...fake.fatal('unresponsive', 'no ready in time'));
  assert.deepEqual(kinds(events), ['error', 'abandoned', 'bye']);
  const error = { code: 'unresponsive', message: 'no ready in time', fatal: true };
  assert.deepEqual(session.error, error);
  assert.equal(events.find((e) => e.type === 'abandoned')?.error, session.error);
  assert.equal(session.act('pickUp').failure, session.error);
  assert.equal(session.ready(), false);
});

test('a connection closed without bye is a failure; closed on purpose it is not', () => {
  const dropped = seated();
  dropped.act('goTo', ['RoomC1'], 'go');
  const events = dropped.closed();
  assert.deepEqual(kinds(events), ['abandoned']);
  assert.equal(dropped.error?.code, 'connection_closed');
  assert.deepEqual(dropped.closed(), [], 'closed once');

  const left = seated();
  left.closing();
  const [abandoned] = left.closed();
  assert.equal(left.error, null);
  assert.equal(abandoned.error.code, 'not_connected');

  const said = seated();
  assert.equal(said.bye(), true);
  assert.equal(said.bye(), false);
  assert.deepEqual(sent(said), [{ type: 'bye' }]);
  feed(said, { type: 'bye', reason: 'goodbye' });
  said.closed();
  assert.equal(said.error, null);
  assert.equal(said.ended, true);
});

test('a line over the protocol limit is refused and nothing is sent', () => {
  const session = seated();
  assert.throws(() => session.say('all', 'x'.repeat(MAX_LINE_BYTES)), RangeError);
  assert.deepEqual(sent(session), []);
  const next = session.act('putDown');
  assert.deepEqual(sent(session), [{ type: 'act', action: 'putDown', args: [], id: next.id }]);
  const events = feed(session, { type: 'ack', id: next.id - 1, ok: true, tick: 0 });
  assert.equal(events[1].request, null, 'the refused say is not awaited');
});
