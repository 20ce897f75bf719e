// A person plays from the page: joins with the form, drives the robot with clicks and keys,
// fetches a block of the needed colour and delivers it, beside a built-in agent, in the one
// match of `bw4t serve --once` (the page at / shows it; no lobby). And alone in a lockstep
// match that waits every tick for the page's `ready`.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { test } from 'node:test';

import { number, openBrowser, screenshot, sleep, startBw4t, stop, tempDir, text, waitForNumber } from './helpers.js';

// Two rooms above one hall, the drop zone below it. Each room holds one Red block and the
// sequence is Red, Red. Spawn points are taken in order, the built-in agent's seat first:
// it starts under RoomA, the first room it explores; the human starts under RoomB, the
// room nearest to it, so its block cannot be taken before it gets there.
const MAP = `
version = 1
name = "two-reds"
area = [40, 30]
sequence = ["Red", "Red"]

[[spawn]]
name = "Builtin"
at = [8, 15]

[[spawn]]
name = "Human"
at = [32, 15]

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
blocks = ["Red"]

[[zone]]
name = "RoomB"
type = "room"
centre = [32, 5]
size = [10, 10]
doors = [[32, 10]]
blocks = ["Red"]

[[zone]]
name = "DropZone"
type = "room"
centre = [20, 25]
size = [12, 10]
doors = [[20, 20]]
`;

/** Waits until the newest log entry for `action` is a result or a rejection; returns it. */
async function outcome(page, action, timeout) {
  const handle = await page.waitForFunction(
    (name) => {
      const entries = [...document.querySelectorAll(`#log li[data-action="${name}"]`)];
      const last = entries[entries.length - 1];
      if (!last || !['result', 'reject'].includes(last.dataset.kind)) return false;
      return { kind: last.dataset.kind, outcome: last.dataset.outcome || last.dataset.code };
    },
    action,
    { timeout, polling: 100 },
  );
  return handle.jsonValue();
}

