//! Walls: each walled zone's edges less the openings of its doors. Computed here once, for
//! the physics (which gives them thickness), the SVG renderer and the page (`/map.json`).

use crate::geometry::{Door, Orientation, Vec2};
use crate::model::Map;
use crate::parts::Zone;

/// A straight piece of wall on a zone's edge, along x (`horizontal`) or along y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wall {
    /// Whether it runs along x.
    pub horizontal: bool,
    /// Its y (horizontal) or x (vertical).
    pub fixed: f32,
    /// Where it starts along its axis.
    pub from: f32,
    /// Where it ends along its axis (`from < to`).
    pub to: f32,
}

impl Wall {
    /// Its two ends as points.
    pub fn ends(&self) -> (Vec2, Vec2) {
        if self.horizontal {
            (Vec2::new(self.from, self.fixed), Vec2::new(self.to, self.fixed))
        } else {
            (Vec2::new(self.fixed, self.from), Vec2::new(self.fixed, self.to))
        }
    }
}

/// The walls of `zone` (whether or not it is walled): its four edges, top, bottom, left,
/// right, less the door openings on each, with every edge extended by `overhang` past both
/// corners (the physics uses half a wall's thickness, so corners close).
pub fn zone_walls(zone: &Zone, overhang: f32) -> Vec<Wall> {
    let (min, max) = (zone.rect.min(), zone.rect.max());
    let half_door = Door::WIDTH / 2.0;
    let edges = [
        (true, min.y, min.x, max.x),
        (true, max.y, min.x, max.x),
        (false, min.x, min.y, max.y),
        (false, max.x, min.y, max.y),
    ];
    let mut walls = Vec::new();
    for (horizontal, fixed, from, to) in edges {
        let orientation = if horizontal { Orientation::Horizontal } else { Orientation::Vertical };
        let mut openings: Vec<(f32, f32)> = zone
            .doors
            .iter()
            .filter(|d| d.orientation == orientation)
            .filter_map(|d| {
                let (along, across) =
                    if horizontal { (d.centre.x, d.centre.y) } else { (d.centre.y, d.centre.x) };
                ((across - fixed).abs() < 1e-3 && (from..=to).contains(&along))
                    .then_some((along - half_door, along + half_door))
            })
            .collect();
        openings.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut start = from - overhang;
        let end = to + overhang;
        for (open_from, open_to) in openings.into_iter().chain([(end, end)]) {
            if open_from > start {
                walls.push(Wall { horizontal, fixed, from: start, to: open_from });
            }
            start = start.max(open_to);
        }
    }
    walls
}

impl Map {
    /// Every wall of the map: the edges of its walled zones (rooms and blockades) less the
    /// openings of their doors, in zone order.
    pub fn walls(&self) -> Vec<Wall> {
        self.zones().iter().filter(|z| z.kind.is_walled()).flat_map(|z| zone_walls(z, 0.0)).collect()
    }
}

impl Door {
    /// The opening the door makes in its wall: the segment of the edge it spans.
    pub fn opening(&self) -> (Vec2, Vec2) {
        let half = Door::WIDTH / 2.0;
        match self.orientation {
            Orientation::Horizontal => {
                (self.centre - Vec2::new(half, 0.0), self.centre + Vec2::new(half, 0.0))
            }
            Orientation::Vertical => (self.centre - Vec2::new(0.0, half), self.centre + Vec2::new(0.0, half)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Rect;
    use crate::parts::ZoneKind;

    fn room(doors: Vec<Door>) -> Zone {
        Zone {
            name: "R".into(),
            kind: ZoneKind::Room,
            rect: Rect::new(Vec2::new(15.0, 15.0), Vec2::new(10.0, 10.0)),
            doors,
            neighbours: vec![],
            blocks: vec![],
        }
    }

    #[test]
    fn edges_leave_an_opening_at_each_door_and_overhang_their_corners() {
        let door = Door { centre: Vec2::new(15.0, 10.0), orientation: Orientation::Horizontal };
        let walls = zone_walls(&room(vec![door]), 0.0);
        let spans: Vec<_> = walls.iter().map(|w| (w.horizontal, w.fixed, w.from, w.to)).collect();
        assert_eq!(
            spans,
            [
                (true, 10.0, 10.0, 13.0),
                (true, 10.0, 17.0, 20.0),
                (true, 20.0, 10.0, 20.0),
                (false, 10.0, 10.0, 20.0),
                (false, 20.0, 10.0, 20.0)
            ]
        );
        let thick = zone_walls(&room(vec![door]), 0.5);
        assert_eq!((thick[0].from, thick[0].to, thick[1].from, thick[1].to), (9.5, 13.0, 17.0, 20.5));
        assert_eq!(door.opening(), (Vec2::new(13.0, 10.0), Vec2::new(17.0, 10.0)));
    }

    #[test]
    fn a_door_of_the_other_orientation_or_off_the_edge_opens_nothing() {
        let vertical_on_top = Door { centre: Vec2::new(15.0, 10.0), orientation: Orientation::Vertical };
        let off_edge = Door { centre: Vec2::new(15.0, 12.0), orientation: Orientation::Horizontal };
        assert_eq!(zone_walls(&room(vec![vertical_on_top, off_edge]), 0.0).len(), 4);
    }
}
