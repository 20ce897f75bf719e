// The study page (/study): one participant goes through the study's pages as the server's
// state says (consent, instructions, trials, questionnaires, the end), and everything the
// participant does is logged to the server.
//
// The participant's id comes from the address (PROLIFIC_PID, participant, pid, workerId or
// PARTICIPANT_ID, the first present; the server makes one up without), is kept in the
// address as `?participant=ID` and in this tab's sessionStorage, so a reload continues
// where it was (and the next person at a shared lab computer, opening the bare link in a
// new window, starts as a new participant). An MTurk preview (`assignmentId` =
// ASSIGNMENT_ID_NOT_AVAILABLE) shows what the study is, making no participant.
// The arrival sets the participant's credential, an HttpOnly cookie that every same-origin
// request here carries; the id alone is not enough to act as them.
// A trial embeds the player view (`/?embed=study&hello=JSON`, embed.js), which reports its
// events here; at the match's end the trial is answered with the match's id (again while
// the server says the match is still running). Events are sent in batches every second,
// and with a keepalive fetch when the page goes away (every POST is JSON). The API: the study contract, served by
// `bw4t study`.
//
// Before anything else the device is checked against the study's needs (`screen` in
// GET /api/study: a screen of at least min_width x min_height CSS pixels, and a mouse or
// touchpad unless touch-only devices are allowed): a device that falls short gets a plain
// page saying what the study needs, and no participant is made.

import { $, el, setText } from './dom.js';

const ID_PARAMS = ['PROLIFIC_PID', 'participant', 'pid', 'workerId', 'PARTICIPANT_ID'];
const STORE_KEY = 'bw4t-study-participant';
/** Where the match of the trial under way is kept, so that a reload goes back into it. */
const trialKey = () => `bw4t-study-trial:${study.id}`;
const FLUSH_MS = 1000;
/** A batch's most bytes (the server takes at most 64 KB). */
const BATCH_BYTES = 60 * 1024;
/** A batch's most events (the server takes at most 1000). */
const BATCH_EVENTS = 1000;
/** How long a finished trial's answer is retried while the server says its match is still
 * running (it is told of the match's end a moment after the player is). */
const TRIAL_ANSWER_MS = 60_000;
const RETRY_MS = 500;
/** What the embedded view reports that the log keeps (the contract's event kinds). */
const VIEW_EVENTS = new Set(['key', 'click', 'act', 'ack', 'done', 'message_sent', 'message_received', 'percepts', 'lobby', 'welcome', 'match_over']);

const study = {
  id: null,
  state: null,
  tick: null, // the latest tick the trial's view reported
  queue: [], // events not sent yet
  sending: false,
  unsent: 0, // events taken from the queue whose request has not been answered
  focused: null, // whether the participant's window has focus, as last logged
  trial: null, // {step, frame, matchId, matchName, finishing}
};

const encoder = new TextEncoder();

/** A request to the study API: {status, ok, body} (body: the JSON answer or null). It is
 * sent to its end even if the page goes away meanwhile (`keepalive`). */
