// The participant view: the player view as a study's participant sees it, embedded in the
// study page (`?embed=study`). Light, in the study page's style, with no system words and
// no match, template, condition or robot names (style.css hides the developer's header,
// log and tick numbers under `body[data-participant]`); a countdown of the trial's time;
// a plain sentence for an action the robot cannot do; the experimenter's pause and the
// end of the task over the map.
//
// The countdown is worked out from the match's ticks, so it stops while the match is
// paused and never runs ahead of the match: the time left is the tick limit
// (`welcome.match.max_ticks`, which the study sets to time_limit_s * tick_hz) less the
// latest tick, over the tick rate. The embedded hello asks for a `percepts` every tick
// (app.js), so the latest tick is the match's.

import { $, params, setText } from './dom.js';
import { embedded } from './embed.js';

/** The study's participant layout: the player view embedded by the study page. */
export const participant = embedded && params.get('embed') === 'study';

/** Plain sentences for the acks a participant's own action can get (the rest say
 * nothing: they are not the participant's doing). */
const REFUSALS = {
  not_at_block: 'You cannot pick that up: your robot is not at a block. Go to the block first.',
  already_holding: 'You cannot pick that up: you are already holding a block.',
  not_holding: 'You cannot put anything down: you are not holding a block.',
  no_space: 'There is no room to put the block down here.',
  block_not_visible: 'That block is not in the room you are in.',
  unknown_block: 'That block is gone.',
  unreachable: 'Your robot cannot get there from here.',
  rate_limited: 'Slow down a little: too many orders at once.',
};

/** How long a plain sentence about a refused action stays. */
const FEEDBACK_MS = 4000;

const clock = { maxTicks: null, tickHz: null, tick: 0 };
let feedbackTimer = null;

/** Marks the page as the participant's (style.css lays it out from this). */
export function setupParticipant() {
  if (!participant) return;
  document.body.dataset.participant = 'true';
  document.title = 'Task';
  showCountdown();
}

/** The match's settings (`welcome.match`): the countdown's limit and rate. */
export function setClockOf(match) {
  clock.maxTicks = Number.isFinite(match?.max_ticks) ? match.max_ticks : null;
  clock.tickHz = match?.tick_hz || null;
  showCountdown();
}

/** The latest tick of the match: the countdown follows it. */
export function setClockTick(tick) {
  clock.tick = tick;
  showCountdown();
}

/** Seconds left in the trial, or null while the limit is not known. */
export function secondsLeft() {
  if (clock.maxTicks === null || !clock.tickHz) return null;
  return Math.max(0, (clock.maxTicks - clock.tick) / clock.tickHz);
}

function showCountdown() {
  if (!participant) return;
  const node = $('#countdown');
  const left = secondsLeft();
  node.hidden = left === null;
  if (left === null) return;
  const whole = Math.ceil(left);
  node.dataset.seconds = String(whole);
  node.classList.toggle('low', whole <= 30);
  setText($('#countdown-time'), `${Math.floor(whole / 60)}:${String(whole % 60).padStart(2, '0')}`);
}

/** A refused action of the participant's (`code`: the ack's): a plain sentence, for a
 * while, if it is one the participant can make sense of. */
export function showRefusalOf(code) {
  const text = REFUSALS[code];
  if (!participant || !text) return;
  const node = $('#feedback');
  node.dataset.code = code;
  setText(node, text);
  node.hidden = false;
  clearTimeout(feedbackTimer);
  feedbackTimer = setTimeout(() => {
    node.hidden = true;
  }, FEEDBACK_MS);
}

/** The server's `pause` (`paused`: true while the operator holds the match). */
export function showPause(paused) {
  const node = $('#paused');
  node.hidden = !paused;
  document.body.dataset.paused = String(paused);
}

/** The match is over: a plain line over the map (the study page then goes on). */
export function showTaskOver() {
  showPause(false);
  const node = $('#task-over');
  node.hidden = false;
}
