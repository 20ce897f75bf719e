// Two players on one server talk to each other through say().

import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { connect } from '../index.js';
import { startServer, within } from './helpers.js';

/** @type {Array<() => Promise<void>>} */
const cleanups = [];
after(async () => {
  for (const cleanup of cleanups) await cleanup();
});

test('two clients exchange messages', { timeout: 30000 }, async () => {
  const s = await startServer(['--robots', '2', '--deadline-ms', '0', '--max-ticks', '5000']);
  cleanups.push(s.stop);
  const ann = await connect({ host: s.host, port: s.port, name: 'Ann' });
  const bob = await connect({ host: s.host, port: s.port, name: 'Bob' });
  cleanups.unshift(() => ann.bye(2000), () => bob.bye(2000));

  // Ann: greet Bob directly, then wait for his answer to everyone.
  const annPlays = (async () => {
    let greeting;
    for await (const update of ann.updates()) {
      greeting ??= ann.say('Bob', 'hello Bob');
      const reply = update.messages.find((m) => m.from === 'Bob');
      if (reply) {
        // A message of the shared language comes as its sentence and its structure.
        assert.equal(reply.text, 'I am on my way.');
        assert.deepEqual(reply.said, { kind: 'on_my_way' });
        assert.ok(update.beliefs.holds('player', 'Bob'));
        return { greeting, tick: update.tick };
      }
    }
    throw new Error('the match ended before Bob answered');
  })();

  // Bob: wait for Ann's greeting, answer everyone, and make sure he does not hear himself.
  const bobPlays = (async () => {
    let answer;
    for await (const update of bob.updates()) {
      assert.ok(!update.messages.some((m) => m.from === 'Bob'), 'a message to all is not sent back');
      const greeting = update.messages.find((m) => m.from === 'Ann');
      if (greeting) {
        assert.equal(greeting.text, 'hello Bob');
        assert.equal(greeting.said, undefined, 'free text has no structure');
        answer = bob.say('all', { kind: 'on_my_way' });
        return { answer, tick: update.tick };
      }
    }
    throw new Error('the match ended before Ann greeted');
  })();

  const [annDone, bobDone] = await within(Promise.all([annPlays, bobPlays]), 20000, 'the exchange');
  assert.equal((await within(annDone.greeting.ack, 5000, "ack of Ann's say")).ok, true);
  assert.equal((await within(bobDone.answer.ack, 5000, "ack of Bob's say")).ok, true);
  assert.ok(annDone.tick > bobDone.tick, 'the answer arrives in a later tick');
  assert.equal(ann.error, null);
  assert.equal(bob.error, null);
});