async function api(method, path, body) {
  const response = await fetch(path, {
    method,
    cache: 'no-store',
    credentials: 'same-origin',
    keepalive: method === 'POST',
    headers: body === undefined ? {} : { 'Content-Type': 'application/json' },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  let answer = null;
  try {
    answer = await response.json();
  } catch {
    // not JSON: the status says enough
  }
  return { status: response.status, ok: response.ok, body: answer };
}

function showError(text) {
  const node = $('#study-error');
  node.hidden = !text;
  setText(node, text || '');
}

const participantPath = (suffix = '') => `/api/study/participants/${encodeURIComponent(study.id)}${suffix}`;

// ---- the event log ----

/** Logs one event of this page (the step shown and the latest tick are added). */
function logEvent(kind, fields = {}) {
  study.queue.push({ wall_ms: Date.now(), tick: study.tick, step: study.state?.step ?? null, kind, ...fields });
}

/** The queued events as batches of at most BATCH_BYTES, taken off the queue. */
function takeBatches() {
  const batches = [];
  let events = [];
  let bytes = 16;
  for (let event of study.queue) {
    let size = encoder.encode(JSON.stringify(event)).length + 1;
    if (size > BATCH_BYTES - 16) {
      // Only a huge percepts snapshot gets here: its facts are dropped, the fact that it came is kept.
      event = { ...event, add: [], del: [], truncated: true };
      size = encoder.encode(JSON.stringify(event)).length + 1;
    }
    if ((bytes + size > BATCH_BYTES || events.length >= BATCH_EVENTS) && events.length) {
      batches.push(events);
      events = [];
      bytes = 16;
    }
    events.push(event);
    bytes += size;
  }
  if (events.length) batches.push(events);
  study.queue = [];
  return batches;
}

/** Sends the queued events; those not taken are queued again, in order. */
async function flush() {
  checkFocus();
  if (!study.id || study.sending || study.queue.length === 0) return;
  study.sending = true;
  const batches = takeBatches();
  study.unsent = batches.reduce((n, events) => n + events.length, 0);
  try {
    while (batches.length) {
      const { ok, status } = await api('POST', participantPath('/events'), { events: batches[0] });
      if (!ok && status >= 500) throw new Error(`HTTP ${status}`);
      study.unsent -= batches.shift().length; // sent (or refused for good: sending again would not help)
    }
  } catch {
    study.queue = batches.flat().concat(study.queue);
  } finally {
    study.sending = false;
    study.unsent = 0;
  }
}

/** The page goes away: what is left goes with keepalive requests (JSON, with the
 * credential's cookie; a beacon could only be text/plain, which the server refuses). */
function flushOnLeave() {
  if (!study.id) return;
  for (const events of takeBatches()) api('POST', participantPath('/events'), { events }).catch(() => {});
}

/** Logs focus and blur of the participant's window (this page or the trial's frame). */
function checkFocus() {
  const focused = document.hasFocus();
  if (focused === study.focused) return;
  const first = study.focused === null;
  study.focused = focused;
  if (!first) logEvent(focused ? 'focus' : 'blur');
}

// ---- the pages ----

/** Answers the current step; shows the next state (or the current one on a wrong step).
 * Returns the API's answer. */
async function answer(answers) {
  const step = study.state.step;
  const result = await api('POST', participantPath('/answer'), { step, answers });
  if (result.ok) {
    showError('');
    render(result.body);
  } else if (result.status === 409 && result.body?.state && result.body.state.step !== step) {
    render(result.body.state); // answered elsewhere (another tab): go on from there
  } else {
    showError(result.body?.error || `could not send the answer (HTTP ${result.status})`);
  }
  return result;
}

/** A block of the study's own HTML (written by the study's authors). */
function html(text) {
  const node = el('div', { class: 'html' });
  node.innerHTML = text || '';
  return node;
}

/** A button that logs its click before doing what it does. */
function button(id, label, onClick, extra = {}) {
  return el(
    'button',
    {
      type: 'button',
      id,
      ...extra,
      onclick: (event) => {
        logEvent('click', { target: id });
        onClick(event);
      },
    },
    label,
  );
}

function renderConsent(p) {
  return [
    el('h2', {}, p.title || 'Consent'),
    html(p.html),
    el(
      'div',
      { class: 'actions' },
      button('consent-agree', p.agree || 'I agree', () => answer({ consent: true })),
      button('consent-decline', p.decline || 'I do not agree', () => answer({ consent: false }), { class: 'secondary' }),
    ),
  ];
}

function renderInstructions(p) {
  return [el('h2', {}, p.title || 'Instructions'), html(p.html), el('div', { class: 'actions' }, button('continue', 'Continue', () => answer({})))];
}

// ---- questionnaires ----

/** The server's limit on a text answer, in characters, when the item sets none. */
const MAX_TEXT = 10_000;
/** A text's character counter shows from this share of its limit. */
const COUNTER_FROM = 0.8;
/** Where a questionnaire's unsent answers are kept (this tab only), so a reload keeps them. */
const draftKey = () => `bw4t-study-draft:${study.id}:${study.state.step}`;

/** A radio input's name: the item's, and a matrix row's key after it. */
const radioName = (item, rowKey) => (rowKey === undefined ? `item-${item.id}` : `item-${item.id}-${rowKey}`);

/** The value of the checked radio button named `name` in `form`, or undefined. */
function checkedValue(form, name) {
  return form.querySelector(`input[name="${CSS.escape(name)}"]:checked`)?.value;
}

/** A number's range in words, as the server says it: "a whole number from 18 to 99". */
function numberRange(item) {
  const what = item.integer ? 'a whole number' : 'a number';
  const [min, max] = [item.min ?? null, item.max ?? null];
  if (min !== null && max !== null) return `${what} from ${min} to ${max}`;
  if (min !== null) return `${what} of at least ${min}`;
  if (max !== null) return `${what} of at most ${max}`;
  return what;
}

/** A matrix: one row of radio buttons per statement, a column per scale point or option. */
function renderMatrix(item) {
  const choices = item.options ? item.options.map((o) => [o, o]) : Array.from({ length: item.scale || 7 }, (_, i) => [String(i + 1), String(i + 1)]);
  const head = el('tr', {}, el('td', {}), ...choices.map(([, label]) => el('th', { scope: 'col' }, label)));
  const body = item.rows.map((row) =>
    el(
      'tr',
      { dataset: { row: row.key } },
      el('th', { scope: 'row' }, row.text),
      ...choices.map(([value, label]) => el('td', {}, el('input', { type: 'radio', name: radioName(item, row.key), value, 'aria-label': `${row.text}: ${label}` }))),
    ),
  );
  const [left, right] = item.labels || ['', ''];
  const ends = left || right ? el('div', { class: 'matrix-ends' }, el('span', {}, left), el('span', {}, right)) : '';
  return [ends, el('div', { class: 'matrix-scroll' }, el('table', { class: 'matrix' }, el('thead', {}, head), el('tbody', {}, ...body)))];
}

/** One questionnaire item as a fieldset; its value is read back by `itemValue`. */
function renderItem(item) {
  const name = radioName(item);
  const legend = el('legend', {}, item.text, item.required ? el('span', { class: 'required', title: 'required' }, ' *') : '');
  const box = el('fieldset', { class: `item ${item.kind}`, dataset: { item: item.id, kind: item.kind } }, legend);
  if (item.kind === 'likert') {
    const scale = item.scale || 7;
    const [left, right] = item.labels || ['', ''];
    const row = el('div', { class: 'likert', role: 'radiogroup' }, el('span', { class: 'end' }, left));
    for (let v = 1; v <= scale; v++) {
      row.append(el('label', {}, el('input', { type: 'radio', name, value: String(v), 'aria-label': `${v} of ${scale}` }), String(v)));
    }
    row.append(el('span', { class: 'end' }, right));
    box.append(row);
  } else if (item.kind === 'choice') {
    const list = el('div', { class: 'choice' });
    for (const option of item.options || []) list.append(el('label', {}, el('input', { type: 'radio', name, value: option }), ` ${option}`));
    box.append(list);
  } else if (item.kind === 'matrix') {
    box.append(...renderMatrix(item));
  } else if (item.kind === 'number') {
    const input = el('input', { type: 'number', name, step: item.integer ? '1' : 'any', inputmode: item.integer ? 'numeric' : 'decimal', 'aria-label': item.text });
    if (item.min != null) input.min = String(item.min);
    if (item.max != null) input.max = String(item.max);
    box.append(el('div', { class: 'number' }, input, item.unit ? el('span', { class: 'unit' }, ` ${item.unit}`) : ''));
  } else {
    const limit = item.maxlength || MAX_TEXT;
    const input = item.multiline ? el('textarea', { name, rows: '4' }) : el('input', { type: 'text', name });
    input.setAttribute('aria-label', item.text);
    input.maxLength = limit;
    box.append(input, el('p', { class: 'counter', hidden: '', 'aria-live': 'polite' }));
  }
  box.append(el('p', { class: 'missing', hidden: '' }, 'Please answer this.'));
  return box;
}

/** A text item's counter: shown near its limit. */
function updateCounter(box, item) {
  const counter = box.querySelector('.counter');
  if (!counter) return;
  const limit = item.maxlength || MAX_TEXT;
  const length = box.querySelector('input, textarea').value.length;
  counter.hidden = length < limit * COUNTER_FROM;
  setText(counter, `${length} of ${limit} characters`);
}

/** An item's value in the form, or undefined when not answered (a matrix: its answered
 * rows, by key). */
function itemValue(form, item) {
  const name = radioName(item);
  if (item.kind === 'likert') {
    const checked = checkedValue(form, name);
    return checked === undefined ? undefined : Number(checked);
  }
  if (item.kind === 'choice') return checkedValue(form, name);
  if (item.kind === 'matrix') {
    const rows = {};
    for (const row of item.rows) {
      const checked = checkedValue(form, radioName(item, row.key));
      if (checked !== undefined) rows[row.key] = item.options ? checked : Number(checked);
    }
    return Object.keys(rows).length ? rows : undefined;
  }
  const input = form.querySelector(`[name="${CSS.escape(name)}"]`);
  if (item.kind === 'number') return input.value === '' ? undefined : Number(input.value);
  const value = input.value.trim();
  return value === '' ? undefined : value;
}

/** Puts a (draft's) value back into the form. */
function setItemValue(form, item, value) {
  const check = (name, v) => {
    const input = form.querySelector(`input[name="${CSS.escape(name)}"][value="${CSS.escape(String(v))}"]`);
    if (input) input.checked = true;
  };
  if (item.kind === 'likert' || item.kind === 'choice') check(radioName(item), value);
  else if (item.kind === 'matrix') for (const [key, v] of Object.entries(value || {})) check(radioName(item, key), v);
  else {
    const input = form.querySelector(`[name="${CSS.escape(radioName(item))}"]`);
    if (input) input.value = String(value);
  }
}


/** The shown items' values (by id), each item shown or hidden as its `show_if` says: an
 * item is shown when the earlier item it names is shown and has one of its answers
 * (numbers compare by value, 4 is 4.0, as on the server). */
function showItems(form, items) {
  const values = {};
  for (const item of items) {
    const rule = item.show_if;
    const shown = !rule || (values[rule.item] !== undefined && rule.in.includes(values[rule.item]));
    const box = form.querySelector(`fieldset[data-item="${CSS.escape(item.id)}"]`);
    box.hidden = !shown;
    if (shown) values[item.id] = itemValue(form, item);
  }
  return values;
}

/** Marks an item as missing or wrong (`why`, or not: null). */
function markItem(form, itemId, why) {
  const box = form.querySelector(`fieldset[data-item="${CSS.escape(itemId)}"]`);
  if (!box) return;
  box.setAttribute('aria-invalid', String(Boolean(why)));
  const note = box.querySelector('.missing');
  note.hidden = !why;
  if (why) setText(note, why);
}

/** What is wrong with a shown item's value in the form (null: nothing). */
function itemProblem(form, item, value) {
  if (item.kind === 'number') {
    const input = form.querySelector(`[name="${CSS.escape(radioName(item))}"]`);
    const v = input.validity;
    if (v.badInput || v.rangeUnderflow || v.rangeOverflow || v.stepMismatch) return `Please give ${numberRange(item)}.`;
  }
  if (item.required === false) return null;
  if (value === undefined) return 'Please answer this.';
  if (item.kind === 'matrix' && item.rows.some((row) => value[row.key] === undefined)) return 'Please answer every row.';
  return null;
}

function renderQuestionnaire(p) {
  const items = p.items || [];
  const form = el('form', { id: 'questionnaire', novalidate: '' }, ...items.map(renderItem));
  form.append(el('div', { class: 'actions' }, el('button', { type: 'submit', id: 'questionnaire-submit' }, 'Continue')));
  // A reload keeps what was filled in and not yet sent.
  let draft = {};
  try {
    draft = JSON.parse(sessionStorage.getItem(draftKey()) || '{}') || {};
  } catch {
    // an unreadable draft is no draft
  }
  for (const item of items) if (draft[item.id] !== undefined) setItemValue(form, item, draft[item.id]);
  showItems(form, items);
  for (const item of items) updateCounter(form.querySelector(`fieldset[data-item="${CSS.escape(item.id)}"]`), item);
  form.dataset.draft = Object.keys(draft).length ? 'restored' : 'none';
  // An item answered after a refused submit is no longer marked; the draft is kept.
  form.addEventListener('input', (event) => {
    const box = event.target.closest('fieldset[data-item]');
    const item = items.find((i) => i.id === box?.dataset.item);
    if (item) updateCounter(box, item);
    if (box?.getAttribute('aria-invalid') === 'true') markItem(form, box.dataset.item, null);
    // Every missing answer given: the reminder goes.
    if (!form.querySelector('fieldset[aria-invalid="true"]')) showError('');
    const values = {};
    for (const i of items) {
      const value = itemValue(form, i);
      if (value !== undefined) values[i.id] = value;
    }
    showItems(form, items);
    sessionStorage.setItem(draftKey(), JSON.stringify(values));
  });
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    logEvent('click', { target: 'questionnaire-submit' });
    const key = draftKey();
    const answers = showItems(form, items);
    let firstWrong = null;
    for (const item of items) {
      const shown = !form.querySelector(`fieldset[data-item="${CSS.escape(item.id)}"]`).hidden;
      const why = shown ? itemProblem(form, item, answers[item.id]) : null;
      markItem(form, item.id, why);
      if (why && !firstWrong) firstWrong = item;
      if (answers[item.id] === undefined) delete answers[item.id];
    }
    if (firstWrong) {
      // Missing answers, as always; else (a number out of range) the item says what it needs.
      const notes = [...form.querySelectorAll('fieldset[aria-invalid="true"] .missing')].map((n) => n.textContent);
      const missing = notes.every((note) => note === 'Please answer this.');
      showError(missing ? 'Please answer every question marked *.' : 'Please check the questions marked in red.');
      form.querySelector(`fieldset[data-item="${CSS.escape(firstWrong.id)}"] :is(input, textarea)`)?.focus();
      return;
    }
    const result = await answer(answers);
    if (result.ok) sessionStorage.removeItem(key);
    // The server names an item it refused: mark it with its words.
    if (result.status === 400) {
      for (const item of items) if (result.body?.error?.includes(`'${item.id}'`)) markItem(form, item.id, result.body.error);
    }
  });
  return [el('h2', {}, p.title || 'Questionnaire'), p.html ? html(p.html) : '', form];
}

