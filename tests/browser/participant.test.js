// The participant view: a study's trial as its participant sees it, through `bw4t study`
// (tests/fixtures/study-view) in real Chromium. At 1280x720, 1366x768 and 1920x1080 the
// trial shows no condition, match, template or robot names and no system words, keeps the
// sequence, what the robot holds, the message menu and the messages inside the window,
// draws the map over most of the height and counts the time down. The participant's own
// robot is seen moving after a click on a place (the latency is printed), a refused
// action is said plainly, and the tick logged with every action's answer is the tick the
// match's replay has for it. A small window gets the screen-out page, and no participant
// is made; nor does an MTurk preview. The robot follows the participant from tab to tab,
// and a practice round's missed pass mark ends on the screen-out page with its code. Screenshots: test-output/browser/participant-WxH.png, participant-screen-out.png;
// with BW4T_SCREENSHOTS=1 also docs/screenshots/study-participant.png (1280x720) and
// study-screen-out.png.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { test } from 'node:test';

import { ROOT, openBrowser, readCsv, runBw4t, screenshot, startBw4t, stop, tempDir } from './helpers.js';

const STUDY = path.join(ROOT, 'tests', 'fixtures', 'study-view', 'study.toml');
const TOKEN = 'op-secret';
const SHOTS = process.env.BW4T_SCREENSHOTS === '1' ? path.join(ROOT, 'docs', 'screenshots') : null;

/** Saves docs/screenshots/study-NAME.png when asked to (BW4T_SCREENSHOTS=1). */
async function keep(page, name) {
  if (!SHOTS) return;
  fs.mkdirSync(SHOTS, { recursive: true });
  await page.screenshot({ path: path.join(SHOTS, `study-${name}.png`) });
}
const CONDITIONS = ['talking', 'deceptive'];
const SIZES = [
  { width: 1280, height: 720 },
  { width: 1366, height: 768 },
  { width: 1920, height: 1080 },
];

/** The participant list as the operator sees it. */
async function participants(server) {
  const response = await fetch(new URL('/api/study/participants', server.url), { headers: { Authorization: `Bearer ${TOKEN}` } });
  assert.equal(response.status, 200);
  return (await response.json()).participants.map((row) => row.participant);
}

/** Whether an element of the trial's frame lies inside the window (`size`), fully. */
async function inWindow(frame, selector, size) {
  const box = await frame.locator(selector).boundingBox();
  assert.ok(box, `${selector} is shown`);
  const inside = box.x >= 0 && box.y >= 0 && box.x + box.width <= size.width + 0.5 && box.y + box.height <= size.height + 0.5;
  assert.ok(inside, `${selector} at ${JSON.stringify(box)} inside ${size.width}x${size.height}`);
  return box;
}

/** Goes from the link to the first trial's view, connected; returns the frame. */
async function toTrial(page, base, id) {
  await page.goto(new URL(`/study?participant=${id}`, base).href);
  await page.waitForSelector('body[data-kind="consent"]');
  await page.click('#consent-agree');
  await page.waitForSelector('body[data-kind="trial"]');
  const frame = await (await page.waitForSelector('#trial-frame')).contentFrame();
  await frame.waitForSelector('body[data-participant="true"] #status[data-status="connected"]', { state: 'attached', timeout: 20_000 });
  return frame;
}

