// The human player: a person drives one robot and sees only what its percepts say.
//
// The beliefs are the JavaScript client's own belief base (protocol/clients/js, served at
// /client/), kept exactly as protocol/README.md says: a full snapshot clears them; `not`
// facts are removed, then `add` facts stored; `at`, `state` and `sequenceIndex` are
// single-valued; `message` facts are events, shown once and never stored. The view shows
// only these beliefs and the colours of blocks seen earlier, which the player was told
// and may remember (Beliefs.colourOf).

import { Beliefs } from './client/beliefs.js';
import { DURATIVE } from './client/table.js';
import { $, el, linkTo, setText } from './dom.js';
import { loadMap, page, setView } from './page.js';
import { zoneAt } from './geometry.js';
import { colourCss } from './renderer.js';
import { addMessage, endMatch, log, setStatus, setTick, setWatchNote, showMatch, showSequence } from './panels.js';
import { helloFor, openSocket } from './connection.js';
import { spectator, startSpectator, stopSpectator } from './spectator.js';
import { hideWaiting, showLobby, showRefusal } from './waiting.js';

export const player = {
  socket: null,
  name: null,
  robot: null,
  beliefs: new Beliefs(),
  nextId: 1,
  pending: new Map(), // request id -> {words, durative, say}: for the log until answered
  retriedWithName: false,
  template: null, // the template joined by (`?template=`), until a match gives a seat
};

// A session belongs to one match: on a server of many, it is kept under the match's name.
const sessionKey = (name) => `bw4t-session:${location.host}${page.matchName ? `:match=${page.matchName}` : ''}:${name}`;

// Refusals of a player that leave the match to be watched instead.
const REFUSALS = ['invalid_name', 'name_taken', 'match_full', 'bad_token'];

/** Leaves the overview and joins as player `name`: the match `page.matchName` (the
 * server's default without one), or with `template`, the next match of that template
 * with a free seat. In a match it takes the robot back with the session this tab was
 * given, if any. */
export function joinAsPlayer(name, template = null) {
  stopSpectator();
  spectator.frame = null;
  page.ended = false;
  player.name = name;
  setView('player');
  setText($('#me'), name);
  setStatus('joining');
  $('#banner').hidden = true;
  $('#join-error').hidden = true;
  $('#log').replaceChildren();
  $('#messages').replaceChildren();
  setWatchNote('');
  hideWaiting();
  player.template = template;
  // After a reload, take the robot back with the session the server gave this tab.
  const session = template ? null : sessionStorage.getItem(sessionKey(name));
  connectPlayer(session ? { session } : { name });
}

/** Where a player's `hello` asks to play: the named match, a template, or neither. */
function destination() {
  if (page.matchName) return { match: page.matchName };
  if (player.template) return { template: player.template };
  return {};
}

/** Opens a player's WebSocket with fresh beliefs; `identity`: `{name}` or `{session}`. */
function connectPlayer(identity) {
  player.beliefs = new Beliefs();
  // Messages from a socket that was replaced (its trailing `bye`) are not this player's.
  const onMessage = (message) => player.socket === socket && onPlayerMessage(message);
  const socket = openSocket(helloFor({ ...identity, ...destination() }), onMessage, () => {
    if (player.socket !== socket) return; // replaced on purpose (a new join, a retry)
    if (!page.ended && $('#status').dataset.status !== 'error') setStatus('disconnected');
    if (!page.ended) log('error', 'connection closed');
  });
  player.socket = socket;
}

