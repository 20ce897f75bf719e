// Test support: find the real bw4t binary, start `bw4t serve` on a free port, run a
// scripted fake server in the test process, bound every wait. Not a test file itself
// (the runner loads it and finds no tests).

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
/** The client's directory (protocol/clients/js). */
export const CLIENT_DIR = path.resolve(here, '..');
/** The repository root. */
export const REPO = path.resolve(CLIENT_DIR, '..', '..', '..');

/**
 * The bw4t binary: `BW4T_BIN`, else the newest of target/release/bw4t and
 * target/debug/bw4t. Throws a clear error when there is none.
 * @returns {string}
 */
export function findBinary() {
  const fromEnv = process.env.BW4T_BIN;
  if (fromEnv) {
    if (!fs.existsSync(fromEnv)) throw new Error(`BW4T_BIN=${fromEnv} does not exist`);
    return fromEnv;
  }
  const candidates = ['release', 'debug']
    .map((profile) => path.join(REPO, 'target', profile, 'bw4t'))
    .filter((p) => fs.existsSync(p))
    .sort((a, b) => fs.statSync(b).mtimeMs - fs.statSync(a).mtimeMs);
  if (candidates.length === 0) {
    throw new Error(
      `no bw4t binary: set BW4T_BIN, or build one (cd ${REPO} && cargo build) so that ` +
        `target/debug/bw4t or target/release/bw4t exists`,
    );
  }
  return candidates[0];
}

/**
 * Reject if `promise` has not settled within `ms`.
 * @template T
 * @param {Promise<T>} promise
 * @param {number} ms
 * @param {string} what named in the error
 * @returns {Promise<T>}
 */
export function within(promise, ms, what) {
  let timer;
  return Promise.race([
    promise,
    new Promise((_, reject) => {
      timer = setTimeout(() => reject(new Error(`timed out after ${ms} ms: ${what}`)), ms);
    }),
  ]).finally(() => clearTimeout(timer));
}

/** @type {Set<import('node:child_process').ChildProcess>} */
const running = new Set();
process.on('exit', () => {
  for (const proc of running) proc.kill('SIGKILL');
});

/**
 * A `bw4t serve` process.
 * @typedef {object} Server
 * @property {string} host
 * @property {number} port
 * @property {() => string} stderr what it printed on stderr so far
 * @property {Promise<number|null>} exited resolves with the exit code
 * @property {() => Promise<void>} stop SIGTERM, then SIGKILL after 2 s; resolves when it is gone
 */

/**
 * Start `bw4t serve --port 0` with these arguments (lockstep on the fixed map with seed 1
 * unless given; nothing with `--config`, whose templates hold the settings) and wait
 * (at most `timeoutMs`) for its `listening on HOST:PORT` line.
 * @param {string[]} [args]
 * @param {{timeoutMs?: number}} [options]
 * @returns {Promise<Server>}
 */
export async function startServer(args = [], options = {}) {
  const has = (flag) => args.includes(flag);
  const full = ['serve', '--port', '0'];
  if (!has('--mode') && !has('--config')) full.push('--mode', 'lockstep');
  if (!has('--map') && !has('--config')) full.push('--map', 'fixed');
  if (!has('--seed') && !has('--config')) full.push('--seed', '1');
  full.push(...args);
  const proc = spawn(findBinary(), full, { stdio: ['ignore', 'pipe', 'pipe'] });
  running.add(proc);
  let stderr = '';
  proc.stderr.setEncoding('utf8');
  proc.stderr.on('data', (d) => {
    stderr += d;
  });
  const exited = new Promise((resolve) => {
    proc.on('exit', (code) => {
      running.delete(proc);
      resolve(code);
    });
  });
  const stop = async () => {
    if (proc.exitCode !== null || proc.signalCode !== null) return;
    proc.kill('SIGTERM');
    const timer = setTimeout(() => proc.kill('SIGKILL'), 2000);
    await exited;
    clearTimeout(timer);
  };
  try {
    const address = await within(
      new Promise((resolve, reject) => {
        let out = '';
        proc.stdout.setEncoding('utf8');
        proc.stdout.on('data', (d) => {
          out += d;
          const m = /listening on (\S+):(\d+)/.exec(out);
          if (m) resolve({ host: m[1], port: Number(m[2]) });
        });
        proc.on('error', reject);
        proc.on('exit', (code) => reject(new Error(`bw4t serve exited (${code}) before listening: ${stderr}`)));
      }),
      options.timeoutMs ?? 10000,
      'bw4t serve to print "listening on"',
    );
    return { ...address, stderr: () => stderr, exited, stop };
  } catch (err) {
    await stop();
    throw err;
  }
}

/**
 * Run `bw4t run ... --json` and parse its result; kill it after `timeoutMs`.
 * @param {string[]} args
 * @param {{timeoutMs?: number}} [options]
 * @returns {Promise<any>}
 */
