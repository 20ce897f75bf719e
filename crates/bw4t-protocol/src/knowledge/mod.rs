//! What one robot knows, as one plain Rust model every reader shares: the facts its
//! percept deltas say hold now, with typed accessors, and what the facts alone forget
//! (rooms seen, block colours, teammates' reports, the latest messages). The built-in
//! agents, the learning environment's observations, the English of [`Knowledge::describe`]
//! and the MCP robot all read it. It lives in this crate, beside the message language
//! that teammates' reports are read with; it knows no JSON.
//!
//! A delta is applied as the spec says a client keeps its state: a full one first forgets
//! every fact, then `not`, then `add`; single-valued facts (`at`, `sequenceIndex`,
//! `state`) are replaced. Place names are numbered once ([`Knowledge::for_map`] numbers a
//! map's zones by their index), so hot readers ask by number and nothing is copied per
//! tick.

mod memory;
mod places;
#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, OnceLock};

use bw4t_map::{Colour, DROP_ZONE, Map, ZoneIdx};
use bw4t_sim::{BlockId, MoveState, Percept, PerceptDelta};

pub use memory::{Heard, RoomSeen, RoomTold};
use places::{PlaceIdx, PlaceTable};

/// What one robot knows, kept from its own percept deltas.
#[derive(Clone, Debug, Default)]
pub struct Knowledge {
    /// Place names and what holds of each (`place`, `occupied`, the memory of rooms).
    places: PlaceTable,
    /// The listed places' names in name order, built on the first ask after they changed:
    /// players read them every decision, and they change about once a match.
    listed: OnceLock<Arc<[Arc<str>]>>,
    name: Option<Arc<str>>,
    robot: Option<u32>,
    sequence: Option<Arc<[Colour]>>,
    /// Other players, in name order.
    players: Vec<Arc<str>>,
    at: Option<PlaceIdx>,
    sequence_index: Option<u32>,
    state: Option<MoveState>,
    room: Option<PlaceIdx>,
    at_block: Option<BlockId>,
    holding: Option<BlockId>,
    /// `color` facts: the blocks visible from the robot's room, ascending by id.
    visible: Vec<(BlockId, Colour)>,
    /// `block` facts, ascending.
    blocks: Vec<BlockId>,
    /// The tick of the latest delta applied.
    tick: Option<u64>,
    /// Every block's colour once seen: a held block is no longer perceived with its colour.
    colours: BTreeMap<BlockId, Colour>,
    /// The latest messages, oldest first: at most [`memory::KEPT_MESSAGES`] before the
    /// latest delta, and every message of the latest delta.
    heard: Vec<Heard>,
    /// How many of `heard` came with the latest delta.
    latest: usize,
    /// Messages heard in all.
    n_heard: u64,
    /// Keep only the latest delta's messages (see [`Knowledge::latest_only`]).
    latest_only: bool,
}

/// Whether a place is a room: its name starts with `Room`, or it is the drop zone. Halls
/// (corridors and the fronts of rooms) are the other places.
pub fn is_room(place: &str) -> bool {
    place.starts_with("Room") || place == DROP_ZONE
}

impl Knowledge {
    /// Knows nothing yet.
    pub fn new() -> Knowledge {
        Knowledge::default()
    }

    /// Knows nothing yet, and numbers places by `map`'s zone indices, so that
    /// [`Knowledge::at_zone`], [`Knowledge::room_zone`] and [`Knowledge::zone_occupied`]
    /// answer for the robot's percepts of that map.
    pub fn for_map(map: &Map) -> Knowledge {
        Knowledge { places: PlaceTable::for_map(map), ..Knowledge::default() }
    }

    /// The same, keeping of the messages only those of the latest delta: for a reader that
    /// looks at no older message (a learner's observation counts the step's messages), so
    /// that memory does not grow with the talk.
    pub fn latest_only(mut self) -> Knowledge {
        self.latest_only = true;
        self
    }

    /// Applies one delta the robot was sent for `tick` (normally `delta.tick`): the facts,
    /// then the memory of rooms and messages.
    pub fn apply(&mut self, tick: u64, delta: &PerceptDelta) {
        let room_before = self.room;
        if delta.full {
            self.forget_facts();
        }
        for percept in &delta.not {
            self.stop(percept);
        }
        self.start_hearing();
        for percept in &delta.add {
            self.start(tick, percept);
        }
        self.tick = Some(tick);
        self.remember_room(tick, room_before);
    }

    fn forget_facts(&mut self) {
        self.places.forget_facts();
        self.listed.take();
        self.name = None;
        self.robot = None;
        self.sequence = None;
        self.players.clear();
        self.at = None;
        self.sequence_index = None;
        self.state = None;
        self.room = None;
        self.at_block = None;
        self.holding = None;
        self.visible.clear();
        self.blocks.clear();
    }

