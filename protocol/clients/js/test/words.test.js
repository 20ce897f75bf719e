// The robot's situation in words: the `words` option in `hello` (also when reconnecting),
// and `update.words` / `client.words`, against a scripted server and the real one.

import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { connect } from '../index.js';
import { startFakeServer, startServer, fake, within } from './helpers.js';

/** @type {Array<() => Promise<void>>} */
const cleanups = [];
after(async () => {
  for (const cleanup of cleanups) await cleanup();
});

/** @param {string[]} args */
async function server(args) {
  const s = await startServer(args);
  cleanups.push(s.stop);
  return s;
}

const SITUATION = 'I am Ann (robot 0), at FrontDropZone, not in a room. I hold nothing. I am standing still.';

test('hello asks for words only when told, and again when reconnecting', { timeout: 10000 }, async () => {
  const s = await startFakeServer(async (conn) => {
    const hello = await conn.expect('hello');
    const snapshot = fake.snapshot();
    conn.send(fake.welcome(), hello.words ? { ...snapshot, words: SITUATION } : snapshot);
    await conn.closed();
  });
  try {
    const plain = await connect({ host: s.host, port: s.port, name: 'Ann' });
    plain.close();
    assert.equal(plain.words, null);
    const first = await connect({ host: s.host, port: s.port, name: 'Ann', words: true });
    assert.equal(first.words, SITUATION);
    const again = await within(first.reconnect(), 5000, 'reconnect');
    again.close();
    assert.equal(again.words, SITUATION);
    const [a, b, c] = s.connections.map((conn) => conn.received[0]);
    assert.equal('words' in a, false);
    assert.equal(b.words, true);
    assert.deepEqual([c.words, c.session], [true, '0123456789abcdef01234567']);
  } finally {
    await s.stop();
  }
});

test('words: every update carries the robot situation in English', { timeout: 20000 }, async () => {
  const s = await server(['--deadline-ms', '0', '--max-ticks', '400']);
  const client = await connect({ host: s.host, port: s.port, name: 'Ann', words: true });
  /** @type {Array<string|null>} */
  const words = [];
  let order = null;
  try {
    await within(
      (async () => {
        for await (const update of client.updates()) {
          words.push(update.words);
          if (order === null) order = client.goTo('RoomC1');
          else if (order.done) break;
        }
      })(),
      15000,
      'Ann to reach RoomC1',
    );
    assert.ok(order?.succeeded, 'arrived in RoomC1');
    assert.ok(words[0]?.startsWith('I am Ann (robot 0), at FrontDropZone, not in a room.'), words[0] ?? 'null');
    assert.ok(words.every((w) => typeof w === 'string' && w.startsWith('I am Ann (robot 0)')), 'words with every update');
    assert.equal(client.words, words.at(-1));
    assert.ok(client.words?.startsWith('I am Ann (robot 0), in RoomC1.'), client.words ?? 'null');
  } finally {
    await within(client.bye(), 6000, 'bye');
  }
});

test('no words unless asked', { timeout: 20000 }, async () => {
  const s = await server(['--deadline-ms', '0', '--max-ticks', '5']);
  const client = await connect({ host: s.host, port: s.port, name: 'Ann', everyTick: true });
  const words = [];
  for await (const update of client.updates()) words.push(update.words);
  assert.deepEqual(words, [null, null, null, null, null, null]);
  assert.equal(client.words, null);
});
