//! `Map::new` and `check_parts` (`map check`) apply one set of rules: on parts that break
//! one rule each, `Map::new` refuses with exactly the errors the check lists first, and
//! on parts that only a match could not be played on, it accepts what the check refuses.

use bw4t_map::{
    Colour, DROP_ZONE, Door, MAX_SPAWNS, MAX_ZONES, Map, MapParts, Orientation, Problem, Spawn, Vec2,
    ZoneKind, check_parts,
};

/// A small valid map: a hall along the top, a room with a red block and the drop zone below.
const BASE: &str = r#"
name = "base"
area = [30, 30]
sequence = ["Red"]
[[spawn]]
name = "Bot1"
at = [15, 5]
[[zone]]
name = "Hall"
type = "corridor"
centre = [15, 5]
size = [30, 10]
neighbours = ["RoomA", "DropZone"]
[[zone]]
name = "RoomA"
type = "room"
centre = [7, 20]
size = [10, 10]
doors = [[7, 15]]
blocks = ["Red"]
[[zone]]
name = "DropZone"
type = "room"
centre = [22, 20]
size = [10, 10]
doors = [[22, 15]]
"#;

/// What breaking one rule, or one play-ability check, looks like.
struct Case {
    what: &'static str,
    edit: fn(&mut MapParts),
    /// Whether it breaks a rule of the map (so `Map::new` refuses), or only makes the map
    /// unplayable (so only the check refuses).
    rule: bool,
    place: &'static str,
    message: &'static str,
}

fn base() -> MapParts {
    Map::from_native(BASE).expect("the base map is valid").parts().clone()
}

fn zone<'a>(parts: &'a mut MapParts, name: &str) -> &'a mut bw4t_map::Zone {
    parts.zones.iter_mut().find(|z| z.name == name).expect("a zone of the base map")
}

fn cases() -> Vec<Case> {
    let case = |what, edit, rule, place, message| Case { what, edit, rule, place, message };
    vec![
        case(
            "too many zones",
            |p| {
                let hall = p.zones[0].clone();
                p.zones
                    .extend((0..MAX_ZONES).map(|i| bw4t_map::Zone { name: format!("H{i}"), ..hall.clone() }));
            },
            true,
            "map",
            "4099 zones, at most 4096 are allowed",
        ),
        case(
            "too many spawn points",
            |p| p.spawns = vec![p.spawns[0].clone(); MAX_SPAWNS + 1],
            true,
            "spawn points",
            "1025, at most 1024 are allowed",
        ),
        case(
            "a coordinate out of range",
            |p| p.area.x = 1e6,
            true,
            "area",
            "width: 1000000 is out of range (coordinates and sizes must be from -10000 to 10000)",
        ),
        case(
            "more random blocks than room",
            |p| p.random_blocks = 11,
            true,
            "random content",
            "11 random blocks, but the rooms (other than the drop zone) have space for 9",
        ),
        case("an empty area", |p| p.area.y = 0.0, true, "area", "30 x 0 is not positive"),
        case("a zone without a name", |p| zone(p, "Hall").name.clear(), true, "zone 1", "has an empty name"),
        case(
            "a name used twice",
            |p| zone(p, "RoomA").name = "Hall".into(),
            true,
            "zone 'Hall'",
            "the name is already used by zone 1 (names must be unique)",
        ),
        case(
            "a zone without size",
            |p| zone(p, "Hall").rect.size.x = 0.0,
            true,
            "zone 'Hall'",
            "size 0 x 10 is not positive",
        ),
        case(
            "a neighbour that is no zone",
            |p| zone(p, "Hall").neighbours.push("Nowhere".into()),
            true,
            "zone 'Hall'",
            "neighbour 'Nowhere' is not a zone",
        ),
        case(
            "a door in a corridor",
            |p| {
                zone(p, "Hall")
                    .doors
                    .push(Door { centre: Vec2::new(15.0, 0.0), orientation: Orientation::Horizontal })
            },
            true,
            "zone 'Hall'",
            "only rooms have doors, this is a corridor",
        ),
        case(
            "a block in a corridor",
            |p| zone(p, "Hall").blocks.push(Colour::Red),
            true,
            "zone 'Hall'",
            "only rooms hold blocks, this is a corridor",
        ),
        case(
            "too many blocks in a room",
            |p| zone(p, "RoomA").blocks = vec![Colour::Red; 11],
            true,
            "zone 'RoomA'",
            "11 blocks, at most 10 fit in a room",
        ),
        case(
            "a door off its room's edges",
            |p| zone(p, "RoomA").doors[0].centre.y = 17.0,
            true,
            "zone 'RoomA'",
            "door at (7, 17) is not on the room's edge",
        ),
        case(
            "a door turned across its edge",
            |p| zone(p, "RoomA").doors[0].orientation = Orientation::Vertical,
            true,
            "zone 'RoomA'",
            "door at (7, 15) is vertical but lies on the room's top or bottom edge",
        ),
        case(
            "no drop zone",
            |p| zone(p, DROP_ZONE).name = "Drop".into(),
            true,
            "drop zone",
            "no zone named 'DropZone'",
        ),
        case(
            "a drop zone that is no room",
            |p| {
                let dz = zone(p, DROP_ZONE);
                (dz.kind, dz.doors) = (ZoneKind::Corridor, Vec::new());
            },
            true,
            "zone 'DropZone'",
            "the drop zone must be a room, not a corridor",
        ),
        case(
            "two drop zones",
            |p| zone(p, "RoomA").name = DROP_ZONE.into(),
            true,
            "drop zone",
            "2 zones are named 'DropZone', there must be one",
        ),
        case(
            "no spawn points",
            |p| p.spawns.clear(),
            true,
            "spawn points",
            "there are none: robots cannot enter",
        ),
        // Only the check refuses these: the map is one, but no match on it can be completed.
        case(
            "overlapping zones",
            |p| {
                let room = zone(p, "RoomA");
                (room.rect.centre.x, room.doors[0].centre.x) = (16.0, 16.0);
            },
            false,
            "zone 'DropZone'",
            "overlaps zone 'RoomA'",
        ),
        case(
            "a room nobody reaches",
            |p| zone(p, "Hall").neighbours.retain(|n| n != "RoomA"),
            false,
            "zone 'RoomA'",
            "no robot can reach it from the spawn points (it has no neighbours)",
        ),
        case(
            "a sequence without its blocks",
            |p| p.sequence.push(Colour::Blue),
            false,
            "sequence",
            "needs 1 Blue block, the map has 0",
        ),
    ]
}

