//! Generated maps in the grid style of the default map: rows of rooms with a door on top,
//! a front corridor above each room, halls down both sides, and the drop zone at the bottom
//! behind a wide front corridor where the robots start.

use crate::colour::Colour;
use crate::geometry::{Door, Orientation, Rect, Vec2};
use crate::model::{Map, MapError};
use crate::parts::{DROP_ZONE, MapParts, Spawn, Zone, ZoneKind};
use crate::problem::Problem;

/// Rows, at most; with the columns, this keeps a generated map within
/// [`MAX_ZONES`](crate::MAX_ZONES).
pub const MAX_ROWS: usize = 40;
/// Columns per row, at most.
pub const MAX_COLUMNS: usize = 40;

/// Spacing of spawn points: robots (2 x 2) placed this far apart never overlap.
const SPAWN_SPACING: f32 = 3.0;

/// A map of `rows` x `cols` rooms with spawn points for `robots`. Its content is fixed by
/// `seed`: the blocks (about three per room) and a six-colour sequence are drawn once and
/// written into the map, and the map keeps the seed, so every match on it has the same
/// blocks in the same places.
pub fn generate(cols: usize, rows: usize, robots: usize, seed: u64) -> Result<Map, MapError> {
    let fail = |problem: String| MapError { problems: vec![Problem::error("generated map", problem)] };
    if cols == 0 || rows == 0 || cols > MAX_COLUMNS || rows > MAX_ROWS {
        return Err(fail(format!("rooms must be 1x1 to {MAX_ROWS}x{MAX_COLUMNS}, got {rows}x{cols}")));
    }
    let (c, r) = (cols as f32, rows as f32);
    let width = 20.0 + 10.0 * c;
    let bottom = 20.0 * r + 5.0; // top of FrontDropZone
    let box_at = |x: f32, y: f32, w: f32, h: f32| Rect::new(Vec2::new(x, y), Vec2::new(w, h));
    let mut zones: Vec<Zone> = Vec::new();
    let mut zone = |name: String, kind, rect, doors: Vec<Door>, neighbours: Vec<String>| {
        zones.push(Zone { name, kind, rect, doors, neighbours, blocks: Vec::new() });
    };
    for row in 0..rows {
        let l = row_name(row);
        let y = 20.0 * row as f32;
        let below = row_name(row + 1);
        zone(
            format!("LeftHall{l}"),
            ZoneKind::Corridor,
            box_at(5.0, y + 10.0, 10.0, 20.0),
            vec![],
            vec![format!("Front{l}1"), format!("LeftHall{below}")],
        );
        zone(
            format!("RightHall{l}"),
            ZoneKind::Corridor,
            box_at(width - 5.0, y + 10.0, 10.0, 20.0),
            vec![],
            vec![format!("Front{l}{cols}"), format!("RightHall{below}")],
        );
        for col in 1..=cols {
            let x = 5.0 + 10.0 * col as f32;
            let mut neighbours = vec![format!("Room{l}{col}")];
            if col < cols {
                neighbours.push(format!("Front{l}{}", col + 1));
            }
            zone(
                format!("Front{l}{col}"),
                ZoneKind::Corridor,
                box_at(x, y + 10.0, 10.0, 10.0),
                vec![],
                neighbours,
            );
            let door = Door { centre: Vec2::new(x, y + 15.0), orientation: Orientation::Horizontal };
            zone(
                format!("Room{l}{col}"),
                ZoneKind::Room,
                box_at(x, y + 20.0, 10.0, 10.0),
                vec![door],
                vec![],
            );
        }
    }
    let end = row_name(rows);
    let front = box_at(10.0 + 5.0 * c, bottom + 5.0, 10.0 * c, 10.0);
    zone(
        format!("LeftHall{end}"),
        ZoneKind::Corridor,
        box_at(5.0, bottom + 5.0, 10.0, 10.0),
        vec![],
        vec!["FrontDropZone".into()],
    );
    zone(
        format!("RightHall{end}"),
        ZoneKind::Corridor,
        box_at(width - 5.0, bottom + 5.0, 10.0, 10.0),
        vec![],
        vec!["FrontDropZone".into()],
    );
    zone("FrontDropZone".into(), ZoneKind::Corridor, front, vec![], vec![DROP_ZONE.into()]);
    let drop_width = (10.0 * c).min(25.0);
    let door =
        Door { centre: Vec2::new(front.centre.x, bottom + 10.0), orientation: Orientation::Horizontal };
    zone(
        DROP_ZONE.into(),
        ZoneKind::Room,
        box_at(front.centre.x, bottom + 15.0, drop_width, 10.0),
        vec![door],
        vec![],
    );

    let spawns = spawn_points(&zones, &front, robots).ok_or_else(|| {
        fail(format!("{robots} robots do not fit around the drop zone of a {rows}x{cols} map"))
    })?;
    let n_rooms = rows * cols;
    let draft = MapParts {
        name: format!("grid-{rows}x{cols}"),
        area: Vec2::new(width, bottom + 20.0),
        zones,
        spawns,
        sequence: Vec::new(),
        random_sequence: 6,
        random_blocks: (3 * n_rooms).saturating_sub(6) as u32,
        seed: None,
    };
    // Draw the content once and write it in, so the file fixes every block.
    let random = Map::new(draft.clone())?;
    let content = random.content(seed).map_err(|e| fail(e.to_string()))?;
    let mut parts = draft;
    parts.random_sequence = 0;
    parts.random_blocks = 0;
    parts.seed = Some(seed);
    parts.sequence = content.sequence.clone();
    for block in &content.blocks {
        parts.zones[block.zone].blocks.push(block.colour);
    }
    // Keep each room's blocks in colour order so the file reads well.
    parts.zones.iter_mut().for_each(|z| z.blocks.sort_by_key(|c| Colour::ALL.iter().position(|a| a == c)));
    Map::new(parts)
}

