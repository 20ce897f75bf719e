// A player connection to a bw4t server: handshake, belief base, actions, messages,
// lockstep pacing and per-tick updates. Written from protocol/PROTOCOL.md.

import net from 'node:net';
import { EventEmitter } from 'node:events';
import { Beliefs } from './beliefs.js';
import { DURATIVE } from './table.js';
import { BW4TError, ActionRejected } from './errors.js';

/** @typedef {import('./beliefs.js').Fact} Fact */
/** @typedef {import('./beliefs.js').ChatMessage} ChatMessage */

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
 * Everything one tick brought: the messages received since the previous update,
 * ended by that tick's `percepts`.
 * @typedef {object} Update
 * @property {number} tick the tick of the `percepts`
 * @property {boolean} full whether it was a full snapshot
 * @property {Fact[]} add the `add` list as received (messages included)
 * @property {Fact[]} not the `not` list as received
 * @property {ChatMessage[]} messages the `message` events, oldest first
 * @property {Ack[]} acks acks received since the previous update
 * @property {ActResult[]} results results received since the previous update
 * @property {ServerErrorMessage[]} errors non-fatal errors received since the previous update
 * @property {string|null} words the `percepts`' `words`: the robot's situation after it in
 *   a few short lines of English, for people and language models (the wording may change
 *   between releases); `null` unless connected with `words: true`
 * @property {Beliefs} beliefs the client's belief base (live: the state after this update
 *   unless later updates are already queued)
 */

const MAX_LINE_BYTES = 65536;

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
 * Refuse a `hello` that names both a match and a template (the server would answer
 * `bad_message`): a player joins one match, or is queued for a template.
 * @param {{match?: string, template?: string}} options
 */