/** A trial: the briefing, and the player view of the condition in a frame, joined with
 * the hello the state gives. */
function renderTrial(p) {
  // A trial under way: the state names its match and the robot's session (any page of the
  // participant's, a reload or a new tab, takes the robot back with them).
  const hello = { ...(p.hello || {}) };
  if (!hello.match) {
    // Reloaded before the server heard of the match: back into it from what this browser kept.
    let kept = null;
    try {
      kept = JSON.parse(localStorage.getItem(trialKey()) || 'null');
    } catch {
      kept = null;
    }
    if (kept && kept.step === study.state.step && kept.match) hello.match = kept.match;
  }
  const view = p.view === 'overview' ? '&view=overview' : '';
  const src = `/?embed=study${view}&hello=${encodeURIComponent(JSON.stringify(hello))}`;
  const frame = el('iframe', { id: 'trial-frame', src, title: 'the task', allow: 'fullscreen' });
  study.trial = { step: study.state.step, frame, matchId: null, matchName: null, rejoining: hello.match || null, finishing: false };
  frame.addEventListener('load', () => frame.focus());
  // The count shows once: as the heading, or beside a heading of the study's own.
  const counted = `Task ${p.trial} of ${p.trials}`;
  const head = el(
    'div',
    { id: 'trial-head' },
    el('h2', {}, p.title || counted),
    p.html ? html(p.html) : '',
    p.title && p.title !== counted ? el('span', { class: 'note' }, counted) : '',
  );
  const over = el('div', { id: 'trial-over', hidden: '' });
  return [head, frame, over];
}

