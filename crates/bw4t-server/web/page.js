// What the page is showing: one state object, so that the drawing loop and the panels
// read the same state whatever the view, the switch between views, and the map shown.

import { $, fetchJSON, setText } from './dom.js';
import { buildMap } from './geometry.js';
import { Renderer } from './renderer.js';

export const page = {
  view: 'loading', // 'lobby' | 'spectator' | 'player' | 'replay'
  lobby: false, // the server hosts many matches (`/info.json` says `"lobby": true`)
  overview: false, // the player sees the whole map too (embedded with `view=overview`)
  matchName: null, // the match shown, by name: `?match=` or `welcome.match.name` (lobby servers only)
  map: null, // the geometry (geometry.js)
  renderer: null, // the Renderer (renderer.js)
  match: null, // welcome.match
  ended: false,
  hover: null, // the zone under the mouse
  dirty: true, // the canvas needs a redraw
  frames: 0, // frames received (live) or shown (replay)
  draws: 0, // pictures drawn
  drawMs: 0, // time spent drawing them
};

/** Shows one view: the elements marked `data-views` for it, and none of the others. */
export function setView(view) {
  page.view = view;
  document.body.dataset.view = view;
  for (const node of document.querySelectorAll('[data-views]')) {
    node.hidden = !node.dataset.views.split(' ').includes(view);
  }
  page.renderer?.resize();
  page.dirty = true;
}

/** Fetches a match's map (`/map.json?match=NAME`; the default match's without a name) and
 * draws it from now on. */
export async function loadMap(matchName, fallbackName = '?') {
  const url = matchName ? `/map.json?match=${encodeURIComponent(matchName)}` : '/map.json';
  const json = await fetchJSON(url);
  page.map = buildMap(json);
  setText($('#map-name'), json.name || fallbackName);
  const canvas = $('#map');
  canvas.hidden = false;
  page.renderer = new Renderer(canvas, page.map);
  page.dirty = true;
}
