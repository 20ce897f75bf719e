//! The robot's situation as its strategy queries it, read from its [`Knowledge`] once per
//! decision.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use bw4t_map::Colour;
pub(crate) use bw4t_map::DROP_ZONE;
use bw4t_protocol::Knowledge;

/// Where robots wait for their turn at the drop zone, when the map has it.
pub(crate) const FRONT_DROP_ZONE: &str = "FrontDropZone";

/// The robot's situation, read from its knowledge.
#[derive(Debug, Default)]
pub(crate) struct View {
    /// Names shared with the knowledge: a decision copies no name it does not keep.
    pub places: Arc<[Arc<str>]>,
    pub players: Vec<Arc<str>>,
    pub sequence: Vec<Colour>,
    pub index: usize,
    pub at: Option<String>,
    pub room: Option<String>,
    pub holding: Option<u32>,
    pub at_block: Option<u32>,
    /// Blocks visible in the robot's room.
    pub visible: BTreeMap<u32, Colour>,
    pub occupied: BTreeSet<String>,
}

impl View {
    pub(crate) fn read(knowledge: &Knowledge) -> View {
        View {
            places: knowledge.place_list(),
            players: knowledge.player_names().to_vec(),
            sequence: knowledge.sequence().to_vec(),
            index: knowledge.sequence_index() as usize,
            at: knowledge.at().map(str::to_string),
            room: knowledge.room().map(str::to_string),
            holding: knowledge.holding().map(|(block, _)| block),
            at_block: knowledge.at_block().map(|(block, _)| block),
            visible: knowledge.visible().iter().copied().collect(),
            occupied: knowledge.occupied().map(str::to_string).collect(),
        }
    }

    /// Rooms that may hold blocks. The interface does not say which places are rooms; the
    /// spec's names (`RoomA1`...) start with `Room`, which every known map follows. On a map
    /// without such names every place but the drop zone is a candidate.
    pub(crate) fn rooms(&self) -> Vec<String> {
        let named: Vec<String> =
            self.places.iter().filter(|p| p.starts_with("Room")).map(|p| p.to_string()).collect();
        if named.is_empty() {
            self.places.iter().filter(|p| &***p != DROP_ZONE).map(|p| p.to_string()).collect()
        } else {
            named
        }
    }

    /// Whether the whole sequence has been delivered.
    pub(crate) fn complete(&self) -> bool {
        !self.sequence.is_empty() && self.index >= self.sequence.len()
    }

    /// Where to wait outside the drop zone: its front corridor when the map has one.
    pub(crate) fn waiting_place(&self, fallback: Option<&String>) -> String {
        if self.has_place(FRONT_DROP_ZONE) {
            FRONT_DROP_ZONE.to_string()
        } else {
            fallback.cloned().unwrap_or_else(|| DROP_ZONE.to_string())
        }
    }

    /// Whether the map has a place of this name.
    pub(crate) fn has_place(&self, name: &str) -> bool {
        self.places.iter().any(|p| &**p == name)
    }

    /// The colour of a block held, from what the robot saw before taking it.
    pub(crate) fn in_drop_zone(&self) -> bool {
        self.room.as_deref() == Some(DROP_ZONE)
    }
}

/// `items` rotated so that player `me` (by its rank among all players' names) starts at
/// its own share, which spreads a team over the rooms without talking.
pub(crate) fn rotated<T: Clone>(items: &[T], me: &str, players: &[Arc<str>]) -> Vec<T> {
    if items.is_empty() {
        return Vec::new();
    }
    let mut names: Vec<&str> = players.iter().map(|p| &**p).chain([me]).collect();
    names.sort_unstable();
    names.dedup();
    let rank = names.iter().position(|n| *n == me).unwrap_or(0);
    let start = rank * items.len() / names.len();
    items[start..].iter().chain(&items[..start]).cloned().collect()
}