/** The trial's match as the API takes it: its name, and its id (`welcome.match.id`) when
 * the server gave one (without, the server finds it by the name). */
function trialMatch(trial) {
  return { ...(trial.matchName ? { match: trial.matchName } : {}), ...(trial.matchId ? { match_id: trial.matchId } : {}) };
}

/** The trial's match has ended: answer the trial with its match (again while the server
 * has not seen the end yet), then offer to go on. */
async function finishTrial() {
  const trial = study.trial;
  if (!trial || trial.finishing || trial.step !== study.state?.step) return;
  trial.finishing = true;
  const over = $('#trial-over');
  over.hidden = false;
  over.replaceChildren(el('p', {}, 'The task is over. Thank you — saving…'));
  await flush();
  if (!trial.matchName && !trial.matchId) {
    over.replaceChildren(el('p', {}, 'The task ended before it started. Please reload the page.'));
    return;
  }
  const deadline = performance.now() + TRIAL_ANSWER_MS;
  for (;;) {
    const result = await api('POST', participantPath('/answer'), { step: trial.step, answers: trialMatch(trial) });
    if (result.ok) {
      localStorage.removeItem(trialKey());
      const next = result.body;
      over.replaceChildren(
        el('p', {}, 'The task is over. Thank you — saved.'),
        button('trial-continue', 'Continue', () => render(next)),
      );
      $('#trial-continue').focus();
      return;
    }
    const stillRunning = result.status === 409 && (!result.body?.state || result.body.state.step === trial.step);
    if (!stillRunning || performance.now() > deadline) {
      if (result.status === 409 && result.body?.state) return render(result.body.state);
      over.replaceChildren(el('p', {}, `Could not save the task: ${result.body?.error || `HTTP ${result.status}`}.`));
      return;
    }
    await new Promise((resolve) => setTimeout(resolve, RETRY_MS));
  }
}

