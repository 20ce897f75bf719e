// A study from end to end in the browser: `bw4t study` serves a short study
// (tests/fixtures/study-short) to two scripted participants in their own browsers at once:
// consent, instructions, a trial in one condition (the robot's own view, or the whole map)
// where they tell a teammate where to go
// with the message menu (and the teammate goes there, seen from the operator's live view
// opened from the dashboard), a questionnaire (its required items checked), the trial of the
// other condition, the completion page (one of them reloads the page during a trial and is
// back in the same match). A third declines consent. The dashboard lists them
// and pauses and resumes a live trial. Then `bw4t study export` must hold every input the
// participants made, with its times. With BW4T_SCREENSHOTS=1 each kind of page is saved as
// docs/screenshots/study-KIND.png.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { test } from 'node:test';

import { ROOT, openBrowser, readCsv, runBw4t, screenshot, startBw4t, stop, tempDir } from './helpers.js';

const STUDY = path.join(ROOT, 'tests', 'fixtures', 'study-short', 'study.toml');
const TOKEN = 'op-secret';
const SHOTS = process.env.BW4T_SCREENSHOTS === '1' ? path.join(ROOT, 'docs', 'screenshots') : null;

/** Saves docs/screenshots/study-NAME.png when asked to (BW4T_SCREENSHOTS=1). */
async function keep(page, name) {
  if (!SHOTS) return;
  fs.mkdirSync(SHOTS, { recursive: true });
  await page.screenshot({ path: path.join(SHOTS, `study-${name}.png`) });
}

/** Waits for the study page to show a page of `kind` (at `step`, if given). */
async function onPage(page, kind, step) {
  const stepped = step === undefined ? '' : `[data-step="${step}"]`;
  await page.waitForSelector(`body[data-kind="${kind}"]${stepped}`, { timeout: 20_000 });
}

/** The dashboard's row of a participant, once it shows `page` at `step` (and a match, for
 * a trial). */
async function dashboardRow(admin, id, page, step) {
  const selector = `#participants tr[data-participant="${id}"][data-page="${page}"][data-step="${step}"]${page === 'trial' ? ':not([data-match=""])' : ''}`;
  await admin.waitForSelector(selector, { timeout: 20_000 });
  return admin.locator(selector);
}

/** Answers a questionnaire: first without the required items (refused on the page), then
 * with them. */
async function questionnaire(page, step, { comments = null } = {}) {
  await onPage(page, 'questionnaire', step);
  await page.click('#questionnaire-submit');
  await page.waitForSelector('fieldset[data-item="teamwork"][aria-invalid="true"]');
  assert.equal(await page.getAttribute('body', 'data-step'), String(step), 'a questionnaire without its required answers stays');
  await page.check('fieldset[data-item="teamwork"] input[value="5"]');
  await page.check('fieldset[data-item="workload"] input[value="Moderate"]');
  if (comments !== null) await page.fill('fieldset[data-item="comments"] textarea', comments);
}

/**
 * One trial: the menu offers the condition's kinds; the participant tells a teammate to go
 * to RoomC3 (and presses D, which is refused: nothing held); the operator's live view of
 * the match sees the teammate get there; at the match's end the page goes on.
 */
