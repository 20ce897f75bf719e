// The bw4t browser page: one script for three views of a match.
//
//   spectator  the whole map as the server's `frame`s show it (the default when live);
//   player     a human drives one robot and sees only what its percepts say;
//   replay     frames of a recorded match fetched from /replay/frame/T, with play and seek.
//
// It speaks protocol/PROTOCOL.md over a WebSocket at /ws (one JSON message per text
// frame) and reads /info.json, /map.json and, for replays, /replay.json. No build step,
// no dependencies: plain modern JavaScript.
//
// Sections: 1 helpers · 2 map geometry · 3 drawing · 4 shared panels · 5 connection ·
// 6 spectator · 7 player · 8 replay · 9 start.

'use strict';

// ---- 1. helpers and constants ------------------------------------------------------

const COLOURS = {
  Blue: '#2f66f5',
  Cyan: '#1ccfe0',
  Magenta: '#cf2fcf',
  Orange: '#ff8a1c',
  Red: '#e0262b',
  White: '#ffffff',
  Green: '#22a54a',
  Yellow: '#ffe01a',
  Pink: '#ffa3d2',
};
const colourCss = (name) => COLOURS[name] || '#8a8a8a';

const params = new URLSearchParams(location.search);
const $ = (selector) => document.querySelector(selector);

/** Makes an element: el('li', {class: 'x', dataset: {id: 1}}, 'text', child). */
function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (key === 'dataset') Object.assign(node.dataset, value);
    else if (key === 'style') node.style.cssText = value;
    else if (key.startsWith('on')) node.addEventListener(key.slice(2), value);
    else node.setAttribute(key, value);
  }
  node.append(...children);
  return node;
}

/** Sets an element's text only when it differs: the panels are refreshed per frame and
 * rewriting unchanged text would still cost style and layout work. */
function setText(node, text) {
  const s = String(text);
  if (node.textContent !== s) node.textContent = s;
}

async function fetchJSON(url) {
  const response = await fetch(url, { cache: 'no-store' });
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response.json();
}

/** Everything the page is currently showing. One object, so the drawing loop and the
 * panels read the same state whatever the view. */
const page = {
  view: 'loading', // 'spectator' | 'player' | 'replay'
  map: null, // the geometry from section 2
  renderer: null,
  match: null, // welcome.match
  ended: false,
  dirty: true, // the canvas needs a redraw
  frames: 0, // frames received (live) or shown (replay)
  draws: 0, // pictures drawn
  drawMs: 0, // time spent drawing them
};

function setView(view) {
  page.view = view;
  document.body.dataset.view = view;
  for (const node of document.querySelectorAll('[data-views]')) {
    node.hidden = !node.dataset.views.split(' ').includes(view);
  }
  page.dirty = true;
  page.renderer?.resize();
}

// ---- 2. map geometry -----------------------------------------------------------------
//
// /map.json gives zones as top-left boxes in map units, y downwards, doors as boxes on a
// room's edge with the opening each makes, and the walls as segments. From it we derive
// only the drawing bounds; the openings are drawn as bars when the room is occupied.

function buildMap(json) {
  const zones = json.zones.map((z) => ({
    ...z,
    doors: z.doors || [],
    isRoom: z.kind === 'room',
    isDrop: z.name === json.drop_zone,
  }));
  // Halls may reach beyond `area` (the default map's top halls do): draw everything,
  // with a small margin so that walls on the outer edges show whole.
  const margin = 0.5;
  let [minX, minY, maxX, maxY] = [0, 0, json.area[0], json.area[1]];
  for (const z of zones) {
    minX = Math.min(minX, z.x);
    minY = Math.min(minY, z.y);
    maxX = Math.max(maxX, z.x + z.w);
    maxY = Math.max(maxY, z.y + z.h);
  }
  [minX, minY, maxX, maxY] = [minX - margin, minY - margin, maxX + margin, maxY + margin];
  // Walls and door openings come computed with the map (bw4t-map owns the geometry).
  const openings = new Map(zones.filter((z) => z.isRoom).map((z) => [z.name, z.doors.map((d) => d.opening)]));
  return {
    name: json.name,
    zones,
    byName: new Map(zones.map((z) => [z.name, z])),
    dropZone: json.drop_zone,
    spawns: json.spawns || [],
    bounds: { x: minX, y: minY, w: maxX - minX, h: maxY - minY },
    walls: json.walls,
    openings,
  };
}

/** The zone under a map point: the smallest box containing it (zones should not overlap,
 * but a small zone drawn over a big one must win if they do). */
function zoneAt(map, x, y) {
  let best = null;
  for (const z of map.zones) {
    if (x >= z.x && x < z.x + z.w && y >= z.y && y < z.y + z.h) {
      if (!best || z.w * z.h < best.w * best.h) best = z;
    }
  }
  return best;
}

// ---- 3. drawing ------------------------------------------------------------------------
//
// The canvas shows the map scaled to fit the stage. The still parts (zones, labels,
// walls) are drawn once per size into an offscreen canvas and copied each frame; the
// moving parts (closed doors, blocks, robots, highlights) are drawn on top. Drawing
// happens in requestAnimationFrame and only when something changed, so frames arriving
// 20 times a second cost one redraw each however many robots there are.

