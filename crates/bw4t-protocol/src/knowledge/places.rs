//! Every place name a robot has come across, numbered once, with what is known of each:
//! whether it is a `place` of the map, whether it is `occupied`, and the memory of rooms.

use std::collections::BTreeMap;
use std::sync::Arc;

use bw4t_map::Map;

use super::{RoomSeen, RoomTold};

/// A place's number in a [`PlaceTable`]; for a table made from a map, a place of the map
/// has its zone's index.
pub(super) type PlaceIdx = usize;

/// What is known of one place.
#[derive(Clone, Debug)]
pub(super) struct Place {
    pub(super) name: Arc<str>,
    /// The `place` fact holds.
    pub(super) listed: bool,
    /// The `occupied` fact holds.
    pub(super) occupied: bool,
    pub(super) seen: Option<RoomSeen>,
    pub(super) told: Option<RoomTold>,
}

/// Place names, numbered in the order they were first met (a map's zones first).
#[derive(Clone, Debug, Default)]
pub(super) struct PlaceTable {
    places: Vec<Place>,
    by_name: BTreeMap<Arc<str>, PlaceIdx>,
    /// Numbers in name order, for lists that are read sorted.
    sorted: Vec<PlaceIdx>,
    /// How many numbers are the zones of the map the table was made from.
    zones: usize,
}

impl PlaceTable {
    /// A table whose first numbers are `map`'s zone indices.
    pub(super) fn for_map(map: &Map) -> PlaceTable {
        let mut table = PlaceTable::default();
        for zone in map.zones() {
            table.number(&zone.name);
        }
        table.zones = map.zones().len();
        table
    }

    /// The number of `name`, given it one if it is new.
    pub(super) fn number(&mut self, name: &str) -> PlaceIdx {
        match self.by_name.get(name) {
            Some(&i) => i,
            None => self.add(Arc::from(name)),
        }
    }

    /// The number of `name` (a percept's shared name, kept without a copy).
    pub(super) fn number_shared(&mut self, name: &Arc<str>) -> PlaceIdx {
        match self.by_name.get(&**name) {
            Some(&i) => i,
            None => self.add(name.clone()),
        }
    }

    fn add(&mut self, name: Arc<str>) -> PlaceIdx {
        let i = self.places.len();
        let at = self.sorted.partition_point(|&j| self.places[j].name < name);
        self.sorted.insert(at, i);
        self.by_name.insert(name.clone(), i);
        self.places.push(Place { name, listed: false, occupied: false, seen: None, told: None });
        i
    }

    /// The number of a name already met.
    pub(super) fn find(&self, name: &str) -> Option<PlaceIdx> {
        self.by_name.get(name).copied()
    }

    pub(super) fn get(&self, i: PlaceIdx) -> &Place {
        &self.places[i]
    }

    pub(super) fn get_mut(&mut self, i: PlaceIdx) -> &mut Place {
        &mut self.places[i]
    }

    /// The place of `name`, if it was met.
    pub(super) fn named(&self, name: &str) -> Option<&Place> {
        self.find(name).map(|i| &self.places[i])
    }

    /// Every place, in name order.
    pub(super) fn sorted(&self) -> impl Iterator<Item = &Place> {
        self.sorted.iter().map(|&i| &self.places[i])
    }

    /// `i` as a zone of the table's map, if it is one.
    pub(super) fn zone(&self, i: PlaceIdx) -> Option<PlaceIdx> {
        (i < self.zones).then_some(i)
    }

    /// Forgets the facts about places (not the memory), as a full snapshot does.
    pub(super) fn forget_facts(&mut self) {
        for place in &mut self.places {
            place.listed = false;
            place.occupied = false;
        }
    }
}
