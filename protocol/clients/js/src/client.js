// A player connection to a bw4t server over TCP: the promises, the per-tick update
// iterator and the timing of lockstep `ready`s around the protocol session of core.js,
// which does the protocol itself. Written from protocol/PROTOCOL.md.

import net from 'node:net';
import { EventEmitter } from 'node:events';
import { PlayerSession, joinConflict } from './core.js';
import { BW4TError, ActionRejected } from './errors.js';

/** @typedef {import('./beliefs.js').Fact} Fact */
/** @typedef {import('./beliefs.js').ChatMessage} ChatMessage */
/** @typedef {import('./beliefs.js').Beliefs} Beliefs */
/** @typedef {import('./core.js').Update} Update */
/** @typedef {import('./core.js').SessionError} SessionError */

/**
 * @typedef {object} ConnectOptions
 * @property {string} [host] default: `BW4T_HOST`, else `127.0.0.1`
 * @property {number|string} [port] default: `BW4T_PORT`, else 12300
 * @property {string} [name] the player name wanted; default: `BW4T_NAME`, else the server picks `PlayerN`
 * @property {string} [token] the shared secret; default: `BW4T_TOKEN` (when set and not empty)
 * @property {boolean} [everyTick] ask for a `percepts` every tick (`every_tick`); default false
 * @property {boolean} [words] ask for the robot's situation in English with every
 *   `percepts` (`hello.words`): `update.words`, `client.words`; default false
 * @property {string} [session] the `session` of an earlier `welcome`, to take a robot back
 *   (with `match`: the match it belongs to, `welcome.match.name`)
 * @property {string} [match] the name of a live match to join (`hello.match`)
 * @property {string} [template] the name of a template: queued into its next match with
 *   a free seat (`hello.template`). Not together with `match`
 * @property {(lobby: Lobby) => void} [onLobby] called with every `lobby` received, also
 *   during `connect()` while queued; throwing from it during `connect()` gives up (the
 *   connection is closed and `connect()` rejects with that error)
 * @property {boolean} [autoReady] lockstep: answer `ready` by itself for ticks no
 *   `updates()` iterator is handling (default true; see the README)
 * @property {number} [timeoutMs] how long connecting and the handshake may take, not
 *   counting the time spent in a template's queue; default 10000 (`Infinity`: no limit)
 */

/**
 * `welcome.match`.
 * @typedef {object} MatchInfo
 * @property {string} [name] the match's name on the server (the `match` of a later `hello`)
 * @property {string} [template] the template the match was made from, if any
 * @property {string} map
 * @property {number} seed
 * @property {'realtime'|'lockstep'} mode
 * @property {number} tick_hz
 * @property {number} [deadline_ms] lockstep only; 0: forever
 * @property {number} players_needed
 * @property {number} [max_ticks]
 * @property {boolean} every_tick
 */

/**
 * `welcome`.
 * @typedef {object} Welcome
 * @property {'welcome'} type
 * @property {number} version
 * @property {string} name
 * @property {number} robot
 * @property {string} session
 * @property {MatchInfo} match
 */

/**
 * `lobby`: the match waiting for its players (after `welcome`, until the first tick; the
 * last one, as the match starts, has `started`), or, before `welcome`, the player's place
 * in a template's queue (`queued`, 1 = next). `players`, `awaited` and `started` are
 * filled in (`[]`, 0, false) when the server left them out.
 * @typedef {object} Lobby
 * @property {'lobby'} type
 * @property {string} [match] the match's name (absent while queued)
 * @property {string} [template] the match's template, or the one queued for
 * @property {string[]} players the players in the match now (built-in agents included), in robot order
 * @property {number} awaited how many more players the match waits for before it starts
 * @property {number} [start_in_ms] the match starts anyway in this many milliseconds
 * @property {number} [queued] before `welcome`: the place in the template's queue
 * @property {boolean} started the match has started (the connection's last `lobby`)
 */

