// The page's input-to-acknowledgement latency, as a person in Chromium sees it on loopback:
// a player presses a key that becomes an action (D, put down: nothing is held, so it is
// refused at the next tick boundary and the robot stays where it is) at random moments, and the page times each from the key event to the `ack` of its action
// (`window.bw4tLatency`). Prints one JSON line. Not a test (node --test does not pick it
// up); run with `BW4T_BIN=target/release/bw4t node tests/browser/bench-page-latency.js [N]`.

import { openBrowser, sleep, startBw4t, stop } from './helpers.js';

const samples = Number(process.argv[2] ?? 200);
const tickHz = 20;

const server = await startBw4t([
  'serve', '--once', '--http', '0', '--port', '0', '--map', 'default', '--builtin', '1', '--robots', '2',
  '--mode', 'realtime', '--tick-hz', String(tickHz), '--seed', '3', '--max-ticks', '0',
]);
const browser = await openBrowser();
try {
  const { page } = browser;
  await page.goto(`${server.url}?play=Bench`);
  await page.waitForSelector('#status[data-status="connected"]');
  await page.evaluate(() => document.activeElement?.blur());
  for (let i = 1; i <= samples; i++) {
    // A person's key press falls anywhere within a tick.
    await sleep(Math.random() * (1000 / tickHz) * 2);
    await page.keyboard.press('d');
    await page.waitForFunction((n) => window.bw4tLatency.samples.length >= n, i, { polling: 'raf', timeout: 10_000 });
  }
  const latency = await page.evaluate(() => ({
    n: window.bw4tLatency.samples.length,
    p50: window.bw4tLatency.p50(),
    p99: window.bw4tLatency.p99(),
  }));
  console.log(
    JSON.stringify({
      case: 'page_latency',
      browser: 'chromium (headless)',
      path: 'key press -> act over WebSocket -> ack shown, loopback',
      mode: 'realtime',
      tick_hz: tickHz,
      samples: latency.n,
      input_to_ack_p50_ms: Math.round(latency.p50 * 10) / 10,
      input_to_ack_p99_ms: Math.round(latency.p99 * 10) / 10,
    }),
  );
} finally {
  await browser.close();
  await stop(server.proc);
}