/** An event from the trial's view: logged; the match's start and end handled. */
async function onViewEvent(event) {
  const trial = study.trial;
  if (!trial || trial.step !== study.state?.step) return;
  if (event.tick !== null && event.tick !== undefined) study.tick = event.tick;
  // The robot's session is a credential: it goes to the server with the trial, not into the log.
  const { session, ...logged } = event;
  if (VIEW_EVENTS.has(event.kind)) study.queue.push({ ...logged, step: trial.step });
  if (event.kind === 'welcome') {
    trial.matchId = event.match?.id ?? null;
    trial.matchName = event.match?.name ?? null;
    localStorage.setItem(trialKey(), JSON.stringify({ step: trial.step, match: trial.matchName }));
    // Back in the match after a reload: its start is recorded already.
    if (trial.rejoining && trial.rejoining === trial.matchName) return;
    const started = { step: trial.step, ...trialMatch(trial), ...(session ? { session } : {}) };
    const result = await api('POST', participantPath('/trial'), started);
    if (!result.ok) console.warn('bw4t study: trial start not recorded', result.status, result.body);
  } else if (event.kind === 'error' && event.code === 'replaced') {
    // Another page of the participant's took the robot: this one steps aside.
    trial.finishing = true;
    const over = $('#trial-over');
    over.hidden = false;
    over.replaceChildren(el('p', { id: 'trial-elsewhere' }, 'This task goes on in another tab or window. You can close this one.'));
    trial.frame.remove();
  } else if (event.kind === 'match_over' || (event.kind === 'bye' && trial.matchName)) {
    finishTrial();
  } else if (event.kind === 'error' && event.fatal && (trial.matchName || trial.rejoining)) {
    // Back after a reload, and the match is gone (or the seat is): the trial is answered
    // with that match, once the server has seen it end.
    trial.matchName = trial.matchName || trial.rejoining;
    finishTrial();
  }
}