async function trial(page, admin, id, step, expected, { reload = false } = {}) {
  await onPage(page, 'trial', step);
  let frame = await (await page.waitForSelector('#trial-frame')).contentFrame();
  await frame.waitForSelector('#status[data-status="connected"]', { state: 'attached', timeout: 20_000 });
  const condition = await page.evaluate(() => document.querySelector('#trial-head')?.textContent || '');
  // Which condition this is shows in what the menu offers.
  await frame.waitForFunction(() => Number(document.querySelector('#menu-form').dataset.kinds) > 0);
  const kinds = Number(await frame.getAttribute('#menu-form', 'data-kinds'));
  const name = kinds === expected.quiet.kinds ? 'quiet' : 'talking';
  assert.equal(kinds, expected[name].kinds, `kinds offered (${condition})`);
  assert.equal(await frame.isVisible('#chat-form'), expected[name].freeText, 'free text box');
  // The quiet condition shows the whole map (the match's frames), the talking one the
  // robot's own view.
  assert.equal(await frame.getAttribute('body', 'data-overview'), String(name === 'quiet'));
  if (name === 'quiet') await frame.waitForSelector('#map[data-frames]:not([data-frames="0"])', { state: 'attached' });
  else assert.equal(await frame.getAttribute('#map', 'data-frames'), null, 'no frames in the own view');

  await frame.waitForSelector('#chat-to option[value^="Bot"]', { state: 'attached' });
  const bot = await frame.getAttribute('#chat-to option[value^="Bot"]', 'value');
  await frame.selectOption('#chat-to', bot);
  await frame.selectOption('#menu-kind', 'go_to');
  await frame.selectOption('#menu-slot-player', bot);
  await frame.selectOption('#menu-slot-room', 'RoomC3');
  await frame.click('#menu-send');
  await frame.waitForSelector('#messages li[data-kind="go_to"]', { state: 'attached' });
  await frame.locator('#map').click({ position: { x: 3, y: 3 } }).catch(() => {});
  await frame.evaluate(() => document.activeElement?.blur());
  await frame.press('body', 'd');
  await frame.waitForSelector('#log li[data-kind="reject"][data-action="putDown"]', { state: 'attached' });
  if (name === 'talking') {
    // A talking teammate says it will.
    await frame.waitForSelector(`#messages li[data-from="${bot}"][data-kind="ok"]`, { state: 'attached', timeout: 15_000 });
  }
  if (reload) {
    // A reload in the middle of a trial goes back into the same match, as the same robot.
    const before = [await frame.textContent('#match-name'), await frame.textContent('#me')];
    await page.reload();
    await onPage(page, 'trial', step);
    frame = await (await page.waitForSelector('#trial-frame')).contentFrame();
    await frame.waitForSelector('#status[data-status="connected"]', { state: 'attached', timeout: 20_000 });
    // The header is hidden in the participant view: its robot line is read once welcomed.
    await frame.waitForFunction(() => document.querySelector('#me').textContent.includes('(robot'), null, { timeout: 20_000 });
    assert.deepEqual([await frame.textContent('#match-name'), await frame.textContent('#me')], before, 'the same match and robot after a reload');
  }

  // The operator watches the match from the dashboard: the teammate gets to RoomC3.
  const row = await dashboardRow(admin, id, 'trial', step);
  const href = await row.locator('a.watch').getAttribute('href');
  const watch = await admin.context().newPage();
  try {
    await watch.goto(new URL(href, admin.url()).href);
    await watch.waitForFunction(
      (b) => document.querySelector(`#robot-list tr[data-name="${b}"] td:nth-child(2)`)?.textContent === 'RoomC3',
      bot,
      { timeout: 25_000, polling: 100 },
    );
  } finally {
    await watch.close();
  }
  if (expected.shot) await keep(page, 'trial');
  // The match ends at its time limit; the page answers the trial and offers to go on.
  await page.waitForSelector('#trial-continue', { timeout: 40_000 });
  await page.click('#trial-continue');
  return { name, bot };
}

/** A participant from the link to the completion page. */
async function participant(page, admin, base, link, id, { shots = false } = {}) {
  const expected = { quiet: { kinds: 6, freeText: true }, talking: { kinds: 30, freeText: false }, shot: shots };
  await page.goto(new URL(link, base).href);
  await onPage(page, 'consent', 0);
  assert.equal(new URL(page.url()).search, `?participant=${id}`, 'the id is kept in the address');
  if (shots) await keep(page, 'consent');
  await page.click('#consent-agree');
  await onPage(page, 'instructions', 1);
  // A reload continues where the participant was.
  await page.reload();
  await onPage(page, 'instructions', 1);
  if (shots) await keep(page, 'instructions');
  await page.click('#continue');
  const first = await trial(page, admin, id, 2, expected, { reload: shots });
  await questionnaire(page, 3, { comments: 'they went where I said' });
  if (shots) await keep(page, 'questionnaire');
  await page.click('#questionnaire-submit');
  const second = await trial(page, admin, id, 4, { ...expected, shot: false });
  assert.notEqual(first.name, second.name, 'the second trial is the other condition');
  await questionnaire(page, 5);
  await page.click('#questionnaire-submit');
  await onPage(page, 'final', 6);
  assert.equal((await page.textContent('#completion-code')).trim(), 'TESTCODE');
  if (shots) await keep(page, 'final');
  return [first.name, second.name];
}

