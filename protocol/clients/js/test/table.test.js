// The client's knowledge of percepts and actions agrees with the protocol's table
// (protocol/schema/table.json, written from the Rust code), and the page uses the client's.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { Client, DURATIVE, EVENTS, SINGLE_VALUED } from '../index.js';
import { CLIENT_DIR, REPO } from './helpers.js';

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

/**
 * The page's modules as the server embeds them: from index.html's module script, every
 * import followed through the server's table of files (crates/bw4t-server/src/http/files.rs),
 * each read from the file it embeds. Returns served path -> {file, source, imports},
 * where imports is a list of {names, from} with `from` a served path.
 */
function pageModules() {
  const src = path.join(REPO, 'crates', 'bw4t-server', 'src', 'http');
  const http = fs.readFileSync(path.join(src, 'files.rs'), 'utf8');
  const embedded = new Map(
    [...http.matchAll(/\(\s*"(\/[^"]*)",\s*\w+,\s*include_str!\("([^"]+)"\),?\s*\)/g)].map((m) => [m[1], path.resolve(src, m[2])]),
  );
  assert.ok(embedded.has('/index.html'), 'files.rs has a table of the page files, index.html in it');
  const html = fs.readFileSync(embedded.get('/index.html'), 'utf8');
  const entries = [...html.matchAll(/<script type="module" src="([^"]+)">/g)].map((m) => new URL(m[1], 'http://page/').pathname);
  assert.ok(entries.length > 0, 'index.html loads the page as a module');
  const modules = new Map();
  const queue = [...entries];
  while (queue.length > 0) {
    const served = queue.shift();
    if (modules.has(served)) continue;
    const file = embedded.get(served);
    assert.ok(file, `${served} is imported by the page but not in files.rs's table`);
    const source = fs.readFileSync(file, 'utf8');
    const imports = [...source.matchAll(/^(?:import|export)\s*(?:\{([^}]*)\}\s*from\s*)?'([^']+)'/gm)].map((m) => ({
      names: (m[1] ?? '').split(',').map((n) => n.trim()).filter(Boolean),
      from: new URL(m[2], `http://page${served}`).pathname,
    }));
    modules.set(served, { file, source, imports });
    queue.push(...imports.map((i) => i.from));
  }
  return modules;
}

test("the page keeps beliefs with this client's files, not a copy", () => {
  const modules = pageModules();
  const own = (name) => path.join(CLIENT_DIR, 'src', name);
  const byFile = new Map([...modules.values()].map((m) => [m.file, m]));
  assert.ok(byFile.has(own('beliefs.js')) && byFile.has(own('table.js')), "the page loads the client's beliefs.js and table.js");
  // So what the tests above check of SINGLE_VALUED, EVENTS and DURATIVE holds for the page.
  const importer = (name, file) =>
    [...modules.values()].find((m) => m.imports.some((i) => i.names.includes(name) && modules.get(i.from)?.file === file));
  const beliefs = importer('Beliefs', own('beliefs.js'));
  assert.ok(beliefs && /new Beliefs\(/.test(beliefs.source), 'a page module keeps its beliefs in a client Beliefs');
  const durative = importer('DURATIVE', own('table.js'));
  assert.ok(durative && /DURATIVE\.has\(/.test(durative.source), "a page module asks the client's DURATIVE which actions last");
  for (const [served, { file, source }] of modules) {
    if (file.startsWith(CLIENT_DIR)) continue;
    const copy = source.match(/\b(?:const|let|var|class|function)\s+(SINGLE_VALUED|EVENTS|DURATIVE|Beliefs)\b/);
    assert.equal(copy, null, `${served} declares its own ${copy?.[1]}`);
  }
});
