//! The crate's tests: spaces against the docs, masks against the match, rewards, episode
//! ends, determinism and the vector against single environments.

mod spaces;

use bw4t_map::Map;

/// The shipped default map.
pub(crate) fn default_map() -> Map {
    Map::from_native(include_str!("../../../../maps/default.toml")).expect("the shipped map")
}
