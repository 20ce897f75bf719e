// The example agent completes real matches started by `bw4t run`.

import { test } from 'node:test';
import assert from 'node:assert/strict';
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

test('the example agent plays with two built-in teammates', { timeout: 90000 }, async () => {
  const result = await runMatch(['--seed', '3', '--robots', '3', '--team', 'builtin', '--agent', agent], { timeoutMs: 80000 });
  assert.equal(result.completed, true, summary(result));
  const mine = result.agents.find((a) => a.kind === 'external');
  assert.equal(mine?.status, 'ok', summary(result));
});
