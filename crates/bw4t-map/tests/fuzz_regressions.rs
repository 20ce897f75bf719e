//! Inputs the fuzz targets (`fuzz/`) found to crash or exhaust memory, kept as test cases.

use std::process::Command;

use bw4t_map::{ContentError, Map};

/// Set in the child process that runs a case under a memory limit.
const CHILD: &str = "BW4T_MAP_TEST_MEMORY_LIMITED";

/// Address space the child may use: far above what these cases need, far below what the
/// bugs allocated (gigabytes), so a regression aborts the child instead of passing slowly.
const LIMIT_KB: u64 = 1024 * 1024;

/// Runs `case` in a copy of this test binary limited to [`LIMIT_KB`] of address space and
/// fails if it does not succeed there. Only Unix has `ulimit`; elsewhere it runs directly.
fn with_memory_limit(test_name: &str, case: fn()) {
    if std::env::var_os(CHILD).is_some() || !cfg!(unix) {
        case();
        return;
    }
    let exe = std::env::current_exe().expect("the test binary's path");
    let status = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {LIMIT_KB} && exec \"$0\" --exact \"$1\" --test-threads 1"))
        .arg(exe)
        .arg(test_name)
        .env(CHILD, "1")
        .status()
        .expect("run the test binary under sh");
    assert!(status.success(), "{test_name} failed under a {LIMIT_KB} KiB address-space limit: {status}");
}

/// fuzz/map_xml: a map asking for 4,000,000,000 random sequence colours drew and held
/// every colour (4 GB) before finding that no room has space for their blocks.
const HUGE_RANDOM_SEQUENCE_XML: &str = r#"<newMap><area><x>20</x><y>20</y></area>
<entities><name>Bot1</name><position><x>5</x><y>15</y></position></entities>
<zones><name>DropZone</name><type>ROOM</type><boundingbox><x>10</x><y>5</y><width>20</width><height>10</height></boundingbox><neighbours>DropZone</neighbours><blocks>RED</blocks></zones>
<randomSequence>4000000000</randomSequence>
</newMap>
"#;

/// The same map in the native format, with the largest count it can hold.
const HUGE_RANDOM_SEQUENCE_TOML: &str = r#"area = [20, 20]
random_sequence = 4294967295
[[spawn]]
name = "Bot1"
at = [5, 15]
[[zone]]
name = "DropZone"
type = "room"
centre = [10, 5]
size = [20, 10]
blocks = ["Red"]
"#;

/// Reading such a map is refused, before anything is drawn, with the error `map check`
/// gives for it (the limit is part of the map's validity, not of drawing its content).
#[test]
fn huge_random_sequence_is_refused_before_allocating() {
    with_memory_limit("huge_random_sequence_is_refused_before_allocating", || {
        for (text, count) in
            [(HUGE_RANDOM_SEQUENCE_XML, "4000000000"), (HUGE_RANDOM_SEQUENCE_TOML, "4294967295")]
        {
            let refused =
                Map::parse(text, "huge").expect_err("too many random blocks for the rooms").to_string();
            let expected =
                format!("{count} random blocks, but the rooms (other than the drop zone) have space for 0");
            assert!(refused.contains(&expected), "refused for another reason: {refused}");
            let problems = bw4t_map::check_text(text, "huge", None).expect("the file reads");
            assert!(
                problems.iter().any(|p| p.is_error() && p.to_string().contains(&expected)),
                "map check gives the same error: {problems:?}"
            );
        }
    });
}

