// The replay viewer: record a match with `bw4t run --replay`, serve it with
// `bw4t replay view FILE --http 0`, then seek, play and pause on the page.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { test } from 'node:test';

import {
  ROOT,
  canvasPicture,
  number,
  openBrowser,
  runBw4t,
  screenshot,
  sleep,
  startBw4t,
  stop,
  tempDir,
  text,
  waitForNumber,
} from './helpers.js';

test('the replay viewer seeks, plays and pauses', { timeout: 180_000 }, async (t) => {
  const dir = tempDir('replay');
  t.after(() => fs.rmSync(dir, { recursive: true, force: true }));
  const file = path.join(dir, 'match.jsonl');
  await runBw4t(['run', '--map', 'fixed', '--seed', '3', '--replay', file]);
  const server = await startBw4t(['replay', 'view', file, '--http', '0']);
  t.after(() => stop(server.proc));
  const info = await (await fetch(new URL('replay.json', server.url))).json();
  assert.ok(info.ticks > 100, `a replay of ${info.ticks} ticks`);

  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;
  try {
    await page.goto(server.url);
    await page.waitForSelector('#status[data-status="replay"]');
    assert.equal(await page.isVisible('#join-form'), false, 'no joining a replay');
    assert.equal(await page.getAttribute('#scrub', 'max'), String(info.ticks));
    await waitForNumber(page, '#tick', { equals: 0 });
    await waitForNumber(page, '#robots', { equals: 3 });
    const atStart = await canvasPicture(page);

    // Set the slider to a tick: that tick's frame is shown, and the picture changed.
    const middle = Math.floor(info.ticks / 2);
    await page.locator('#scrub').fill(String(middle));
    await waitForNumber(page, '#tick', { equals: middle });
    const atMiddle = await canvasPicture(page);
    assert.notEqual(atMiddle, atStart, 'the picture changed');
    // The page shows the server's frame of that tick.
    const frame = await (await fetch(new URL(`replay/frame/${middle}`, server.url))).json();
    assert.equal(await number(page, '#sequence-index'), frame.sequence_index);
    assert.equal(await number(page, '#robots'), frame.robots.length);

    // Drag the slider with the mouse to about three quarters.
    const slider = await page.locator('#scrub').boundingBox();
    const y = slider.y + slider.height / 2;
    await page.mouse.move(slider.x + slider.width / 2, y);
    await page.mouse.down();
    await page.mouse.move(slider.x + slider.width * 0.75, y, { steps: 8 });
    await page.mouse.up();
    const dragged = Number(await page.inputValue('#scrub'));
    assert.ok(dragged > middle + info.ticks * 0.1, `the slider moved to ${dragged}`);
    await waitForNumber(page, '#tick', { equals: dragged });
    assert.notEqual(await canvasPicture(page), atMiddle);

    // Back to the middle, then play: the tick advances.
    await page.locator('#scrub').fill(String(middle));
    await waitForNumber(page, '#tick', { equals: middle });
    await page.click('#play');
    assert.equal(await page.isDisabled('#play'), true);
    const playing = await waitForNumber(page, '#tick', { above: middle + 5 });
    // Pause: it stays put.
    await page.click('#pause');
    const paused = await number(page, '#tick');
    assert.ok(paused >= playing);
    await sleep(600);
    assert.equal(await number(page, '#tick'), paused, 'paused stays put');
    assert.equal(await page.inputValue('#scrub'), String(paused), 'the slider follows playback');

    // Faster: at 8x a second of playback covers many more ticks than at 1x.
    await page.selectOption('#speed', '8');
    await page.click('#play');
    const fastFrom = await number(page, '#tick');
    await sleep(1000);
    await page.click('#pause');
    const fastTicks = (await number(page, '#tick')) - fastFrom;
    assert.ok(fastTicks > 50 || (await number(page, '#tick')) === info.ticks, `8x moved ${fastTicks} ticks in 1 s`);

    // To the end: playback stops there.
    await page.locator('#scrub').fill(String(info.ticks - 10));
    await waitForNumber(page, '#tick', { equals: info.ticks - 10 });
    await page.click('#play');
    await waitForNumber(page, '#tick', { equals: info.ticks }, 15_000);
    await page.waitForSelector('#play:not([disabled])');
    assert.match(await text(page, '#replay-position'), new RegExp(`^${info.ticks} / ${info.ticks}$`));
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'replay');
  }
});

const LANGUAGE = JSON.parse(fs.readFileSync(path.join(ROOT, 'protocol', 'schema', 'language.json'), 'utf8'));

/** What the page shows for a message's text: a message of the language (an object, or its
 * JSON text form) as its sentence, with positions counted from 1; other text as it is. */
function shownText(text) {
  let said = text;
  if (typeof text === 'string') {
    if (!text.startsWith('{')) return text;
    said = JSON.parse(text);
  }
  const row = LANGUAGE.kinds.find((k) => k.kind === said.kind);
  return row.slots.reduce((sentence, slot) => sentence.replace(`{${slot}}`, slot === 'position' ? said[slot] + 1 : said[slot]), row.sentence);
}