const ROBOT = 2; // robots are 2 x 2 map units
const BLOCK = 1; // blocks 1 x 1
const CHIP = 1.6; // a block the player sees, drawn as a chip in its room
const CHIP_GAP = 0.5;

class Renderer {
  constructor(canvas, map) {
    this.canvas = canvas;
    this.map = map;
    this.ctx = canvas.getContext('2d');
    this.still = document.createElement('canvas');
    this.scale = 1;
    this.chipBoxes = []; // where the player's block chips were drawn, for clicks
    // The map box the canvas shows, in map units: lets tests click a place by coordinates.
    const { x, y, w, h } = map.bounds;
    canvas.dataset.bounds = [x, y, w, h].join(' ');
    this.resize();
  }

  /** Fits the map into the stage, keeping its proportions and the screen's pixel density. */
  resize() {
    const stage = this.canvas.parentElement;
    const { w, h } = this.map.bounds;
    const availW = Math.max(100, stage.clientWidth - 16);
    const availH = Math.max(100, stage.clientHeight - 16);
    const scale = Math.min(availW / w, availH / h);
    const cssW = Math.floor(w * scale);
    const cssH = Math.floor(h * scale);
    const dpr = window.devicePixelRatio || 1;
    if (this.cssW === cssW && this.cssH === cssH && this.dpr === dpr) return;
    Object.assign(this, { scale, cssW, cssH, dpr });
    this.canvas.style.width = `${cssW}px`;
    this.canvas.style.height = `${cssH}px`;
    for (const c of [this.canvas, this.still]) {
      c.width = Math.round(cssW * dpr);
      c.height = Math.round(cssH * dpr);
    }
    this.drawStill();
    page.dirty = true;
  }

  /** Map units to canvas pixels: the transform every drawing call works under. */
  toMapTransform(ctx) {
    const k = this.scale * this.dpr;
    ctx.setTransform(k, 0, 0, k, -this.map.bounds.x * k, -this.map.bounds.y * k);
  }

  /** A mouse event's position in map units. */
  eventToMap(event) {
    const rect = this.canvas.getBoundingClientRect();
    return {
      x: (event.clientX - rect.left) / this.scale + this.map.bounds.x,
      y: (event.clientY - rect.top) / this.scale + this.map.bounds.y,
    };
  }

  /** A font size in map units that stays readable: between 9 and 14 screen pixels. */
  fontUnits(pixels) {
    return Math.min(14, Math.max(9, pixels)) / this.scale;
  }

