// The deployment of docs/DEPLOY.md, tested: `bw4t study` on loopback behind Caddy with
// TLS, made from the repository's deploy/Caddyfile (its site name, upstream port and
// certificate replaced with this test's). A real Chromium participant goes through the
// example study over https and wss to its completion code, under a domain name (mapped to
// 127.0.0.1 inside the browser) that bw4t lets in only because of `--allow-origin`; a
// WebSocket handshake from another origin is still refused by bw4t through the proxy;
// `bw4t study export` holds the participant's data. Skipped, with the reason, where
// `caddy` or `openssl` is not installed.

import assert from 'node:assert/strict';
import { spawn, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import https from 'node:https';
import net from 'node:net';
import path from 'node:path';
import { test } from 'node:test';

import { ROOT, openBrowser, runBw4t, screenshot, startBw4t, stop, tempDir } from './helpers.js';

const EXAMPLE = path.join(ROOT, 'examples', 'study');
const CADDYFILE = path.join(ROOT, 'deploy', 'Caddyfile');
/** The public name the participant uses; only the test's browser resolves it (to 127.0.0.1). */
const SITE = 'study.bw4t.test';
const PARTICIPANT = 'DEPLOY1';

/** The full path of `name` on PATH, or null. */
function onPath(name) {
  for (const dir of (process.env.PATH || '').split(path.delimiter)) {
    const file = path.join(dir, name);
    try {
      fs.accessSync(file, fs.constants.X_OK);
      return file;
    } catch {
      // not in this folder
    }
  }
  return null;
}

/** A TCP port free on 127.0.0.1 just now (for Caddy, which cannot report a port it picked). */
function freePort() {
  return new Promise((resolve, reject) => {
    const server = net.createServer();
    server.once('error', reject);
    server.listen(0, '127.0.0.1', () => {
      const { port } = server.address();
      server.close(() => resolve(port));
    });
  });
}

/** A self-signed certificate for `localhost` and SITE, written into `dir`. */
function certificate(dir) {
  const cert = path.join(dir, 'cert.pem');
  const key = path.join(dir, 'key.pem');
  const made = spawnSync(
    'openssl',
    ['req', '-x509', '-newkey', 'rsa:2048', '-nodes', '-days', '1', '-subj', '/CN=localhost',
      '-addext', `subjectAltName=DNS:localhost,DNS:${SITE},IP:127.0.0.1`, '-keyout', key, '-out', cert],
    { encoding: 'utf8', timeout: 30_000 },
  );
  assert.equal(made.status, 0, `openssl req failed:\n${made.stderr}`);
  return { cert, key };
}

/**
 * The repository's Caddyfile for this test: its global options replaced with ones that
 * keep Caddy off the machine's ports 80/443, its admin endpoint and its certificate
 * authorities (a given certificate, storage in `dir`), and the site, upstream and `tls`
 * set. Each replacement must find what it replaces, so a changed deploy/Caddyfile fails
 * here instead of going untested.
 */
function testCaddyfile(dir, { port, httpPort, upstream, cert, key }) {
  let text = fs.readFileSync(CADDYFILE, 'utf8');
  const replace = (pattern, by, what) => {
    assert.match(text, pattern, `deploy/Caddyfile has ${what}`);
    text = text.replace(pattern, () => by);
  };
  const options = [
    '{',
    '\tadmin off',
    '\tauto_https disable_redirects',
    '\tskip_install_trust',
    `\tstorage file_system ${path.join(dir, 'caddy-storage')}`,
    `\thttps_port ${port}`,
    // Must differ from https_port; nothing listens on it (no plain-http site, no redirects).
    `\thttp_port ${httpPort}`,
    '}',
  ];
  replace(/^\{\n(?:[^\n]*\n)*?\}\n/m, `${options.join('\n')}\n`, 'a global options block');
  replace(/^study\.example\.org \{$/m, `https://${SITE}:${port} {\n\ttls ${cert} ${key}`, 'the site study.example.org');
  replace(/reverse_proxy 127\.0\.0\.1:8080\b/, `reverse_proxy ${upstream}`, 'reverse_proxy 127.0.0.1:8080');
  const file = path.join(dir, 'Caddyfile');
  fs.writeFileSync(file, text);
  return file;
}

/** Starts `caddy run` on `file`; resolves with {proc, output()} once it serves. */
function startCaddy(file, home, { timeoutMs = 30_000 } = {}) {
  const env = { ...process.env, HOME: home, XDG_DATA_HOME: path.join(home, 'data'), XDG_CONFIG_HOME: path.join(home, 'config') };
  const proc = spawn('caddy', ['run', '--config', file, '--adapter', 'caddyfile'], { cwd: home, env, stdio: ['ignore', 'pipe', 'pipe'] });
  let log = '';
  const output = () => `--- caddy\n${log}`;
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => {
      stop(proc);
      reject(new Error(`caddy did not serve within ${timeoutMs} ms\n${output()}`));
    }, timeoutMs);
    const read = (chunk) => {
      log += chunk;
      if (log.includes('serving initial configuration')) {
        clearTimeout(timer);
        resolve({ proc, output });
      }
    };
    proc.stdout.setEncoding('utf8');
    proc.stderr.setEncoding('utf8');
    proc.stdout.on('data', read);
    proc.stderr.on('data', read);
    proc.on('error', (err) => {
      clearTimeout(timer);
      reject(err);
    });
    proc.on('exit', (code, signal) => {
      clearTimeout(timer);
      reject(new Error(`caddy exited (${code ?? signal}) before serving\n${output()}`));
    });
  });
}

