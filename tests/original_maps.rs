//! The original BW4T map files: import, format detection, errors, map tools and the
//! built-in team on them. They are not part of this repository: these tests read the folder
//! named by `BW4T_ORIGINAL_MAPS` and are ignored unless asked for (`./test.sh` runs them when
//! it is set). `tests/fixtures/bw4t-xml/` covers the same behaviours on files of its own.

use std::path::Path;

use bw4t_agents::Strategy;
use bw4t_map::{Colour, Map, MapLoadError, Orientation, Problem, XmlError, ZoneKind};
use bw4t_sim::{Action, Match, MatchConfig};

use crate::agents::ticks_to_complete;
use crate::import::{fixed_blocks, zone};
use crate::map_tools::{bw4t, path_str, problems, read, stderr, stdout, temp_dir};
use crate::util::{original_map_path, original_map_text, shipped_map};

/// Every original map file, by path in the original maps folder, with its zone and spawn counts.
const ORIGINALS: [(&str, usize, usize); 7] = [
    ("Banana", 28, 3),
    ("Dutch Flag", 28, 3),
    ("Rainbow", 28, 3),
    ("Random", 28, 3),
    ("SuperRandom", 28, 10),
    ("test-variants/Rainbow-with-blockade", 28, 3),
    ("test-variants/red.map", 25, 4),
];

