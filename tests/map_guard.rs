use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

use serde_json::Value;

/// How long one command may take before it counts as hung (or as playing a whole match).
const LIMIT: Duration = Duration::from_secs(60);

/// Address space given to a command that must refuse a map before allocating for it, in
/// KiB: far more than a refusal needs, far less than the gigabytes the map asks for.
const MEMORY_KIB: u64 = 1_500_000;

/// A small map that checks clean: a hall over two rooms, one red block, one spawn point.
const BASE: &str = r#"
name = "guard"
area = [30, 30]
sequence = ["Red"]

[[spawn]]
name = "Bot1"
at = [5, 5]

[[zone]]
name = "Hall"
type = "corridor"
centre = [15, 5]
size = [30, 10]
neighbours = ["RoomA", "DropZone"]

[[zone]]
name = "RoomA"
type = "room"
centre = [7.5, 15]
size = [10, 10]
doors = [[7.5, 10]]
blocks = ["Red"]

[[zone]]
name = "DropZone"
type = "room"
centre = [22.5, 15]
size = [10, 10]
doors = [[22.5, 10]]
"#;

/// The base map with each `(from, to)` applied once; every edit must apply.
fn edited(edits: &[(&str, &str)]) -> String {
    edits.iter().fold(BASE.to_string(), |text, (from, to)| {
        assert!(text.contains(from), "the base map has no '{from}'");
        text.replacen(from, to, 1)
    })
}

/// The map as an original BW4T XML file, with `random_sequence` random sequence colours.
fn xml_map(random_sequence: &str) -> String {
    let point = |x: &str, y: &str| format!("<x>{x}</x><y>{y}</y>");
    let zone = |name: &str, kind: &str, centre: (&str, &str), size: (&str, &str), rest: &str| {
        format!(
            "<zones><name>{name}</name><type>{kind}</type><boundingbox>{}<width>{}</width><height>{}</height></boundingbox>{rest}</zones>\n",
            point(centre.0, centre.1),
            size.0,
            size.1
        )
    };
    let door = |x: &str| {
        format!("<doors><position>{}</position><orientation>HORIZONTAL</orientation></doors>", point(x, "10"))
    };
    format!(
        "<newMap>\n<area>{}</area>\n<entities><name>Bot1</name><position>{}</position></entities>\n<randomBlocks>0</randomBlocks>\n<randomSequence>{random_sequence}</randomSequence>\n<sequence>RED</sequence>\n{}{}{}</newMap>\n",
        point("30", "30"),
        point("5", "5"),
        zone(
            "Hall",
            "CORRIDOR",
            ("15", "5"),
            ("30", "10"),
            "<neighbours>RoomA</neighbours><neighbours>DropZone</neighbours>"
        ),
        zone("RoomA", "ROOM", ("7.5", "15"), ("10", "10"), &format!("{}<blocks>RED</blocks>", door("7.5"))),
        zone("DropZone", "ROOM", ("22.5", "15"), ("10", "10"), &door("22.5")),
    )
}

