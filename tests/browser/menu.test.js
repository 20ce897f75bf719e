// The message menu of the player view: a person composes messages of the shared language
// (every group's), the chat shows each as its sentence, and the wire carries the structured
// form (`say` with `said`, no text). A cooperative built-in agent acts on a request made
// with the menu ("Bot1, go to RoomC3"): the operator's overview sees its robot go there.

import assert from 'node:assert/strict';
import path from 'node:path';
import { test } from 'node:test';

import { openBrowser, screenshot, startBw4t, stop } from './helpers.js';

/** Chooses a kind and its slots in the menu (slots: {room, colour, player, count, position}). */
async function compose(page, kind, slots = {}) {
  await page.selectOption('#menu-kind', kind);
  for (const [slot, value] of Object.entries(slots)) {
    const selector = `#menu-slot-${slot}`;
    if (slot === 'count') await page.fill(selector, String(value));
    else await page.selectOption(selector, String(value));
  }
}

/** The `say` messages the page sent on its WebSocket, as parsed JSON. */
function recordSays(page) {
  const says = [];
  page.on('websocket', (ws) => {
    ws.on('framesent', ({ payload }) => {
      if (typeof payload !== 'string') return;
      for (const line of payload.split('\n')) {
        if (!line.trim()) continue;
        const message = JSON.parse(line);
        if (message.type === 'say') says.push(message);
      }
    });
  });
  return says;
}

/** Waits until the chat shows a line of `kind` from `from` with `sentence`. */
async function seeSentence(page, from, kind, sentence) {
  await page.waitForFunction(
    ([f, k, s]) =>
      [...document.querySelectorAll(`#messages li[data-from="${f}"][data-kind="${k}"] .sentence`)].some(
        (node) => node.textContent === s,
      ),
    [from, kind, sentence],
    { timeout: 15_000, polling: 100 },
  );
}

