// One player's own view in the replay viewer: what its robot perceived at the tick shown
// (/replay/view/R/T), in a column beside the overview, chosen with a select in the replay
// box ("none" by default, which leaves the viewer as it was).
//
// The facts are kept in the JavaScript client's belief base, as the player view keeps its
// percepts, and the map is drawn by the page's Renderer from the same kind of scene as the
// player view's (the robot's place, the blocks it sees as chips in its room, the occupied
// rooms' doors, what it holds). Views are fetched only for the tick on screen: one request
// at a time, and while playing at most one every VIEW_GAP_MS, the last one always fetched
// once playback stops; the newest few are cached for seeking back and forth.

import { Beliefs } from './client/beliefs.js';
import { $, el, setText } from './dom.js';
import { page } from './page.js';
import { Renderer, colourCss, perceivedScene, visibleBlocks } from './renderer.js';
import { chatLine } from './language.js';
import { LOG_LIMIT } from './panels.js';

const VIEW_GAP_MS = 200;
const MAX_CACHED_VIEWS = 200;

const STYLE = `
#ownview { width: 300px; flex: none; margin: 0.5rem 0 0.5rem 0.5rem; overflow-y: auto; }
#ownview .ownview-stage { position: relative; height: min(320px, 40vh); display: flex; align-items: center; justify-content: center; }
#ownview-map { display: block; box-shadow: 0 0 0 1px #000; }
#ownview .chips li { padding: 0.05rem 0.35rem; border-radius: 3px; font-size: 0.78rem; }
#ownview-sequence li.done { opacity: 0.3; text-decoration: line-through; }
#ownview-sequence li.current { box-shadow: 0 0 0 2px var(--accent); }
#ownview-messages { max-height: 18rem; }
#ownview[data-stale="true"] .facts, #ownview[data-stale="true"] .chips { opacity: 0.6; }
@media (max-width: 760px) { #ownview { width: auto; margin: 0.5rem; } }
`;