/// A fresh temporary directory for one test.
fn temp(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bw4t-map-guard-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write map");
    path.to_string_lossy().into_owned()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Runs `command` to its end, failing the test if it takes longer than [`LIMIT`] (the
/// process is then killed).
fn finish(command: Command, what: &str) -> Output {
    crate::util::output_within(command, LIMIT, what)
}

fn bw4t(args: &[&str]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_bw4t"));
    command.args(args);
    finish(command, &format!("bw4t {args:?}"))
}

/// `bw4t ARGS` with its address space limited to [`MEMORY_KIB`], so that a large
/// allocation aborts it instead of taking the machine's memory.
fn bw4t_in_little_memory(args: &[&str]) -> Output {
    let mut command = Command::new("sh");
    command
        .arg("-c")
        .arg(format!("ulimit -v {MEMORY_KIB} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_bw4t"))
        .args(args);
    finish(command, &format!("bw4t {args:?} in {MEMORY_KIB} KiB"))
}

/// The error lines `bw4t map check` prints for `file`; there must be some.
fn check_errors(file: &str) -> Vec<String> {
    let out = bw4t(&["map", "check", file]);
    assert!(!out.status.success(), "map check passed {file}: {}", text(&out.stdout));
    let errors: Vec<String> = text(&out.stdout)
        .lines()
        .filter(|l| l.starts_with(&format!("{file}: error: ")))
        .map(String::from)
        .collect();
    assert!(!errors.is_empty(), "no error lines: {}", text(&out.stdout));
    errors
}

/// Asserts `out` failed before playing, with every error `bw4t map check` gives for `file`.
fn refused_like_map_check(out: &Output, file: &str, what: &str) {
    let err = text(&out.stderr);
    assert!(!out.status.success(), "{what}: exit 0 on a map the check rejects; stderr: {err}");
    for line in check_errors(file) {
        assert!(err.contains(&line), "{what}: expected the check's '{line}' in: {err}");
    }
    assert!(!err.contains("bw4t: map '"), "{what}: a match was set up: {err}");
}

#[test]
fn the_base_maps_check_clean() {
    let dir = temp("base");
    for (name, map) in [("base.toml", BASE.to_string()), ("base.xml", xml_map("0"))] {
        let file = write(&dir, name, &map);
        let out = bw4t(&["map", "check", &file]);
        assert_eq!(text(&out.stdout), format!("{file}: ok\n"), "{}", text(&out.stderr));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn huge_random_content_is_refused_before_anything_is_allocated() {
    let dir = temp("huge");
    let native = write(
        &dir,
        "huge.toml",
        &edited(&[("sequence = [\"Red\"]", "sequence = [\"Red\"]\nrandom_sequence = 4000000000")]),
    );
    let xml = write(&dir, "huge.xml", &xml_map("4000000000"));
    let blocks = write(
        &dir,
        "blocks.toml",
        &edited(&[("sequence = [\"Red\"]", "sequence = [\"Red\"]\nrandom_blocks = 4000000000")]),
    );
    for file in [&native, &xml, &blocks] {
        let errors = check_errors(file);
        assert!(
            errors.iter().any(|e| e.contains("random content: 4000000000 random blocks, but the rooms")),
            "{errors:?}"
        );
        let out = bw4t_in_little_memory(&["run", "--map", file, "--robots", "1", "--seed", "1"]);
        refused_like_map_check(&out, file, "run");
    }
    let out =
        bw4t_in_little_memory(&["serve", "--map", &native, "--port", "0", "--robots", "1", "--seed", "1"]);
    refused_like_map_check(&out, &native, "serve");
    assert!(!text(&out.stdout).contains("listening on"), "serve listened: {}", text(&out.stdout));
    let _ = std::fs::remove_dir_all(&dir);
}

/// One unplayable variant of the base map per error of finding 13, with the check's words.
fn unplayable() -> Vec<(&'static str, String, &'static str)> {
    vec![
        (
            "doorless",
            edited(&[("doors = [[7.5, 10]]\n", "")]),
            "zone 'RoomA': no robot can reach it from the spawn points (it has no doors)",
        ),
        (
            "unreachable",
            edited(&[(r#"neighbours = ["RoomA", "DropZone"]"#, r#"neighbours = ["DropZone"]"#)]),
            "zone 'RoomA': no robot can reach it from the spawn points (it has no neighbours)",
        ),
        (
            "overlapping",
            edited(&[
                ("centre = [7.5, 15]", "centre = [15, 15]"),
                ("doors = [[7.5, 10]]", "doors = [[15, 10]]"),
            ]),
            "zone 'DropZone': overlaps zone 'RoomA'",
        ),
        (
            "short",
            edited(&[(r#"sequence = ["Red"]"#, r#"sequence = ["Red", "Red"]"#)]),
            "sequence: needs 2 Red blocks, the map has 1",
        ),
    ]
}

#[test]
fn run_refuses_every_map_the_check_rejects_with_the_checks_errors() {
    let dir = temp("run");
    for (name, map, expected) in unplayable() {
        let file = write(&dir, &format!("{name}.toml"), &map);
        let errors = check_errors(&file);
        assert!(errors.iter().any(|e| e.ends_with(expected)), "{name}: {errors:?}");
        let out = bw4t(&["run", "--map", &file, "--robots", "1", "--seed", "1", "--max-ticks", "100"]);
        refused_like_map_check(&out, &file, &format!("run on {name}"));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn serve_and_tournament_refuse_a_map_the_check_rejects() {
    let dir = temp("serve");
    for (name, map, _) in unplayable().into_iter().step_by(3) {
        let file = write(&dir, &format!("{name}.toml"), &map);
        let out = bw4t(&["serve", "--map", &file, "--port", "0", "--robots", "1", "--seed", "1"]);
        refused_like_map_check(&out, &file, &format!("serve on {name}"));
        assert!(!text(&out.stdout).contains("listening on"), "serve listened: {}", text(&out.stdout));

        let out_dir = dir.join(format!("tournament-{name}"));
        let out = bw4t(&[
            "tournament",
            "--map",
            &file,
            "--team",
            "coop=builtin",
            "--robots",
            "1",
            "--seeds",
            "1",
            "--max-ticks",
            "100",
            "--out",
            &out_dir.to_string_lossy(),
        ]);
        refused_like_map_check(&out, &file, &format!("tournament on {name}"));
        assert!(!out_dir.join("matches.jsonl").exists(), "tournament on {name} played matches");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_replay_whose_map_the_check_rejects_is_refused() {
    let dir = temp("replay");
    let replay = dir.join("r.jsonl");
    let out = bw4t(&[
        "run",
        "--map",
        "fixed",
        "--seed",
        "1",
        "--max-ticks",
        "5",
        "--replay",
        &replay.to_string_lossy(),
    ]);
    // 5 ticks do not complete the sequence: exit status 3, but the replay is written.
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    let recorded = std::fs::read_to_string(&replay).expect("replay");
    let (first, rest) = recorded.split_once('\n').expect("a header line");
    let mut header: Value = serde_json::from_str(first).expect("header");
    let map = header["map_native"].as_str().expect("map_native").to_string();
    let door = "doors = [{ at = [15, 10], orientation = \"horizontal\" }]\n";
    assert!(map.contains(door), "{map}");
    header["map_native"] = Value::String(map.replacen(door, "", 1));
    std::fs::write(&replay, format!("{header}\n{rest}")).expect("write replay");
    for command in ["verify", "show"] {
        let out = bw4t(&["replay", command, &replay.to_string_lossy()]);
        let err = text(&out.stderr);
        assert!(!out.status.success(), "replay {command}: exit 0 on a doorless room");
        assert!(
            err.contains("zone 'RoomA1': no robot can reach it from the spawn points (it has no doors)"),
            "replay {command}: {err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn warnings_are_printed_and_the_match_is_played() {
    let dir = temp("warn");
    let file = write(
        &dir,
        "warned.toml",
        &edited(&[(r#"["RoomA", "DropZone"]"#, r#"["RoomA", "DropZone", "Hall"]"#)]),
    );
    let warning = format!("{file}: warning: zone 'Hall': names itself as a neighbour");
    let out = bw4t(&["map", "check", &file]);
    assert!(out.status.success() && text(&out.stdout).contains(&warning), "{}", text(&out.stdout));
    let out = bw4t(&["run", "--map", &file, "--robots", "1", "--seed", "1"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains(&warning), "{}", text(&out.stderr));
    assert!(text(&out.stdout).starts_with("completed"), "{}", text(&out.stdout));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn numbers_out_of_range_are_named_with_the_allowed_range() {
    let dir = temp("range");
    let range = "is out of range (coordinates and sizes must be from -10000 to 10000)";
    let cases = [
        (
            "size.toml",
            edited(&[("size = [30, 10]", "size = [1e300, 10]")]),
            format!("zone 'Hall': size width: 1e300 {range}"),
        ),
        (
            "area.toml",
            edited(&[("area = [30, 30]", "area = [30, 20000]")]),
            format!("area height: 20000 {range}"),
        ),
        (
            "spawn.toml",
            edited(&[("at = [5, 5]", "at = [-1e12, 5]")]),
            format!("spawn 1 'Bot1': at x: -1e12 {range}"),
        ),
        (
            "door.toml",
            edited(&[("doors = [[22.5, 10]]", "doors = [[22.5, inf]]")]),
            format!("zone 'DropZone': door 1 y: inf {range}"),
        ),
        (
            "box.xml",
            xml_map("0").replacen("<x>15</x>", "<x>1e300</x>", 1),
            format!("zone 'Hall', <boundingbox>: <x>: 1e300 {range}"),
        ),
    ];
    for (name, map, expected) in cases {
        let file = write(&dir, name, &map);
        for args in [vec!["map", "check", &file], vec!["run", "--map", &file, "--robots", "1"]] {
            let out = bw4t(&args);
            let said = text(&out.stdout) + &text(&out.stderr);
            assert!(!out.status.success(), "{args:?} passed");
            assert!(said.contains(&expected), "{args:?}: expected '{expected}' in: {said}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn generated_maps_name_rows_past_z_with_two_letters() {
    let hall_names = |rooms: &str| -> Vec<String> {
        let out = bw4t(&["map", "generate", "--rooms", rooms, "--robots", "3"]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let map = bw4t_map::Map::from_native(&text(&out.stdout)).expect("a valid map");
        map.zones().iter().filter_map(|z| z.name.strip_prefix("LeftHall")).map(String::from).collect()
    };
    // Up to 25 rows, names stay as they were: one letter per row, and one for the halls below.
    let letters: Vec<String> = ('A'..='Z').map(String::from).collect();
    assert_eq!(hall_names("25x1"), letters);
    let mut expected = letters.clone();
    expected.push("AA".into());
    assert_eq!(hall_names("26x1"), expected);
    expected.extend(["AB", "AC", "AD"].map(String::from));
    assert_eq!(hall_names("29x1"), expected);

    let dir = temp("generate");
    let file = dir.join("g.toml");
    let out = bw4t(&["map", "generate", "--rooms", "30x2", "--robots", "3", "-o", &file.to_string_lossy()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = bw4t(&["map", "check", &file.to_string_lossy()]);
    assert!(out.status.success(), "{}", text(&out.stdout));
    assert!(std::fs::read_to_string(&file).expect("read").contains("name = \"RoomAD2\""));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The value of attribute `name` in the tag `tag`.
fn attribute(tag: &str, name: &str) -> f32 {
    let start =
        tag.find(&format!(" {name}=\"")).unwrap_or_else(|| panic!("no {name} in {tag}")) + name.len() + 3;
    let end = tag[start..].find('"').expect("closing quote") + start;
    tag[start..end].parse().unwrap_or_else(|e| panic!("{name} in {tag}: {e}"))
}

/// (min x, min y, max x, max y)
type Box2 = (f32, f32, f32, f32);

fn overlap(a: Box2, b: Box2) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// Every zone label of `svg` (its text and the box it covers: about 0.6 em per character,
/// one em high, centred 0.35 em above the baseline) and every spawn marker's box.
fn labels_and_spawns(svg: &str) -> (Vec<(String, Box2)>, Vec<Box2>) {
    let mut labels = Vec::new();
    let mut spawns = Vec::new();
    for line in svg.lines() {
        if let Some(rest) = line.strip_prefix("<text class=\"label\"") {
            let (tag, name) = rest.split_once('>').expect("text content");
            let name = name.trim_end_matches("</text>").to_string();
            let (x, y, size) = (attribute(tag, "x"), attribute(tag, "y"), attribute(tag, "font-size"));
            let (half_width, centre) = (0.3 * size * name.chars().count() as f32, y - 0.35 * size);
            labels.push((name, (x - half_width, centre - size / 2.0, x + half_width, centre + size / 2.0)));
        } else if line.starts_with("<rect class=\"spawn\"") {
            let (x, y) = (attribute(line, "x"), attribute(line, "y"));
            spawns.push((x, y, x + attribute(line, "width"), y + attribute(line, "height")));
        }
    }
    (labels, spawns)
}

#[test]
fn spawn_markers_never_cover_a_zone_label() {
    let dir = temp("labels");
    let generated = dir.join("g.toml");
    let out =
        bw4t(&["map", "generate", "--rooms", "2x4", "--robots", "30", "-o", &generated.to_string_lossy()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    for map in ["default".to_string(), "crowd24".to_string(), generated.to_string_lossy().into_owned()] {
        let out = bw4t(&["map", "render", &map, "--seed", "1"]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let (labels, spawns) = labels_and_spawns(&text(&out.stdout));
        assert!(labels.iter().any(|(name, _)| name == "FrontDropZone"), "{map}: no FrontDropZone label");
        assert!(!spawns.is_empty(), "{map}: no spawn markers");
        for (name, label) in &labels {
            if let Some(spawn) = spawns.iter().find(|s| overlap(*label, **s)) {
                panic!("{map}: the label {name} at {label:?} is under the spawn marker at {spawn:?}");
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
