// One player's protocol session without I/O: server lines or messages in, events and
// client lines out. It builds the `hello`, numbers actions, matches `ack`s and `result`s
// to them, keeps the belief base and the lockstep `ready` rule, answers `resync`s and
// knows how to take the robot back. The Node client (client.js) drives it over TCP and
// the browser page (crates/bw4t-server/web/player.js) over its WebSocket, so it imports
// nothing from Node (the server serves it at /client/core.js).

import { Beliefs } from './beliefs.js';
import { DURATIVE } from './table.js';

/** @typedef {import('./beliefs.js').Fact} Fact */
/** @typedef {import('./beliefs.js').ChatMessage} ChatMessage */

/** The protocol's longest line, in bytes. */
export const MAX_LINE_BYTES = 65536;

/**
 * How a player joins: what its `hello` says.
 * @typedef {object} JoinOptions
 * @property {string} [name] the player name wanted (else the server picks `PlayerN`)
 * @property {string} [token] the shared secret
 * @property {string} [session] the `session` of an earlier `welcome`: take that robot back
 * @property {boolean} [everyTick] a `percepts` every tick (`every_tick`)
 * @property {boolean} [words] the robot's situation in English with every `percepts`
 * @property {string} [match] the name of a live match to join
 * @property {string} [template] the name of a template: queued into its next match with a
 *   free seat. Not together with `match`
 * @property {string} [seat] the seat token a study's trial page gives: a template that seats
 *   only invited players refuses a player without it (`not_invited`)
 * @property {object} [fields] more fields of the `hello`, sent as they are
 */

/**
 * An error as plain data (the shape of the protocol's `error`): a fatal one from the
 * server, or the session's own (`connection_closed`, `match_over`, `not_connected`).
 * @typedef {object} SessionError
 * @property {string} code
 * @property {string} message
 * @property {boolean} fatal
 */

/**
 * One `act` or `say` sent. `tag` is the caller's own, given back with every event
 * about it (the Node client's `ActionHandle`, the page's log words).
 * @typedef {object} Request
 * @property {number} id
 * @property {string} action the action (`say` for a `say`)
 * @property {any[]} args
 * @property {boolean} durative whether a `result` follows the `ack` (goTo, goToBlock)
 * @property {SessionError|null} failure why it was not sent (the session is over), if so
 * @property {any} tag
 */

/**
 * Everything one tick brought: the messages received since the previous update,
 * ended by that tick's `percepts`.
 * @typedef {object} Update
 * @property {number} tick the tick of the `percepts`
 * @property {boolean} full whether it was a full snapshot
 * @property {Fact[]} add the `add` list as received (messages included)
 * @property {Fact[]} not the `not` list as received
 * @property {ChatMessage[]} messages the `message` events, oldest first
 * @property {object[]} acks acks received since the previous update
 * @property {object[]} results results received since the previous update
 * @property {object[]} errors non-fatal errors received since the previous update
 * @property {string|null} words the `percepts`' `words`: the robot's situation after it in
 *   a few short lines of English, for people and language models (the wording may change
 *   between releases); `null` unless the `hello` asked for `words`
 * @property {Beliefs} beliefs the session's belief base (live: the state after this
 *   update unless later updates are already applied)
 */

/**
 * What a received line did, in order: `server` (every message, before it is applied),
 * `bad_line` (not JSON), `welcome` (`afterQueue`: seated after waiting in a template's
 * queue), `queued` (the first queue place before `welcome`), `lobby`, `ack` and `result`
 * (with their `request`, or `null` for an unknown id), `settled` (a request's outcome is
 * final and the beliefs show it: its `result`, `null` for a non-durative action), `percepts`
 * (its `update`; `resynced`: the tags of the `resync`s it answers), `joined` (the first
 * `percepts` after `welcome`), `error` (the server's, fatal or not), `pong` (with the
 * ping's `tag`), `match_end`, `bye`, `abandoned` (the session is over: the `error` that
 * ended it and the tags of the requests, resyncs and pings that will get no answer).
 * @typedef {{type: string, [field: string]: any}} SessionEvent
 */