fn original(file: &str) -> Map {
    Map::from_bw4t_xml_named(&original_map_text(file), file).unwrap_or_else(|e| panic!("{file}: {e}"))
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn every_original_map_imports_with_its_content() {
    for (file, zones, spawns) in ORIGINALS {
        let map = original(file);
        assert_eq!(map.name(), file);
        assert_eq!(map.zones().len(), zones, "{file}: zones");
        assert_eq!(map.spawns().len(), spawns, "{file}: spawn points");
        assert_eq!(map.zones()[map.drop_zone()].name, "DropZone");
        let content = map.content(7).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert!(!content.sequence.is_empty(), "{file}: empty sequence");
        // The name-less entry point reads the same map.
        let unnamed = Map::from_bw4t_xml(&original_map_text(file)).expect("unnamed import");
        assert_eq!(unnamed.name(), "");
        assert_eq!(unnamed.zones(), map.zones());
    }
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn imported_maps_survive_the_native_format_unchanged() {
    for (file, ..) in ORIGINALS {
        let map = original(file);
        let native = map.to_native();
        let again = Map::from_native(&native).unwrap_or_else(|e| panic!("{file}: {e}\n{native}"));
        assert_eq!(again, map, "{file}");
    }
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn matches_run_on_every_original_map() {
    for (file, ..) in ORIGINALS {
        let map = original(file);
        let mut game = Match::new(&map, &MatchConfig::default(), 1).unwrap_or_else(|e| panic!("{file}: {e}"));
        let ids: Vec<_> = ["Alice", "Bob", "Carol"]
            .iter()
            .map(|name| game.join(name).unwrap_or_else(|e| panic!("{file}: join {name}: {e}")))
            .collect();
        game.handle_action(ids[0], &Action::GoTo("DropZone".into()))
            .unwrap_or_else(|e| panic!("{file}: goTo(DropZone) refused: {e:?}"));
        let in_drop_zone =
            |game: &Match| game.robots().any(|r| r.id == ids[0] && r.room == Some(map.drop_zone()));
        let mut ticks = 0;
        while !in_drop_zone(&game) && ticks < 5000 {
            game.step();
            ticks += 1;
        }
        assert!(in_drop_zone(&game), "{file}: robot did not reach the DropZone in {ticks} ticks");
    }
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn banana_has_fixed_yellow_content_and_the_original_layout() {
    let map = original("Banana");
    assert_eq!(map.area().to_array(), [50.0, 80.0]);
    assert_eq!(map.sequence(), &[Colour::Yellow; 6]);
    assert_eq!(fixed_blocks(&map), 27);
    assert_eq!((map.random_sequence(), map.random_blocks(), map.seed()), (0, 0, None));
    let spawns: Vec<[f32; 2]> = map.spawns().iter().map(|s| s.pos.to_array()).collect();
    assert_eq!(spawns, [[25.0, 65.0], [21.0, 63.0], [29.0, 63.0]]);
    let names: Vec<&str> = map.spawns().iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["Bot1", "Bot2", "Bot3"]);

    // Names are kept as the file spells them (not the spec's `FrontA1`).
    let front = zone(&map, "FrontRoomA1");
    assert_eq!(front.kind, ZoneKind::Corridor);
    assert_eq!(front.rect.centre.to_array(), [15.0, 5.0]);
    assert_eq!(front.rect.size.to_array(), [10.0, 10.0]);
    assert_eq!(front.neighbours, ["RoomA1", "LeftHallA", "FrontRoomA2"]);
    let room = zone(&map, "RoomA1");
    assert_eq!(room.kind, ZoneKind::Room);
    assert_eq!(room.blocks, [Colour::Orange, Colour::Green, Colour::White]);
    assert_eq!(room.doors.len(), 1);
    assert_eq!(room.doors[0].centre.to_array(), [15.0, 10.0]);
    assert_eq!(room.doors[0].orientation, Orientation::Horizontal);
    // A hall that sticks out of the area (y from -5 to 15) still loads.
    assert_eq!(zone(&map, "LeftHallA").rect.min().y, -5.0);
    let dz = zone(&map, "DropZone");
    assert_eq!((dz.rect.centre.to_array(), dz.rect.size.to_array()), ([25.0, 75.0], [25.0, 10.0]));
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn dutch_flag_and_rainbow_have_their_sequences() {
    let dutch = original("Dutch Flag");
    use Colour::*;
    assert_eq!(dutch.sequence(), &[Red, Red, White, White, Blue, Blue]);
    assert_eq!(fixed_blocks(&dutch), 23);

    let rainbow = original("Rainbow");
    assert_eq!(rainbow.sequence(), &[Blue, Green, Yellow, Pink, Orange, Red]);
    assert_eq!(fixed_blocks(&rainbow), 22);
    assert_eq!(rainbow.seed(), Some(1));
    // The map's own seed wins over the match seed.
    assert_eq!(rainbow.content(1).expect("content"), rainbow.content(2).expect("content"));
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn random_maps_draw_their_content_from_the_seed() {
    let map = original("Random");
    assert_eq!((map.random_sequence(), map.random_blocks(), map.seed()), (6, 22, None));
    assert!(map.sequence().is_empty());
    assert_eq!(fixed_blocks(&map), 0);
    for seed in [1, 2, 3] {
        let content = map.content(seed).expect("content");
        assert_eq!(content.sequence.len(), 6);
        assert_eq!(content.blocks.len(), 28);
    }
    let super_random = original("SuperRandom");
    assert_eq!(super_random.spawns().len(), 10);
    assert_eq!(super_random.content(5).expect("content").blocks.len(), 28);
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn the_blockade_variant_has_a_charging_zone_and_a_blockade() {
    let map = original("test-variants/Rainbow-with-blockade");
    assert_eq!(zone(&map, "LeftHallA").kind, ZoneKind::Charging);
    let blockade = zone(&map, "BlockadeA");
    assert_eq!(blockade.kind, ZoneKind::Blockade);
    assert_eq!(blockade.rect.centre.to_array(), [45.0, 5.0]);
    assert!(map.zone_named("RightHallA").is_none());
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn red_map_has_a_vertical_door_and_repeated_spawn_names() {
    let map = original("test-variants/red.map");
    assert_eq!(map.area().to_array(), [50.0, 50.0]);
    assert_eq!(map.sequence(), &[Colour::Red]);
    assert_eq!(fixed_blocks(&map), 1);
    let dz = &map.zones()[map.drop_zone()];
    assert_eq!(dz.doors.len(), 1);
    assert_eq!(dz.doors[0].orientation, Orientation::Vertical);
    assert_eq!(dz.doors[0].centre.to_array(), [30.0, 5.0]);
    assert!(map.spawns().iter().all(|s| s.name == "Bot"));
    assert_eq!(map.spawns().len(), 4);
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn parse_detects_the_format() {
    let xml = original_map_text("Banana");
    let from_xml = Map::parse(&format!("\n  {xml}"), "banana").expect("XML with leading whitespace");
    assert_eq!(from_xml.name(), "banana");
    assert_eq!(from_xml.zones(), original("Banana").zones());

    let native_path = format!("{}/maps/default.toml", repo_root!());
    let native = std::fs::read_to_string(&native_path).expect("maps/default.toml");
    // A native file's own name wins over the given one.
    let from_native = Map::parse(&native, "other").expect("native");
    assert_eq!(from_native, Map::from_native(&native).expect("native"));
    assert_eq!(from_native.name(), "default");

    // Without a name of its own, a native map takes the given one.
    let unnamed = from_xml.to_native().replace("name = \"banana\"\n", "");
    let renamed = Map::parse(&unnamed, "from-the-caller").expect("unnamed native");
    assert_eq!(renamed.name(), "from-the-caller");
    assert_eq!(renamed.zones(), from_xml.zones());

    // Each format's errors come through, with their own messages.
    let err = Map::parse("<newMap></newMap>", "x").expect_err("no area");
    assert!(matches!(err, MapLoadError::Xml(XmlError::Missing { element: "area", .. })), "{err:?}");
    let err = Map::parse("area = 3", "x").expect_err("bad native");
    assert!(matches!(err, MapLoadError::Native(_)), "{err:?}");
    assert!(!err.to_string().is_empty());
}

/// Banana with the first occurrence of `from` replaced by `to`; the edit must apply.
fn banana_with(from: &str, to: &str) -> String {
    let text = original_map_text("Banana");
    assert!(text.contains(from), "Banana has no '{from}'");
    text.replacen(from, to, 1)
}

fn import_error(text: &str) -> XmlError {
    Map::from_bw4t_xml(text).expect_err("should fail")
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn broken_files_give_errors_that_name_the_place() {
    let zone_a1 = "<name>RoomA1</name>";
    let cases: Vec<(String, &[&str])> = vec![
        // Line 8 holds `<name>Bot1</name>`: the close tag no longer matches.
        (banana_with("<name>Bot1</name>", "<name>Bot1</nam>"), &["not well-formed XML at line 8", "'name'"]),
        (
            banana_with("<newMap>", "<oldMap>").replace("</newMap>", "</oldMap>"),
            &["root element is <oldMap>"],
        ),
        (
            banana_with("<area>\n        <x>50.0</x>\n        <y>80.0</y>\n    </area>", ""),
            &["line 2, <newMap>: missing <area>"],
        ),
        (banana_with("<y>80.0</y>", ""), &["line 3, <area>: missing <y>"]),
        // The third zone (RoomA1) loses its name: it is named by index.
        (banana_with(zone_a1, ""), &["zone 3: missing <name>"]),
        (
            banana_with("<type>CORRIDOR</type>", "<type>LAKE</type>"),
            &["zone 'LeftHallA'", "unknown zone type 'LAKE'"],
        ),
        (
            banana_with("<blocks>GREEN</blocks>", "<blocks>PURPLE</blocks>"),
            &["zone 'RoomA1', <blocks>", "'PURPLE'"],
        ),
        (
            banana_with("<sequence>YELLOW</sequence>", "<sequence>PURPLE</sequence>"),
            &["<sequence>", "'PURPLE'"],
        ),
        (
            banana_with("<width>10.0</width>", "<width>ten</width>"),
            &["zone 'LeftHallA', <boundingbox>: <width> is 'ten', not a finite number"],
        ),
        (banana_with("<x>25.0</x>", "<x>2 5</x>"), &["entity 1 'Bot1', <position>: <x> is '2 5'"]),
        (
            banana_with("<randomBlocks>0</randomBlocks>", "<randomBlocks>-3</randomBlocks>"),
            &["<randomBlocks> is '-3', not a whole number"],
        ),
        (
            banana_with("<orientation>HORIZONTAL</orientation>", "<orientation>DIAGONAL</orientation>"),
            &["zone 'RoomA1', door 1", "unknown door orientation 'DIAGONAL'"],
        ),
        (
            banana_with("<oneBotPerCorridorZone>false", "<oneBotPerCorridorZone>maybe"),
            &["<oneBotPerCorridorZone> is 'maybe', not true or false"],
        ),
        (
            banana_with("<randomBlocks>", "<seed>x</seed><randomBlocks>"),
            &["<seed> is 'x', not a whole number"],
        ),
        (banana_with("<area>", "<area><x>1</x>"), &["<area>: <x> is given more than once"]),
        // Without <orientation>, a door in a room's corner fits two edges.
        (
            banana_with("<orientation>HORIZONTAL</orientation>", "").replacen(
                "<x>15.0</x>\n                <y>10.0</y>",
                "<x>10.0</x><y>10.0</y>",
                1,
            ),
            &["zone 'RoomA1', door 1: the door at (10, 10) needs an <orientation>"],
        ),
        // Problems found by validation come through `MapError`.
        (banana_with("<name>DropZone</name>", "<name>Drop</name>"), &["no zone named 'DropZone'"]),
        (
            banana_with("<name>RoomA2</name>", "<name>RoomA1</name>"),
            &["zone 'RoomA1': the name is already used by zone"],
        ),
    ];
    for (text, expected) in cases {
        let message = import_error(&text).to_string();
        for part in expected {
            assert!(message.contains(part), "expected '{part}' in: {message}");
        }
    }
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn error_kinds_are_distinguishable() {
    let err = import_error(&banana_with("<type>ROOM</type>", "<type>LAKE</type>"));
    assert!(matches!(&err, XmlError::ZoneType { found, .. } if found == "LAKE"), "{err:?}");
    let err = import_error(&banana_with("<blocks>GREEN</blocks>", "<blocks>PURPLE</blocks>"));
    assert!(matches!(&err, XmlError::Colour { place, .. } if place.line > 1), "{err:?}");
    let err = import_error(&banana_with("<width>10.0</width>", "<width>NaN</width>"));
    assert!(matches!(&err, XmlError::Number { element: "width", .. }), "{err:?}");
    let err = import_error(&banana_with(
        "<orientation>HORIZONTAL</orientation>",
        "<orientation>DIAGONAL</orientation>",
    ));
    assert!(matches!(&err, XmlError::Orientation { found, .. } if found == "DIAGONAL"), "{err:?}");
    let err = import_error(&banana_with("<name>DropZone</name>", "<name>Drop</name>"));
    assert!(matches!(&err, XmlError::Invalid(_)), "{err:?}");
    let err = import_error(&original_map_text("Banana")[..400]);
    assert!(matches!(&err, XmlError::Syntax { line, .. } if *line > 1), "{err:?}");
    // Blank lines before the XML declaration load, and line numbers stay those of the file.
    let text = format!("\n\n{}", banana_with("<width>10.0</width>", "<width>ten</width>"));
    let err = import_error(&text);
    assert!(matches!(&err, XmlError::Number { place, .. } if place.line == 45), "{err}");
    // It is a standard error with a source chain for validation problems.
    let boxed: Box<dyn std::error::Error> = Box::new(import_error("<newMap>"));
    assert!(!boxed.to_string().is_empty());
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn lenient_inputs_load() {
    // Whole numbers without `.0`, lower-case names, comments inside values, no orientation,
    // unknown elements.
    let text = banana_with("<x>50.0</x>", "<x>50</x>")
        .replace("<sequence>YELLOW</sequence>", "<sequence>yellow<!-- any case --></sequence>")
        .replacen("<orientation>HORIZONTAL</orientation>", "", 1)
        .replace(
            "<randomBlocks>",
            "<renderOptions><x/></renderOptions><futureField>1</futureField><randomBlocks>",
        );
    let map = Map::from_bw4t_xml(&text).expect("lenient file loads");
    assert_eq!(map.area().x, 50.0);
    assert_eq!(map.sequence(), &[Colour::Yellow; 6]);
    // The door on RoomA1's top edge gets its orientation from the edge.
    assert_eq!(zone(&map, "RoomA1").doors[0].orientation, Orientation::Horizontal);
    assert_eq!(map.zones(), original("Banana").zones());
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn neighbours_that_name_no_zone_are_dropped() {
    // Rainbow-with-blockade relies on this: it still names `RightHallA`, renamed `BlockadeA`.
    let map = original("test-variants/Rainbow-with-blockade");
    assert_eq!(zone(&map, "RightHallB").neighbours, ["FrontRoomB3", "RightHallC"]);
    let blockade = map.zone_named("BlockadeA").expect("BlockadeA");
    let right_hall_b = map.zone_named("RightHallB").expect("RightHallB");
    assert!(map.neighbours(right_hall_b).contains(&blockade), "the blockade's own list still links it");

    let text = banana_with("<neighbours>LeftHallB</neighbours>", "<neighbours>Nowhere</neighbours>");
    let map = Map::from_bw4t_xml(&text).expect("a dangling neighbour is not an error");
    assert_eq!(zone(&map, "LeftHallA").neighbours, ["FrontRoomA1"]);
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn every_original_map_checks_without_errors() {
    for (file, ..) in ORIGINALS {
        let found = problems(&original_map_text(file), None);
        let expected: &[&str] = match file {
            // The variant renamed RightHallA to BlockadeA but two lists still name it.
            "test-variants/Rainbow-with-blockade" => &[
                "warning: zone 'FrontRoomA3': neighbour 'RightHallA' (line 160) is not a zone; it is ignored",
                "warning: zone 'RightHallB': neighbour 'RightHallA' (line 185) is not a zone; it is ignored",
            ],
            _ => &[],
        };
        let found: Vec<String> = found.iter().map(Problem::to_string).collect();
        assert_eq!(found, expected, "{file}");
    }
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn map_import_writes_native_maps_that_check_clean_and_equal_the_original() {
    let dir = temp_dir("import-originals");
    for (file, ..) in ORIGINALS {
        let source = original_map_path(file);
        let source = path_str(&source);
        let stem = Path::new(source).file_stem().and_then(|s| s.to_str()).expect("stem").to_string();
        let out_path = dir.join(format!("{stem}.toml"));
        let out = bw4t(&["map", "import", source, "-o", path_str(&out_path)]);
        assert!(out.status.success(), "{file}: {}", stderr(&out));
        if file.ends_with("Rainbow-with-blockade") {
            assert!(stderr(&out).contains("neighbour 'RightHallA' (line 160) is not a zone; it is ignored"));
        } else {
            assert_eq!(stderr(&out), "", "{file}");
        }
        let check = bw4t(&["map", "check", path_str(&out_path)]);
        assert!(check.status.success(), "{file}: {}", stdout(&check));
        assert_eq!(stdout(&check), format!("{}: ok\n", path_str(&out_path)), "{file}");
        let imported = Map::from_native(&read(path_str(&out_path))).expect("native map");
        let original = Map::parse(&read(source), &stem).expect("original");
        assert_eq!(imported, original, "{file}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The original maps and the two shipped maps that share their layout.
fn originals_and_default_maps() -> Vec<(String, Map)> {
    let mut maps: Vec<(String, Map)> =
        ["default", "fixed"].iter().map(|n| (n.to_string(), shipped_map(n))).collect();
    maps.extend(ORIGINALS.iter().map(|(file, ..)| (file.to_string(), original(file))));
    maps
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn the_cooperative_team_completes_every_original_map_with_one_to_ten_robots() {
    for (name, map) in originals_and_default_maps() {
        let ticks =
            ticks_to_complete(&name, &map, Strategy::Cooperative, &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10], 4);
        assert!(!ticks.is_empty());
    }
}

#[test]
#[ignore = "needs BW4T_ORIGINAL_MAPS (the original BW4T map folder)"]
fn on_the_original_maps_the_baseline_completes_too_but_teamwork_is_faster() {
    let (mut coop_total, mut baseline_total) = (0, 0);
    for (name, map) in originals_and_default_maps() {
        let baseline = ticks_to_complete(&name, &map, Strategy::Baseline, &[1, 3, 10], 2);
        let coop = ticks_to_complete(&name, &map, Strategy::Cooperative, &[1, 3, 10], 2);
        baseline_total += baseline.iter().sum::<u64>();
        coop_total += coop.iter().sum::<u64>();
    }
    assert!(
        coop_total * 10 < baseline_total * 8,
        "coop {coop_total} ticks in all, baseline {baseline_total}"
    );
}
