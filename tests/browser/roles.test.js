// Roles on the page: each view needs its own role's token, spectators are not shown
// private messages while the operator is, and a full match refuses one more player. The
// server serves one match (`--once`), which the page shows at / (no lobby).

import assert from 'node:assert/strict';
import { test } from 'node:test';

import { openBrowser, screenshot, startBw4t, stop, text } from './helpers.js';

/** Waits (bounded) until some message in the page's list contains `words`. */
function messageShown(page, words) {
  return page.waitForFunction(
    (w) => [...document.querySelectorAll('#messages li')].some((li) => li.textContent.includes(w)),
    words,
  );
}

async function messagesContaining(page, words) {
  return page.$$eval('#messages li', (items, w) => items.filter((li) => li.textContent.includes(w)).length, words);
}

test('each role has its own token, and spectators see public messages only', { timeout: 120_000 }, async (t) => {
  const server = await startBw4t([
    'serve', '--once', '--http', '0', '--port', '0', '--map', 'fixed', '--seed', '3', '--mode', 'realtime',
    '--builtin', '1', '--robots', '2', '--max-ticks', '20000',
    '--token', 'player-secret', '--spectator-token', 'spectator-secret', '--operator-token', 'operator-secret',
  ]);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page, context } = browser;
  const spectator = await context.newPage();
  const operator = await context.newPage();
  const latecomer = await context.newPage();

  try {
    // A player's token opens no overview; the page says which token watching needs.
    await page.goto(`${server.url}?token=player-secret`);
    await page.waitForSelector('#status[data-status="error"]');
    assert.match(await text(page, '#status'), /bad_token/);
    assert.match(await text(page, '#watch-note'), /spectator_token=/);
    assert.equal(await page.isVisible('#join-form'), true, 'joining is still offered');

    await spectator.goto(`${server.url}?spectator_token=spectator-secret`);
    await spectator.waitForSelector('#status[data-status="connected"]');
    assert.match(await text(spectator, '#watch-note'), /not shown/);
    await operator.goto(`${server.url}?operator_token=operator-secret`);
    await operator.waitForSelector('#status[data-status="connected"]');
    assert.equal(await operator.isVisible('#watch-note'), false, 'the operator misses nothing');

    // The player joins with its token (the match starts: two players with Bot1), then
    // says one thing to Bot1 alone and one to everyone.
    await page.fill('#join-name', 'Hugo');
    await page.click('#join-button');
    await page.waitForSelector('#status[data-status="connected"]');
    await page.waitForSelector('#chat-to option[value="Bot1"]', { state: 'attached' });
    await page.selectOption('#chat-to', 'Bot1');
    await page.fill('#chat-text', 'psst, only for Bot1');
    await page.click('#chat-send');
    await page.waitForSelector('#log li[data-kind="ok"][data-action="say"]', { state: 'attached' });
    await page.selectOption('#chat-to', 'all');
    await page.fill('#chat-text', 'hello everyone');
    await page.click('#chat-send');

    // Frames carry every message since the previous frame: by the time the public one
    // shows, the private one would have shown before it.
    await messageShown(spectator, 'hello everyone');
    assert.equal(await messagesContaining(spectator, 'psst'), 0, 'a spectator is not shown private messages');
    await messageShown(operator, 'hello everyone');
    assert.equal(await messagesContaining(operator, 'psst, only for Bot1'), 1, 'the operator sees it');

    // The match admits two players (Bot1 and Hugo): a third is refused, with the reason.
    await latecomer.goto(`${server.url}?token=player-secret`);
    await latecomer.fill('#join-name', 'Ivy');
    await latecomer.click('#join-button');
    await latecomer.waitForSelector('#join-error:not([hidden])');
    assert.match(await text(latecomer, '#join-error'), /match is full/);
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(spectator, 'roles-spectator');
    await screenshot(operator, 'roles-operator');
  }
});
