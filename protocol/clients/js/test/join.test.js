// Joining a named match or a template, `lobby` messages and reconnecting to the
// session's match: first against a scripted server, which checks exactly what the client
// sends and what it makes of the answers, then against the real server.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { setTimeout as sleep } from 'node:timers/promises';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { connect, BW4TError } from '../index.js';
import { startFakeServer, startServer, fake, within } from './helpers.js';

/**
 * Run `body` against a fake server running `script` per connection; the server is
 * stopped afterwards and an error in a script fails the test.
 * @param {(conn: import('./helpers.js').FakeConnection) => Promise<void>} script
 * @param {(server: Awaited<ReturnType<typeof startFakeServer>>) => Promise<void>} body
 */
async function withFake(script, body) {
  const server = await startFakeServer(script);
  try {
    await body(server);
  } finally {
    await server.stop();
  }
}

/**
 * A script answering `hello` with `welcome` and a snapshot, then waiting for the client
 * to close.
 * @param {Parameters<typeof fake.welcome>[0]} [fields]
 */
function seat(fields) {
  return async (conn) => {
    await conn.expect('hello');
    conn.send(fake.welcome(fields), fake.snapshot());
    await conn.closed();
  };
}

test('hello names the match', { timeout: 10000 }, async () => {
  await withFake(seat({ match: 'team-a' }), async (s) => {
    const client = await connect({ host: s.host, port: s.port, name: 'Ann', match: 'team-a' });
    client.close();
    const hello = s.connections[0].received[0];
    assert.equal(hello.match, 'team-a');
    assert.equal('template' in hello, false);
    assert.deepEqual([hello.name, hello.protocol, hello.versions], ['Ann', 'bw4t', [1]]);
    assert.equal(client.match?.name, 'team-a');
  });
});

test('hello names the template', { timeout: 10000 }, async () => {
  await withFake(seat({ match: 'ladder-3', template: 'ladder' }), async (s) => {
    const client = await connect({ host: s.host, port: s.port, name: 'Ann', template: 'ladder' });
    client.close();
    const hello = s.connections[0].received[0];
    assert.equal(hello.template, 'ladder');
    assert.equal('match' in hello, false);
    assert.deepEqual([client.match?.name, client.match?.template], ['ladder-3', 'ladder']);
  });
});

test('hello without match or template joins the default match', { timeout: 10000 }, async () => {
  await withFake(seat(), async (s) => {
    const client = await connect({ host: s.host, port: s.port, name: 'Ann' });
    client.close();
    const hello = s.connections[0].received[0];
    assert.equal('match' in hello || 'template' in hello, false);
  });
});

test('match and template together are refused before connecting', { timeout: 10000 }, async () => {
  await withFake(seat(), async (s) => {
    await assert.rejects(connect({ host: s.host, port: s.port, match: 'team-a', template: 'ladder' }), (err) => {
      assert.ok(err instanceof BW4TError);
      assert.equal(err.code, 'bad_options');
      assert.match(err.message, /not both/);
      return true;
    });
    // Nothing was sent: the first connection the server sees is this one.
    const bob = await connect({ host: s.host, port: s.port, name: 'Bob' });
    bob.close();
    assert.equal(s.connections.length, 1);
    assert.equal(s.connections[0].received[0].name, 'Bob');
  });
});

test('reconnect names the match the session belongs to', { timeout: 10000 }, async () => {
  const session = '00112233445566778899aabb';
  await withFake(seat({ match: 'ladder-3', template: 'ladder', session }), async (s) => {
    const first = await connect({ host: s.host, port: s.port, name: 'Ann', template: 'ladder' });
    const second = await within(first.reconnect(), 5000, 'reconnect');
    second.close();
    assert.ok(first.closed);
    assert.equal(second.session, session);
    assert.equal(second.match?.name, 'ladder-3');
    const [a, b] = s.connections.map((c) => c.received[0]);
    assert.equal(a.template, 'ladder');
    assert.equal('match' in a || 'session' in a, false);
    assert.deepEqual([b.match, b.session, b.name, 'template' in b], ['ladder-3', session, 'Ann', false]);
  });
});

