// The lobby of a server of many matches (`bw4t serve --config FILE`): it lists the
// matches with their players and ticks, Watch opens one match's overview on its own map,
// the operator stops and makes matches, and players join a template's match and a named
// match from it, wait in the waiting panel, then play.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { test } from 'node:test';

import { openBrowser, screenshot, startBw4t, stop, tempDir, text, waitForNumber } from './helpers.js';

// A small map of its own, so that watching a match shows that match's map, not the default's.
const SMALL_MAP = `
version = 1
name = "small-pair"
area = [40, 30]
sequence = ["Red", "Blue"]

[[spawn]]
name = "West"
at = [8, 15]

[[spawn]]
name = "East"
at = [32, 15]

[[spawn]]
name = "Middle"
at = [20, 15]

[[zone]]
name = "Hall"
type = "corridor"
centre = [20, 15]
size = [40, 10]
neighbours = ["RoomA", "RoomB", "DropZone"]

[[zone]]
name = "RoomA"
type = "room"
centre = [8, 5]
size = [10, 10]
doors = [[8, 10]]
blocks = ["Red", "Blue"]

[[zone]]
name = "RoomB"
type = "room"
centre = [32, 5]
size = [10, 10]
doors = [[32, 10]]
blocks = ["Blue", "Red"]

[[zone]]
name = "DropZone"
type = "room"
centre = [20, 25]
size = [12, 10]
doors = [[20, 20]]
`;

/** Writes the small map and a server configuration (`templates`: TOML text using
 * SMALL_MAP_FILE for the small map's path) into a fresh folder; returns the config's path. */
function writeConfig(t, templates) {
  const dir = tempDir('lobby');
  t.after(() => fs.rmSync(dir, { recursive: true, force: true }));
  const mapFile = path.join(dir, 'small-pair.toml');
  fs.writeFileSync(mapFile, SMALL_MAP);
  const configFile = path.join(dir, 'arena.toml');
  fs.writeFileSync(configFile, templates.replaceAll('SMALL_MAP_FILE', JSON.stringify(mapFile)));
  return configFile;
}

/** The lobby's row of a match (a live one unless `state` says otherwise). */
const row = (name, state = null) =>
  state ? `#matches tbody tr[data-name="${name}"][data-state="${state}"]` : `#matches tbody tr[data-name="${name}"]:not([data-state="finished"])`;

/** Waits (bounded) until the lobby shows `name`'s tick above `above`; resolves with it. */
async function lobbyTick(page, name, above, timeout = 20_000) {
  const handle = await page.waitForFunction(
    ([selector, more]) => {
      const tr = document.querySelector(selector);
      const tick = tr ? Number(tr.dataset.tick) : NaN;
      return tick > more ? { tick } : false;
    },
    [row(name), above],
    { timeout, polling: 100 },
  );
  return (await handle.jsonValue()).tick;
}

