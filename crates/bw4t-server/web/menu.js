// The message menu of the player view: a message of the shared language is composed by
// choosing its kind (grouped as the language's table groups them), then its arguments (a
// room from the map's places, a colour, a player, a count, a sequence position), and its
// receiver; the sentence shows as it is composed, and Send says it. Only the kinds the
// match allows are offered (`welcome.match.language`), and the free-text box only if the
// match allows free text. Every control is a form field, so Tab, the arrow keys and Enter
// work; the key M (outside a field) puts the focus on the kind.

import { $, el, setText } from './dom.js';
import { page } from './page.js';
import { COLOUR_NAMES } from './renderer.js';
import { GROUPS, language, loadLanguage, sentenceOf } from './language.js';

const SLOT_LABELS = { room: 'room', colour: 'colour', player: 'player', count: 'count', position: 'position' };

const menu = {
  allowed: null, // the kinds' words the match allows (null: all)
  freeText: true,
  onSend: null, // (to, said, input) => void
  slotsFor: '', // the kind the slot controls are for
  enterAt: null, // when Enter was pressed in the form, if it was the last key there
  options: { rooms: [], colours: [], players: [], sequence: [] }, // what the slots offer
};

/** The kind chosen, or null. */
function chosenRow() {
  return language.byKind.get($('#menu-kind').value) || null;
}

/** The message as composed so far: the kind and the slots given. */
function composed() {
  const row = chosenRow();
  if (!row) return null;
  const said = { kind: row.kind };
  for (const slot of row.slots) {
    const input = $(`#menu-slot-${slot}`);
    const raw = input ? input.value : '';
    if (raw === '') continue;
    said[slot] = slot === 'count' || slot === 'position' ? Number(raw) : raw;
  }
  return said;
}

/** Complete: every slot has a valid value. */
function complete(said) {
  const row = said && language.byKind.get(said.kind);
  if (!row) return false;
  return row.slots.every((slot) => {
    const value = said[slot];
    if (value === undefined || value === '') return false;
    if (slot === 'count') return Number.isInteger(value) && value >= 1;
    if (slot === 'position') return Number.isInteger(value) && value >= 0;
    return true;
  });
}

/** Shows the sentence of what is composed, and whether it can be sent. */
function preview() {
  const said = composed();
  const node = $('#menu-preview');
  const ready = complete(said);
  node.dataset.complete = String(ready);
  setText(node, said ? sentenceOf(said, { partial: true }) : '');
  $('#menu-send').disabled = !ready || !menu.onSend;
}

/** The options of one select, keeping the choice if it is still offered. */
function fillSelect(select, values, labels = values) {
  const key = values.join('\u0001') + '\u0002' + labels.join('\u0001');
  if (select.dataset.key === key) return;
  select.dataset.key = key;
  const chosen = select.value;
  select.replaceChildren(el('option', { value: '' }, '–'), ...values.map((v, i) => el('option', { value: String(v) }, labels[i])));
  select.value = values.map(String).includes(chosen) ? chosen : '';
}

/** The controls for the chosen kind's slots, in the order of its sentence. */
function buildSlots() {
  const row = chosenRow();
  // The same kind again (chosen anew, or the kinds rebuilt): keep what was chosen.
  if ((row?.kind ?? '') === menu.slotsFor) return preview();
  menu.slotsFor = row?.kind ?? '';
  const box = $('#menu-slots');
  box.replaceChildren();
  if (!row) return preview();
  for (const slot of row.slots) {
    let input;
    if (slot === 'count') {
      input = el('input', { id: `menu-slot-${slot}`, type: 'number', min: '1', step: '1', value: '1' });
    } else {
      input = el('select', { id: `menu-slot-${slot}` });
    }
    input.dataset.slot = slot;
    input.addEventListener('input', preview);
    input.addEventListener('change', preview);
    box.append(el('label', { class: 'slot' }, `${SLOT_LABELS[slot]} `, input));
  }
  fillSlots();
  // A request to one player: that player is the one the message goes to.
  const to = $('#chat-to').value;
  const who = $('#menu-slot-player');
  if (who && to !== 'all' && menu.options.players.includes(to)) who.value = to;
  preview();
}