test('two participants go through a study; its export holds every input with its times', { timeout: 300_000 }, async (t) => {
  const data = tempDir('study-data');
  t.after(() => fs.rmSync(data, { recursive: true, force: true }));
  const server = await startBw4t(['study', STUDY, '--data', data, '--http', '0', '--port', '0', '--operator-token', TOKEN]);
  t.after(() => stop(server.proc));
  const browsers = await Promise.all([openBrowser(), openBrowser(), openBrowser(), openBrowser({ width: 1400, height: 700 })]);
  t.after(() => Promise.all(browsers.map((b) => b.close())));
  const [alice, bob, carol, operator] = browsers;
  const admin = operator.page;
  try {
    // The dashboard, with the token from its link.
    await admin.goto(new URL(`/study/admin?token=${TOKEN}`, server.url).href);
    await admin.waitForSelector('#dash-status:not([data-polls="0"])', { state: 'attached' });

    // A third person declines and is done.
    await carol.page.goto(new URL('/study?workerId=CAROL3', server.url).href);
    await onPage(carol.page, 'consent', 0);
    await carol.page.click('#consent-decline');
    await onPage(carol.page, 'declined');
    if (SHOTS) await keep(carol.page, 'declined');

    // The operator pauses one live trial and resumes it.
    const pauseCheck = (async () => {
      const row = await dashboardRow(admin, 'ALICE1', 'trial', 2);
      const match = await row.getAttribute('data-match');
      const paused = async () => {
        const response = await fetch(new URL('/api/matches', server.url), { headers: { Authorization: `Bearer ${TOKEN}` } });
        const list = await response.json();
        return (list.matches || list).find((m) => m.name === match)?.paused;
      };
      await row.locator('button.pause').click();
      for (let i = 0; i < 50 && (await paused()) !== true; i++) await new Promise((r) => setTimeout(r, 100));
      assert.equal(await paused(), true, 'paused from the dashboard');
      await admin.waitForSelector('#participants tr[data-participant="ALICE1"][data-paused="true"] button.pause:disabled');
      if (SHOTS) await keep(admin, 'dashboard');
      await row.locator('button.resume').click();
      for (let i = 0; i < 50 && (await paused()) !== false; i++) await new Promise((r) => setTimeout(r, 100));
      assert.equal(await paused(), false, 'resumed from the dashboard');
      await admin.waitForSelector('#participants tr[data-participant="ALICE1"][data-paused="false"] button.resume:disabled');
    })();

    const [aliceOrder, bobOrder] = await Promise.all([
      participant(alice.page, admin, server.url, '/study?PROLIFIC_PID=ALICE1&STUDY_ID=s1', 'ALICE1', { shots: true }),
      participant(bob.page, admin, server.url, '/study?pid=BOB2', 'BOB2'),
      pauseCheck,
    ]);
    assert.notDeepEqual(aliceOrder, bobOrder, 'counterbalanced: the two start with different conditions');
    await admin.waitForSelector('#participants tr[data-participant="ALICE1"][data-completed="true"]');
    await admin.waitForSelector('#participants tr[data-participant="BOB2"][data-completed="true"]');
    // The counts: each condition given to all three, completed by two; one declined.
    await admin.waitForFunction(() => /2 completed/.test(document.querySelector('#dash-states').textContent));
    assert.match(await admin.innerText('#dash-states'), /3 participants: .*1 declined/);
    for (const row of await admin.locator('#dash-summary tbody tr').all()) {
      const cells = await row.locator('td').allInnerTexts();
      assert.deepEqual([cells[1], cells[3]], ['3', '2'], `condition ${cells[0]}: assigned, completed`);
    }
    // The filter keeps the rows that match.
    await admin.fill('#dash-filter', 'bob2');
    await admin.waitForSelector('#participants tr[data-participant="ALICE1"]', { state: 'hidden' });
    assert.ok(await admin.isVisible('#participants tr[data-participant="BOB2"]'));
    await admin.fill('#dash-filter', '');
    // The export, made and saved from the dashboard.
    await admin.click('#dash-export');
    await admin.waitForSelector('.export-file[data-file="trials.csv"]');
    const [download] = await Promise.all([admin.waitForEvent('download'), admin.click('.export-file[data-file="trials.csv"]')]);
    assert.match(download.suggestedFilename(), /trials\.csv$/);
    const saved = fs.readFileSync(await download.path(), 'utf8');
    assert.ok(saved.startsWith('participant,step,trial,') && saved.includes('ALICE1') && saved.includes('BOB2'), saved.slice(0, 200));
    for (const b of browsers) assert.deepEqual(b.errors, [], 'no errors on the pages');
  } finally {
    await screenshot(alice.page, 'study-alice');
    await screenshot(bob.page, 'study-bob');
    await screenshot(admin, 'study-dashboard');
  }
  // Every event is with the server before the pages close (they send once a second, and
  // each batch is on disk when it is answered).
  for (const b of [alice, bob, carol]) {
    await b.page.waitForFunction(() => window.bw4tStudy.pending() === 0, null, { timeout: 10_000 });
  }
  await stop(server.proc);

  const out = path.join(data, 'export');
  await runBw4t(['study', 'export', data, '--out', out]);
  const events = readCsv(path.join(out, 'events.csv'));
  const trials = readCsv(path.join(out, 'trials.csv'));
  const answers = readCsv(path.join(out, 'answers.csv'));
  for (const id of ['ALICE1', 'BOB2']) {
    const mine = events.filter((e) => e.participant === id);
    for (const e of mine) {
      assert.ok(Number(e.wall_ms) > 1.6e12 && Number(e.server_ms) > 1.6e12, `times of ${JSON.stringify(e)}`);
    }
    const clicks = mine.filter((e) => e.kind === 'click').map((e) => JSON.parse(e.data).target);
    for (const target of ['consent-agree', 'continue', 'questionnaire-submit', 'trial-continue', 'menu-send']) {
      assert.ok(clicks.includes(target), `${id}: click on ${target} logged (${clicks.join(' ')})`);
    }
    const keys = mine.filter((e) => e.kind === 'key').map((e) => JSON.parse(e.data).key);
    assert.equal(keys.filter((k) => k === 'd').length, 2, `${id}: the D keys`);
    // Both trials' actions and their answers, with the tick they happened at.
    const sent = mine.filter((e) => e.kind === 'message_sent').map((e) => JSON.parse(e.data));
    assert.equal(sent.filter((m) => m.said?.kind === 'go_to' && m.said.room === 'RoomC3').length, 2, `${id}: go_to sent twice`);
    const acts = mine.filter((e) => e.kind === 'act');
    assert.ok(acts.length >= 4, `${id}: ${acts.length} acts`);
    assert.ok(acts.every((e) => e.tick !== '' && Number(e.tick) >= 0), `${id}: acts have ticks`);
    const acked = new Set(mine.filter((e) => e.kind === 'ack').map((e) => `${e.step}:${JSON.parse(e.data).id}`));
    for (const a of acts) assert.ok(acked.has(`${a.step}:${JSON.parse(a.data).id}`), `${id}: act ${a.data} acknowledged`);
    const shown = new Set(mine.filter((e) => e.kind === 'page_shown').map((e) => Number(e.step)));
    for (let step = 0; step <= 6; step++) assert.ok(shown.has(step), `${id}: page ${step} shown`);
    for (const kind of ['welcome', 'match_over', 'percepts', 'message_received']) {
      assert.ok(mine.some((e) => e.kind === kind), `${id}: ${kind} logged`);
    }
    const done = trials.filter((r) => r.participant === id);
    assert.equal(done.length, 2, `${id}: two trials`);
    assert.ok(done.every((r) => r.complete === 'true'), `${id}: trials complete`);
    assert.deepEqual(new Set(done.map((r) => r.condition)), new Set(['talking', 'quiet']));
    const teamwork = answers.filter((a) => a.participant === id && a.item === 'teamwork').map((a) => a.value);
    assert.deepEqual(teamwork, ['5', '5'], `${id}: answers`);
  }
  assert.ok(events.some((e) => e.participant === 'CAROL3' && e.kind === 'click' && JSON.parse(e.data).target === 'consent-decline'));
});