test('the lobby lists the matches, and Watch spectates one on its own map', { timeout: 120_000 }, async (t) => {
  const config = writeConfig(
    t,
    `
[[template]]
name = "classroom"
map = "fixed"
robots = 2
builtin = 2
names = ["team-a"]

[[template]]
name = "small"
map = SMALL_MAP_FILE
robots = 3
builtin = 3
names = ["team-b"]

[[template]]
name = "ladder"
map = "fixed"
robots = 2
builtin = 1
`,
  );
  const server = await startBw4t(['serve', '--config', config, '--http', '0', '--port', '0']);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;

  try {
    await page.goto(server.url);
    await page.waitForSelector('#lobby:not([hidden])');
    await page.waitForSelector('#status[data-status="lobby"]');
    assert.equal(await page.isVisible('#map'), false, 'the lobby shows no map');

    // Both named matches are listed, playing, with their players and a tick that goes up.
    await page.waitForSelector(row('team-a'));
    await page.waitForSelector(row('team-b'));
    const teamA = page.locator(row('team-a'));
    assert.equal(await teamA.getAttribute('data-template'), 'classroom');
    assert.equal(await teamA.getAttribute('data-map'), 'fixed');
    assert.equal((await teamA.getAttribute('data-players')).split(',').length, 2);
    assert.equal((await page.locator(row('team-b')).getAttribute('data-players')).split(',').length, 3);
    const first = await lobbyTick(page, 'team-b', 0);
    await lobbyTick(page, 'team-b', first);
    assert.equal(await page.locator(row('team-b')).getAttribute('data-state'), 'playing');
    assert.match(await text(page, `${row('team-b')} td.progress`), /^\d+\/2$/);
    assert.equal(await page.locator(`${row('team-a')} a.watch`).count(), 1);
    assert.equal(await page.locator(`${row('team-a')} button.play:disabled`).count(), 1, 'every seat is taken');
    assert.equal(await page.locator('#matches button.stop').count(), 0, 'no Stop without the operator token');
    // The template that makes matches on demand is offered to play.
    assert.equal(await page.locator('#templates li[data-template="ladder"] button.play').count(), 1);
    // Playing needs a name: the lobby says so instead of leaving.
    await page.click('#templates li[data-template="ladder"] button.play');
    await page.waitForSelector('#lobby-name-error:not([hidden])');
    assert.equal(new URL(page.url()).search, '');
    await screenshot(page, 'lobby-list');

    // Watch team-b: its overview, on its own map, with its frames.
    await page.click(`${row('team-b')} a.watch`);
    await page.waitForURL((url) => url.searchParams.get('match') === 'team-b');
    await page.waitForSelector('#status[data-status="connected"]');
    assert.equal(await text(page, '#map-name'), 'small-pair');
    assert.match(await text(page, '#match-name'), /^team-b/);
    assert.equal(await page.getAttribute('#map', 'data-bounds'), '-0.5 -0.5 41 31');
    await waitForNumber(page, '#tick', { above: 0 });
    await page.waitForFunction(() => Number(document.querySelector('#map').dataset.frames) > 5);
    await waitForNumber(page, '#robots', { equals: 3 });
    assert.equal(await page.isVisible('#lobby-link'), true, 'the way back to the lobby');
    assert.equal(await page.isVisible('#waiting'), false);
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'lobby-watch');
  }
});

