// The lobby: the server's matches (`GET /api/matches`, asked again every POLL_MS while the
// page is visible) to watch or join, the templates from `/info.json` to join by, and for
// the operator (a token typed here, kept for this tab) seeds, Stop and a form for a new
// match. Watching and playing open the match's own view: `/?match=NAME` (with `play=` for
// a player) or `/?template=NAME&play=` (the server picks the match).

import { $, el, linkTo, params, setText } from './dom.js';
import { setView } from './page.js';
import { setStatus } from './panels.js';
import { OPERATOR_TOKEN_KEY, TOKEN_PARAMS } from './connection.js';

const POLL_MS = 1500;
const NAME_KEY = 'bw4t-player-name';
const NAME_PATTERN = /^[A-Za-z][A-Za-z0-9]*$/;

const lobby = {
  timer: null, // the next poll
  inFlight: false, // a poll is waiting for its answer
  again: false, // poll once more when it comes (something changed meanwhile)
  polls: 0, // answers shown
  rows: new Map(), // row key -> <tr>, reused between polls
};

/** An answer of the API that is not 2xx: its status and the `error` it gave. */
class ApiError extends Error {
  constructor(status, message) {
    super(message);
    this.status = status;
  }
}

/** The operator token typed into the lobby (or given as `?operator_token=`), if any. */
const lobbyToken = () => sessionStorage.getItem(OPERATOR_TOKEN_KEY) || '';

