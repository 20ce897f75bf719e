//! Maps drawn as SVG: zones, walls with their door openings, labels, blocks, spawn points
//! and the goal sequence, in one standalone document; and a moment of a match (blocks where
//! they lie, robots where they stand) drawn the same way.
//!
//! The drawing is in map units (y grows downwards, as in map files) inside one scaled
//! group, so its coordinates can be read against the map file. Output depends only on the
//! input: numbers are rounded to hundredths and printed the same way everywhere.

use std::fmt::Write as _;

use crate::colour::Colour;
use crate::content::Content;
use crate::geometry::{Rect, Vec2};
use crate::model::Map;
use crate::parts::{Zone, ZoneKind};
use crate::walls::zone_walls;

/// Pixels per map unit.
const SCALE: f32 = 10.0;
/// Blank space around everything, in pixels.
const MARGIN: f32 = 20.0;
/// Height of the title line, in pixels.
const TITLE_HEIGHT: f32 = 30.0;
/// Height of the sequence row below the map, in pixels.
const SEQUENCE_HEIGHT: f32 = 44.0;
/// Side of a square of the sequence row, in pixels.
const GOAL_SQUARE: f32 = 16.0;
/// Room taken by the `Sequence` label before the squares, in pixels.
const SEQUENCE_LABEL: f32 = 80.0;
/// Width of a wall line, in map units.
const WALL: f32 = 0.4;
/// Largest zone label, in map units.
const LABEL_SIZE: f32 = 1.2;

/// Draws `map` as a standalone SVG document, 10 pixels per map unit.
///
/// With `content` (the blocks and sequence of one match, and the seed they were drawn
/// from) blocks are drawn where they lie and the sequence row shows the whole sequence;
/// without it only the fixed sequence is shown, and no blocks (their spots are random).
/// The same input always gives the same bytes.
pub fn render_svg(map: &Map, content: Option<(&Content, u64)>) -> String {
    let name = map_name(map);
    let title = match content {
        Some((c, seed)) => {
            let s = if c.blocks.len() == 1 { "" } else { "s" };
            format!("{name}, seed {seed}: {} block{s}, a sequence of {}", c.blocks.len(), c.sequence.len())
        }
        None => format!("{name}: layout and fixed sequence"),
    };
    let ids: Vec<u32> = (1..).take(content.map_or(0, |(c, _)| c.blocks.len())).collect();
    draw(map, content.map(|(c, _)| c), &ids, &[], &title)
}

/// A robot drawn in a [`render_scene`].
#[derive(Clone, Debug, PartialEq)]
pub struct RobotMark {
    /// Its player's name.
    pub name: String,
    /// Its centre.
    pub pos: Vec2,
    /// The colour of the block it holds.
    pub holding: Option<Colour>,
}

/// Draws one moment of a match: `content` holds the blocks lying in rooms (block
/// `block_ids[i]` is `content.blocks[i]`) and the sequence; robots are drawn as 2 x 2 discs
/// with their name, holding a block of its colour. `title` heads the drawing.
pub fn render_scene(
    map: &Map,
    content: &Content,
    block_ids: &[u32],
    robots: &[RobotMark],
    title: &str,
) -> String {
    draw(map, Some(content), block_ids, robots, title)
}

fn map_name(map: &Map) -> &str {
    if map.name().is_empty() { "(unnamed map)" } else { map.name() }
}

