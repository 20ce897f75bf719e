// A page from another site, open in the same browser, cannot open the match's WebSocket
// unless `bw4t serve --allow-origin` names it: the browser's own `Origin` is checked. One
// match (`--once`), so the server's own page at / joins it (no lobby).

import assert from 'node:assert/strict';
import http from 'node:http';
import { test } from 'node:test';

import { openBrowser, startBw4t, stop } from './helpers.js';

/** A page on its own HTTP server (another origin) that tries `ws://TARGET/ws` and puts
 * `open` or `refused` in its title. Resolves {url, close}. */
function otherSite() {
  const server = http.createServer((request, response) => {
    const target = new URL(request.url, 'http://x').searchParams.get('ws');
    response.writeHead(200, { 'Content-Type': 'text/html; charset=utf-8' });
    response.end(`<!doctype html><title>trying</title><script>
      const ws = new WebSocket(${JSON.stringify(target)});
      ws.onopen = () => { document.title = 'open'; ws.close(); };
      ws.onclose = () => { if (document.title === 'trying') document.title = 'refused'; };
    </script>`);
  });
  return new Promise((resolve) => {
    server.listen(0, '127.0.0.1', () => {
      const { port } = server.address();
      resolve({ url: `http://127.0.0.1:${port}/`, origin: `http://127.0.0.1:${port}`, close: () => server.close() });
    });
  });
}

/** What the other site's page got when it tried the match's WebSocket. */
async function attempt(browser, site, bw4t) {
  const target = bw4t.url.replace(/^http/, 'ws') + 'ws';
  await browser.page.goto(`${site.url}?ws=${encodeURIComponent(target)}`);
  await browser.page.waitForFunction(() => document.title !== 'trying', null, { timeout: 15_000 });
  return browser.page.title();
}

test('a page from another origin is refused the WebSocket unless allowed', { timeout: 120_000 }, async (t) => {
  const site = await otherSite();
  t.after(() => site.close());
  const browser = await openBrowser();
  t.after(() => browser.close());
  const args = ['serve', '--once', '--http', '0', '--port', '0', '--map', 'fixed', '--robots', '2'];

  const guarded = await startBw4t(args);
  t.after(() => stop(guarded.proc));
  assert.equal(await attempt(browser, site, guarded), 'refused');
  assert.ok(
    browser.errors.some((e) => e.includes('403')),
    `the browser reports the refusal: ${JSON.stringify(browser.errors)}`,
  );
  // The server's own page still connects.
  await browser.page.goto(guarded.url);
  await browser.page.waitForSelector('#status[data-status="connected"]');

  const open = await startBw4t([...args, '--allow-origin', site.origin]);
  t.after(() => stop(open.proc));
  assert.equal(await attempt(browser, site, open), 'open');
});
