//! Finding maps: a name of a map shipped in `maps/` (built into the binary) or a file path
//! (native or original BW4T XML).

use anyhow::{Context, Result, bail};
use bw4t_map::Map;

/// The maps shipped in `maps/`, by name, as built into the binary.
pub const BUILTIN: &[(&str, &str)] = &[
    ("default", include_str!("../../maps/default.toml")),
    ("fixed", include_str!("../../maps/fixed.toml")),
    ("rooms12", include_str!("../../maps/rooms12.toml")),
    ("rooms24", include_str!("../../maps/rooms24.toml")),
    ("crowd24", include_str!("../../maps/crowd24.toml")),
    ("side-doors", include_str!("../../maps/side-doors.toml")),
    ("rooms100", include_str!("../../maps/rooms100.toml")),
];

/// Loads `spec`: a path to a map file if one exists there, else the name of a shipped map.
pub fn load(spec: &str) -> Result<Map> {
    let path = std::path::Path::new(spec);
    let (text, origin, name) = if path.is_file() {
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read map file '{spec}'"))?;
        let stem = path.file_stem().map_or_else(|| spec.to_string(), |s| s.to_string_lossy().into_owned());
        (text, spec.to_string(), stem)
    } else if let Some((_, text)) = BUILTIN.iter().find(|(name, _)| *name == spec) {
        (text.to_string(), format!("built-in map '{spec}'"), spec.to_string())
    } else {
        let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
        bail!("no map file '{spec}' and no built-in map of that name (built-in: {})", names.join(", "));
    };
    // Original BW4T XML maps and native TOML maps are told apart by their first character.
    Map::parse(&text, &name).with_context(|| format!("{origin} is not a valid map"))
}

/// A map's text, found as [`load`] finds it, before it is parsed.
pub struct Source {
    /// The file's (or built-in map's) text.
    pub text: String,
    /// The name a map without a name of its own gets: the file name without extension.
    pub name: String,
}

/// Reads `spec` as [`load`] does (a file if one exists there, else a shipped map's name),
/// without parsing it, so the caller can check it or report its problems.
pub fn read(spec: &str) -> Result<Source> {
    let path = std::path::Path::new(spec);
    if path.is_file() {
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read map file '{spec}'"))?;
        let name = path.file_stem().map_or_else(|| spec.to_string(), |s| s.to_string_lossy().into_owned());
        return Ok(Source { text, name });
    }
    match BUILTIN.iter().find(|(name, _)| *name == spec) {
        Some((name, text)) => Ok(Source { text: text.to_string(), name: name.to_string() }),
        None => {
            let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
            bail!("no map file '{spec}' and no built-in map of that name (built-in: {})", names.join(", "))
        }
    }
}
