//! An environment's match drawn: as SVG (the map drawing with blocks and robots where they
//! are now) and as an RGB image of the same scene for `render_mode="rgb_array"`.

use bw4t_map::{Content, Map, PlacedBlock, RobotMark, Vec2, colour_hex, render_scene, zone_fill, zone_walls};
use bw4t_sim::{BlockPlace, Match};

/// The blocks lying in rooms now, with their ids, and each robot.
fn scene(game: &Match) -> (Content, Vec<u32>, Vec<RobotMark>) {
    let mut content = Content { sequence: game.sequence().to_vec(), blocks: Vec::new() };
    let mut ids = Vec::new();
    let mut held = Vec::new();
    for (id, colour, place) in game.blocks() {
        match place {
            BlockPlace::Room { zone, pos } => {
                content.blocks.push(PlacedBlock { colour, zone, pos });
                ids.push(id);
            }
            BlockPlace::Held(robot) => held.push((robot, colour)),
            BlockPlace::Gone => {}
        }
    }
    let robots = game
        .robots()
        .map(|r| RobotMark {
            name: r.name.to_string(),
            pos: r.pos,
            holding: held.iter().find(|(robot, _)| *robot == r.id).map(|(_, c)| *c),
        })
        .collect();
    (content, ids, robots)
}

/// The match now as a standalone SVG document.
pub(crate) fn svg(game: &Match) -> String {
    let (content, ids, robots) = scene(game);
    let delivered = game.sequence_index();
    let title = format!(
        "{}, seed {}, tick {}: {delivered} of {} delivered",
        game.map().name(),
        game.seed(),
        game.tick(),
        content.sequence.len()
    );
    render_scene(game.map(), &content, &ids, &robots, &title)
}

/// An RGB image: `height × width × 3` bytes, row after row.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rgb {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// `height × width × 3` bytes.
    pub pixels: Vec<u8>,
}

/// Blank space around the map, in map units.
const BORDER: f32 = 1.0;

/// The match now drawn at `scale` pixels per map unit: zones in their map colours, walls,
/// blocks lying in rooms, robots (with the colour of what they hold), and the sequence as
/// a strip along the bottom (delivered positions darkened).
pub(crate) fn rgb(game: &Match, scale: f32) -> Rgb {
    let map = game.map();
    let (min, max) = extent(map);
    let scale = scale.clamp(1.0, 32.0);
    let strip = 2.0;
    let width = ((max.x - min.x + 2.0 * BORDER) * scale).ceil() as usize;
    let height = ((max.y - min.y + 2.0 * BORDER + strip) * scale).ceil() as usize;
    let mut canvas = Canvas {
        width,
        height,
        pixels: vec![255; width * height * 3],
        min: min - Vec2::splat(BORDER),
        scale,
    };
    for (idx, zone) in map.zones().iter().enumerate() {
        canvas.rect(zone.rect.min(), zone.rect.max(), hex(zone_fill(zone, idx == map.drop_zone())));
    }
    let wall = [58, 58, 58];
    for zone in map.zones().iter().filter(|z| z.kind.is_walled()) {
        for w in zone_walls(zone, 0.2) {
            let (a, b) = if w.horizontal {
                (Vec2::new(w.from, w.fixed - 0.2), Vec2::new(w.to, w.fixed + 0.2))
            } else {
                (Vec2::new(w.fixed - 0.2, w.from), Vec2::new(w.fixed + 0.2, w.to))
            };
            canvas.rect(a, b, wall);
        }
    }
    let (content, _, robots) = scene(game);
    for block in &content.blocks {
        canvas.rect(
            block.pos - Vec2::splat(0.5),
            block.pos + Vec2::splat(0.5),
            hex(colour_hex(block.colour)),
        );
    }
    for robot in &robots {
        canvas.disc(robot.pos, 1.0, [29, 79, 145]);
        if let Some(colour) = robot.holding {
            canvas.rect(
                robot.pos - Vec2::splat(0.45),
                robot.pos + Vec2::splat(0.45),
                hex(colour_hex(colour)),
            );
        }
    }
    let done = game.sequence_index() as usize;
    let top = max.y + BORDER;
    for (i, colour) in content.sequence.iter().enumerate() {
        let x = min.x + i as f32 * 1.5;
        let mut fill = hex(colour_hex(*colour));
        if i < done {
            fill = fill.map(|c| c / 3);
        }
        canvas.rect(Vec2::new(x, top + 0.25), Vec2::new(x + 1.2, top + 1.45), fill);
    }
    Rgb { width, height, pixels: canvas.pixels }
}

/// The part of the plane the map covers.
fn extent(map: &Map) -> (Vec2, Vec2) {
    let zones = map.zones().iter().map(|z| (z.rect.min(), z.rect.max()));
    zones.fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)))
}

/// `#rrggbb` as bytes (the drawing's colour tables are written that way).
fn hex(colour: &str) -> [u8; 3] {
    let byte = |i: usize| u8::from_str_radix(colour.get(i..i + 2).unwrap_or("00"), 16).unwrap_or(0);
    [byte(1), byte(3), byte(5)]
}

struct Canvas {
    width: usize,
    height: usize,
    pixels: Vec<u8>,
    min: Vec2,
    scale: f32,
}

impl Canvas {
    /// The pixel range covering map coordinates `from..to` along one axis.
    fn span(&self, from: f32, to: f32, origin: f32, limit: usize) -> std::ops::Range<usize> {
        let a = ((from - origin) * self.scale).round().max(0.0) as usize;
        let b = ((to - origin) * self.scale).round().max(0.0) as usize;
        a.min(limit)..b.min(limit)
    }

    fn put(&mut self, x: usize, y: usize, rgb: [u8; 3]) {
        let i = (y * self.width + x) * 3;
        self.pixels[i..i + 3].copy_from_slice(&rgb);
    }

    fn rect(&mut self, a: Vec2, b: Vec2, rgb: [u8; 3]) {
        for y in self.span(a.y, b.y, self.min.y, self.height) {
            for x in self.span(a.x, b.x, self.min.x, self.width) {
                self.put(x, y, rgb);
            }
        }
    }

    fn disc(&mut self, centre: Vec2, radius: f32, rgb: [u8; 3]) {
        let (a, b) = (centre - Vec2::splat(radius), centre + Vec2::splat(radius));
        for y in self.span(a.y, b.y, self.min.y, self.height) {
            for x in self.span(a.x, b.x, self.min.x, self.width) {
                let p = self.min + (Vec2::new(x as f32, y as f32) + Vec2::splat(0.5)) / self.scale;
                if p.distance_squared(centre) <= radius * radius {
                    self.put(x, y, rgb);
                }
            }
        }
    }
}