test('the operator stops a match and makes one from the lobby', { timeout: 120_000 }, async (t) => {
  const config = writeConfig(
    t,
    `
[[template]]
name = "classroom"
map = "fixed"
robots = 2
builtin = 2
names = ["team-a", "team-b"]
`,
  );
  const server = await startBw4t([
    'serve', '--config', config, '--http', '0', '--port', '0', '--operator-token', 'op-secret',
  ]);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;

  try {
    await page.goto(server.url);
    await page.waitForSelector(row('team-a'));
    assert.equal(await page.isVisible('#new-match'), false, 'no form without the token');
    assert.equal(await page.isVisible('#matches th.operator-only'), false, 'no seeds without the token');

    // A wrong token: the API says why, as text.
    await page.fill('#operator-token', 'wrong');
    await page.click('#operator-use');
    await page.waitForSelector(`${row('team-a')} button.stop`);
    await page.click(`${row('team-a')} button.stop`);
    await page.waitForFunction(() => /could not stop team-a: .+/.test(document.querySelector('#api-error').textContent));
    assert.equal(await page.isVisible('#api-error'), true);
    assert.ok(await page.locator(row('team-a')).count(), 'team-a still plays');

    // The right token: seeds show, Stop ends team-a, and the lobby shows it finished.
    await page.fill('#operator-token', 'op-secret');
    await page.click('#operator-use');
    await page.waitForFunction((selector) => document.querySelector(selector)?.dataset.seed !== '', row('team-a'));
    assert.equal(await page.isVisible('#matches th.operator-only'), true);
    assert.match(await text(page, `${row('team-a')} td.seed`), /^\d+$/);
    assert.equal(await page.isVisible('#api-error'), false);
    await page.click(`${row('team-a')} button.stop`);
    await page.waitForSelector(row('team-a', 'finished'));
    assert.equal(await page.getAttribute(row('team-a', 'finished'), 'data-end-reason'), 'interrupted');
    assert.match(await text(page, `${row('team-a', 'finished')} td.state`), /finished: interrupted/);
    assert.equal(await page.locator(`${row('team-a', 'finished')} a.watch`).count(), 0, 'nothing to watch');
    assert.equal(await page.locator(row('team-a')).count(), 0);
    assert.ok(await page.locator(row('team-b')).count(), 'team-b plays on');

    // A new match from the form, and a refused one with the server's reason.
    await page.fill('#new-name', 'extra');
    await page.fill('#new-map', 'fixed');
    await page.fill('#new-robots', '1');
    await page.fill('#new-builtin', '1');
    await page.selectOption('#new-mode', 'realtime');
    await page.click('#new-create');
    await page.waitForSelector(row('extra'));
    assert.match(await text(page, '#api-note'), /created extra/);
    await lobbyTick(page, 'extra', 0);
    await page.click('#new-create'); // the same name again, while it is live
    await page.waitForFunction(() => /could not create the match: .+/.test(document.querySelector('#api-error').textContent));
    assert.equal(await page.isVisible('#api-error'), true);

    // The token is kept for this tab: after a reload the operator's parts are still there.
    await page.reload();
    await page.waitForSelector(`${row('extra')} button.stop`);
    assert.equal(await page.inputValue('#operator-token'), 'op-secret');
    assert.deepEqual(browser.errors.filter((e) => !/status of (401|409|400)/.test(e)), []);
  } finally {
    await screenshot(page, 'lobby-operator');
  }
});

test('players join a template and a named match from the lobby, wait, then play', { timeout: 120_000 }, async (t) => {
  // Three robots, one built-in: a match of it waits for two people.
  const config = writeConfig(
    t,
    `
[[template]]
name = "trio"
map = SMALL_MAP_FILE
robots = 3
builtin = 1
start_timeout_s = 600
`,
  );
  const server = await startBw4t(['serve', '--config', config, '--http', '0', '--port', '0']);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page: ann, context } = browser;
  const bea = await context.newPage();
  const watcher = await context.newPage();

  try {
    // Ann plays the template: the server makes a match, which waits for one more player.
    await ann.goto(server.url);
    await ann.waitForSelector('#templates li[data-template="trio"]');
    await ann.fill('#lobby-name', 'Ann');
    await ann.click('#templates li[data-template="trio"] button.play');
    await ann.waitForSelector('#status[data-status="connected"]');
    await ann.waitForSelector('#waiting[data-state="waiting"]:not([hidden])');
    const match = new URL(ann.url()).searchParams.get('match');
    assert.ok(match, `the address names the match now: ${ann.url()}`);
    assert.match(await text(ann, '#match-name'), new RegExp(`^${match}`));
    await ann.waitForSelector('#waiting-players li[data-name="Ann"]');
    assert.equal(await ann.locator('#waiting-players li').count(), 2, 'Ann and the built-in player');
    assert.equal(await ann.getAttribute('#waiting-awaited', 'data-awaited'), '1');
    const seconds = Number(await ann.getAttribute('#waiting-countdown', 'data-seconds'));
    assert.ok(seconds > 500 && seconds <= 600, `starts in ${seconds} s`);
    assert.equal(await ann.isVisible('#tick'), false, 'no running clock while waiting');
    assert.equal(await ann.isVisible('#waiting-short'), true);
    assert.equal(await text(ann, '#map-name'), 'small-pair', "the match's map, known from welcome");
    // The robot's first view (tick 0) is shown, and the panel stays until the match starts.
    await ann.waitForFunction(() => document.querySelector('#at').textContent.trim() !== '–');
    assert.equal(await ann.isVisible('#waiting'), true);
    await screenshot(ann, 'lobby-waiting');

    // A spectator of the waiting match sees the same panel.
    await watcher.goto(`${server.url}?match=${match}`);
    await watcher.waitForSelector('#waiting[data-state="waiting"]:not([hidden])');
    await watcher.waitForSelector('#waiting-players li[data-name="Ann"]');

    // Bea finds the match in the lobby, waiting, with Ann in it, and plays in it by name.
    await bea.goto(server.url);
    await bea.waitForSelector(row(match, 'waiting'));
    assert.ok((await bea.getAttribute(row(match), 'data-players')).split(',').includes('Ann'));
    assert.equal(await bea.getAttribute(row(match), 'data-awaited'), '1');
    await bea.fill('#lobby-name', 'Bea');
    await bea.click(`${row(match)} button.play`);
    await bea.waitForURL((url) => url.searchParams.get('match') === match && url.searchParams.get('play') === 'Bea');

    // The match starts: both players' panels give way to the game, and so does the overview's.
    for (const player of [ann, bea]) {
      await player.waitForSelector('#waiting', { state: 'hidden' });
      await player.waitForFunction(() => document.querySelector('#at').textContent.trim() !== '–');
      await waitForNumber(player, '#tick', { above: 0 });
      assert.equal(await player.isVisible('#tick'), true);
    }
    await watcher.waitForSelector('#waiting', { state: 'hidden' });
    await watcher.waitForFunction(() => Number(document.querySelector('#map').dataset.frames) > 0);
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(ann, 'lobby-player-ann');
    await screenshot(bea, 'lobby-player-bea');
  }
});