/** A request through the proxy to 127.0.0.1:port as SITE (SNI and Host); resolves with
 * {status, headers, body}. Bounded. */
function viaProxy(port, urlPath, headers = {}) {
  return new Promise((resolve, reject) => {
    const request = https.request(
      { host: '127.0.0.1', port, path: urlPath, servername: SITE, rejectUnauthorized: false, timeout: 10_000, headers: { Host: `${SITE}:${port}`, ...headers } },
      (response) => {
        let body = '';
        response.setEncoding('utf8');
        response.on('data', (c) => (body += c));
        response.on('end', () => resolve({ status: response.statusCode, headers: response.headers, body }));
      },
    );
    // A handshake that is accepted would hand over the socket; this test expects none.
    request.on('upgrade', (response, socket) => {
      socket.destroy();
      resolve({ status: response.statusCode, headers: response.headers, body: '' });
    });
    request.on('timeout', () => request.destroy(new Error(`no answer to ${urlPath} within 10 s`)));
    request.on('error', reject);
    request.end();
  });
}

/** Waits for the study page to show a page of `kind` at `step` (as study.test.js does). */
async function onPage(page, kind, step) {
  await page.waitForSelector(`body[data-kind="${kind}"][data-step="${step}"]`, { timeout: 20_000 });
}

/** Answers a questionnaire's required items: the first option of every choice and scale. */
async function answer(page, step) {
  await onPage(page, 'questionnaire', step);
  const items = await page.$$eval('fieldset[data-item]', (boxes) =>
    boxes.filter((box) => box.querySelector('input[type="radio"]')).map((box) => box.dataset.item),
  );
  assert.ok(items.length > 0, `questionnaire at step ${step} has items to answer`);
  for (const item of items) await page.check(`fieldset[data-item="${item}"] input[type="radio"] >> nth=0`);
  await page.click('#questionnaire-submit');
}

/** A trial: connected over the page's WebSocket, played until the match's time limit. */
async function trial(page, step) {
  await onPage(page, 'trial', step);
  const frame = await (await page.waitForSelector('#trial-frame')).contentFrame();
  // The participant's view shows no status words: the connection's state is an attribute.
  await frame.waitForSelector('#status[data-status="connected"]', { state: 'attached', timeout: 20_000 });
  // The study file's time limit was shortened to a few seconds (below).
  await page.waitForSelector('#trial-continue', { timeout: 40_000 });
  await page.click('#trial-continue');
}

