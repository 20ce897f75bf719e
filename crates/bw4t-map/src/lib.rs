//! BW4T maps: the zone model, the native TOML format, and the seeded random content.
//!
//! Pure: everything here parses and produces values; no files, clocks or OS randomness.

mod bw4t_xml;
mod check;
mod colour;
mod content;
mod generate;
mod geometry;
mod limits;
mod locate;
mod model;
mod native;
mod render;
mod rng;
mod walls;

pub use bw4t_xml::{MapLoadError, XmlError, XmlPlace};
pub use check::{CheckError, Problem, Severity, check_parts, check_text, parse_parts};
pub use colour::{Colour, UnknownColour};
pub use content::{
    BLOCK_SPACING, Content, ContentError, MAX_BLOCKS_PER_ROOM, PlacedBlock, block_area, spot_is_clear,
};
pub use generate::{MAX_COLUMNS, MAX_ROWS, generate};
pub use geometry::{Door, Orientation, Rect, Vec2};
pub use limits::{MAX_COORDINATE, MAX_MAP_BYTES, MAX_SPAWNS, MAX_ZONES, coordinate_problem};
pub use model::{DROP_ZONE, Map, MapError, MapParts, Spawn, Zone, ZoneIdx, ZoneKind};
pub use native::NativeError;
pub use render::render_svg;
pub use rng::SeededRng;
pub use walls::{Wall, zone_walls};
