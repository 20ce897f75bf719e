//! Finding maps: a name of a map shipped in `maps/` (built into the binary) or a file path
//! (native or original BW4T XML).

use anyhow::{Context, Result, bail};
use bw4t_map::Map;

/// The maps shipped in `maps/`, by name, as built into the binary.
pub const BUILTIN: &[(&str, &str)] =
    &[("default", include_str!("../../maps/default.toml")), ("fixed", include_str!("../../maps/fixed.toml"))];

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