test('the participant view fits the window, names nothing of the study and logs the ticks the replay has', { timeout: 180_000 }, async (t) => {
  const data = tempDir('study-view');
  t.after(() => fs.rmSync(data, { recursive: true, force: true }));
  const server = await startBw4t(['study', STUDY, '--data', data, '--http', '0', '--port', '0', '--operator-token', TOKEN]);
  t.after(() => stop(server.proc));
  const browsers = await Promise.all(SIZES.map((size) => openBrowser(size)));
  t.after(() => Promise.all(browsers.map((b) => b.close())));
  const ids = SIZES.map((size) => `V${size.width}x${size.height}`);
  let latency = null;

  const checkView = async (b, size, id) => {
    const frame = await toTrial(b.page, server.url, id);
    const matchName = await frame.evaluate(() => document.querySelector('#match-name').textContent);
    const robotLine = await frame.evaluate(() => document.querySelector('#me').textContent);
    // Nothing of what the study does is shown: no condition, match, template, robot id,
    // nor the developer's words.
    await frame.waitForSelector('#sequence li', { timeout: 15_000 });
    await frame.waitForSelector('#countdown:not([hidden])');
    const shown = `${await b.page.innerText('body')}\n${await frame.innerText('body')}`;
    const banned = [
      ...CONDITIONS.map((c) => new RegExp(`\\b${c}\\b`, 'i')),
      /\bmode\b/i,
      /\bstatus\b/i,
      /\baccepted\b/i,
      /\brejected\b/i,
      /\bticks?\b/i,
      /\brealtime\b/i,
      /\brobot \d/i,
      /\bmatch\b/i,
    ];
    assert.ok(matchName.length > 0 && robotLine.includes('robot'), 'the page knows the match and robot it hides');
    for (const word of [...banned, new RegExp(matchName.replace(/[-()]/g, '\\$&'))]) {
      assert.doesNotMatch(shown, word, `${size.width}x${size.height}: the view shows ${word}`);
    }
    // What the participant works with, inside the window.
    for (const selector of ['#countdown-box', '#sequence-box', '#player-box #pickup', '#holding', '#menu-kind', '#menu-send', '#chat-to', '#messages-box']) {
      await inWindow(frame, selector, size);
    }
    const messages = await inWindow(frame, '#messages-box', size);
    assert.ok(messages.height >= 150, `the messages have room (${messages.height} px)`);
    // The map takes most of the window's height.
    const map = await frame.locator('#map').boundingBox();
    assert.ok(map.height >= 0.72 * size.height, `the map is ${map.height} px high in ${size.height}`);
    // The countdown goes down with the match.
    const first = Number(await frame.getAttribute('#countdown', 'data-seconds'));
    assert.ok(first > 0 && first <= 24, `time left ${first}`);
    await frame.waitForFunction((s) => Number(document.querySelector('#countdown').dataset.seconds) < s, first, { timeout: 5000, polling: 50 });
    await screenshot(b.page, `participant-${size.width}x${size.height}`);
    return frame;
  };

  const acts = async (frame) => {
    // D with nothing held: refused, and said plainly.
    await frame.evaluate(() => document.activeElement?.blur());
    await frame.press('body', 'd');
    await frame.waitForSelector('#feedback[data-code="not_holding"]:not([hidden])');
    await keep(browsers[0].page, 'participant');
    assert.match(await frame.innerText('#feedback'), /not holding a block/);
    // A click on a place: the robot is seen moving on the map (its "on its way" ring, when a
    // picture catches it before the marker moves, gives the latency report a figure too).
    const before = await frame.evaluate(() => ({ reacted: window.bw4tMotion.reacted.length, moved: window.bw4tMotion.moved.length }));
    // The places' buttons (for keyboards) show once focused; Enter is a click.
    await frame.focus('#places button[data-place="RoomC3"]');
    await frame.press('#places button[data-place="RoomC3"]', 'Enter');
    await frame
      .waitForFunction((n) => window.bw4tMotion.moved.length > n.moved, before, { timeout: 10_000, polling: 50 })
      .catch(async (err) => {
        const seen = await frame.evaluate(() => JSON.stringify({ motion: window.bw4tMotion, log: [...document.querySelectorAll('#log li')].slice(-8).map((n) => n.textContent) }));
        throw new Error(`${err.message}: the robot was not seen moving (${seen})`);
      });
    latency = await frame.evaluate(() => ({ reacted: window.bw4tMotion.reacted.at(-1), moved: window.bw4tMotion.moved.at(-1), ack: window.bw4tLatency.p50() }));
    await frame.press('body', 'p');
    await frame.waitForFunction(() => window.bw4tLatency.samples.length >= 3, null, { timeout: 5000 });
  };

  // The experimenter pauses the participant's match and resumes it: the view says so.
  const operator = async (verb, match) => {
    const url = new URL(`/api/matches/${encodeURIComponent(match)}/${verb}`, server.url);
    const response = await fetch(url, { method: 'POST', headers: { Authorization: `Bearer ${TOKEN}` } });
    assert.equal(response.status, 200, `${verb} ${match}`);
  };
  const pausing = async (frame, id) => {
    const response = await fetch(new URL('/api/study/participants', server.url), { headers: { Authorization: `Bearer ${TOKEN}` } });
    const match = (await response.json()).participants.find((p) => p.participant === id)?.match;
    assert.ok(match, `${id} is in a match`);
    await operator('pause', match);
    await frame.waitForSelector('#paused:not([hidden])', { timeout: 10_000 });
    assert.match(await frame.innerText('#paused'), /The experimenter has paused the task/);
    await operator('resume', match);
    await frame.waitForSelector('#paused', { state: 'hidden', timeout: 10_000 });
  };

  try {
    const frames = await Promise.all(SIZES.map((size, i) => checkView(browsers[i], size, ids[i])));
    await acts(frames[0]);
    await pausing(frames[1], ids[1]);
    // The match ends at its time limit: the view says so plainly, and the page saves it.
    for (const [i, frame] of frames.entries()) {
      await frame.waitForSelector('#task-over:not([hidden])', { timeout: 40_000 });
      assert.match(await frame.innerText('#task-over'), /The task is over/);
      await browsers[i].page.waitForSelector('#trial-continue', { timeout: 30_000 });
    }
    for (const b of browsers) assert.deepEqual(b.errors, [], 'no errors on the pages');
  } finally {
    for (const [i, b] of browsers.entries()) await screenshot(b.page, `participant-end-${SIZES[i].width}`);
  }
  for (const b of browsers) await b.page.waitForFunction(() => window.bw4tStudy.pending() === 0, null, { timeout: 10_000 });
  console.log(`participant view latency at 10 ticks/s: input to ack ${latency.ack?.toFixed(0)} ms, to the robot shown on its way ${latency.reacted?.toFixed(0) ?? '-'} ms, to the robot drawn moving ${latency.moved.toFixed(0)} ms`);
  await stop(server.proc);

  // Every answer to an action is logged with the tick the replay has for that action.
  const out = path.join(data, 'export');
  await runBw4t(['study', 'export', data, '--out', out]);
  const events = readCsv(path.join(out, 'events.csv')).filter((e) => e.participant === ids[0] && e.step === '1');
  const trial = readCsv(path.join(out, 'trials.csv')).find((r) => r.participant === ids[0] && r.step === '1');
  const robot = JSON.parse(events.find((e) => e.kind === 'welcome').data).robot;
  const replayFile = path.isAbsolute(trial.replay) ? trial.replay : path.join(out, trial.replay);
  const replayed = fs
    .readFileSync(replayFile, 'utf8')
    .split('\n')
    .filter(Boolean)
    .map((line) => JSON.parse(line))
    .filter((line) => line.type === 'tick')
    .flatMap((line) => line.events.filter((e) => e.kind === 'act' && e.robot === robot).map((e) => ({ tick: line.tick, action: e.action, ok: e.ok })));
  const sentById = new Map(events.filter((e) => e.kind === 'act').map((e) => [JSON.parse(e.data).id, JSON.parse(e.data).action]));
  const logged = events
    .filter((e) => e.kind === 'ack')
    .map((e) => ({ tick: Number(e.tick), action: sentById.get(JSON.parse(e.data).id), ok: JSON.parse(e.data).ok }))
    .filter((e) => e.action !== 'sendMessage' && e.action !== 'say');
  const moves = replayed.filter((e) => e.action !== 'sendMessage');
  assert.ok(logged.length >= 3, `acks logged: ${JSON.stringify(logged)}`);
  assert.deepEqual(
    logged.map((e) => [e.action, e.ok, e.tick]),
    moves.map((e) => [e.action, e.ok, e.tick]),
    'the logged ticks of the actions are the replay\'s',
  );
});