fn draw(
    map: &Map,
    content: Option<&Content>,
    block_ids: &[u32],
    robots: &[RobotMark],
    title: &str,
) -> String {
    let (min, max) = bounds(map);
    let size = (max - min) * SCALE;
    let sequence: &[Colour] = content.map_or(map.sequence(), |c| &c.sequence);
    let more_random = if content.is_none() { map.random_sequence() } else { 0 };
    let row_width = SEQUENCE_LABEL + sequence.len() as f32 * (GOAL_SQUARE + 4.0) + 110.0;
    // A rough width of the bold title, so it is never cut off.
    let title_width = title.chars().count() as f32 * 9.5;
    let width = size.x.max(row_width).max(title_width) + 2.0 * MARGIN;
    let height = MARGIN + TITLE_HEIGHT + size.y + SEQUENCE_HEIGHT + MARGIN;

    let mut svg = Svg::default();
    svg.line(&format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif">"#,
        w = num(width),
        h = num(height)
    ));
    svg.line(&format!("<title>{}</title>", escape(title)));
    svg.line(r##"<rect width="100%" height="100%" fill="#ffffff"/>"##);
    svg.line(&format!(
        r##"<text x="{}" y="{}" font-size="15" font-weight="bold" fill="#222222">{}</text>"##,
        num(MARGIN),
        num(MARGIN + 16.0),
        escape(title)
    ));
    let origin = Vec2::new(MARGIN, MARGIN + TITLE_HEIGHT) - min * SCALE;
    svg.line(&format!(
        r#"<g transform="translate({} {}) scale({})">"#,
        num(origin.x),
        num(origin.y),
        num(SCALE)
    ));
    draw_map(&mut svg, map);
    // Labels go below blocks and spawn points, and are moved out from under them.
    draw_labels(&mut svg, map, content);
    if let Some(c) = content {
        draw_blocks(&mut svg, c, block_ids);
    }
    if robots.is_empty() {
        draw_spawns(&mut svg, map);
    }
    draw_robots(&mut svg, robots);
    svg.line("</g>");
    draw_sequence(&mut svg, sequence, more_random, MARGIN + TITLE_HEIGHT + size.y + 14.0);
    svg.line("</svg>");
    svg.0
}

/// The SVG text being written, one element per line.
#[derive(Default)]
struct Svg(String);

impl Svg {
    fn line(&mut self, s: &str) {
        self.0.push_str(s);
        self.0.push('\n');
    }
}

/// The part of the plane to draw: the area, every zone and every spawn point.
fn bounds(map: &Map) -> (Vec2, Vec2) {
    let mut boxes: Vec<Rect> = Vec::new();
    let area = map.area();
    if area.is_finite() && area.x > 0.0 && area.y > 0.0 {
        boxes.push(Rect::new(area / 2.0, area));
    }
    boxes.extend(map.zones().iter().map(|z| z.rect));
    boxes.extend(map.spawns().iter().map(|s| Rect::new(s.pos, Vec2::splat(2.0))));
    let finite: Vec<&Rect> = boxes.iter().filter(|r| r.min().is_finite() && r.max().is_finite()).collect();
    if finite.is_empty() {
        return (Vec2::ZERO, Vec2::ONE);
    }
    let min = finite.iter().fold(Vec2::splat(f32::MAX), |m, r| m.min(r.min()));
    let max = finite.iter().fold(Vec2::splat(f32::MIN), |m, r| m.max(r.max()));
    (min, max)
}

/// Zone fills, the area's outline, walls and doors.
fn draw_map(svg: &mut Svg, map: &Map) {
    let area = map.area();
    svg.line(&format!(
        r##"<rect class="area" x="0" y="0" width="{}" height="{}" fill="none" stroke="#9a9a9a" stroke-width="0.1" stroke-dasharray="0.6 0.4"/>"##,
        num(area.x),
        num(area.y)
    ));
    for (idx, zone) in map.zones().iter().enumerate() {
        let (class, fill) = zone_style(zone, idx == map.drop_zone());
        let r = zone.rect;
        svg.line(&format!(
            r##"<rect class="{class}" x="{}" y="{}" width="{}" height="{}" fill="{fill}" stroke="#c4c4c4" stroke-width="0.05"><title>{}</title></rect>"##,
            num(r.min().x),
            num(r.min().y),
            num(r.size.x),
            num(r.size.y),
            escape(&zone.name)
        ));
    }
    for zone in map.zones().iter().filter(|z| z.kind.is_walled()) {
        let d = wall_path(zone);
        if !d.is_empty() {
            svg.line(&format!(
                r##"<path class="wall" d="{d}" fill="none" stroke="#3a3a3a" stroke-width="{}" stroke-linecap="square"/>"##,
                num(WALL)
            ));
        }
    }
    for zone in map.zones() {
        for door in &zone.doors {
            let r = door.rect();
            svg.line(&format!(
                r##"<rect class="door" x="{}" y="{}" width="{}" height="{}" fill="#fff4cc" stroke="#b08a2e" stroke-width="0.08"/>"##,
                num(r.min().x),
                num(r.min().y),
                num(r.size.x),
                num(r.size.y)
            ));
        }
    }
}