/** The slots' choices from what the view knows now. */
function fillSlots() {
  const o = menu.options;
  const room = $('#menu-slot-room');
  if (room) fillSelect(room, o.rooms);
  const colour = $('#menu-slot-colour');
  if (colour) fillSelect(colour, o.colours);
  const who = $('#menu-slot-player');
  if (who) fillSelect(who, o.players);
  const position = $('#menu-slot-position');
  if (position) {
    fillSelect(
      position,
      o.sequence.map((_, i) => i),
      o.sequence.map((c, i) => `${i + 1} (${c})`),
    );
  }
}

/** The kinds offered, grouped as the table groups them (only the allowed ones). */
function buildKinds() {
  const select = $('#menu-kind');
  const chosen = select.value;
  const groups = [];
  for (const [group, label] of GROUPS) {
    const rows = language.kinds.filter((row) => row.group === group && (!menu.allowed || menu.allowed.includes(row.kind)));
    if (rows.length === 0) continue;
    groups.push(
      el(
        'optgroup',
        { label, dataset: { group } },
        ...rows.map((row) => el('option', { value: row.kind, dataset: { group } }, sentenceOf(row, { partial: true }) || row.kind)),
      ),
    );
  }
  select.replaceChildren(el('option', { value: '' }, 'choose a message…'), ...groups);
  select.value = [...select.options].some((o) => o.value === chosen) ? chosen : '';
  $('#menu-form').dataset.kinds = String(select.options.length - 1);
  buildSlots();
}

/** Sets the match's message policy (`welcome.match.language`; all kinds and free text
 * when the server does not say). */
export async function setMessagePolicy(policy) {
  menu.allowed = Array.isArray(policy?.kinds) ? policy.kinds : null;
  menu.freeText = policy?.free_text !== false;
  $('#chat-form').hidden = !menu.freeText;
  try {
    await loadLanguage();
  } catch (err) {
    console.warn('bw4t: no message language', err);
  }
  buildKinds();
}

/** What the slots offer: the map's rooms (its places without one), the colours, the other
 * players, the sequence. */
export function setMenuOptions({ places = [], players = [], sequence = [] }) {
  const rooms = page.map ? page.map.zones.filter((z) => z.isRoom).map((z) => z.name) : [];
  const colours = [...COLOUR_NAMES];
  for (const c of sequence) if (!colours.includes(c)) colours.push(c);
  menu.options = { rooms: rooms.length ? rooms : places, colours, players, sequence };
  fillSlots();
  preview();
}

/** Wires the menu: `onSend(to, said, input)` says a composed message. */
export function setupMenu(onSend) {
  menu.onSend = onSend;
  $('#menu-kind').addEventListener('change', buildSlots);
  $('#chat-to').addEventListener('change', () => {
    const who = $('#menu-slot-player');
    const to = $('#chat-to').value;
    if (who && to !== 'all' && menu.options.players.includes(to)) who.value = to;
    preview();
  });
  $('#menu-form').addEventListener('submit', (event) => {
    event.preventDefault();
    const said = composed();
    if (!complete(said)) return;
    const input = menu.enterAt !== null ? { kind: 'key', key: 'Enter', at: menu.enterAt } : { kind: 'click', target: 'menu-send', at: event.timeStamp };
    menu.enterAt = null;
    menu.onSend($('#chat-to').value, said, input);
  });
  // Enter in a field sends too: remembered so that the send is logged as a key.
  $('#menu-form').addEventListener('keydown', (event) => {
    menu.enterAt = event.key === 'Enter' ? event.timeStamp : null;
  });
  $('#menu-form').addEventListener('pointerdown', () => {
    menu.enterAt = null;
  });
  document.addEventListener('keydown', (event) => {
    if (page.view !== 'player' || event.ctrlKey || event.metaKey || event.altKey) return;
    if (event.target.closest?.('input, textarea, select')) return;
    if (event.key.toLowerCase() !== 'm') return;
    event.preventDefault();
    $('#menu-kind').focus();
  });
  preview();
}