test('a small window gets the screen-out page and a preview makes no participant; the bare link in a new window is a new one', { timeout: 60_000 }, async (t) => {
  const data = tempDir('study-small');
  t.after(() => fs.rmSync(data, { recursive: true, force: true }));
  const server = await startBw4t(['study', STUDY, '--data', data, '--http', '0', '--port', '0', '--operator-token', TOKEN]);
  t.after(() => stop(server.proc));
  const small = await openBrowser({ width: 800, height: 600 });
  t.after(() => small.close());
  await small.page.goto(new URL('/study?participant=SMALL1', server.url).href);
  await small.page.waitForSelector('body[data-kind="screen-out"]');
  assert.match(await small.page.innerText('#screen-needs'), /screen of at least 1024 × 640 pixels and a keyboard and mouse/);
  assert.equal(await small.page.$('#consent-agree'), null, 'no consent page');
  assert.deepEqual(await participants(server), [], 'no participant made');
  await screenshot(small.page, 'participant-screen-out');
  await keep(small.page, 'screen-out');
  // The same link in a window large enough comes to consent, and makes the participant.
  await small.page.setViewportSize({ width: 1280, height: 720 });
  await small.page.click('#screen-again');
  await small.page.waitForSelector('body[data-kind="consent"]');
  assert.deepEqual(await participants(server), ['SMALL1']);
  // An MTurk preview shows what the study is and makes nobody.
  const large = async () => {
    const page = await small.context.newPage();
    await page.setViewportSize({ width: 1280, height: 720 });
    return page;
  };
  const preview = await large();
  await preview.goto(new URL('/study?assignmentId=ASSIGNMENT_ID_NOT_AVAILABLE&hitId=H1&workerId=W9', server.url).href);
  await preview.waitForSelector('body[data-kind="preview"]');
  assert.match(await preview.innerText('#study-page'), /preview/);
  assert.deepEqual(await participants(server), ['SMALL1'], 'a preview makes no participant');
  // The next person at this computer opens the bare link in a new window: a new participant,
  // not the last one's session.
  const first = await large();
  await first.goto(new URL('/study', server.url).href);
  await first.waitForSelector('body[data-kind="consent"]');
  const next = await large();
  await next.goto(new URL('/study', server.url).href);
  await next.waitForSelector('body[data-kind="consent"]');
  const made = await participants(server);
  assert.equal(new Set(made).size, 3, `two anonymous arrivals are two participants: ${made}`);
  // A reload keeps its own participant.
  await next.reload();
  await next.waitForSelector('body[data-kind="consent"]');
  assert.equal((await participants(server)).length, 3, 'a reload is no new participant');
  assert.deepEqual(small.errors, [], 'no errors on the page');
});