  drawStill() {
    const ctx = this.still.getContext('2d');
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.still.width, this.still.height);
    this.toMapTransform(ctx);
    const unit = 1 / this.scale; // one screen pixel in map units
    ctx.fillStyle = '#1d2126';
    const b = this.map.bounds;
    ctx.fillRect(b.x, b.y, b.w, b.h);
    for (const z of this.map.zones) {
      ctx.fillStyle = zoneFill(z);
      ctx.fillRect(z.x, z.y, z.w, z.h);
      if (z.kind === 'blockade') {
        // Hatched: never entered.
        ctx.save();
        ctx.beginPath();
        ctx.rect(z.x, z.y, z.w, z.h);
        ctx.clip();
        ctx.strokeStyle = '#6d5f52';
        ctx.lineWidth = 2 * unit;
        for (let d = -z.h; d < z.w; d += 1.5) {
          ctx.beginPath();
          ctx.moveTo(z.x + d, z.y + z.h);
          ctx.lineTo(z.x + d + z.h, z.y);
          ctx.stroke();
        }
        ctx.restore();
      }
      // Faint borders between halls, so the places one can go to are visible.
      ctx.strokeStyle = 'rgba(0,0,0,0.12)';
      ctx.lineWidth = unit;
      ctx.strokeRect(z.x, z.y, z.w, z.h);
    }
    // Spawn points: small crosses.
    ctx.strokeStyle = 'rgba(0,0,0,0.25)';
    ctx.lineWidth = unit;
    for (const [x, y] of this.map.spawns) {
      ctx.beginPath();
      ctx.moveTo(x - 0.4, y);
      ctx.lineTo(x + 0.4, y);
      ctx.moveTo(x, y - 0.4);
      ctx.lineTo(x, y + 0.4);
      ctx.stroke();
    }
    // Walls.
    ctx.strokeStyle = '#30343a';
    ctx.lineWidth = Math.max(0.3, 3 * unit);
    ctx.lineCap = 'square';
    for (const [x1, y1, x2, y2] of this.map.walls) {
      ctx.beginPath();
      ctx.moveTo(x1, y1);
      ctx.lineTo(x2, y2);
      ctx.stroke();
    }
    // Labels: rooms at their top-left, halls faint at their centre.
    const size = this.fontUnits(this.scale * 1.1);
    ctx.textBaseline = 'top';
    for (const z of this.map.zones) {
      if (z.w < size * 3) continue;
      ctx.font = `${z.isRoom ? '600 ' : ''}${size}px system-ui, sans-serif`;
      if (z.isRoom) {
        ctx.fillStyle = z.isDrop ? '#5a4300' : '#3b3f45';
        ctx.textAlign = 'left';
        ctx.fillText(z.name, z.x + 0.5, z.y + 0.5, z.w - 1);
      } else {
        ctx.fillStyle = 'rgba(0,0,0,0.35)';
        ctx.textAlign = 'center';
        ctx.fillText(z.name, z.x + z.w / 2, z.y + z.h / 2 - size / 2, z.w - 0.5);
      }
    }
  }

  /** Draws one picture. `scene`: {occupied: Set, blocks, robots, at, inRoom, me, chips,
   * atBlock, hover}; see spectatorScene and playerScene. */
  draw(scene) {
    const ctx = this.ctx;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    ctx.drawImage(this.still, 0, 0);
    this.toMapTransform(ctx);
    const unit = 1 / this.scale;

    if (scene.hover) {
      const z = scene.hover;
      ctx.fillStyle = 'rgba(255,255,255,0.18)';
      ctx.fillRect(z.x, z.y, z.w, z.h);
    }
    if (scene.at) {
      // The player's place: the only position a player knows.
      const z = scene.at;
      ctx.fillStyle = 'rgba(40,140,255,0.28)';
      ctx.fillRect(z.x, z.y, z.w, z.h);
      ctx.strokeStyle = '#1f7ae0';
      ctx.lineWidth = 3 * unit;
      ctx.strokeRect(z.x + 1.5 * unit, z.y + 1.5 * unit, z.w - 3 * unit, z.h - 3 * unit);
      const size = this.fontUnits(this.scale * 1.2);
      ctx.font = `600 ${size}px system-ui, sans-serif`;
      ctx.textAlign = 'right';
      ctx.textBaseline = 'bottom';
      ctx.fillStyle = '#0b4fa0';
      const text = `▶ ${scene.me || 'you'}`;
      const right = z.x + z.w - 0.4;
      ctx.fillText(text, right, z.y + z.h - 0.3, z.w - 0.8);
      if (scene.holdingColor) {
        // What it carries, as a block beside its name.
        const w = Math.min(ctx.measureText(text).width, z.w - 0.8);
        ctx.fillStyle = colourCss(scene.holdingColor);
        ctx.fillRect(right - w - BLOCK - 0.3, z.y + z.h - 0.3 - size * 0.9, BLOCK, BLOCK);
        ctx.strokeStyle = 'rgba(0,0,0,0.6)';
        ctx.lineWidth = unit;
        ctx.strokeRect(right - w - BLOCK - 0.3, z.y + z.h - 0.3 - size * 0.9, BLOCK, BLOCK);
      }
    }

    // Doors: a bar across the opening while the room is occupied (closed for everyone
    // else), a thin dashed line while it is free.
    for (const [room, lines] of this.map.openings) {
      const closed = scene.occupied.has(room);
      ctx.strokeStyle = closed ? '#d8342c' : 'rgba(60,64,70,0.45)';
      ctx.lineWidth = closed ? Math.max(0.35, 5 * unit) : unit;
      ctx.setLineDash(closed ? [] : [3 * unit, 3 * unit]);
      for (const [x1, y1, x2, y2] of lines) {
        ctx.beginPath();
        ctx.moveTo(x1, y1);
        ctx.lineTo(x2, y2);
        ctx.stroke();
      }
    }
    ctx.setLineDash([]);

    // Blocks lying in rooms (held ones are drawn on their robot).
    ctx.lineWidth = unit;
    for (const b of scene.blocks || []) {
      if (b.held_by !== undefined && b.held_by !== null) continue;
      ctx.fillStyle = colourCss(b.color);
      ctx.fillRect(b.x - BLOCK / 2, b.y - BLOCK / 2, BLOCK, BLOCK);
      ctx.strokeStyle = 'rgba(0,0,0,0.55)';
      ctx.strokeRect(b.x - BLOCK / 2, b.y - BLOCK / 2, BLOCK, BLOCK);
    }

    // The player's view of blocks: chips in the room it is in.
    this.chipBoxes = [];
    if (scene.inRoom && scene.chips?.length) this.drawChips(ctx, scene.inRoom, scene.chips, scene.atBlock);

    // Robots: 2 x 2 squares, the held block's colour inside, the name above.
    const label = this.fontUnits(this.scale * 1.0);
    ctx.font = `600 ${label}px system-ui, sans-serif`;
    ctx.textAlign = 'center';
    ctx.textBaseline = 'bottom';
    for (const r of scene.robots || []) {
      const x = r.x - ROBOT / 2;
      const y = r.y - ROBOT / 2;
      ctx.fillStyle = '#2a2f36';
      ctx.fillRect(x, y, ROBOT, ROBOT);
      if (r.holdingColor) {
        ctx.fillStyle = colourCss(r.holdingColor);
        ctx.fillRect(r.x - 0.55, r.y - 0.55, 1.1, 1.1);
      }
      ctx.strokeStyle = r.state === 'collided' ? '#ff3b30' : r.state === 'traveling' ? '#ffffff' : '#9aa3ad';
      ctx.lineWidth = 2 * unit;
      ctx.strokeRect(x, y, ROBOT, ROBOT);
      const w = ctx.measureText(r.name).width;
      ctx.fillStyle = 'rgba(20,22,26,0.7)';
      ctx.fillRect(r.x - w / 2 - 2 * unit, y - label - 2 * unit, w + 4 * unit, label + 2 * unit);
      ctx.fillStyle = '#ffffff';
      ctx.fillText(r.name, r.x, y - unit);
    }
  }

  /** The blocks a player sees in its room. Their positions are not in the percepts, so
   * they are laid out as a grid of chips; the grid is clickable (goToBlock). */
  drawChips(ctx, room, chips, atBlock) {
    const unit = 1 / this.scale;
    const top = room.y + 0.6 + this.fontUnits(this.scale * 1.1) + 0.4;
    const cols = Math.max(1, Math.floor((room.w - CHIP_GAP) / (CHIP + CHIP_GAP)));
    const size = this.fontUnits(this.scale * 0.8);
    ctx.font = `600 ${size}px system-ui, sans-serif`;
    ctx.textAlign = 'center';
    ctx.textBaseline = 'middle';
    chips.forEach((chip, i) => {
      const x = room.x + CHIP_GAP + (i % cols) * (CHIP + CHIP_GAP);
      const y = top + Math.floor(i / cols) * (CHIP + CHIP_GAP);
      ctx.fillStyle = colourCss(chip.color);
      ctx.fillRect(x, y, CHIP, CHIP);
      ctx.strokeStyle = chip.id === atBlock ? '#1f7ae0' : 'rgba(0,0,0,0.6)';
      ctx.lineWidth = (chip.id === atBlock ? 4 : 1) * unit;
      ctx.strokeRect(x, y, CHIP, CHIP);
      if (CHIP * this.scale >= 18) {
        ctx.fillStyle = chip.color === 'Blue' || chip.color === 'Magenta' ? '#fff' : '#111';
        ctx.fillText(String(chip.id), x + CHIP / 2, y + CHIP / 2, CHIP);
      }
      this.chipBoxes.push({ id: chip.id, x, y, w: CHIP, h: CHIP });
    });
  }

  chipAt(x, y) {
    return this.chipBoxes.find((c) => x >= c.x && x < c.x + c.w && y >= c.y && y < c.y + c.h) || null;
  }
}