export async function runMatch(args, options = {}) {
  const timeoutMs = options.timeoutMs ?? 60000;
  const proc = spawn(findBinary(), ['run', ...args, '--json'], { cwd: REPO, stdio: ['ignore', 'pipe', 'pipe'] });
  running.add(proc);
  let stdout = '';
  let stderr = '';
  proc.stdout.setEncoding('utf8').on('data', (d) => (stdout += d));
  proc.stderr.setEncoding('utf8').on('data', (d) => (stderr += d));
  let timedOut = false;
  const timer = setTimeout(() => {
    timedOut = true;
    proc.kill('SIGKILL');
  }, timeoutMs);
  const code = await new Promise((resolve, reject) => {
    proc.on('error', reject);
    proc.on('exit', (c) => resolve(c));
  }).finally(() => {
    clearTimeout(timer);
    running.delete(proc);
  });
  if (timedOut) throw new Error(`bw4t run ${args.join(' ')} took more than ${timeoutMs} ms\n${stderr}`);
  if (code !== 0) throw new Error(`bw4t run exited with ${code}:\n${stderr}\n${stdout}`);
  return JSON.parse(stdout);
}

/**
 * One client connection seen by a fake server: the client's messages in order, read
 * with `next()`/`expect(type)` (bounded), and `send(...)` to answer.
 */
export class FakeConnection {
  /** @param {import('node:net').Socket} socket */
  constructor(socket) {
    this.socket = socket;
    /** Every message received, in order. @type {any[]} */
    this.received = [];
    /** @type {any[]} */
    this.unread = [];
    /** @type {Array<() => void>} */
    this.waiting = [];
    this.ended = false;
    let buffer = '';
    socket.setEncoding('utf8');
    socket.on('data', (chunk) => {
      buffer += chunk;
      let newline;
      while ((newline = buffer.indexOf('\n')) >= 0) {
        const message = JSON.parse(buffer.slice(0, newline));
        buffer = buffer.slice(newline + 1);
        this.received.push(message);
        this.unread.push(message);
      }
      this.#wake();
    });
    socket.on('close', () => {
      this.ended = true;
      this.#wake();
    });
    socket.on('error', () => {});
  }

  #wake() {
    for (const wake of this.waiting.splice(0)) wake();
  }

  /**
   * The client's next message, or `null` once it closed the connection.
   * @param {number} [ms]
   * @returns {Promise<any>}
   */
  async next(ms = 10000) {
    const arrived = async () => {
      while (this.unread.length === 0 && !this.ended) await new Promise((resolve) => this.waiting.push(() => resolve(undefined)));
      return this.unread.shift() ?? null;
    };
    return within(arrived(), ms, 'a message from the client');
  }

  /**
   * The client's next message, which must be of this type.
   * @param {string} type
   */
  async expect(type) {
    const message = await this.next();
    if (message?.type !== type) throw new Error(`expected ${type} from the client, got ${JSON.stringify(message)}`);
    return message;
  }

  /** Read what the client still sends until it closes the connection. */
  async closed() {
    while ((await this.next()) !== null);
  }

  /** @param {...object} messages */
  send(...messages) {
    this.socket.write(messages.map((m) => JSON.stringify(m) + '\n').join(''));
  }
}

/**
 * A scripted bw4t server in the test process: each connection runs `script(conn)`.
 * `stop()` closes it, waits for the scripts (bounded) and throws the first error of one,
 * so a failed check inside a script fails the test.
 * @param {(conn: FakeConnection) => Promise<void>} script
 * @returns {Promise<{host: string, port: number, connections: FakeConnection[], stop: () => Promise<void>}>}
 */
export async function startFakeServer(script) {
  /** @type {FakeConnection[]} */
  const connections = [];
  /** @type {Promise<void>[]} */
  const runs = [];
  /** @type {unknown[]} */
  const errors = [];
  const server = net.createServer((socket) => {
    const conn = new FakeConnection(socket);
    connections.push(conn);
    runs.push(
      script(conn)
        .catch((err) => {
          errors.push(err);
        })
        .finally(() => socket.end()),
    );
  });
  await new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(undefined)));
  const { port } = /** @type {import('node:net').AddressInfo} */ (server.address());
  const stop = async () => {
    const closed = new Promise((resolve) => server.close(() => resolve(undefined)));
    await within(Promise.all(runs), 10000, 'the fake server scripts to finish');
    await within(closed, 10000, 'the fake server to close');
    if (errors.length > 0) throw errors[0];
  };
  return { host: '127.0.0.1', port, connections, stop };
}

/** Messages of a many-match server, for fake servers. */
export const fake = {
  /**
   * @param {{name?: string, match?: string, template?: string, session?: string, mode?: string}} [fields]
   */
  welcome({ name = 'Ann', match = 'default', template, session = '0123456789abcdef01234567', mode = 'realtime' } = {}) {
    const info = { name: match, template, map: 'fixed', seed: 1, mode, tick_hz: 20, players_needed: 2, every_tick: false };
    if (mode === 'lockstep') info.deadline_ms = 0;
    return { type: 'welcome', version: 1, name, robot: 0, session, match: info };
  },
  snapshot(tick = 0, name = 'Ann') {
    const add = [['ownName', name], ['bot', 0], ['at', 'FrontDropZone'], ['state', 'arrived'], ['player', name]];
    return { type: 'percepts', tick, add, not: [], full: true };
  },
  /** @param {object} fields */
  lobby(fields) {
    return { type: 'lobby', ...fields };
  },
  /**
   * A fatal error and the bye after it.
   * @param {string} code
   * @param {string} message
   */
  fatal(code, message) {
    return [
      { type: 'error', code, message, fatal: true },
      { type: 'bye', reason: code },
    ];
  },
};
