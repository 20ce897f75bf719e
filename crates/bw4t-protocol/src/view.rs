//! Whole-match views for spectators and the browser page: frames and the map's layout.

use bw4t_map::{Map, ZoneKind};
use bw4t_sim::{BlockPlace, Match};
use serde_json::{Value, json};

use crate::messages::{Frame, FrameBlock, FrameMessage, FrameRobot};

impl Frame {
    /// The god view of `game` now, with the messages sent since the previous frame.
    pub fn of(game: &Match, messages: Vec<FrameMessage>) -> Frame {
        let zones = game.map().zones();
        let robots: Vec<FrameRobot> = game
            .robots()
            .map(|r| FrameRobot {
                id: r.id.0,
                name: r.name.to_string(),
                x: r.pos.x,
                y: r.pos.y,
                state: r.state.into(),
                holding: r.holding,
            })
            .collect();
        let blocks = game
            .blocks()
            .filter_map(|(id, colour, place)| {
                let (x, y, held_by) = match place {
                    BlockPlace::Room { pos, .. } => (pos.x, pos.y, None),
                    BlockPlace::Held(r) => {
                        let holder = robots.iter().find(|fr| fr.id == r.0)?;
                        (holder.x, holder.y, Some(r.0))
                    }
                    BlockPlace::Gone => return None,
                };
                Some(FrameBlock { id, color: colour.name().into(), x, y, held_by })
            })
            .collect();
        let occupied =
            (0..zones.len()).filter(|&z| game.occupant(z).is_some()).map(|z| zones[z].name.clone()).collect();
        Frame {
            tick: game.tick(),
            sim_seconds: game.config().seconds(game.tick()),
            sequence: game.sequence().iter().map(|c| c.name().to_string()).collect(),
            sequence_index: game.sequence_index(),
            robots,
            blocks,
            occupied,
            messages,
        }
    }
}

/// The map's layout for drawing: zones as top-left boxes in map units (y down), doors with
/// the opening each makes in its wall, the walls themselves (`[x1, y1, x2, y2]`, from
/// [`Map::walls`]), spawn points. The page draws what it is given.
pub fn map_layout(map: &Map) -> Value {
    let zones: Vec<Value> = map
        .zones()
        .iter()
        .map(|z| {
            let (min, size) = (z.rect.min(), z.rect.size);
            let kind = match z.kind {
                ZoneKind::Room => "room",
                ZoneKind::Corridor => "corridor",
                ZoneKind::Charging => "charging",
                ZoneKind::Blockade => "blockade",
            };
            let doors: Vec<Value> = z
                .doors
                .iter()
                .map(|d| {
                    let r = d.rect();
                    let (a, b) = d.opening();
                    json!({"x": r.min().x, "y": r.min().y, "w": r.size.x, "h": r.size.y, "opening": [a.x, a.y, b.x, b.y]})
                })
                .collect();
            json!({"name": z.name, "kind": kind, "x": min.x, "y": min.y, "w": size.x, "h": size.y, "doors": doors})
        })
        .collect();
    json!({
        "name": map.name(),
        "area": [map.area().x, map.area().y],
        "zones": zones,
        "walls": map.walls().iter().map(|w| {
            let (a, b) = w.ends();
            [a.x, a.y, b.x, b.y]
        }).collect::<Vec<_>>(),
        "spawns": map.spawns().iter().map(|s| [s.pos.x, s.pos.y]).collect::<Vec<_>>(),
        "drop_zone": map.zones()[map.drop_zone()].name,
    })
}