test('a participant goes through the example study over https and wss behind Caddy', { timeout: 240_000 }, async (t) => {
  for (const tool of ['caddy', 'openssl']) {
    if (!onPath(tool)) {
      t.skip(`${tool} is not installed (Debian: apt-get install ${tool}); test.sh installs it`);
      return;
    }
  }
  const dir = tempDir('deploy');
  t.after(() => fs.rmSync(dir, { recursive: true, force: true }));
  const { cert, key } = certificate(dir);

  // The example study, with trials of 4 s instead of 5 minutes so that the test ends soon,
  // and counted although this scripted participant never moves its robot
  // (min_active_ticks = 0; a real participant's trial counts only if they played).
  const study = path.join(dir, 'study');
  fs.cpSync(EXAMPLE, study, { recursive: true });
  const studyFile = path.join(study, 'study.toml');
  const original = fs.readFileSync(studyFile, 'utf8');
  const shortened = original
    .replace(/^time_limit_s = \d+/m, 'time_limit_s = 4')
    .replace(/^\[\[condition\]\]$/gm, '[[condition]]\nmin_active_ticks = 0');
  assert.notEqual(shortened, original, 'the example study sets time_limit_s');
  assert.equal(shortened.match(/^min_active_ticks = 0$/gm)?.length, 2, 'both conditions counted without moving');
  fs.writeFileSync(studyFile, shortened);
  const code = original.match(/^completion_code = "([^"]+)"/m)?.[1];
  assert.ok(code, 'the example study has a completion code');

  // bw4t on loopback only, letting in pages of the public origin (DEPLOY.md).
  const port = await freePort();
  const origin = `https://${SITE}:${port}`;
  const data = path.join(dir, 'data');
  const server = await startBw4t(['study', studyFile, '--data', data, '--bind', '127.0.0.1', '--http', '0', '--port', '0', '--operator-token', 'deploy-secret', '--allow-origin', origin]);
  t.after(() => stop(server.proc));
  const upstream = new URL(server.url).host;
  assert.match(upstream, /^127\.0\.0\.1:\d+$/, 'bw4t listens on loopback');

  const caddyHome = path.join(dir, 'caddy-home');
  fs.mkdirSync(caddyHome);
  const caddy = await startCaddy(testCaddyfile(dir, { port, httpPort: await freePort(), upstream, cert, key }), caddyHome);
  t.after(() => stop(caddy.proc));

  // What the proxy adds: TLS and its headers. What bw4t enforces still holds behind it: a
  // page of another origin may not open a WebSocket.
  const front = await viaProxy(port, `/study?participant=${PARTICIPANT}-probe`);
  assert.equal(front.status, 200, `the study page through the proxy\n${caddy.output()}`);
  assert.match(front.headers['strict-transport-security'] ?? '', /max-age=\d+/, 'HSTS from the proxy');
  const wsHeaders = { Connection: 'Upgrade', Upgrade: 'websocket', 'Sec-WebSocket-Version': '13', 'Sec-WebSocket-Key': 'dGhlIHNhbXBsZSBub25jZQ==' };
  const foreign = await viaProxy(port, '/ws', { ...wsHeaders, Origin: 'https://evil.example' });
  assert.equal(foreign.status, 403, `bw4t refuses another origin's WebSocket behind the proxy: ${foreign.body}`);

  // Takes the self-signed certificate and resolves SITE to 127.0.0.1.
  const browser = await openBrowser({ ignoreHTTPSErrors: true, args: [`--host-resolver-rules=MAP ${SITE} 127.0.0.1`] });
  t.after(() => browser.close());
  const { page } = browser;
  const sockets = [];
  page.on('websocket', (socket) => sockets.push(socket.url()));
  try {
    const response = await page.goto(`${origin}/study?participant=${PARTICIPANT}`);
    assert.equal(response.status(), 200);
    assert.equal(new URL(page.url()).protocol, 'https:', 'the page is served over https');
    assert.equal((await response.securityDetails())?.subjectName, 'localhost', 'with the test certificate');
    await onPage(page, 'consent', 0);
    await page.click('#consent-agree');
    await onPage(page, 'instructions', 1);
    await page.click('#continue');
    await trial(page, 2);
    await answer(page, 3);
    await trial(page, 4);
    await answer(page, 5);
    await answer(page, 6);
    await onPage(page, 'final', 7);
    assert.equal((await page.textContent('#completion-code')).trim(), code, 'the completion code');
    assert.ok(sockets.length >= 2, `a WebSocket for each trial: ${sockets.join(' ')}`);
    for (const url of sockets) assert.ok(url.startsWith(`wss://${SITE}:${port}/`), `the trial's WebSocket is wss through the proxy: ${url}`);
    assert.deepEqual(browser.errors, [], 'no errors on the page');
    // Every event is with the server before it stops (the page sends them once a second).
    await page.waitForFunction(() => window.bw4tStudy.pending() === 0, null, { timeout: 10_000 });
  } finally {
    await screenshot(page, 'deploy-final');
  }
  await stop(caddy.proc);
  await stop(server.proc);

  const out = path.join(dir, 'export');
  await runBw4t(['study', 'export', data, '--out', out]);
  const participants = fs.readFileSync(path.join(out, 'participants.csv'), 'utf8');
  assert.match(participants, new RegExp(`^${PARTICIPANT},`, 'm'), `participants.csv lists ${PARTICIPANT}:\n${participants}`);
  const trials = fs.readFileSync(path.join(out, 'trials.csv'), 'utf8').split('\n').filter((l) => l.startsWith(`${PARTICIPANT},`));
  assert.equal(trials.length, 2, `two trials of ${PARTICIPANT} in trials.csv`);
  const answers = fs.readFileSync(path.join(out, 'answers.csv'), 'utf8').split('\n').filter((l) => l.startsWith(`${PARTICIPANT},`));
  assert.ok(answers.length >= 8, `${PARTICIPANT}'s answers in answers.csv (${answers.length})`);
  const events = fs.readFileSync(path.join(out, 'events.csv'), 'utf8');
  assert.match(events, new RegExp(`^${PARTICIPANT},.*consent-agree`, 'm'), 'the consent click in events.csv');
});
