// Drawing the map on the canvas.
//
// The canvas shows the map scaled to fit the stage. The still parts (zones, labels,
// walls) are drawn once per size into an offscreen canvas and copied each frame; the
// moving parts (closed doors, blocks, robots, highlights) are drawn on top. The drawing
// loop (app.js) draws only when something changed, so frames arriving 20 times a second
// cost one redraw each however many robots there are.

/** The block colours of the protocol, as drawn. */
const COLOURS = {
  Blue: '#2f66f5',
  Cyan: '#1ccfe0',
  Magenta: '#cf2fcf',
  Orange: '#ff8a1c',
  Red: '#e0262b',
  White: '#ffffff',
  Green: '#22a54a',
  Yellow: '#ffe01a',
  Pink: '#ffa3d2',
};
export const colourCss = (name) => COLOURS[name] || '#8a8a8a';
/** The colours' names (the message menu offers them). */
export const COLOUR_NAMES = Object.keys(COLOURS);

const BLOCK = 1; // blocks 1 x 1
const CHIP = 1.6; // a block the player sees, drawn as a chip in its room
const CHIP_GAP = 0.5;

export class Renderer {
  constructor(canvas, map) {
    this.canvas = canvas;
    this.map = map;
    this.ctx = canvas.getContext('2d');
    this.still = document.createElement('canvas');
    this.scale = 1;
    this.chipBoxes = []; // where the player's block chips were drawn, for clicks
    // The map box the canvas shows, in map units: lets tests click a place by coordinates.
    const { x, y, w, h } = map.bounds;
    canvas.dataset.bounds = [x, y, w, h].join(' ');
    this.resize();
  }

  /** Fits the map into the stage, keeping its proportions and the screen's pixel density.
   * Returns whether the size changed (the picture must then be drawn again). */
  resize() {
    const stage = this.canvas.parentElement;
    const { w, h } = this.map.bounds;
    const availW = Math.max(100, stage.clientWidth - 16);
    const availH = Math.max(100, stage.clientHeight - 16);
    const scale = Math.min(availW / w, availH / h);
    const cssW = Math.floor(w * scale);
    const cssH = Math.floor(h * scale);
    const dpr = window.devicePixelRatio || 1;
    if (this.cssW === cssW && this.cssH === cssH && this.dpr === dpr) return false;
    Object.assign(this, { scale, cssW, cssH, dpr });
    this.canvas.style.width = `${cssW}px`;
    this.canvas.style.height = `${cssH}px`;
    for (const c of [this.canvas, this.still]) {
      c.width = Math.round(cssW * dpr);
      c.height = Math.round(cssH * dpr);
    }
    this.drawStill();
    return true;
  }

  /** Map units to canvas pixels: the transform every drawing call works under. */
  toMapTransform(ctx) {
    const k = this.scale * this.dpr;
    ctx.setTransform(k, 0, 0, k, -this.map.bounds.x * k, -this.map.bounds.y * k);
  }

  /** A mouse event's position in map units. */
  eventToMap(event) {
    const rect = this.canvas.getBoundingClientRect();
    return {
      x: (event.clientX - rect.left) / this.scale + this.map.bounds.x,
      y: (event.clientY - rect.top) / this.scale + this.map.bounds.y,
    };
  }

  /** A font size in map units that stays readable: between 9 and 14 screen pixels. */
  fontUnits(pixels) {
    return Math.min(14, Math.max(9, pixels)) / this.scale;
  }

