// The study dashboard (/study/admin): for the operator (the token typed here or given as
// `?token=`, kept for this tab), the participants and how far each is (GET /api/study/participants, every POLL_MS),
// and for each live trial its match (its tick, and whether it is paused, from
// GET /api/matches): watch it (the page's overview as the operator, in a
// new tab), pause, resume or abort it (POST /api/matches/NAME/pause|resume|stop). Above
// the table: how many participants are in each state and each condition; a filter over
// the rows; and the export (POST /api/study/export, then each CSV file to save).

import { $, el, setText } from './dom.js';
import { OPERATOR_TOKEN_KEY } from './connection.js';

const POLL_MS = 2000;

const dash = {
  conditions: [], // the study's, from GET /api/study
  timer: null,
  polls: 0,
  rows: new Map(), // participant -> <tr>
  matches: new Map(), // live match name -> its summary
};

const token = () => sessionStorage.getItem(OPERATOR_TOKEN_KEY) || '';

function showError(text) {
  const node = $('#study-error');
  node.hidden = !text;
  setText(node, text || '');
}

/** A request with the operator token; the JSON answer, or throws with the API's error. */
async function api(method, path) {
  const headers = { Authorization: `Bearer ${token()}` };
  // The study's POSTs take JSON only (so no other site can send them).
  const body = method === 'POST' ? '{}' : undefined;
  if (body) headers['Content-Type'] = 'application/json';
  const response = await fetch(path, { method, cache: 'no-store', headers, body });
  let answer = null;
  try {
    answer = await response.json();
  } catch {
    // not JSON
  }
  if (!response.ok) throw new Error(answer?.error || `HTTP ${response.status}`);
  return answer;
}

/** A time (ms since the epoch) as its date and time of day. */
const clock = (ms) => (ms ? new Date(ms).toLocaleString() : '');

/** The states a participant can be in, as the summary counts them. */
function stateOf(p) {
  if (p.completed) return 'completed';
  if (p.page_kind === 'declined') return 'declined';
  if (p.page_kind === 'screened_out') return 'screened out';
  if (p.match) return 'in a trial';
  return 'under way';
}

/** The counts above the table: each condition's, and each state's. */
function showSummary(list, conditions) {
  const rows = conditions.map((c) => {
    const assigned = list.filter((p) => (p.conditions || []).includes(c));
    const playing = list.filter((p) => p.condition === c && p.match).length;
    const completed = assigned.filter((p) => p.completed).length;
    return el('tr', { dataset: { condition: c } }, ...[c, assigned.length, playing, completed].map((v) => el('td', {}, String(v))));
  });
  $('#dash-summary tbody').replaceChildren(...rows);
  const counts = new Map();
  for (const p of list) counts.set(stateOf(p), (counts.get(stateOf(p)) || 0) + 1);
  const said = [...counts].map(([state, n]) => `${n} ${state}`).join(' · ');
  setText($('#dash-states'), `${list.length} participants${said ? `: ${said}` : ''}`);
}

/** Shows only the rows whose text has the filter's words. */
function applyFilter() {
  const words = $('#dash-filter').value.trim().toLowerCase().split(/\s+/).filter(Boolean);
  for (const row of dash.rows.values()) {
    const text = row.textContent.toLowerCase();
    row.hidden = !words.every((w) => text.includes(w));
  }
}

/** Exports now, then offers each CSV file to save (fetched with the token). */
async function exportNow() {
  const files = $('#dash-files');
  setText(files, 'exporting…');
  try {
    const made = await api('POST', '/api/study/export');
    const links = made.files.map((file) =>
      el('a', { href: '#', class: 'export-file', dataset: { file }, onclick: (event) => { event.preventDefault(); save(file); } }, file),
    );
    files.replaceChildren(`${made.participants} participants, ${made.trials} trials: `, ...links.flatMap((a, i) => (i ? [' ', a] : [a])));
    showError('');
  } catch (err) {
    setText(files, '');
    showError(`export: ${err.message}`);
  }
}

/** Saves one file of the export. */
async function save(file) {
  const response = await fetch(`/api/study/export/${encodeURIComponent(file)}`, { cache: 'no-store', headers: { Authorization: `Bearer ${token()}` } });
  if (!response.ok) return showError(`${file}: HTTP ${response.status}`);
  const url = URL.createObjectURL(await response.blob());
  const name = /filename="([^"]+)"/.exec(response.headers.get('Content-Disposition') || '')?.[1] || file;
  const link = el('a', { href: url, download: name });
  document.body.append(link);
  link.click();
  link.remove();
  URL.revokeObjectURL(url);
}

/** Pauses, resumes or stops a match, then polls at once. */
async function control(match, verb) {
  if (verb === 'stop' && !window.confirm(`Abort match ${match}? The trial ends without a result.`)) return;
  try {
    await api('POST', `/api/matches/${encodeURIComponent(match)}/${verb}`);
    showError('');
  } catch (err) {
    showError(`${verb} ${match}: ${err.message}`);
  }
  poll();
}

