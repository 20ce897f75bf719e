// The panels every view shares: the header's status, tick and time, the colour sequence,
// the message list, the player's log, the banner and the end of a match.

import { $, el, setText } from './dom.js';
import { page } from './page.js';
import { colourCss } from './renderer.js';
import { chatLine } from './language.js';

/** The header's status (`data-status` for tests), with a detail in brackets. */
export function setStatus(status, detail = '') {
  const node = $('#status');
  node.dataset.status = status;
  setText(node, detail ? `${status} (${detail})` : status);
}

/** The header's tick and simulated time (left as it is when `simSeconds` is not known). */
export function setTick(tick, simSeconds) {
  const node = $('#tick');
  node.dataset.tick = String(tick);
  setText(node, tick);
  if (simSeconds !== undefined) setText($('#sim-time'), `${Number(simSeconds).toFixed(1)} s`);
}

/** The colour sequence as chips; delivered ones dimmed, the next one marked. */
export function showSequence(sequence, index) {
  const list = $('#sequence');
  if (list.dataset.colours !== sequence.join(' ')) {
    list.dataset.colours = sequence.join(' ');
    list.replaceChildren(
      ...sequence.map((c, i) =>
        el('li', { title: `${i}: ${c}`, dataset: { color: c, position: String(i) }, style: `--chip:${colourCss(c)}` }, c),
      ),
    );
  }
  list.querySelectorAll('li').forEach((li, i) => {
    li.classList.toggle('done', i < index);
    li.classList.toggle('current', i === index);
  });
  const node = $('#sequence-index');
  node.dataset.index = String(index);
  setText(node, index);
  setText($('#sequence-length'), sequence.length);
  $('#sequence-box').classList.toggle('complete', sequence.length > 0 && index >= sequence.length);
}

/** The most lines a log list keeps (the replay's message list as well). */
export const LOG_LIMIT = 300;

/** Appends to a log list, newest at the bottom, keeping it short and scrolled down. */
export function appendLog(list, node) {
  const stick = list.scrollTop + list.clientHeight >= list.scrollHeight - 4;
  list.append(node);
  while (list.children.length > LOG_LIMIT) list.firstElementChild.remove();
  if (stick) list.scrollTop = list.scrollHeight;
}

/** One line of the message list (`to`: null for a message to all): the sentence of a
 * message of the language (`said`, or a text that is its text form), else the text.
 * `shown`: the sender's name as shown (the participant view shows its own as "You"). */
export function addMessage(tick, from, to, text, said = null, shown = from) {
  const line = chatLine(text, said);
  const dataset = { from, to: to ?? '' };
  if (line.said) {
    dataset.kind = line.said.kind;
    dataset.said = JSON.stringify(line.said);
  }
  appendLog(
    $('#messages'),
    el(
      'li',
      { dataset },
      el('span', { class: 'when' }, `${tick ?? ''}`),
      el('b', {}, shown),
      to && to !== 'all' ? el('span', { class: 'to' }, ` → ${to}`) : '',
      ': ',
      el('span', { class: 'sentence' }, line.sentence),
    ),
  );
  return line;
}

/** The player's event log: kind is 'sent', 'ok', 'reject', 'result', 'error' or 'info'.
 * `data` goes into data- attributes (action, outcome, code), for tests and styling. */
export function log(kind, text, tick, data = {}) {
  const dataset = { kind };
  for (const [key, value] of Object.entries(data)) if (value !== undefined) dataset[key] = String(value);
  appendLog($('#log'), el('li', { class: kind, dataset }, el('span', { class: 'when' }, `${tick ?? ''}`), text));
}

/** A line across the map (the end of the match). */
export function showBanner(text) {
  const banner = $('#banner');
  banner.textContent = text;
  banner.hidden = false;
}

/** A note above the message list (why messages are missing), or none. */
export function setWatchNote(text) {
  const note = $('#watch-note');
  note.hidden = !text;
  setText(note, text || '');
}

/** The match's settings from `welcome`: kept, and its mode (and name) shown. */
export function showMatch(match) {
  page.match = match;
  setText($('#mode'), match.mode);
  // On a server of many matches, which one this is.
  $('#match-field').hidden = !(page.lobby && match.name);
  if (match.name) setText($('#match-name'), match.template ? `${match.name} (${match.template})` : match.name);
}

/** A `match_end`: the status, and a banner with the result (`me`: the player's name, to
 * show what that robot delivered; none for the overview). */
export function endMatch(message, me = null) {
  page.ended = true;
  setStatus('ended', message.reason);
  const r = message.result || {};
  const seq = r.sequence ? `, sequence ${r.sequence_index}/${r.sequence.length}` : '';
  let mine = '';
  if (me !== null) {
    const robot = (r.per_robot || []).find((each) => each.name === me);
    if (robot) mine = `; you delivered ${robot.good_drops} in order${robot.wrong_drops ? `, ${robot.wrong_drops} wrong` : ''}`;
  }
  showBanner(`Match over: ${message.reason} after ${r.ticks ?? '?'} ticks${seq}${mine}`);
}