  drawStill() {
    const ctx = this.still.getContext('2d');
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.still.width, this.still.height);
    this.toMapTransform(ctx);
    const unit = 1 / this.scale; // one screen pixel in map units
    ctx.fillStyle = '#1d2126';
    const b = this.map.bounds;
    ctx.fillRect(b.x, b.y, b.w, b.h);
    for (const z of this.map.zones) {
      ctx.fillStyle = zoneFill(z);
      ctx.fillRect(z.x, z.y, z.w, z.h);
      if (z.kind === 'blockade') {
        // Hatched: never entered.
        ctx.save();
        ctx.beginPath();
        ctx.rect(z.x, z.y, z.w, z.h);
        ctx.clip();
        ctx.strokeStyle = '#6d5f52';
        ctx.lineWidth = 2 * unit;
        for (let d = -z.h; d < z.w; d += 1.5) {
          ctx.beginPath();
          ctx.moveTo(z.x + d, z.y + z.h);
          ctx.lineTo(z.x + d + z.h, z.y);
          ctx.stroke();
        }
        ctx.restore();
      }
      // Faint borders between halls, so the places one can go to are visible.
      ctx.strokeStyle = 'rgba(0,0,0,0.12)';
      ctx.lineWidth = unit;
      ctx.strokeRect(z.x, z.y, z.w, z.h);
    }
    // Spawn points: small crosses.
    ctx.strokeStyle = 'rgba(0,0,0,0.25)';
    ctx.lineWidth = unit;
    for (const [x, y] of this.map.spawns) {
      ctx.beginPath();
      ctx.moveTo(x - 0.4, y);
      ctx.lineTo(x + 0.4, y);
      ctx.moveTo(x, y - 0.4);
      ctx.lineTo(x, y + 0.4);
      ctx.stroke();
    }
    // Walls.
    ctx.strokeStyle = '#30343a';
    ctx.lineWidth = Math.max(0.3, 3 * unit);
    ctx.lineCap = 'square';
    for (const [x1, y1, x2, y2] of this.map.walls) {
      ctx.beginPath();
      ctx.moveTo(x1, y1);
      ctx.lineTo(x2, y2);
      ctx.stroke();
    }
    // Labels: rooms at their top-left, halls faint at their centre.
    const size = this.fontUnits(this.scale * 1.1);
    ctx.textBaseline = 'top';
    for (const z of this.map.zones) {
      if (z.w < size * 3) continue;
      ctx.font = `${z.isRoom ? '600 ' : ''}${size}px system-ui, sans-serif`;
      if (z.isRoom) {
        ctx.fillStyle = z.isDrop ? '#5a4300' : '#3b3f45';
        ctx.textAlign = 'left';
        ctx.fillText(z.name, z.x + 0.5, z.y + 0.5, z.w - 1);
      } else {
        ctx.fillStyle = 'rgba(0,0,0,0.35)';
        ctx.textAlign = 'center';
        ctx.fillText(z.name, z.x + z.w / 2, z.y + z.h / 2 - size / 2, z.w - 0.5);
      }
    }
  }

  /** Draws one picture. `scene`: {occupied: Set, blocks, robots, at, inRoom, me, chips,
   * atBlock, holdingColor, hover}; see spectatorScene (spectator.js) and playerScene
   * (player.js). */
  draw(scene) {
    const ctx = this.ctx;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    ctx.drawImage(this.still, 0, 0);
    this.toMapTransform(ctx);
    const unit = 1 / this.scale;

    if (scene.hover) {
      const z = scene.hover;
      ctx.fillStyle = 'rgba(255,255,255,0.18)';
      ctx.fillRect(z.x, z.y, z.w, z.h);
    }
    if (scene.at) {
      // The player's place: the only position a player knows.
      const z = scene.at;
      ctx.fillStyle = 'rgba(40,140,255,0.28)';
      ctx.fillRect(z.x, z.y, z.w, z.h);
      ctx.strokeStyle = '#1f7ae0';
      ctx.lineWidth = 3 * unit;
      ctx.strokeRect(z.x + 1.5 * unit, z.y + 1.5 * unit, z.w - 3 * unit, z.h - 3 * unit);
    }
    // The place's label names the player (not in the participant view: its robot is "you").
    if (scene.at && !scene.self && scene.placeLabel !== false) {
      const z = scene.at;
      const size = this.fontUnits(this.scale * 1.2);
      ctx.font = `600 ${size}px system-ui, sans-serif`;
      ctx.textAlign = 'right';
      ctx.textBaseline = 'bottom';
      ctx.fillStyle = '#0b4fa0';
      const text = `▶ ${scene.me || 'you'}`;
      const right = z.x + z.w - 0.4;
      ctx.fillText(text, right, z.y + z.h - 0.3, z.w - 0.8);
      if (scene.holdingColor) {
        // What it carries, as a block beside its name.
        const w = Math.min(ctx.measureText(text).width, z.w - 0.8);
        ctx.fillStyle = colourCss(scene.holdingColor);
        ctx.fillRect(right - w - BLOCK - 0.3, z.y + z.h - 0.3 - size * 0.9, BLOCK, BLOCK);
        ctx.strokeStyle = 'rgba(0,0,0,0.6)';
        ctx.lineWidth = unit;
        ctx.strokeRect(right - w - BLOCK - 0.3, z.y + z.h - 0.3 - size * 0.9, BLOCK, BLOCK);
      }
    }

    // Doors: a bar across the opening while the room is occupied (closed for everyone
    // else), a thin dashed line while it is free.
    for (const [room, lines] of this.map.openings) {
      const closed = scene.occupied.has(room);
      ctx.strokeStyle = closed ? '#d8342c' : 'rgba(60,64,70,0.45)';
      ctx.lineWidth = closed ? Math.max(0.35, 5 * unit) : unit;
      ctx.setLineDash(closed ? [] : [3 * unit, 3 * unit]);
      for (const [x1, y1, x2, y2] of lines) {
        ctx.beginPath();
        ctx.moveTo(x1, y1);
        ctx.lineTo(x2, y2);
        ctx.stroke();
      }
    }
    ctx.setLineDash([]);

    // Blocks lying in rooms (held ones are drawn on their robot).
    ctx.lineWidth = unit;
    for (const b of scene.blocks || []) {
      if (b.held_by !== undefined && b.held_by !== null) continue;
      ctx.fillStyle = colourCss(b.color);
      ctx.fillRect(b.x - BLOCK / 2, b.y - BLOCK / 2, BLOCK, BLOCK);
      ctx.strokeStyle = 'rgba(0,0,0,0.55)';
      ctx.strokeRect(b.x - BLOCK / 2, b.y - BLOCK / 2, BLOCK, BLOCK);
    }

    // The player's view of blocks: chips in the room it is in.
    this.chipBoxes = [];
    if (scene.inRoom && scene.chips?.length) this.drawChips(ctx, scene.inRoom, scene.chips, scene.atBlock);

    // Robots: squares of the layout's size, the held block's colour inside, the name above.
    const robot = this.map.robot;
    const label = this.fontUnits(this.scale * 1.0);
    ctx.font = `600 ${label}px system-ui, sans-serif`;
    ctx.textAlign = 'center';
    ctx.textBaseline = 'bottom';
    for (const r of scene.robots || []) {
      const x = r.x - robot / 2;
      const y = r.y - robot / 2;
      ctx.fillStyle = '#2a2f36';
      ctx.fillRect(x, y, robot, robot);
      if (r.holdingColor) {
        ctx.fillStyle = colourCss(r.holdingColor);
        ctx.fillRect(r.x - 0.55, r.y - 0.55, 1.1, 1.1);
      }
      ctx.strokeStyle = r.state === 'collided' ? '#ff3b30' : r.state === 'traveling' ? '#ffffff' : '#9aa3ad';
      ctx.lineWidth = 2 * unit;
      ctx.strokeRect(x, y, robot, robot);
      const w = ctx.measureText(r.name).width;
      ctx.fillStyle = 'rgba(20,22,26,0.7)';
      ctx.fillRect(r.x - w / 2 - 2 * unit, y - label - 2 * unit, w + 4 * unit, label + 2 * unit);
      ctx.fillStyle = '#ffffff';
      ctx.fillText(r.name, r.x, y - unit);
    }
    if (scene.self) this.drawSelf(ctx, scene.self);
  }

  /** The participant's own robot where glide.js puts it (`self`: {x, y, holdingColor,
   * traveling}): a disc with what it holds inside, ringed while it travels, named "you". */
  drawSelf(ctx, self) {
    const unit = 1 / this.scale;
    const radius = Math.max(this.map.robot * 0.75, 7 * unit);
    ctx.beginPath();
    ctx.arc(self.x, self.y, radius, 0, 2 * Math.PI);
    ctx.fillStyle = '#1f6fd1';
    ctx.fill();
    ctx.lineWidth = (self.traveling ? 3 : 1.5) * unit;
    ctx.strokeStyle = self.traveling ? '#ffffff' : '#0b3a78';
    ctx.stroke();
    if (self.holdingColor) {
      const side = radius * 1.1;
      ctx.fillStyle = colourCss(self.holdingColor);
      ctx.fillRect(self.x - side / 2, self.y - side / 2, side, side);
      ctx.strokeStyle = 'rgba(0,0,0,0.6)';
      ctx.lineWidth = unit;
      ctx.strokeRect(self.x - side / 2, self.y - side / 2, side, side);
    }
    const size = this.fontUnits(this.scale * 1.2);
    ctx.font = `700 ${size}px system-ui, sans-serif`;
    ctx.textAlign = 'center';
    ctx.textBaseline = 'bottom';
    const w = ctx.measureText('you').width;
    ctx.fillStyle = 'rgba(255,255,255,0.85)';
    ctx.fillRect(self.x - w / 2 - 2 * unit, self.y - radius - size - 3 * unit, w + 4 * unit, size + 2 * unit);
    ctx.fillStyle = '#0b3a78';
    ctx.fillText('you', self.x, self.y - radius - 2 * unit);
  }

  /** The blocks a player sees in its room. Their positions are not in the percepts, so
   * they are laid out as a grid of chips; the grid is clickable (goToBlock). */
  drawChips(ctx, room, chips, atBlock) {
    const unit = 1 / this.scale;
    const top = room.y + 0.6 + this.fontUnits(this.scale * 1.1) + 0.4;
    const cols = Math.max(1, Math.floor((room.w - CHIP_GAP) / (CHIP + CHIP_GAP)));
    const size = this.fontUnits(this.scale * 0.8);
    ctx.font = `600 ${size}px system-ui, sans-serif`;
    ctx.textAlign = 'center';
    ctx.textBaseline = 'middle';
    chips.forEach((chip, i) => {
      const x = room.x + CHIP_GAP + (i % cols) * (CHIP + CHIP_GAP);
      const y = top + Math.floor(i / cols) * (CHIP + CHIP_GAP);
      ctx.fillStyle = colourCss(chip.color);
      ctx.fillRect(x, y, CHIP, CHIP);
      ctx.strokeStyle = chip.id === atBlock ? '#1f7ae0' : 'rgba(0,0,0,0.6)';
      ctx.lineWidth = (chip.id === atBlock ? 4 : 1) * unit;
      ctx.strokeRect(x, y, CHIP, CHIP);
      if (CHIP * this.scale >= 18) {
        ctx.fillStyle = chip.color === 'Blue' || chip.color === 'Magenta' ? '#fff' : '#111';
        ctx.fillText(String(chip.id), x + CHIP / 2, y + CHIP / 2, CHIP);
      }
      this.chipBoxes.push({ id: chip.id, x, y, w: CHIP, h: CHIP });
    });
  }

  chipAt(x, y) {
    return this.chipBoxes.find((c) => x >= c.x && x < c.x + c.w && y >= c.y && y < c.y + c.h) || null;
  }
}

