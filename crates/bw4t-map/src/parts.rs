//! What a map file says, before validation: zones, doors, spawn points, blocks and the
//! goal sequence.

use crate::colour::Colour;
use crate::geometry::{Door, Rect, Vec2};

/// Index of a zone in [`Map::zones`](crate::Map::zones).
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
