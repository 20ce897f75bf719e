//! Original BW4T XML maps, on this repository's own files in that format
//! (`tests/fixtures/bw4t-xml/`): every construct the importer reads, the lenient inputs it
//! accepts, format detection, and the exact error for each broken file. The original map
//! files themselves are tested in `original_maps`.

use bw4t_map::{Colour, Map, MapLoadError, Orientation, XmlError, ZoneKind};
use bw4t_sim::{Action, Match, MatchConfig, Rejection};

use crate::util::{fixture_path, fixture_text};

/// A fixture under `tests/fixtures/bw4t-xml/`, by file name.
fn xml_text(file: &str) -> String {
    fixture_text(&format!("bw4t-xml/{file}"))
}

/// A fixture imported and named after its file.
fn fixture(file: &str) -> Map {
    Map::from_bw4t_xml_named(&xml_text(file), file).unwrap_or_else(|e| panic!("{file}: {e}"))
}

/// How many fixed blocks the map's rooms hold.
pub fn fixed_blocks(map: &Map) -> usize {
    map.zones().iter().map(|z| z.blocks.len()).sum()
}

/// The zone with this name; fails the test if there is none.
pub fn zone<'m>(map: &'m Map, name: &str) -> &'m bw4t_map::Zone {
    &map.zones()[map.zone_named(name).unwrap_or_else(|| panic!("no zone {name}"))]
}

/// The playable fixtures, written as the original server wrote its files.
const STRICT: [&str; 3] = ["fixed-content.xml", "random-content.xml", "small.xml"];

#[test]
fn every_zone_kind_and_both_door_orientations_import() {
    let map = fixture("fixed-content.xml");
    assert_eq!(map.name(), "fixed-content.xml");
    assert_eq!(map.area().to_array(), [40.0, 40.0]);
    let kinds: Vec<(&str, ZoneKind)> = map.zones().iter().map(|z| (z.name.as_str(), z.kind)).collect();
    use ZoneKind::*;
    assert_eq!(
        kinds,
        [
            ("NorthHall", Corridor),
            ("RoomNW", Room),
            ("RoomNE", Room),
            ("Charger", Charging),
            ("MidHall", Corridor),
            ("Blockade", Blockade),
            ("RoomSW", Room),
            ("FrontDropZone", Corridor),
            ("RoomSE", Room),
            ("DropZone", Room),
        ]
    );
    // Boxes are given by their centre; a hall may stick out of the area (y from -5 to 10).
    let hall = zone(&map, "NorthHall");
    assert_eq!((hall.rect.centre.to_array(), hall.rect.size.to_array()), ([20.0, 2.5], [20.0, 15.0]));
    assert_eq!(hall.rect.min().y, -5.0);

    let doors = |name: &str| -> Vec<([f32; 2], Orientation)> {
        zone(&map, name).doors.iter().map(|d| (d.centre.to_array(), d.orientation)).collect()
    };
    assert_eq!(doors("RoomNW"), [([10.0, 5.0], Orientation::Vertical)]);
    assert_eq!(doors("RoomNE"), [([30.0, 5.0], Orientation::Vertical)]);
    assert_eq!(doors("RoomSW"), [([5.0, 20.0], Orientation::Horizontal)]);
    assert_eq!(doors("DropZone"), [([20.0, 30.0], Orientation::Horizontal)]);
    assert!(doors("MidHall").is_empty() && doors("Charger").is_empty() && doors("Blockade").is_empty());
    assert_eq!(map.drop_zone(), map.zone_named("DropZone").expect("drop zone"));

    use Colour::*;
    assert_eq!(map.sequence(), &[Red, Blue, Green, Red]);
    assert_eq!(zone(&map, "RoomNW").blocks, [Red, Blue]);
    assert_eq!(zone(&map, "RoomSE").blocks, [Blue, White, Red]);
    assert_eq!(fixed_blocks(&map), 8);
    assert_eq!((map.random_sequence(), map.random_blocks(), map.seed()), (0, 0, None));
    // Fixed content: the seed moves blocks within their rooms, nothing more.
    let what = |seed| {
        let content = map.content(seed).expect("content");
        let blocks: Vec<_> = content.blocks.iter().map(|b| (b.colour, b.zone)).collect();
        (content.sequence, blocks)
    };
    assert_eq!(what(1), what(2));

    // Neighbour lists are kept as written, and are undirected edges.
    assert_eq!(zone(&map, "MidHall").neighbours, ["NorthHall", "Charger", "FrontDropZone", "Blockade"]);
    let blockade = map.zone_named("Blockade").expect("blockade");
    assert_eq!(zone(&map, "Blockade").neighbours, ["MidHall"]);
    assert!(map.neighbours(map.zone_named("MidHall").expect("hall")).contains(&blockade));

    let spawns: Vec<(&str, [f32; 2])> =
        map.spawns().iter().map(|s| (s.name.as_str(), s.pos.to_array())).collect();
    assert_eq!(spawns, [("Bot1", [20.0, 25.0]), ("Bot2", [16.0, 25.0]), ("Bot3", [24.0, 25.0])]);

    // The name-less entry point reads the same map.
    let unnamed = Map::from_bw4t_xml(&xml_text("fixed-content.xml")).expect("unnamed import");
    assert_eq!(unnamed.name(), "");
    assert_eq!(unnamed.zones(), map.zones());
}

