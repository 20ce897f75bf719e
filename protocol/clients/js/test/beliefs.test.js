// The belief base on its own: the rules of protocol/README.md, and a captured transcript.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { Beliefs } from '../index.js';
import { REPO } from './helpers.js';

test('a full snapshot clears what was held', () => {
  const b = new Beliefs();
  b.apply({ tick: 0, add: [['in', 'RoomA1'], ['at', 'RoomA1']], not: [], full: true });
  b.apply({ tick: 5, add: [['at', 'FrontA1'], ['place', 'FrontA1']], not: [], full: true });
  assert.equal(b.holds('in'), false);
  assert.equal(b.get('at'), 'FrontA1');
  assert.equal(b.size, 2);
  assert.equal(b.tick, 5);
});

test('not is applied before add', () => {
  const b = new Beliefs();
  b.apply({ tick: 0, add: [['atBlock', 11]], not: [], full: true });
  b.apply({ tick: 1, add: [['atBlock', 11]], not: [['atBlock', 11]] });
  assert.ok(b.holds('atBlock', 11));
  b.apply({ tick: 2, add: [], not: [['atBlock', 11]] });
  assert.ok(!b.holds('atBlock'));
});

test('at, state and sequenceIndex are single-valued', () => {
  const b = new Beliefs();
  b.apply({ tick: 0, add: [['at', 'FrontDropZone'], ['state', 'arrived'], ['sequenceIndex', 0]], not: [], full: true });
  b.apply({ tick: 1, add: [['state', 'traveling'], ['at', 'LeftHallD']], not: [] });
  b.apply({ tick: 2, add: [['sequenceIndex', 1]], not: [] });
  assert.deepEqual(b.all('at'), [['LeftHallD']]);
  assert.deepEqual(b.all('state'), [['traveling']]);
  assert.equal(b.get('sequenceIndex'), 1);
  assert.equal(b.size, 3);
});

test('other facts are sets; message facts are events, not stored', () => {
  const b = new Beliefs();
  const messages = b.apply({
    tick: 0,
    add: [['color', 11, 'Yellow'], ['color', 12, 'Blue'], ['color', 11, 'Yellow'], ['message', 'Bob', 'hi'], ['message', 'Cy', 'yo']],
    not: [],
    full: true,
  });
  assert.deepEqual(messages, [{ from: 'Bob', text: 'hi' }, { from: 'Cy', text: 'yo' }]);
  const said = { kind: 'contains', room: 'RoomB2', colour: 'Red' };
  const heard = b.apply({ tick: 2, add: [['message', 'Ann', 'RoomB2 contains Red.', said]], not: [] });
  assert.deepEqual(heard, [{ from: 'Ann', text: 'RoomB2 contains Red.', said }]);
  assert.deepEqual(b.all('color'), [[11, 'Yellow'], [12, 'Blue']]);
  assert.ok(!b.holds('message'));
  b.apply({ tick: 1, add: [], not: [['color', 11, 'Yellow']] });
  assert.deepEqual(b.all('color'), [[12, 'Blue']]);
});

test('queries: holds (with a prefix of the arguments), all, get', () => {
  const b = new Beliefs();
  b.apply({
    tick: 0,
    add: [['in', 'RoomA1'], ['color', 11, 'Yellow'], ['sequence', ['Yellow', 'Red']], ['bot', 0]],
    not: [],
    full: true,
  });
  assert.ok(b.holds('in', 'RoomA1'));
  assert.ok(!b.holds('in', 'RoomA2'));
  assert.ok(b.holds('color', 11));
  assert.ok(b.holds('color', 11, 'Yellow'));
  assert.ok(!b.holds('color', 11, 'Red'));
  assert.ok(b.holds('sequence', ['Yellow', 'Red']));
  assert.equal(b.get('bot'), 0);
  assert.deepEqual(b.get('sequence'), ['Yellow', 'Red']);
  assert.deepEqual(b.get('color'), [11, 'Yellow']);
  assert.equal(b.get('holding'), undefined);
  assert.deepEqual(b.all('holding'), []);
});

test('clone, equals and diff', () => {
  const b = new Beliefs();
  b.apply({ tick: 3, add: [['in', 'RoomA1'], ['at', 'RoomA1']], not: [], full: true });
  const c = b.clone();
  assert.ok(c.equals(b));
  assert.equal(c.tick, 3);
  c.apply({ tick: 4, add: [['at', 'FrontA1']], not: [['in', 'RoomA1']] });
  assert.ok(!c.equals(b));
  assert.deepEqual(c.diff(b), { extra: [['at', 'FrontA1']], missing: [['at', 'RoomA1'], ['in', 'RoomA1']] });
  assert.ok(b.holds('in', 'RoomA1'), 'the original is unchanged');
});

test('the colour of a block is remembered after its color fact goes, until clear()', () => {
  const b = new Beliefs();
  b.apply({ tick: 0, add: [['in', 'RoomA1'], ['color', 11, 'Yellow'], ['color', 12, 'Blue']], not: [], full: true });
  // Picked up: the block is no longer seen in the room, but it is held.
  b.apply({ tick: 1, add: [['holding', 11]], not: [['color', 11, 'Yellow']] });
  assert.ok(!b.holds('color', 11));
  assert.equal(b.colourOf(11), 'Yellow');
  // A full snapshot (a resync) elsewhere: the colours are still the match's.
  b.apply({ tick: 2, add: [['in', 'RoomB1'], ['color', 20, 'Red']], not: [], full: true });
  assert.deepEqual([b.colourOf(11), b.colourOf(12), b.colourOf(20)], ['Yellow', 'Blue', 'Red']);
  assert.equal(b.colourOf(13), undefined, 'never seen');
  assert.equal(b.size, 2, 'remembered colours are not held facts');
  const copy = b.clone();
  b.clear();
  assert.equal(b.colourOf(11), undefined);
  assert.equal(copy.colourOf(11), 'Yellow', 'a clone keeps its own memory');
});

test('replaying examples/fetch-and-deliver.jsonl gives the expected end state', () => {
  const file = path.join(REPO, 'protocol', 'examples', 'fetch-and-deliver.jsonl');
  const b = new Beliefs();
  for (const line of fs.readFileSync(file, 'utf8').split('\n')) {
    if (!line.trim()) continue;
    const entry = JSON.parse(line);
    if (entry.recv?.type === 'percepts') b.apply(entry.recv);
  }
  assert.equal(b.tick, 263);
  assert.equal(b.get('sequenceIndex'), 1);
  assert.equal(b.get('at'), 'DropZone');
  assert.ok(b.holds('in', 'DropZone'));
  assert.ok(b.holds('occupied', 'DropZone'));
  assert.equal(b.get('state'), 'arrived');
  assert.ok(!b.holds('holding'));
  assert.deepEqual(b.all('color'), []);
  assert.equal(b.all('place').length, 28);
  assert.equal(b.get('ownName'), 'Ann');
});
