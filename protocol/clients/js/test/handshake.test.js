// Joining a real server: welcome and snapshot, ping, bye, environment defaults, and
// fatal errors during the handshake.

import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import net from 'node:net';
import { connect, BW4TError } from '../index.js';
import { startServer, within } from './helpers.js';

/** @type {Array<() => Promise<void>>} */
const cleanups = [];
after(async () => {
  for (const cleanup of cleanups) await cleanup();
});

async function server(args = []) {
  const s = await startServer(args);
  cleanups.push(s.stop);
  return s;
}

test('handshake: welcome, the first snapshot, ping, bye', { timeout: 20000 }, async () => {
  // No tick limit: an idle robot is not waited for, so a limited match could end before
  // the bye (in milliseconds), and then `finished` would hold its result.
  const s = await server(['--deadline-ms', '0', '--max-ticks', '0']);
  const client = await connect({ host: s.host, port: s.port, name: 'Ann' });
  try {
    assert.equal(client.name, 'Ann');
    assert.equal(client.robot, 0);
    assert.equal(typeof client.session, 'string');
    assert.equal(client.welcome?.version, 1);
    assert.equal(client.match?.mode, 'lockstep');
    assert.equal(client.match?.map, 'fixed');
    assert.equal(client.match?.every_tick, false);
    assert.equal(client.tick, 0);
    const b = client.beliefs;
    assert.equal(b.get('ownName'), 'Ann');
    assert.equal(b.get('bot'), 0);
    assert.deepEqual(b.get('sequence'), ['Yellow', 'Red', 'Blue', 'Green', 'White', 'Orange']);
    assert.equal(b.get('at'), 'FrontDropZone');
    assert.equal(b.get('sequenceIndex'), 0);
    assert.equal(b.get('state'), 'arrived');
    assert.ok(b.holds('place', 'RoomA1'));
    assert.equal(b.all('place').length, 28);

    const pong = await within(client.ping('p1'), 5000, 'pong');
    assert.deepEqual(pong, { type: 'pong', id: 'p1' });
  } finally {
    await within(client.bye(), 6000, 'bye');
  }
  assert.ok(client.closed);
  assert.equal(client.error, null);
  assert.equal(await within(client.finished, 1000, 'finished'), null);
});

test('connect() defaults to the BW4T_* environment', { timeout: 20000 }, async () => {
  const s = await server(['--token', 's3cret', '--deadline-ms', '0']);
  const saved = { ...process.env };
  Object.assign(process.env, { BW4T_HOST: s.host, BW4T_PORT: String(s.port), BW4T_NAME: 'Envy', BW4T_TOKEN: 's3cret' });
  let client;
  try {
    client = await connect();
  } finally {
    for (const key of ['BW4T_HOST', 'BW4T_PORT', 'BW4T_NAME', 'BW4T_TOKEN']) {
      if (saved[key] === undefined) delete process.env[key];
      else process.env[key] = saved[key];
    }
  }
  assert.equal(client.name, 'Envy');
  await within(client.bye(), 6000, 'bye');
});

test('fatal handshake errors reject connect() with their code', { timeout: 20000 }, async () => {
  const s = await server(['--token', 's3cret', '--robots', '2', '--deadline-ms', '0']);
  await assert.rejects(connect({ host: s.host, port: s.port, name: 'Ann' }), (err) => {
    assert.ok(err instanceof BW4TError);
    assert.equal(err.code, 'bad_token');
    assert.equal(err.fatal, true);
    return true;
  });
  const ann = await connect({ host: s.host, port: s.port, name: 'Ann', token: 's3cret' });
  try {
    await assert.rejects(connect({ host: s.host, port: s.port, name: 'Ann', token: 's3cret' }), { code: 'name_taken' });
    await assert.rejects(connect({ host: s.host, port: s.port, name: '9lives', token: 's3cret' }), { code: 'invalid_name' });
  } finally {
    await within(ann.bye(), 6000, 'bye');
  }
});

test('a refused connection is a connect_failed error', { timeout: 10000 }, async () => {
  // A port that was free a moment ago.
  const port = await new Promise((resolve) => {
    const probe = net.createServer().listen(0, '127.0.0.1', () => {
      const p = /** @type {net.AddressInfo} */ (probe.address()).port;
      probe.close(() => resolve(p));
    });
  });
  await assert.rejects(connect({ host: '127.0.0.1', port, name: 'Ann', timeoutMs: 3000 }), { code: 'connect_failed' });
});