/** A request to the API, with the operator token when there is one (`anonymous`: never). */
async function api(method, path, { body, anonymous = false } = {}) {
  const headers = {};
  const token = anonymous ? '' : lobbyToken();
  if (token) headers.Authorization = `Bearer ${token}`;
  if (body !== undefined) headers['Content-Type'] = 'application/json';
  const response = await fetch(path, {
    method,
    headers,
    cache: 'no-store',
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  let answer = null;
  try {
    answer = await response.json();
  } catch {
    // not JSON: the status says enough
  }
  if (!response.ok) throw new ApiError(response.status, answer?.error || `HTTP ${response.status}`);
  return answer;
}

/** A line under the operator's controls: what the API refused (or '' to clear it), and
 * what it did. */
function showApiError(text) {
  const node = $('#api-error');
  node.hidden = !text;
  setText(node, text);
}

function showApiNote(text) {
  setText($('#api-note'), text);
}

/** Opens the lobby: the templates once, the matches now and then. */
export function startLobby(info) {
  setView('lobby');
  setStatus('loading');
  $('#lobby-link').hidden = true;
  showTemplates(info.templates || []);

  const name = $('#lobby-name');
  name.value = sessionStorage.getItem(NAME_KEY) || '';
  $('#lobby-name-form').addEventListener('submit', (event) => {
    event.preventDefault();
    playerName();
  });

  if (params.get(TOKEN_PARAMS.operator) && !lobbyToken()) {
    sessionStorage.setItem(OPERATOR_TOKEN_KEY, params.get(TOKEN_PARAMS.operator));
  }
  $('#operator-token').value = lobbyToken();
  $('#operator-form').addEventListener('submit', (event) => {
    event.preventDefault();
    useOperatorToken($('#operator-token').value.trim());
  });
  $('#operator-forget').addEventListener('click', () => {
    $('#operator-token').value = '';
    useOperatorToken('');
  });
  $('#new-match').addEventListener('submit', (event) => {
    event.preventDefault();
    createMatch();
  });
  showOperator();

  // Asking while nobody looks is wasted: stop when the page is hidden, ask at once when back.
  document.addEventListener('visibilitychange', () => {
    if (document.hidden) {
      clearTimeout(lobby.timer);
      lobby.timer = null;
    } else {
      poll();
    }
  });
  poll();
}

/** Asks for the matches and shows them, then again after POLL_MS (unless hidden). */
async function poll() {
  clearTimeout(lobby.timer);
  lobby.timer = null;
  if (lobby.inFlight) {
    lobby.again = true;
    return;
  }
  lobby.inFlight = true;
  try {
    let answer;
    try {
      answer = await api('GET', '/api/matches');
    } catch (err) {
      if (!(err instanceof ApiError && err.status === 401 && lobbyToken())) throw err;
      // A wrong operator token: say so, and show what anyone may see.
      showApiError(`operator token refused: ${err.message}`);
      answer = await api('GET', '/api/matches', { anonymous: true });
    }
    showMatches(answer.matches || []);
    setStatus('lobby');
  } catch (err) {
    setStatus('error', err.message);
  } finally {
    lobby.inFlight = false;
    if (lobby.again) {
      lobby.again = false;
      poll();
    } else if (!document.hidden) {
      lobby.timer = setTimeout(poll, POLL_MS);
    }
  }
}

/** A match's row is its own while it lives; a finished one (its name may live again) is another. */
const rowKey = (m) => `${m.state === 'finished' ? 'finished' : 'live'}:${m.name}:${m.run ?? ''}`;

/** The table of matches, live ones first (in the server's order), rows reused. */
function showMatches(matches) {
  const live = matches.filter((m) => m.state !== 'finished');
  const finished = matches.filter((m) => m.state === 'finished');
  const operator = Boolean(lobbyToken());
  const body = $('#matches tbody');
  const rows = new Map();
  const ordered = [...live, ...finished].map((m) => {
    const key = rowKey(m);
    const row = rows.get(key) || lobby.rows.get(key) || newRow();
    rows.set(key, row);
    showRow(row, m, operator);
    return row;
  });
  lobby.rows = rows;
  ordered.forEach((row, i) => {
    if (body.children[i] !== row) body.insertBefore(row, body.children[i] || null);
  });
  while (body.children.length > ordered.length) body.lastElementChild.remove();
  $('#matches-empty').hidden = ordered.length > 0;
  const table = $('#matches');
  table.classList.toggle('operator', operator);
  lobby.polls += 1;
  table.dataset.polls = String(lobby.polls);
  showMapChoices(matches);
}

const COLUMNS = ['name', 'template', 'map', 'state', 'players', 'tick', 'progress', 'seed', 'actions'];

function newRow() {
  return el('tr', {}, ...COLUMNS.map((column) => el('td', { class: column === 'seed' ? `${column} operator-only` : column })));
}

/** One match's row: its summary as text (and data- attributes for tests), its buttons. */
function showRow(row, m, operator) {
  const cell = Object.fromEntries(COLUMNS.map((column, i) => [column, row.children[i]]));
  const players = m.players || [];
  const [delivered, length] = m.sequence || [0, 0];
  const awaited = m.awaited ?? 0;
  Object.assign(row.dataset, {
    name: m.name,
    state: m.state,
    template: m.template || '',
    map: m.map || '',
    players: players.join(','),
    awaited: String(awaited),
    tick: String(m.tick ?? 0),
    delivered: String(delivered),
    endReason: m.end_reason || '',
    seed: m.seed !== undefined ? String(m.seed) : '',
  });
  setText(cell.name, m.name);
  setText(cell.template, m.template || '');
  setText(cell.map, m.map || '');
  setText(cell.state, m.state === 'finished' ? `finished: ${m.end_reason || '?'}` : m.state);
  const who = players.join(', ') || '–';
  setText(cell.players, awaited > 0 ? `${who} (${awaited} more awaited)` : who);
  cell.players.title = `${players.length} of ${m.robots ?? '?'} robots`;
  setText(cell.tick, m.tick ?? 0);
  setText(cell.progress, `${delivered}/${length}`);
  setText(cell.seed, m.seed ?? '');

  // Buttons are made again only when what they offer changes, so a click is never lost
  // to a poll.
  const live = m.state !== 'finished';
  const full = m.robots !== undefined && players.length >= m.robots;
  const offer = `${live} ${full} ${operator} ${m.watch}`;
  if (cell.actions.dataset.offer === offer) return;
  cell.actions.dataset.offer = offer;
  const buttons = [];
  if (live) {
    const watch = el('a', { class: 'watch button', href: linkTo({ match: m.name }) }, 'Watch');
    if (m.watch === 'token') watch.title = 'watching this match needs a spectator (or the operator) token';
    const join = el('button', { type: 'button', class: 'play', onclick: () => play({ match: m.name }) }, 'Play');
    if (full) {
      join.disabled = true;
      join.title = 'every seat is taken';
    }
    buttons.push(watch, join);
    if (operator) buttons.push(el('button', { type: 'button', class: 'stop', onclick: () => stopMatch(m.name) }, 'Stop'));
  }
  cell.actions.replaceChildren(...buttons);
}

/** The templates to join by, each with its Play. */
function showTemplates(templates) {
  $('#templates-box').hidden = templates.length === 0;
  for (const t of templates) addMapChoice(t.map);
  $('#templates').replaceChildren(
    ...templates.map((t) =>
      el(
        'li',
        { dataset: { template: t.name } },
        el('b', {}, t.name),
        ` ${t.map ?? ''}${t.robots ? `, ${t.robots} robots` : ''} `,
        el('button', { type: 'button', class: 'play', onclick: () => play({ template: t.name }) }, 'Play'),
      ),
    ),
  );
}

/** The name typed to play with (kept for this tab), or null after saying what is wrong. */
function playerName() {
  const input = $('#lobby-name');
  const name = input.value.trim();
  const error = $('#lobby-name-error');
  if (!NAME_PATTERN.test(name)) {
    error.hidden = false;
    setText(error, 'Type your name first: letters and digits, starting with a letter.');
    input.focus();
    return null;
  }
  error.hidden = true;
  sessionStorage.setItem(NAME_KEY, name);
  return name;
}

/** Opens the player's view of a match (`{match}`) or of a template's next seat (`{template}`). */
function play(where) {
  const name = playerName();
  if (name) location.assign(linkTo({ ...where, play: name }));
}

/** Keeps the operator token for this tab ('' forgets it) and shows what it allows. */
function useOperatorToken(token) {
  if (token) sessionStorage.setItem(OPERATOR_TOKEN_KEY, token);
  else sessionStorage.removeItem(OPERATOR_TOKEN_KEY);
  showApiError('');
  showApiNote('');
  showOperator();
  poll();
}

/** The operator's parts of the lobby: shown with a token. */
function showOperator() {
  const operator = Boolean(lobbyToken());
  $('#new-match').hidden = !operator;
  $('#operator-forget').hidden = !operator;
  $('#matches').classList.toggle('operator', operator);
}

async function stopMatch(name) {
  try {
    await api('POST', `/api/matches/${encodeURIComponent(name)}/stop`);
    showApiError('');
    showApiNote(`stopped ${name}`);
  } catch (err) {
    showApiError(`could not stop ${name}: ${err.message}`);
  }
  poll();
}

/** Posts the new-match form: only the fields filled in, the server's defaults for the rest. */
async function createMatch() {
  const body = {};
  const text = (id) => $(id).value.trim();
  if (text('#new-name')) body.name = text('#new-name');
  if (text('#new-map')) body.map = text('#new-map');
  if (text('#new-robots')) body.robots = Number(text('#new-robots'));
  if (text('#new-builtin')) body.builtin = Number(text('#new-builtin'));
  if (text('#new-mode')) body.mode = text('#new-mode');
  try {
    const made = await api('POST', '/api/matches', { body });
    showApiError('');
    showApiNote(`created ${made?.name ?? 'a match'}`);
  } catch (err) {
    showApiError(`could not create the match: ${err.message}`);
  }
  poll();
}

/** The maps offered for a new match: those of the templates and of the matches seen. */
function showMapChoices(matches) {
  for (const m of matches) addMapChoice(m.map);
}

function addMapChoice(name) {
  const list = $('#map-choices');
  if (name && ![...list.options].some((o) => o.value === name)) list.append(el('option', { value: name }));
}