/**
 * Queued twice, seated, a lobby before and after the tick-0 snapshot, two lockstep ticks
 * and the end.
 * @param {import('./helpers.js').FakeConnection} conn
 */
async function lobbyScript(conn) {
  const hello = await conn.expect('hello');
  assert.equal(hello.template, 'ladder');
  conn.send(
    fake.lobby({ template: 'ladder', players: [], awaited: 0, queued: 2 }),
    fake.lobby({ template: 'ladder', players: [], awaited: 0, queued: 1 }),
    fake.welcome({ match: 'ladder-3', template: 'ladder', mode: 'lockstep' }),
    fake.lobby({ match: 'ladder-3', template: 'ladder', players: ['Ann'], awaited: 1, start_in_ms: 25000 }),
    fake.snapshot(0),
  );
  assert.deepEqual(await conn.expect('ready'), { type: 'ready', tick: 0 });
  // Someone joins: a lobby, then the first tick (a lobby asks for no ready).
  conn.send(
    fake.lobby({ match: 'ladder-3', template: 'ladder', players: ['Ann', 'Bot1'], started: true }),
    { type: 'percepts', tick: 1, add: [['state', 'traveling']], not: [['state', 'arrived']] },
  );
  assert.deepEqual(await conn.expect('ready'), { type: 'ready', tick: 1 });
  conn.send({ type: 'match_end', reason: 'interrupted', result: { completed: false } }, { type: 'bye', reason: 'match_over' });
}

test('lobby messages before and after welcome', { timeout: 10000 }, async () => {
  await withFake(lobbyScript, async (s) => {
    const seen = [];
    const client = await connect({ host: s.host, port: s.port, name: 'Ann', template: 'ladder', onLobby: (l) => seen.push(l) });
    assert.deepEqual(seen.slice(0, 3).map((l) => l.queued), [2, 1, undefined]);
    const events = [];
    client.on('lobby', (l) => events.push(l));
    const ticks = [];
    for await (const update of client.updates()) ticks.push(update.tick);
    assert.deepEqual(ticks, [0, 1]);
    assert.equal(client.endReason, 'interrupted');
    assert.equal(client.error, null);
    assert.deepEqual(
      seen.map((l) => [l.match, l.template, l.players, l.awaited, l.start_in_ms, l.queued, l.started]),
      [
        [undefined, 'ladder', [], 0, undefined, 2, false],
        [undefined, 'ladder', [], 0, undefined, 1, false],
        ['ladder-3', 'ladder', ['Ann'], 1, 25000, undefined, false],
        ['ladder-3', 'ladder', ['Ann', 'Bot1'], 0, undefined, undefined, true],
      ],
    );
    assert.equal(client.lobby, seen.at(-1));
    // The last lobby came after connect() resolved: also an event.
    assert.deepEqual(events, [seen.at(-1)]);
  });
});

test('time in a template queue is not bounded by timeoutMs', { timeout: 10000 }, async () => {
  const timeoutMs = 300;
  const script = async (conn) => {
    await conn.expect('hello');
    conn.send(fake.lobby({ template: 'ladder', players: [], awaited: 0, queued: 1 }));
    await sleep(3 * timeoutMs); // the queue moves slowly: longer than the handshake's bound
    conn.send(fake.welcome({ match: 'ladder-1', template: 'ladder' }), fake.snapshot());
    await conn.closed();
  };
  await withFake(script, async (s) => {
    const client = await connect({ host: s.host, port: s.port, template: 'ladder', timeoutMs });
    client.close();
    assert.equal(client.match?.name, 'ladder-1');
    assert.equal(client.lobby?.queued, 1);
  });
});

test('a silent server still times out', { timeout: 10000 }, async () => {
  await withFake(
    async (conn) => conn.closed(),
    async (s) => {
      await assert.rejects(connect({ host: s.host, port: s.port, template: 'ladder', timeoutMs: 300 }), { code: 'timeout' });
    },
  );
});