test('a human joins from the page and delivers a block beside a built-in agent', { timeout: 180_000 }, async (t) => {
  const dir = tempDir('player');
  t.after(() => fs.rmSync(dir, { recursive: true, force: true }));
  const mapFile = path.join(dir, 'two-reds.toml');
  fs.writeFileSync(mapFile, MAP);
  const server = await startBw4t([
    'serve', '--once', '--http', '0', '--port', '0', '--map', mapFile, '--builtin', '1', '--robots', '2',
    '--mode', 'realtime', '--seed', '1', '--max-ticks', '4000',
  ]);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;

  try {
    await page.goto(server.url);
    await page.waitForSelector('#status[data-status="connected"]');

    // Join with the form.
    await page.fill('#join-name', 'Hugo');
    await page.click('#join-button');
    await page.waitForSelector('#status[data-status="connected"]');
    await page.waitForFunction(() => document.querySelector('#at').textContent.trim() === 'Hall');
    assert.equal(await text(page, '#holding'), 'nothing');
    assert.equal(await text(page, '#sequence-index'), '0');
    // What the robot knows, in the server's words (`percepts.words`): who and where it is.
    await page.waitForFunction(() => /^I am Hugo \(robot 1\), at Hall, not in a room\./.test(document.querySelector('#words').textContent));
    assert.equal(await page.isVisible('#words-box'), true);
    assert.equal(await text(page, '#words-title'), 'What I know');
    assert.equal(await page.isVisible('#robots-box'), false, 'a player does not see the other robots');
    assert.equal(await page.isVisible('#join-form'), false);
    // The built-in agent is a player it can talk to: a message to it is accepted and shown.
    await page.waitForSelector('#chat-to option[value="Bot1"]', { state: 'attached' });
    await page.selectOption('#chat-to', 'Bot1');
    await page.fill('#chat-text', 'hello from the page');
    await page.click('#chat-send');
    await page.waitForSelector('#log li[data-kind="ok"][data-action="say"]', { state: 'attached' });
    assert.match(await text(page, '#messages'), /hello from the page/);

    // A rejected action is reported with its reason: nothing is held yet (key D).
    await page.keyboard.press('d');
    await page.waitForSelector('#log li[data-kind="reject"][data-action="putDown"][data-code="not_holding"]', {
      state: 'attached',
    });
    assert.match(await text(page, '#log'), /putDown: rejected, not_holding/);

    // Click RoomB on the map (canvas hit-testing): its centre is (32, 5) in map units; the
    // canvas says which box of the map it shows.
    const box = await page.locator('#map').boundingBox();
    const [bx, by, bw] = (await page.getAttribute('#map', 'data-bounds')).split(' ').map(Number);
    const scale = box.width / bw;
    await page.mouse.click(box.x + (32 - bx) * scale, box.y + (5 - by) * scale);
    await page.waitForFunction(() => document.querySelector('#in').textContent.trim() === 'RoomB', null, { timeout: 30_000 });
    // The words follow each percepts: inside RoomB, seeing its Red block.
    await page.waitForFunction(() => {
      const words = document.querySelector('#words').textContent;
      return /^I am Hugo \(robot 1\), in RoomB[.,]/.test(words) && /\nHere I see block \d+ \(Red\)/.test(words);
    });

    // The Red block shows as a chip: click it to go to it, then pick it up with the key.
    const chip = page.locator('#blocks [data-block-id][data-color="Red"]');
    await chip.waitFor();
    const blockId = await chip.getAttribute('data-block-id');
    await chip.click();
    assert.deepEqual(await outcome(page, 'goToBlock', 20_000), { kind: 'result', outcome: 'arrived' });
    await page.keyboard.press('p');
    await page.waitForSelector(`#holding[data-block-id="${blockId}"][data-color="Red"]`);
    await page.waitForFunction(() => document.querySelectorAll('#blocks [data-block-id]').length === 0);

    // To the drop zone through the list of places (no coordinates). The built-in robot may
    // be in there (the room's door is closed then): wait and try again.
    let arrived = false;
    for (let attempt = 0; attempt < 8 && !arrived; attempt++) {
      await page.locator('[data-place="DropZone"]').dispatchEvent('click');
      const got = await outcome(page, 'goTo', 40_000);
      arrived = got.kind === 'result' && got.outcome === 'arrived';
      if (!arrived) await sleep(1000);
    }
    assert.ok(arrived, 'reached the drop zone');
    assert.equal(await text(page, '#at'), 'DropZone');
    assert.equal(await text(page, '#in'), 'DropZone');

    // Put it down with the button: the sequence advances and the hand is empty.
    const before = await number(page, '#sequence-index');
    await page.click('#putdown');
    await page.waitForSelector('#holding[data-block-id=""]');
    assert.equal(await text(page, '#holding'), 'nothing');
    const after = await waitForNumber(page, '#sequence-index', { above: before });
    assert.ok(after > before);
    await page.waitForSelector('#log li[data-kind="ok"][data-action="putDown"]', { state: 'attached' });

    // With the built-in agent's Red, the sequence is complete: the match ends.
    await page.waitForSelector('#status[data-status="ended"]', { timeout: 90_000 });
    assert.equal(await text(page, '#sequence-index'), '2');
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'player');
  }
});

test('in a lockstep match the page answers every tick with one ready', { timeout: 120_000 }, async (t) => {
  const dir = tempDir('player-lockstep');
  t.after(() => fs.rmSync(dir, { recursive: true, force: true }));
  const mapFile = path.join(dir, 'two-reds.toml');
  fs.writeFileSync(mapFile, MAP);
  // Every tick waits for the player's ready, for ever: the clock moves only as the page answers.
  const server = await startBw4t([
    'serve', '--once', '--http', '0', '--port', '0', '--map', mapFile, '--robots', '1',
    '--mode', 'lockstep', '--deadline-ms', '0', '--every-tick', '--seed', '1', '--max-ticks', '100000',
  ]);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;

  try {
    await page.goto(server.url);
    await page.waitForSelector('#status[data-status="connected"]');
    await page.fill('#join-name', 'Lena');
    await page.click('#join-button');
    await page.waitForFunction(() => document.querySelector('#at').textContent.trim() === 'Hall');
    await waitForNumber(page, '#tick', { above: 20 });

    // An order is carried out over the ticks the page answers.
    await page.locator('[data-place="RoomA"]').dispatchEvent('click');
    assert.deepEqual(await outcome(page, 'goTo', 30_000), { kind: 'result', outcome: 'arrived' });
    assert.equal(await text(page, '#in'), 'RoomA');
    // No ready was late, early or missing: the server reported no error.
    assert.equal(await page.locator('#log li[data-kind="error"]').count(), 0, await text(page, '#log'));
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'player-lockstep');
  }
});
