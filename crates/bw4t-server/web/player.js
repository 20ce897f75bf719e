// The human player: a person drives one robot and sees only what its percepts say.
//
// The protocol is the JavaScript client's own session (protocol/clients/js/src/core.js,
// served at /client/ with the files it imports), driven over the WebSocket: it builds the
// hello, numbers the actions, matches acks and results to them and says when `ready` is
// due. Its beliefs are kept exactly as protocol/README.md says: a full snapshot clears
// them; `not` facts are removed, then `add` facts stored; `at`, `state` and
// `sequenceIndex` are single-valued; `message` facts are events, shown once and never
// stored. The view shows only these beliefs and the colours of blocks seen earlier, which
// the player was told and may remember (Beliefs.colourOf).
//
// The hello asks for `words` (not when embedded, unless the embedding page's hello does):
// each `percepts` then carries the robot's situation in English, the same text language
// models get, shown as "What I know".
//
// Messages are composed with the menu (menu.js) in the shared language, or typed when the
// match allows free text. The time from a key or click to the `ack` of the action it made
// is kept in `window.bw4tLatency` (samples in ms, and their percentiles), for tests and
// benchmarks. Embedded in the study page, the view reports what happens (embed.js), each
// event with the match's tick then: an ack's or result's own tick, else the latest
// `percepts`' (the participant view asks for one every tick). It is then the participant
// view (participant.js): its own robot drawn moving (glide.js), a countdown, plain words.

import { Beliefs } from './client/beliefs.js';
import { PlayerSession } from './client/core.js';
import { $, el, linkTo, setText } from './dom.js';
import { loadMap, page, setView } from './page.js';
import { zoneAt } from './geometry.js';
import { colourCss, perceivedScene, visibleBlocks } from './renderer.js';
import { sentenceOf } from './language.js';
import { addMessage, endMatch, log, setStatus, setTick, setWatchNote, showMatch, showSequence } from './panels.js';
import { helloFor, openSocket, tokenOf } from './connection.js';
import { spectator, spectatorScene, startSpectator, stopSpectator } from './spectator.js';
import { hideWaiting, showLobby, showRefusal } from './waiting.js';
import { embedded, report, setReportTick } from './embed.js';
import { setMenuOptions, setMessagePolicy, setupMenu } from './menu.js';
import { participant, setClockOf, setClockTick, showPause, showRefusalOf, showTaskOver } from './participant.js';
import { glide } from './glide.js';

/** Input-to-acknowledgement latency: ms from a key or click to the `ack` of its action. */
const latency = {
  samples: [],
  /** The q-quantile of the samples (q in 0..1), or null without samples. */
  quantile(q) {
    if (this.samples.length === 0) return null;
    const sorted = [...this.samples].sort((a, b) => a - b);
    return sorted[Math.min(sorted.length - 1, Math.floor(q * sorted.length))];
  },
  p50() {
    return this.quantile(0.5);
  },
  p99() {
    return this.quantile(0.99);
  },
};
window.bw4tLatency = latency;

/** The beliefs shown before any join. */
const noBeliefs = new Beliefs();

