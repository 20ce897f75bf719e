// Shared pieces of the browser tests: find the bw4t binary, start it and read its address,
// stop it, drive Debian's Chromium through playwright-core, save screenshots.
//
// Every wait is bounded, and every process a test starts is stopped by its id when the
// test ends, whether it passed or not.

import { spawn } from 'node:child_process';
import net from 'node:net';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { chromium } from 'playwright-core';

export const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
export const OUTPUT = path.join(ROOT, 'test-output', 'browser');

/** The binary under test: BW4T_BIN, else the newer of the release and debug builds. */
export function binary() {
  if (process.env.BW4T_BIN) return process.env.BW4T_BIN;
  const builds = ['release', 'debug']
    .map((profile) => path.join(ROOT, 'target', profile, 'bw4t'))
    .filter((file) => fs.existsSync(file))
    .sort((a, b) => fs.statSync(b).mtimeMs - fs.statSync(a).mtimeMs);
  if (builds.length === 0) throw new Error('no bw4t binary: run `cargo build` or set BW4T_BIN');
  return builds[0];
}

/** A fresh temporary folder, removed by `cleanup`. */
export function tempDir(prefix) {
  return fs.mkdtempSync(path.join(os.tmpdir(), `bw4t-browser-${prefix}-`));
}

/**
 * Starts `bw4t ARGS...` and resolves once it has printed `http on HOST:PORT`, with
 * {proc, url, output()}. Rejects (and stops the process) if it exits first or prints
 * nothing within `timeoutMs`.
 */
export function startBw4t(args, { timeoutMs = 30_000 } = {}) {
  const proc = spawn(binary(), args, { cwd: ROOT, stdio: ['ignore', 'pipe', 'pipe'] });
  let stdout = '';
  let stderr = '';
  const output = () => `--- stdout\n${stdout}--- stderr\n${stderr}`;
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => {
      stop(proc);
      reject(new Error(`bw4t ${args.join(' ')} printed no 'http on' line within ${timeoutMs} ms\n${output()}`));
    }, timeoutMs);
    proc.stdout.setEncoding('utf8');
    proc.stderr.setEncoding('utf8');
    proc.stdout.on('data', (chunk) => {
      stdout += chunk;
      const found = stdout.match(/^http on (\S+):(\d+)\s*$/m);
      if (found) {
        clearTimeout(timer);
        // `bw4t serve` also prints the protocol's TCP port (before the HTTP one).
        const tcp = stdout.match(/^listening on (\S+):(\d+)\s*$/m);
        resolve({
          proc,
          url: `http://${found[1]}:${found[2]}/`,
          tcp: tcp ? { host: tcp[1], port: Number(tcp[2]) } : null,
          output,
        });
      }
    });
    proc.stderr.on('data', (chunk) => {
      stderr += chunk;
    });
    proc.on('error', (err) => {
      clearTimeout(timer);
      reject(err);
    });
    proc.on('exit', (code, signal) => {
      clearTimeout(timer);
      reject(new Error(`bw4t ${args.join(' ')} exited (${code ?? signal}) before serving\n${output()}`));
    });
  });
}

/** Runs `bw4t ARGS...` to its end (bounded), rejecting on a non-zero exit. */
export function runBw4t(args, { timeoutMs = 120_000 } = {}) {
  const proc = spawn(binary(), args, { cwd: ROOT, stdio: ['ignore', 'pipe', 'pipe'] });
  let out = '';
  proc.stdout.on('data', (c) => (out += c));
  proc.stderr.on('data', (c) => (out += c));
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => {
      stop(proc);
      reject(new Error(`bw4t ${args.join(' ')} did not finish within ${timeoutMs} ms\n${out}`));
    }, timeoutMs);
    proc.on('exit', (code) => {
      clearTimeout(timer);
      if (code === 0) resolve(out);
      else reject(new Error(`bw4t ${args.join(' ')} exited ${code}\n${out}`));
    });
  });
}

/** Stops a process we started: SIGTERM, then SIGKILL if it is still there after 3 s. */
export async function stop(proc) {
  if (!proc || proc.exitCode !== null || proc.signalCode !== null) return;
  const exited = new Promise((resolve) => proc.once('exit', resolve));
  proc.kill('SIGTERM');
  const timer = new Promise((resolve) => setTimeout(() => resolve('timeout'), 3000));
  if ((await Promise.race([exited, timer])) === 'timeout') {
    proc.kill('SIGKILL');
    await Promise.race([exited, new Promise((resolve) => setTimeout(resolve, 2000))]);
  }
}

/**
 * Chromium from Debian, headless, with a fresh profile. Resolves {context, page, close}.
 * `ignoreHTTPSErrors` takes a self-signed certificate; `args` are more Chromium flags.
 */
