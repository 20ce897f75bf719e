//! The native map format: a small TOML document, described field by field in `maps/README.md`.

use std::fmt::Write as _;

use serde::Deserialize;

use crate::colour::{Colour, UnknownColour};
use crate::geometry::{Door, Orientation, Rect, Vec2};
use crate::limits::coordinate_problem;
use crate::model::{Map, MapError};
use crate::parts::{MapParts, Spawn, Zone, ZoneKind};
use crate::problem::Problem;
use crate::rules::guess_orientation;
use crate::rules::infer_orientation;

/// The format version this code reads and writes.
const FORMAT_VERSION: u32 = 1;

/// How errors name the numbers of a point and of a size.
const POINT: [&str; 2] = ["x", "y"];
const SIZE: [&str; 2] = ["width", "height"];

/// Why a native map file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum NativeError {
    /// Not TOML, or a field is missing, misspelt or of the wrong type (with line and column).
    #[error(transparent)]
    Syntax(#[from] toml::de::Error),
    /// A newer format than this program reads.
    #[error("map format version {0} is not supported (this program reads version {FORMAT_VERSION})")]
    Version(u32),
    /// A colour name that is not one of the nine.
    #[error("{place}: {colour}")]
    Colour {
        /// Where the colour was found.
        place: String,
        /// The bad name.
        colour: UnknownColour,
    },
    /// A coordinate or size out of range (or NaN).
    #[error("{place}: {problem}")]
    Range {
        /// The field, e.g. `zone 'RoomA1': centre x`.
        place: String,
        /// What is wrong, with the allowed range.
        problem: String,
    },
    /// A door given without orientation whose centre does not pick one edge.
    #[error("zone '{zone}': door at ({x}, {y}) needs an explicit orientation (horizontal or vertical)")]
    DoorOrientation {
        /// The room.
        zone: String,
        /// Door centre x.
        x: f32,
        /// Door centre y.
        y: f32,
    },
    /// The file parsed but describes an invalid map.
    #[error(transparent)]
    Invalid(#[from] MapError),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MapFile {
    #[serde(default)]
    version: Option<u32>,
    #[serde(default)]
    name: String,
    area: [f64; 2],
    #[serde(default)]
    sequence: Vec<String>,
    #[serde(default)]
    random_sequence: u32,
    #[serde(default)]
    random_blocks: u32,
    #[serde(default)]
    seed: Option<u64>,
    #[serde(default)]
    spawn: Vec<SpawnFile>,
    #[serde(default)]
    zone: Vec<ZoneFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpawnFile {
    name: String,
    at: [f64; 2],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ZoneFile {
    name: String,
    #[serde(rename = "type")]
    kind: KindFile,
    centre: [f64; 2],
    size: [f64; 2],
    #[serde(default)]
    doors: Vec<DoorFile>,
    #[serde(default)]
    neighbours: Vec<String>,
    #[serde(default)]
    blocks: Vec<String>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum KindFile {
    Room,
    Corridor,
    Charging,
    Blockade,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum DoorFile {
    At([f64; 2]),
    Full { at: [f64; 2], orientation: OrientationFile },
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum OrientationFile {
    Horizontal,
    Vertical,
}

impl Map {
    /// Parses a map in the native format.
    pub fn from_native(text: &str) -> Result<Map, NativeError> {
        Ok(Map::new(native_parts(text, None)?)?)
    }

    /// Writes the map in the native format; [`Map::from_native`] reads it back unchanged.
    pub fn to_native(&self) -> String {
        let mut out = String::new();
        let parts = self.parts();
        // Writing to a String cannot fail.
        let _ = writeln!(out, "version = {FORMAT_VERSION}");
        let _ = writeln!(out, "name = {}", quoted(&parts.name));
        let _ = writeln!(out, "area = {}", pair(parts.area));
        let _ = writeln!(out, "sequence = {}", names(parts.sequence.iter().map(|c| c.name())));
        let _ = writeln!(out, "random_sequence = {}", parts.random_sequence);
        let _ = writeln!(out, "random_blocks = {}", parts.random_blocks);
        if let Some(seed) = parts.seed {
            let _ = writeln!(out, "seed = {seed}");
        }
        for spawn in &parts.spawns {
            let _ = writeln!(out, "\n[[spawn]]\nname = {}\nat = {}", quoted(&spawn.name), pair(spawn.pos));
        }
        for zone in &parts.zones {
            let _ = writeln!(out, "\n[[zone]]\nname = {}", quoted(&zone.name));
            let _ = writeln!(out, "type = \"{}\"", zone.kind.name());
            let _ = writeln!(out, "centre = {}\nsize = {}", pair(zone.rect.centre), pair(zone.rect.size));
            if !zone.doors.is_empty() {
                let doors: Vec<String> = zone.doors.iter().map(door_to_native).collect();
                let _ = writeln!(out, "doors = [{}]", doors.join(", "));
            }
            let _ = writeln!(out, "neighbours = {}", names(zone.neighbours.iter().map(String::as_str)));
            if !zone.blocks.is_empty() {
                let _ = writeln!(out, "blocks = {}", names(zone.blocks.iter().map(|c| c.name())));
            }
        }
        out
    }
}

/// Reads a native map into its parts without validating them. With `lenient`, a door
/// given without orientation whose centre picks no single edge is kept and left to the
/// checks (see [`guess_orientation`]) instead of refused.
pub(crate) fn native_parts(
    text: &str,
    mut lenient: Option<&mut Vec<Problem>>,
) -> Result<MapParts, NativeError> {
    let file: MapFile = toml::from_str(text)?;
    if let Some(v) = file.version.filter(|&v| v > FORMAT_VERSION) {
        return Err(NativeError::Version(v));
    }
    let area = file_pair(file.area, "area", SIZE)?;
    let sequence = colours(&file.sequence, "sequence")?;
    let mut spawns = Vec::with_capacity(file.spawn.len());
    for (i, s) in file.spawn.into_iter().enumerate() {
        let pos = file_pair(s.at, &format!("spawn {} '{}': at", i + 1, s.name), POINT)?;
        spawns.push(Spawn { name: s.name, pos });
    }
    let mut zones = Vec::with_capacity(file.zone.len());
    for z in file.zone {
        zones.push(zone_from_file(z, lenient.as_deref_mut())?);
    }
    Ok(MapParts {
        name: file.name,
        area,
        zones,
        spawns,
        sequence,
        random_sequence: file.random_sequence,
        random_blocks: file.random_blocks,
        seed: file.seed,
    })
}

fn zone_from_file(z: ZoneFile, mut lenient: Option<&mut Vec<Problem>>) -> Result<Zone, NativeError> {
    let place = format!("zone '{}'", z.name);
    let centre = file_pair(z.centre, &format!("{place}: centre"), POINT)?;
    let rect = Rect::new(centre, file_pair(z.size, &format!("{place}: size"), SIZE)?);
    let mut doors = Vec::with_capacity(z.doors.len());
    for (i, d) in z.doors.iter().enumerate() {
        let (at, given) = match d {
            DoorFile::At(at) => (*at, None),
            DoorFile::Full { at, orientation } => (*at, Some(*orientation)),
        };
        let at = file_pair(at, &format!("{place}: door {}", i + 1), POINT)?;
        let orientation = match (given, infer_orientation(at, &rect), lenient.as_deref_mut()) {
            (Some(OrientationFile::Horizontal), ..) => Orientation::Horizontal,
            (Some(OrientationFile::Vertical), ..) => Orientation::Vertical,
            (None, Some(inferred), _) => inferred,
            (None, None, Some(problems)) => {
                guess_orientation(&format!("zone '{}'", z.name), at, &rect, problems)
            }
            (None, None, None) => {
                return Err(NativeError::DoorOrientation { zone: z.name.clone(), x: at.x, y: at.y });
            }
        };
        doors.push(Door { centre: at, orientation });
    }
    let kind = match z.kind {
        KindFile::Room => ZoneKind::Room,
        KindFile::Corridor => ZoneKind::Corridor,
        KindFile::Charging => ZoneKind::Charging,
        KindFile::Blockade => ZoneKind::Blockade,
    };
    let blocks = colours(&z.blocks, &format!("zone '{}': blocks", z.name))?;
    Ok(Zone { name: z.name, kind, rect, doors, neighbours: z.neighbours, blocks })
}

/// A point or size from the file, each number within the limits (see [`coordinate_problem`]);
/// `axes` name its two numbers in errors.
fn file_pair(v: [f64; 2], place: &str, axes: [&str; 2]) -> Result<Vec2, NativeError> {
    for (axis, x) in axes.into_iter().zip(v) {
        if let Some(problem) = coordinate_problem(x) {
            return Err(NativeError::Range { place: format!("{place} {axis}"), problem });
        }
    }
    // In range, so the narrowing only rounds.
    Ok(Vec2::new(v[0] as f32, v[1] as f32))
}

fn colours(names: &[String], place: &str) -> Result<Vec<Colour>, NativeError> {
    names
        .iter()
        .map(|n| n.parse().map_err(|colour| NativeError::Colour { place: place.to_string(), colour }))
        .collect()
}

fn door_to_native(door: &Door) -> String {
    let orientation = match door.orientation {
        Orientation::Horizontal => "horizontal",
        Orientation::Vertical => "vertical",
    };
    format!("{{ at = {}, orientation = \"{orientation}\" }}", pair(door.centre))
}

fn quoted(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

fn names<'a>(items: impl Iterator<Item = &'a str>) -> String {
    let quoted: Vec<String> = items.map(quoted).collect();
    format!("[{}]", quoted.join(", "))
}

/// Whole numbers without a fraction, so written maps read like hand-written ones. Others in
/// Rust's debug form, which always has a `.` or an exponent: TOML reads digits alone as an
/// integer, and those above 2^63 not at all. Negative zero stays `-0.0`, so a written map
/// reads back bit for bit.
fn number(x: f32) -> String {
    let whole = x.fract() == 0.0 && x.abs() < 1e7 && !(x == 0.0 && x.is_sign_negative());
    if whole { format!("{}", x as i64) } else { format!("{x:?}") }
}

fn pair(v: Vec2) -> String {
    format!("[{}, {}]", number(v.x), number(v.y))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = r#"
        name = "small"
        area = [30, 30]
        sequence = ["red", "BLUE"]
        [[spawn]]
        name = "Bot1"
        at = [5, 5]
        [[zone]]
        name = "Hall"
        type = "corridor"
        centre = [15, 5]
        size = [30, 10]
        neighbours = ["DropZone"]
        [[zone]]
        name = "DropZone"
        type = "room"
        centre = [15, 20]
        size = [10, 10]
        doors = [[15, 15], { at = [20, 20], orientation = "vertical" }]
        blocks = ["Red"]
    "#;

    #[test]
    fn parses_and_round_trips() {
        let map = Map::from_native(SMALL).expect("valid map");
        assert_eq!(map.sequence(), &[Colour::Red, Colour::Blue]);
        let dz = &map.zones()[map.drop_zone()];
        assert_eq!(dz.doors[0].orientation, Orientation::Horizontal);
        assert_eq!(dz.doors[1].orientation, Orientation::Vertical);
        // The edge is undirected although only Hall names it.
        assert_eq!(map.neighbours(map.drop_zone()), &[0]);
        let again = Map::from_native(&map.to_native()).expect("written map reads back");
        assert_eq!(again, map);
    }

    fn error(text: &str) -> String {
        Map::from_native(text).expect_err("should fail").to_string()
    }

    #[test]
    fn errors_name_the_problem() {
        let cases = [
            (SMALL.replace("\"Red\"]", "\"Purple\"]"), "zone 'DropZone': blocks: unknown colour 'Purple'"),
            (
                SMALL.replace("[\"DropZone\"]", "[\"Nowhere\"]"),
                "zone 'Hall': neighbour 'Nowhere' is not a zone",
            ),
            (
                SMALL.replace("[[15, 15],", "[[15, 17],"),
                "zone 'DropZone': door at (15, 17) needs an explicit",
            ),
            (SMALL.replace("name = \"DropZone\"", "name = \"Drop\""), "no zone named 'DropZone'"),
            (SMALL.replace("centre = [15, 5]", "centre = [15, 5]\ncolour = 1"), "unknown field `colour`"),
            (SMALL.replace("type = \"corridor\"", "type = \"lake\""), "unknown variant `lake`"),
            (format!("version = 9\n{SMALL}"), "map format version 9 is not supported"),
        ];
        for (text, expected) in cases {
            let message = error(&text);
            assert!(message.contains(expected), "expected '{expected}' in: {message}");
        }
    }

    #[test]
    fn reports_every_problem_at_once() {
        let text = SMALL.replace("[\"DropZone\"]", "[\"A\", \"B\"]");
        let message = error(&text);
        assert!(message.contains("'A' is not a zone") && message.contains("'B' is not a zone"), "{message}");
    }
}
