// Actions against a real server: acks, results, refusals, superseded orders.

import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { connect, ActionRejected } from '../index.js';
import { startServer, within } from './helpers.js';

/** @type {Array<() => Promise<void>>} */
const cleanups = [];
after(async () => {
  for (const cleanup of cleanups) await cleanup();
});

async function join({ everyTick = false } = {}) {
  const s = await startServer(['--deadline-ms', '0', '--max-ticks', '3000']);
  cleanups.push(s.stop);
  const client = await connect({ host: s.host, port: s.port, name: 'Ann', everyTick });
  cleanups.unshift(() => client.bye(2000));
  return client;
}

test('fetch and deliver: ack and result of each action, beliefs follow', { timeout: 30000 }, async () => {
  const client = await join();
  const wait = (p, what) => within(p, 10000, what);

  const go = client.goTo('RoomC1');
  assert.equal(go.action, 'goTo');
  assert.ok(!go.done);
  const ack = await wait(go.ack, 'ack of goTo');
  assert.deepEqual(ack, { type: 'ack', id: go.id, ok: true, tick: 0 });
  const result = await wait(go.result, 'result of goTo');
  assert.equal(result.outcome, 'arrived');
  assert.equal(result.id, go.id);
  assert.ok(go.done && go.succeeded);
  // The result settles once its tick's percepts are applied.
  assert.equal(client.tick, result.tick);
  assert.ok(client.beliefs.holds('in', 'RoomC1'));
  assert.equal(client.beliefs.get('at'), 'RoomC1');
  assert.equal(client.beliefs.get('state'), 'arrived');
  assert.ok(client.beliefs.holds('color', 11, 'Yellow'));

  const toBlock = client.goToBlock(11);
  assert.equal((await wait(toBlock.result, 'goToBlock')).outcome, 'arrived');
  assert.ok(client.beliefs.holds('atBlock', 11));

  const pick = client.pickUp();
  assert.equal((await wait(pick.ack, 'pickUp ack')).ok, true);
  // Non-durative: `result` is null, settled once the change is in the beliefs.
  assert.equal(await wait(pick.result, 'pickUp result'), null);
  assert.equal(client.beliefs.get('holding'), 11);
  assert.ok(!client.beliefs.holds('color', 11));

  assert.equal((await wait(client.goTo('DropZone').result, 'goTo DropZone')).outcome, 'arrived');
  const drop = client.putDown();
  await wait(drop.result, 'putDown');
  assert.equal(drop.acked?.ok, true);
  assert.equal(client.beliefs.get('sequenceIndex'), 1);
  assert.ok(!client.beliefs.holds('holding'));
});

test('refused actions: the ack says why, the result rejects', { timeout: 30000 }, async () => {
  // A refused action changes nothing, so no percepts follows its ack and the server does
  // not wait for this player: ticks would race to --max-ticks. everyTick keeps it waiting.
  const client = await join({ everyTick: true });
  const wait = (p, what) => within(p, 10000, what);

  const nowhere = client.goTo('Nowhere');
  const ack = await wait(nowhere.ack, 'ack');
  assert.equal(ack.ok, false);
  assert.equal(ack.code, 'unknown_place');
  await assert.rejects(wait(nowhere.result, 'result'), (err) => {
    assert.ok(err instanceof ActionRejected);
    assert.equal(err.code, 'unknown_place');
    assert.equal(err.ack, ack);
    return true;
  });
  assert.ok(nowhere.done && !nowhere.succeeded);

  // Refused at once, without waiting for a tick boundary.
  assert.equal((await wait(client.act('fly').ack, 'unknown action')).code, 'unknown_action');
  assert.equal((await wait(client.act('goToBlock', 'Yellow').ack, 'bad args')).code, 'bad_args');
  // Refused by the simulation.
  assert.equal((await wait(client.pickUp().ack, 'pickUp')).code, 'not_at_block');
  assert.equal((await wait(client.putDown().ack, 'putDown')).code, 'not_holding');
  assert.equal((await wait(client.say('Nobody', 'hi').ack, 'say')).code, 'unknown_receiver');
  // An unobserved rejection must not crash the process: this handle is never awaited.
  client.goTo('NowhereElse');
  await wait(client.ping(), 'ping');
});

test('a newer order supersedes the current one', { timeout: 30000 }, async () => {
  const client = await join();
  const first = client.goTo('RoomA1');
  const second = client.goTo('RoomC1');
  assert.equal((await within(first.result, 10000, 'first result')).outcome, 'superseded');
  assert.equal((await within(second.result, 10000, 'second result')).outcome, 'arrived');
  assert.ok(client.beliefs.holds('in', 'RoomC1'));
});

test('a line longer than 64 KiB is refused by the client', { timeout: 20000 }, async () => {
  const client = await join();
  assert.throws(() => client.say('all', 'x'.repeat(70000)), RangeError);
});