/**
 * `ack`: an action (or `say`) accepted or refused.
 * @typedef {object} Ack
 * @property {'ack'} type
 * @property {number|string} [id]
 * @property {boolean} ok
 * @property {number} tick the action was applied after this tick
 * @property {string} [code] when refused
 * @property {string} [reason] when refused
 */

/**
 * `result`: how a durative order (`goTo`, `goToBlock`) ended.
 * @typedef {object} ActResult
 * @property {'result'} type
 * @property {number|string} id
 * @property {'arrived'|'collided'|'superseded'} outcome
 * @property {number} tick
 */

/**
 * A non-fatal `error` from the server.
 * @typedef {object} ServerErrorMessage
 * @property {'error'} type
 * @property {string} code
 * @property {string} message
 * @property {boolean} fatal
 */

/**
 * `match_end.result` (see PROTOCOL.md for every field).
 * @typedef {object} MatchResult
 * @property {string} map
 * @property {number} seed
 * @property {string} [mode]
 * @property {number} robots
 * @property {boolean} completed
 * @property {string} end_reason
 * @property {number} ticks
 * @property {number} [completed_tick]
 * @property {number} sim_seconds
 * @property {number} wall_ms
 * @property {string[]} sequence
 * @property {number} sequence_index
 * @property {number} good_drops
 * @property {number} wrong_drops
 * @property {number} messages
 * @property {string} digest
 * @property {object[]} per_robot
 */

/**
 * `setTimeout`, or nothing for an endless wait (`Infinity`).
 * @param {number} ms
 * @param {() => void} fire
 * @returns {NodeJS.Timeout|undefined}
 */
function timer(ms, fire) {
  return Number.isFinite(ms) ? setTimeout(fire, ms) : undefined;
}

/**
 * The `BW4TError` of a session's error.
 * @param {SessionError} error
 */
function errorOf(error) {
  return new BW4TError(error.code, error.message, { fatal: error.fatal });
}

/**
 * A promise with its settle functions; its rejection is marked handled so that an
 * unobserved rejection never crashes the process (awaiting it still throws).
 * @template T
 */
class Deferred {
  constructor() {
    /** @type {(value: T) => void} */
    this.resolve = () => {};
    /** @type {(error: Error) => void} */
    this.reject = () => {};
    /** @type {Promise<T>} */
    this.promise = new Promise((resolve, reject) => {
      this.resolve = resolve;
      this.reject = reject;
    });
    this.promise.catch(() => {});
  }
}

/**
 * One `act` (or `say`) in flight. `ack` resolves with the server's ack (also when it
 * refuses: check `ok`). `result` resolves with the `result` of a `goTo`/`goToBlock`
 * once that tick's percepts is applied; for other actions with `null` once accepted
 * (for `pickUp`/`putDown`, once the percepts showing the change is applied). It rejects
 * with `ActionRejected` when the ack refuses. Both reject with a `BW4TError` if the
 * connection or the match ends first.
 */
export class ActionHandle {
  /** @param {import('./core.js').Request} request */
  constructor(request) {
    /** The request id. */
    this.id = request.id;
    /** The action (`say` for `say`). */
    this.action = request.action;
    /** The arguments. */
    this.args = request.args;
    /** Whether the action has a `result` (goTo, goToBlock). */
    this.durative = request.durative;
    /** @type {Deferred<Ack>} */
    this._ack = new Deferred();
    /** @type {Deferred<ActResult|null>} */
    this._result = new Deferred();
    /** Resolves with the ack. */
    this.ack = this._ack.promise;
    /** Resolves with the result (durative) or `null`; rejects when refused. */
    this.result = this._result.promise;
    /** The ack, once received. @type {Ack|null} */
    this.acked = null;
    /** The result, once received. @type {ActResult|null} */
    this.outcome = null;
    /** Why it failed (refused, connection lost, match over). @type {Error|null} */
    this.failure = null;
  }

  /** Whether nothing more will be received for it. */
  get done() {
    if (this.failure) return true;
    if (!this.acked) return false;
    return !this.durative || this.outcome !== null;
  }

