// The replay viewer: frames of a recorded match, with play, pause, speed and seek.
//
// Frames come one per request from /replay/frame/T and are cached. While playing, the
// position advances by tick_hz x speed ticks per second and the newest fetched frame not
// past it is shown; frames ahead are fetched a few at a time, every tick at low speed and
// every few ticks at high speed (frames hold the whole state, so skipping costs nothing).
// If the fetches fall behind, playback waits for them instead of jumping. The message list
// comes from every message of the match, in /replay.json: whatever tick is shown, it holds
// the messages sent up to that tick (the newest LOG_LIMIT of them). One player's own view
// of the tick shown can be put beside the overview (ownview.js).

import { $, fetchJSON, params, setText } from './dom.js';
import { setView } from './page.js';
import { LOG_LIMIT, addMessage, setStatus } from './panels.js';
import { ownView } from './ownview.js';
import { showFrame } from './spectator.js';

export const replay = {
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
    ownView.setup(players);
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
    ownView.follow(tick, this.cache.get(tick), this.playing);
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
    for (const m of this.messages.slice(from, upTo)) addMessage(m.tick, m.from, m.to, m.text, m.said);
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