function onPlayerMessage(message) {
  switch (message.type) {
    case 'welcome':
      player.name = message.name;
      player.robot = message.robot;
      if (page.lobby && message.match.name) {
        // The match (maybe chosen by a template) is now this page's: a reload comes back to it.
        page.matchName = message.match.name;
        history.replaceState(null, '', linkTo({ match: page.matchName, play: message.name }));
      }
      sessionStorage.setItem(sessionKey(message.name), message.session);
      showMatch(message.match);
      setText($('#me'), `${message.name} (robot ${message.robot})`);
      setStatus('connected');
      log(
        'info',
        `joined as ${message.name}, robot ${message.robot}; ${message.match.mode} match${message.match.name ? ` ${message.match.name}` : ''} on ${message.match.map}`,
      );
      // A template's match is known only now: draw its map.
      if (!page.map) loadMap(page.matchName, message.match.map).catch((err) => log('error', `no map: ${err.message}`));
      break;
    case 'lobby':
      showLobby(message); // queued for a seat, or the match waits for its players
      break;
    case 'percepts':
      // A waiting match sends the robot's first view (tick 0) before its `lobby`; the
      // match has started once a tick has run.
      if (message.tick > 0) hideWaiting();
      onPercepts(message);
      break;
    case 'ack': {
      const request = player.pending.get(message.id) || { words: `#${message.id ?? '?'}` };
      if (message.ok) {
        log('ok', `${request.words}: accepted`, message.tick, { action: request.action });
        // Players are not sent their own messages: show an accepted one in the chat here.
        if (request.say) addMessage(message.tick, player.name, request.say.to, request.say.text);
        // A durative order stays pending until its result; anything else is done.
        if (!request.durative) player.pending.delete(message.id);
      } else {
        log('reject', `${request.words}: rejected, ${message.code}: ${message.reason || ''}`, message.tick, {
          action: request.action,
          code: message.code,
        });
        player.pending.delete(message.id);
      }
      break;
    }
    case 'result': {
      const request = player.pending.get(message.id) || { words: `#${message.id}` };
      player.pending.delete(message.id);
      log('result', `${request.words}: ${message.outcome}`, message.tick, {
        action: request.action,
        outcome: message.outcome,
      });
      break;
    }
    case 'error':
      log('error', `error ${message.code}: ${message.message}${message.fatal ? ' (fatal)' : ''}`, undefined, {
        code: message.code,
      });
      onPlayerError(message);
      break;
    case 'match_end':
      hideWaiting();
      endMatch(message, player.name);
      log('info', `match over: ${message.reason}`);
      break;
    case 'bye':
      if (message.reason !== 'match_over') log('info', `server said bye: ${message.reason}`);
      break;
    default:
      break;
  }
}

function onPlayerError(message) {
  if (!message.fatal) return;
  const socket = player.socket;
  if (message.code === 'bad_session' && !player.retriedWithName) {
    // The stored session is from an older match or its grace period passed: join anew.
    player.retriedWithName = true;
    sessionStorage.removeItem(sessionKey(player.name));
    player.socket = null;
    socket?.close();
    connectPlayer({ name: player.name });
    return;
  }
  const noMatch = ['unknown_match', 'unknown_template'].includes(message.code);
  if (noMatch || (REFUSALS.includes(message.code) && !page.matchName && player.template)) {
    // No match to watch instead: say why, and where the others are.
    player.socket = null;
    socket?.close();
    setStatus('error', message.code);
    showRefusal(`could not join: ${message.message}`, page.lobby ? { href: linkTo(), text: 'Back to the matches' } : null);
    return;
  }
  if (REFUSALS.includes(message.code)) {
    // Back to the overview, with the reason under the join form.
    player.socket = null;
    socket?.close();
    startSpectator();
    const note = $('#join-error');
    note.hidden = false;
    note.textContent = `could not join: ${message.message}`;
    return;
  }
  setStatus('error', message.code);
}

/** A `percepts`: the beliefs, the messages in it, `ready`, the panels. */
function onPercepts(percepts) {
  const messages = player.beliefs.apply(percepts);
  for (const { from, text } of messages) addMessage(percepts.tick, from, null, text);
  // In lockstep the match waits for this; in realtime it is accepted and ignored.
  player.socket.send({ type: 'ready', tick: percepts.tick });
  setTick(percepts.tick, page.match ? percepts.tick / page.match.tick_hz : undefined);
  showPlayerPanel();
  page.dirty = true;
}

/** The visible blocks: id and colour from `color` facts, in id order. */
function visibleBlocks() {
  return player.beliefs
    .all('color')
    .map(([id, color]) => ({ id, color }))
    .sort((a, b) => a.id - b.id);
}

