// The client's and the page's knowledge of percepts and actions agrees with the protocol's
// table (protocol/schema/table.json, written from the Rust code).

import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { Client, DURATIVE, EVENTS, SINGLE_VALUED } from '../index.js';
import { REPO } from './helpers.js';

const TABLE = JSON.parse(fs.readFileSync(path.join(REPO, 'protocol', 'schema', 'table.json'), 'utf8'));
const names = (rows, where) =>
  new Set(rows.filter((r) => Object.entries(where).every(([k, v]) => r[k] === v)).map((r) => r.name));

test('single-valued facts are the percepts sent on change', () => {
  assert.deepEqual(SINGLE_VALUED, names(TABLE.percepts, { send: 'on_change' }));
});

test('event facts are the percepts sent as events', () => {
  assert.deepEqual(EVENTS, names(TABLE.percepts, { send: 'event' }));
});

test('durative actions are those the table marks, and every action has a method', () => {
  assert.deepEqual(DURATIVE, names(TABLE.actions, { durative: true }));
  for (const { name } of TABLE.actions) {
    assert.equal(typeof Client.prototype[name], 'function', `Client.${name}()`);
  }
});

test("the page's single-valued facts and durative actions are the table's", () => {
  // The page has no build step and no imports from the client yet: read its source.
  const page = fs.readFileSync(path.join(REPO, 'crates', 'bw4t-server', 'web', 'app.js'), 'utf8');
  const single = page.match(/const SINGLE_VALUED = new Set\(\[([^\]]*)\]\)/);
  assert.ok(single, 'app.js declares SINGLE_VALUED');
  const listed = new Set([...single[1].matchAll(/'([^']+)'/g)].map((m) => m[1]));
  assert.deepEqual(listed, names(TABLE.percepts, { send: 'on_change' }));
  const durative = page.match(/durative: (action === '[^']+'(?: \|\| action === '[^']+')*)/);
  assert.ok(durative, 'app.js says which actions are durative');
  const actions = new Set([...durative[1].matchAll(/'([^']+)'/g)].map((m) => m[1]));
  assert.deepEqual(actions, names(TABLE.actions, { durative: true }));
});
