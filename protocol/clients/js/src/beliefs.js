// The belief base: the facts a player holds, kept from `percepts` deltas exactly as
// protocol/README.md ("Keeping the state") describes. No Node imports: the browser page
// keeps its player's beliefs with this same file.

import { EVENTS, SINGLE_VALUED } from './table.js';

/**
 * A fact (percept) as it travels on the wire: `[name, ...args]`,
 * e.g. `["in", "RoomA1"]` or `["color", 11, "Yellow"]`.
 * @typedef {[string, ...any[]]} Fact
 */

/**
 * A `message` event taken out of a `percepts`' `add`.
 * @typedef {object} ChatMessage
 * @property {string} from the sender's name
 * @property {string} text the text; for a message of the shared language, its sentence
 * @property {object} [said] a message of the shared language: `{kind, room?, colour?,
 *   player?, count?, position?}` (see `protocol/schema/language.json`)
 */

/** @param {Fact} fact */
function keyOf(fact) {
  return JSON.stringify(fact);
}

/**
 * Deep equality of two JSON values (arguments of facts: strings, numbers, arrays).
 * @param {any} a
 * @param {any} b
 */
function sameValue(a, b) {
  if (a === b) return true;
  if (Array.isArray(a) && Array.isArray(b)) {
    return a.length === b.length && a.every((x, i) => sameValue(x, b[i]));
  }
  return false;
}

/**
 * The facts the robot holds now. Facts are stored by name; each name maps to a set of
 * facts (one at most for the single-valued ones).
 */
export class Beliefs {
  /** @type {Map<string, Map<string, Fact>>} name -> (fact key -> fact) */
  #byName = new Map();

  /**
   * Block id -> colour, from every `color` fact ever applied. A block's colour never
   * changes, and a player may remember what it was told: so the colour of a block out of
   * sight, or held, is still known.
   * @type {Map<number, string>}
   */
  #colours = new Map();

  /** The tick of the last `percepts` applied, or `null` before the first one. */
  tick = /** @type {number | null} */ (null);

  /**
   * Apply one `percepts` message: if `full`, clear everything; remove every fact in
   * `not`; then for each fact in `add`: a `message` is an event (returned, not stored),
   * an on-change fact replaces the stored fact of the same name, anything else is
   * stored.
   * @param {{tick: number, add?: Fact[], not?: Fact[], full?: boolean}} percepts
   * @returns {ChatMessage[]} the `message` events of this delta, oldest first
   */
  apply(percepts) {
    if (percepts.full) this.#byName.clear();
    for (const fact of percepts.not ?? []) {
      const facts = this.#byName.get(fact[0]);
      if (facts) {
        facts.delete(keyOf(fact));
        if (facts.size === 0) this.#byName.delete(fact[0]);
      }
    }
    /** @type {ChatMessage[]} */
    const messages = [];
    for (const fact of percepts.add ?? []) {
      const name = fact[0];
      if (EVENTS.has(name)) {
        messages.push(fact.length > 3 ? { from: fact[1], text: fact[2], said: fact[3] } : { from: fact[1], text: fact[2] });
        continue;
      }
      if (name === 'color') this.#colours.set(fact[1], fact[2]);
      let facts = this.#byName.get(name);
      if (!facts) {
        facts = new Map();
        this.#byName.set(name, facts);
      } else if (SINGLE_VALUED.has(name)) {
        facts.clear();
      }
      facts.set(keyOf(fact), fact);
    }
    this.tick = percepts.tick;
    return messages;
  }

  /** Forget everything, remembered colours included. */
  clear() {
    this.#byName.clear();
    this.#colours.clear();
    this.tick = null;
  }

  /**
   * The colour of a block as last perceived (a `color` fact), whether or not that fact
   * still holds: `undefined` for a block never seen. Full snapshots keep these (the
   * colours are facts of the match), `clear()` forgets them.
   * @param {number} block
   * @returns {string | undefined}
   */
  colourOf(block) {
    return this.#colours.get(block);
  }

  /**
   * Whether a fact with this name holds whose first arguments are `args`
   * (all of them, or a prefix: `holds("color", 11)` is true if block 11 has any colour).
   * @param {string} name
   * @param {...any} args
   * @returns {boolean}
   */
  holds(name, ...args) {
    const facts = this.#byName.get(name);
    if (!facts) return false;
    if (args.length === 0) return facts.size > 0;
    for (const fact of facts.values()) {
      if (args.every((arg, i) => sameValue(arg, fact[i + 1]))) return true;
    }
    return false;
  }

  /**
   * The arguments of every fact with this name, in the order they were stored,
   * e.g. `all("color")` -> `[[11, "Yellow"], [12, "Blue"]]`.
   * @param {string} name
   * @returns {any[][]}
   */
  all(name) {
    const facts = this.#byName.get(name);
    return facts ? [...facts.values()].map((fact) => fact.slice(1)) : [];
  }

  /**
   * The value of a fact with this name: its argument when it has one
   * (`get("at")` -> `"RoomC1"`, `get("sequence")` -> `["Yellow", ...]`), the array of
   * its arguments when it has several, `undefined` when none holds. Meant for
   * single-valued facts (`at`, `state`, `sequenceIndex`, `ownName`, `bot`,
   * `sequence`, and `in`, `holding`, `atBlock`, which hold for one value at most).
   * @param {string} name
   * @returns {any}
   */
  get(name) {
    const facts = this.#byName.get(name);
    if (!facts || facts.size === 0) return undefined;
    const args = facts.values().next().value.slice(1);
    return args.length === 1 ? args[0] : args;
  }

  /**
   * Every fact held, as `[name, ...args]` arrays.
   * @returns {Fact[]}
   */
  facts() {
    /** @type {Fact[]} */
    const out = [];
    for (const facts of this.#byName.values()) {
      for (const fact of facts.values()) out.push(/** @type {Fact} */ ([...fact]));
    }
    return out;
  }

  /** How many facts are held. */
  get size() {
    let n = 0;
    for (const facts of this.#byName.values()) n += facts.size;
    return n;
  }

  /**
   * An independent copy, remembered colours included.
   * @returns {Beliefs}
   */
  clone() {
    const copy = new Beliefs();
    copy.#colours = new Map(this.#colours);
    copy.apply({ tick: this.tick ?? 0, add: this.facts(), not: [], full: true });
    copy.tick = this.tick;
    return copy;
  }

  /**
   * What differs from `other`: facts only here (`extra`) and facts only there
   * (`missing`), each sorted.
   * @param {Beliefs} other
   * @returns {{extra: Fact[], missing: Fact[]}}
   */
  diff(other) {
    const mine = new Map(this.facts().map((f) => [keyOf(f), f]));
    const theirs = new Map(other.facts().map((f) => [keyOf(f), f]));
    const extra = [...mine.keys()].filter((k) => !theirs.has(k)).sort();
    const missing = [...theirs.keys()].filter((k) => !mine.has(k)).sort();
    return {
      extra: extra.map((k) => /** @type {Fact} */ (mine.get(k))),
      missing: missing.map((k) => /** @type {Fact} */ (theirs.get(k))),
    };
  }

  /**
   * Whether both hold exactly the same facts (the tick is not compared).
   * @param {Beliefs} other
   */
  equals(other) {
    const d = this.diff(other);
    return d.extra.length === 0 && d.missing.length === 0;
  }

  /** The facts, sorted, for JSON.stringify and logs. */
  toJSON() {
    return this.facts()
      .map((f) => [keyOf(f), f])
      .sort((a, b) => (a[0] < b[0] ? -1 : a[0] > b[0] ? 1 : 0))
      .map((p) => p[1]);
  }
}