  /** Whether it was accepted and, if durative, ended `arrived`. */
  get succeeded() {
    if (!this.acked?.ok || this.failure) return false;
    return !this.durative || this.outcome?.outcome === 'arrived';
  }

  /** @param {Ack} ack */
  _onAck(ack) {
    this.acked = ack;
    this._ack.resolve(ack);
    if (!ack.ok) {
      this.failure = new ActionRejected(this.action, ack);
      this._result.reject(this.failure);
    }
  }

  /** @param {ActResult|null} result the result, `null` for a non-durative action */
  _onResult(result) {
    if (result) this.outcome = result;
    this._result.resolve(result);
  }

  /** @param {Error} error */
  _fail(error) {
    if (this.done) return;
    this.failure = error;
    if (!this.acked) this._ack.reject(error);
    this._result.reject(error);
  }
}

/**
 * A connected player. Create it with `connect()`.
 *
 * Events (EventEmitter): `update` (Update, every tick's update, iterated or not),
 * `lobby` (Lobby, while the match waits for its players; those before `connect()`
 * resolves only reach the `onLobby` option), `server` (every message from the server),
 * `serverError` (a non-fatal `error`), `end` (the connection is over; `client.error`
 * tells whether it failed).
 */
export class Client extends EventEmitter {
  /** @type {net.Socket} */
  #socket;
  /** The protocol session (core.js). @type {PlayerSession} */
  #core;
  #autoReady = true;
  /** Updates not yet taken by an iterator. @type {Update[]} */
  #queue = [];
  /** @type {Array<() => void>} */
  #wakers = [];
  #iterating = false;
  /** The update the iterator handed out and whose handler has not finished. @type {Update|null} */
  #handling = null;
  /** The last update built. @type {Update|null} */
  #latest = null;
  /** @type {Deferred<Client>} */
  #handshake = new Deferred();
  /** The options given to `connect()`, defaults resolved. @type {ConnectOptions} */
  #options;
  /** The handshake's timer; stopped while queued for a template. @type {NodeJS.Timeout|undefined} */
  #handshakeTimer;
  /** @type {Deferred<MatchResult|null>} */
  #finished = new Deferred();
  /** @type {Deferred<void>} */
  #closedDeferred = new Deferred();

  /** `error`, once made. @type {BW4TError|null} */
  #error = null;

  /** Whether the connection is closed. */
  closed = false;

  /** The fatal error that ended the connection, if any. @type {BW4TError|null} */
  get error() {
    const failure = this.#core.error;
    if (failure) this.#error ??= errorOf(failure);
    return this.#error;
  }

  /** The belief base, kept from every `percepts`. @type {Beliefs} */
  get beliefs() {
    return this.#core.beliefs;
  }
  /** The `welcome` message. @type {Welcome|null} */
  get welcome() {
    return this.#core.welcome;
  }
  /** The player's name. @type {string|null} */
  get name() {
    return this.#core.name;
  }
  /** The robot's id. @type {number|null} */
  get robot() {
    return this.#core.robot;
  }
  /** The session, for reconnecting. @type {string|null} */
  get session() {
    return this.#core.session;
  }
  /** About the match (`welcome.match`). @type {MatchInfo|null} */
  get match() {
    return this.#core.match;
  }
  /** The latest `lobby` received (kept after the match started). @type {Lobby|null} */
  get lobby() {
    return this.#core.lobby;
  }
  /** The tick of the last `percepts` received. @type {number|null} */
  get tick() {
    return this.#core.tick;
  }
  /**
   * The robot's situation in words from the last `percepts` received (`I am Ann (robot 0),
   * in RoomC1. ...`), or `null` (not connected with `words: true`). @type {string|null}
   */
  get words() {
    return this.#core.words;
  }
  /** The match result, once `match_end` arrived. @type {MatchResult|null} */
  get result() {
    return this.#core.result;
  }
  /** `match_end.reason`: `completed`, `max_ticks`, `interrupted` or `abandoned`. @type {string|null} */
  get endReason() {
    return this.#core.endReason;
  }

