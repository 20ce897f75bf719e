//! Map tools: `check`, `render`, `show` and `import`, through the library and the binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use bw4t_map::{Map, Problem, Severity, check_parts, check_text, parse_parts, render_svg};

use crate::util::{fixture_path, fixture_text};

pub fn read(path: &str) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn fixed_text() -> String {
    read(&format!("{}/maps/fixed.toml", repo_root!()))
}

pub fn bw4t(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bw4t")).args(args).output().expect("run bw4t")
}

pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

pub fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bw4t-map-tools-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

pub fn path_str(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// `maps/fixed.toml` with each `(from, to)` replaced; every `from` must occur.
fn edited(edits: &[(&str, &str)]) -> String {
    let mut text = fixed_text();
    for (from, to) in edits {
        assert!(text.contains(from), "fixed.toml has no {from:?}");
        text = text.replacen(from, to, 1);
    }
    text
}

/// `maps/fixed.toml` without its spawn points.
fn without_spawns() -> String {
    let text = fixed_text();
    let (start, end) = (text.find("[[spawn]]").expect("spawns"), text.find("[[zone]]").expect("zones"));
    format!("{}{}", &text[..start], &text[end..])
}

pub fn problems(text: &str, robots: Option<usize>) -> Vec<Problem> {
    check_text(text, "edited", robots).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

fn listed(problems: &[Problem]) -> String {
    problems.iter().map(|p| format!("\n  {p}")).collect()
}

/// The well-formed map fixtures in the original BW4T format.
pub const XML_FIXTURES: [&str; 4] = [
    "bw4t-xml/fixed-content.xml",
    "bw4t-xml/fixed-content-lenient.xml",
    "bw4t-xml/random-content.xml",
    "bw4t-xml/small.xml",
];

/// The one problem of the lenient fixture: a neighbour that names no zone (it is dropped).
const LENIENT_WARNING: &str =
    "warning: zone 'MidHall': neighbour 'EastHall' (line 50) is not a zone; it is ignored";

#[test]
fn every_fixture_and_shipped_map_checks_as_expected() {
    for file in XML_FIXTURES {
        let found: Vec<String> = problems(&fixture_text(file), None).iter().map(Problem::to_string).collect();
        let expected: &[&str] = if file.ends_with("-lenient.xml") { &[LENIENT_WARNING] } else { &[] };
        assert_eq!(found, expected, "{file}");
    }
    for name in ["default", "fixed"] {
        let text = read(&format!("{}/maps/{name}.toml", repo_root!()));
        let found = problems(&text, Some(12));
        assert!(found.is_empty(), "{name}:{}", listed(&found));
    }
}

#[test]
fn map_check_names_the_problem_of_every_broken_fixture() {
    let dir = fixture_path("bw4t-xml/broken");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .expect("broken fixtures")
        .map(|e| path_str(&e.expect("entry").path()).to_string())
        .collect();
    files.sort();
    assert!(files.len() >= 30, "{} broken fixtures", files.len());
    let mut args = vec!["map", "check"];
    args.extend(files.iter().map(String::as_str));
    let out = bw4t(&args);
    assert!(!out.status.success(), "{}", stdout(&out));
    let text = stdout(&out);
    for file in &files {
        assert!(text.contains(&format!("{file}: error: ")), "no error for {file} in:\n{text}");
    }
    assert!(
        stderr(&out).contains(&format!("{0} of {0} maps failed the check", files.len())),
        "{}",
        stderr(&out)
    );
    // Read to report everything, a door at a corner without orientation is one problem
    // among others rather than the end of the file.
    let corner = path_str(&dir.join("door-at-corner-without-orientation.xml")).to_string();
    assert!(
        text.contains(&format!(
            "{corner}: error: zone 'RoomA', door 1: door at (10, 0) is at a corner of the room: its orientation must be given"
        )),
        "{text}"
    );
}

/// One broken (or odd) copy of `maps/fixed.toml` per check: the edits, the robots asked
/// for, and the problem expected among those reported (the message is matched by prefix).
struct Case {
    edits: Vec<(&'static str, &'static str)>,
    robots: Option<usize>,
    severity: Severity,
    place: &'static str,
    message: &'static str,
}

fn case(
    edits: &[(&'static str, &'static str)],
    severity: Severity,
    place: &'static str,
    message: &'static str,
) -> Case {
    Case { edits: edits.to_vec(), robots: None, severity, place, message }
}

fn cases() -> Vec<Case> {
    use Severity::{Error, Warning};
    let robots = Case { robots: Some(13), ..case(&[], Error, "spawn points", "12 for 13 robots") };
    vec![
        case(
            &[(r#"["RoomA1", "FrontA2", "LeftHallA"]"#, r#"["RoomA1", "FrontA2", "LeftHall"]"#)],
            Error,
            "zone 'FrontA1'",
            "neighbour 'LeftHall' is not a zone",
        ),
        case(
            &[(r#"name = "RoomA2""#, r#"name = "RoomA1""#)],
            Error,
            "zone 'RoomA1'",
            "the name is already used by zone 6",
        ),
        case(&[("centre = [25, 15]", "centre = [22, 15]")], Error, "zone 'RoomA2'", "overlaps zone 'RoomA1'"),
        case(
            &[("doors = [[15, 10]]", "doors = [[15, 17]]")],
            Error,
            "zone 'RoomA1'",
            "door at (15, 17) is not on the room's edge",
        ),
        case(
            &[("doors = [[15, 10]]", r#"doors = [{ at = [15, 10], orientation = "vertical" }]"#)],
            Error,
            "zone 'RoomA1'",
            "door at (15, 10) is vertical but lies on the room's top or bottom edge",
        ),
        case(
            &[("doors = [[15, 10]]", "doors = [[10, 10]]")],
            Error,
            "zone 'RoomA1'",
            "door at (10, 10) is at a corner of the room",
        ),
        case(
            &[(
                "name = \"FrontA1\"\ntype = \"corridor\"",
                "name = \"FrontA1\"\ntype = \"corridor\"\ndoors = [[15, 10]]",
            )],
            Error,
            "zone 'FrontA1'",
            "only rooms have doors, this is a corridor",
        ),
        case(
            &[(
                "name = \"FrontA2\"\ntype = \"corridor\"",
                "name = \"FrontA2\"\ntype = \"corridor\"\nblocks = [\"Red\"]",
            )],
            Error,
            "zone 'FrontA2'",
            "only rooms hold blocks, this is a corridor",
        ),
        case(&[(r#"name = "DropZone""#, r#"name = "Drop""#)], Error, "drop zone", "no zone named 'DropZone'"),
        case(
            &[(r#"name = "RoomC3""#, r#"name = "DropZone""#)],
            Error,
            "drop zone",
            "2 zones are named 'DropZone'",
        ),
        case(
            &[("name = \"DropZone\"\ntype = \"room\"", "name = \"DropZone\"\ntype = \"corridor\"")],
            Error,
            "zone 'DropZone'",
            "the drop zone must be a room, not a corridor",
        ),
        case(
            &[
                (r#"["RoomC3", "FrontC2", "RightHallC"]"#, r#"["FrontC2", "RightHallC"]"#),
                ("neighbours = [\"FrontC3\"]", "neighbours = []"),
            ],
            Error,
            "zone 'RoomC3'",
            "no robot can reach it from the spawn points (it has no neighbours)",
        ),
        case(
            &[("doors = [[25, 70]]\n", "")],
            Error,
            "zone 'DropZone'",
            "no robot can reach it from the spawn points (it has no doors)",
        ),
        // A blockade is never passable: the room behind it is cut off.
        case(
            &[("name = \"FrontC3\"\ntype = \"corridor\"", "name = \"FrontC3\"\ntype = \"blockade\"")],
            Error,
            "zone 'RoomC3'",
            "no robot can reach it from the spawn points",
        ),
        case(
            &[(r#"sequence = ["Yellow", "Red""#, r#"sequence = ["Yellow", "Yellow", "Yellow", "Red""#)],
            Error,
            "sequence",
            "needs 3 Yellow blocks, the map has 2",
        ),
        robots,
        case(
            &[(
                r#"blocks = ["Red", "Blue"]"#,
                r#"blocks = ["Red", "Blue", "Red", "Red", "Red", "Red", "Red", "Red", "Red", "Red", "Red"]"#,
            )],
            Error,
            "zone 'RoomA1'",
            "11 blocks, at most 10 fit in a room",
        ),
        case(&[("area = [50, 80]", "area = [0, 80]")], Error, "area", "0 x 80 is not positive"),
        case(
            &[("size = [10, 10]", "size = [0, 10]")],
            Error,
            "zone 'FrontA1'",
            "size 0 x 10 is not positive",
        ),
        case(
            &[("random_blocks = 0", "random_blocks = 100")],
            Error,
            "random content",
            "100 random blocks, but the rooms (other than the drop zone) have space for 73",
        ),
        // Warnings: the map loads and plays, but something looks unintended.
        case(
            &[("centre = [45, 5]", "centre = [145, 5]")],
            Warning,
            "zone 'RightHallA'",
            "lies outside the area (50 x 80)",
        ),
        case(
            &[("area = [50, 80]", "area = [50, 78]")],
            Warning,
            "zone 'DropZone'",
            "extends beyond the area (50 x 78)",
        ),
        case(&[("at = [25, 65]", "at = [8, 57.5]")], Warning, "spawn 1 'Bot1'", "at (8, 57.5) is in no zone"),
        case(
            &[("at = [25, 65]", "at = [15, 15]")],
            Warning,
            "spawn 1 'Bot1'",
            "at (15, 15) is inside room 'RoomA1', which holds one robot at a time",
        ),
        case(
            &[
                ("name = \"RightHallD\"\ntype = \"corridor\"", "name = \"RightHallD\"\ntype = \"blockade\""),
                ("at = [37, 65]", "at = [45, 65]"),
            ],
            Warning,
            "spawn 11 'Bot11'",
            "at (45, 65) is inside blockade 'RightHallD': the robot cannot move",
        ),
        case(
            &[("at = [21, 63]", "at = [24, 64]")],
            Warning,
            "spawn 2 'Bot2'",
            "at (24, 64) overlaps spawn 1 'Bot1'",
        ),
        case(
            &[(r#"["RoomA1", "FrontA2", "LeftHallA"]"#, r#"["RoomA1", "FrontA2", "LeftHallA", "FrontB1"]"#)],
            Warning,
            "zone 'FrontA1'",
            "the way to neighbour 'FrontB1' goes through the walls of zone 'RoomA1'",
        ),
        case(
            &[("neighbours = [\"FrontA1\"]", "neighbours = [\"FrontA1\", \"LeftHallB\"]")],
            Warning,
            "zone 'RoomA1'",
            "no door leads to its neighbour 'LeftHallB'",
        ),
        case(
            &[(r#"["RoomA2", "FrontA1", "FrontA3"]"#, r#"["RoomA2", "FrontA1", "FrontA3", "FrontA2"]"#)],
            Warning,
            "zone 'FrontA2'",
            "names itself as a neighbour",
        ),
        case(
            &[("doors = [[15, 10]]", "doors = [[11, 10]]")],
            Warning,
            "zone 'RoomA1'",
            "door at (11, 10) reaches past the room's corner",
        ),
        case(
            &[(r#"sequence = ["Yellow", "Red", "Blue", "Green", "White", "Orange"]"#, "sequence = []")],
            Warning,
            "sequence",
            "is empty",
        ),
    ]
}

#[test]
fn each_broken_map_gets_its_problem_at_its_place() {
    for Case { edits, robots, severity, place, message } in cases() {
        let text = edited(&edits);
        let found = problems(&text, robots);
        let hit = found
            .iter()
            .any(|p| p.severity == severity && p.place == place && p.message.starts_with(message));
        assert!(hit, "{edits:?}: expected {severity}: {place}: {message}; got:{}", listed(&found));
        // The check never passes what loading refuses, and warnings never stop a map loading.
        let loads = Map::parse(&text, "edited").is_ok();
        if !loads {
            assert!(found.iter().any(Problem::is_error), "{edits:?}: refused by Map::parse but no error");
        }
        if severity == Severity::Warning {
            assert!(loads, "{edits:?}: a warning case must load");
            assert!(!found.iter().any(Problem::is_error), "{edits:?}: unexpected errors:{}", listed(&found));
        }
    }
}

#[test]
fn random_content_can_supply_any_sequence_colour() {
    let short = [(r#"sequence = ["Yellow", "Red""#, r#"sequence = ["Yellow", "Yellow", "Yellow", "Red""#)];
    for random in [("random_blocks = 0", "random_blocks = 1"), ("random_sequence = 0", "random_sequence = 1")]
    {
        let found = problems(&edited(&[short[0], random]), None);
        assert!(found.is_empty(), "{random:?}:{}", listed(&found));
    }
}

#[test]
fn a_map_with_several_problems_reports_all_of_them_errors_first() {
    let text = edited(&[
        (r#"["RoomA1", "FrontA2", "LeftHallA"]"#, r#"["RoomA1", "FrontA2", "LeftHall"]"#),
        ("doors = [[15, 10]]", "doors = [[15, 17]]"),
        (r#"sequence = ["Yellow", "Red""#, r#"sequence = ["Yellow", "Yellow", "Yellow", "Red""#),
        ("at = [25, 65]", "at = [35, 35]"),
        (r#"name = "RoomA2""#, r#"name = "RoomA1""#),
    ]);
    let found: Vec<String> = problems(&text, Some(20)).iter().map(Problem::to_string).collect();
    // Errors first; within each, in the order checked (names, zones in file order, ...).
    let expected = [
        "error: zone 'RoomA1': the name is already used by zone 6 (names must be unique)",
        "error: zone 'FrontA1': neighbour 'LeftHall' is not a zone",
        "error: zone 'FrontA2': neighbour 'RoomA2' is not a zone",
        "error: zone 'RoomA1': door at (15, 17) is not on the room's edge",
        "error: spawn points: 12 for 20 robots: each robot needs one",
        "error: sequence: needs 3 Yellow blocks, the map has 2",
        "warning: spawn 1 'Bot1': at (35, 35) is inside room 'RoomB3', which holds one robot at a time",
        "warning: zone 'RoomA1': no door leads to its neighbour 'FrontA1'",
    ];
    assert_eq!(found, expected);
    // Loading refuses the file too (at its first problem: the door's orientation cannot be told).
    let err = Map::parse(&text, "edited").expect_err("refused").to_string();
    assert!(err.contains("door at (15, 17)"), "{err}");
}

#[test]
fn parts_come_back_unvalidated_with_the_readers_warnings() {
    let (parts, warnings) =
        parse_parts(&fixture_text("bw4t-xml/fixed-content-lenient.xml"), "lenient").expect("parts");
    assert_eq!(parts.name, "lenient");
    let warnings: Vec<String> = warnings.iter().map(Problem::to_string).collect();
    assert_eq!(warnings, [LENIENT_WARNING]);
    // The dropped name is gone from the parts, as on import.
    assert!(parts.zones.iter().all(|z| !z.neighbours.iter().any(|n| n == "EastHall")));
    // Parts that Map::new refuses are still checked.
    let (mut parts, _) = parse_parts(&fixed_text(), "fixed").expect("parts");
    parts.spawns.clear();
    let found = check_parts(&parts, None);
    assert_eq!(found.len(), 1, "{}", listed(&found));
    assert_eq!(found[0].to_string(), "error: spawn points: there are none: robots cannot enter");
    let found = problems(&without_spawns(), None);
    assert!(found.iter().any(|p| p.place == "spawn points"), "{}", listed(&found));
    // Syntax errors stay errors, with their position.
    let err = parse_parts("area = [10, 10\n", "x").expect_err("syntax error").to_string();
    assert!(err.contains("line 1"), "{err}");
}

fn write_temp(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write");
    path_str(&path).to_string()
}

#[test]
fn map_check_fails_only_on_errors_and_names_every_file() {
    let dir = temp_dir("check");
    let warned = write_temp(&dir, "warned.toml", &edited(&[("at = [25, 65]", "at = [15, 15]")]));
    let broken = write_temp(&dir, "broken.toml", &edited(&[("doors = [[15, 10]]", "doors = [[15, 17]]")]));
    let garbage = write_temp(&dir, "garbage.toml", "area = [10, 10]\n[[zone]]\nname = \"A\"\n");
    let missing = path_str(&dir.join("missing.toml")).to_string();

    let out = bw4t(&["map", "check", "fixed", &warned]);
    assert!(out.status.success(), "{}{}", stdout(&out), stderr(&out));
    let text = stdout(&out);
    assert!(text.contains("fixed: ok"), "{text}");
    assert!(
        text.contains(&format!("{warned}: warning: spawn 1 'Bot1': at (15, 15) is inside room 'RoomA1'")),
        "{text}"
    );

    let out = bw4t(&["map", "check", &broken, "fixed"]);
    assert!(!out.status.success());
    let text = stdout(&out);
    assert!(
        text.contains(&format!("{broken}: error: zone 'RoomA1': door at (15, 17) is not on the room's edge")),
        "{text}"
    );
    assert!(text.contains("fixed: ok"), "later files are still checked: {text}");
    assert!(stderr(&out).contains("1 of 2 maps failed the check"), "{}", stderr(&out));

    let out = bw4t(&["map", "check", &missing, &garbage]);
    assert!(!out.status.success());
    let text = stdout(&out);
    assert!(text.contains(&format!("{missing}: error: no map file '{missing}'")), "{text}");
    assert!(text.contains(&format!("{garbage}: error: {garbage} cannot be read as a map")), "{text}");
    assert!(text.contains("missing field `type`"), "{text}");

    let out = bw4t(&["map", "check", "fixed", "--robots", "13"]);
    assert!(!out.status.success());
    assert!(stdout(&out).contains("fixed: error: spawn points: 12 for 13 robots"), "{}", stdout(&out));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Checks that `svg` is well-formed XML as this renderer writes it: balanced tags, quoted
/// attributes, escaped text, one root element. Returns the element names in order.
fn xml_elements(svg: &str) -> Vec<String> {
    let mut stack: Vec<String> = Vec::new();
    let mut names = Vec::new();
    let mut rest = svg;
    let mut roots = 0;
    while let Some(lt) = rest.find('<') {
        let text = &rest[..lt];
        assert!(!text.contains('>'), "stray '>' in text {text:?}");
        for (i, _) in text.match_indices('&') {
            let entity = &text[i..];
            assert!(
                ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"].iter().any(|e| entity.starts_with(e)),
                "bare '&' in {text:?}"
            );
        }
        let end = rest[lt..].find('>').expect("unclosed tag") + lt;
        let tag = &rest[lt + 1..end];
        rest = &rest[end + 1..];
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(stack.pop().as_deref(), Some(name.trim()), "mismatched </{name}>");
            continue;
        }
        let self_closing = tag.ends_with('/');
        let body = tag.trim_end_matches('/');
        let name: String = body.chars().take_while(|c| !c.is_whitespace()).collect();
        assert!(
            !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-'),
            "bad tag <{tag}>"
        );
        // Attributes: name="value" pairs, values without quotes or '<' inside.
        let mut attrs = body[name.len()..].trim();
        while !attrs.is_empty() {
            let eq = attrs.find("=\"").unwrap_or_else(|| panic!("bad attributes in <{tag}>"));
            let value_end = attrs[eq + 2..].find('"').expect("unterminated value") + eq + 2;
            assert!(!attrs[eq + 2..value_end].contains('<'), "'<' in <{tag}>");
            attrs = attrs[value_end + 1..].trim_start();
        }
        if stack.is_empty() {
            roots += 1;
        }
        names.push(name.clone());
        if !self_closing {
            stack.push(name);
        }
    }
    assert!(rest.trim().is_empty() && stack.is_empty(), "unclosed elements {stack:?}");
    assert_eq!(roots, 1, "one root element");
    names
}

#[test]
fn map_render_draws_rooms_blocks_and_the_sequence_deterministically() {
    let dir = temp_dir("render");
    let svg_path = |name: &str| path_str(&dir.join(name)).to_string();
    let render = |seed: &str, out: &str| {
        let out = bw4t(&["map", "render", "default", "-o", out, "--seed", seed]);
        assert!(out.status.success(), "{}", stderr(&out));
    };
    render("1", &svg_path("a.svg"));
    render("1", &svg_path("b.svg"));
    render("2", &svg_path("c.svg"));
    let (a, b, c) = (read(&svg_path("a.svg")), read(&svg_path("b.svg")), read(&svg_path("c.svg")));
    assert_eq!(a, b, "same seed, same bytes");
    assert_ne!(a, c, "another seed, other blocks");

    assert!(a.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""), "{}", &a[..80]);
    let elements = xml_elements(&a);
    assert_eq!(elements[0], "svg");
    let count = |needle: &str| a.matches(needle).count();
    assert_eq!(count("<rect class=\"room"), 10, "one rect per room");
    assert_eq!(count("<rect class=\"room drop-zone\""), 1);
    assert_eq!(count("<rect class=\"block\""), 28, "one square per block");
    assert_eq!(count("<rect class=\"goal\""), 6, "the sequence row");
    assert_eq!(count("<rect class=\"spawn\""), 12);
    assert!(a.contains("<title>default, seed 1: 28 blocks, a sequence of 6</title>"));

    // The blocks are the seed's blocks, in their colours.
    let map =
        Map::parse(&read(&format!("{}/maps/default.toml", repo_root!())), "default").expect("default map");
    let content = map.content(1).expect("content");
    for (i, block) in content.blocks.iter().enumerate() {
        assert!(a.contains(&format!("<title>block {}: {}</title>", i + 1, block.colour)), "block {}", i + 1);
    }
    // The binary draws exactly what the library does.
    assert_eq!(a, render_svg(&map, Some((&content, 1))));

    // A name needing escapes stays well-formed; without content there are no blocks.
    let odd =
        Map::parse(&fixed_text().replace("name = \"fixed\"", "name = \"a<b & 'c'\""), "x").expect("map");
    let svg = render_svg(&odd, None);
    xml_elements(&svg);
    assert!(svg.contains("a&lt;b &amp; &apos;c&apos;") && !svg.contains("class=\"block\""), "{svg}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `maps/default.svg`, embedded in `maps/README.md`, must show the default map as it is.
/// Regenerate it with `cargo run -- map render default -o maps/default.svg --seed 1`.
#[test]
fn the_committed_default_picture_is_up_to_date() {
    let dir = temp_dir("picture");
    let fresh = dir.join("default.svg");
    let out = bw4t(&["map", "render", "default", "-o", path_str(&fresh), "--seed", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let committed = read(&format!("{}/maps/default.svg", repo_root!()));
    let fresh = read(path_str(&fresh));
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        committed == fresh,
        "maps/default.svg is stale: regenerate it with `cargo run -- map render default -o maps/default.svg --seed 1`"
    );
}

#[test]
fn map_import_writes_native_maps_that_check_clean_and_equal_the_original() {
    let dir = temp_dir("import");
    for file in XML_FIXTURES {
        let source = fixture_path(file);
        let source = path_str(&source);
        let stem = Path::new(source).file_stem().and_then(|s| s.to_str()).expect("stem").to_string();
        let out_path = dir.join(format!("{stem}.toml"));
        let out = bw4t(&["map", "import", source, "-o", path_str(&out_path)]);
        assert!(out.status.success(), "{file}: {}", stderr(&out));
        if file.ends_with("-lenient.xml") {
            assert_eq!(stderr(&out), format!("{source}: {LENIENT_WARNING}\n"), "{file}");
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
    // Without -o the native text goes to standard output.
    let out = bw4t(&["map", "import", path_str(&fixture_path("bw4t-xml/fixed-content.xml"))]);
    assert!(out.status.success());
    let imported = Map::from_native(&stdout(&out)).expect("native map on stdout");
    assert_eq!(imported.name(), "fixed-content");
    let out = bw4t(&["map", "import", path_str(&dir.join("nowhere.xml"))]);
    assert!(!out.status.success() && stderr(&out).contains("nowhere.xml"), "{}", stderr(&out));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn map_show_summarises_rooms_content_and_sequence() {
    let out = bw4t(&["map", "show", "fixed"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    for expected in [
        "map 'fixed'",
        "area: 50 x 80",
        "zones: 28 (10 rooms, 18 corridors)",
        "RoomA1",
        "blocks: Red Blue",
        "the drop zone",
        "sequence: Yellow Red Blue Green White Orange",
        "random content: none",
        "spawn points: 12",
    ] {
        assert!(text.contains(expected), "missing {expected:?} in:\n{text}");
    }
    let out = bw4t(&["map", "show", "default", "--seed", "1"]);
    let text = stdout(&out);
    let sequence = Map::parse(&read(&format!("{}/maps/default.toml", repo_root!())), "default")
        .expect("default")
        .content(1)
        .expect("content")
        .sequence;
    let words: Vec<&str> = sequence.iter().map(|c| c.name()).collect();
    assert!(text.contains("sequence: (none), then 6 random colours"), "{text}");
    assert!(text.contains(&format!("with seed 1:\n  sequence: {}", words.join(" "))), "{text}");
    let out = bw4t(&["map", "show", "nowhere"]);
    assert!(!out.status.success() && stderr(&out).contains("no map file 'nowhere'"), "{}", stderr(&out));
}
