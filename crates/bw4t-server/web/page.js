// What the page is showing: one state object, so that the drawing loop and the panels
// read the same state whatever the view, and the switch between views.

export const page = {
  view: 'loading', // 'spectator' | 'player' | 'replay'
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
