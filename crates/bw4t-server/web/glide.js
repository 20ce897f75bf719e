// The participant's own robot drawn moving: a player's percepts say only which place the
// robot is at (`at`), so the marker glides from the place it was drawn at to the centre of
// the newest place the percepts named, at the robot's own speed (faster when it is far
// behind). It follows what the player already knows and never runs ahead of it.
//
// `window.bw4tMotion` keeps, for tests and the latency report, the ms from the key or click
// that sent the robot somewhere to the first picture showing it on its way (`reacted`:
// its "moving" ring, drawn on the first `percepts` that says `traveling`) and to the
// first picture with the marker moved (`moved`).

/** Map units per tick the simulation moves a robot (bw4t-sim's MatchConfig::default). */
const UNITS_PER_TICK = 0.5;
/** The marker catches up with the newest place within about this many seconds. */
const CATCH_UP_S = 0.6;

const motion = { reacted: [], moved: [] };
window.bw4tMotion = motion;

export const glide = {
  drawn: null, // {x, y}: where the marker is drawn
  target: null, // {x, y}: the centre of the newest place the percepts named
  place: null, // that place's name
  unitsPerSecond: UNITS_PER_TICK * 10,
  lastMs: null,
  inputAt: null, // a pending go-to's input time, until the robot is seen moving
  reactedFor: null, // the input time whose `reacted` sample was taken

  /** The match's tick rate: the robot's speed in map units per second. */
  setTickHz(tickHz) {
    if (tickHz > 0) this.unitsPerSecond = UNITS_PER_TICK * tickHz;
  },

  /** The robot is at `zone` (a zone of the page's map, or null when not known). */
  setPlace(zone) {
    if (!zone) return;
    if (zone.name === this.place) return;
    this.place = zone.name;
    this.target = { x: zone.x + zone.w / 2, y: zone.y + zone.h / 2 };
    if (!this.drawn) this.drawn = { ...this.target };
  },

  /** A go-to was sent, made by an input at `inputAt` (performance.now() time). */
  sent(inputAt) {
    if (inputAt !== undefined && inputAt !== null) this.inputAt = inputAt;
  },

  /** The picture shows the robot travelling (its first sign of moving). */
  shownTraveling(now) {
    if (this.inputAt === null || this.reactedFor === this.inputAt) return;
    this.reactedFor = this.inputAt;
    motion.reacted.push(now - this.inputAt);
  },

  /** Moves the marker for the time since the last call; returns whether it moved. */
  step(now) {
    const last = this.lastMs;
    this.lastMs = now;
    if (!this.drawn || !this.target || last === null) return false;
    const dx = this.target.x - this.drawn.x;
    const dy = this.target.y - this.drawn.y;
    const distance = Math.hypot(dx, dy);
    if (distance < 1e-3) return false;
    const seconds = Math.min(0.1, (now - last) / 1000);
    const travel = Math.max(this.unitsPerSecond, distance / CATCH_UP_S) * seconds;
    const k = Math.min(1, travel / distance);
    this.drawn = { x: this.drawn.x + dx * k, y: this.drawn.y + dy * k };
    if (this.inputAt !== null) {
      motion.moved.push(now - this.inputAt);
      this.inputAt = null;
    }
    return true;
  },
};
