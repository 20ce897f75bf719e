// The example agent completes real matches started by `bw4t run`.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtemp, readFile } from 'node:fs/promises';
import os from 'node:os';
import path from 'node:path';
import { CLIENT_DIR, runMatch } from './helpers.js';

const agent = `node ${JSON.stringify(path.join(CLIENT_DIR, 'examples', 'agent.js'))}`;

function summary(result) {
  return JSON.stringify({ completed: result.completed, ticks: result.ticks, agents: result.agents });
}

test('the example agent completes the fixed map alone', { timeout: 90000 }, async () => {
  const result = await runMatch(['--map', 'fixed', '--seed', '1', '--agent', agent], { timeoutMs: 80000 });
  assert.equal(result.completed, true, summary(result));
  assert.equal(result.agents.length, 1);
  assert.equal(result.agents[0].status, 'ok', summary(result));
  assert.equal(result.wrong_drops, 0);
  assert.equal(result.per_robot[0].late_ticks, 0);
});

test('a team of three example agents completes the default map', { timeout: 90000 }, async () => {
  const result = await runMatch(['--map', 'default', '--seed', '1', '--robots', '3', '--agent', agent], { timeoutMs: 80000 });
  assert.equal(result.completed, true, summary(result));
  assert.equal(result.agents.length, 3);
  for (const a of result.agents) assert.equal(a.status, 'ok', summary(result));
  assert.equal(result.wrong_drops, 0);
});

test('the example agent plays with two built-in teammates, in the message language', { timeout: 90000 }, async () => {
  const replay = path.join(await mkdtemp(path.join(os.tmpdir(), 'bw4t-agent-')), 'replay.jsonl');
  const args = ['--seed', '3', '--robots', '3', '--team', 'builtin', '--agent', agent, '--replay', replay];
  const result = await runMatch(args, { timeoutMs: 80000 });
  assert.equal(result.completed, true, summary(result));
  const mine = result.agents.find((a) => a.kind === 'external');
  assert.equal(mine?.status, 'ok', summary(result));
  assert.equal(result.wrong_drops, 0);
  // It takes part: the built-in robots understand its claims and reports, and it theirs.
  const robot = result.per_robot.find((r) => r.name === mine.name);
  assert.ok(robot.good_drops >= 1, summary(result));
  const kinds = new Set();
  for (const line of (await readFile(replay, 'utf8')).split('\n').filter(Boolean)) {
    for (const e of JSON.parse(line).events ?? []) {
      if (e.kind === 'act' && e.robot === robot.id && e.action === 'sendMessage') {
        assert.equal(typeof e.args[1], 'object', `not a message of the language: ${JSON.stringify(e.args)}`);
        kinds.add(e.args[1].kind);
      }
    }
  }
  for (const kind of ['going_to', 'contains_many', 'getting_for', 'bringing']) assert.ok(kinds.has(kind), [...kinds].join());
});
