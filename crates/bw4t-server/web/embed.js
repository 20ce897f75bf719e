// The player view inside another page of the same server (the study page embeds it in a
// frame at `/?embed=study&hello=JSON`): what happens in it (inputs, actions and their
// answers, messages, percepts, the match's start and end) is reported to that page, which
// logs it. Outside a frame every report is dropped.

import { params } from './dom.js';

/** Embedded: the page was opened as `?embed=...` inside a frame. */
export const embedded = params.has('embed') && window.parent !== window;

/** The hello the embedding page asks for (`?hello=` JSON: name, template, ...), or null. */
export function embeddedHello() {
  if (!embedded || !params.has('hello')) return null;
  try {
    const hello = JSON.parse(params.get('hello'));
    return hello && typeof hello === 'object' ? hello : null;
  } catch {
    return null;
  }
}

const current = { tick: null };

/** The latest tick the view knows, given with every report. */
export function setReportTick(tick) {
  current.tick = tick;
}

/** Reports one event (`kind` and its fields) to the embedding page, with the page clock's
 * time (`wall_ms`, ms since the Unix epoch) and the match's tick: `tick` when the server
 * said it (an ack's, a result's), else the latest tick the view knows. */
export function report(kind, fields = {}, tick = current.tick) {
  if (!embedded) return;
  const event = { wall_ms: Date.now(), tick: tick ?? current.tick, kind, ...fields };
  window.parent.postMessage({ bw4t: 'event', event }, location.origin);
}

if (embedded) {
  document.body.dataset.embed = params.get('embed');
  // The embedding page works out whether the participant's window has focus (it may be in
  // this frame or in the page around it): tell it when this frame's focus changes.
  for (const type of ['focus', 'blur']) {
    window.addEventListener(type, () => window.parent.postMessage({ bw4t: 'focus' }, location.origin));
  }
}