#[test]
fn random_content_comes_from_the_match_seed_unless_the_map_fixes_one() {
    let map = fixture("random-content.xml");
    assert_eq!((map.random_sequence(), map.random_blocks(), map.seed()), (3, 5, None));
    assert_eq!(map.sequence(), &[Colour::Orange], "the fixed part of the sequence");
    assert_eq!(fixed_blocks(&map), 3);
    // Entities may share a name.
    assert_eq!(map.spawns().len(), 4);
    assert!(map.spawns().iter().all(|s| s.name == "Bot"));

    let drop_zone = map.drop_zone();
    let mut contents = Vec::new();
    for seed in 1..=5 {
        let content = map.content(seed).expect("content");
        assert_eq!(content.sequence.len(), 4, "seed {seed}");
        assert_eq!(content.sequence[0], Colour::Orange, "seed {seed}");
        assert_eq!(content.blocks.len(), 3 + 3 + 5, "seed {seed}: fixed, one per random colour, random");
        assert!(content.blocks.iter().all(|b| b.zone != drop_zone), "seed {seed}: a block in the drop zone");
        // Every sequence colour has its blocks, so the match can be completed.
        for colour in &content.sequence {
            let need = content.sequence.iter().filter(|c| *c == colour).count();
            let have = content.blocks.iter().filter(|b| b.colour == *colour).count();
            assert!(have >= need, "seed {seed}: {need} {colour} needed, {have} placed");
        }
        contents.push(content);
    }
    assert!(contents.iter().any(|c| *c != contents[0]), "five seeds, one content");

    // A map's own <seed> wins over the match seed; a negative one (Java's int) stays fixed.
    let with_seed = |seed: &str| {
        let text = xml_text("random-content.xml").replacen(
            "    <sequence>",
            &format!("    <seed>{seed}</seed>\n    <sequence>"),
            1,
        );
        Map::from_bw4t_xml(&text).expect("map with a seed")
    };
    let seeded = with_seed("42");
    assert_eq!(seeded.seed(), Some(42));
    assert_eq!(seeded.content(1).expect("content"), seeded.content(2).expect("content"));
    assert_eq!(seeded.content(1).expect("content"), map.content(42).expect("content"));
    let negative = with_seed("-7");
    assert_eq!(negative.seed(), Some((-7i64) as u64));
    assert_eq!(negative.content(1).expect("content"), negative.content(9).expect("content"));
}

#[test]
fn imported_fixtures_survive_the_native_format_unchanged() {
    for file in STRICT.into_iter().chain(["fixed-content-lenient.xml"]) {
        let map = fixture(file);
        let native = map.to_native();
        let again = Map::from_native(&native).unwrap_or_else(|e| panic!("{file}: {e}\n{native}"));
        assert_eq!(again, map, "{file}");
    }
}