test('a player queued for a full template waits for its place, then plays', { timeout: 120_000 }, async (t) => {
  // One match at a time, of one person and one built-in player.
  const config = writeConfig(
    t,
    `
operator_token = "op-secret"

[[template]]
name = "solo"
map = SMALL_MAP_FILE
robots = 2
builtin = 1
max_running = 1
`,
  );
  const server = await startBw4t(['serve', '--config', config, '--http', '0', '--port', '0']);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page: ann, context } = browser;
  const bea = await context.newPage();

  try {
    // Ann's match starts at once: she and the built-in player fill it.
    await ann.goto(`${server.url}?template=solo&play=Ann`);
    await ann.waitForFunction(() => document.querySelector('#at').textContent.trim() !== '–');
    const first = new URL(ann.url()).searchParams.get('match');
    assert.ok(first);

    // Bea asks for the same template: no seat and no room for another match, so she queues.
    await bea.goto(`${server.url}?template=solo&play=Bea`);
    await bea.waitForSelector('#waiting[data-state="queued"][data-queued="1"]:not([hidden])');
    assert.match(await text(bea, '#waiting-title'), /queue/);
    assert.match(await text(bea, '#waiting-awaited'), /next/);
    assert.equal(await bea.getAttribute('#status', 'data-status'), 'joining', 'no welcome yet');
    await screenshot(bea, 'lobby-queued');

    // Ann's match is stopped: the template makes the next, and Bea gets its seat.
    const stopped = await fetch(`${server.url}api/matches/${first}/stop`, {
      method: 'POST',
      headers: { Authorization: 'Bearer op-secret' },
    });
    assert.equal(stopped.status, 200);
    await ann.waitForSelector('#status[data-status="ended"]');
    await bea.waitForSelector('#status[data-status="connected"]');
    await bea.waitForFunction(() => document.querySelector('#at').textContent.trim() !== '–');
    assert.equal(await bea.isVisible('#waiting'), false);
    const second = new URL(bea.url()).searchParams.get('match');
    assert.ok(second && second !== first, `Bea plays in ${second}, not ${first}`);
    assert.equal(await text(bea, '#map-name'), 'small-pair');
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(bea, 'lobby-queued-bea');
  }
});