function renderFinal(p) {
  const parts = [el('h2', {}, p.title || 'Thank you'), html(p.html)];
  if (p.completion_code) {
    parts.push(el('p', {}, 'Your completion code:'), el('p', {}, el('span', { class: 'code', id: 'completion-code' }, p.completion_code)));
  }
  if (p.redirect) {
    parts.push(el('p', { class: 'note' }, 'You will be taken back in a few seconds, or ', el('a', { href: p.redirect, id: 'redirect' }, 'go now'), '.'));
    setTimeout(() => {
      flushOnLeave();
      location.assign(p.redirect);
    }, 5000);
  }
  return parts;
}

/** Declined: the text, and the platform's code and way back if the study gives them. */
function renderDeclined(p) {
  return renderFinal(p);
}

const RENDERERS = {
  consent: renderConsent,
  instructions: renderInstructions,
  questionnaire: renderQuestionnaire,
  trial: renderTrial,
  final: renderFinal,
  declined: renderDeclined,
  // A practice round plays as a trial does; a screen-out ends as the final page does.
  practice: renderTrial,
  screened_out: renderFinal,
};

/** Shows the participant's state: its page, and the progress. */
function render(state) {
  study.state = state;
  study.trial = null;
  study.tick = null;
  const p = state.page || {};
  document.body.dataset.kind = p.kind || 'unknown';
  document.body.dataset.step = String(state.step);
  const progress = $('#study-progress');
  progress.dataset.step = String(state.step);
  progress.dataset.steps = String(state.steps);
  setText(progress, `step ${Math.min(state.step + 1, state.steps)} of ${state.steps}`);
  const make = RENDERERS[p.kind] || ((x) => [el('p', {}, `Unknown page: ${x.kind}`)]);
  $('#study-page').replaceChildren(...make(p));
  window.scrollTo(0, 0);
  logEvent('page_shown', { page: p.kind, ...(p.id ? { id: p.id } : {}), ...(p.trial ? { trial: p.trial, condition: p.condition } : {}) });
  $('#study-page').querySelector('button, input, textarea')?.focus({ preventScroll: true });
}

