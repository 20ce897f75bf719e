//! What an agent knows from its percepts, in a form its strategy can query.

use std::collections::{BTreeMap, BTreeSet};

use bw4t_map::Colour;
use bw4t_sim::{Beliefs, MoveState, Percept};

/// The name of the drop zone, fixed by the spec.
pub(crate) const DROP_ZONE: &str = "DropZone";
/// Where robots wait for their turn at the drop zone, when the map has it.
pub(crate) const FRONT_DROP_ZONE: &str = "FrontDropZone";

/// The robot's situation, read from its beliefs.
#[derive(Debug, Default)]
pub(crate) struct View {
    pub places: Vec<String>,
    pub players: Vec<String>,
    pub sequence: Vec<Colour>,
    pub index: usize,
    pub at: Option<String>,
    pub room: Option<String>,
    pub state: Option<MoveState>,
    pub holding: Option<u32>,
    pub at_block: Option<u32>,
    /// Blocks visible in the robot's room.
    pub visible: BTreeMap<u32, Colour>,
    pub occupied: BTreeSet<String>,
}

impl View {
    pub(crate) fn read(beliefs: &Beliefs) -> View {
        let mut v = View::default();
        for p in beliefs.facts() {
            match p {
                Percept::Place(n) => v.places.push(n.to_string()),
                Percept::Player(n) => v.players.push(n.to_string()),
                Percept::Sequence(s) => v.sequence = s.to_vec(),
                Percept::SequenceIndex(i) => v.index = *i as usize,
                Percept::At(n) => v.at = Some(n.to_string()),
                Percept::In(n) => v.room = Some(n.to_string()),
                Percept::State(s) => v.state = Some(*s),
                Percept::Holding(b) => v.holding = Some(*b),
                Percept::AtBlock(b) => v.at_block = Some(*b),
                Percept::Color(b, c) => {
                    v.visible.insert(*b, *c);
                }
                Percept::Occupied(n) => {
                    v.occupied.insert(n.to_string());
                }
                _ => {}
            }
        }
        v
    }

    /// Rooms that may hold blocks. The interface does not say which places are rooms; the
    /// spec's names (`RoomA1`...) start with `Room`, which every known map follows. On a map
    /// without such names every place but the drop zone is a candidate.
    pub(crate) fn rooms(&self) -> Vec<String> {
        let named: Vec<String> = self.places.iter().filter(|p| p.starts_with("Room")).cloned().collect();
        if named.is_empty() {
            self.places.iter().filter(|p| p.as_str() != DROP_ZONE).cloned().collect()
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
        if self.places.iter().any(|p| p == FRONT_DROP_ZONE) {
            FRONT_DROP_ZONE.to_string()
        } else {
            fallback.cloned().unwrap_or_else(|| DROP_ZONE.to_string())
        }
    }

    /// The colour of a block held, from what the robot saw before taking it.
    pub(crate) fn in_drop_zone(&self) -> bool {
        self.room.as_deref() == Some(DROP_ZONE)
    }
}

/// `items` rotated so that player `me` (by its rank among all players' names) starts at
/// its own share, which spreads a team over the rooms without talking.
pub(crate) fn rotated<T: Clone>(items: &[T], me: &str, players: &[String]) -> Vec<T> {
    if items.is_empty() {
        return Vec::new();
    }
    let mut names: Vec<&str> = players.iter().map(String::as_str).chain([me]).collect();
    names.sort_unstable();
    names.dedup();
    let rank = names.iter().position(|n| *n == me).unwrap_or(0);
    let start = rank * items.len() / names.len();
    items[start..].iter().chain(&items[..start]).cloned().collect()
}