/** The trial's frame of a page already at the trial, once connected. */
async function connectedFrame(page) {
  await page.waitForSelector('body[data-kind="trial"]');
  const frame = await (await page.waitForSelector('#trial-frame')).contentFrame();
  await frame.waitForSelector('body[data-participant="true"] #status[data-status="connected"]', { state: 'attached', timeout: 20_000 });
  return frame;
}

test('the robot follows the participant, not the tab: a second tab takes it over, a closed tab comes back to it, the absence is recorded', { timeout: 150_000 }, async (t) => {
  const data = tempDir('study-tabs');
  t.after(() => fs.rmSync(data, { recursive: true, force: true }));
  const server = await startBw4t(['study', STUDY, '--data', data, '--http', '0', '--port', '0', '--operator-token', TOKEN]);
  t.after(() => stop(server.proc));
  const b = await openBrowser({ width: 1280, height: 720 });
  t.after(() => b.close());
  const id = 'tabs1';
  const link = new URL(`/study?participant=${id}`, server.url).href;
  const first = await toTrial(b.page, server.url, id);
  const me = await first.evaluate(() => document.querySelector('#me').textContent);
  // The server has the trial's start (and the robot's session) once the page has said it.
  const started = async () => {
    const response = await fetch(new URL('/api/study/participants', server.url), { headers: { Authorization: `Bearer ${TOKEN}` } });
    return (await response.json()).participants.find((p) => p.participant === id)?.match_id;
  };
  const deadline = Date.now() + 10_000;
  while (!(await started())) {
    assert.ok(Date.now() < deadline, 'the trial start is recorded');
    await b.page.waitForTimeout(100);
  }
  // A second tab of the same browser: the same robot; the first tab steps aside, saying why.
  const second = await b.context.newPage();
  await second.goto(link);
  const secondFrame = await connectedFrame(second);
  assert.equal(await secondFrame.evaluate(() => document.querySelector('#me').textContent), me);
  await b.page.waitForSelector('#trial-elsewhere');
  assert.match(await b.page.innerText('#trial-elsewhere'), /another tab or window/);
  // That tab is closed, and the participant comes back in a new one: the same robot again.
  await second.close();
  const third = await b.context.newPage();
  await third.goto(link);
  const thirdFrame = await connectedFrame(third);
  assert.equal(await thirdFrame.evaluate(() => document.querySelector('#me').textContent), me);
  await screenshot(third, 'participant-back');
  // The trial plays to its end in the tab that is left, and counts.
  await third.waitForSelector('#trial-continue', { timeout: 60_000 });
  await third.waitForFunction(() => window.bw4tStudy.pending() === 0, null, { timeout: 10_000 });
  await stop(server.proc);
  const out = path.join(data, 'export');
  await runBw4t(['study', 'export', data, '--out', out]);
  const trial = readCsv(path.join(out, 'trials.csv')).find((r) => r.participant === id);
  assert.equal(trial.complete, 'true', JSON.stringify(trial));
  assert.ok(Number(trial.disconnections) >= 1 && Number(trial.absent_s) > 0, `the absence is recorded: ${JSON.stringify(trial)}`);
});