fn listed(problems: &[Problem]) -> String {
    problems.iter().map(|p| format!("\n  {p}")).collect()
}

#[test]
fn the_base_map_passes_both() {
    let parts = base();
    assert!(Map::new(parts.clone()).is_ok());
    let found = check_parts(&parts, None);
    assert!(!found.iter().any(Problem::is_error), "{}", listed(&found));
}

#[test]
fn map_new_refuses_exactly_the_rules_the_check_lists_first() {
    for Case { what, edit, rule, place, message } in cases() {
        let mut parts = base();
        edit(&mut parts);
        let errors: Vec<Problem> = check_parts(&parts, None).into_iter().filter(Problem::is_error).collect();
        let expected = Problem::error(place, message);
        assert!(errors.contains(&expected), "{what}: the check does not say {expected}:{}", listed(&errors));
        match Map::new(parts) {
            Err(refused) => {
                assert!(rule, "{what}: Map::new refuses ({refused}) what only the check should");
                assert!(
                    refused.problems.contains(&expected),
                    "{what}: Map::new does not say {expected}: {refused}"
                );
                // The same problems, in the same words and order, as the check's first errors.
                assert_eq!(refused.problems, errors[..refused.problems.len()], "{what}");
                let said: Vec<String> = refused.problems.iter().map(Problem::located).collect();
                assert_eq!(refused.to_string(), format!("invalid map: {}", said.join("; ")), "{what}");
            }
            Ok(_) => assert!(!rule, "{what}: Map::new accepts a broken rule: {expected}"),
        }
    }
}

#[test]
fn parts_with_nothing_in_them_break_the_same_rules_for_both() {
    let bare =
        MapParts { spawns: vec![Spawn { name: "Bot1".into(), pos: Vec2::ZERO }], ..MapParts::default() };
    let refused = Map::new(bare.clone()).expect_err("no area, no zones");
    let errors: Vec<Problem> = check_parts(&bare, None).into_iter().filter(Problem::is_error).collect();
    assert_eq!(refused.problems, errors);
    assert_eq!(
        refused.to_string(),
        "invalid map: area: 0 x 0 is not positive; drop zone: no zone named 'DropZone'"
    );
}
