//! The rules that make parts a map, written once as [`Problem`]s with places: [`Map::new`]
//! refuses parts that break any of them, and `map check` ([`check_parts`]) reports them
//! among its own checks of play-ability and its warnings.
//!
//! [`Map::new`]: crate::Map::new
//! [`check_parts`]: crate::check_parts

use std::collections::BTreeMap;

use crate::geometry::{Door, Orientation, Rect, Vec2};
use crate::limits::MAX_BLOCKS_PER_ROOM;
use crate::limits::{in_range, limit_problems, within_counts};
use crate::parts::{DROP_ZONE, MapParts, Zone, ZoneKind};
use crate::problem::{Problem, point, zone_place};

/// Every rule `parts` breaks, as errors: the limits, then a positive area, unique
/// non-empty zone names, each zone's own rules in file order, one drop zone that is a
/// room, and at least one spawn point. Past a count limit only the limits are looked at:
/// the rest may be costly with the counts, and the map is refused anyway.
pub(crate) fn rule_problems(parts: &MapParts) -> Vec<Problem> {
    let mut out = limit_problems(parts);
    if !within_counts(parts) {
        return out;
    }
    let area = parts.area;
    // A number out of range is reported by the limits.
    if in_range(area) && !(area.x > 0.0 && area.y > 0.0) {
        out.push(Problem::error("area", format!("{} x {} is not positive", area.x, area.y)));
    }
    names(parts, &mut out);
    let names: BTreeMap<&str, ()> = parts.zones.iter().map(|z| (z.name.as_str(), ())).collect();
    for (idx, zone) in parts.zones.iter().enumerate() {
        zone_rules(idx, zone, &names, &mut out);
    }
    drop_zone(parts, &mut out);
    if parts.spawns.is_empty() {
        out.push(Problem::error("spawn points", "there are none: robots cannot enter"));
    }
    out
}

/// Zone names are not empty, and unique (a zone's name is its `PlaceID`).
fn names(parts: &MapParts, out: &mut Vec<Problem>) {
    let mut first: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, zone) in parts.zones.iter().enumerate() {
        if zone.name.is_empty() {
            out.push(Problem::error(zone_place(i, zone), "has an empty name"));
            continue;
        }
        match first.get(zone.name.as_str()) {
            Some(&j) => out.push(Problem::error(
                zone_place(i, zone),
                format!("the name is already used by zone {} (names must be unique)", j + 1),
            )),
            None => {
                first.insert(zone.name.as_str(), i);
            }
        }
    }
}

/// One zone's rules: a positive size, neighbours that are zones, doors and blocks only in
/// rooms, at most [`MAX_BLOCKS_PER_ROOM`] blocks, every door on an edge of its room.
fn zone_rules(idx: usize, zone: &Zone, names: &BTreeMap<&str, ()>, out: &mut Vec<Problem>) {
    let place = zone_place(idx, zone);
    let size = zone.rect.size;
    // Numbers out of range are reported by the limits.
    if in_range(zone.rect.centre) && in_range(size) && !(size.x > 0.0 && size.y > 0.0) {
        out.push(Problem::error(&place, format!("size {} x {} is not positive", size.x, size.y)));
    }
    for n in &zone.neighbours {
        if !names.contains_key(n.as_str()) {
            out.push(Problem::error(&place, format!("neighbour '{n}' is not a zone")));
        }
    }
    if zone.kind != ZoneKind::Room {
        if !zone.doors.is_empty() {
            out.push(Problem::error(
                &place,
                format!("only rooms have doors, this is a {}", zone.kind.name()),
            ));
        }
        if !zone.blocks.is_empty() {
            out.push(Problem::error(
                &place,
                format!("only rooms hold blocks, this is a {}", zone.kind.name()),
            ));
        }
    }
    if zone.blocks.len() > MAX_BLOCKS_PER_ROOM {
        out.push(Problem::error(
            &place,
            format!("{} blocks, at most {MAX_BLOCKS_PER_ROOM} fit in a room", zone.blocks.len()),
        ));
    }
    if zone.kind == ZoneKind::Room {
        for door in zone.doors.iter().filter(|d| in_range(d.centre)) {
            if let Some(message) = door_off_edge(door, &zone.rect) {
                out.push(Problem::error(&place, message));
            }
        }
    }
}

/// What is wrong with where `door` is on `room`, if anything: a door is an opening in
/// one of the room's edges, along that edge.
fn door_off_edge(door: &Door, room: &Rect) -> Option<String> {
    if door_on_edge(door, room) {
        return None;
    }
    let at = point(door.centre);
    let flipped = match door.orientation {
        Orientation::Horizontal => Orientation::Vertical,
        Orientation::Vertical => Orientation::Horizontal,
    };
    if door_on_edge(&Door { centre: door.centre, orientation: flipped }, room) {
        let (is, edge) = match door.orientation {
            Orientation::Horizontal => ("horizontal", "left or right"),
            Orientation::Vertical => ("vertical", "top or bottom"),
        };
        Some(format!("door at {at} is {is} but lies on the room's {edge} edge"))
    } else {
        Some(format!("door at {at} is not on the room's edge"))
    }
}

