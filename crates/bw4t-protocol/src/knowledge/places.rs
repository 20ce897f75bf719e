//! Every place name a robot has come across, numbered once, with what is known of each:
//! whether it is a `place` of the map, whether it is `occupied`, and the memory of rooms.

use std::collections::BTreeMap;
use std::sync::Arc;

use bw4t_map::Map;

use super::{RoomSeen, RoomTold};

/// A place's number in a [`PlaceTable`]; for a table made from a map, a place of the map
/// has its zone's index.
pub(super) type PlaceIdx = usize;

/// What is known of one place. The memory is boxed: most places are never visited or
/// reported on, and a learner keeps one table per robot.
#[derive(Clone, Debug, Default)]
pub(super) struct Place {
    /// The `place` fact holds.
    pub(super) listed: bool,
    /// The `occupied` fact holds.
    pub(super) occupied: bool,
    pub(super) seen: Option<Box<RoomSeen>>,
    pub(super) told: Option<Box<RoomTold>>,
}

/// The names a table numbers. Tables made from one map share them (a clone of a
/// [`Knowledge`](super::Knowledge) copies no name); a table copies them only when it meets
/// a name the map does not have.
#[derive(Clone, Debug, Default)]
struct Names {
    names: Vec<Arc<str>>,
    by_name: BTreeMap<Arc<str>, PlaceIdx>,
    /// Numbers in name order, for lists that are read sorted.
    sorted: Vec<PlaceIdx>,
}

/// Place names, numbered in the order they were first met (a map's zones first), and what
/// is known of each.
#[derive(Clone, Debug, Default)]
pub(super) struct PlaceTable {
    names: Arc<Names>,
    places: Vec<Place>,
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
        match self.names.by_name.get(name) {
            Some(&i) => i,
            None => self.add(Arc::from(name)),
        }
    }

    /// The number of `name` (a percept's shared name, kept without a copy).
    pub(super) fn number_shared(&mut self, name: &Arc<str>) -> PlaceIdx {
        match self.names.by_name.get(&**name) {
            Some(&i) => i,
            None => self.add(name.clone()),
        }
    }

    fn add(&mut self, name: Arc<str>) -> PlaceIdx {
        let names = Arc::make_mut(&mut self.names);
        let i = names.names.len();
        let at = names.sorted.partition_point(|&j| names.names[j] < name);
        names.sorted.insert(at, i);
        names.by_name.insert(name.clone(), i);
        names.names.push(name);
        self.places.push(Place::default());
        i
    }

    /// The number of a name already met.
    pub(super) fn find(&self, name: &str) -> Option<PlaceIdx> {
        self.names.by_name.get(name).copied()
    }

    /// The name numbered `i`.
    pub(super) fn name(&self, i: PlaceIdx) -> &Arc<str> {
        &self.names.names[i]
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

    /// Every place with its name, in name order.
    pub(super) fn sorted(&self) -> impl Iterator<Item = (&Arc<str>, &Place)> {
        self.names.sorted.iter().map(|&i| (&self.names.names[i], &self.places[i]))
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