test('throwing from onLobby gives up the wait', { timeout: 10000 }, async () => {
  const script = async (conn) => {
    await conn.expect('hello');
    conn.send(fake.lobby({ template: 'ladder', players: [], awaited: 0, queued: 7 }));
    await conn.closed(); // the client leaves the queue by closing
  };
  await withFake(script, async (s) => {
    const tooFar = (lobby) => {
      if (lobby.queued > 3) throw new Error(`place ${lobby.queued} in the queue`);
    };
    await assert.rejects(connect({ host: s.host, port: s.port, template: 'ladder', onLobby: tooFar }), /place 7/);
  });
});

for (const [option, code] of [
  ['match', 'unknown_match'],
  ['template', 'unknown_template'],
]) {
  test(`${code} rejects connect()`, { timeout: 10000 }, async () => {
    const script = async (conn) => {
      await conn.expect('hello');
      conn.send(...fake.fatal(code, `no ${option} named "nope"`));
    };
    await withFake(script, async (s) => {
      await assert.rejects(connect({ host: s.host, port: s.port, [option]: 'nope' }), (err) => {
        assert.ok(err instanceof BW4TError);
        assert.deepEqual([err.code, err.fatal], [code, true]);
        assert.match(err.detail, /nope/);
        return true;
      });
    });
  });
}

// ---- the real server -------------------------------------------------------------
// Joining the default match by its name, lobby messages, reconnecting and unknown names
// need only `bw4t serve`; templates and named matches need `bw4t serve --config`.

test('the named default match: lobby messages, then reconnect', { timeout: 20000 }, async () => {
  const s = await startServer(['--mode', 'realtime', '--robots', '2', '--grace-s', '30', '--max-ticks', '2000']);
  try {
    const lobbies = [];
    const ann = await connect({ host: s.host, port: s.port, name: 'Ann', match: 'default', everyTick: true, onLobby: (l) => lobbies.push(l) });
    assert.equal(ann.match?.name, 'default');
    const bob = await connect({ host: s.host, port: s.port, name: 'Bob', match: 'default' });
    // The match started with Bob: every lobby came before the percepts of tick 1.
    for await (const update of ann.updates()) if (update.tick >= 1) break;
    assert.ok(lobbies.length > 0, 'no lobby after welcome');
    const [first, last] = [lobbies[0], lobbies.at(-1)];
    assert.deepEqual([first.match, first.players, first.awaited], ['default', ['Ann'], 1]);
    assert.deepEqual([last.match, last.players, last.awaited, last.started], ['default', ['Ann', 'Bob'], 0, true]);
    assert.ok(lobbies.slice(0, -1).every((l) => !l.started));
    assert.equal(ann.lobby, last);
    assert.ok(lobbies.every((l) => l.queued === undefined));

    const again = await within(ann.reconnect(), 10000, 'reconnect');
    assert.deepEqual([again.robot, again.name, again.match?.name], [0, 'Ann', 'default']);
    assert.equal(again.error, null);
    await within(Promise.all([again.bye(), bob.bye()]), 10000, 'bye');
  } finally {
    await s.stop();
  }
});

for (const [option, code] of [
  ['match', 'unknown_match'],
  ['template', 'unknown_template'],
]) {
  test(`the real server refuses an unknown ${option} with ${code}`, { timeout: 20000 }, async () => {
    const s = await startServer(['--deadline-ms', '0']);
    try {
      await assert.rejects(connect({ host: s.host, port: s.port, name: 'Ann', [option]: 'nope' }), (err) => {
        assert.deepEqual([err.code, err.fatal], [code, true]);
        assert.match(err.detail, /nope/);
        return true;
      });
    } finally {
      await s.stop();
    }
  });
}

// Templates and named matches (`bw4t serve --config`). The default match is `team-a`, so a
// reconnect that did not name its match would land there and be refused.
const ARENA = `
default = "team-a"

[[template]]
name = "classroom"
map = "fixed"
robots = 2
names = ["team-a", "team-b"]

[[template]]
name = "ladder"
map = "fixed"
robots = 2
max_ticks = 2000

[[template]]
name = "solo"
map = "fixed"
robots = 1
max_running = 1
mode = "lockstep"
deadline_ms = 0
max_ticks = 5
`;