function zoneFill(z) {
  if (z.isDrop) return '#f3d77a';
  switch (z.kind) {
    case 'room':
      return '#e9e4d8';
    case 'charging':
      return '#bfe3c4';
    case 'blockade':
      return '#8c7b6b';
    default:
      return '#c9ced6';
  }
}

/** The one drawing loop: redraws when something changed, and lets the replay advance. */
function animate(now) {
  if (page.view === 'replay') replay.step(now);
  if (page.dirty && page.renderer) {
    page.dirty = false;
    const started = performance.now();
    const scene = page.view === 'player' ? playerScene() : spectatorScene();
    page.renderer.draw(scene);
    // How many pictures were drawn and the time they took: shown to tests, which check
    // that drawing keeps up with the frames.
    page.draws += 1;
    page.drawMs += performance.now() - started;
    page.renderer.canvas.dataset.draws = String(page.draws);
    page.renderer.canvas.dataset.drawMs = page.drawMs.toFixed(1);
  }
  requestAnimationFrame(animate);
}

// ---- 4. shared panels ------------------------------------------------------------------

function setStatus(status, detail = '') {
  const node = $('#status');
  node.dataset.status = status;
  setText(node, detail ? `${status} (${detail})` : status);
}

function setTick(tick, simSeconds) {
  const node = $('#tick');
  node.dataset.tick = String(tick);
  setText(node, tick);
  if (simSeconds !== undefined) setText($('#sim-time'), `${Number(simSeconds).toFixed(1)} s`);
}

/** The colour sequence as chips; delivered ones dimmed, the next one marked. */
function showSequence(sequence, index) {
  const list = $('#sequence');
  if (list.dataset.colours !== sequence.join(' ')) {
    list.dataset.colours = sequence.join(' ');
    list.replaceChildren(
      ...sequence.map((c, i) =>
        el('li', { title: `${i}: ${c}`, dataset: { color: c, position: String(i) }, style: `--chip:${colourCss(c)}` }, c),
      ),
    );
  }
  list.querySelectorAll('li').forEach((li, i) => {
    li.classList.toggle('done', i < index);
    li.classList.toggle('current', i === index);
  });
  const node = $('#sequence-index');
  node.dataset.index = String(index);
  setText(node, index);
  setText($('#sequence-length'), sequence.length);
  $('#sequence-box').classList.toggle('complete', sequence.length > 0 && index >= sequence.length);
}

const LOG_LIMIT = 300;

/** Appends to a log list, newest at the bottom, keeping it short and scrolled down. */
function appendLog(list, node) {
  const stick = list.scrollTop + list.clientHeight >= list.scrollHeight - 4;
  list.append(node);
  while (list.children.length > LOG_LIMIT) list.firstElementChild.remove();
  if (stick) list.scrollTop = list.scrollHeight;
}