// ---- the device ----

/** What the device lacks for the study (`screen`: GET /api/study's), in words, or null
 * when it has what the study needs. The screen is the device's (a window smaller than its
 * screen can be made larger). Touch-only: a touch screen and no fine pointer. */
function deviceShortfall(screenNeeds) {
  if (!screenNeeds) return null;
  const width = Math.max(window.screen.width, window.innerWidth);
  const height = Math.max(window.screen.height, window.innerHeight);
  const small = width < screenNeeds.min_width || height < screenNeeds.min_height;
  const touchOnly = navigator.maxTouchPoints > 0 && !window.matchMedia('(any-pointer: fine)').matches;
  if (!small && (screenNeeds.allow_touch_only || !touchOnly)) return null;
  return { small, touchOnly, width, height };
}

/** The page for a device the study cannot be done on: what it needs, plainly. */
function renderScreenOut(screenNeeds, shortfall) {
  document.body.dataset.kind = 'screen-out';
  const needs = `a screen of at least ${screenNeeds.min_width} × ${screenNeeds.min_height} pixels`;
  const pointer = screenNeeds.allow_touch_only ? '' : ' and a keyboard and mouse (or touchpad)';
  const why = [];
  if (shortfall.small) why.push(`This screen is ${shortfall.width} × ${shortfall.height} pixels.`);
  if (shortfall.touchOnly && !screenNeeds.allow_touch_only) why.push('This device seems to have only a touch screen.');
  $('#study-page').replaceChildren(
    el('h2', {}, 'This study needs a computer'),
    el('p', { id: 'screen-needs' }, `This study needs a computer with ${needs}${pointer}.`),
    el('p', { class: 'note' }, why.join(' ')),
    el('p', {}, 'Please open the same link on such a computer. Nothing has been recorded.'),
    el('div', { class: 'actions' }, el('button', { type: 'button', id: 'screen-again', onclick: () => location.reload() }, 'Check again')),
  );
}