/** The messages a replay file records as sent ({tick, from, to, text}), in order. */
function messagesInReplay(file) {
  const names = new Map();
  const sent = [];
  for (const line of fs.readFileSync(file, 'utf8').split('\n')) {
    if (!line.trim()) continue;
    const record = JSON.parse(line);
    if (record.type !== 'tick') continue;
    for (const event of record.events) {
      if (event.kind === 'join') names.set(event.robot, event.name);
      if (event.kind === 'act' && event.action === 'sendMessage' && event.ok) {
        sent.push({ tick: record.tick, from: names.get(event.robot), to: event.args[0], text: shownText(event.args[1]) });
      }
    }
  }
  return sent;
}

/** The tick on screen and the message list, read together. */
function shownMessages(page) {
  return page.evaluate(() => ({
    tick: Number(document.querySelector('#tick').textContent.trim()),
    list: [...document.querySelectorAll('#messages li')].map((li) => ({
      tick: Number(li.querySelector('.when').textContent),
      from: li.dataset.from,
      to: li.dataset.to,
      text: li.lastChild.textContent,
    })),
  }));
}

test('the replay message list holds every message sent up to the tick shown', { timeout: 180_000 }, async (t) => {
  const dir = tempDir('replay-messages');
  t.after(() => fs.rmSync(dir, { recursive: true, force: true }));
  const file = path.join(dir, 'match.jsonl');
  // The cooperative team announces what it does: many messages.
  await runBw4t(['run', '--map', 'fixed', '--seed', '3', '--replay', file]);
  const sent = messagesInReplay(file);
  assert.ok(sent.length >= 20, `${sent.length} messages in the replay`);
  const server = await startBw4t(['replay', 'view', file, '--http', '0']);
  t.after(() => stop(server.proc));
  const info = await (await fetch(new URL('replay.json', server.url))).json();
  const LOG_LIMIT = 300; // the page keeps the newest 300 entries of a list

  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;
  const expectListAt = async (what) => {
    const shown = await shownMessages(page);
    const expected = sent.filter((m) => m.tick <= shown.tick).slice(-LOG_LIMIT);
    assert.deepEqual(shown.list, expected, `${what}: the list at tick ${shown.tick}`);
    return shown;
  };
  try {
    await page.goto(new URL('?speed=8', server.url).href);
    await page.waitForSelector('#status[data-status="replay"]');
    await waitForNumber(page, '#tick', { equals: 0 });
    await expectListAt('at the start');

    // Play at 8x past a good part of the messages (frames are fetched and shown sparsely).
    assert.equal(await page.inputValue('#speed'), '8');
    await page.click('#play');
    await waitForNumber(page, '#tick', { above: sent[Math.floor(sent.length / 2)].tick }, 30_000);
    await page.click('#pause');
    const played = await expectListAt('played at 8x');
    assert.ok(played.list.length > sent.length / 2, `${played.list.length} messages listed`);

    // Seek forwards, then back: the list is that of the tick sought.
    for (const [what, tick] of [
      ['sought forwards', sent[sent.length - 3].tick + 1],
      ['sought back', sent[4].tick],
      ['sought to the start', 0],
    ]) {
      await page.locator('#scrub').fill(String(tick));
      await waitForNumber(page, '#tick', { equals: tick });
      await expectListAt(what);
    }

    // From a tick in the middle at 8x to the end: every message.
    await page.locator('#scrub').fill(String(sent[10].tick - 1));
    await waitForNumber(page, '#tick', { equals: sent[10].tick - 1 });
    await page.click('#play');
    await waitForNumber(page, '#tick', { equals: info.ticks }, 30_000);
    const end = await expectListAt('played to the end');
    assert.equal(end.list.length, Math.min(sent.length, LOG_LIMIT));
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'replay-messages');
  }
});

/** A robot's own view of a tick, as the server gives it. */
async function viewOf(url, robot, tick) {
  const response = await fetch(new URL(`replay/view/${robot}/${tick}`, url));
  assert.equal(response.status, 200, `the view of robot ${robot} at tick ${tick}`);
  return response.json();
}

const factOf = (view, name) => view.facts.find((f) => f[0] === name)?.slice(1);

/** What the own-view column shows, read at once. */
function shownOwnView(page) {
  return page.evaluate(() => {
    const section = document.querySelector('#ownview');
    return {
      tick: Number(section.dataset.tick),
      at: document.querySelector('#ownview-at').textContent.trim(),
      index: Number(document.querySelector('#ownview-index').dataset.index),
      blocks: [...document.querySelectorAll('#ownview-blocks li')].map((li) => [Number(li.dataset.blockId), li.dataset.color]),
      messages: [...document.querySelectorAll('#ownview-messages li')].map((li) => ({
        from: li.dataset.from,
        text: li.querySelector('.sentence').textContent,
      })),
    };
  });
}

/** Waits (bounded) until the own view shows the tick the overview shows. */
function ownViewCaughtUp(page, tick = null) {
  return page.waitForFunction(
    (want) => {
      const section = document.querySelector('#ownview');
      const shown = want ?? Number(document.querySelector('#tick').textContent.trim());
      return section.dataset.stale === 'false' && section.dataset.tick === String(shown);
    },
    tick,
    { timeout: 15_000 },
  );
}

