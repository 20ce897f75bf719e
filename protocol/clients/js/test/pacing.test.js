// Lockstep pacing: ready after each handled tick (never late, never twice), the end of
// the match, and fatal errors surfacing from the iterator.

import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { connect, BW4TError } from '../index.js';
import { startServer, within } from './helpers.js';

/** @type {Array<() => Promise<void>>} */
const cleanups = [];
after(async () => {
  for (const cleanup of cleanups) await cleanup();
});

test('updates run to match_end with no late ticks and no pacing errors', { timeout: 30000 }, async () => {
  // The default deadline (1000 ms): a missing ready would show as late_ticks.
  const s = await startServer(['--max-ticks', '400']);
  cleanups.push(s.stop);
  const client = await connect({ host: s.host, port: s.port, name: 'Ann' });
  const errors = [];
  client.on('serverError', (e) => errors.push(e));
  const ticks = [];
  let order = null;
  const plan = ['RoomC1', 'DropZone', 'RoomC2', 'DropZone'];
  await within(
    (async () => {
      for await (const update of client.updates()) {
        ticks.push(update.tick);
        // A slow handler: the server must wait for it.
        if (update.tick === 1) await new Promise((resolve) => setTimeout(resolve, 50));
        if (order === null || order.done) order = client.goTo(plan.shift() ?? 'RoomA1');
      }
    })(),
    25000,
    'the match',
  );
  assert.equal(client.endReason, 'max_ticks');
  assert.equal(client.result?.ticks, 400);
  assert.equal(client.result?.per_robot[0].late_ticks, 0);
  assert.deepEqual(errors, []);
  assert.equal(ticks[0], 0);
  assert.ok(ticks.every((t, i) => i === 0 || t > ticks[i - 1]), 'one update per tick, in order');
  assert.ok(ticks.length < 400, 'ticks where nothing happened are skipped');
  assert.equal(await within(client.finished, 5000, 'finished'), client.result);
  await within(new Promise((resolve) => (client.closed ? resolve(undefined) : client.once('end', resolve))), 5000, 'close');
});

test('everyTick: an update every tick', { timeout: 20000 }, async () => {
  const s = await startServer(['--max-ticks', '50', '--deadline-ms', '0']);
  cleanups.push(s.stop);
  const client = await connect({ host: s.host, port: s.port, name: 'Ann', everyTick: true });
  assert.equal(client.match?.every_tick, true);
  const ticks = [];
  for await (const update of client.updates()) ticks.push(update.tick);
  assert.deepEqual(ticks, Array.from({ length: 51 }, (_, i) => i));
});

test('a fatal error ends the iterator with a BW4TError', { timeout: 20000 }, async () => {
  // everyTick: the server waits for Ann every tick, so the match cannot run to its end
  // before the second connection comes.
  const s = await startServer(['--deadline-ms', '0', '--max-ticks', '1000000']);
  cleanups.push(s.stop);
  const first = await connect({ host: s.host, port: s.port, name: 'Ann', everyTick: true });
  const iterating = (async () => {
    for await (const update of first.updates()) void update;
  })();
  iterating.catch(() => {}); // awaited below, once the second connection is in
  // Taking the session over from another connection: the first gets `replaced`.
  const second = await connect({ host: s.host, port: s.port, session: first.session ?? undefined, everyTick: true });
  cleanups.unshift(() => second.bye(2000));
  assert.equal(second.name, 'Ann');
  await assert.rejects(within(iterating, 5000, 'the first iterator'), (err) => {
    assert.ok(err instanceof BW4TError);
    assert.equal(err.code, 'replaced');
    return true;
  });
  assert.equal(first.error?.code, 'replaced');
  await assert.rejects(first.finished, { code: 'replaced' });
  // Requests after the end fail at once.
  await assert.rejects(first.goTo('RoomA1').ack, { code: 'replaced' });
});

test('an early joiner learns of later players in its next delta', { timeout: 20000 }, async () => {
  const s = await startServer(['--robots', '2', '--deadline-ms', '0', '--max-ticks', '30']);
  cleanups.push(s.stop);
  const ann = await connect({ host: s.host, port: s.port, name: 'Ann' });
  const annUpdates = [];
  const annPlays = (async () => {
    for await (const update of ann.updates()) annUpdates.push(update);
  })();
  annPlays.catch(() => {});
  const bob = await connect({ host: s.host, port: s.port, name: 'Bob' });
  const bobPlays = (async () => {
    for await (const update of bob.updates()) void update;
  })();
  // With --deadline-ms 0 the match would stop if Ann did not answer what she was sent.
  await within(Promise.all([annPlays, bobPlays]), 15000, 'the match');
  assert.equal(ann.endReason, 'max_ticks');
  assert.deepEqual(annUpdates.slice(0, 2).map((u) => [u.tick, u.full]), [[0, true], [1, false]]);
  assert.deepEqual(annUpdates[1].add, [['player', 'Bob']]);
  assert.ok(bob.beliefs.holds('player', 'Ann'));
});
