// The overview follows a live match: `bw4t serve --once --http 0` with built-in robots
// only (one match, so / shows it rather than the lobby), the page opened at / as a spectator.

import assert from 'node:assert/strict';
import { test } from 'node:test';

import {
  canvasPicture,
  number,
  openBrowser,
  screenshot,
  sleep,
  startBw4t,
  stop,
  tcpSpectator,
  text,
  waitForNumber,
} from './helpers.js';

/** The robots' positions as the page's robot table shows them. */
function positions(page) {
  return page.$$eval('#robot-list tbody tr', (rows) => rows.map((r) => `${r.dataset.name}@${r.dataset.x},${r.dataset.y}`));
}

test('the spectator view follows a match of three built-in robots', { timeout: 120_000 }, async (t) => {
  const server = await startBw4t([
    'serve', '--once', '--http', '0', '--port', '0', '--builtin', '3', '--robots', '3', '--mode', 'realtime',
    '--map', 'fixed', '--seed', '5', '--max-ticks', '6000',
  ]);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;

  try {
    await page.goto(server.url);
    await page.waitForSelector('#status[data-status="connected"]');
    assert.equal(await text(page, '#map-name'), 'fixed');
    assert.equal(await page.isVisible('#join-form'), true, 'the join form is offered');

    // Frames arrive: the tick goes up and the three robots are listed and drawn.
    const first = await waitForNumber(page, '#tick', { above: 0 });
    await waitForNumber(page, '#robots', { equals: 3 });
    assert.equal(await page.locator('#robot-list tbody tr').count(), 3);
    const names = await page.$$eval('#robot-list tbody tr', (rows) => rows.map((r) => r.dataset.name).sort());
    assert.deepEqual(names, ['Bot1', 'Bot2', 'Bot3']);
    const before = await positions(page);
    const pictureBefore = await canvasPicture(page);
    await waitForNumber(page, '#tick', { above: first + 20 });
    assert.notDeepEqual(await positions(page), before, 'robots moved between two samples');
    assert.notEqual(await canvasPicture(page), pictureBefore, 'the picture changed');
    assert.match(await text(page, '#sim-time'), /^\d+\.\d s$/);
    assert.equal(await page.locator('#sequence li').count(), 6);

    // The team delivers: the sequence index goes up, and the colour is marked done.
    await waitForNumber(page, '#sequence-index', { above: 0 }, 60_000);
    assert.equal(await page.locator('#sequence li.done').count() >= 1, true);
    // Their messages are shown.
    assert.ok((await page.locator('#messages li').count()) > 0, 'team messages are listed');
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'spectator');
  }
});

test('the overview keeps up with 20 robots at 20 ticks/s', { timeout: 120_000 }, async (t) => {
  const server = await startBw4t([
    'serve', '--once', '--http', '0', '--port', '0', '--builtin', '20', '--robots', '20', '--mode', 'realtime',
    '--map', 'crowd24', '--seed', '2', '--max-ticks', '6000',
  ]);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;
  // The same frames over TCP, read by this process: the match's tick to compare with.
  const reference = await tcpSpectator(server.tcp);
  t.after(() => reference.close());

  try {
    await page.goto(server.url);
    await waitForNumber(page, '#robots', { equals: 20 });
    await waitForNumber(page, '#tick', { above: 0 });
    const attribute = async (name) => Number(await page.getAttribute('#map', `data-${name}`));
    const frames0 = await attribute('frames');
    const sent0 = reference.frames;
    const draws0 = await attribute('draws');
    const ms0 = await attribute('draw-ms');
    const lags = [];
    for (let i = 0; i < 8; i++) {
      await sleep(500);
      lags.push(reference.tick - (await number(page, '#tick')));
    }
    const frames = (await attribute('frames')) - frames0;
    const sent = reference.frames - sent0;
    const draws = (await attribute('draws')) - draws0;
    const perDraw = ((await attribute('draw-ms')) - ms0) / Math.max(1, draws);
    console.log(
      `20 robots: page behind the match by ${lags.join(', ')} ticks; ` +
        `${frames} frames (${sent} to the TCP spectator), ${draws} pictures in 4 s, ${perDraw.toFixed(2)} ms each`,
    );
    // Frames reach the page as they reach a TCP client: at most half a second behind.
    assert.ok(Math.max(...lags) <= 10, `the page fell behind: ${lags}`);
    // A picture per frame (the server sends up to 20 a second; two arriving within one
    // display frame make one picture), each drawn well within a display frame.
    assert.ok(frames >= 20, `only ${frames} frames in 4 s`);
    assert.ok(frames >= sent * 0.8, `the page got ${frames} frames, a TCP spectator ${sent}`);
    assert.ok(draws >= frames * 0.7, `${draws} pictures for ${frames} frames`);
    assert.ok(perDraw < 16, `a picture takes ${perDraw} ms`);
    assert.deepEqual(browser.errors, []);
  } finally {
    await screenshot(page, 'spectator-20-robots');
  }
});