#[test]
fn matches_run_on_every_fixture_and_robots_walk_through_a_charging_zone() {
    for file in STRICT {
        let map = fixture(file);
        let mut game = Match::new(&map, &MatchConfig::default(), 1).unwrap_or_else(|e| panic!("{file}: {e}"));
        let id = game.join("Alice").unwrap_or_else(|e| panic!("{file}: join: {e}"));
        game.handle_action(id, &Action::GoTo("DropZone".into()))
            .unwrap_or_else(|e| panic!("{file}: goTo(DropZone) refused: {e:?}"));
        let in_drop_zone =
            |game: &Match| game.robots().any(|r| r.id == id && r.room == Some(map.drop_zone()));
        let mut ticks = 0;
        while !in_drop_zone(&game) && ticks < 3000 {
            game.step();
            ticks += 1;
        }
        assert!(in_drop_zone(&game), "{file}: robot did not reach the DropZone in {ticks} ticks");
    }

    // RoomSW opens onto the charging zone only: the way there crosses it.
    let map = fixture("fixed-content.xml");
    let mut game = Match::new(&map, &MatchConfig::default(), 1).expect("match");
    let id = game.join("Alice").expect("join");
    let (charger, room) =
        (map.zone_named("Charger").expect("Charger"), map.zone_named("RoomSW").expect("RoomSW"));
    game.handle_action(id, &Action::GoTo("RoomSW".into())).expect("goTo(RoomSW)");
    let (mut crossed, mut ticks) = (false, 0);
    let robot = |game: &Match| game.robots().find(|r| r.id == id).expect("robot");
    while robot(&game).room != Some(room) && ticks < 3000 {
        game.step();
        crossed |= map.zone_at(robot(&game).pos) == Some(charger);
        ticks += 1;
    }
    assert_eq!(robot(&game).room, Some(room), "robot did not reach RoomSW in {ticks} ticks");
    assert!(crossed, "the robot never stood in the charging zone");
    // Nobody enters a blockade.
    let refused =
        game.handle_action(id, &Action::GoTo("Blockade".into())).expect_err("a blockade is entered");
    assert!(matches!(refused, Rejection::Unreachable(ref place) if place == "Blockade"), "{refused:?}");
}

#[test]
fn the_lenient_fixture_imports_as_its_strict_twin() {
    // Blank lines before the declaration, elements in any order, whole numbers, any case,
    // comments inside values, doors without <orientation>, unknown elements, no random
    // counts, `1` for true, a neighbour that names no zone (dropped).
    let lenient = Map::from_bw4t_xml(&xml_text("fixed-content-lenient.xml")).expect("lenient file");
    let strict = Map::from_bw4t_xml(&xml_text("fixed-content.xml")).expect("strict file");
    assert_eq!(lenient, strict);
    // Without <orientation>, each door got the one its edge allows.
    assert_eq!(zone(&lenient, "RoomNW").doors[0].orientation, Orientation::Vertical);
    assert_eq!(zone(&lenient, "RoomSW").doors[0].orientation, Orientation::Horizontal);
    assert!(!zone(&lenient, "MidHall").neighbours.iter().any(|n| n == "EastHall"));
    // The text really is written differently.
    let text = xml_text("fixed-content-lenient.xml");
    for lenient_part in
        ["\n\n<?xml", "<type>corridor</type>", "<!-- centre -->20", "<renderOptions>", "EastHall"]
    {
        assert!(text.contains(lenient_part), "the lenient fixture lost {lenient_part:?}");
    }
    assert!(!text.contains("<randomBlocks>") && !text.contains("<randomSequence>"));
}

#[test]
fn a_byte_order_mark_and_blank_lines_before_the_declaration_are_accepted() {
    let strict = Map::from_bw4t_xml(&xml_text("small.xml")).expect("small");
    let with_bom = format!("\u{feff}{}", xml_text("small.xml"));
    assert_eq!(Map::from_bw4t_xml(&with_bom).expect("with a byte-order mark"), strict);
    assert_eq!(Map::parse(&with_bom, "").expect("detected as XML"), strict);
    // Line numbers stay those of the file (the width is on line 18).
    let text = format!("\n\n{}", xml_text("broken/zone-width-not-a-number.xml"));
    let err = import_error(&text);
    assert!(matches!(&err, XmlError::Number { place, .. } if place.line == 20), "{err}");
}