/** `bw4t serve --config` with the templates of ARENA. */
async function startArena() {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'bw4t-arena-'));
  const file = path.join(dir, 'arena.toml');
  fs.writeFileSync(file, ARENA);
  const server = await startServer(['--config', file]);
  return {
    ...server,
    stop: async () => {
      await server.stop();
      fs.rmSync(dir, { recursive: true, force: true });
    },
  };
}

test('a named match of a template, and the default match', { timeout: 20000 }, async () => {
  const s = await startArena();
  try {
    const ann = await connect({ host: s.host, port: s.port, name: 'Ann', match: 'team-b' });
    assert.deepEqual([ann.match?.name, ann.match?.template, ann.match?.players_needed], ['team-b', 'classroom', 2]);
    const bob = await connect({ host: s.host, port: s.port, name: 'Bob' });
    assert.deepEqual([bob.match?.name, bob.robot], ['team-a', 0]);
    await within(Promise.all([ann.bye(), bob.bye()]), 10000, 'bye');
  } finally {
    await s.stop();
  }
});

test('a template: lobby messages, and reconnect into its match', { timeout: 20000 }, async () => {
  const s = await startArena();
  try {
    const lobbies = [];
    const first = await connect({ host: s.host, port: s.port, name: 'Ann', template: 'ladder', everyTick: true, onLobby: (l) => lobbies.push(l) });
    const name = first.match?.name;
    assert.equal(first.match?.template, 'ladder');
    assert.match(String(name), /^ladder/);
    const bob = await connect({ host: s.host, port: s.port, name: 'Bob', template: 'ladder' });
    assert.deepEqual([bob.match?.name, bob.robot], [name, 1]); // the match with a free seat
    for await (const update of first.updates()) if (update.tick >= 1) break; // lobbies come before tick 1
    assert.deepEqual([lobbies[0].match, lobbies[0].template, lobbies[0].players], [name, 'ladder', ['Ann']]);
    const last = lobbies.at(-1);
    assert.deepEqual([last.match, last.players, last.awaited, last.started], [name, ['Ann', 'Bob'], 0, true]);
    // Once the match has started, a dropped player's robot waits for it (before the start
    // a seat left is free again at once). Names the match: the default one would refuse
    // the session.
    const ann = await within(first.reconnect(), 10000, 'reconnect');
    assert.deepEqual([ann.robot, ann.session, ann.match?.name], [0, first.session, name]);
    await within(Promise.all([ann.bye(), bob.bye()]), 10000, 'bye');
  } finally {
    await s.stop();
  }
});

test('queued for a template, then seated', { timeout: 20000 }, async () => {
  const s = await startArena();
  try {
    // Ann answers tick 0 only when she iterates: until then her match (lockstep) waits.
    const ann = await connect({ host: s.host, port: s.port, name: 'Ann', template: 'solo', autoReady: false });
    assert.equal(ann.match?.template, 'solo');
    const bobLobbies = [];
    let onQueued = () => {};
    const queued = new Promise((resolve) => (onQueued = resolve));
    const bobJoins = connect({
      host: s.host,
      port: s.port,
      name: 'Bob',
      template: 'solo',
      onLobby: (l) => {
        bobLobbies.push(l);
        if (l.queued !== undefined) onQueued(undefined);
      },
    });
    // The only match of solo is Ann's (max_running = 1): Bob waits in the queue until it
    // ends, which it does once Ann has answered its 5 ticks.
    await within(queued, 10000, 'Bob to be queued');
    for await (const _update of ann.updates());
    assert.equal(ann.endReason, 'max_ticks');
    const bob = await within(bobJoins, 10000, 'Bob to be seated');
    assert.equal(bob.match?.template, 'solo');
    assert.notEqual(bob.match?.name, ann.match?.name);
    assert.deepEqual([bobLobbies[0].queued, bobLobbies[0].template, bobLobbies[0].match], [1, 'solo', undefined]);
    await within(bob.bye(), 10000, 'bye');
  } finally {
    await s.stop();
  }
});
