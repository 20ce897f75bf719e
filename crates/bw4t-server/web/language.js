// The message language players share (protocol/schema/language.json, served at
// /language.json): every kind with its group, its slots and its English sentence. The menu
// composes messages from it and the chat renders their sentences from it, so the page has
// one table of both, the server's.

import { fetchJSON } from './dom.js';

/** The groups, in the menu's order, and how the menu names them. */
export const GROUPS = [
  ['rooms', 'Rooms'],
  ['blocks', 'Blocks'],
  ['requests', 'Requests'],
  ['answers', 'Answers'],
];

export const language = {
  kinds: [], // [{kind, group, slots, sentence}] in the table's order
  byKind: new Map(),
  loaded: null, // the promise of the table
};

/** Fetches the table once (later calls share the first). */
export function loadLanguage() {
  if (!language.loaded) {
    language.loaded = fetchJSON('/language.json').then((table) => {
      language.kinds = table.kinds || [];
      language.byKind = new Map(language.kinds.map((row) => [row.kind, row]));
      return language;
    });
  }
  return language.loaded;
}

/** A slot's value as a sentence shows it: positions count from 1 there (0 on the wire). */
function shown(slot, value) {
  if (slot === 'position') return String(Number(value) + 1);
  return String(value);
}

/** The sentence of a structured message, or null when the kind is unknown or a slot is
 * missing (`partial`: missing slots are shown as `…`, for the menu's preview). */
export function sentenceOf(said, { partial = false } = {}) {
  const row = said && language.byKind.get(said.kind);
  if (!row) return null;
  let text = row.sentence;
  for (const slot of row.slots) {
    const value = said[slot];
    if (value === undefined || value === null || value === '') {
      if (!partial) return null;
      text = text.replace(`{${slot}}`, '…');
    } else {
      text = text.replace(`{${slot}}`, shown(slot, value));
    }
  }
  return text;
}

/** The structured message a text stands for, if it is the text form a match carries
 * (the compact JSON of a message of the language), else null. */
export function saidOfText(text) {
  if (typeof text !== 'string' || !text.startsWith('{')) return null;
  try {
    const said = JSON.parse(text);
    return said && typeof said.kind === 'string' && language.byKind.has(said.kind) ? said : null;
  } catch {
    return null;
  }
}

/**
 * What the chat shows for a message: `{sentence, said}`. A structured message is shown as
 * its sentence (rendered from the table; the server's `sentence` if the table does not know
 * the kind); free text as it is.
 */
export function chatLine(text, said = null) {
  const structured = said || saidOfText(text);
  if (!structured) return { sentence: text, said: null };
  return { sentence: sentenceOf(structured) || text, said: structured };
}
