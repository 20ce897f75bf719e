//! The validated map: its parts once every rule holds, and where each zone is.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

use crate::colour::Colour;
use crate::geometry::Vec2;
use crate::locate::{ZoneGrid, is_room};
use crate::parts::{DROP_ZONE, MapParts, Spawn, Zone, ZoneIdx};
use crate::problem::Problem;
use crate::rules::rule_problems;

/// A validated map: names resolve, exactly one drop zone, doors on their room's edges.
/// Cloning one shares it: the many matches of a server or a vector of environments on one
/// map read one copy (and keep it in cache).
#[derive(Clone, Debug, PartialEq)]
pub struct Map {
    shared: Arc<Layout>,
}

/// What a map is once built; never changed.
#[derive(Debug, PartialEq)]
struct Layout {
    parts: MapParts,
    adjacency: Vec<Vec<ZoneIdx>>,
    drop_zone: ZoneIdx,
    /// Zone indices by name.
    names: BTreeMap<String, ZoneIdx>,
    grid: ZoneGrid,
}

impl Map {
    /// Validates `parts` against the map's rules (the errors `map check` gives for
    /// [`MapParts`] before it looks at play-ability), reporting every rule broken, not only
    /// the first.
    pub fn new(parts: MapParts) -> Result<Map, MapError> {
        let problems: Vec<Problem> = rule_problems(&parts).into_iter().filter(Problem::is_error).collect();
        if !problems.is_empty() {
            return Err(MapError { problems });
        }
        // The rules make every neighbour name and the drop zone resolve.
        let index: BTreeMap<&str, ZoneIdx> =
            parts.zones.iter().enumerate().map(|(i, z)| (z.name.as_str(), i)).collect();
        let mut adjacency = vec![Vec::new(); parts.zones.len()];
        for (i, zone) in parts.zones.iter().enumerate() {
            for n in &zone.neighbours {
                let j = index[n.as_str()];
                // Neighbour lists are undirected edges, whichever side names them.
                if i != j {
                    adjacency[i].push(j);
                    adjacency[j].push(i);
                }
            }
        }
        for list in &mut adjacency {
            list.sort_unstable();
            list.dedup();
        }
        let drop_zone = index[DROP_ZONE];
        let names = index.into_iter().map(|(name, i)| (name.to_string(), i)).collect();
        let grid = ZoneGrid::new(&parts.zones);
        Ok(Map { shared: Arc::new(Layout { parts, adjacency, drop_zone, names, grid }) })
    }

    /// The map's short name.
    pub fn name(&self) -> &str {
        &self.shared.parts.name
    }

    /// Width and height of the world.
    pub fn area(&self) -> Vec2 {
        self.shared.parts.area
    }

    /// All zones, in file order; a [`ZoneIdx`] indexes this slice.
    pub fn zones(&self) -> &[Zone] {
        &self.shared.parts.zones
    }

    /// The zones reachable in one step from `zone`, in index order.
    pub fn neighbours(&self, zone: ZoneIdx) -> &[ZoneIdx] {
        &self.shared.adjacency[zone]
    }

    /// The drop zone's index.
    pub fn drop_zone(&self) -> ZoneIdx {
        self.shared.drop_zone
    }

    /// The zone with this exact name.
    pub fn zone_named(&self, name: &str) -> Option<ZoneIdx> {
        self.shared.names.get(name).copied()
    }

    /// The first zone (in file order) whose box contains `p`.
    pub fn zone_at(&self, p: Vec2) -> Option<ZoneIdx> {
        self.shared.grid.first(&self.shared.parts.zones, p, |_| true)
    }

    /// [`Map::zone_at`] and [`Map::room_at`] together, in one look.
    pub fn zone_and_room_at(&self, p: Vec2) -> (Option<ZoneIdx>, Option<ZoneIdx>) {
        self.shared.grid.first_zone_and_room(&self.shared.parts.zones, p)
    }

    /// The zone whose box is nearest to `p` (containing it, if any does), the first in file
    /// order on ties.
    pub fn nearest_zone(&self, p: Vec2) -> ZoneIdx {
        self.shared.grid.nearest(&self.shared.parts.zones, p)
    }

    /// The first room (in file order) whose box contains `p`.
    pub fn room_at(&self, p: Vec2) -> Option<ZoneIdx> {
        self.shared.grid.first(&self.shared.parts.zones, p, is_room)
    }

    /// Spawn points in the order robots take them.
    pub fn spawns(&self) -> &[Spawn] {
        &self.shared.parts.spawns
    }

    /// The fixed part of the goal sequence.
    pub fn sequence(&self) -> &[Colour] {
        &self.shared.parts.sequence
    }

    /// How many random colours are appended to the sequence.
    pub fn random_sequence(&self) -> u32 {
        self.shared.parts.random_sequence
    }

    /// How many extra random blocks are placed.
    pub fn random_blocks(&self) -> u32 {
        self.shared.parts.random_blocks
    }

    /// The map's own seed for random content, if it fixes one.
    pub fn seed(&self) -> Option<u64> {
        self.shared.parts.seed
    }

    /// Everything the map says, as given to [`Map::new`].
    pub fn parts(&self) -> &MapParts {
        &self.shared.parts
    }
}

/// A map that failed validation, with every rule it breaks.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub struct MapError {
    /// The errors, in the order `map check` lists them, each with the zone, door or field
    /// concerned as its place.
    pub problems: Vec<Problem>,
}

impl fmt::Display for MapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let problems: Vec<String> = self.problems.iter().map(Problem::located).collect();
        write!(f, "invalid map: {}", problems.join("; "))
    }
}