/**
 * Why a `hello` cannot name these (both a match and a template: the server would answer
 * `bad_message`), or `null` when it can.
 * @param {JoinOptions} options
 * @returns {string|null}
 */
export function joinConflict({ match, template }) {
  if (!match || !template) return null;
  return (
    `give match or template, not both (match "${match}", template "${template}"): match joins ` +
    'that live match, template queues for the next match of that template'
  );
}

/**
 * The `hello` of these options; what is not given (or false, or an empty match or
 * template) is left out.
 * @param {JoinOptions} options
 */
export function helloOf(options) {
  const hello = { ...options.fields, type: 'hello', protocol: 'bw4t', versions: [1] };
  if (options.name != null) hello.name = options.name;
  if (options.token != null) hello.token = options.token;
  if (options.session != null) hello.session = options.session;
  if (options.everyTick) hello.every_tick = true;
  if (options.words) hello.words = true;
  if (options.match) hello.match = options.match;
  if (options.template) hello.template = options.template;
  if (options.seat) hello.seat = options.seat;
  return hello;
}

const encoder = new TextEncoder();

/** One player's session over one connection. */
export class PlayerSession {
  /** @type {JoinOptions} */
  #options;
  /** Lines to send, oldest first. @type {string[]} */
  #outbox = [];
  /** What a stream delivered after its last newline. */
  #partial = '';
  #nextId = 1;
  /** Requests awaiting their ack or result. @type {Map<number|string, Request>} */
  #pending = new Map();
  /** Requests whose outcome is known but shows in the beliefs only with the next `percepts`. @type {Array<[Request, object|null]>} */
  #toSettle = [];
  /** What arrived since the last `percepts`. */
  #group = { acks: /** @type {object[]} */ ([]), results: /** @type {object[]} */ ([]), errors: /** @type {object[]} */ ([]) };
  /** The tags of the `resync`s sent and not yet answered, oldest first. @type {any[]} */
  #resyncs = [];
  /** @type {Array<[any, any]>} ping id and tag */
  #pings = [];
  /** Whether a `percepts` arrived that no `ready` sent after it answers yet. */
  #unanswered = false;
  #lastTick = -1;
  #byeSent = false;
  #closed = false;

  /** The belief base, kept from every `percepts`. */
  beliefs = new Beliefs();
  /** @type {any} the `welcome` message */
  welcome = null;
  /** @type {string|null} */
  name = null;
  /** @type {number|null} */
  robot = null;
  /** The session token, for taking the robot back. @type {string|null} */
  session = null;
  /** `welcome.match`. @type {any} */
  match = null;
  /** The latest `lobby`. @type {any} */
  lobby = null;
  /** The tick of the last `percepts`. @type {number|null} */
  tick = null;
  /** The last `percepts`' `words`. @type {string|null} */
  words = null;
  /** `match_end.result`. @type {any} */
  result = null;
  /** `match_end.reason`. @type {string|null} */
  endReason = null;
  /** What ended the session in failure, if anything. @type {SessionError|null} */
  error = null;
  /** Whether the match is over for this player (`match_end`, or the server's goodbye). */
  ended = false;
  /** Waiting in a template's queue for a seat (from its first place until `welcome`). */
  queued = false;
  /** Whether the operator has paused the match (the latest `pause`). */
  paused = false;
  /** `welcome` and a `percepts` after it arrived. */
  joined = false;

  /**
   * @param {JoinOptions & Record<string, any>} [options] the options to join with; kept
   *   (others included) for `reconnectOptions()`
   */
  constructor(options = {}) {
    this.#options = options;
  }

  // ---- out -------------------------------------------------------------------------

  /** Queue the `hello`. */
  start() {
    this.#send(helloOf(this.#options));
  }

  /**
   * The lines to send, oldest first (without newlines: a stream ends each with one, a
   * WebSocket sends each as a frame); the outbox is empty afterwards.
   * @returns {string[]}
   */
  takeLines() {
    return this.#outbox.splice(0);
  }