export async function openBrowser({ width = 1280, height = 800, ignoreHTTPSErrors = false, args = [] } = {}) {
  const profile = tempDir('profile');
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    ignoreHTTPSErrors,
    viewport: { width, height },
    args: [
      '--headless',
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      ...args,
    ],
    timeout: 30_000,
  });
  context.setDefaultTimeout(15_000);
  const page = context.pages()[0] || (await context.newPage());
  // The page's own errors fail the test that made them.
  const errors = [];
  page.on('pageerror', (err) => errors.push(err.message));
  page.on('console', (message) => {
    if (message.type() === 'error') errors.push(message.text());
  });
  return {
    context,
    page,
    errors,
    async close() {
      await context.close().catch(() => {});
      fs.rmSync(profile, { recursive: true, force: true });
    },
  };
}

/** Saves a screenshot under test-output/browser/NAME.png (never fails the test). */
export async function screenshot(page, name) {
  try {
    fs.mkdirSync(OUTPUT, { recursive: true });
    await page.screenshot({ path: path.join(OUTPUT, `${name}.png`), timeout: 10_000 });
  } catch (err) {
    console.error(`screenshot ${name} failed: ${err.message}`);
  }
}

/** Text of an element, trimmed. */
export async function text(page, selector) {
  return ((await page.textContent(selector)) ?? '').trim();
}

/** A number shown by an element. */
export async function number(page, selector) {
  return Number(await text(page, selector));
}

/** Waits (bounded) until the number shown by `selector` is above `above` (or equals
 * `equals`); resolves with it. */
export async function waitForNumber(page, selector, { above, equals }, timeout = 15_000) {
  const handle = await page.waitForFunction(
    ([sel, more, same]) => {
      const node = document.querySelector(sel);
      if (!node || node.textContent.trim() === '') return false;
      const value = Number(node.textContent.trim());
      // An object, so that 0 counts as found.
      if (more !== null && value > more) return { value };
      if (same !== null && value === same) return { value };
      return false;
    },
    [selector, above ?? null, equals ?? null],
    { timeout, polling: 100 },
  );
  return (await handle.jsonValue()).value;
}

/** The picture on the map canvas, as a data URL: two of them differ when it changed. */
export function canvasPicture(page) {
  return page.evaluate(() => document.querySelector('#map').toDataURL());
}

/**
 * A spectator over the TCP protocol port, beside the page: a reference for the match's
 * tick. Resolves once its `welcome` came; `tick` is the latest frame's, `frames` counts them.
 */
export function tcpSpectator({ host, port }, { timeoutMs = 10_000 } = {}) {
  return new Promise((resolve, reject) => {
    const socket = net.connect(port, host);
    const watcher = { tick: -1, frames: 0, close: () => socket.destroy() };
    let buffer = '';
    const timer = setTimeout(() => {
      socket.destroy();
      reject(new Error('the TCP spectator got no welcome'));
    }, timeoutMs);
    socket.setEncoding('utf8');
    socket.on('connect', () => {
      socket.write(`${JSON.stringify({ type: 'hello', protocol: 'bw4t', versions: [1], role: 'spectator' })}\n`);
    });
    socket.on('data', (chunk) => {
      buffer += chunk;
      let end;
      while ((end = buffer.indexOf('\n')) >= 0) {
        const line = buffer.slice(0, end);
        buffer = buffer.slice(end + 1);
        const message = JSON.parse(line);
        if (message.type === 'welcome') {
          clearTimeout(timer);
          resolve(watcher);
        } else if (message.type === 'frame') {
          watcher.tick = message.tick;
          watcher.frames += 1;
        }
      }
    });
    socket.on('error', (err) => {
      clearTimeout(timer);
      reject(err);
    });
  });
}

export const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

/** A CSV file as rows of cells (quoted cells may hold commas, quotes and newlines). */
export function readCsv(file) {
  const text = fs.readFileSync(file, 'utf8');
  const rows = [];
  let row = [];
  let cell = '';
  let quoted = false;
  for (let i = 0; i < text.length; i++) {
    const c = text[i];
    if (quoted) {
      if (c === '"' && text[i + 1] === '"') {
        cell += '"';
        i++;
      } else if (c === '"') quoted = false;
      else cell += c;
    } else if (c === '"') quoted = true;
    else if (c === ',') {
      row.push(cell);
      cell = '';
    } else if (c === '\n') {
      row.push(cell);
      rows.push(row);
      row = [];
      cell = '';
    } else cell += c;
  }
  if (cell || row.length) rows.push([...row, cell]);
  const [head, ...body] = rows;
  return body.map((cells) => Object.fromEntries(head.map((name, i) => [name, cells[i] ?? ''])));
}