test('a participant who misses the practice round\'s pass mark ends on the screen-out page with its code', { timeout: 90_000 }, async (t) => {
  const data = tempDir('study-practice');
  t.after(() => fs.rmSync(data, { recursive: true, force: true }));
  const practice = path.join(ROOT, 'tests', 'fixtures', 'study-practice', 'study.toml');
  const server = await startBw4t(['study', practice, '--data', data, '--http', '0', '--port', '0', '--operator-token', TOKEN]);
  t.after(() => stop(server.proc));
  const b = await openBrowser({ width: 1280, height: 720 });
  t.after(() => b.close());
  // The practice plays as a trial does; this participant does nothing in it.
  await b.page.goto(new URL('/study?participant=idle1', server.url).href);
  await b.page.waitForSelector('body[data-kind="consent"]');
  await b.page.click('#consent-agree');
  await b.page.waitForSelector('body[data-kind="practice"]');
  const frame = await (await b.page.waitForSelector('#trial-frame')).contentFrame();
  await frame.waitForSelector('body[data-participant="true"] #status[data-status="connected"]', { state: 'attached', timeout: 20_000 });
  await b.page.waitForSelector('#trial-continue', { timeout: 40_000 });
  await b.page.click('#trial-continue');
  await b.page.waitForSelector('body[data-kind="screened_out"]');
  assert.match(await b.page.innerText('#study-page'), /practice round was not passed/);
  assert.equal(await b.page.innerText('#completion-code'), 'SCREENED');
  await screenshot(b.page, 'participant-screened-out');
  assert.deepEqual(b.errors, [], 'no errors on the page');
});