  /**
   * Connect, say `hello` and wait for `welcome` and the first snapshot.
   * @param {ConnectOptions} [options]
   * @returns {Promise<Client>}
   */
  static async connect(options = {}) {
    const env = process.env;
    const host = options.host ?? (env.BW4T_HOST || '127.0.0.1');
    const port = Number(options.port ?? (env.BW4T_PORT || 12300));
    const name = options.name ?? (env.BW4T_NAME || undefined);
    const token = options.token ?? (env.BW4T_TOKEN || undefined);
    const timeoutMs = options.timeoutMs ?? 10000;
    if (!Number.isInteger(port) || port < 0 || port > 65535) {
      throw new BW4TError('connect_failed', `bad port ${String(options.port ?? env.BW4T_PORT)}`);
    }
    const conflict = joinConflict(options);
    if (conflict) throw new BW4TError('bad_options', conflict);
    const socket = await new Promise((resolve, reject) => {
      const s = net.connect({ host, port });
      const connecting = timer(timeoutMs, () => {
        s.destroy();
        reject(new BW4TError('timeout', `could not connect to ${host}:${port} within ${timeoutMs} ms`));
      });
      s.once('connect', () => {
        clearTimeout(connecting);
        s.removeAllListeners('error');
        resolve(s);
      });
      s.once('error', (err) => {
        clearTimeout(connecting);
        reject(new BW4TError('connect_failed', `could not connect to ${host}:${port}: ${err.message}`, { cause: err }));
      });
    });
    const resolved = { ...options, host, port, name, token, timeoutMs };
    const client = new Client(socket, options.autoReady ?? true, resolved);
    client.#core.start();
    client.#flush();
    client.#armHandshakeTimer();
    try {
      return await client.#handshake.promise;
    } catch (err) {
      client.close();
      throw err;
    } finally {
      clearTimeout(client.#handshakeTimer);
    }
  }

  /** (Re)start the bound on the handshake (`timeoutMs`). */
  #armHandshakeTimer() {
    clearTimeout(this.#handshakeTimer);
    const ms = this.#options.timeoutMs ?? 10000;
    this.#handshakeTimer = timer(ms, () =>
      this.#handshake.reject(new BW4TError('timeout', `no welcome and snapshot within ${ms} ms`)),
    );
  }