function zoneFill(z) {
  if (z.isDrop) return '#f3d77a';
  switch (z.kind) {
    case 'room':
      return '#e9e4d8';
    case 'charging':
      return '#bfe3c4';
    case 'blockade':
      return '#8c7b6b';
    default:
      return '#c9ced6';
  }
}


/**
 * The blocks a robot sees, from its `color` facts, in id order.
 * @param {import('./client/beliefs.js').Beliefs} beliefs
 */
export function visibleBlocks(beliefs) {
  return beliefs
    .all('color')
    .map(([id, color]) => ({ id, color }))
    .sort((a, b) => a.id - b.id);
}

/**
 * The scene of the map as one robot perceives it (its place, its room, the blocks it sees
 * as chips, the occupied rooms, what it holds): what the player view draws, and the
 * replay's view of one player.
 * @param {import('./client/beliefs.js').Beliefs} beliefs the robot's facts
 * @param {{byName: Map<string, object>}} map the page's map
 * @param {string} me the player's name
 * @param {string|null} holdingColor the colour of the block held, if any
 */
export function perceivedScene(beliefs, map, me, holdingColor) {
  return {
    occupied: new Set(beliefs.all('occupied').map(([room]) => room)),
    at: map.byName.get(beliefs.get('at')) || null,
    inRoom: map.byName.get(beliefs.get('in')) || null,
    chips: visibleBlocks(beliefs),
    atBlock: beliefs.get('atBlock'),
    holdingColor,
    me,
    hover: null,
  };
}