function addMessage(tick, from, to, text) {
  appendLog(
    $('#messages'),
    el(
      'li',
      { dataset: { from, to: to ?? '' } },
      el('span', { class: 'when' }, `${tick ?? ''}`),
      el('b', {}, from),
      to ? el('span', { class: 'to' }, ` → ${to}`) : '',
      ': ',
      text,
    ),
  );
}

/** The player's event log: kind is 'sent', 'ok', 'reject', 'result', 'error' or 'info'.
 * `data` goes into data- attributes (action, outcome, code), for tests and styling. */
function log(kind, text, tick, data = {}) {
  const dataset = { kind };
  for (const [key, value] of Object.entries(data)) if (value !== undefined) dataset[key] = String(value);
  appendLog($('#log'), el('li', { class: kind, dataset }, el('span', { class: 'when' }, `${tick ?? ''}`), text));
}

function showBanner(text) {
  const banner = $('#banner');
  banner.textContent = text;
  banner.hidden = false;
}

function endMatch(message) {
  page.ended = true;
  setStatus('ended', message.reason);
  const r = message.result || {};
  const seq = r.sequence ? `, sequence ${r.sequence_index}/${r.sequence.length}` : '';
  let mine = '';
  if (page.view === 'player') {
    const me = (r.per_robot || []).find((robot) => robot.name === player.name);
    if (me) mine = `; you delivered ${me.good_drops} in order${me.wrong_drops ? `, ${me.wrong_drops} wrong` : ''}`;
  }
  showBanner(`Match over: ${message.reason} after ${r.ticks ?? '?'} ticks${seq}${mine}`);
}

// Hovering a place names it (all views) and shows it can be clicked (player view).
function setupHover(canvas) {
  const tip = $('#hover');
  canvas.addEventListener('mousemove', (event) => {
    if (!page.renderer) return;
    const p = page.renderer.eventToMap(event);
    const chip = page.view === 'player' ? page.renderer.chipAt(p.x, p.y) : null;
    const zone = zoneAt(page.map, p.x, p.y);
    if (zone !== page.hover) {
      page.hover = zone;
      page.dirty = true;
    }
    const text = chip ? `block ${chip.id}` : zone ? zone.name : '';
    tip.hidden = !text;
    setText(tip, text);
    const stage = canvas.parentElement.getBoundingClientRect();
    tip.style.left = `${event.clientX - stage.left + 14}px`;
    tip.style.top = `${event.clientY - stage.top + 14}px`;
    canvas.style.cursor = page.view === 'player' && (chip || zone) ? 'pointer' : 'default';
  });
  canvas.addEventListener('mouseleave', () => {
    tip.hidden = true;
    page.hover = null;
    page.dirty = true;
  });
}

// ---- 5. connection ---------------------------------------------------------------------

function socketUrl() {
  return `${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`;
}

/** Opens the WebSocket, says `hello` and hands every server message to onMessage.
 * The contract is one message per text frame; several lines in one frame are accepted
 * too, as the TCP protocol would send them. */
function openSocket(hello, onMessage, onClose) {
  const ws = new WebSocket(socketUrl());
  ws.addEventListener('open', () => ws.send(JSON.stringify(hello)));
  ws.addEventListener('message', (event) => {
    if (typeof event.data !== 'string') return;
    for (const line of event.data.split('\n')) {
      if (!line.trim()) continue;
      let message;
      try {
        message = JSON.parse(line);
      } catch {
        console.warn('bw4t: not JSON from the server:', line);
        continue;
      }
      onMessage(message);
    }
  });
  ws.addEventListener('close', (event) => onClose(event));
  return {
    ws,
    send(message) {
      if (ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(message));
    },
    close() {
      ws.close();
    },
  };
}

/** The URL parameter holding each role's credential (PROTOCOL.md, Roles). */
const TOKEN_PARAMS = { agent: 'token', spectator: 'spectator_token', operator: 'operator_token' };

/** A `hello` with the credential of its role from the page's address, if given. */
function helloFor(extra) {
  const hello = { type: 'hello', protocol: 'bw4t', versions: [1], ...extra };
  const token = params.get(TOKEN_PARAMS[extra.role || 'agent']);
  if (token) hello.token = token;
  return hello;
}

/** A note above the message list (why messages are missing), or none. */
function setWatchNote(text) {
  const note = $('#watch-note');
  note.hidden = !text;
  setText(note, text || '');
}

function showMatch(match) {
  page.match = match;
  setText($('#mode'), match.mode);
}

// ---- 6. spectator ----------------------------------------------------------------------

const spectator = {
  socket: null,
  frame: null, // the latest frame: the whole state of the match
};