#[test]
fn parse_detects_the_format() {
    let xml = xml_text("fixed-content.xml");
    let from_xml = Map::parse(&format!("\n  {xml}"), "xml").expect("XML with leading whitespace");
    assert_eq!(from_xml.name(), "xml");
    assert_eq!(from_xml.zones(), fixture("fixed-content.xml").zones());

    let native_path = format!("{}/maps/default.toml", repo_root!());
    let native = std::fs::read_to_string(&native_path).expect("maps/default.toml");
    // A native file's own name wins over the given one.
    let from_native = Map::parse(&native, "other").expect("native");
    assert_eq!(from_native, Map::from_native(&native).expect("native"));
    assert_eq!(from_native.name(), "default");

    // Without a name of its own, a native map takes the given one.
    let unnamed = from_xml.to_native().replace("name = \"xml\"\n", "");
    let renamed = Map::parse(&unnamed, "from-the-caller").expect("unnamed native");
    assert_eq!(renamed.name(), "from-the-caller");
    assert_eq!(renamed.zones(), from_xml.zones());

    // Each format's errors come through, with their own messages.
    let err = Map::parse(&xml_text("broken/no-area.xml"), "x").expect_err("no area");
    assert!(matches!(err, MapLoadError::Xml(XmlError::Missing { element: "area", .. })), "{err:?}");
    let err = Map::parse("area = 3", "x").expect_err("bad native");
    assert!(matches!(err, MapLoadError::Native(_)), "{err:?}");
    assert!(!err.to_string().is_empty());
}

fn import_error(text: &str) -> XmlError {
    Map::from_bw4t_xml(text).expect_err("should fail")
}

/// Every file in `tests/fixtures/bw4t-xml/broken/` (each `small.xml` with one fault, or a
/// few) and the whole error it gives.
const BROKEN: [(&str, &str); 36] = [
    ("mismatched-tag", "not well-formed XML at line 4, column 25: expected 'name' tag, not 'nmae'"),
    ("cut-short", "not well-formed XML at line 9, column 1: the root node was opened but never closed"),
    ("wrong-root", "the root element is <oldMap>, expected <newMap> (an original BW4T map)"),
    ("no-area", "line 2, <newMap>: missing <area>"),
    ("area-without-y", "line 3, <area>: missing <y>"),
    ("area-x-twice", "line 3, <area>: <x> is given more than once"),
    ("area-not-positive", "invalid map: area: 0 x 20 is not positive"),
    ("entity-without-name", "line 4, entity 1: missing <name>"),
    ("entity-without-position", "line 4, entity 1 'Bot1': missing <position>"),
    ("entity-x-not-a-number", "line 4, entity 1 'Bot1', <position>: <x> is '5 0', not a finite number"),
    ("no-entities", "invalid map: spawn points: there are none: robots cannot enter"),
    ("one-bot-maybe", "line 5, <newMap>: <oneBotPerCorridorZone> is 'maybe', not true or false"),
    (
        "random-blocks-negative",
        "line 6, <newMap>: <randomBlocks> is '-3', not a whole number from 0 to 4294967295",
    ),
    (
        "random-sequence-fraction",
        "line 7, <newMap>: <randomSequence> is '1.5', not a whole number from 0 to 4294967295",
    ),
    ("seed-not-a-number", "line 8, <newMap>: <seed> is 'seven', not a whole number"),
    ("seed-twice", "line 9, <newMap>: <seed> is given more than once"),
    (
        "sequence-unknown-colour",
        "line 8, <sequence>: unknown colour 'PURPLE' (expected one of Blue, Cyan, Magenta, Orange, Red, White, Green, Yellow, Pink)",
    ),
    ("zone-without-name", "line 16, zone 2: missing <name>"),
    ("zone-without-type", "line 16, zone 'RoomA': missing <type>"),
    (
        "zone-unknown-type",
        "line 14, zone 'Hall': unknown zone type 'LAKE' (expected ROOM, CORRIDOR, CHARGINGZONE or BLOCKADE)",
    ),
    ("zone-without-boundingbox", "line 9, zone 'Hall': missing <boundingbox>"),
    (
        "zone-width-not-a-number",
        "line 18, zone 'RoomA', <boundingbox>: <width> is 'ten', not a finite number",
    ),
    (
        "zone-height-infinite",
        "line 10, zone 'Hall', <boundingbox>: <height>: inf is out of range (coordinates and sizes must be from -10000 to 10000)",
    ),
    ("zone-size-zero", "invalid map: zone 'Hall': size 10 x 0 is not positive"),
    (
        "block-unknown-colour",
        "line 17, zone 'RoomA', <blocks>: unknown colour 'PURPLE' (expected one of Blue, Cyan, Magenta, Orange, Red, White, Green, Yellow, Pink)",
    ),
    ("door-without-position", "line 19, zone 'RoomA', door 1: missing <position>"),
    (
        "door-unknown-orientation",
        "line 19, zone 'RoomA', door 1: unknown door orientation 'DIAGONAL' (expected HORIZONTAL or VERTICAL)",
    ),
    (
        "door-at-corner-without-orientation",
        "line 19, zone 'RoomA', door 1: the door at (10, 0) needs an <orientation>",
    ),
    ("door-off-the-edge", "invalid map: zone 'DropZone': door at (12, 15) is not on the room's edge"),
    ("door-on-a-corridor", "invalid map: zone 'Hall': only rooms have doors, this is a corridor"),
    ("blocks-in-a-corridor", "invalid map: zone 'Hall': only rooms hold blocks, this is a corridor"),
    ("eleven-blocks", "invalid map: zone 'RoomA': 11 blocks, at most 10 fit in a room"),
    ("no-drop-zone", "invalid map: drop zone: no zone named 'DropZone'"),
    ("drop-zone-not-a-room", "invalid map: zone 'DropZone': the drop zone must be a room, not a corridor"),
    (
        "zone-defined-twice",
        "invalid map: zone 'Hall': the name is already used by zone 1 (names must be unique)",
    ),
    (
        "several-problems",
        "invalid map: zone 'RoomA': 11 blocks, at most 10 fit in a room; \
         zone 'RoomA': door at (12, 5) is not on the room's edge; drop zone: no zone named 'DropZone'",
    ),
];

