//! Original BW4T map files (JAXB XML, root `<newMap>`).
//!
//! The root holds `<area>` (`<x>` width, `<y>` height), repeated `<entities>` (spawn points:
//! `<name>`, `<position>`), `<randomBlocks>`, `<randomSequence>`, an optional `<seed>`,
//! repeated `<sequence>` colours and repeated `<zones>`: `<name>`, `<type>`, `<boundingbox>`
//! (centre `<x>` `<y>`, `<width>`, `<height>`), `<blocks>`, `<doors>` and `<neighbours>`.
//! Elements may come in any order; unknown ones (and `<renderOptions>`, entity `<type>`) are
//! ignored. Names are kept as written, so the original corridors stay `FrontRoomA1`..., not
//! the spec's `FrontA1`.

use std::collections::BTreeSet;
use std::fmt;

use roxmltree::{Document, Node};

use crate::colour::{Colour, UnknownColour};
use crate::geometry::{Door, Orientation, Rect, Vec2};
use crate::limits::coordinate_problem;
use crate::model::{Map, MapError};
use crate::parts::{MapParts, Spawn, Zone, ZoneKind};
use crate::problem::{Problem, zone_place};
use crate::rules::guess_orientation;
use crate::rules::infer_orientation;

/// The root element of an original map file.
const ROOT: &str = "newMap";

/// How errors name the top level of the file.
const MAP_PLACE: &str = "<newMap>";

/// Where a problem in an XML map file is: a line and the part of the map being read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct XmlPlace {
    /// 1-based line of the element concerned.
    pub line: u32,
    /// The map part, e.g. `zone 'RoomA1', door 1` or `entity 2 'Bot2'`.
    pub what: String,
}

impl fmt::Display for XmlPlace {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}, {}", self.line, self.what)
    }
}

/// Why an original BW4T map file could not be loaded; the message names the place.
#[derive(Debug, thiserror::Error)]
pub enum XmlError {
    /// Not well-formed XML.
    #[error("not well-formed XML at line {line}, column {column}: {message}")]
    Syntax {
        /// 1-based line.
        line: u32,
        /// 1-based column.
        column: u32,
        /// The XML parser's description.
        message: String,
    },
    /// Well-formed XML, but not a BW4T map.
    #[error("the root element is <{found}>, expected <{ROOT}> (an original BW4T map)")]
    Root {
        /// The root element's name.
        found: String,
    },
    /// A required element is absent.
    #[error("{place}: missing <{element}>")]
    Missing {
        /// The element that should contain it.
        place: XmlPlace,
        /// The absent element's name.
        element: &'static str,
    },
    /// An element that may appear once appears again.
    #[error("{place}: <{element}> is given more than once")]
    Repeated {
        /// The second occurrence.
        place: XmlPlace,
        /// The element's name.
        element: &'static str,
    },
    /// A number (or boolean) that does not parse.
    #[error("{place}: <{element}> is '{text}', not {expected}")]
    Number {
        /// The element holding it.
        place: XmlPlace,
        /// The element's name.
        element: &'static str,
        /// The text found.
        text: String,
        /// What was expected, e.g. `a finite number`.
        expected: &'static str,
    },
    /// A coordinate or size out of range, e.g. `1e300`.
    #[error("{place}: <{element}>: {problem}")]
    Range {
        /// The element holding it.
        place: XmlPlace,
        /// The element's name.
        element: &'static str,
        /// What is wrong, with the allowed range.
        problem: String,
    },
    /// A zone `<type>` other than ROOM, CORRIDOR, CHARGINGZONE and BLOCKADE.
    #[error("{place}: unknown zone type '{found}' (expected ROOM, CORRIDOR, CHARGINGZONE or BLOCKADE)")]
    ZoneType {
        /// The `<type>` element.
        place: XmlPlace,
        /// The text found.
        found: String,
    },
    /// A colour name that is not one of the nine.
    #[error("{place}: {colour}")]
    Colour {
        /// The element holding it.
        place: XmlPlace,
        /// The bad name.
        colour: UnknownColour,
    },
    /// A door `<orientation>` other than HORIZONTAL and VERTICAL.
    #[error("{place}: unknown door orientation '{found}' (expected HORIZONTAL or VERTICAL)")]
    Orientation {
        /// The `<orientation>` element.
        place: XmlPlace,
        /// The text found.
        found: String,
    },
    /// A door without `<orientation>` whose centre does not pick one edge of its room.
    #[error("{place}: the door at ({x}, {y}) needs an <orientation>")]
    DoorOrientation {
        /// The `<doors>` element.
        place: XmlPlace,
        /// Door centre x.
        x: f32,
        /// Door centre y.
        y: f32,
    },
    /// The file parsed but describes an invalid map.
    #[error(transparent)]
    Invalid(#[from] MapError),
}

impl Map {
    /// Parses an original BW4T XML map; the map's name is empty (see [`Map::from_bw4t_xml_named`]).
    pub fn from_bw4t_xml(text: &str) -> Result<Map, XmlError> {
        Map::from_bw4t_xml_named(text, "")
    }