    /// A fact that started to hold (or changed value), or a message.
    fn start(&mut self, tick: u64, percept: &Percept) {
        match percept {
            Percept::Place(name) => {
                let i = self.places.number_shared(name);
                self.places.get_mut(i).listed = true;
                self.listed.take();
            }
            Percept::Player(name) => {
                if let Err(at) = self.players.binary_search(name) {
                    self.players.insert(at, name.clone());
                }
            }
            Percept::OwnName(name) => self.name = Some(name.clone()),
            Percept::Bot(id) => self.robot = Some(*id),
            Percept::Sequence(colours) => self.sequence = Some(colours.clone()),
            Percept::At(place) => self.at = Some(self.places.number_shared(place)),
            Percept::SequenceIndex(index) => self.sequence_index = Some(*index),
            Percept::State(state) => self.state = Some(*state),
            Percept::In(room) => self.room = Some(self.places.number_shared(room)),
            Percept::AtBlock(block) => self.at_block = Some(*block),
            Percept::Occupied(room) => {
                let i = self.places.number_shared(room);
                self.places.get_mut(i).occupied = true;
            }
            Percept::Color(block, colour) => {
                self.colours.insert(*block, *colour);
                match self.visible.binary_search_by_key(block, |(b, _)| *b) {
                    Ok(i) => self.visible[i].1 = *colour,
                    Err(i) => self.visible.insert(i, (*block, *colour)),
                }
            }
            Percept::Holding(block) => self.holding = Some(*block),
            Percept::Block(block) => {
                if let Err(at) = self.blocks.binary_search(block) {
                    self.blocks.insert(at, *block);
                }
            }
            Percept::Message { from, text } => self.hear(tick, from, text),
        }
    }

    /// A fact that stopped holding; one that does not hold is let be.
    fn stop(&mut self, percept: &Percept) {
        fn clear<T: PartialEq>(slot: &mut Option<T>, gone: &T) {
            if slot.as_ref() == Some(gone) {
                *slot = None;
            }
        }
        match percept {
            Percept::Place(name) => {
                if let Some(i) = self.places.find(name) {
                    self.places.get_mut(i).listed = false;
                    self.listed.take();
                }
            }
            Percept::Occupied(name) => {
                if let Some(i) = self.places.find(name) {
                    self.places.get_mut(i).occupied = false;
                }
            }
            Percept::At(name) => {
                if let Some(i) = self.places.find(name) {
                    clear(&mut self.at, &i);
                }
            }
            Percept::In(name) => {
                if let Some(i) = self.places.find(name) {
                    clear(&mut self.room, &i);
                }
            }
            Percept::Player(name) => {
                if let Ok(at) = self.players.binary_search(name) {
                    self.players.remove(at);
                }
            }
            Percept::OwnName(name) => clear(&mut self.name, name),
            Percept::Bot(id) => clear(&mut self.robot, id),
            Percept::Sequence(colours) => clear(&mut self.sequence, colours),
            Percept::SequenceIndex(index) => clear(&mut self.sequence_index, index),
            Percept::State(state) => clear(&mut self.state, state),
            Percept::AtBlock(block) => clear(&mut self.at_block, block),
            Percept::Holding(block) => clear(&mut self.holding, block),
            Percept::Color(block, colour) => self.visible.retain(|v| *v != (*block, *colour)),
            Percept::Block(block) => self.blocks.retain(|b| b != block),
            Percept::Message { .. } => {}
        }
    }

    /// The tick of the latest delta applied.
    pub fn tick(&self) -> Option<u64> {
        self.tick
    }

    /// The robot's player name (`ownName`).
    pub fn name(&self) -> Option<&str> {
        self.name.as_deref()
    }

    /// The robot's id (`bot`).
    pub fn robot(&self) -> Option<u32> {
        self.robot
    }

    /// The place the robot is at, or nearest to (`at`).
    pub fn at(&self) -> Option<&str> {
        self.at.map(|i| &**self.places.name(i))
    }

    /// The zone the robot is at (`at`), for a model made [`Knowledge::for_map`].
    pub fn at_zone(&self) -> Option<ZoneIdx> {
        self.at.and_then(|i| self.places.zone(i))
    }

    /// The room the robot is in (`in`), if it is in one.
    pub fn room(&self) -> Option<&str> {
        self.room.map(|i| &**self.places.name(i))
    }

    /// The zone of the room the robot is in (`in`), for a model made [`Knowledge::for_map`].
    pub fn room_zone(&self) -> Option<ZoneIdx> {
        self.room.and_then(|i| self.places.zone(i))
    }

    /// The block the robot holds, with its colour if it was seen.
    pub fn holding(&self) -> Option<(BlockId, Option<Colour>)> {
        self.holding.map(|block| (block, self.colour_of(block)))
    }

    /// The block the robot is at and can pick up (`atBlock`), with its colour if seen.
    pub fn at_block(&self) -> Option<(BlockId, Option<Colour>)> {
        self.at_block.map(|block| (block, self.colour_of(block)))
    }

    /// Whether the robot stands, travels or was stopped (`state`).
    pub fn state(&self) -> Option<MoveState> {
        self.state
    }

    /// The blocks visible from the robot's room (`color`), ascending by id.
    pub fn visible(&self) -> &[(BlockId, Colour)] {
        &self.visible
    }

