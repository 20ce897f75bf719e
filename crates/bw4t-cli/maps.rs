//! Finding maps: a name of a map shipped in `maps/` (built into the binary) or a file path
//! (native or original BW4T XML), and the one way every command that plays loads them.

use anyhow::{Context, Result, bail};
use bw4t_map::{CheckError, MAX_MAP_BYTES, Map};

/// The maps shipped in `maps/`, by name, as built into the binary.
pub(crate) const BUILTIN: &[(&str, &str)] = &[
    ("default", include_str!("../../maps/default.toml")),
    ("fixed", include_str!("../../maps/fixed.toml")),
    ("rooms12", include_str!("../../maps/rooms12.toml")),
    ("rooms24", include_str!("../../maps/rooms24.toml")),
    ("crowd24", include_str!("../../maps/crowd24.toml")),
    ("side-doors", include_str!("../../maps/side-doors.toml")),
    ("rooms100", include_str!("../../maps/rooms100.toml")),
];

/// Loads `spec` for a match: a path to a map file if one exists there, else the name of a
/// shipped map. The map is checked as `bw4t map check` checks it, before anything is built
/// from it: any error refuses it, each error on a line as `map check` prints it; warnings
/// are printed to standard error and the map is played.
pub(crate) fn load(spec: &str) -> Result<Map> {
    let source = read(spec)?;
    match Map::parse_checked(&source.text, &source.name, None) {
        Ok((map, warnings)) => {
            for warning in &warnings {
                eprintln!("bw4t: {spec}: {warning}");
            }
            Ok(map)
        }
        Err(CheckError::Unreadable(e)) => {
            Err(e).with_context(|| format!("{} is not a valid map", source.origin))
        }
        Err(CheckError::Failed(errors)) => {
            let lines: Vec<String> = errors.iter().map(|e| format!("{spec}: {e}")).collect();
            bail!(
                "{} fails the map check (`bw4t map check` lists the same):\n{}",
                source.origin,
                lines.join("\n")
            )
        }
    }
}

/// Loads `spec` as its file says, refused only for what loading refuses, so that a map the
/// check rejects can still be shown or drawn.
pub(crate) fn load_as_is(spec: &str) -> Result<Map> {
    let source = read(spec)?;
    Map::parse(&source.text, &source.name).with_context(|| format!("{} is not a valid map", source.origin))
}

/// A map's text, found as [`load`] finds it, before it is parsed.
pub(crate) struct Source {
    /// The file's (or built-in map's) text.
    pub text: String,
    /// The name a map without a name of its own gets: the file name without extension.
    pub name: String,
    /// How errors name it: the path, or `built-in map 'NAME'`.
    pub origin: String,
}

/// Reads `spec` as [`load`] does (a file if one exists there, else a shipped map's name),
/// without parsing it, so the caller can check it or report its problems. A file larger
/// than [`MAX_MAP_BYTES`] is refused unread.
pub(crate) fn read(spec: &str) -> Result<Source> {
    let path = std::path::Path::new(spec);
    if path.is_file() {
        let len = std::fs::metadata(path).with_context(|| format!("cannot read map file '{spec}'"))?.len();
        if len > MAX_MAP_BYTES {
            bail!("map file '{spec}' is {len} bytes; a map file may be at most {MAX_MAP_BYTES}");
        }
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read map file '{spec}'"))?;
        let name = path.file_stem().map_or_else(|| spec.to_string(), |s| s.to_string_lossy().into_owned());
        return Ok(Source { text, name, origin: spec.to_string() });
    }
    match BUILTIN.iter().find(|(name, _)| *name == spec) {
        Some((name, text)) => Ok(Source {
            text: text.to_string(),
            name: name.to_string(),
            origin: format!("built-in map '{spec}'"),
        }),
        None => {
            let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
            bail!("no map file '{spec}' and no built-in map of that name (built-in: {})", names.join(", "))
        }
    }
}