/** The side panel from the beliefs: the robot's facts, the blocks in view, receivers, places. */
function showPlayerPanel() {
  const b = player.beliefs;
  const seq = b.get('sequence') || [];
  showSequence(seq, b.get('sequenceIndex') ?? 0);
  setText($('#at'), b.get('at') ?? '–');
  setText($('#in'), b.get('in') ?? '–');
  const state = $('#state');
  setText(state, b.get('state') ?? '–');
  state.dataset.state = b.get('state') ?? '';

  const holding = $('#holding');
  const held = b.get('holding');
  const heldColour = held !== undefined ? b.colourOf(held) : undefined;
  holding.dataset.blockId = held !== undefined ? String(held) : '';
  holding.dataset.color = heldColour || '';
  if (held === undefined) {
    setText(holding, 'nothing');
  } else {
    const label = `${heldColour || '?'} (block ${held})`;
    if (holding.textContent !== label) {
      holding.replaceChildren(el('span', { class: 'swatch', style: `--chip:${colourCss(heldColour)}` }, label));
    }
  }

  // Visible blocks as buttons (rebuilt only when the set changes).
  const blocks = visibleBlocks();
  const atBlock = b.get('atBlock');
  const list = $('#blocks');
  const key = blocks.map((x) => `${x.id}:${x.color}`).join(' ');
  if (list.dataset.key !== key) {
    list.dataset.key = key;
    list.replaceChildren(
      ...blocks.map((x) =>
        el(
          'li',
          {},
          el(
            'button',
            {
              type: 'button',
              class: 'chip',
              title: `go to block ${x.id}`,
              dataset: { blockId: String(x.id), color: x.color },
              style: `--chip:${colourCss(x.color)}`,
              onclick: () => act('goToBlock', [x.id]),
            },
            `${x.color} ${x.id}`,
          ),
        ),
      ),
    );
  }
  for (const button of list.querySelectorAll('button')) {
    button.classList.toggle('at', Number(button.dataset.blockId) === atBlock);
  }
  $('#blocks-empty').hidden = blocks.length > 0;

  // Receivers: all, or another player from `player` facts; keep the choice if still valid.
  const to = $('#chat-to');
  const players = b.all('player').map(([name]) => name).sort();
  const names = ['all', ...players];
  if (to.dataset.names !== names.join(' ')) {
    const chosen = to.value;
    to.dataset.names = names.join(' ');
    to.replaceChildren(...names.map((n) => el('option', { value: n }, n)));
    to.value = names.includes(chosen) ? chosen : 'all';
  }

  // Places: from `place` facts (every place of the map the player may go to).
  const places = b.all('place').map(([p]) => p);
  const nav = $('#places');
  if (nav.dataset.key !== places.join(' ')) {
    nav.dataset.key = places.join(' ');
    nav.replaceChildren(
      ...places.map((p) =>
        el('button', { type: 'button', dataset: { place: p }, onclick: () => act('goTo', [p]) }, p),
      ),
    );
  }
}

/** What the renderer draws: the map as the player's beliefs show it. */
export function playerScene() {
  const b = player.beliefs;
  const map = page.map;
  const inName = b.get('in');
  return {
    occupied: new Set(b.all('occupied').map(([room]) => room)),
    at: map.byName.get(b.get('at')) || null,
    inRoom: map.byName.get(inName) || null,
    chips: visibleBlocks(),
    atBlock: b.get('atBlock'),
    holdingColor: b.get('holding') !== undefined ? b.colourOf(b.get('holding')) || '?' : null,
    me: player.name,
    hover: page.hover,
  };
}

/** Sends an action; the log line names it until its ack and result come back. */
function act(action, args = []) {
  if (!player.socket || page.ended) return;
  const id = player.nextId++;
  let words = [action, ...args].join(' ');
  const colour = action === 'goToBlock' ? player.beliefs.colourOf(args[0]) : undefined;
  if (colour) words += ` (${colour})`;
  player.pending.set(id, { words, action, durative: DURATIVE.has(action) });
  player.socket.send({ type: 'act', id, action, args });
  log('sent', words, undefined, { action });
}

/** Sends a message (`to`: a player's name or `all`); shown in the chat once accepted. */
function say(to, text) {
  if (!player.socket || page.ended) return;
  const id = player.nextId++;
  const words = `say to ${to}: ${text}`;
  player.pending.set(id, { words, action: 'say', say: { to, text } });
  player.socket.send({ type: 'say', id, to, text });
  log('sent', words, undefined, { action: 'say' });
}

/** The controls: buttons, keys, clicks on the map, the join and chat forms. */
export function setupPlayerControls(canvas) {
  $('#pickup').addEventListener('click', () => act('pickUp'));
  $('#putdown').addEventListener('click', () => act('putDown'));
  $('#chat-form').addEventListener('submit', (event) => {
    event.preventDefault();
    const text = $('#chat-text').value.trim();
    if (!text) return;
    say($('#chat-to').value, text);
    $('#chat-text').value = '';
  });
  // P and D, unless the player is typing.
  document.addEventListener('keydown', (event) => {
    if (page.view !== 'player' || event.ctrlKey || event.metaKey || event.altKey) return;
    if (event.target.closest?.('input, textarea, select')) return;
    const key = event.key.toLowerCase();
    if (key === 'p') act('pickUp');
    else if (key === 'd') act('putDown');
    else return;
    event.preventDefault();
  });
  // A click on a block chip goes to the block; anywhere else, to the place under it.
  canvas.addEventListener('click', (event) => {
    if (page.view !== 'player' || !page.renderer) return;
    const p = page.renderer.eventToMap(event);
    const chip = page.renderer.chipAt(p.x, p.y);
    if (chip) return act('goToBlock', [chip.id]);
    const zone = zoneAt(page.map, p.x, p.y);
    if (zone) act('goTo', [zone.name]);
  });
  $('#join-form').addEventListener('submit', (event) => {
    event.preventDefault();
    const name = $('#join-name').value.trim();
    if (name) joinAsPlayer(name);
  });
}
