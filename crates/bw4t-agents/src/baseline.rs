//! The baseline: every robot for itself, no messages. It explores rooms in its own order,
//! remembers what it saw, fetches the colour needed now and puts back a block that is no
//! longer needed. It completes, slowly, which is what makes teamwork show in the figures.

use std::collections::{BTreeMap, BTreeSet};

use bw4t_map::Colour;
use bw4t_sim::Action;

use crate::orders::Orders;
use crate::view::{DROP_ZONE, View, rotated};
use crate::{Agent, Observation};

/// A player that works alone.
pub struct Baseline {
    name: String,
    orders: Orders,
    /// Blocks seen lying in rooms: id -> (room, colour).
    known: BTreeMap<u32, (String, Colour)>,
    explored: BTreeSet<String>,
    /// Where the held block was picked up, to put it back there.
    picked_in: Option<String>,
    last_hall: Option<String>,
}

impl Baseline {
    /// A baseline agent for player `name`.
    pub fn new(name: &str) -> Self {
        Baseline {
            name: name.to_string(),
            orders: Orders::new(),
            known: BTreeMap::new(),
            explored: BTreeSet::new(),
            picked_in: None,
            last_hall: None,
        }
    }

    fn go(&mut self, place: String) -> Vec<Action> {
        self.orders.move_first();
        vec![Action::GoTo(place)]
    }

    fn plan(&mut self, v: &View) -> Vec<Action> {
        let needed = v.sequence.get(v.index).copied();
        if let Some(held) = v.holding {
            if self.orders.knowledge.colour_of(held) == needed {
                if v.in_drop_zone() {
                    self.picked_in = None;
                    return vec![Action::PutDown];
                }
                if v.occupied.contains(DROP_ZONE) {
                    return self.wait_outside(v);
                }
                return self.go(DROP_ZONE.to_string());
            }
            // Not needed now: put it back in a room (never in the drop zone or a hall).
            if v.room.is_some() && !v.in_drop_zone() {
                self.picked_in = None;
                return vec![Action::PutDown];
            }
            let room = self.picked_in.clone().or_else(|| v.rooms().into_iter().find(|r| r != DROP_ZONE));
            let free = v.rooms().into_iter().find(|r| r != DROP_ZONE && !v.occupied.contains(r));
            return match room.filter(|r| !v.occupied.contains(r)).or(free) {
                Some(r) => self.go(r),
                None => self.wait_outside(v),
            };
        }
        let Some(colour) = needed else { return Vec::new() };
        let here = v.room.clone();
        let wanted = self
            .known
            .iter()
            .filter(|(_, (_, c))| *c == colour)
            .min_by_key(|(id, (room, _))| (Some(room) != here.as_ref(), **id))
            .map(|(id, (room, _))| (*id, room.clone()));
        if let Some((block, room)) = wanted {
            if here.as_ref() == Some(&room) {
                if v.at_block == Some(block) {
                    self.picked_in = Some(room);
                    return vec![Action::PickUp(Some(block))];
                }
                self.orders.move_first();
                return vec![Action::GoToBlock(block)];
            }
            if v.occupied.contains(&room) {
                return self.wait_outside(v);
            }
            return self.go(room);
        }
        let rooms: Vec<String> = rotated(
            &v.rooms().into_iter().filter(|r| r != DROP_ZONE).collect::<Vec<_>>(),
            &self.name,
            &v.players,
        );
        if rooms.iter().all(|r| self.explored.contains(r)) {
            self.explored.clear();
        }
        let next = rooms.iter().find(|r| !self.explored.contains(*r) && !v.occupied.contains(*r)).cloned();
        match next {
            Some(room) => self.go(room),
            None => self.wait_outside(v),
        }
    }

    /// Waits in a hall, never in a room, so as not to keep out whoever it waits for.
    fn wait_outside(&mut self, v: &View) -> Vec<Action> {
        if v.room.is_none() {
            return Vec::new();
        }
        let place = if v.in_drop_zone() {
            v.waiting_place(self.last_hall.as_ref())
        } else {
            self.last_hall.clone().unwrap_or_else(|| v.waiting_place(None))
        };
        self.go(place)
    }
}

impl Agent for Baseline {
    fn decide(&mut self, obs: &Observation) -> Vec<Action> {
        self.orders.observe(obs);
        let v = View::read(&self.orders.knowledge);
        if v.room.is_none() {
            self.last_hall.clone_from(&v.at);
        }
        if let Some(room) = v.room.clone().filter(|r| r != DROP_ZONE) {
            self.explored.insert(room.clone());
            self.known.retain(|_, (r, _)| *r != room);
            for (id, colour) in &v.visible {
                self.known.insert(*id, (room.clone(), *colour));
            }
        }
        let actions = if v.complete() || self.orders.moving() { Vec::new() } else { self.plan(&v) };
        self.orders.returned(actions.len());
        actions
    }
}