/// The name of row `i` (from 0), as in spreadsheet columns: `A` to `Z`, then `AA`, `AB`, ...
/// The halls below the last row take the next name.
fn row_name(i: usize) -> String {
    let mut name = Vec::new();
    let mut n = i + 1;
    while n > 0 {
        n -= 1;
        name.push(b'A' + (n % 26) as u8);
        n /= 26;
    }
    name.reverse();
    String::from_utf8_lossy(&name).into_owned()
}

/// Up to `n` points on a grid, in FrontDropZone first and then in the halls beside it,
/// nearest to the drop zone's door first.
fn spawn_points(zones: &[Zone], front: &Rect, n: usize) -> Option<Vec<Spawn>> {
    let door = Vec2::new(front.centre.x, front.max().y);
    let mut points: Vec<Vec2> = Vec::new();
    let areas = zones.iter().filter(|z| {
        z.name == "FrontDropZone" || (z.kind == ZoneKind::Corridor && z.rect.centre.y == front.centre.y)
    });
    for zone in areas {
        let inner = zone.rect.shrunk(1.5);
        let (min, max) = (inner.min(), inner.max());
        let mut y = min.y;
        while y <= max.y {
            let mut x = min.x;
            while x <= max.x {
                points.push(Vec2::new(x, y));
                x += SPAWN_SPACING;
            }
            y += SPAWN_SPACING;
        }
    }
    // Nearest the door first; ties in a fixed order.
    points.sort_by(|a, b| {
        a.distance(door).total_cmp(&b.distance(door)).then(a.x.total_cmp(&b.x)).then(a.y.total_cmp(&b.y))
    });
    (points.len() >= n.max(1)).then(|| {
        points
            .into_iter()
            .take(n.max(1))
            .enumerate()
            .map(|(i, pos)| Spawn { name: format!("Bot{}", i + 1), pos })
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_maps_are_valid_and_round_trip() {
        for (cols, rows, robots) in [(1, 1, 1), (3, 3, 10), (4, 3, 20), (10, 10, 100)] {
            let map = generate(cols, rows, robots, 7).expect("valid");
            assert_eq!(map.spawns().len(), robots);
            let rooms = map.zones().iter().filter(|z| z.kind == ZoneKind::Room).count();
            assert_eq!(rooms, cols * rows + 1);
            assert_eq!(Map::from_native(&map.to_native()).expect("reads back"), map);
            assert_eq!(
                map.content(1).expect("content"),
                map.content(2).expect("content"),
                "content is fixed"
            );
        }
        assert!(generate(0, 3, 3, 1).is_err());
        assert!(generate(1, MAX_ROWS + 1, 1, 1).is_err());
        assert!(generate(1, 1, 500, 1).is_err());
    }

    #[test]
    fn rows_are_named_like_spreadsheet_columns() {
        let names: Vec<String> = [0, 1, 25, 26, 27, 51, 52, 701, 702].into_iter().map(row_name).collect();
        assert_eq!(names, ["A", "B", "Z", "AA", "AB", "AZ", "BA", "ZZ", "AAA"]);
    }
}
