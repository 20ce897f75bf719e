// What the protocol's table of percepts and actions (protocol/schema/table.json) tells a
// client to treat specially. Kept free of Node imports, like beliefs.js: the browser page
// imports both as they are (the server serves them at /client/).

/**
 * The on-change facts: single-valued, a new one replaces the stored one of the same
 * name, and they never appear in `not`.
 * @type {ReadonlySet<string>}
 */
export const SINGLE_VALUED = new Set(['at', 'state', 'sequenceIndex']);

/**
 * Facts that are events: delivered once in `add`, never stored.
 * @type {ReadonlySet<string>}
 */
export const EVENTS = new Set(['message']);

/**
 * Actions whose order ends later with a `result`.
 * @type {ReadonlySet<string>}
 */
export const DURATIVE = new Set(['goTo', 'goToBlock']);