function checkJoin({ match, template }) {
  if (match && template) {
    throw new BW4TError(
      'bad_options',
      `give match or template, not both (match "${match}", template "${template}"): match joins ` +
        'that live match, template queues for the next match of that template',
    );
  }
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
  /**
   * @param {number} id
   * @param {string} action
   * @param {any[]} args
   */
  constructor(id, action, args) {
    /** The request id. */
    this.id = id;
    /** The action (`say` for `say`). */
    this.action = action;
    /** The arguments. */
    this.args = args;
    /** Whether the action has a `result` (goTo, goToBlock). */
    this.durative = DURATIVE.has(action);
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
  #buffer = '';
  #nextId = 1;
  /** @type {Map<number|string, ActionHandle>} */
  #handles = new Map();
  /** Handles whose `result` arrived (or accepted pickUp/putDown), settled when the tick's `percepts` arrives. @type {Array<[ActionHandle, ActResult|null]>} */
  #resultsToSettle = [];
  /** What arrived since the last `percepts`. */
  #group = { acks: /** @type {Ack[]} */ ([]), results: /** @type {ActResult[]} */ ([]), errors: /** @type {ServerErrorMessage[]} */ ([]) };
  /** The tick of the last `percepts` received. */
  #lastTick = -1;
  /** Whether a `percepts` arrived that no `ready` sent after it answers yet. */
  #unanswered = false;
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
  /** @type {Array<Deferred<Update>>} */
  #resyncs = [];
  /** @type {Array<[any, Deferred<object>]>} */
  #pings = [];
  /** @type {Deferred<Client>} */
  #handshake = new Deferred();
  #joined = false;
  /** The options given to `connect()` (defaults resolved), for `reconnect()`. @type {ConnectOptions} */
  #options;
  /** The handshake's timer; stopped while queued for a template. @type {NodeJS.Timeout|undefined} */
  #handshakeTimer;
  #queued = false;
  /** @type {Deferred<MatchResult|null>} */
  #finished = new Deferred();
  #ended = false;
  #byeSent = false;
  /** @type {Deferred<void>} */
  #closedDeferred = new Deferred();

  /** The belief base, kept from every `percepts`. */
  beliefs = new Beliefs();
  /** The `welcome` message. @type {Welcome|null} */
  welcome = null;
  /** The player's name. @type {string|null} */
  name = null;
  /** The robot's id. @type {number|null} */
  robot = null;
  /** The session, for reconnecting. @type {string|null} */
  session = null;
  /** About the match (`welcome.match`). @type {MatchInfo|null} */
  match = null;
  /** The latest `lobby` received (kept after the match started). @type {Lobby|null} */
  lobby = null;
  /** The tick of the last `percepts` received. @type {number|null} */
  tick = null;
  /**
   * The robot's situation in words from the last `percepts` received (`I am Ann (robot 0),
   * in RoomC1. ...`), or `null` (not connected with `words: true`). @type {string|null}
   */
  words = null;
  /** The match result, once `match_end` arrived. @type {MatchResult|null} */
  result = null;
  /** `match_end.reason`: `completed`, `max_ticks` or `interrupted`. @type {string|null} */
  endReason = null;
  /** The fatal error that ended the connection, if any. @type {BW4TError|null} */
  error = null;
  /** Whether the connection is closed. */
  closed = false;

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
    checkJoin(options);
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
    client.#send({
      type: 'hello',
      protocol: 'bw4t',
      versions: [1],
      name,
      token,
      session: options.session,
      every_tick: options.everyTick ? true : undefined,
      words: options.words ? true : undefined,
      match: options.match || undefined,
      template: options.template || undefined,
    });
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
    const { template: _template, ...kept } = this.#options;
    return Client.connect({ ...kept, session: this.session, match: this.match?.name || kept.match, ...options });
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
    socket.setNoDelay(true);
    socket.setEncoding('utf8');
    socket.on('data', (chunk) => this.#onData(String(chunk)));
    socket.on('error', (err) => {
      if (!this.error && !this.#ended && !this.#byeSent) {
        this.error = new BW4TError('connection_closed', `connection failed: ${err.message}`, { cause: err });
      }
    });
    socket.on('close', () => this.#onClose());
  }

  // ---- sending -------------------------------------------------------------------

  /**
   * @param {object} message
   * @returns {boolean} whether it was written
   */
  #send(message) {
    const line = JSON.stringify(message);
    if (Buffer.byteLength(line) > MAX_LINE_BYTES) {
      throw new RangeError(`message of ${Buffer.byteLength(line)} bytes is longer than the protocol's 64 KiB line limit`);
    }
    if (this.closed || this.#socket.destroyed || !this.#socket.writable) return false;
    this.#socket.write(line + '\n');
    return true;
  }

  /** Why a new request cannot be sent, if it cannot. */
  #unavailable() {
    if (this.error) return this.error;
    if (this.#ended || this.closed || this.#byeSent) {
      return new BW4TError(this.result ? 'match_over' : 'not_connected', 'the connection is over', { fatal: false });
    }
    return null;
  }

  /**
   * Ask for an action. Returns at once; the action is applied at the next tick boundary
   * (in lockstep: send a tick's actions before its `ready`, i.e. from the tick's handler).
   * @param {string} action `goTo`, `goToBlock`, `pickUp`, `putDown` or `sendMessage`
   * @param {...any} args the action's arguments in the spec's order
   * @returns {ActionHandle}
   */
  act(action, ...args) {
    const id = this.#nextId++;
    const handle = new ActionHandle(id, action, args);
    const unavailable = this.#unavailable();
    if (unavailable) {
      handle._fail(unavailable);
      return handle;
    }
    this.#handles.set(id, handle);
    try {
      this.#send({ type: 'act', id, action, args });
    } catch (err) {
      this.#handles.delete(id);
      throw err;
    }
    return handle;
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
    const id = this.#nextId++;
    const handle = new ActionHandle(id, 'say', [to, text]);
    const unavailable = this.#unavailable();
    if (unavailable) {
      handle._fail(unavailable);
      return handle;
    }
    this.#handles.set(id, handle);
    try {
      this.#send(typeof text === 'object' ? { type: 'say', id, to, said: text } : { type: 'say', id, to, text });
    } catch (err) {
      this.#handles.delete(id);
      throw err;
    }
    return handle;
  }

  /**
   * Ask for a full snapshot. Resolves with its update once it has been applied (the
   * belief base is then rebuilt from it). Called from an iterator's handler, the
   * snapshot is of the tick being handled and is not yielded again by the iterator.
   * @returns {Promise<Update>}
   */
  resync() {
    const deferred = /** @type {Deferred<Update>} */ (new Deferred());
    const unavailable = this.#unavailable();
    if (unavailable) {
      deferred.reject(unavailable);
      return deferred.promise;
    }
    this.#resyncs.push(deferred);
    this.#send({ type: 'resync' });
    return deferred.promise;
  }

  /**
   * `ping`; resolves with the `pong`.
   * @param {number|string} [id]
   * @returns {Promise<object>}
   */
  ping(id = `p${this.#nextId++}`) {
    const deferred = new Deferred();
    const unavailable = this.#unavailable();
    if (unavailable) {
      deferred.reject(unavailable);
      return deferred.promise;
    }
    this.#pings.push([id, deferred]);
    this.#send({ type: 'ping', id });
    return deferred.promise;
  }

  /**
   * Lockstep: tell the server everything for `tick` has been sent. The client does this
   * itself (see `updates()` and the `autoReady` option); call it only when pacing by
   * hand (`autoReady: false` and no iterator). Nothing is sent unless `tick` is the tick
   * of the latest `percepts` and no `ready` has been sent since that `percepts` arrived.
   * @param {number} [tick] default: the latest tick received
   */
  ready(tick = this.#lastTick) {
    this.#sendReady(tick);
  }

  /**
   * Leave the match: sends `bye` and waits (at most `timeoutMs`) for the server to
   * answer and close.
   * @param {number} [timeoutMs]
   */
  async bye(timeoutMs = 5000) {
    if (this.closed) return;
    if (!this.#byeSent && !this.#ended) {
      this.#byeSent = true;
      this.#send({ type: 'bye' });
    }
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
    if (!this.#ended && !this.error) this.#byeSent = true; // closing on purpose is not an error
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
    return this.#ended || this.closed;
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
    if (this.#queue.length === 0 && this.#latest && !this.#ended) this.#queue.push(this.#latest);
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
          if (this.#ended || this.closed) {
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

  /** @param {number} tick */
  #sendReady(tick) {
    if (this.match?.mode !== 'lockstep') return;
    if (this.#ended || this.closed || this.error) return;
    // One `ready` answers every `percepts` received before it (for that tick): a resync
    // reply for the tick being handled needs no second one, but a `percepts` that comes
    // after the tick's `ready` (the tick-0 delta naming later players) gets its own.
    // An older tick is over: its `ready` would be `late_ready`.
    if (!this.#unanswered || tick !== this.#lastTick) return;
    this.#unanswered = false;
    this.#send({ type: 'ready', tick });
  }

  /** @param {Update} update */
  #autoReadyFor(update) {
    if (this.#iterating || !this.#autoReady) return;
    const i = this.#queue.indexOf(update);
    if (i >= 0) this.#queue.splice(i, 1);
    // A resync in flight: its reply (of this tick, if the server waits for us) comes
    // first, and the ready after it answers both.
    if (this.#resyncs.length > 0) return;
    this.#sendReady(update.tick);
  }

  // ---- receiving -----------------------------------------------------------------

  /** @param {string} chunk */
  #onData(chunk) {
    this.#buffer += chunk;
    let newline;
    while ((newline = this.#buffer.indexOf('\n')) >= 0) {
      let line = this.#buffer.slice(0, newline);
      this.#buffer = this.#buffer.slice(newline + 1);
      if (line.endsWith('\r')) line = line.slice(0, -1);
      if (line.trim() === '') continue;
      let message;
      try {
        message = JSON.parse(line);
      } catch {
        this.emit('serverError', { type: 'error', code: 'bad_json', message: `unparsable line from the server: ${line.slice(0, 200)}`, fatal: false });
        continue;
      }
      if (message === null || typeof message !== 'object' || typeof message.type !== 'string') continue;
      this.#dispatch(message);
    }
  }

  /** @param {any} message */
  #dispatch(message) {
    this.emit('server', message);
    switch (message.type) {
      case 'welcome':
        this.welcome = message;
        this.name = message.name ?? null;
        this.robot = message.robot ?? null;
        this.session = message.session ?? null;
        this.match = message.match ?? null;
        if (this.#queued) {
          // Seated after waiting in a template's queue: the handshake's bound starts again.
          this.#queued = false;
          if (!this.#joined) this.#armHandshakeTimer();
        }
        break;
      case 'lobby':
        this.#onLobby(message);
        break;
      case 'percepts':
        this.#onPercepts(message);
        break;
      case 'ack':
        this.#onAck(message);
        break;
      case 'result':
        this.#onResult(message);
        break;
      case 'error':
        this.#onError(message);
        break;
      case 'pong': {
        const i = this.#pings.findIndex(([id]) => id === message.id);
        if (i >= 0) this.#pings.splice(i, 1)[0][1].resolve(message);
        break;
      }
      case 'match_end':
        this.result = message.result ?? null;
        this.endReason = message.reason ?? null;
        this.#ended = true;
        this.#failPending(new BW4TError('match_over', `the match ended (${message.reason})`, { fatal: false }));
        this.#finished.resolve(this.result);
        this.#wake();
        break;
      case 'bye':
        if (message.reason === 'goodbye' || message.reason === 'match_over') {
          this.#ended = true;
        } else if (!this.error) {
          this.error = new BW4TError(message.reason ?? 'bye', 'the server closed the connection');
        }
        this.#wake();
        break;
      default:
        break; // unknown types are ignored (Versioning)
    }
  }

  /** @param {any} message */
  #onPercepts(message) {
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
      acks: this.#group.acks,
      results: this.#group.results,
      errors: this.#group.errors,
      words: this.words,
      beliefs: this.beliefs,
    };
    this.#group = { acks: [], results: [], errors: [] };
    // Results settle now, so that code awaiting them sees this tick's beliefs.
    const settle = this.#resultsToSettle;
    this.#resultsToSettle = [];
    for (const [handle, result] of settle) handle._onResult(result);

    let resyncReply = false;
    if (update.full && this.#resyncs.length > 0) {
      resyncReply = true;
      for (const deferred of this.#resyncs.splice(0)) deferred.resolve(update);
    }
    this.#latest = update;
    this.emit('update', update);
    if (this.welcome) {
      this.#joined = true;
      this.#handshake.resolve(this);
    }

    // A resync reply for the tick the iterator's handler is working on belongs to that
    // tick: it is returned by resync() and not yielded again.
    if (resyncReply && this.#iterating && this.#handling?.tick === update.tick) return;
    this.#queue.push(update);
    if (this.#iterating) this.#wake();
    else setImmediate(() => this.#autoReadyFor(update));
  }

  /**
   * A `lobby`: kept, emitted and passed to `onLobby`. It comes only before the first tick
   * and changes nothing of the tick's state (no update, no `ready`).
   * @param {any} message
   */
  #onLobby(message) {
    /** @type {Lobby} */
    const lobby = {
      ...message,
      players: Array.isArray(message.players) ? message.players : [],
      awaited: message.awaited ?? 0,
      started: message.started === true,
    };
    this.lobby = lobby;
    if (!this.welcome && lobby.queued !== undefined && !this.#queued) {
      // Waiting for a seat in a template's queue can take long: it is not bounded.
      this.#queued = true;
      clearTimeout(this.#handshakeTimer);
    }
    const onLobby = this.#options.onLobby;
    if (onLobby) {
      try {
        onLobby(lobby);
      } catch (err) {
        if (this.#joined) throw err;
        this.#handshake.reject(err instanceof Error ? err : new Error(String(err)));
        return;
      }
    }
    this.emit('lobby', lobby);
  }

  /** @param {Ack} message */
  #onAck(message) {
    this.#group.acks.push(message);
    if (message.id === undefined) return;
    const handle = this.#handles.get(message.id);
    if (!handle) return;
    if (!message.ok || !handle.durative) this.#handles.delete(message.id);
    handle._onAck(message);
    if (!message.ok || handle.durative) return;
    // An accepted pickUp/putDown changes what the robot holds, so a percepts follows:
    // its `result` settles when that is applied. A message changes nothing for the sender.
    if (handle.action === 'pickUp' || handle.action === 'putDown') this.#resultsToSettle.push([handle, null]);
    else handle._onResult(null);
  }

  /** @param {ActResult} message */
  #onResult(message) {
    this.#group.results.push(message);
    const handle = this.#handles.get(message.id);
    if (!handle) return;
    this.#handles.delete(message.id);
    this.#resultsToSettle.push([handle, message]);
  }

  /** @param {ServerErrorMessage} message */
  #onError(message) {
    if (message.fatal) {
      if (!this.error) {
        this.error = new BW4TError(message.code, message.message, { fatal: true });
      }
      this.#handshake.reject(this.error);
      this.#failPending(this.error);
      this.#wake();
      return;
    }
    this.#group.errors.push(message);
    this.emit('serverError', message);
  }

  /** @param {Error} error */
  #failPending(error) {
    for (const [handle, result] of this.#resultsToSettle.splice(0)) handle._onResult(result);
    for (const handle of this.#handles.values()) handle._fail(error);
    this.#handles.clear();
    for (const deferred of this.#resyncs.splice(0)) deferred.reject(error);
    for (const [, deferred] of this.#pings.splice(0)) deferred.reject(error);
  }

  #onClose() {
    this.closed = true;
    if (!this.error && !this.#ended && !this.#byeSent) {
      this.error = new BW4TError('connection_closed', 'the server closed the connection without bye');
    }
    const error = this.error ?? new BW4TError(this.result ? 'match_over' : 'not_connected', 'the connection is closed', { fatal: false });
    this.#handshake.reject(error);
    this.#failPending(error);
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
