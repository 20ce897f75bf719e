// The bw4t browser page: the matches of a server and three views of a match, as ES
// modules the browser loads itself (no build step, no dependencies, no external URLs).
//
//   lobby      the server's matches and templates, to watch or join (at / on a server of
//              many matches, `/info.json` saying `"lobby": true`);
//   spectator  the whole map as the server's `frame`s show it (the default when live;
//              `?match=NAME` picks the match);
//   player     a human drives one robot and sees only what its percepts say;
//   replay     frames of a recorded match fetched from /replay/frame/T, with play and seek.
//
// Messages of the shared language are shown as sentences from /language.json; the study
// page (study.html) embeds the player view in a frame (`?embed=study&hello=JSON`, embed.js).
//
// It speaks protocol/PROTOCOL.md over a WebSocket at /ws (one JSON message per text
// frame) and reads /info.json, /map.json, /api/matches (the lobby) and, for replays,
// /replay.json. This module starts the page and runs the drawing loop; the others are
//   dom.js · page.js (the state shown) · geometry.js · renderer.js · panels.js ·
//   connection.js · waiting.js · lobby.js · spectator.js · player.js · replay.js ·
//   language.js · menu.js · embed.js · participant.js · glide.js,
// and the JavaScript client's belief base, served from protocol/clients/js/src at
// /client/beliefs.js and /client/table.js.

import { $, fetchJSON, linkTo, params, setText } from './dom.js';
import { loadMap, page } from './page.js';
import { zoneAt } from './geometry.js';
import { setStatus } from './panels.js';
import { showRefusal } from './waiting.js';
import { startLobby } from './lobby.js';
import { spectatorScene, startSpectator } from './spectator.js';
import { joinAsPlayer, playerScene, setupPlayerControls } from './player.js';
import { replay } from './replay.js';
import { loadLanguage } from './language.js';
import { embeddedHello } from './embed.js';
import { participant, setupParticipant } from './participant.js';
import { glide } from './glide.js';

/** The one drawing loop: redraws when something changed, and lets the replay advance. */
function animate(now) {
  if (page.view === 'replay') replay.step(now);
  // The participant's own robot glides between the places its percepts named.
  if (participant && page.view === 'player' && glide.step(now)) page.dirty = true;
  if (page.dirty && page.renderer) {
    page.dirty = false;
    const started = performance.now();
    const scene = page.view === 'player' ? playerScene() : spectatorScene();
    page.renderer.draw(scene);
    // How many pictures were drawn and the time they took: shown to tests, which check
    // that drawing keeps up with the frames.
    page.draws += 1;
    page.drawMs += performance.now() - started;
    page.renderer.canvas.dataset.draws = String(page.draws);
    page.renderer.canvas.dataset.drawMs = page.drawMs.toFixed(1);
  }
  requestAnimationFrame(animate);
}

// Hovering a place names it (all views) and shows it can be clicked (player view).
function setupHover(canvas) {
  const tip = $('#hover');
  canvas.addEventListener('mousemove', (event) => {
    if (!page.renderer) return;
    const p = page.renderer.eventToMap(event);
    const chip = page.view === 'player' ? page.renderer.chipAt(p.x, p.y) : null;
    const zone = zoneAt(page.map, p.x, p.y);
    if (zone !== page.hover) {
      page.hover = zone;
      page.dirty = true;
    }
    const text = chip ? `block ${chip.id}` : zone ? zone.name : '';
    tip.hidden = !text;
    setText(tip, text);
    const stage = canvas.parentElement.getBoundingClientRect();
    tip.style.left = `${event.clientX - stage.left + 14}px`;
    tip.style.top = `${event.clientY - stage.top + 14}px`;
    canvas.style.cursor = page.view === 'player' && (chip || zone) ? 'pointer' : 'default';
  });
  canvas.addEventListener('mouseleave', () => {
    tip.hidden = true;
    page.hover = null;
    page.dirty = true;
  });
}

/** Reads the server's description, then opens the view the address asks for: the lobby,
 * or a match (its map first, unless a template's seat decides the match). */
async function start() {
  let info;
  // The language's table first, so that the first messages show as sentences (without it
  // they show as the server's sentences).
  const language = loadLanguage().catch((err) => console.warn('bw4t: no /language.json', err));
  try {
    info = await fetchJSON('/info.json');
  } catch (err) {
    setStatus('error', err.message);
    return;
  }
  await language;
  // `?match=` and `?template=` mean something only to a server of many matches.
  page.lobby = info.lobby === true && info.mode !== 'replay';
  if (page.lobby) {
    page.matchName = params.get('match') || null;
    const link = $('#lobby-link');
    link.href = linkTo();
    link.hidden = false;
  }
  const canvas = $('#map');
  new ResizeObserver(() => {
    if (page.renderer?.resize()) page.dirty = true;
  }).observe($('#stage'));
  setupHover(canvas);
  setupPlayerControls(canvas);
  requestAnimationFrame(animate);

  // Embedded by the study page: play with the hello it gives: a template's next match, or
  // (after a reload) the match the trial is in, with this tab's session for it.
  const hello = embeddedHello();
  setupParticipant();
  if (hello) {
    // A player's role is the protocol's default (`agent`); the page sets the rest itself.
    const { name: embeddedName, template, match, type: _t, protocol: _p, versions: _v, role: _r, ...extra } = hello;
    page.lobby = page.lobby || Boolean(template || match);
    if (match) page.matchName = match;
    page.overview = params.get('view') === 'overview';
    document.body.dataset.overview = String(page.overview);
    joinAsPlayer(embeddedName, match ? null : template || null, extra);
    return;
  }

  const name = params.get('play');
  if (page.lobby && !page.matchName && !name) {
    startLobby(info);
    return;
  }
  const template = page.lobby && !page.matchName ? params.get('template') : null;
  if (!(template && name)) {
    try {
      await loadMap(page.matchName, info.map);
    } catch (err) {
      setStatus('error', err.message);
      if (page.matchName) {
        showRefusal(`No map for match ${page.matchName} (${err.message}).`, { href: linkTo(), text: 'Back to the matches' }, 'No such match');
      }
      return;
    }
  }

  if (info.mode === 'replay') {
    try {
      await replay.start();
    } catch (err) {
      setStatus('error', err.message);
    }
    return;
  }
  if (name) joinAsPlayer(name, template);
  else startSpectator();
}

start();
