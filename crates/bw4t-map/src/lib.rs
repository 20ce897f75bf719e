//! BW4T maps: the zone model, the native TOML format, and the seeded random content.
//!
//! Pure: everything here parses and produces values; no files, clocks or OS randomness.

mod bw4t_xml;
mod check;
mod colour;
mod content;
mod format;
mod generate;
mod geometry;
mod limits;
mod locate;
mod model;
mod native;
mod parts;
mod problem;
mod render;
mod rng;
mod rules;
mod walls;

pub use bw4t_xml::{XmlError, XmlPlace};
pub use check::{CheckError, check_parts, check_text};
pub use colour::{Colour, UnknownColour};
pub use content::{BLOCK_SPACING, Content, ContentError, PlacedBlock, block_area, spot_is_clear};
pub use format::{MapFormat, MapLoadError, parse_parts};
pub use generate::{MAX_COLUMNS, MAX_ROWS, generate};
pub use geometry::{Door, Orientation, ROBOT_SIZE, Rect, Vec2};
pub use limits::{
    MAX_BLOCKS_PER_ROOM, MAX_COORDINATE, MAX_MAP_BYTES, MAX_SPAWNS, MAX_ZONES, coordinate_problem,
};
pub use model::{Map, MapError};
pub use native::NativeError;
pub use parts::{DROP_ZONE, MapParts, Spawn, Zone, ZoneIdx, ZoneKind};
pub use problem::{Problem, Severity};
pub use render::{RobotMark, colour_hex, render_scene, render_svg, zone_fill};
pub use rng::{SeededRng, fnv1a};
pub use walls::{Wall, zone_walls};