/** The cells of one participant's row. */
function cells(p) {
  const match = p.match || '';
  const live = dash.matches.get(match);
  const paused = live?.paused === true;
  const controls = match
    ? [
        el('span', { class: 'note live' }, live ? `${paused ? 'paused' : live.state} at tick ${live.tick} ` : ''),
        el('a', { href: `/?match=${encodeURIComponent(match)}&operator_token=${encodeURIComponent(token())}`, target: '_blank', rel: 'noopener', class: 'watch' }, 'watch'),
        ' ',
        el('button', { type: 'button', class: 'pause', ...(paused ? { disabled: '' } : {}), onclick: () => control(match, 'pause') }, 'pause'),
        ' ',
        el('button', { type: 'button', class: 'resume', ...(paused ? {} : { disabled: '' }), onclick: () => control(match, 'resume') }, 'resume'),
        ' ',
        el('button', { type: 'button', class: 'abort secondary', onclick: () => control(match, 'stop') }, 'abort'),
      ]
    : [];
  return [
    p.participant,
    `${Math.min(p.step + 1, p.steps)} / ${p.steps}`,
    p.page_kind || '',
    p.condition || '',
    match,
    p.completed ? 'yes' : '',
    clock(p.started_ms),
    clock(p.last_ms),
    controls,
  ];
}

/** The table from one answer; rows are kept, and remade only when they change. */
function showParticipants(list) {
  const body = $('#participants tbody');
  const seen = new Set();
  for (const p of list) {
    seen.add(p.participant);
    const live = dash.matches.get(p.match);
    const key = JSON.stringify([p.step, p.steps, p.page_kind, p.condition, p.match, p.completed, p.started_ms, p.last_ms, live?.paused, live?.tick, live?.state]);
    let row = dash.rows.get(p.participant);
    if (!row) {
      row = el('tr', { dataset: { participant: p.participant } });
      dash.rows.set(p.participant, row);
    }
    body.append(row); // in the server's order
    if (row.dataset.key === key) continue;
    row.dataset.key = key;
    row.dataset.step = String(p.step);
    row.dataset.page = p.page_kind || '';
    row.dataset.match = p.match || '';
    row.dataset.paused = String(live?.paused === true);
    row.dataset.completed = String(Boolean(p.completed));
    row.replaceChildren(...cells(p).map((content) => el('td', {}, ...(Array.isArray(content) ? content : [String(content)]))));
  }
  for (const [id, row] of dash.rows) {
    if (!seen.has(id)) {
      row.remove();
      dash.rows.delete(id);
    }
  }
  $('#participants-empty').hidden = list.length > 0;
}

/** Asks for the participants now, and again in POLL_MS. */
async function poll() {
  clearTimeout(dash.timer);
  dash.timer = null;
  if (!token()) return;
  try {
    const [answer, matches] = await Promise.all([api('GET', '/api/study/participants'), api('GET', '/api/matches').catch(() => null)]);
    const list = Array.isArray(matches) ? matches : matches?.matches || [];
    dash.matches = new Map(list.map((m) => [m.name, m]));
    showParticipants(answer.participants || []);
    showSummary(answer.participants || [], dash.conditions);
    applyFilter();
    dash.polls += 1;
    const status = $('#dash-status');
    status.dataset.polls = String(dash.polls);
    setText(status, `updated ${new Date().toLocaleTimeString()}`);
    showError('');
  } catch (err) {
    showError(`participants: ${err.message}`);
  }
  clearTimeout(dash.timer);
  dash.timer = setTimeout(poll, POLL_MS);
}

function showTokenForm() {
  const has = Boolean(token());
  $('#dash-token-forget').hidden = !has;
  $('#dash-token').placeholder = has ? 'operator token (set)' : 'operator token';
}

function start() {
  // `?token=` (the link the server prints): kept for this tab, and taken out of the address.
  const query = new URLSearchParams(location.search);
  if (query.get('token')) {
    sessionStorage.setItem(OPERATOR_TOKEN_KEY, query.get('token'));
    history.replaceState(null, '', location.pathname);
  }
  $('#dash-token-form').addEventListener('submit', (event) => {
    event.preventDefault();
    const value = $('#dash-token').value.trim();
    if (!value) return;
    sessionStorage.setItem(OPERATOR_TOKEN_KEY, value);
    $('#dash-token').value = '';
    showTokenForm();
    poll();
  });
  $('#dash-token-forget').addEventListener('click', () => {
    sessionStorage.removeItem(OPERATOR_TOKEN_KEY);
    showTokenForm();
    clearTimeout(dash.timer);
    showParticipants([]);
  });
  fetch('/api/study', { cache: 'no-store' })
    .then((r) => (r.ok ? r.json() : null))
    .then((s) => {
      if (!s) return;
      setText($('#study-title'), `${s.title || s.name} · dashboard`);
      setText($('#dash-conditions'), `conditions: ${(s.conditions || []).join(', ')}`);
      dash.conditions = s.conditions || [];
    })
    .catch(() => {});
  $('#dash-filter').addEventListener('input', applyFilter);
  $('#dash-export').addEventListener('click', exportNow);
  showTokenForm();
  poll();
}

start();
