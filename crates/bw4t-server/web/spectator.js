// The overview: the whole match as the server's `frame`s show it (the default when live).
// Replays show their frames through showFrame too.

import { $, el, setText } from './dom.js';
import { page, setView } from './page.js';
import { zoneAt } from './geometry.js';
import { colourCss } from './renderer.js';
import { addMessage, endMatch, setStatus, setTick, setWatchNote, showMatch, showSequence } from './panels.js';
import { TOKEN_PARAMS, helloFor, openSocket, operatorToken } from './connection.js';
import { hideWaiting, showLobby } from './waiting.js';

export const spectator = {
  socket: null,
  frame: null, // the latest frame: the whole state of the match
};

/** Joins /ws as a spectator (as the operator with the operator token) and shows its frames:
 * of the match `page.matchName`, or the server's default match. */
export function startSpectator() {
  setView('spectator');
  setStatus('connecting');
  setWatchNote('');
  hideWaiting();
  // With the operator token the overview shows every message; else it is a spectator's.
  const role = operatorToken() ? 'operator' : 'spectator';
  const hello = helloFor(page.matchName ? { role, match: page.matchName } : { role });
  const socket = openSocket(
    hello,
    (message) => {
      if (spectator.socket !== socket) return; // the player view took over
      switch (message.type) {
        case 'welcome':
          showMatch(message.match);
          setStatus('connected');
          if (message.private_messages === false) setWatchNote('Messages to one player are not shown to spectators.');
          break;
        case 'lobby':
          showLobby(message); // the match waits for its players
          break;
        case 'frame':
          if (message.tick > 0) hideWaiting(); // the match has started (see player.js)
          showFrame(message);
          break;
        case 'match_end':
          hideWaiting();
          endMatch(message);
          break;
        case 'error':
          console.warn('bw4t spectator error', message);
          if (message.fatal) setStatus('error', message.code);
          if (message.code === 'bad_token') {
            setWatchNote(`Cannot watch: ${message.message}. Open the page with ?${TOKEN_PARAMS[role]}=SECRET to watch; joining as a player needs ?token=SECRET.`);
          }
          if (message.code === 'unknown_match') setWatchNote(`Cannot watch: ${message.message}.`);
          break;
        default:
          break; // bye, pong: nothing to show
      }
    },
    () => {
      if (spectator.socket !== socket) return; // closed on purpose: the player view took over
      if (!page.ended && $('#status').dataset.status !== 'error') setStatus('disconnected');
    },
  );
  spectator.socket = socket;
}

/** Leaves the overview (the player view takes over). */
export function stopSpectator() {
  const socket = spectator.socket;
  spectator.socket = null;
  socket?.close();
}

/** A frame (live or from a replay): keep it, update the panels, redraw. */
export function showFrame(frame) {
  spectator.frame = frame;
  page.frames += 1;
  page.renderer.canvas.dataset.frames = String(page.frames);
  setTick(frame.tick, frame.sim_seconds);
  showSequence(frame.sequence || [], frame.sequence_index ?? 0);
  showRobotList(frame);
  // A replay lists messages from its own index (frames skipped or sought past carry some).
  if (page.view !== 'replay') for (const m of frame.messages || []) addMessage(frame.tick, m.from, m.to, m.text, m.said);
  page.dirty = true;
}

/** The robot table: one row per robot, reused between frames. */
function showRobotList(frame) {
  const robots = frame.robots || [];
  const count = $('#robots');
  count.dataset.count = String(robots.length);
  setText(count, robots.length);
  const body = $('#robot-list tbody');
  const colourOf = new Map((frame.blocks || []).map((b) => [b.id, b.color]));
  while (body.children.length > robots.length) body.lastElementChild.remove();
  robots.forEach((r, i) => {
    let row = body.children[i];
    if (!row) {
      row = el('tr', {}, el('td'), el('td'), el('td'), el('td'));
      body.append(row);
    }
    row.dataset.robot = String(r.id);
    row.dataset.name = r.name;
    row.dataset.x = r.x.toFixed(2);
    row.dataset.y = r.y.toFixed(2);
    row.dataset.state = r.state;
    const zone = zoneAt(page.map, r.x, r.y);
    const held = r.holding !== undefined && r.holding !== null ? colourOf.get(r.holding) : null;
    setText(row.children[0], r.name);
    setText(row.children[1], zone ? zone.name : '');
    setText(row.children[2], r.state);
    const cell = row.children[3];
    if ((cell.dataset.color || '') !== (held || '')) {
      cell.dataset.color = held || '';
      cell.replaceChildren(held ? el('span', { class: 'swatch', style: `--chip:${colourCss(held)}` }, held) : '');
    }
  });
}

/** What the renderer draws for the latest frame. */
export function spectatorScene() {
  const frame = spectator.frame;
  if (!frame) return { occupied: new Set(), hover: page.hover };
  const colourOf = new Map((frame.blocks || []).map((b) => [b.id, b.color]));
  return {
    occupied: new Set(frame.occupied || []),
    blocks: frame.blocks,
    robots: (frame.robots || []).map((r) => ({ ...r, holdingColor: r.holding !== undefined ? colourOf.get(r.holding) : null })),
    hover: page.hover,
  };
}
