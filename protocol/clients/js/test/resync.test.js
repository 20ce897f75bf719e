// The belief base kept from deltas equals the server's full snapshot (resync), checked
// repeatedly during several hundred ticks of play by two robots.

import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { connect } from '../index.js';
import { startServer, within } from './helpers.js';

/** @type {Array<() => Promise<void>>} */
const cleanups = [];
after(async () => {
  for (const cleanup of cleanups) await cleanup();
});

/**
 * Play a fixed plan (each step starts when the previous action is done), and at the
 * first update past every `every` ticks compare the beliefs with a fresh snapshot.
 * @param {import('../index.js').Client} client
 * @param {Array<(c: import('../index.js').Client) => import('../index.js').ActionHandle>} plan
 * @param {{every: number, until: number}} options
 */
async function playAndCheck(client, plan, { every, until }) {
  const checks = [];
  const errors = [];
  client.on('serverError', (e) => errors.push(e));
  let step = 0;
  let current = null;
  let nextCheck = every;
  for await (const update of client.updates()) {
    if (update.tick >= nextCheck) {
      const before = update.beliefs.clone();
      const snapshot = await within(client.resync(), 5000, `resync at tick ${update.tick}`);
      assert.equal(snapshot.full, true);
      assert.equal(snapshot.tick, update.tick, 'in lockstep the snapshot is of the tick being handled');
      assert.deepEqual(before.diff(client.beliefs), { extra: [], missing: [] }, `beliefs at tick ${update.tick}`);
      assert.ok(client.beliefs.size > 30);
      checks.push({ tick: update.tick, facts: client.beliefs.size, holding: client.beliefs.holds('holding'), in: client.beliefs.get('in') });
      nextCheck = update.tick + every;
    }
    if (update.tick >= until) break;
    if (current === null || current.done) {
      current = plan[step % plan.length](client);
      step += 1;
    }
  }
  assert.deepEqual(errors, [], 'no late_ready, bad_tick or other errors');
  return checks;
}

test('beliefs equal a resync snapshot during play', { timeout: 60000 }, async () => {
  const s = await startServer(['--robots', '2', '--deadline-ms', '0', '--max-ticks', '5000']);
  cleanups.push(s.stop);
  const ann = await connect({ host: s.host, port: s.port, name: 'Ann' });
  const bob = await connect({ host: s.host, port: s.port, name: 'Bob', everyTick: true });
  cleanups.unshift(() => ann.bye(2000), () => bob.bye(2000));

  const annPlan = [
    (c) => c.goTo('RoomC1'),
    (c) => c.goToBlock(11),
    (c) => c.pickUp(11),
    (c) => c.say('Bob', 'I have the Yellow block'),
    (c) => c.goTo('DropZone'),
    (c) => c.putDown(),
    (c) => c.goTo('RoomA1'),
    (c) => c.goTo('RoomB2'),
  ];
  const bobPlan = [
    (c) => c.goTo('RoomC3'),
    (c) => c.say('all', 'in C3'),
    (c) => c.goTo('RoomB1'),
    (c) => c.goTo('RoomC2'),
  ];
  const [annChecks, bobChecks] = await within(
    Promise.all([playAndCheck(ann, annPlan, { every: 97, until: 700 }), playAndCheck(bob, bobPlan, { every: 113, until: 700 })]),
    50000,
    'play',
  );
  for (const checks of [annChecks, bobChecks]) {
    assert.ok(checks.length >= 4, `checked ${checks.length} times`);
    assert.ok(checks.at(-1).tick >= 300);
  }
  assert.ok(annChecks.some((c) => c.holding) || annChecks.some((c) => c.in), 'checked in interesting states');
});

test('resync outside an iterator', { timeout: 20000 }, async () => {
  const s = await startServer(['--deadline-ms', '0', '--max-ticks', '3000']);
  cleanups.push(s.stop);
  const client = await connect({ host: s.host, port: s.port, name: 'Ann' });
  cleanups.unshift(() => client.bye(2000));
  const arrived = await within(client.goTo('RoomC1').result, 10000, 'goTo');
  const before = client.beliefs.clone();
  const snapshot = await within(client.resync(), 5000, 'resync');
  assert.ok(snapshot.full);
  // The tick the order ended at is answered only after the snapshot: same tick, same facts.
  assert.equal(snapshot.tick, arrived.tick);
  assert.deepEqual(before.diff(client.beliefs), { extra: [], missing: [] });
  // Acting right after the snapshot lands at that tick's boundary, and the match goes on.
  const back = client.goTo('DropZone');
  assert.equal((await within(back.ack, 10000, 'ack after resync')).tick, arrived.tick);
  assert.equal((await within(back.result, 10000, 'goTo after resync')).outcome, 'arrived');
});