/// The CSS class and fill of a zone: rooms light, halls lighter, blockades dark, charging
/// zones tinted, the drop zone its own colour.
fn zone_style(zone: &Zone, is_drop_zone: bool) -> (&'static str, &'static str) {
    (zone_class(zone, is_drop_zone), zone_fill(zone, is_drop_zone))
}

fn zone_class(zone: &Zone, is_drop_zone: bool) -> &'static str {
    match zone.kind {
        ZoneKind::Room if is_drop_zone => "room drop-zone",
        ZoneKind::Room => "room",
        ZoneKind::Corridor => "corridor",
        ZoneKind::Charging => "charging",
        ZoneKind::Blockade => "blockade",
    }
}

/// A zone's fill colour (`#rrggbb`) in drawings of the map.
pub fn zone_fill(zone: &Zone, is_drop_zone: bool) -> &'static str {
    match zone.kind {
        ZoneKind::Room if is_drop_zone => "#cfe8c6",
        ZoneKind::Room => "#efe7d4",
        ZoneKind::Corridor => "#fafaf6",
        ZoneKind::Charging => "#d7ebf7",
        ZoneKind::Blockade => "#4d4d4d",
    }
}

/// The walls of a walled zone as path data ([`zone_walls`]).
fn wall_path(zone: &Zone) -> String {
    let mut d = String::new();
    for wall in zone_walls(zone, 0.0) {
        let (a, b) = (num(wall.from), num(wall.to));
        let fixed = num(wall.fixed);
        // Writing to a String cannot fail.
        let _ = if wall.horizontal { write!(d, "M{a} {fixed}H{b}") } else { write!(d, "M{fixed} {a}V{b}") };
    }
    d
}

fn draw_blocks(svg: &mut Svg, content: &Content, ids: &[u32]) {
    for (block, id) in content.blocks.iter().zip(ids) {
        svg.line(&format!(
            r##"<rect class="block" x="{}" y="{}" width="1" height="1" fill="{}" stroke="#333333" stroke-width="0.08"><title>block {}: {}</title></rect>"##,
            num(block.pos.x - 0.5),
            num(block.pos.y - 0.5),
            colour_hex(block.colour),
            id,
            block.colour
        ));
    }
}

/// Robots as discs of a robot's size with their name, a held block as a square inside.
fn draw_robots(svg: &mut Svg, robots: &[RobotMark]) {
    for robot in robots {
        let p = robot.pos;
        svg.line(&format!(
            r##"<circle class="robot" cx="{}" cy="{}" r="1" fill="#1d4f91"><title>{}</title></circle>"##,
            num(p.x),
            num(p.y),
            escape(&robot.name)
        ));
        if let Some(colour) = robot.holding {
            svg.line(&format!(
                r##"<rect class="held" x="{}" y="{}" width="0.9" height="0.9" fill="{}" stroke="#ffffff" stroke-width="0.08"/>"##,
                num(p.x - 0.45),
                num(p.y - 0.45),
                colour_hex(colour)
            ));
        }
        svg.line(&format!(
            r##"<text x="{}" y="{}" font-size="0.8" text-anchor="middle" fill="#1d4f91">{}</text>"##,
            num(p.x),
            num(p.y - 1.2),
            escape(&robot.name)
        ));
    }
}

/// Spawn points as robot-sized (2 x 2) outlines, numbered in the order robots take them.
fn draw_spawns(svg: &mut Svg, map: &Map) {
    for (i, spawn) in map.spawns().iter().enumerate() {
        let p = spawn.pos;
        svg.line(&format!(
            r##"<rect class="spawn" x="{}" y="{}" width="2" height="2" fill="none" stroke="#1d4f91" stroke-width="0.12"><title>spawn {}: {}</title></rect>"##,
            num(p.x - 1.0),
            num(p.y - 1.0),
            i + 1,
            escape(&spawn.name)
        ));
        svg.line(&format!(
            r##"<text x="{}" y="{}" font-size="0.9" text-anchor="middle" fill="#1d4f91">{}</text>"##,
            num(p.x),
            num(p.y + 0.32),
            i + 1
        ));
    }
}

