// A questionnaire in the browser: `bw4t study` serves tests/fixtures/study-questionnaire to
// one scripted participant, who fills in a number (first out of range: the page says the
// range), a matrix row by row, a choice that shows a conditional item live (and hides it
// again), and a text up to its maxlength (the counter shows near the limit); reloads half
// way and finds the draft restored; sends it. The export then has a row per matrix row and
// the conditional item's answer. With BW4T_SCREENSHOTS=1 the page is saved as
// docs/screenshots/study-questionnaire-items.png.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { test } from 'node:test';

import { ROOT, openBrowser, runBw4t, screenshot, startBw4t, stop, tempDir } from './helpers.js';

const STUDY = path.join(ROOT, 'tests', 'fixtures', 'study-questionnaire', 'study.toml');
const ID = 'QUIN1';
const item = (id) => `fieldset[data-item="${id}"]`;

/** answers.csv's rows of the participant as [item, value] (no cell here holds a comma). */
function answerRows(file) {
  const [head, ...lines] = fs.readFileSync(file, 'utf8').trim().split('\n').map((l) => l.split(','));
  const col = (name) => head.indexOf(name);
  return lines.filter((cells) => cells[col('participant')] === ID).map((cells) => [cells[col('item')], cells[col('value')]]);
}

test('a participant fills a number, a matrix and a conditional item, reloads, finds the draft and sends it', { timeout: 120_000 }, async (t) => {
  const data = tempDir('study-questionnaire');
  t.after(() => fs.rmSync(data, { recursive: true, force: true }));
  const server = await startBw4t(['study', STUDY, '--data', data, '--http', '0', '--port', '0']);
  t.after(() => stop(server.proc));
  const browser = await openBrowser();
  t.after(() => browser.close());
  const { page } = browser;
  try {
    await page.goto(new URL(`/study?participant=${ID}`, server.url).href);
    await page.waitForSelector('body[data-kind="questionnaire"][data-step="0"]');
    assert.equal(await page.getAttribute('#questionnaire', 'data-draft'), 'none', 'nothing to restore at first');

    // The conditional item shows only while its answer is given.
    assert.equal(await page.isHidden(item('hours')), true, 'hours hidden before gamer is answered');
    await page.check(`${item('gamer')} input[value="yes"]`);
    await page.waitForSelector(item('hours'), { state: 'visible' });
    await page.check(`${item('gamer')} input[value="no"]`);
    await page.waitForSelector(item('hours'), { state: 'hidden' });
    await page.check(`${item('gamer')} input[value="yes"]`);
    await page.waitForSelector(item('hours'), { state: 'visible' });

    // A number out of range is refused on the page, saying the range.
    await page.fill(`${item('age')} input`, '150');
    assert.equal(await page.textContent(`${item('age')} .unit`), ' years');
    await page.click('#questionnaire-submit');
    await page.waitForSelector(`${item('age')}[aria-invalid="true"]`);
    assert.equal(await page.textContent(`${item('age')} .missing`), 'Please give a whole number from 18 to 99.');
    assert.equal(await page.getAttribute('body', 'data-step'), '0', 'not sent');
    // The matrix's unanswered rows, too.
    await page.waitForSelector(`${item('tlx')}[aria-invalid="true"]`);
    await page.fill(`${item('age')} input`, '34');
    await page.fill(`${item('hours')} input`, '7.5');
    await page.check(`${item('tlx')} tr[data-row="1"] input[value="4"]`);
    await page.check(`${item('tlx')} tr[data-row="2"] input[value="1"]`);

    // The text keeps to its maxlength; the counter shows near it.
    const note = `${item('note')} input`;
    assert.equal(await page.getAttribute(note, 'maxlength'), '20');
    assert.equal(await page.isHidden(`${item('note')} .counter`), true);
    await page.fill(note, 'all fine thank you');
    assert.equal(await page.textContent(`${item('note')} .counter`), '18 of 20 characters');
    await page.locator(note).pressSequentially('!!!');
    assert.equal(await page.inputValue(note), 'all fine thank you!!', 'typing stops at the limit');

    // A reload keeps the unsent answers.
    await page.reload();
    await page.waitForSelector('body[data-kind="questionnaire"][data-step="0"]');
    assert.equal(await page.getAttribute('#questionnaire', 'data-draft'), 'restored');
    assert.equal(await page.inputValue(`${item('age')} input`), '34');
    assert.equal(await page.isChecked(`${item('gamer')} input[value="yes"]`), true);
    await page.waitForSelector(item('hours'), { state: 'visible' });
    assert.equal(await page.inputValue(`${item('hours')} input`), '7.5');
    assert.equal(await page.isChecked(`${item('tlx')} tr[data-row="1"] input[value="4"]`), true);
    assert.equal(await page.isChecked(`${item('tlx')} tr[data-row="2"] input[value="1"]`), true);
    assert.equal(await page.inputValue(note), 'all fine thank you!!');

    // The last matrix row, and it is sent: the draft goes with it.
    await page.check(`${item('tlx')} tr[data-row="3"] input[value="2"]`);
    if (process.env.BW4T_SCREENSHOTS === '1') {
      await page.screenshot({ path: path.join(ROOT, 'docs', 'screenshots', 'study-questionnaire-items.png'), fullPage: true });
    }
    await page.click('#questionnaire-submit');
    await page.waitForSelector('body[data-kind="trial"][data-step="1"]');
    const drafts = await page.evaluate(() => Object.keys(sessionStorage).filter((k) => k.startsWith('bw4t-study-draft:')));
    assert.deepEqual(drafts, [], 'the draft is cleared once sent');
    await page.waitForFunction(() => window.bw4tStudy.pending() === 0, null, { timeout: 10_000 });
    assert.deepEqual(browser.errors, [], 'no errors on the page');
  } finally {
    await screenshot(page, 'study-questionnaire');
  }
  await stop(server.proc);

  const out = path.join(data, 'export');
  await runBw4t(['study', 'export', data, '--out', out]);
  const rows = answerRows(path.join(out, 'answers.csv'));
  assert.deepEqual(rows, [
    ['age', '34'],
    ['gamer', 'yes'],
    ['hours', '7.5'],
    ['note', 'all fine thank you!!'],
    ['tlx.1', '4'],
    ['tlx.2', '1'],
    ['tlx.3', '2'],
  ]);
});