    /// Parses an original BW4T XML map and names it `name` (the files carry no name).
    ///
    /// `<oneBotPerCorridorZone>` is checked to be a boolean and otherwise ignored: this
    /// project's corridors never limit robots. A negative `<seed>` is kept as its
    /// two's-complement `u64`, so the content stays fixed.
    pub fn from_bw4t_xml_named(text: &str, name: &str) -> Result<Map, XmlError> {
        Ok(Map::new(xml_parts(text, name, None)?)?)
    }
}

/// Reads an original map into its parts without validating them. Neighbour names that name
/// no zone are dropped; with `lenient` each is reported there as a warning, and a door
/// without `<orientation>` whose centre picks no single edge is kept and left to the checks
/// (see [`guess_orientation`]) instead of refused.
pub(crate) fn xml_parts(
    text: &str,
    name: &str,
    mut lenient: Option<&mut Vec<Problem>>,
) -> Result<MapParts, XmlError> {
    let text = without_bom(text);
    let blanked = blank_late_declaration(text);
    let text = blanked.as_deref().unwrap_or(text);
    let doc = Document::parse(text).map_err(|e| syntax_error(text, &e))?;
    let root = doc.root_element();
    if root.tag_name().name() != ROOT {
        return Err(XmlError::Root { found: root.tag_name().name().to_string() });
    }
    let area_node = required(root, "area", MAP_PLACE)?;
    let area = point(area_node, "<area>")?;

    let spawns = elements(root, "entities")
        .enumerate()
        .map(|(i, node)| spawn(node, i + 1))
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(node) = optional(root, "oneBotPerCorridorZone", MAP_PLACE)? {
        boolean(node, "oneBotPerCorridorZone")?;
    }
    let random_blocks = optional_count(root, "randomBlocks")?;
    let random_sequence = optional_count(root, "randomSequence")?;
    let seed = optional(root, "seed", MAP_PLACE)?.map(seed).transpose()?;
    let sequence = elements(root, "sequence").map(|n| colour(n, "<sequence>")).collect::<Result<_, _>>()?;
    let mut zones = Vec::new();
    for (i, node) in elements(root, "zones").enumerate() {
        zones.push(zone(node, i + 1, lenient.as_deref_mut())?);
    }
    drop_dangling_neighbours(root, &mut zones, lenient);

    Ok(MapParts {
        name: name.to_string(),
        area,
        zones,
        spawns,
        sequence,
        random_sequence,
        random_blocks,
        seed,
    })
}

/// The text with its XML declaration blanked out when whitespace precedes it (which XML
/// forbids), so a file with a stray leading blank line still loads. Newlines are kept, so
/// every line number stays as in the file.
fn blank_late_declaration(text: &str) -> Option<String> {
    let body = text.trim_start();
    let start = text.len() - body.len();
    let is_declaration = body.strip_prefix("<?xml").is_some_and(|rest| rest.starts_with(char::is_whitespace));
    if start == 0 || !is_declaration {
        return None;
    }
    let end = start + body.find("?>")? + 2;
    let blank: String = text[start..end].chars().map(|c| if c == '\n' { c } else { ' ' }).collect();
    let mut out = text.to_string();
    out.replace_range(start..end, &blank);
    Some(out)
}

fn syntax_error(text: &str, e: &roxmltree::Error) -> XmlError {
    let pos = match e {
        // These carry no position of their own (1:1); the problem is at the end of the text.
        roxmltree::Error::UnexpectedEndOfStream | roxmltree::Error::UnclosedRootNode => {
            let last_line = text.rsplit('\n').next().unwrap_or("");
            let (line, column) = (text.matches('\n').count() + 1, last_line.chars().count() + 1);
            roxmltree::TextPos::new(
                u32::try_from(line).unwrap_or(u32::MAX),
                u32::try_from(column).unwrap_or(1),
            )
        }
        _ => e.pos(),
    };
    // Most messages end in the position, which the error shows anyway.
    let message = e.to_string();
    let message = message.strip_suffix(&format!(" at {}", e.pos())).unwrap_or(&message).to_string();
    XmlError::Syntax { line: pos.row, column: pos.col, message }
}

fn spawn(node: Node, index: usize) -> Result<Spawn, XmlError> {
    let name = text(required(node, "name", &format!("entity {index}"))?);
    let what = format!("entity {index} '{name}'");
    let pos = point(required(node, "position", &what)?, &format!("{what}, <position>"))?;
    Ok(Spawn { name, pos })
}

fn zone(node: Node, index: usize, mut lenient: Option<&mut Vec<Problem>>) -> Result<Zone, XmlError> {
    let name = text(required(node, "name", &format!("zone {index}"))?);
    let what = if name.is_empty() { format!("zone {index}") } else { format!("zone '{name}'") };

    let kind_node = required(node, "type", &what)?;
    let kind = match text(kind_node).to_ascii_uppercase().as_str() {
        "ROOM" => ZoneKind::Room,
        "CORRIDOR" => ZoneKind::Corridor,
        "CHARGINGZONE" => ZoneKind::Charging,
        "BLOCKADE" => ZoneKind::Blockade,
        _ => return Err(XmlError::ZoneType { place: place(kind_node, &what), found: text(kind_node) }),
    };

    let bbox = required(node, "boundingbox", &what)?;
    let bbox_what = format!("{what}, <boundingbox>");
    // The box is given by its centre, as in the native format.
    let centre = point(bbox, &bbox_what)?;
    let size = Vec2::new(number(bbox, "width", &bbox_what)?, number(bbox, "height", &bbox_what)?);
    let rect = Rect::new(centre, size);

    let blocks_what = format!("{what}, <blocks>");
    let blocks = elements(node, "blocks").map(|n| colour(n, &blocks_what)).collect::<Result<_, _>>()?;
    let mut doors = Vec::new();
    for (i, n) in elements(node, "doors").enumerate() {
        doors.push(door(n, &rect, &format!("{what}, door {}", i + 1), lenient.as_deref_mut())?);
    }
    let neighbours = elements(node, "neighbours").map(text).collect();
    Ok(Zone { name, kind, rect, doors, neighbours, blocks })
}

/// Drops neighbour names that are no zone of the file, which the native format rejects: an
/// original file has them (`Rainbow-with-blockade` still names `RightHallA`, renamed to
/// `BlockadeA`), and edges are undirected, so the renamed zone's own list still links it.
/// With `lenient`, each dropped name is reported there as a warning with its line.
fn drop_dangling_neighbours(root: Node, zones: &mut [Zone], lenient: Option<&mut Vec<Problem>>) {
    let names: BTreeSet<String> = zones.iter().map(|z| z.name.clone()).collect();
    if let Some(problems) = lenient {
        // `zones` was read from these nodes, in this order.
        for (i, (zone, node)) in zones.iter().zip(elements(root, "zones")).enumerate() {
            for n in elements(node, "neighbours").filter(|n| !names.contains(&text(*n))) {
                let line = place(n, "").line;
                problems.push(Problem::warning(
                    zone_place(i, zone),
                    format!("neighbour '{}' (line {line}) is not a zone; it is ignored", text(n)),
                ));
            }
        }
    }
    for zone in zones {
        zone.neighbours.retain(|n| names.contains(n));
    }
}

fn door(node: Node, room: &Rect, what: &str, lenient: Option<&mut Vec<Problem>>) -> Result<Door, XmlError> {
    let centre = point(required(node, "position", what)?, &format!("{what}, <position>"))?;
    let orientation = match optional(node, "orientation", what)? {
        Some(o) => match text(o).to_ascii_uppercase().as_str() {
            "HORIZONTAL" => Orientation::Horizontal,
            "VERTICAL" => Orientation::Vertical,
            _ => return Err(XmlError::Orientation { place: place(o, what), found: text(o) }),
        },
        // JAXB always writes it; a hand-written file may leave it to the door's edge.
        None => match (infer_orientation(centre, room), lenient) {
            (Some(inferred), _) => inferred,
            (None, Some(problems)) => guess_orientation(what, centre, room, problems),
            (None, None) => {
                return Err(XmlError::DoorOrientation { place: place(node, what), x: centre.x, y: centre.y });
            }
        },
    };
    Ok(Door { centre, orientation })
}

fn colour(node: Node, what: &str) -> Result<Colour, XmlError> {
    text(node).parse().map_err(|colour| XmlError::Colour { place: place(node, what), colour })
}

/// The `<x>` and `<y>` children of `node`.
fn point(node: Node, what: &str) -> Result<Vec2, XmlError> {
    Ok(Vec2::new(number(node, "x", what)?, number(node, "y", what)?))
}

/// The required child `element` of `node` as a number within the limits (`50` and `50.0`
/// both parse; see [`coordinate_problem`]).
fn number(node: Node, element: &'static str, what: &str) -> Result<f32, XmlError> {
    let child = required(node, element, what)?;
    let s = text(child);
    match s.parse::<f64>() {
        Ok(x) if !x.is_nan() => match coordinate_problem(x) {
            // In range, so the narrowing only rounds.
            None => Ok(x as f32),
            Some(problem) => Err(XmlError::Range { place: place(child, what), element, problem }),
        },
        _ => {
            Err(XmlError::Number { place: place(child, what), element, text: s, expected: "a finite number" })
        }
    }
}

/// An optional top-level count such as `<randomBlocks>`; JAXB reads an absent int as 0.
fn optional_count(root: Node, element: &'static str) -> Result<u32, XmlError> {
    let Some(node) = optional(root, element, MAP_PLACE)? else { return Ok(0) };
    let s = text(node);
    s.parse().map_err(|_| XmlError::Number {
        place: place(node, MAP_PLACE),
        element,
        text: s,
        expected: "a whole number from 0 to 4294967295",
    })
}

fn seed(node: Node) -> Result<u64, XmlError> {
    let s = text(node);
    // Java wrote a signed integer; wrapping keeps a negative seed fixed and distinct.
    s.parse::<u64>().or_else(|_| s.parse::<i64>().map(|v| v as u64)).map_err(|_| XmlError::Number {
        place: place(node, MAP_PLACE),
        element: "seed",
        text: s,
        expected: "a whole number",
    })
}

/// An `xs:boolean`, as JAXB reads it.
fn boolean(node: Node, element: &'static str) -> Result<bool, XmlError> {
    let s = text(node);
    match s.as_str() {
        "true" | "1" => Ok(true),
        "false" | "0" => Ok(false),
        _ => Err(XmlError::Number {
            place: place(node, MAP_PLACE),
            element,
            text: s,
            expected: "true or false",
        }),
    }
}

/// The child elements of `node` called `tag`, in file order.
fn elements<'a, 'i>(node: Node<'a, 'i>, tag: &'static str) -> impl Iterator<Item = Node<'a, 'i>> {
    node.children().filter(move |c| c.is_element() && c.tag_name().name() == tag)
}

/// The child `tag` of `node`, if present; a second one is an error rather than a silent choice.
fn optional<'a, 'i>(
    node: Node<'a, 'i>,
    tag: &'static str,
    what: &str,
) -> Result<Option<Node<'a, 'i>>, XmlError> {
    let mut found = elements(node, tag);
    let first = found.next();
    match found.next() {
        Some(second) => Err(XmlError::Repeated { place: place(second, what), element: tag }),
        None => Ok(first),
    }
}

fn required<'a, 'i>(node: Node<'a, 'i>, tag: &'static str, what: &str) -> Result<Node<'a, 'i>, XmlError> {
    optional(node, tag, what)?.ok_or_else(|| XmlError::Missing { place: place(node, what), element: tag })
}

/// The element's text, with comments skipped and surrounding whitespace removed.
fn text(node: Node) -> String {
    let all: String = node.children().filter(|c| c.is_text()).filter_map(|c| c.text()).collect();
    all.trim().to_string()
}

fn place(node: Node, what: &str) -> XmlPlace {
    XmlPlace { line: node.document().text_pos_at(node.range().start).row, what: what.to_string() }
}
/// The text without a leading byte-order mark, which is not whitespace but must neither
/// hide the `<` of an XML file nor reach a reader.
pub(crate) fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}