test('the menu composes every group\'s messages; the chat shows sentences; the wire is structured', { timeout: 120_000 }, async (t) => {
  const server = await startBw4t([
    'serve', '--once', '--http', '0', '--port', '0', '--map', 'default', '--builtin', '1', '--robots', '2',
    '--mode', 'realtime', '--seed', '3', '--max-ticks', '6000',
  ]);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;
  const says = recordSays(page);
  try {
    await page.goto(`${server.url}?play=Hugo`);
    await page.waitForSelector('#status[data-status="connected"]');
    await page.waitForSelector('#chat-to option[value="Bot1"]', { state: 'attached' });
    // Every kind of the language is offered, grouped (the match allows all of them).
    const language = await (await fetch(new URL('/language.json', server.url))).json();
    await page.waitForFunction((n) => document.querySelector('#menu-form').dataset.kinds === String(n), language.kinds.length);
    const groups = await page.$$eval('#menu-kind optgroup', (nodes) => nodes.map((g) => g.dataset.group));
    assert.deepEqual(groups, ['rooms', 'blocks', 'requests', 'answers']);
    assert.equal(await page.isVisible('#chat-form'), true, 'free text is allowed in this match');

    // Send is off until every slot is chosen; the sentence shows as it is composed.
    await compose(page, 'contains_many', { room: 'RoomA1' });
    assert.equal(await page.isDisabled('#menu-send'), true);
    assert.equal(await page.textContent('#menu-preview'), 'RoomA1 contains 1 ….');
    await compose(page, 'contains_many', { count: 2, colour: 'Red' });
    assert.equal(await page.textContent('#menu-preview'), 'RoomA1 contains 2 Red.');
    assert.equal(await page.isDisabled('#menu-send'), false);

    // One message of each group, to all or to Bot1.
    const cases = [
      { to: 'all', said: { kind: 'contains_many', room: 'RoomA1', count: 2, colour: 'Red' }, sentence: 'RoomA1 contains 2 Red.' },
      { to: 'all', said: { kind: 'getting_for', colour: 'Blue', room: 'RoomB2', position: 0 }, sentence: 'I am getting Blue from RoomB2 for position 1.' },
      { to: 'Bot1', said: { kind: 'where_is', colour: 'Green' }, sentence: 'Where is Green?' },
      { to: 'Bot1', said: { kind: 'on_my_way' }, sentence: 'I am on my way.' },
    ];
    for (const { to, said, sentence } of cases) {
      await page.selectOption('#chat-to', to);
      const { kind, ...slots } = said;
      await compose(page, kind, slots);
      assert.equal(await page.textContent('#menu-preview'), sentence);
      await page.click('#menu-send');
      await seeSentence(page, 'Hugo', kind, sentence);
    }
    // Keyboard only: M focuses the menu, a letter picks "Yes.", Tab reaches Send, Enter sends.
    await page.locator('#map').click({ position: { x: 2, y: 2 } }).catch(() => {});
    await page.evaluate(() => document.activeElement?.blur());
    await page.keyboard.press('m');
    assert.equal(await page.evaluate(() => document.activeElement?.id), 'menu-kind');
    await page.keyboard.type('Y');
    assert.equal(await page.inputValue('#menu-kind'), 'yes');
    await page.keyboard.press('Tab');
    assert.equal(await page.evaluate(() => document.activeElement?.id), 'menu-send');
    await page.keyboard.press('Enter');
    await seeSentence(page, 'Hugo', 'yes', 'Yes.');

    // On the wire: structured, no text.
    const sent = says.filter((m) => m.said);
    assert.deepEqual(
      sent.map((m) => [m.to, m.said]),
      [...cases.map((c) => [c.to, c.said]), ['Bot1', { kind: 'yes' }]],
    );
    assert.ok(sent.every((m) => m.text === undefined), 'a menu message carries no text');

    // Every key or click that made an action was timed to its ack: 20 presses of D more
    // (each refused, nothing is held), one after the other's ack.
    for (let i = 1; i <= 20; i++) {
      await page.keyboard.press('d');
      await page.waitForFunction((n) => document.querySelectorAll('#log li[data-kind="reject"][data-action="putDown"]').length >= n, i);
    }
    const latency = await page.evaluate(() => ({
      n: window.bw4tLatency.samples.length,
      p50: window.bw4tLatency.p50(),
      p99: window.bw4tLatency.p99(),
    }));
    t.diagnostic(`input-to-ack latency: ${latency.n} samples, p50 ${latency.p50.toFixed(1)} ms, p99 ${latency.p99.toFixed(1)} ms (realtime, 20 ticks/s)`);
    assert.equal(latency.n, cases.length + 1 + 20, 'one sample per action made by a key or click');
    assert.ok(latency.p50 > 0 && latency.p99 < 2000, `p50 ${latency.p50} ms, p99 ${latency.p99} ms`);
    if (process.env.BW4T_SCREENSHOTS === '1') {
      await compose(page, 'go_to', { player: 'Bot1', room: 'RoomC3' });
      await page.screenshot({ path: path.join(process.cwd(), 'docs', 'screenshots', 'study-menu.png') });
    }
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'menu');
  }
});

test('a cooperative agent goes where a menu request tells it to', { timeout: 180_000 }, async (t) => {
  const server = await startBw4t([
    'serve', '--once', '--http', '0', '--port', '0', '--map', 'default', '--builtin', '1', '--robots', '2',
    '--mode', 'realtime', '--seed', '5', '--max-ticks', '6000', '--operator-token', 'op',
  ]);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page, context } = browser;
  // The operator's overview: where each robot is.
  const overview = await context.newPage();
  try {
    await page.goto(`${server.url}?play=Hugo`);
    await page.waitForSelector('#chat-to option[value="Bot1"]', { state: 'attached' });
    await overview.goto(`${server.url}?operator_token=op`);
    await overview.waitForSelector('#robot-list tr[data-name="Bot1"]');

    await page.selectOption('#chat-to', 'Bot1');
    await compose(page, 'go_to', { player: 'Bot1', room: 'RoomC3' });
    assert.equal(await page.textContent('#menu-preview'), 'Bot1, go to RoomC3.');
    await page.click('#menu-send');
    await seeSentence(page, 'Hugo', 'go_to', 'Bot1, go to RoomC3.');
    // The agent answers (its `ok` reaches the human as a sentence) and its robot is seen in
    // the room.
    await seeSentence(page, 'Bot1', 'ok', 'OK.');
    await overview.waitForFunction(
      () => document.querySelector('#robot-list tr[data-name="Bot1"] td:nth-child(2)')?.textContent === 'RoomC3',
      null,
      { timeout: 90_000, polling: 100 },
    );
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'menu-request');
    await screenshot(overview, 'menu-request-overview');
  }
});