/// Zone names, sized to fit and outlined in the zone's colour so walls do not hide them.
/// Each sits at its zone's centre, or, where spawn points or blocks cover that, at the
/// clear spot of the zone nearest its centre, in a smaller type if only that fits.
fn draw_labels(svg: &mut Svg, map: &Map, content: Option<&Content>) {
    // Spawn points (2 x 2) and blocks (1 x 1) with their outlines, as drawn below.
    let mut marks: Vec<Rect> = map.spawns().iter().map(|s| Rect::new(s.pos, Vec2::splat(2.12))).collect();
    if let Some(c) = content {
        marks.extend(c.blocks.iter().map(|b| Rect::new(b.pos, Vec2::splat(1.08))));
    }
    for (idx, zone) in map.zones().iter().enumerate() {
        let (_, fill) = zone_style(zone, idx == map.drop_zone());
        let text_colour = if zone.kind == ZoneKind::Blockade { "#ffffff" } else { "#555555" };
        // About 0.6 em per character: keep the name within 90% of the zone's width.
        let chars = zone.name.chars().count().max(1) as f32;
        let full = LABEL_SIZE.min(0.9 * zone.rect.size.x / (0.6 * chars)).max(0.3);
        let here: Vec<Rect> = marks.iter().copied().filter(|m| m.overlaps(&zone.rect)).collect();
        let (at, size) = LABEL_SHRINK
            .iter()
            .map(|scale| (full * scale).max(0.3))
            .find_map(|size| label_spot(&zone.rect, label_size(chars, size), &here).map(|at| (at, size)))
            .unwrap_or((zone.rect.centre, full));
        svg.line(&format!(
            r#"<text class="label" x="{}" y="{}" font-size="{}" text-anchor="middle" fill="{text_colour}" stroke="{fill}" stroke-width="{}" paint-order="stroke">{}</text>"#,
            num(at.x),
            num(at.y + 0.35 * size),
            num(size),
            num(LABEL_OUTLINE),
            escape(&zone.name)
        ));
    }
}

/// Width of the outline drawn around label letters, in map units.
const LABEL_OUTLINE: f32 = 0.3;

/// The type sizes tried for a label that marks crowd, as fractions of its full size.
const LABEL_SHRINK: [f32; 4] = [1.0, 0.85, 0.7, 0.55];

/// Marks whose edges give the spots tried for one label, at most (the nearest).
const LABEL_MARKS: usize = 64;

/// The box a label of `chars` characters at font size `size` covers, outline included:
/// about 0.65 em per character (a little more than the fitting above assumes), one em high.
fn label_size(chars: f32, size: f32) -> Vec2 {
    Vec2::new(0.65 * size * chars, size) + LABEL_OUTLINE
}

/// Where to centre a label of `label` size in `zone`, clear of every mark and of the
/// zone's walls: the zone's centre if clear, else the clear spot nearest it among those
/// where the label touches a mark or the zone's edge on each axis, or lies on a grid.
/// `None` when nothing is clear.
fn label_spot(zone: &Rect, label: Vec2, marks: &[Rect]) -> Option<Vec2> {
    let clear = |at: Vec2| !marks.iter().any(|m| m.overlaps(&Rect::new(at, label)));
    let centre = zone.centre;
    if clear(centre) {
        return Some(centre);
    }
    // The centres that keep the label inside the zone, off its walls' inner half.
    let (lo, hi) = (zone.min() + (label + WALL) / 2.0, zone.max() - (label + WALL) / 2.0);
    let (lo, hi) = (lo.min(centre), hi.max(centre));
    let mut near: Vec<&Rect> = marks.iter().collect();
    near.sort_by(|a, b| a.distance(centre).total_cmp(&b.distance(centre)));
    near.truncate(LABEL_MARKS);
    // Candidate positions on one axis: centre, the ends, a grid, and just past each mark.
    let axis = |c: f32, lo: f32, hi: f32, half: f32, edges: &dyn Fn(&Rect) -> (f32, f32)| {
        let mut out = vec![c, lo, hi];
        out.extend((0..=16).map(|i| lo + (hi - lo) * i as f32 / 16.0));
        for m in &near {
            let (min, max) = edges(m);
            out.extend([min - half - 0.01, max + half + 0.01]);
        }
        out.retain(|v| (lo..=hi).contains(v));
        out.sort_by(f32::total_cmp);
        out.dedup();
        out
    };
    let xs = axis(centre.x, lo.x, hi.x, label.x / 2.0, &|m| (m.min().x, m.max().x));
    let ys = axis(centre.y, lo.y, hi.y, label.y / 2.0, &|m| (m.min().y, m.max().y));
    let mut spots: Vec<Vec2> = ys.iter().flat_map(|&y| xs.iter().map(move |&x| Vec2::new(x, y))).collect();
    // Nearest first; ties above before below, then left before right.
    spots.sort_by(|a, b| {
        let (da, db) = (a.distance_squared(centre), b.distance_squared(centre));
        da.total_cmp(&db).then(a.y.total_cmp(&b.y)).then(a.x.total_cmp(&b.x))
    });
    spots.into_iter().find(|&at| clear(at))
}

