// The waiting panel: a match's `lobby` messages (who is there, how many more it waits for,
// when it starts anyway) or a template's queue, shown over the map instead of the running
// clock until the match starts (the last `lobby`, marked `started`, or the first `frame` or
// `percepts` after tick 0) or ends.

import { $, el, setText } from './dom.js';

const waiting = {
  deadline: null, // performance.now() at which the match starts anyway, if the server said
  timer: null, // the countdown's interval
};

/** Shows a `lobby` message (PROTOCOL.md, lobby): the players in the match and the awaited
 * seats, or, with `queued`, the place in the template's queue. */
export function showLobby(message) {
  // The last lobby a connection gets: the match has started (an idle player's robot may
  // perceive nothing new for a while, so this, not the next percepts, ends the wait).
  if (message.started) return hideWaiting();
  const panel = $('#waiting');
  panel.hidden = false;
  document.body.dataset.waiting = '';
  const queued = message.queued ?? null;
  panel.dataset.state = queued === null ? 'waiting' : 'queued';
  panel.dataset.queued = queued === null ? '' : String(queued);
  setText($('#waiting-title'), queued === null ? 'Waiting for players' : 'In the queue');
  const about = [];
  if (message.match) about.push(`match ${message.match}`);
  if (message.template) about.push(`template ${message.template}`);
  setText($('#waiting-about'), about.join(' · '));

  const players = message.players || [];
  const list = $('#waiting-players');
  if (list.dataset.names !== players.join(' ')) {
    list.dataset.names = players.join(' ');
    list.replaceChildren(...players.map((name) => el('li', { dataset: { name } }, name)));
  }
  const awaited = message.awaited ?? 0;
  const count = $('#waiting-awaited');
  count.dataset.awaited = String(awaited);
  let words;
  if (queued !== null) words = queued === 1 ? 'You are next for a seat.' : `Place ${queued} in the queue for a seat.`;
  else if (awaited > 0) words = `Waiting for ${awaited} more player${awaited === 1 ? '' : 's'}.`;
  else words = 'Everyone is here.';
  setText(count, words);

  waiting.deadline = message.start_in_ms !== undefined && message.start_in_ms !== null ? performance.now() + message.start_in_ms : null;
  clearInterval(waiting.timer);
  waiting.timer = null;
  if (waiting.deadline !== null) waiting.timer = setInterval(showCountdown, 250);
  showCountdown();
}

/** The time left before the match starts anyway, in whole seconds. */
function showCountdown() {
  const node = $('#waiting-countdown');
  if (waiting.deadline === null) {
    node.dataset.seconds = '';
    setText(node, '');
    setText($('#waiting-short'), $('#waiting-awaited').textContent);
    return;
  }
  const seconds = Math.max(0, Math.ceil((waiting.deadline - performance.now()) / 1000));
  node.dataset.seconds = String(seconds);
  const words = seconds > 0 ? `Starts in ${seconds} s.` : 'Starting…';
  setText(node, words);
  setText($('#waiting-short'), words);
}

/** Hides the panel and brings the clock back (the match started, or ended, or the view left). */
export function hideWaiting() {
  if ($('#waiting').hidden && waiting.timer === null) return; // called on every frame
  clearInterval(waiting.timer);
  waiting.timer = null;
  waiting.deadline = null;
  $('#waiting').hidden = true;
  delete document.body.dataset.waiting;
}

/** The panel as a notice that joining or watching failed (`link`: where to go instead). */
export function showRefusal(text, link = null, title = 'Could not join') {
  hideWaiting();
  const panel = $('#waiting');
  panel.hidden = false;
  panel.dataset.state = 'refused';
  panel.dataset.queued = '';
  setText($('#waiting-title'), title);
  setText($('#waiting-about'), '');
  $('#waiting-players').replaceChildren();
  $('#waiting-players').dataset.names = '';
  const count = $('#waiting-awaited');
  count.dataset.awaited = '';
  count.replaceChildren(text, link ? el('span', {}, ' ', el('a', { href: link.href }, link.text)) : '');
  setText($('#waiting-countdown'), '');
}