test('two people share a trial: the first waits in the waiting room until the second comes', { timeout: 120_000 }, async (t) => {
  const data = tempDir('study-pair');
  t.after(() => fs.rmSync(data, { recursive: true, force: true }));
  const pair = path.join(ROOT, 'tests', 'fixtures', 'study-pair', 'study.toml');
  const server = await startBw4t(['study', pair, '--data', data, '--http', '0', '--port', '0', '--operator-token', TOKEN]);
  t.after(() => stop(server.proc));
  const browsers = await Promise.all([openBrowser(), openBrowser()]);
  t.after(() => Promise.all(browsers.map((b) => b.close())));
  const [ann, ben] = browsers.map((b) => b.page);
  const frameOf = async (page) => (await page.waitForSelector('#trial-frame')).contentFrame();
  try {
    await ann.goto(new URL('/study?participant=ANN', server.url).href);
    await onPage(ann, 'trial', 0);
    const annView = await frameOf(ann);
    // Alone: the waiting room says one more person is awaited.
    await annView.waitForSelector('#waiting[data-state="waiting"]', { timeout: 20_000 });
    await annView.waitForSelector('#waiting-awaited[data-awaited="1"]');
    if (SHOTS) await keep(ann, 'waiting');

    await ben.goto(new URL('/study?participant=BEN', server.url).href);
    await onPage(ben, 'trial', 0);
    const benView = await frameOf(ben);
    for (const view of [annView, benView]) {
      await view.waitForSelector('#status[data-status="connected"]', { state: 'attached' });
      await view.waitForSelector('#waiting', { state: 'hidden', timeout: 20_000 });
    }
    assert.equal(await annView.textContent('#match-name'), await benView.textContent('#match-name'), 'one match for both');

    // Ann tells Ben what the team needs; Ben reads the sentence.
    const benName = (await benView.textContent('#me')).split(' ')[0];
    await annView.waitForSelector(`#chat-to option[value="${benName}"]`, { state: 'attached' });
    await annView.selectOption('#chat-to', benName);
    await annView.selectOption('#menu-kind', 'need');
    await annView.selectOption('#menu-slot-colour', 'Red');
    await annView.click('#menu-send');
    await benView.waitForSelector('#messages li[data-kind="need"]', { state: 'attached' });
    assert.equal(await benView.textContent('#messages li[data-kind="need"] .sentence'), 'We need Red.');

    for (const page of [ann, ben]) {
      await page.waitForSelector('#trial-continue', { timeout: 40_000 });
      await page.click('#trial-continue');
      await onPage(page, 'final', 1);
      assert.equal((await page.textContent('#completion-code')).trim(), 'PAIR');
    }
    for (const b of browsers) assert.deepEqual(b.errors, [], 'no errors on the pages');
  } finally {
    await screenshot(ann, 'study-pair-ann');
    await screenshot(ben, 'study-pair-ben');
  }
});
