//! The map model: zones, doors, spawn points, blocks and the goal sequence, validated.

use std::collections::BTreeMap;
use std::fmt;

use crate::colour::Colour;
use crate::geometry::{Door, Rect, Vec2};
use crate::locate::{ZoneGrid, is_room};
use crate::rules::{Problem, rule_problems};

/// Index of a zone in [`Map::zones`].
pub type ZoneIdx = usize;

/// The name of the one room that is the drop zone.
pub const DROP_ZONE: &str = "DropZone";

/// What a zone is; it decides walls, occupancy and navigation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZoneKind {
    /// Walls with doors, holds blocks, at most one robot at a time.
    Room,
    /// Free space (a hall).
    Corridor,
    /// Free space where robots would recharge in the original; behaves as a corridor.
    Charging,
    /// A walled-off zone nobody can enter or pass through.
    Blockade,
}

impl ZoneKind {
    /// The lower-case name used in map files.
    pub fn name(self) -> &'static str {
        match self {
            ZoneKind::Room => "room",
            ZoneKind::Corridor => "corridor",
            ZoneKind::Charging => "charging",
            ZoneKind::Blockade => "blockade",
        }
    }

    /// Whether robots may stand in or travel through the zone.
    pub fn is_walkable(self) -> bool {
        self != ZoneKind::Blockade
    }

    /// Whether the zone has walls around it (doors are openings in them).
    pub fn is_walled(self) -> bool {
        matches!(self, ZoneKind::Room | ZoneKind::Blockade)
    }
}

/// One named zone of the map.
#[derive(Clone, Debug, PartialEq)]
pub struct Zone {
    /// Unique name, used as the `PlaceID` in percepts and actions.
    pub name: String,
    /// Room, corridor, charging zone or blockade.
    pub kind: ZoneKind,
    /// Its box.
    pub rect: Rect,
    /// Openings in its walls (rooms only).
    pub doors: Vec<Door>,
    /// Names of the zones a robot may travel to directly from this one.
    pub neighbours: Vec<String>,
    /// Colours of the fixed blocks in it (rooms only).
    pub blocks: Vec<Colour>,
}

/// A named place where a robot can enter the match.
#[derive(Clone, Debug, PartialEq)]
pub struct Spawn {
    /// Name from the map file (informational; players choose their own names).
    pub name: String,
    /// Where the robot's centre starts.
    pub pos: Vec2,
}

/// Everything a map file says, before validation.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MapParts {
    /// A short name for reports.
    pub name: String,
    /// Width and height of the world.
    pub area: Vec2,
    /// The zones, in file order.
    pub zones: Vec<Zone>,
    /// Spawn points, in the order robots take them.
    pub spawns: Vec<Spawn>,
    /// Fixed goal colours, before any random ones.
    pub sequence: Vec<Colour>,
    /// How many random colours to append to the sequence (each also gets a block).
    pub random_sequence: u32,
    /// How many extra random blocks to place.
    pub random_blocks: u32,
    /// A fixed seed for the random content; `None` uses the match seed.
    pub seed: Option<u64>,
}

/// A validated map: names resolve, exactly one drop zone, doors on their room's edges.
#[derive(Clone, Debug, PartialEq)]
pub struct Map {
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
        Ok(Map { parts, adjacency, drop_zone, names, grid })
    }

    /// The map's short name.
    pub fn name(&self) -> &str {
        &self.parts.name
    }

    /// Width and height of the world.
    pub fn area(&self) -> Vec2 {
        self.parts.area
    }

    /// All zones, in file order; a [`ZoneIdx`] indexes this slice.
    pub fn zones(&self) -> &[Zone] {
        &self.parts.zones
    }

    /// The zones reachable in one step from `zone`, in index order.
    pub fn neighbours(&self, zone: ZoneIdx) -> &[ZoneIdx] {
        &self.adjacency[zone]
    }

    /// The drop zone's index.
    pub fn drop_zone(&self) -> ZoneIdx {
        self.drop_zone
    }

    /// The zone with this exact name.
    pub fn zone_named(&self, name: &str) -> Option<ZoneIdx> {
        self.names.get(name).copied()
    }

    /// The first zone (in file order) whose box contains `p`.
    pub fn zone_at(&self, p: Vec2) -> Option<ZoneIdx> {
        self.grid.first(&self.parts.zones, p, |_| true)
    }

    /// The first room (in file order) whose box contains `p`.
    pub fn room_at(&self, p: Vec2) -> Option<ZoneIdx> {
        self.grid.first(&self.parts.zones, p, is_room)
    }

    /// Spawn points in the order robots take them.
    pub fn spawns(&self) -> &[Spawn] {
        &self.parts.spawns
    }

    /// The fixed part of the goal sequence.
    pub fn sequence(&self) -> &[Colour] {
        &self.parts.sequence
    }

    /// How many random colours are appended to the sequence.
    pub fn random_sequence(&self) -> u32 {
        self.parts.random_sequence
    }

    /// How many extra random blocks are placed.
    pub fn random_blocks(&self) -> u32 {
        self.parts.random_blocks
    }

    /// The map's own seed for random content, if it fixes one.
    pub fn seed(&self) -> Option<u64> {
        self.parts.seed
    }

    /// Everything the map says, as given to [`Map::new`].
    pub fn parts(&self) -> &MapParts {
        &self.parts
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