#[test]
fn every_broken_file_gives_its_exact_error() {
    for (file, expected) in BROKEN {
        let text = xml_text(&format!("broken/{file}.xml"));
        assert_eq!(import_error(&text).to_string(), expected, "broken/{file}.xml");
        // Through the format-detecting entry point, the same message.
        let err = Map::parse(&text, file).expect_err("should fail");
        assert_eq!(err.to_string(), expected, "broken/{file}.xml via Map::parse");
    }
    // The table covers every file there.
    let dir = fixture_path("bw4t-xml/broken");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .expect("broken fixtures")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = BROKEN.iter().map(|(file, _)| format!("{file}.xml")).collect();
    listed.sort();
    assert_eq!(on_disk, listed);
}

#[test]
fn error_kinds_are_distinguishable() {
    let broken = |file: &str| import_error(&xml_text(&format!("broken/{file}.xml")));
    let err = broken("mismatched-tag");
    assert!(matches!(&err, XmlError::Syntax { line: 4, column: 25, .. }), "{err:?}");
    let err = broken("wrong-root");
    assert!(matches!(&err, XmlError::Root { found } if found == "oldMap"), "{err:?}");
    let err = broken("area-without-y");
    assert!(matches!(&err, XmlError::Missing { element: "y", place } if place.what == "<area>"), "{err:?}");
    let err = broken("seed-twice");
    assert!(matches!(&err, XmlError::Repeated { element: "seed", place } if place.line == 9), "{err:?}");
    let err = broken("zone-unknown-type");
    assert!(matches!(&err, XmlError::ZoneType { found, .. } if found == "LAKE"), "{err:?}");
    let err = broken("block-unknown-colour");
    assert!(matches!(&err, XmlError::Colour { place, .. } if place.line == 17), "{err:?}");
    let err = broken("zone-width-not-a-number");
    assert!(matches!(&err, XmlError::Number { element: "width", text, .. } if text == "ten"), "{err:?}");
    let err = broken("door-unknown-orientation");
    assert!(matches!(&err, XmlError::Orientation { found, .. } if found == "DIAGONAL"), "{err:?}");
    let err = broken("door-at-corner-without-orientation");
    assert!(matches!(&err, XmlError::DoorOrientation { x, y, .. } if (*x, *y) == (10.0, 0.0)), "{err:?}");
    let err = broken("several-problems");
    assert!(matches!(&err, XmlError::Invalid(e) if e.problems.len() == 3), "{err:?}");
    // It is a standard error with a source chain for validation problems.
    let boxed: Box<dyn std::error::Error> = Box::new(import_error("<newMap>"));
    assert!(!boxed.to_string().is_empty());
}