  /**
   * Take the robot back on a new connection, after a drop or to replace this one: closes
   * this connection if it is still open (without `bye`, which would make the robot
   * leave), then connects with this client's options, its `session` and `match` = the
   * match the session belongs to (`match.name`; never `template`). Resolves with the new
   * `Client` (its first update is the full snapshot); rejects like `connect()`, e.g. with
   * `bad_session` once the server's grace period has passed.
   * @param {ConnectOptions} [options] overrides (e.g. `timeoutMs`)
   * @returns {Promise<Client>}
   */
  async reconnect(options = {}) {
    if (!this.session) throw new BW4TError('not_connected', 'no session to reconnect with');
    this.close();
    return Client.connect(this.#core.reconnectOptions(options));
  }

  /**
   * Use `connect()`.
   * @param {net.Socket} socket
   * @param {boolean} autoReady
   * @param {ConnectOptions} [options] what `connect()` was given, defaults resolved
   */
  constructor(socket, autoReady, options = {}) {
    super();
    this.#socket = socket;
    this.#autoReady = autoReady;
    this.#options = options;
    this.#core = new PlayerSession(options);
    socket.setNoDelay(true);
    socket.setEncoding('utf8');
    socket.on('data', (chunk) => {
      for (const event of this.#core.receiveChunk(String(chunk))) this.#onEvent(event);
    });
    socket.on('error', (err) => {
      const before = this.#core.error;
      this.#core.lost(`connection failed: ${err.message}`);
      const failure = this.#core.error;
      if (failure && failure !== before) this.#error = new BW4TError(failure.code, failure.message, { cause: err });
    });
    socket.on('close', () => this.#onClose());
  }

  // ---- sending -------------------------------------------------------------------

  /** Write what the session has to send. */
  #flush() {
    const lines = this.#core.takeLines();
    if (lines.length === 0 || this.closed || this.#socket.destroyed || !this.#socket.writable) return;
    this.#socket.write(lines.map((line) => line + '\n').join(''));
  }

  /**
   * The client's error for one of the session's (the one that ended it is `client.error`).
   * @param {SessionError} error
   */
  #errorFor(error) {
    return error === this.#core.error ? /** @type {BW4TError} */ (this.error) : errorOf(error);
  }

  /**
   * A handle on a request the session made (failed at once if it could not be sent).
   * @param {import('./core.js').Request} request
   */
  #handleFor(request) {
    const handle = new ActionHandle(request);
    if (request.failure) {
      handle._fail(this.#errorFor(request.failure));
      return handle;
    }
    request.tag = handle;
    this.#flush();
    return handle;
  }

  /**
   * Ask for an action. Returns at once; the action is applied at the next tick boundary
   * (in lockstep: send a tick's actions before its `ready`, i.e. from the tick's handler).
   * @param {string} action `goTo`, `goToBlock`, `pickUp`, `putDown` or `sendMessage`
   * @param {...any} args the action's arguments in the spec's order
   * @returns {ActionHandle}
   */
  act(action, ...args) {
    return this.#handleFor(this.#core.act(action, args));
  }

  /**
   * Travel to a place (durative).
   * @param {string} place
   */
  goTo(place) {
    return this.act('goTo', place);
  }

  /**
   * Travel to a block in the robot's room (durative).
   * @param {number} block
   */
  goToBlock(block) {
    return this.act('goToBlock', block);
  }

  /**
   * Pick up the block the robot is at, or the named block if within reach.
   * @param {number} [block]
   */
  pickUp(block) {
    return block === undefined ? this.act('pickUp') : this.act('pickUp', block);
  }

  /** Put the held block down (in `DropZone`: deliver it). */
  putDown() {
    return this.act('putDown');
  }

  /**
   * `act` `sendMessage`.
   * @param {string} to a player's name or `all`
   * @param {string} text
   */
  sendMessage(to, text) {
    return this.act('sendMessage', to, text);
  }

  /**
   * Send a text to another player or to `all` others (a `say`, with an id so that its
   * ack can be matched). The receivers get it in their next update's `messages`.
   * @param {string} to a player's name or `all`
   * @param {string|object} text free text, or a message of the shared language
   *   (`{kind: 'will_get', colour: 'Blue'}`); a match may allow only some kinds, or no
   *   free text (the ack then says `not_allowed`)
   * @returns {ActionHandle}
   */
  say(to, text) {
    return this.#handleFor(this.#core.say(to, text));
  }

  /**
   * Ask for a full snapshot. Resolves with its update once it has been applied (the
   * belief base is then rebuilt from it). Called from an iterator's handler, the
   * snapshot is of the tick being handled and is not yielded again by the iterator.
   * @returns {Promise<Update>}
   */
  resync() {
    const deferred = /** @type {Deferred<Update>} */ (new Deferred());
    const unavailable = this.#core.resync(deferred);
    if (unavailable) deferred.reject(this.#errorFor(unavailable));
    this.#flush();
    return deferred.promise;
  }

  /**
   * `ping`; resolves with the `pong`.
   * @param {number|string} [id]
   * @returns {Promise<object>}
   */
  ping(id) {
    const deferred = new Deferred();
    const unavailable = this.#core.ping(id, deferred);
    if (unavailable) deferred.reject(this.#errorFor(unavailable));
    this.#flush();
    return deferred.promise;
  }

  /**
   * Lockstep: tell the server everything for `tick` has been sent. The client does this
   * itself (see `updates()` and the `autoReady` option); call it only when pacing by
   * hand (`autoReady: false` and no iterator). Nothing is sent unless `tick` is the tick
   * of the latest `percepts` and no `ready` has been sent since that `percepts` arrived.
   * @param {number} [tick] default: the latest tick received
   */
  ready(tick) {
    this.#core.ready(tick);
    this.#flush();
  }

  /**
   * Leave the match: sends `bye` and waits (at most `timeoutMs`) for the server to
   * answer and close.
   * @param {number} [timeoutMs]
   */
  async bye(timeoutMs = 5000) {
    if (this.closed) return;
    this.#core.bye();
    this.#flush();
    let timer;
    await Promise.race([
      this.#closedDeferred.promise,
      new Promise((resolve) => {
        timer = setTimeout(resolve, timeoutMs);
      }),
    ]);
    clearTimeout(timer);
    this.close();
  }

  /** Close the connection at once (the robot stays for the server's grace period). */
  close() {
    this.#core.closing();
    this.#socket.destroy();
  }

  /**
   * Resolves with the match result when `match_end` arrives (or `null` if the connection
   * ended normally without one, e.g. after `bye`); rejects with the fatal error.
   * @returns {Promise<MatchResult|null>}
   */
  get finished() {
    return this.#finished.promise;
  }

  /** Whether the match has ended (`match_end`) or the connection is over. */
  get ended() {
    return this.#core.ended || this.closed;
  }

  // ---- updates and pacing --------------------------------------------------------

  /**
   * Iterate over the per-tick updates, oldest first, ending after the last tick's
   * update when `match_end` arrives (then `client.result` is set), or throwing the
   * fatal error. It starts with the updates not yet answered (right after `connect()`:
   * the first snapshot), else with the latest update again, so the loop always starts
   * from the current state.
   *
   * In lockstep, `ready` for a tick is sent when the loop asks for the next update after
   * the tick's one, i.e. when its body has finished (also when it exits with `break`).
   * Act from the body; do not await an order's `result` inside it (that comes in a
   * later tick, which cannot run before this one is answered). Only one iterator may be
   * active at a time.
   * @returns {AsyncIterableIterator<Update>}
   */
  updates() {
    if (this.#iterating) throw new Error('updates() is already being iterated');
    this.#iterating = true;
    // Start from the current state: the updates not yet answered, else the latest one.
    if (this.#queue.length === 0 && this.#latest && !this.#core.ended) this.#queue.push(this.#latest);
    const finishHandling = () => {
      if (this.#handling) {
        const tick = this.#handling.tick;
        this.#handling = null;
        this.#sendReady(tick);
      }
    };
    /** @type {AsyncIterableIterator<Update>} */
    const iterator = {
      [Symbol.asyncIterator]() {
        return iterator;
      },
      next: async () => {
        finishHandling();
        for (;;) {
          if (!this.#iterating) return { value: undefined, done: true };
          if (this.error) {
            this.#iterating = false;
            throw this.error;
          }
          const update = this.#queue.shift();
          if (update) {
            this.#handling = update;
            return { value: update, done: false };
          }
          if (this.#core.ended || this.closed) {
            this.#iterating = false;
            return { value: undefined, done: true };
          }
          await new Promise((resolve) => this.#wakers.push(() => resolve(undefined)));
        }
      },
      return: async () => {
        finishHandling();
        this.#iterating = false;
        for (const update of this.#queue) setImmediate(() => this.#autoReadyFor(update));
        return { value: undefined, done: true };
      },
    };
    return iterator;
  }

  #wake() {
    const wakers = this.#wakers;
    this.#wakers = [];
    for (const wake of wakers) wake();
  }

  /**
   * Lockstep: the `ready` for `tick`, if the session owes one (see `PlayerSession.ready`).
   * @param {number} tick
   */
  #sendReady(tick) {
    if (this.closed) return;
    this.#core.ready(tick);
    this.#flush();
  }

  /** @param {Update} update */
  #autoReadyFor(update) {
    if (this.#iterating || !this.#autoReady) return;
    const i = this.#queue.indexOf(update);
    if (i >= 0) this.#queue.splice(i, 1);
    // A resync in flight: its reply (of this tick, if the server waits for us) comes
    // first, and the ready after it answers both.
    if (this.#core.resyncsPending > 0) return;
    this.#sendReady(update.tick);
  }

  // ---- receiving -----------------------------------------------------------------

  /** @param {import('./core.js').SessionEvent} event */
  #onEvent(event) {
    switch (event.type) {
      case 'server':
        this.emit('server', event.message);
        break;
      case 'bad_line':
        this.emit('serverError', {
          type: 'error',
          code: 'bad_json',
          message: `unparsable line from the server: ${event.line.slice(0, 200)}`,
          fatal: false,
        });
        break;
      case 'welcome':
        // Seated after waiting in a template's queue: the handshake's bound starts again.
        if (event.afterQueue && !this.#core.joined) this.#armHandshakeTimer();
        break;
      case 'queued':
        // Waiting for a seat in a template's queue can take long: it is not bounded.
        clearTimeout(this.#handshakeTimer);
        break;
      case 'lobby':
        this.#onLobby(event.lobby);
        break;
      case 'ack':
        event.request?.tag?._onAck(event.ack);
        break;
      case 'settled':
        event.request.tag?._onResult(event.result);
        break;
      case 'percepts':
        this.#onPercepts(event.update, event.resynced);
        break;
      case 'joined':
        this.#handshake.resolve(this);
        break;
      case 'error':
        if (!event.error.fatal) this.emit('serverError', event.error);
        break;
      case 'pong':
        event.tag?.resolve(event.pong);
        break;
      case 'abandoned': {
        // Nothing more will be answered, the handshake included.
        const error = this.#errorFor(event.error);
        this.#handshake.reject(error);
        for (const request of event.requests) request.tag?._fail(error);
        for (const deferred of event.resyncs) deferred.reject(error);
        for (const deferred of event.pings) deferred.reject(error);
        this.#wake();
        break;
      }
      case 'match_end':
        this.#finished.resolve(this.result);
        this.#wake();
        break;
      case 'bye':
        this.#wake();
        break;
      default:
        break;
    }
  }

  /**
   * A `percepts` applied: its update emitted, queued for the iterator (or answered by
   * itself), and the resyncs it answers resolved.
   * @param {Update} update
   * @param {Array<Deferred<Update>>} resynced
   */
  #onPercepts(update, resynced) {
    for (const deferred of resynced) deferred.resolve(update);
    this.#latest = update;
    this.emit('update', update);
    // A resync reply for the tick the iterator's handler is working on belongs to that
    // tick: it is returned by resync() and not yielded again.
    if (resynced.length > 0 && this.#iterating && this.#handling?.tick === update.tick) return;
    this.#queue.push(update);
    if (this.#iterating) this.#wake();
    else setImmediate(() => this.#autoReadyFor(update));
  }

  /**
   * A `lobby`: passed to `onLobby` and emitted. It comes only before the first tick and
   * changes nothing of the tick's state (no update, no `ready`).
   * @param {Lobby} lobby
   */
  #onLobby(lobby) {
    const onLobby = this.#options.onLobby;
    if (onLobby) {
      try {
        onLobby(lobby);
      } catch (err) {
        if (this.#core.joined) throw err;
        this.#handshake.reject(err instanceof Error ? err : new Error(String(err)));
        return;
      }
    }
    this.emit('lobby', lobby);
  }

  #onClose() {
    this.closed = true;
    for (const event of this.#core.closed()) this.#onEvent(event);
    if (this.error) this.#finished.reject(this.error);
    else this.#finished.resolve(this.result);
    this.#closedDeferred.resolve();
    this.#wake();
    this.emit('end', this.error);
  }
}

/**
 * Connect to a bw4t server as a player: `hello`, then wait for `welcome` and the first
 * full snapshot. Options default to the `BW4T_*` environment that `bw4t run` sets.
 * Rejects with a `BW4TError` (e.g. code `name_taken`, `bad_token`, `connect_failed`,
 * `timeout`).
 * @param {ConnectOptions} [options]
 * @returns {Promise<Client>}
 */
export function connect(options = {}) {
  return Client.connect(options);
}
