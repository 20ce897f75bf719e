//! The two map file formats, told apart in one place ([`MapFormat::of`]), and reading a
//! file of either: validated ([`Map::parse`]) or as parts for the check ([`parse_parts`]).

use crate::bw4t_xml::without_bom;
use crate::bw4t_xml::{XmlError, xml_parts};
use crate::model::Map;
use crate::native::{NativeError, native_parts};
use crate::parts::MapParts;
use crate::problem::Problem;

/// The format of a map file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapFormat {
    /// The native TOML format ([`Map::from_native`]).
    Native,
    /// The original BW4T XML format ([`Map::from_bw4t_xml_named`]).
    Xml,
}

impl MapFormat {
    /// The format a map file's text is in: original BW4T XML when it starts with `<`
    /// (after a byte-order mark and whitespace), else the native format. Neither format can
    /// start otherwise: a TOML document cannot start with `<`, an XML document must.
    pub fn of(text: &str) -> MapFormat {
        if without_bom(text).trim_start().starts_with('<') { MapFormat::Xml } else { MapFormat::Native }
    }
}

/// A map file in either format that could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum MapLoadError {
    /// The native TOML format.
    #[error(transparent)]
    Native(#[from] NativeError),
    /// An original BW4T XML file.
    #[error(transparent)]
    Xml(#[from] XmlError),
}

impl Map {
    /// Parses a map in either format (see [`MapFormat::of`]). `name` names the map unless
    /// the native text gives a non-empty `name` of its own.
    pub fn parse(text: &str, name: &str) -> Result<Map, MapLoadError> {
        let (format, parts) = read_parts(text, name, None)?;
        Map::new(parts).map_err(|invalid| match format {
            MapFormat::Native => NativeError::Invalid(invalid).into(),
            MapFormat::Xml => XmlError::Invalid(invalid).into(),
        })
    }
}

/// Reads a map file in either format (told apart as [`Map::parse`] does) into its parts,
/// without validating them. Syntax errors (and anything else that leaves no map to look
/// at) are errors; the problems returned are those the readers tolerate to go on: a door
/// at a room's corner given without orientation, and (original XML files) neighbour
/// names that name no zone, which are dropped as on import.
///
/// `name` names the map unless the native text gives a non-empty `name` of its own.
pub fn parse_parts(text: &str, name: &str) -> Result<(MapParts, Vec<Problem>), MapLoadError> {
    let mut problems = Vec::new();
    let (_, parts) = read_parts(text, name, Some(&mut problems))?;
    Ok((parts, problems))
}

/// The format of `text` and its parts, read by that format's reader; `lenient` as the
/// readers take it (see [`parse_parts`]).
fn read_parts(
    text: &str,
    name: &str,
    lenient: Option<&mut Vec<Problem>>,
) -> Result<(MapFormat, MapParts), MapLoadError> {
    let text = without_bom(text);
    let format = MapFormat::of(text);
    let parts = match format {
        MapFormat::Xml => xml_parts(text, name, lenient)?,
        MapFormat::Native => {
            let mut parts = native_parts(text, lenient)?;
            if parts.name.is_empty() {
                parts.name = name.to_string();
            }
            parts
        }
    };
    Ok((format, parts))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_character_tells_the_formats_apart() {
        assert_eq!(MapFormat::of("<newMap/>"), MapFormat::Xml);
        assert_eq!(MapFormat::of("\u{feff}\n  <?xml version=\"1.0\"?>"), MapFormat::Xml);
        assert_eq!(MapFormat::of("area = [10, 10]"), MapFormat::Native);
        assert_eq!(MapFormat::of("# <newMap> in a comment\n"), MapFormat::Native);
        assert_eq!(MapFormat::of(""), MapFormat::Native);
    }
}