  /**
   * @param {object} message
   */
  #send(message) {
    const line = JSON.stringify(message);
    const bytes = encoder.encode(line).length;
    if (bytes > MAX_LINE_BYTES) {
      throw new RangeError(`message of ${bytes} bytes is longer than the protocol's 64 KiB line limit`);
    }
    this.#outbox.push(line);
  }

  /**
   * Why no new request can be sent, or `null` when one can.
   * @returns {SessionError|null}
   */
  unavailable() {
    if (this.error) return this.error;
    if (this.ended || this.#closed || this.#byeSent) {
      return { code: this.result ? 'match_over' : 'not_connected', message: 'the connection is over', fatal: false };
    }
    return null;
  }

  /**
   * A new request; sent (and awaited) unless the session is over, then `failure` says why.
   * @param {string} action
   * @param {any[]} args
   * @param {object} message the line to send, without its id
   * @param {any} tag
   * @returns {Request}
   */
  #request(action, args, message, tag) {
    const id = this.#nextId++;
    /** @type {Request} */
    const request = { id, action, args, durative: DURATIVE.has(action), failure: this.unavailable(), tag };
    if (request.failure) return request;
    this.#send({ ...message, id });
    this.#pending.set(id, request);
    return request;
  }

  /**
   * An `act`. Throws a `RangeError` (nothing sent) when the line would be too long.
   * @param {string} action
   * @param {any[]} [args]
   * @param {any} [tag]
   */
  act(action, args = [], tag = null) {
    return this.#request(action, args, { type: 'act', action, args }, tag);
  }

  /**
   * A `say`: free `text`, or a message of the shared language (an object, sent as `said`).
   * @param {string} to a player's name or `all`
   * @param {string|object} text
   * @param {any} [tag]
   */
  say(to, text, tag = null) {
    const content = typeof text === 'object' ? { said: text } : { text };
    return this.#request('say', [to, text], { type: 'say', to, ...content }, tag);
  }

  /**
   * A `resync`; the `percepts` event of its snapshot names `tag` in `resynced`.
   * @param {any} [tag]
   * @returns {SessionError|null} why it was not sent, if it was not
   */
  resync(tag = null) {
    const unavailable = this.unavailable();
    if (unavailable) return unavailable;
    this.#send({ type: 'resync' });
    this.#resyncs.push(tag);
    return null;
  }

  /** How many `resync`s wait for their snapshot. */
  get resyncsPending() {
    return this.#resyncs.length;
  }

  /**
   * A `ping`; its `pong` event carries `tag`.
   * @param {number|string} [id] default: a fresh one
   * @param {any} [tag]
   * @returns {SessionError|null} why it was not sent, if it was not
   */
  ping(id = `p${this.#nextId++}`, tag = null) {
    const unavailable = this.unavailable();
    if (unavailable) return unavailable;
    this.#send({ type: 'ping', id });
    this.#pings.push([id, tag]);
    return null;
  }

  /**
   * Lockstep: say everything for `tick` has been sent. Queues a `ready` only if `tick`
   * is the latest `percepts`' tick and no `ready` was sent since that `percepts` arrived:
   * one `ready` answers a tick's `percepts` and a `resync` snapshot of it, a `percepts`
   * after its tick's `ready` gets its own, an older tick is over (its `ready` would be
   * `late_ready`). Never in realtime, never once the session is over.
   * @param {number} [tick] default: the latest tick received
   * @returns {boolean} whether it was queued
   */
  ready(tick = this.#lastTick) {
    if (this.match?.mode !== 'lockstep') return false;
    if (this.ended || this.#closed || this.error) return false;
    if (!this.#unanswered || tick !== this.#lastTick) return false;
    this.#unanswered = false;
    this.#send({ type: 'ready', tick });
    return true;
  }

  /**
   * Leave the match: queues `bye` unless sent already or the match is over.
   * @returns {boolean} whether it was queued
   */
  bye() {
    if (this.#byeSent || this.ended) return false;
    this.#byeSent = true;
    this.#send({ type: 'bye' });
    return true;
  }

  /** The connection is being closed on purpose: its end is not a failure. */
  closing() {
    if (!this.ended && !this.error) this.#byeSent = true;
  }

  /**
   * The options that take this robot back on a new connection: those given, with this
   * session and `match` = the match it belongs to (`welcome.match.name`), never a template.
   * @param {Record<string, any>} [overrides]
   */
  reconnectOptions(overrides = {}) {
    const { template: _template, ...kept } = this.#options;
    return { ...kept, session: this.session, match: this.match?.name || kept.match, ...overrides };
  }

  // ---- in --------------------------------------------------------------------------

  /**
   * Part of a stream of lines (TCP): the events of each complete line, line by line (a
   * generator, so each line's events are handled before the next line is applied).
   * @param {string} chunk
   * @returns {Generator<SessionEvent>}
   */
  *receiveChunk(chunk) {
    this.#partial += chunk;
    let newline;
    while ((newline = this.#partial.indexOf('\n')) >= 0) {
      const line = this.#partial.slice(0, newline);
      this.#partial = this.#partial.slice(newline + 1);
      yield* this.receiveLine(line);
    }
  }

  /**
   * One line from the server (a WebSocket frame holds one, or several joined by newlines).
   * @param {string} line
   * @returns {SessionEvent[]}
   */
  receiveLine(line) {
    const text = line.endsWith('\r') ? line.slice(0, -1) : line;
    if (text.trim() === '') return [];
    let message;
    try {
      message = JSON.parse(text);
    } catch {
      return [{ type: 'bad_line', line: text }];
    }
    if (message === null || typeof message !== 'object' || typeof message.type !== 'string') return [];
    return this.receive(message);
  }

  /**
   * One message from the server.
   * @param {any} message
   * @returns {SessionEvent[]}
   */
  receive(message) {
    /** @type {SessionEvent[]} */
    const events = [{ type: 'server', message }];
    switch (message.type) {
      case 'welcome': {
        this.welcome = message;
        this.name = message.name ?? null;
        this.robot = message.robot ?? null;
        this.session = message.session ?? null;
        this.match = message.match ?? null;
        events.push({ type: 'welcome', welcome: message, afterQueue: this.queued });
        this.queued = false;
        break;
      }
      case 'lobby':
        this.#onLobby(message, events);
        break;
      case 'pause':
        // The operator paused (or resumed) the match; no tick comes while paused.
        this.paused = Boolean(message.paused);
        events.push({ type: 'pause', paused: this.paused });
        break;
      case 'percepts':
        this.#onPercepts(message, events);
        break;
      case 'ack':
        this.#onAck(message, events);
        break;
      case 'result': {
        this.#group.results.push(message);
        const request = this.#pending.get(message.id) ?? null;
        if (request) {
          this.#pending.delete(message.id);
          this.#toSettle.push([request, message]);
        }
        events.push({ type: 'result', result: message, request });
        break;
      }
      case 'error':
        events.push({ type: 'error', error: message });
        if (message.fatal) {
          this.error ??= { code: message.code, message: message.message, fatal: true };
          this.#abandon(this.error, events);
        } else {
          this.#group.errors.push(message);
        }
        break;
      case 'pong': {
        const i = this.#pings.findIndex(([id]) => id === message.id);
        const tag = i >= 0 ? this.#pings.splice(i, 1)[0][1] : null;
        events.push({ type: 'pong', pong: message, tag, matched: i >= 0 });
        break;
      }
      case 'match_end':
        this.result = message.result ?? null;
        this.endReason = message.reason ?? null;
        this.ended = true;
        this.#abandon({ code: 'match_over', message: `the match ended (${message.reason})`, fatal: false }, events);
        events.push({ type: 'match_end', result: this.result, reason: this.endReason });
        break;
      case 'bye':
        if (message.reason === 'goodbye' || message.reason === 'match_over') {
          this.ended = true;
        } else {
          this.error ??= { code: message.reason ?? 'bye', message: 'the server closed the connection', fatal: true };
        }
        events.push({ type: 'bye', reason: message.reason ?? null });
        break;
      default:
        break; // unknown types are ignored (Versioning)
    }
    return events;
  }

  /**
   * The connection is gone: a failure unless the match was over, `bye` was sent or it
   * was closed on purpose (`closing()`).
   * @param {string} [why] the failure's words
   * @returns {SessionEvent[]}
   */
  closed(why = 'the server closed the connection without bye') {
    /** @type {SessionEvent[]} */
    const events = [];
    if (this.#closed) return events;
    this.lost(why);
    this.#closed = true;
    const error = this.error ?? { code: this.result ? 'match_over' : 'not_connected', message: 'the connection is closed', fatal: false };
    this.#abandon(error, events);
    return events;
  }

  /**
   * The transport failed (the connection will close): a failure unless the end was
   * expected.
   * @param {string} why
   */
  lost(why) {
    if (!this.error && !this.ended && !this.#byeSent) this.error = { code: 'connection_closed', message: why, fatal: true };
  }

  /** @param {any} message @param {SessionEvent[]} events */
  #onLobby(message, events) {
    const lobby = {
      ...message,
      players: Array.isArray(message.players) ? message.players : [],
      awaited: message.awaited ?? 0,
      started: message.started === true,
    };
    this.lobby = lobby;
    if (!this.welcome && lobby.queued !== undefined && !this.queued) {
      this.queued = true;
      events.push({ type: 'queued', lobby });
    }
    events.push({ type: 'lobby', lobby });
  }

  /** @param {any} message @param {SessionEvent[]} events */
  #onPercepts(message, events) {
    const messages = this.beliefs.apply(message);
    this.tick = message.tick;
    this.words = typeof message.words === 'string' ? message.words : null;
    this.#lastTick = message.tick;
    this.#unanswered = true;
    /** @type {Update} */
    const update = {
      tick: message.tick,
      full: message.full === true,
      add: message.add ?? [],
      not: message.not ?? [],
      messages,
      ...this.#group,
      words: this.words,
      beliefs: this.beliefs,
    };
    this.#group = { acks: [], results: [], errors: [] };
    // Outcomes settle now, so that whoever awaits them sees this tick's beliefs.
    for (const [request, result] of this.#toSettle.splice(0)) events.push({ type: 'settled', request, result });
    const resynced = update.full ? this.#resyncs.splice(0) : [];
    events.push({ type: 'percepts', percepts: message, update, resynced });
    if (this.welcome && !this.joined) {
      this.joined = true;
      events.push({ type: 'joined' });
    }
  }

  /** @param {any} message @param {SessionEvent[]} events */
  #onAck(message, events) {
    this.#group.acks.push(message);
    const request = message.id === undefined ? null : (this.#pending.get(message.id) ?? null);
    events.push({ type: 'ack', ack: message, request });
    if (!request) return;
    if (!message.ok || !request.durative) this.#pending.delete(message.id);
    if (!message.ok || request.durative) return;
    // An accepted pickUp/putDown changes what the robot holds, so a percepts follows: it
    // settles when that is applied. A message changes nothing for the sender.
    if (request.action === 'pickUp' || request.action === 'putDown') this.#toSettle.push([request, null]);
    else events.push({ type: 'settled', request, result: null });
  }

  /**
   * Nothing more will be answered: what is settled settles, the rest is abandoned.
   * @param {SessionError} error
   * @param {SessionEvent[]} events
   */
  #abandon(error, events) {
    for (const [request, result] of this.#toSettle.splice(0)) events.push({ type: 'settled', request, result });
    const requests = [...this.#pending.values()];
    this.#pending.clear();
    const resyncs = this.#resyncs.splice(0);
    const pings = this.#pings.splice(0).map(([, tag]) => tag);
    events.push({ type: 'abandoned', error, requests, resyncs, pings });
  }
}