export const ownView = {
  robot: null, // the chosen robot's id, null for none
  name: null, // its name
  ids: new Map(), // name -> robot id, from the frames shown
  wanted: -1, // the tick the overview shows
  heldColours: new Map(), // block id -> colour, from the frame shown (see render)
  playing: false,
  views: new Map(), // `${robot}/${tick}` -> view, or null (not in the match then)
  loading: null, // the key being fetched
  lastFetch: -Infinity,
  timer: null,
  renderer: null, // draws the map as the robot perceives it
  beliefs: null, // the view shown, as a belief base

  /** Adds the select to the replay box (`players`: the replay's names) and the column. */
  setup(players) {
    document.head.append(el('style', {}, STYLE));
    const select = el('select', { id: 'ownview-robot', 'aria-label': "a player's own view" }, el('option', { value: '' }, 'none'));
    select.addEventListener('change', () => this.choose(select.value || null));
    $('#replay-box .buttons').append(el('label', {}, 'view of ', select));
    for (const name of players) this.addPlayer(name);

    const section = el(
      'section',
      { id: 'ownview', class: 'box', 'aria-label': "a player's own view", hidden: '' },
      el('h2', {}, el('span', { id: 'ownview-title' }, ''), el('span', { class: 'note' }, 'tick ', el('b', { id: 'ownview-tick' }, '–'))),
      el('div', { class: 'ownview-stage' }, el('canvas', { id: 'ownview-map', role: 'img', 'aria-label': 'the map as the robot perceives it' })),
      el(
        'dl',
        { class: 'facts' },
        ...['at', 'in', 'state', 'holding', 'occupied'].flatMap((fact) => [el('dt', {}, fact), el('dd', { id: `ownview-${fact}` }, '–')]),
      ),
      el('h3', {}, 'Sequence ', el('span', { class: 'note' }, 'next ', el('b', { id: 'ownview-index' }, '–'))),
      el('ol', { id: 'ownview-sequence', class: 'chips', 'aria-label': 'colour sequence as perceived' }),
      el('h3', {}, 'Blocks in view'),
      el('ul', { id: 'ownview-blocks', class: 'chips', 'aria-label': 'blocks in view' }),
      el('p', { class: 'note', id: 'ownview-blocks-empty' }, 'none'),
      el('h3', {}, 'Messages received'),
      el('ol', { id: 'ownview-messages', class: 'log', 'aria-label': 'messages received' }),
      el('p', { class: 'note', id: 'ownview-note', role: 'status' }),
    );
    $('main').insertBefore(section, $('#panel'));
  },

  addPlayer(name) {
    const select = $('#ownview-robot');
    if ([...select.options].some((option) => option.value === name)) return;
    select.append(el('option', { value: name }, name));
  },

  /** Shows `name`'s view from now on, or none. */
  choose(name) {
    this.name = name;
    this.robot = name === null ? null : (this.ids.get(name) ?? null);
    const section = $('#ownview');
    section.hidden = name === null;
    // The overview's stage changed width: app.js's observer redraws it.
    page.dirty = true;
    if (name === null) return;
    setText($('#ownview-title'), `${name}'s view`);
    if (!this.renderer && page.map) {
      this.renderer = new Renderer($('#ownview-map'), page.map);
      new ResizeObserver(() => {
        if (this.renderer.resize()) this.draw();
      }).observe(section.querySelector('.ownview-stage'));
    }
    this.clear();
    this.update();
  },

  /** The overview shows `tick` (its `frame`): the view follows. */
  follow(tick, frame, playing) {
    this.wanted = tick;
    this.playing = playing;
    for (const r of frame?.robots || []) {
      if (!this.ids.has(r.name)) {
        this.ids.set(r.name, r.id);
        this.addPlayer(r.name);
      }
    }
    if (this.name !== null && this.robot === null) this.robot = this.ids.get(this.name) ?? null;
    this.heldColours = new Map((frame?.blocks || []).map((b) => [b.id, b.color]));
    if (this.name !== null) this.update();
  },

  /** Shows the wanted view if it is cached, else fetches it when the pace allows. */
  update() {
    if (this.robot === null) {
      this.note(`${this.name} is not in the match at tick ${this.wanted}`);
      return;
    }
    const key = `${this.robot}/${this.wanted}`;
    if (this.views.has(key)) {
      this.render(this.views.get(key), this.wanted);
      return;
    }
    $('#ownview').dataset.stale = 'true';
    if (this.loading !== null || this.timer !== null) return; // update() runs again after
    const wait = this.playing ? this.lastFetch + VIEW_GAP_MS - performance.now() : 0;
    if (wait > 0) {
      this.timer = setTimeout(() => {
        this.timer = null;
        this.update();
      }, wait);
      return;
    }
    this.fetch(this.robot, this.wanted);
  },

  async fetch(robot, tick) {
    const key = `${robot}/${tick}`;
    this.loading = key;
    this.lastFetch = performance.now();
    try {
      const response = await fetch(`/replay/view/${robot}/${tick}`, { cache: 'no-store' });
      if (response.status === 404) this.keep(key, null);
      else if (!response.ok) throw new Error(`HTTP ${response.status}`);
      else this.keep(key, await response.json());
    } catch (err) {
      console.warn('bw4t replay view', err);
      this.note(`the view of tick ${tick} failed: ${err.message}`);
      this.loading = null;
      return; // tried again when the tick shown changes
    }
    this.loading = null;
    if (this.name !== null) this.update();
  },

  keep(key, view) {
    this.views.set(key, view);
    while (this.views.size > MAX_CACHED_VIEWS) this.views.delete(this.views.keys().next().value);
  },

  note(text) {
    setText($('#ownview-note'), text);
  },

  /** Empties the column (another robot was chosen). */
  clear() {
    this.beliefs = new Beliefs();
    const section = $('#ownview');
    delete section.dataset.tick;
    section.dataset.stale = 'true';
    for (const id of ['#ownview-blocks', '#ownview-sequence', '#ownview-messages']) $(id).replaceChildren();
    for (const fact of ['at', 'in', 'state', 'holding', 'occupied']) setText($(`#ownview-${fact}`), '–');
    setText($('#ownview-tick'), '–');
    this.note('');
    this.draw();
  },

  /** Shows a view (null: the robot was not in the match at `tick`). */
  render(view, tick) {
    const section = $('#ownview');
    section.dataset.tick = String(tick);
    section.dataset.robot = String(this.robot);
    section.dataset.stale = 'false';
    setText($('#ownview-tick'), tick);
    if (view === null) {
      this.clear();
      section.dataset.tick = String(tick);
      section.dataset.stale = 'false';
      this.note(`${this.name} is not in the match at tick ${tick}`);
      return;
    }
    this.note('');
    const b = new Beliefs();
    b.apply({ tick: view.tick, full: true, add: view.facts });
    this.beliefs = b;

    setText($('#ownview-at'), b.get('at') ?? '–');
    setText($('#ownview-in'), b.get('in') ?? '–');
    setText($('#ownview-state'), b.get('state') ?? '–');
    const occupied = b.all('occupied').map(([room]) => room).sort();
    setText($('#ownview-occupied'), occupied.length ? occupied.join(', ') : 'none');

    // A robot saw the block it holds when it picked it up; its percepts now name only the
    // blocks in its room, so the colour comes from the frame when it is out of sight.
    const holding = $('#ownview-holding');
    const held = b.get('holding');
    const heldColour = held === undefined ? '' : b.colourOf(held) || this.heldColours.get(held) || '?';
    holding.dataset.blockId = held === undefined ? '' : String(held);
    holding.dataset.color = heldColour;
    if (held === undefined) setText(holding, 'nothing');
    else holding.replaceChildren(el('span', { class: 'swatch', style: `--chip:${colourCss(heldColour)}` }, `${heldColour} (block ${held})`));

    const sequence = b.get('sequence') || [];
    const index = b.get('sequenceIndex') ?? 0;
    const indexNode = $('#ownview-index');
    indexNode.dataset.index = String(index);
    setText(indexNode, `${index} of ${sequence.length}`);
    $('#ownview-sequence').replaceChildren(
      ...sequence.map((colour, i) =>
        el(
          'li',
          { class: i < index ? 'done' : i === index ? 'current' : '', dataset: { color: colour }, style: `background:${colourCss(colour)};color:#111` },
          colour,
        ),
      ),
    );

    const blocks = visibleBlocks(this.beliefs);
    const atBlock = b.get('atBlock');
    $('#ownview-blocks').replaceChildren(
      ...blocks.map((x) =>
        el('li', { class: `chip${x.id === atBlock ? ' at' : ''}`, dataset: { blockId: String(x.id), color: x.color }, style: `--chip:${colourCss(x.color)}` }, `${x.color} ${x.id}`),
      ),
    );
    $('#ownview-blocks-empty').hidden = blocks.length > 0;

    this.listMessages(view.messages || []);
    this.draw();
  },

  /** The messages received by then, as sentences, newest last (the newest LOG_LIMIT). */
  listMessages(messages) {
    const list = $('#ownview-messages');
    const shown = messages.slice(-LOG_LIMIT);
    const key = `${messages.length}:${shown.at(-1)?.tick ?? ''}`;
    if (list.dataset.key === key) return;
    list.dataset.key = key;
    list.replaceChildren(
      ...shown.map(({ tick, message }) => {
        const line = chatLine(message.text, message.said || null);
        return el(
          'li',
          { dataset: { from: message.from, to: message.to ?? '', tick: String(tick) } },
          el('span', { class: 'when' }, String(tick)),
          el('b', {}, message.from),
          message.to && message.to !== 'all' ? el('span', { class: 'to' }, ` → ${message.to}`) : '',
          ': ',
          el('span', { class: 'sentence' }, line.sentence),
        );
      }),
    );
    list.scrollTop = list.scrollHeight;
  },


  /** The map as the robot perceives it: the scene the player view draws (player.js). */
  draw() {
    if (!this.renderer || !this.beliefs) return;
    const held = this.beliefs.get('holding');
    const holding = held !== undefined ? $('#ownview-holding').dataset.color || '?' : null;
    this.renderer.draw(perceivedScene(this.beliefs, page.map, this.name, holding));
  },
};