/// fuzz/map_xml: a spawn point at y = 6e28 was written by `to_native` as the integer
/// 60000000000000000000000000000, which TOML cannot hold, so the map did not read back.
/// Coordinates are now bounded when read; within the bounds every number round-trips.
const HUGE_COORDINATE_XML: &str = r#"<newMap><area><x>50.0</x><y>70.0</y></area>
<entities><name>Bot1</name><position><x>25.0</x><y>55.0</y></position><type>NORMAL</type></entities>
<entities><name>Bot4DropZone</name><position><x>15.0</x><y>59999999999999999999999999995.0</y></position><type>NORMAL</type></entities>
<zones><name>Hall</name><type>CORRIDOR</type><boundingbox><x>25</x><y>55</y><width>30</width><height>10</height></boundingbox><neighbours>DropZone</neighbours></zones>
<zones><name>DropZone</name><type>ROOM</type><boundingbox><x>25</x><y>65</y><width>20</width><height>10</height></boundingbox><doors><position><x>25</x><y>60</y></position><orientation>HORIZONTAL</orientation></doors><blocks>RED</blocks></zones>
<sequence>RED</sequence>
</newMap>
"#;

#[test]
fn coordinates_out_of_range_are_refused_and_those_within_round_trip() {
    let refused = Map::from_bw4t_xml(HUGE_COORDINATE_XML).expect_err("y = 6e28 is out of range").to_string();
    assert!(refused.contains("Bot4DropZone") && refused.contains("6e28 is out of range"), "{refused}");
    let in_range = HUGE_COORDINATE_XML.replace("59999999999999999999999999995.0", "45.0");
    let map = Map::from_bw4t_xml(&in_range).expect("the map is valid");
    // Every number the writer may meet within the bounds: whole or not, at the edges.
    let max = bw4t_map::MAX_COORDINATE;
    for y in [max, -max, max - 0.5, 9_999.999, 1e-7, -1e-7, 0.5, 3.0, 0.0, -0.0, 1234.567] {
        let mut parts = map.parts().clone();
        parts.spawns[1].pos.y = y;
        let map = Map::new(parts).expect("still valid");
        let written = map.to_native();
        let again = Map::from_native(&written).unwrap_or_else(|e| panic!("y = {y}: {e}\n{written}"));
        assert_eq!(again.spawns()[1].pos.y.to_bits(), y.to_bits(), "y = {y} reads back bit for bit");
    }
}

/// A native map (`maps/side-doors.toml`, cut down) whose room `RoomE3` has the `centre`,
/// `size` and `doors` given and holds the fixed `blocks`.
fn side_room_map(centre: &str, size: &str, doors: &str, blocks: &str) -> String {
    format!(
        r#"area = [50, 70]
[[spawn]]
name = "Bot1"
at = [25, 55]
[[zone]]
name = "Hall3"
type = "corridor"
centre = [25, 35]
size = [10, 10]
neighbours = ["RoomE3", "DropZone"]
[[zone]]
name = "RoomE3"
type = "room"
centre = {centre}
size = {size}
doors = {doors}
blocks = {blocks}
[[zone]]
name = "DropZone"
type = "room"
centre = [25, 65]
size = [20, 10]
doors = [[25, 60]]
"#
    )
}

/// fuzz/map_native: a room of size `[10, 101e38]` (infinite as an `f32`) left every random
/// spot undefined, and the scan for a free one overflowed counting its grid rows (a panic
/// in debug builds). A room too large for its coordinates' precision would scan billions of
/// identical points. Either the map is refused when read, or its content fails cleanly.
#[test]
fn rooms_too_large_for_their_coordinates_get_no_blocks_without_panic() {
    let cases = [
        ("[35, 35]", "[10, 101e38]", "[[30, 35]]", r#"["Red", "Blue"]"#),
        // Finite, but 1e23 is below the spacing of f32 values near 1e30: 3 distinct spots.
        ("[35, 1e30]", "[1, 1e23]", "[]", r#"["Red", "Blue", "Green", "White", "Pink"]"#),
    ];
    for (centre, size, doors, blocks) in cases {
        let map = match Map::from_native(&side_room_map(centre, size, doors, blocks)) {
            Ok(map) => map,
            Err(refused) => {
                assert!(refused.to_string().contains("RoomE3"), "refused for another reason: {refused}");
                continue;
            }
        };
        for seed in [1, 2, 3] {
            assert_eq!(map.content(seed), Err(ContentError::RoomFull("RoomE3".into())), "size {size}");
        }
    }
}