export const player = {
  socket: null,
  core: null, // the protocol session over `socket`; its requests' tags: {words, say, inputAt}
  name: null,
  robot: null,
  get beliefs() {
    return this.core?.beliefs ?? noBeliefs;
  },
  retriedWithName: false,
  extra: {}, // more fields of the hello (the study page's)
  overviewSocket: null, // the overview's frames, when the player sees the whole map
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
export function joinAsPlayer(name, template = null, extra = {}) {
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
  showWords(null);
  setWatchNote('');
  hideWaiting();
  player.template = template;
  player.extra = extra;
  // After a reload, take the robot back with the session the server gave this tab.
  const session = template ? null : sessionStorage.getItem(sessionKey(name));
  // A seat token (the study's) is checked against the name: it goes with the session too.
  connectPlayer(session ? { session, ...(extra.seat ? { name } : {}) } : { name });
}

/** Where a player's `hello` asks to play: the named match, a template, or neither. */
function destination() {
  if (page.matchName) return { match: page.matchName };
  if (player.template) return { template: player.template };
  return {};
}

/** Opens a player's WebSocket with a new protocol session (fresh beliefs); `identity`:
 * `{name}` or `{session}`. The embedding page's fields go into the hello too, over the
 * page's own choices (but the token of the page's address, and where to play). */
function connectPlayer(identity) {
  stopOverview();
  const hello = { words: !embedded, ...(participant ? { every_tick: true } : {}), ...identity, ...player.extra, ...destination() };
  const { name, session, words, match, template, token = null, ...fields } = hello;
  const core = new PlayerSession({ name, session, words, match, template, token: tokenOf('agent') ?? token, fields });
  core.start();
  const [helloLine] = core.takeLines();
  // Messages from a socket that was replaced (its trailing `bye`) are not this player's.
  const onMessage = (message) => player.socket === socket && onPlayerMessage(message);
  const socket = openSocket(helloLine, onMessage, () => {
    if (player.socket !== socket) return; // replaced on purpose (a new join, a retry)
    if (!page.ended && $('#status').dataset.status !== 'error') setStatus('disconnected');
    if (!page.ended) log('error', 'connection closed');
  });
  player.socket = socket;
  player.core = core;
}

/** Sends what the protocol session has to send. */
function flush() {
  for (const line of player.core.takeLines()) player.socket.sendLine(line);
}

/** A server message: through the protocol session, then shown. */
function onPlayerMessage(message) {
  const core = player.core;
  for (const event of core.receive(message)) onPlayerEvent(event, message);
  if (player.core === core) flush(); // not after a retry replaced the connection
}

/** What the protocol session made of `message`. */
function onPlayerEvent(event, message) {
  switch (event.type) {
    case 'welcome':
      player.name = message.name;
      player.robot = message.robot;
      // The session goes to the study page (which keeps it with the trial, so any page of
      // the participant's takes the robot back); the page does not log it.
      report('welcome', { name: message.name, robot: message.robot, match: message.match, session: message.session });
      setMessagePolicy(message.match.language);
      if (page.lobby && message.match.name) {
        // The match (maybe chosen by a template) is now this page's: a reload comes back to
        // it (embedded, the embedding page decides what a reload does).
        page.matchName = message.match.name;
        if (!embedded) history.replaceState(null, '', linkTo({ match: page.matchName, play: message.name }));
      }
      sessionStorage.setItem(sessionKey(message.name), player.core.session);
      showMatch(message.match);
      setClockOf(message.match);
      glide.setTickHz(message.match.tick_hz);
      setText($('#me'), `${message.name} (robot ${message.robot})`);
      setStatus('connected');
      log(
        'info',
        `joined as ${message.name}, robot ${message.robot}; ${message.match.mode} match${message.match.name ? ` ${message.match.name}` : ''} on ${message.match.map}`,
      );
      // A template's match is known only now: draw its map.
      if (!page.map) loadMap(page.matchName, message.match.map).catch((err) => log('error', `no map: ${err.message}`));
      if (page.overview) startOverview(message.match.name);
      break;
    case 'lobby':
      report('lobby', { lobby: message });
      showLobby(message); // queued for a seat, or the match waits for its players
      break;
    case 'percepts':
      // A waiting match sends the robot's first view (tick 0) before its `lobby`; the
      // match has started once a tick has run.
      if (message.tick > 0) hideWaiting();
      onPercepts(message);
      break;
    case 'ack': {
      const action = event.request?.action;
      const request = event.request?.tag ?? { words: `#${message.id ?? '?'}` };
      if (request.inputAt !== undefined) latency.samples.push(performance.now() - request.inputAt);
      report('ack', { id: message.id, ok: message.ok, ...(message.ok ? {} : { code: message.code }) }, message.tick);
      if (message.ok) {
        log('ok', `${request.words}: accepted`, message.tick, { action });
        // Players are not sent their own messages: show an accepted one in the chat here.
        if (request.say) addMessage(message.tick, player.name, request.say.to, request.say.text, request.say.said, participant ? 'You' : undefined);
      } else {
        if (!request.say) showRefusalOf(message.code);
        log('reject', `${request.words}: rejected, ${message.code}: ${message.reason || ''}`, message.tick, {
          action,
          code: message.code,
        });
      }
      break;
    }
    case 'result': {
      const request = event.request?.tag ?? { words: `#${message.id}` };
      report('done', { id: message.id, outcome: message.outcome }, message.tick);
      log('result', `${request.words}: ${message.outcome}`, message.tick, {
        action: event.request?.action,
        outcome: message.outcome,
      });
      break;
    }
    case 'error':
      report('error', { code: message.code, fatal: message.fatal === true });
      log('error', `error ${message.code}: ${message.message}${message.fatal ? ' (fatal)' : ''}`, undefined, {
        code: message.code,
      });
      onPlayerError(message);
      break;
    case 'match_end':
      report('match_over', { reason: message.reason, result: message.result }, message.result?.ticks);
      hideWaiting();
      endMatch(message, player.name);
      if (participant) showTaskOver();
      log('info', `match over: ${message.reason}`);
      break;
    case 'bye':
      report('bye', { reason: message.reason });
      if (message.reason !== 'match_over') log('info', `server said bye: ${message.reason}`);
      break;
    case 'server':
      // The operator paused or resumed the match (a server that never says so is fine).
      if (message.type === 'pause') {
        report('pause', { paused: message.paused === true });
        showPause(message.paused === true);
      }
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

/** A `percepts` (the session has applied it to the beliefs): the messages in it,
 * `ready`, the panels. */
function onPercepts(percepts) {
  setReportTick(percepts.tick);
  setClockTick(percepts.tick);
  if (percepts.full || percepts.add?.length || percepts.not?.length) {
    report('percepts', { full: percepts.full === true, add: percepts.add || [], del: percepts.not || [] });
  }
  // Messages are events in `add`: `["message", from, text]`, or for a message of the
  // language `["message", from, sentence, said]` (read here, whatever the belief base keeps).
  for (const fact of percepts.add || []) {
    if (fact[0] !== 'message') continue;
    const line = addMessage(percepts.tick, fact[1], null, fact[2], fact[3] || null);
    report('message_received', {
      from: fact[1],
      ...(line.said ? { said: line.said } : { text: fact[2] }),
      sentence: line.sentence,
    });
  }
  // In lockstep the match waits for this (the session sends it only then).
  player.core.ready(percepts.tick);
  setTick(percepts.tick, page.match ? percepts.tick / page.match.tick_hz : undefined);
  if (typeof percepts.words === 'string') showWords(percepts);
  if (page.map) glide.setPlace(page.map.byName.get(player.beliefs.get('at')));
  showPlayerPanel();
  page.dirty = true;
}

/** The latest `words` (`percepts`, or null to clear the panel), with its tick in `data-tick`. */
function showWords(percepts) {
  const box = $('#words-box');
  box.dataset.words = percepts ? 'some' : 'none';
  const node = $('#words');
  node.dataset.tick = percepts ? String(percepts.tick) : '';
  setText(node, percepts ? percepts.words : '');
}

/** The visible blocks: id and colour from `color` facts, in id order. */

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
  const blocks = visibleBlocks(player.beliefs);
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
              onclick: (event) => act('goToBlock', [x.id], clicked(event, `block ${x.id}`)),
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
  setMenuOptions({ places, players, sequence: seq });
  const nav = $('#places');
  if (nav.dataset.key !== places.join(' ')) {
    nav.dataset.key = places.join(' ');
    nav.replaceChildren(
      ...places.map((p) =>
        el('button', { type: 'button', dataset: { place: p }, onclick: (event) => act('goTo', [p], clicked(event, `place ${p}`)) }, p),
      ),
    );
  }
}

/** The whole map beside the player's own view (`page.overview`, a study condition's
 * `view = "overview"`): the match's frames as a spectator sees them, drawn under the
 * player's place and chips. Refused (the match is not open to spectators), the player
 * keeps its own view. */
function startOverview(matchName) {
  stopOverview();
  // A study's condition gives its spectator token (its matches are watched by no one else).
  const watch = player.extra.watch_token ? { token: player.extra.watch_token } : {};
  const hello = helloFor(matchName ? { role: 'spectator', match: matchName, ...watch } : { role: 'spectator', ...watch });
  const socket = openSocket(
    hello,
    (message) => {
      if (player.overviewSocket !== socket) return;
      if (message.type === 'frame') {
        spectator.frame = message;
        page.frames += 1;
        if (page.renderer) page.renderer.canvas.dataset.frames = String(page.frames);
        page.dirty = true;
      } else if (message.type === 'error' && message.fatal) {
        log('info', `no overview: ${message.message}`);
      }
    },
    () => {},
  );
  player.overviewSocket = socket;
}

function stopOverview() {
  const socket = player.overviewSocket;
  player.overviewSocket = null;
  spectator.frame = null;
  socket?.close();
}

/** What the renderer draws: the map as the player's beliefs show it (over the whole map's
 * frame, in the overview). */
export function playerScene() {
  const b = player.beliefs;
  const map = page.map;
  const inName = b.get('in');
  if (page.overview && spectator.frame) {
    const whole = spectatorScene();
    const room = map.byName.get(inName);
    const inside = (x, y) => room && x >= room.x && x < room.x + room.w && y >= room.y && y < room.y + room.h;
    return {
      ...whole,
      // The participant's robot is named "you", as in the own view.
      robots: participant ? (whole.robots || []).map((r) => (r.name === player.name ? { ...r, name: 'you' } : r)) : whole.robots,
      // The room the player is in shows its blocks as the player's chips.
      blocks: (whole.blocks || []).filter((block) => !inside(block.x, block.y)),
      at: map.byName.get(b.get('at')) || null,
      inRoom: room || null,
      chips: visibleBlocks(b),
      atBlock: b.get('atBlock'),
      holdingColor: b.get('holding') !== undefined ? b.colourOf(b.get('holding')) || '?' : null,
      me: player.name,
      placeLabel: !participant,
      hover: page.hover,
    };
  }
  const holding = b.get('holding') !== undefined ? b.colourOf(b.get('holding')) || '?' : null;
  const scene = { ...perceivedScene(b, map, player.name, holding), hover: page.hover };
  if (participant && glide.drawn) {
    const traveling = b.get('state') === 'traveling';
    if (traveling) glide.shownTraveling(performance.now());
    scene.self = { ...glide.drawn, holdingColor: holding, traveling };
  }
  return scene;
}

/** The input that made an action: a click (on `target`) at the event's time. */
function clicked(event, target) {
  return { kind: 'click', target, at: event.timeStamp };
}

/** Reports the key or click that became an action (`input`: {kind, key | target, at}). */
function reportInput(input) {
  if (!input) return;
  if (input.kind === 'key') report('key', { key: input.key });
  else report('click', { target: input.target });
}

/** Sends an action; the log line names it until its ack and result come back. `input`:
 * the key or click that made it, timed from its event to the ack. */
function act(action, args = [], input = null) {
  if (!player.socket || page.ended) return;
  reportInput(input);
  let words = [action, ...args].join(' ');
  const colour = action === 'goToBlock' ? player.beliefs.colourOf(args[0]) : undefined;
  if (colour) words += ` (${colour})`;
  if (action === 'goTo' || action === 'goToBlock') glide.sent(input?.at);
  sent(player.core.act(action, args, { words, inputAt: input?.at }), words, args);
}

/** A request the protocol session made: sent and logged, or why it could not be. */
function sent(request, words, args) {
  if (request.failure) {
    log('error', `${words}: not sent, ${request.failure.message}`, undefined, { action: request.action });
    return;
  }
  flush();
  report('act', { id: request.id, action: request.action, args });
  log('sent', words, undefined, { action: request.action });
}

/** Sends a message (`to`: a player's name or `all`): `said`, a message of the language,
 * or free `text`. Shown in the chat once accepted. */
function say(to, { said = null, text = null }, input = null) {
  if (!player.socket || page.ended) return;
  reportInput(input);
  const content = said ? { said } : { text };
  const words = `say to ${to}: ${said ? sentenceOf(said) || JSON.stringify(said) : text}`;
  let request;
  try {
    request = player.core.say(to, said || text, { words, say: { to, text: text ?? '', said }, inputAt: input?.at });
  } catch (err) {
    log('error', `${words}: not sent, ${err.message}`, undefined, { action: 'say' }); // over the line limit
    return;
  }
  sent(request, words, [to, said || text]);
  if (!request.failure) report('message_sent', { to, ...content });
}

/** The controls: buttons, keys, clicks on the map, the join and chat forms. */
export function setupPlayerControls(canvas) {
  $('#pickup').addEventListener('click', (event) => act('pickUp', [], clicked(event, 'pickup')));
  $('#putdown').addEventListener('click', (event) => act('putDown', [], clicked(event, 'putdown')));
  setupMenu((to, said, input) => say(to, { said }, input));
  $('#chat-form').addEventListener('submit', (event) => {
    event.preventDefault();
    const text = $('#chat-text').value.trim();
    if (!text) return;
    say($('#chat-to').value, { text }, { kind: 'key', key: 'Enter', at: event.timeStamp });
    $('#chat-text').value = '';
  });
  // P and D, unless the player is typing.
  document.addEventListener('keydown', (event) => {
    if (page.view !== 'player' || event.ctrlKey || event.metaKey || event.altKey) return;
    if (event.target.closest?.('input, textarea, select')) return;
    const key = event.key.toLowerCase();
    const input = { kind: 'key', key: event.key, at: event.timeStamp };
    if (key === 'p') act('pickUp', [], input);
    else if (key === 'd') act('putDown', [], input);
    else return;
    event.preventDefault();
  });
  // A click on a block chip goes to the block; anywhere else, to the place under it.
  canvas.addEventListener('click', (event) => {
    if (page.view !== 'player' || !page.renderer) return;
    const p = page.renderer.eventToMap(event);
    const chip = page.renderer.chipAt(p.x, p.y);
    if (chip) return act('goToBlock', [chip.id], clicked(event, `map block ${chip.id}`));
    const zone = zoneAt(page.map, p.x, p.y);
    if (zone) act('goTo', [zone.name], clicked(event, `map ${zone.name}`));
  });
  $('#join-form').addEventListener('submit', (event) => {
    event.preventDefault();
    const name = $('#join-name').value.trim();
    if (name) joinAsPlayer(name);
  });
}