/// The sequence as a row of coloured squares below the map, in pixels.
fn draw_sequence(svg: &mut Svg, sequence: &[Colour], more_random: u32, top: f32) {
    svg.line(&format!(
        r##"<text x="{}" y="{}" font-size="13" fill="#222222">Sequence</text>"##,
        num(MARGIN),
        num(top + 13.0)
    ));
    let mut x = MARGIN + SEQUENCE_LABEL;
    for (i, colour) in sequence.iter().enumerate() {
        svg.line(&format!(
            r##"<rect class="goal" x="{}" y="{}" width="{s}" height="{s}" fill="{}" stroke="#333333" stroke-width="1"><title>{}: {}</title></rect>"##,
            num(x),
            num(top),
            colour_hex(*colour),
            i + 1,
            colour,
            s = num(GOAL_SQUARE)
        ));
        x += GOAL_SQUARE + 4.0;
    }
    let note = match (sequence.is_empty(), more_random) {
        (true, 0) => "(empty)".to_string(),
        (_, 0) => String::new(),
        (_, n) => format!("+ {n} random"),
    };
    if !note.is_empty() {
        svg.line(&format!(
            r##"<text x="{}" y="{}" font-size="13" fill="#222222">{note}</text>"##,
            num(x + 2.0),
            num(top + 13.0)
        ));
    }
}

/// The fill of a block of `colour`.
/// A block colour as drawn (`#rrggbb`).
pub fn colour_hex(colour: Colour) -> &'static str {
    match colour {
        Colour::Blue => "#1f64d6",
        Colour::Cyan => "#1fc8d8",
        Colour::Magenta => "#d22bc9",
        Colour::Orange => "#f28a1a",
        Colour::Red => "#d62828",
        Colour::White => "#ffffff",
        Colour::Green => "#2e9e44",
        Colour::Yellow => "#f5d31a",
        Colour::Pink => "#f59ac2",
    }
}

/// A number rounded to hundredths, without trailing zeros; what is not finite prints as 0.
fn num(x: f32) -> String {
    if !x.is_finite() {
        return "0".to_string();
    }
    // Adding 0.0 turns -0 into 0.
    let rounded = (f64::from(x) * 100.0).round() / 100.0 + 0.0;
    format!("{rounded}")
}

/// Text made safe for XML content and attribute values.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Door, Orientation};

    #[test]
    fn numbers_are_short_and_stable() {
        assert_eq!(num(15.0), "15");
        assert_eq!(num(2.5), "2.5");
        assert_eq!(num(13.567), "13.57");
        assert_eq!(num(-0.001), "0");
        assert_eq!(num(f32::NAN), "0");
    }

    #[test]
    fn text_is_escaped() {
        assert_eq!(escape(r#"a<b & "c" 'd'>"#), "a&lt;b &amp; &quot;c&quot; &apos;d&apos;&gt;");
    }

    #[test]
    fn walls_leave_gaps_at_doors() {
        let zone = Zone {
            name: "R".into(),
            kind: ZoneKind::Room,
            rect: Rect::new(Vec2::new(15.0, 15.0), Vec2::new(10.0, 10.0)),
            doors: vec![Door { centre: Vec2::new(15.0, 10.0), orientation: Orientation::Horizontal }],
            neighbours: vec![],
            blocks: vec![],
        };
        assert_eq!(wall_path(&zone), "M10 10H13M17 10H20M10 20H20M10 10V20M20 10V20");
    }
}