test("the replay viewer shows one player's own view beside the overview", { timeout: 180_000 }, async (t) => {
  const dir = tempDir('replay-ownview');
  t.after(() => fs.rmSync(dir, { recursive: true, force: true }));
  const file = path.join(dir, 'match.jsonl');
  await runBw4t(['run', '--map', 'fixed', '--seed', '3', '--replay', file]);
  const server = await startBw4t(['replay', 'view', file, '--http', '0']);
  t.after(() => stop(server.proc));
  const info = await (await fetch(new URL('replay.json', server.url))).json();
  const robots = (await (await fetch(new URL('replay/frame/0', server.url))).json()).robots;

  // A robot and a tick where it is in a room seeing blocks and has heard messages.
  let chosen = null;
  for (const robot of robots) {
    for (let tick = Math.floor(info.ticks / 4); tick <= info.ticks && !chosen; tick += 10) {
      const view = await viewOf(server.url, robot.id, tick);
      if (view.facts.some((f) => f[0] === 'color') && view.messages.length > 0) chosen = { robot, tick, view };
    }
    if (chosen) break;
  }
  assert.ok(chosen, 'some robot sees blocks after having heard messages');
  const { robot, tick, view } = chosen;
  assert.equal(view.name, robot.name);

  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;
  const viewRequests = [];
  page.on('request', (request) => {
    if (new URL(request.url()).pathname.startsWith('/replay/view/')) viewRequests.push(request.url());
  });
  try {
    await page.goto(server.url);
    await page.waitForSelector('#status[data-status="replay"]');
    await waitForNumber(page, '#tick', { equals: 0 });
    // None by default: no column, nothing fetched.
    assert.equal(await page.inputValue('#ownview-robot'), '');
    const options = await page.$$eval('#ownview-robot option', (all) => all.map((o) => o.textContent));
    assert.deepEqual(options, ['none', ...info.players]);
    assert.equal(await page.isVisible('#ownview'), false);
    const overviewWidth = await page.evaluate(() => document.querySelector('#stage').clientWidth);

    // Pick the robot, then move to the tick: its place, the blocks it sees, the sequence
    // index and the messages it had heard, as the server's view of that tick has them.
    await page.selectOption('#ownview-robot', robot.name);
    assert.equal(await page.isVisible('#ownview'), true);
    assert.ok((await page.evaluate(() => document.querySelector('#stage').clientWidth)) < overviewWidth, 'beside the overview');
    await ownViewCaughtUp(page, 0);
    await page.locator('#scrub').fill(String(tick));
    await waitForNumber(page, '#tick', { equals: tick });
    await ownViewCaughtUp(page, tick);
    const shown = await shownOwnView(page);
    assert.equal(shown.at, factOf(view, 'at')[0]);
    assert.equal(shown.index, factOf(view, 'sequenceIndex')[0]);
    const seen = view.facts.filter((f) => f[0] === 'color').map((f) => [f[1], f[2]]);
    assert.ok(seen.length > 0);
    assert.deepEqual(shown.blocks, seen.sort((a, b) => a[0] - b[0]));
    assert.deepEqual(
      shown.messages,
      view.messages.slice(-300).map((m) => ({ from: m.message.from, text: m.message.text })),
      'the messages heard, as sentences, newest last',
    );
    assert.match(await page.getAttribute('#ownview-map', 'width'), /^[1-9]\d*$/);
    await screenshot(page, 'replay-ownview');

    // Playing fast: the view follows at a bounded pace, and catches up once paused.
    await page.locator('#scrub').fill('0');
    await waitForNumber(page, '#tick', { equals: 0 });
    await ownViewCaughtUp(page, 0);
    await page.selectOption('#speed', '8');
    const before = viewRequests.length;
    const framesBefore = Number(await page.getAttribute('#map', 'data-frames'));
    await page.click('#play');
    await sleep(1500);
    await page.click('#pause');
    const requested = viewRequests.length - before;
    const framesShown = Number(await page.getAttribute('#map', 'data-frames')) - framesBefore;
    assert.ok(requested >= 2 && requested <= 12, `${requested} views fetched while ${framesShown} frames were shown`);
    assert.ok(framesShown > requested, `${framesShown} frames shown`);
    await ownViewCaughtUp(page);
    const paused = await number(page, '#tick');
    const pausedView = await viewOf(server.url, robot.id, paused);
    assert.equal((await shownOwnView(page)).at, factOf(pausedView, 'at')[0], `at tick ${paused}`);

    // None again: the column goes and nothing more is fetched.
    await page.selectOption('#ownview-robot', '');
    assert.equal(await page.isVisible('#ownview'), false);
    await page.waitForFunction((width) => document.querySelector('#stage').clientWidth === width, overviewWidth, { timeout: 5000 });
    const fetched = viewRequests.length;
    await page.locator('#scrub').fill(String(tick + 7));
    await waitForNumber(page, '#tick', { equals: tick + 7 });
    assert.equal(viewRequests.length, fetched, 'no view fetched for none');
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'replay-ownview-last');
  }
});