    /// The colour of a block the robot has seen, now or before.
    pub fn colour_of(&self, block: BlockId) -> Option<Colour> {
        self.colours.get(&block).copied()
    }

    /// The goal colours in order (`sequence`); empty before the first delta.
    pub fn sequence(&self) -> &[Colour] {
        self.sequence.as_deref().unwrap_or_default()
    }

    /// The index of the next colour needed (`sequenceIndex`): how many are delivered.
    pub fn sequence_index(&self) -> u32 {
        self.sequence_index.unwrap_or(0)
    }

    /// The next colour the team needs, if the sequence is not complete.
    pub fn next_colour(&self) -> Option<Colour> {
        self.sequence().get(self.sequence_index() as usize).copied()
    }

    /// The rooms some robot is in (`occupied`, the robot's own room included), in name order.
    pub fn occupied(&self) -> impl Iterator<Item = &str> {
        self.places.sorted().filter(|(_, p)| p.occupied).map(|(name, _)| &**name)
    }

    /// Whether some robot is in zone `zone`, for a model made [`Knowledge::for_map`].
    pub fn zone_occupied(&self, zone: ZoneIdx) -> bool {
        self.places.zone(zone).is_some_and(|i| self.places.get(i).occupied)
    }

    /// Every place of the map (`place`), in name order.
    pub fn places(&self) -> impl Iterator<Item = &str> {
        self.listed().iter().map(|name| &**name)
    }

    /// [`Knowledge::places`] as one shared list, to keep without copying.
    pub fn place_list(&self) -> Arc<[Arc<str>]> {
        self.listed().clone()
    }

    fn listed(&self) -> &Arc<[Arc<str>]> {
        self.listed.get_or_init(|| {
            self.places.sorted().filter(|(_, p)| p.listed).map(|(name, _)| name.clone()).collect()
        })
    }

    /// The places that are rooms (see [`is_room`]), in name order.
    pub fn rooms(&self) -> impl Iterator<Item = &str> {
        self.places().filter(|p| is_room(p))
    }

    /// The other players in the match (`player`), in name order.
    pub fn players(&self) -> impl Iterator<Item = &str> {
        self.players.iter().map(|p| &**p)
    }

    /// [`Knowledge::players`] as the shared names the model holds.
    pub fn player_names(&self) -> &[Arc<str>] {
        &self.players
    }

    /// Every fact that holds, as percepts in their fixed order (messages are not facts).
    /// Built on each call: for tests and tools, not for every tick.
    pub fn facts(&self) -> BTreeSet<Percept> {
        let name = |i: PlaceIdx| self.places.name(i).clone();
        let mut facts = BTreeSet::new();
        facts.extend(
            self.places.sorted().filter(|(_, p)| p.listed).map(|(name, _)| Percept::Place(name.clone())),
        );
        facts.extend(self.players.iter().map(|p| Percept::Player(p.clone())));
        facts.extend(self.name.clone().map(Percept::OwnName));
        facts.extend(self.robot.map(Percept::Bot));
        facts.extend(self.sequence.clone().map(Percept::Sequence));
        facts.extend(self.at.map(|i| Percept::At(name(i))));
        facts.extend(self.sequence_index.map(Percept::SequenceIndex));
        facts.extend(self.state.map(Percept::State));
        facts.extend(self.room.map(|i| Percept::In(name(i))));
        facts.extend(self.at_block.map(Percept::AtBlock));
        facts.extend(
            self.places.sorted().filter(|(_, p)| p.occupied).map(|(name, _)| Percept::Occupied(name.clone())),
        );
        facts.extend(self.visible.iter().map(|&(b, c)| Percept::Color(b, c)));
        facts.extend(self.holding.map(Percept::Holding));
        facts.extend(self.blocks.iter().map(|&b| Percept::Block(b)));
        facts
    }

    /// Whether `fact` holds (a message never does).
    pub fn holds(&self, fact: &Percept) -> bool {
        let is = |i: Option<PlaceIdx>, name: &str| i.is_some_and(|i| **self.places.name(i) == *name);
        let place = |name: &str| self.places.named(name);
        match fact {
            Percept::Place(name) => place(name).is_some_and(|p| p.listed),
            Percept::Occupied(name) => place(name).is_some_and(|p| p.occupied),
            Percept::Player(name) => self.players.binary_search(name).is_ok(),
            Percept::OwnName(name) => self.name.as_ref() == Some(name),
            Percept::Bot(id) => self.robot == Some(*id),
            Percept::Sequence(colours) => self.sequence.as_ref() == Some(colours),
            Percept::At(name) => is(self.at, name),
            Percept::SequenceIndex(index) => self.sequence_index == Some(*index),
            Percept::State(state) => self.state == Some(*state),
            Percept::In(name) => is(self.room, name),
            Percept::AtBlock(block) => self.at_block == Some(*block),
            Percept::Color(block, colour) => self.visible.contains(&(*block, *colour)),
            Percept::Holding(block) => self.holding == Some(*block),
            Percept::Block(block) => self.blocks.binary_search(block).is_ok(),
            Percept::Message { .. } => false,
        }
    }
}