function startSpectator() {
  setView('spectator');
  setStatus('connecting');
  setWatchNote('');
  // With the operator token the overview shows every message; else it is a spectator's.
  const role = params.get('operator_token') ? 'operator' : 'spectator';
  const socket = openSocket(
    helloFor({ role }),
    (message) => {
      if (spectator.socket !== socket) return; // the player view took over
      switch (message.type) {
        case 'welcome':
          showMatch(message.match);
          setStatus('connected');
          if (message.private_messages === false) setWatchNote('Messages to one player are not shown to spectators.');
          break;
        case 'frame':
          showFrame(message);
          break;
        case 'match_end':
          endMatch(message);
          break;
        case 'error':
          console.warn('bw4t spectator error', message);
          if (message.fatal) setStatus('error', message.code);
          if (message.code === 'bad_token') {
            setWatchNote(`Cannot watch: ${message.message}. Open the page with ?${TOKEN_PARAMS[role]}=SECRET to watch; joining as a player needs ?token=SECRET.`);
          }
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

function stopSpectator() {
  const socket = spectator.socket;
  spectator.socket = null;
  socket?.close();
}

/** A frame (live or from a replay): keep it, update the panels, redraw. */
function showFrame(frame) {
  spectator.frame = frame;
  page.frames += 1;
  page.renderer.canvas.dataset.frames = String(page.frames);
  setTick(frame.tick, frame.sim_seconds);
  showSequence(frame.sequence || [], frame.sequence_index ?? 0);
  showRobotList(frame);
  // A replay lists messages from its own index (frames skipped or sought past carry some).
  if (page.view !== 'replay') for (const m of frame.messages || []) addMessage(frame.tick, m.from, m.to, m.text);
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

function spectatorScene() {
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

// ---- 7. player -------------------------------------------------------------------------
//
// The player's beliefs are kept exactly as protocol/README.md says: a full snapshot
// clears them; `not` facts are removed, then `add` facts stored; `at`, `state` and
// `sequenceIndex` are single-valued (a new one replaces the old); `message` facts are
// events, shown once and never stored. The view shows only these beliefs (plus the
// colours of blocks seen earlier, which the player was told and may remember).

const SINGLE_VALUED = new Set(['at', 'state', 'sequenceIndex']);

class Beliefs {
  constructor() {
    this.facts = new Map(); // JSON of the fact -> fact
    this.single = new Map(); // name -> fact, for single-valued facts
  }

  /** Applies one `percepts` message; returns its message events [[from, text], ...]. */
  apply(percepts) {
    if (percepts.full) {
      this.facts.clear();
      this.single.clear();
    }
    for (const fact of percepts.not || []) {
      if (SINGLE_VALUED.has(fact[0])) continue; // never negated, by the protocol
      this.facts.delete(JSON.stringify(fact));
    }
    const events = [];
    for (const fact of percepts.add || []) {
      if (fact[0] === 'message') events.push([fact[1], fact[2]]);
      else if (SINGLE_VALUED.has(fact[0])) this.single.set(fact[0], fact);
      else this.facts.set(JSON.stringify(fact), fact);
    }
    return events;
  }

  /** The argument lists of every fact of that name. */
  all(name) {
    const out = [];
    for (const fact of this.facts.values()) if (fact[0] === name) out.push(fact.slice(1));
    for (const fact of this.single.values()) if (fact[0] === name) out.push(fact.slice(1));
    return out;
  }

  /** The first argument of the (single) fact of that name, or undefined. */
  one(name) {
    const fact = this.single.get(name);
    if (fact) return fact[1];
    for (const f of this.facts.values()) if (f[0] === name) return f[1];
    return undefined;
  }
}

const player = {
  socket: null,
  name: null,
  robot: null,
  beliefs: new Beliefs(),
  remembered: new Map(), // block id -> colour, from every `color` fact seen
  nextId: 1,
  pending: new Map(), // request id -> {words, durative, say}: for the log until answered
  retriedWithName: false,
};

const sessionKey = (name) => `bw4t-session:${location.host}:${name}`;

function joinAsPlayer(name) {
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
  // After a reload, take the robot back with the session the server gave this tab.
  const session = sessionStorage.getItem(sessionKey(name));
  connectPlayer(session ? { session } : { name });
}

function connectPlayer(identity) {
  player.beliefs = new Beliefs();
  // Messages from a socket that was replaced (its trailing `bye`) are not this player's.
  const onMessage = (message) => player.socket === socket && onPlayerMessage(message);
  const socket = openSocket(helloFor(identity), onMessage, () => {
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
      sessionStorage.setItem(sessionKey(message.name), message.session);
      showMatch(message.match);
      setText($('#me'), `${message.name} (robot ${message.robot})`);
      setStatus('connected');
      log('info', `joined as ${message.name}, robot ${message.robot}; ${message.match.mode} match on ${message.match.map}`);
      break;
    case 'percepts':
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
      endMatch(message);
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
  if (['invalid_name', 'name_taken', 'match_full', 'bad_token'].includes(message.code)) {
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

function onPercepts(percepts) {
  const events = player.beliefs.apply(percepts);
  for (const [id, colour] of player.beliefs.all('color')) player.remembered.set(id, colour);
  for (const [from, text] of events) addMessage(percepts.tick, from, null, text);
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

function showPlayerPanel() {
  const b = player.beliefs;
  const seq = b.one('sequence') || [];
  showSequence(seq, b.one('sequenceIndex') ?? 0);
  setText($('#at'), b.one('at') ?? '–');
  setText($('#in'), b.one('in') ?? '–');
  const state = $('#state');
  setText(state, b.one('state') ?? '–');
  state.dataset.state = b.one('state') ?? '';

  const holding = $('#holding');
  const held = b.one('holding');
  const heldColour = held !== undefined ? player.remembered.get(held) : undefined;
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
  const atBlock = b.one('atBlock');
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

function playerScene() {
  const b = player.beliefs;
  const map = page.map;
  const inName = b.one('in');
  return {
    occupied: new Set(b.all('occupied').map(([room]) => room)),
    at: map.byName.get(b.one('at')) || null,
    inRoom: map.byName.get(inName) || null,
    chips: visibleBlocks(),
    atBlock: b.one('atBlock'),
    holdingColor: b.one('holding') !== undefined ? player.remembered.get(b.one('holding')) || '?' : null,
    me: player.name,
    hover: page.hover,
  };
}

/** Sends an action; the log line names it until its ack and result come back. */
function act(action, args = []) {
  if (!player.socket || page.ended) return;
  const id = player.nextId++;
  let words = [action, ...args].join(' ');
  if (action === 'goToBlock' && player.remembered.has(args[0])) words += ` (${player.remembered.get(args[0])})`;
  player.pending.set(id, { words, action, durative: action === 'goTo' || action === 'goToBlock' });
  player.socket.send({ type: 'act', id, action, args });
  log('sent', words, undefined, { action });
}

function say(to, text) {
  if (!player.socket || page.ended) return;
  const id = player.nextId++;
  const words = `say to ${to}: ${text}`;
  player.pending.set(id, { words, action: 'say', say: { to, text } });
  player.socket.send({ type: 'say', id, to, text });
  log('sent', words, undefined, { action: 'say' });
}

function setupPlayerControls(canvas) {
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

// ---- 8. replay -------------------------------------------------------------------------
//
// Frames come one per request from /replay/frame/T and are cached. While playing, the
// position advances by tick_hz x speed ticks per second and the newest fetched frame not
// past it is shown; frames ahead are fetched a few at a time, every tick at low speed and
// every few ticks at high speed (frames hold the whole state, so skipping costs nothing).
// If the fetches fall behind, playback waits for them instead of jumping. The message list
// comes from every message of the match, in /replay.json: whatever tick is shown, it holds
// the messages sent up to that tick (the newest LOG_LIMIT of them).

const replay = {
  ticks: 0,
  tickHz: 20,
  cache: new Map(), // tick -> frame
  loading: new Set(), // ticks being fetched
  failed: new Map(), // tick -> time of the failure, to retry later
  position: 0, // the tick wanted (fractional while playing)
  shown: -1, // the tick on screen
  playing: false,
  speed: 1,
  last: null, // time of the previous step
  seeking: null, // the tick sought and not yet on screen
  scrubbing: false,
  messages: [], // every message of the match {tick, from, to, text}, by tick
  listed: 0, // how many of them (from the first) the message list reflects

  MAX_LOADING: 6,
  MAX_CACHED: 5000,

  async start() {
    setView('replay');
    setStatus('replay');
    setText($('#mode'), 'replay');
    const info = await fetchJSON('/replay.json');
    this.ticks = info.ticks;
    this.tickHz = info.tick_hz || 20;
    this.messages = info.messages || [];
    const players = (info.players || []).map((p) => (typeof p === 'string' ? p : p.name ?? JSON.stringify(p)));
    setText($('#replay-about'), `seed ${info.seed}${players.length ? `, ${players.join(', ')}` : ''}`);
    const scrub = $('#scrub');
    scrub.max = String(this.ticks);
    this.speed = Number(params.get('speed')) || 1;
    $('#speed').value = String(this.speed);
    this.position = Math.min(this.ticks, Math.max(0, Number(params.get('tick')) || 0));
    scrub.value = String(this.position);

    $('#play').addEventListener('click', () => this.play());
    $('#pause').addEventListener('click', () => this.pause());
    $('#speed').addEventListener('change', (e) => {
      this.speed = Number(e.target.value) || 1;
    });
    scrub.addEventListener('pointerdown', () => (this.scrubbing = true));
    scrub.addEventListener('pointerup', () => (this.scrubbing = false));
    scrub.addEventListener('input', () => this.seek(Number(scrub.value)));
    scrub.addEventListener('change', () => {
      this.scrubbing = false;
      this.seek(Number(scrub.value));
    });
    document.addEventListener('keydown', (event) => {
      if (event.target.closest?.('input:not([type=range]), textarea, select')) return;
      if (event.key === ' ') {
        event.preventDefault();
        if (this.playing) this.pause();
        else this.play();
      }
    });
    this.showButtons();
    this.fetchAhead();
  },

  play() {
    if (this.shown >= this.ticks) this.seek(0); // from the start again
    this.playing = true;
    this.last = null;
    this.showButtons();
  },

  pause() {
    this.playing = false;
    if (this.seeking === null) this.position = Math.max(this.shown, 0);
    this.showButtons();
  },

  seek(tick) {
    this.position = Math.min(this.ticks, Math.max(0, Math.round(tick)));
    if (this.position === this.shown) {
      this.seeking = null;
      return;
    }
    this.seeking = this.position;
    this.fetch(this.position); // first, before the frames ahead
    this.fetchAhead();
    this.showCached();
  },

  showButtons() {
    $('#play').disabled = this.playing;
    $('#pause').disabled = !this.playing;
    document.body.dataset.playing = String(this.playing);
  },

  /** Called from the drawing loop. */
  step(now) {
    // After a seek, the clock waits until the frame sought is on screen.
    if (this.playing && this.seeking === null) {
      const dt = this.last === null ? 0 : Math.min(0.25, (now - this.last) / 1000);
      // Never run more than a quarter second of frames ahead of what is on screen.
      const lead = Math.max(2, this.tickHz * this.speed * 0.25);
      this.position = Math.min(this.position + dt * this.tickHz * this.speed, Math.max(this.shown, 0) + lead, this.ticks);
      this.showCached();
      if (this.shown >= this.ticks) this.pause();
    }
    this.last = now;
    this.fetchAhead();
  },

  /** Shows the frame for the position if it is fetched. While playing forwards, any
   * fetched frame between the one shown and the position will do; after a seek, only the
   * frame sought. */
  showCached() {
    if (this.seeking !== null) {
      if (this.cache.has(this.seeking)) this.display(this.seeking);
      return;
    }
    const want = Math.floor(this.position);
    if (want === this.shown) return;
    let t = want;
    const floor = want > this.shown ? this.shown : want - 1;
    while (t > floor && !this.cache.has(t)) t--;
    if (t > floor && t !== this.shown) this.display(t);
  },

  display(tick) {
    this.shown = tick;
    this.seeking = null;
    showFrame(this.cache.get(tick));
    this.listMessages(tick);
    if (!this.scrubbing) $('#scrub').value = String(tick);
    setText($('#replay-position'), `${tick} / ${this.ticks}`);
  },

  /** Makes the message list hold the messages sent up to `tick`: appends when moving
   * forwards, starts again when moving back or too far ahead. */
  listMessages(tick) {
    const list = $('#messages');
    // Binary search for the first message after `tick`.
    let upTo = 0;
    for (let hi = this.messages.length; upTo < hi; ) {
      const mid = (upTo + hi) >> 1;
      if (this.messages[mid].tick <= tick) upTo = mid + 1;
      else hi = mid;
    }
    let from = this.listed;
    if (upTo < this.listed || upTo - this.listed > LOG_LIMIT) {
      list.replaceChildren();
      from = Math.max(0, upTo - LOG_LIMIT);
    }
    for (const m of this.messages.slice(from, upTo)) addMessage(m.tick, m.from, m.to, m.text);
    this.listed = upTo;
  },

  stride() {
    return Math.max(1, Math.floor(this.speed / 2));
  },

  fetchAhead() {
    const from = Math.floor(this.position);
    const span = Math.min(400, Math.ceil(this.tickHz * Math.max(1, this.speed) * 2));
    const stride = this.stride();
    this.fetch(from);
    for (let t = from - (from % stride) + stride; t <= Math.min(this.ticks, from + span); t += stride) {
      if (this.loading.size >= this.MAX_LOADING) break;
      this.fetch(t);
    }
    if (from + span >= this.ticks) this.fetch(this.ticks);
    setText($('#replay-loading'), this.loading.size ? 'loading…' : '');
  },

  fetch(tick) {
    if (this.cache.has(tick) || this.loading.has(tick)) return;
    if (this.loading.size >= this.MAX_LOADING && tick !== Math.floor(this.position)) return;
    const failedAt = this.failed.get(tick);
    if (failedAt !== undefined && performance.now() - failedAt < 2000) return;
    this.loading.add(tick);
    fetchJSON(`/replay/frame/${tick}`)
      .then((frame) => {
        this.failed.delete(tick);
        this.cache.set(tick, frame);
        this.trimCache();
        this.showCached();
      })
      .catch((err) => {
        console.warn('bw4t replay', err);
        this.failed.set(tick, performance.now());
        setStatus('replay', `frame ${tick} failed`);
      })
      .finally(() => this.loading.delete(tick));
  },

  /** Keeps memory bounded on long replays: drops the frames farthest from the position. */
  trimCache() {
    if (this.cache.size <= this.MAX_CACHED) return;
    const far = [...this.cache.keys()].sort((a, b) => Math.abs(b - this.position) - Math.abs(a - this.position));
    for (const t of far.slice(0, this.cache.size - this.MAX_CACHED * 0.8)) {
      if (t !== this.shown) this.cache.delete(t);
    }
  },
};

// ---- 9. start ----------------------------------------------------------------------------

async function start() {
  let info;
  let mapJson;
  try {
    [info, mapJson] = await Promise.all([fetchJSON('/info.json'), fetchJSON('/map.json')]);
  } catch (err) {
    setStatus('error', err.message);
    return;
  }
  page.map = buildMap(mapJson);
  setText($('#map-name'), mapJson.name || info.map || '?');
  const canvas = $('#map');
  page.renderer = new Renderer(canvas, page.map);
  new ResizeObserver(() => page.renderer.resize()).observe($('#stage'));
  setupHover(canvas);
  setupPlayerControls(canvas);
  requestAnimationFrame(animate);

  if (info.mode === 'replay') {
    try {
      await replay.start();
    } catch (err) {
      setStatus('error', err.message);
    }
    return;
  }
  const name = params.get('play');
  if (name) joinAsPlayer(name);
  else startSpectator();
}

start();