// ---- start ----

/** An MTurk preview: what the study is, and that accepting the task starts it; no
 * participant is made. */
function renderPreview(info) {
  document.body.dataset.kind = 'preview';
  const title = info?.title || info?.name || 'Study';
  $('#study-page').replaceChildren(
    el('h2', {}, title),
    el('p', {}, 'This is a preview. Accept the task to take part: the study starts with a consent form.'),
  );
}

async function start() {
  const query = new URLSearchParams(location.search);
  const params = Object.fromEntries(query);
  if (!ID_PARAMS.some((key) => query.get(key))) {
    // A reload without the id in the address (or a new tab): the one this browser has.
    const stored = sessionStorage.getItem(STORE_KEY);
    if (stored) params.participant = stored;
  }
  let info = null;
  try {
    const { ok, body } = await api('GET', '/api/study');
    if (ok && body) info = body;
  } catch {
    // the arrival below says the server cannot be reached
  }
  if (info) {
    setText($('#study-title'), info.title || info.name || 'Study');
    document.title = info.title || info.name || 'Study';
    // A device the study cannot be done on is turned away before consent: no participant.
    const shortfall = deviceShortfall(info.screen);
    if (shortfall) return renderScreenOut(info.screen, shortfall);
  }
  if (query.get('assignmentId') === 'ASSIGNMENT_ID_NOT_AVAILABLE') return renderPreview(info);
  let result;
  try {
    result = await api('POST', '/api/study/participants', { params });
  } catch (err) {
    return showError(`The study server cannot be reached (${err.message}). Please reload the page.`);
  }
  if (!result.ok) return showError(result.body?.error || `The study could not start (HTTP ${result.status}).`);
  study.id = result.body.participant;
  sessionStorage.setItem(STORE_KEY, study.id);
  history.replaceState(null, '', `/study?participant=${encodeURIComponent(study.id)}`);
  document.body.dataset.participant = study.id;

  window.addEventListener('message', (message) => {
    if (message.origin !== location.origin || !message.data?.bw4t) return;
    if (message.source !== study.trial?.frame.contentWindow) return;
    if (message.data.bw4t === 'event') onViewEvent(message.data.event);
    else if (message.data.bw4t === 'focus') setTimeout(checkFocus, 0);
  });
  for (const type of ['focus', 'blur']) window.addEventListener(type, () => setTimeout(checkFocus, 0));
  document.addEventListener('visibilitychange', () => logEvent('visibility', { state: document.visibilityState }));
  window.addEventListener('pagehide', flushOnLeave);
  setInterval(flush, FLUSH_MS);
  checkFocus();
  render(result.body);
}

/** For tests: how many events are not yet recorded by the server. */
window.bw4tStudy = { pending: () => study.queue.length + study.unsent };

start();