/// Exactly one zone is named [`DROP_ZONE`], and it is a room.
fn drop_zone(parts: &MapParts, out: &mut Vec<Problem>) {
    let drop_zones: Vec<(usize, &Zone)> =
        parts.zones.iter().enumerate().filter(|(_, z)| z.name == DROP_ZONE).collect();
    match drop_zones.as_slice() {
        [] => out.push(Problem::error(DROP_ZONE_PLACE, format!("no zone named '{DROP_ZONE}'"))),
        [(i, dz)] if dz.kind != ZoneKind::Room => out.push(Problem::error(
            zone_place(*i, dz),
            format!("the drop zone must be a room, not a {}", dz.kind.name()),
        )),
        [_] => {}
        several => out.push(Problem::error(
            DROP_ZONE_PLACE,
            format!("{} zones are named '{DROP_ZONE}', there must be one", several.len()),
        )),
    }
}

/// How problems of the drop zone as a whole (none, or several) name their place.
const DROP_ZONE_PLACE: &str = "drop zone";

/// How far off an edge a door's centre may lie and still be on it.
const EDGE_TOLERANCE: f32 = 1e-3;

/// Whether the door's centre lies on an edge of `room` that its orientation allows.
pub(crate) fn door_on_edge(door: &Door, room: &Rect) -> bool {
    let (min, max, c) = (room.min(), room.max(), door.centre);
    let near = |a: f32, b: f32| (a - b).abs() <= EDGE_TOLERANCE;
    match door.orientation {
        Orientation::Horizontal => (near(c.y, min.y) || near(c.y, max.y)) && min.x <= c.x && c.x <= max.x,
        Orientation::Vertical => (near(c.x, min.x) || near(c.x, max.x)) && min.y <= c.y && c.y <= max.y,
    }
}

/// The orientation a door at `centre` must have on `room`, when only one edge fits.
pub(crate) fn infer_orientation(centre: Vec2, room: &Rect) -> Option<Orientation> {
    let fits = |orientation| door_on_edge(&Door { centre, orientation }, room);
    match (fits(Orientation::Horizontal), fits(Orientation::Vertical)) {
        (true, false) => Some(Orientation::Horizontal),
        (false, true) => Some(Orientation::Vertical),
        _ => None,
    }
}

/// The orientation to keep for a door given without one whose centre picks no single
/// edge of its room, for a reader that goes on to report every problem. A door at a
/// corner (on two edges) is reported here; one off every edge is left to [`check_parts`],
/// which names it.
pub(crate) fn guess_orientation(
    place: &str,
    centre: Vec2,
    room: &Rect,
    out: &mut Vec<Problem>,
) -> Orientation {
    let on_both = door_on_edge(&Door { centre, orientation: Orientation::Horizontal }, room);
    if on_both {
        out.push(Problem::error(
            place,
            format!("door at {} is at a corner of the room: its orientation must be given", point(centre)),
        ));
    }
    Orientation::Horizontal
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn problems_print_with_severity_and_place() {
        let p = Problem::error("zone 'RoomA1'", "door at (15, 17) is not on the room's edge");
        assert_eq!(p.to_string(), "error: zone 'RoomA1': door at (15, 17) is not on the room's edge");
        assert_eq!(p.located(), "zone 'RoomA1': door at (15, 17) is not on the room's edge");
        assert_eq!(Problem::warning("sequence", "x").to_string(), "warning: sequence: x");
    }

    #[test]
    fn doors_fit_only_the_edges_their_orientation_allows() {
        let room = Rect::new(Vec2::new(5.0, 5.0), Vec2::new(10.0, 10.0));
        let door = |x, y, orientation| Door { centre: Vec2::new(x, y), orientation };
        assert_eq!(door_off_edge(&door(5.0, 0.0, Orientation::Horizontal), &room), None);
        assert_eq!(
            door_off_edge(&door(5.0, 0.0, Orientation::Vertical), &room).as_deref(),
            Some("door at (5, 0) is vertical but lies on the room's top or bottom edge")
        );
        assert_eq!(
            door_off_edge(&door(5.0, 3.0, Orientation::Horizontal), &room).as_deref(),
            Some("door at (5, 3) is not on the room's edge")
        );
        assert_eq!(infer_orientation(Vec2::new(10.0, 4.0), &room), Some(Orientation::Vertical));
        assert_eq!(infer_orientation(Vec2::new(0.0, 0.0), &room), None, "a corner fits both");
    }
}
