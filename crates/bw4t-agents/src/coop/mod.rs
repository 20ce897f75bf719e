//! The cooperative strategy: explore without duplicating work, tell the team what each
//! room holds, agree (by message) who fetches which position of the sequence, deliver in
//! order, and wait for one's turn outside the drop zone.
//!
//! Messages, all to `all`: `explore ROOM`, `room ROOM ID:COLOUR...` (what a room holds now),
//! `claim POS BLOCK`, `release POS`. A claim replaces the claimer's previous one. When two
//! players claim the same position in the same tick, every player lets the lexically
//! smaller name win, so all agree without a leader.
//!
//! The progress rule, which makes the team deliver every position (no deadlock): with `n`
//! robots on the team, a robot
//! - holds at most one claim, and only on a position in the window `[index, index + n)`,
//!   whether to fetch a block or for a block it already holds;
//! - holds a block only under such a claim, or on its way to put the block back into a
//!   room (a loser of a collision, or a holder whose position was filled or left the
//!   window, first re-claims an open position of its colour in the window, else puts the
//!   block back);
//! - moves its claim to an earlier open position of its block's colour.
//!
//! Claims name distinct positions, so while nobody has claimed `index` at most `n - 1`
//! robots have claims, and at least one robot is free (after at most one trip to put a
//! block back) to fetch for `index` or look for its colour, unless a holder of that colour
//! moves its claim there first. Whoever claims `index` delivers it, so the sequence advances.
//! The guarantee is for a team that follows this rule; players that do not claim count as
//! free in `n`.

use std::collections::{BTreeMap, BTreeSet};

use bw4t_map::Colour;
use bw4t_sim::{Action, Beliefs, OrderOutcome, Receiver};

use crate::view::{DROP_ZONE, View, rotated};
use crate::{Agent, Observation};

#[derive(Clone, Debug, PartialEq, Eq)]
enum Task {
    Idle,
    Explore(String),
    Fetch {
        pos: usize,
        block: u32,
        room: String,
    },
    Deliver {
        pos: usize,
    },
    /// Take the held block back into a room: no position in the window is open for it.
    PutBack,
}

/// A cooperative player.
pub struct Cooperative {
    name: String,
    beliefs: Beliefs,
    /// Blocks believed to lie in rooms: id -> (room, colour).
    known: BTreeMap<u32, (String, Colour)>,
    /// The colour of every block ever seen, so a held block's colour is known.
    colours: BTreeMap<u32, Colour>,
    explored: BTreeSet<String>,
    /// Room -> the player exploring it.
    exploring: BTreeMap<String, String>,
    /// Sequence position -> (player, block).
    claims: BTreeMap<usize, (String, u32)>,
    task: Task,
    next_action: u64,
    /// The goTo/goToBlock in flight.
    moving: Option<u64>,
    /// The corridor the robot was last in (a place to wait when the map has no FrontDropZone).
    last_hall: Option<String>,
    outbox: Vec<String>,
}

impl Cooperative {
    /// A cooperative agent for player `name`.
    pub fn new(name: &str) -> Self {
        Cooperative {
            name: name.to_string(),
            beliefs: Beliefs::default(),
            known: BTreeMap::new(),
            colours: BTreeMap::new(),
            explored: BTreeSet::new(),
            exploring: BTreeMap::new(),
            claims: BTreeMap::new(),
            task: Task::Idle,
            next_action: 0,
            moving: None,
            last_hall: None,
            outbox: Vec::new(),
        }
    }

    fn say(&mut self, text: String) {
        self.outbox.push(text);
    }

    fn hear(&mut self, from: &str, text: &str) {
        let words: Vec<&str> = text.split_whitespace().collect();
        match words.as_slice() {
            ["explore", room] => {
                let holder = self.exploring.entry(room.to_string()).or_insert_with(|| from.to_string());
                if from < holder.as_str() {
                    *holder = from.to_string();
                }
                if self.task == Task::Explore(room.to_string()) && from < self.name.as_str() {
                    self.task = Task::Idle;
                }
            }
            ["room", room, blocks @ ..] => {
                self.explored.insert(room.to_string());
                self.known.retain(|_, (r, _)| r != room);
                for entry in blocks {
                    let Some((id, colour)) = entry.split_once(':') else { continue };
                    if let (Ok(id), Ok(colour)) = (id.parse::<u32>(), colour.parse::<Colour>()) {
                        self.known.insert(id, (room.to_string(), colour));
                        self.colours.insert(id, colour);
                    }
                }
            }
            ["claim", pos, block] => {
                let (Ok(pos), Ok(block)) = (pos.parse::<usize>(), block.parse::<u32>()) else { return };
                self.resolve_claim(from, pos, block);
            }
            ["release", pos] => {
                if let Ok(pos) = pos.parse::<usize>() {
                    if self.claims.get(&pos).is_some_and(|(who, _)| who == from) {
                        self.claims.remove(&pos);
                    }
                }
            }
            _ => {}
        }
    }

    /// Records `from`'s claim, which replaces its previous one. Where it collides with
    /// another claim on the same position the smaller name wins; every player resolves
    /// the same messages the same way, so all keep the same claims.
    fn resolve_claim(&mut self, from: &str, pos: usize, block: u32) {
        self.claims.retain(|_, (who, _)| who != from);
        if let Some((rival, _)) = self.claims.get(&pos) {
            if rival.as_str() < from {
                return;
            }
            if *rival == self.name {
                // Lost the position, even with the block in hand: Idle re-claims within
                // the window or puts the block back, so no robot holds a block unclaimed.
                self.task = Task::Idle;
            }
        }
        self.claims.insert(pos, (from.to_string(), block));
        // Two players going for one block: the later name looks for another (a block in
        // hand is kept; whoever goes for it will find it gone).
        if let Task::Fetch { pos: mine, block: wanted, .. } = self.task {
            if wanted == block && from < self.name.as_str() && mine != pos {
                self.release(mine);
                self.task = Task::Idle;
            }
        }
    }

    /// Claims `pos`, replacing this player's previous claim.
    fn claim(&mut self, pos: usize, block: u32) {
        self.claims.retain(|_, (who, _)| *who != self.name);
        self.claims.insert(pos, (self.name.clone(), block));
        self.say(format!("claim {pos} {block}"));
    }

    fn holds_claim(&self, pos: usize) -> bool {
        self.claims.get(&pos).is_some_and(|(who, _)| *who == self.name)
    }

    /// The positions a robot may claim: one ahead per teammate, so while the next position
    /// is not claimed somebody is free to fetch it (the progress rule in the module docs).
    fn window(v: &View) -> std::ops::Range<usize> {
        let team = v.players.len() + 1;
        v.index..(v.index + team).min(v.sequence.len())
    }

    /// The first open position in the window for a block of `colour`.
    fn open_position(&self, v: &View, colour: Option<Colour>) -> Option<usize> {
        Self::window(v).find(|p| Some(v.sequence[*p]) == colour && !self.claims.contains_key(p))
    }

    fn release(&mut self, pos: usize) {
        if self.claims.get(&pos).is_some_and(|(who, _)| *who == self.name) {
            self.claims.remove(&pos);
            self.say(format!("release {pos}"));
        }
    }

    /// What the robot sees in its room is the truth about that room: record it, and tell
    /// the team when it differs from what was believed.
    fn observe_room(&mut self, v: &View) {
        let Some(room) = v.room.clone() else { return };
        if room == DROP_ZONE {
            return;
        }
        let before: BTreeMap<u32, Colour> =
            self.known.iter().filter(|(_, (r, _))| *r == room).map(|(id, (_, c))| (*id, *c)).collect();
        let first_visit = self.explored.insert(room.clone());
        if self.exploring.get(&room).is_some_and(|who| *who == self.name) {
            self.exploring.remove(&room);
        }
        if before != v.visible || first_visit {
            self.known.retain(|_, (r, _)| *r != room);
            for (id, colour) in &v.visible {
                self.known.insert(*id, (room.clone(), *colour));
                self.colours.insert(*id, *colour);
            }
            let list: Vec<String> = v.visible.iter().map(|(id, c)| format!("{id}:{c}")).collect();
            self.say(format!("room {room} {}", list.join(" ")).trim_end().to_string());
        }
    }

    fn go(&mut self, actions: &mut Vec<Action>, action: Action) {
        if matches!(action, Action::GoTo(_) | Action::GoToBlock(_)) {
            self.moving = Some(self.next_action + actions.len() as u64);
        }
        actions.push(action);
    }

    /// Runs the task machine until it produces an action or decides to wait.
    fn step(&mut self, v: &View, actions: &mut Vec<Action>) {
        for _ in 0..6 {
            match self.task.clone() {
                Task::Idle => {
                    self.choose(v);
                    if self.task == Task::Idle {
                        return self.wait_outside(v, actions);
                    }
                }
                Task::Explore(room) => {
                    if v.room.as_ref() == Some(&room) || self.explored.contains(&room) {
                        self.task = Task::Idle;
                    } else if v.occupied.contains(&room) {
                        // Someone is inside; it will be seen later or reported.
                        self.exploring.remove(&room);
                        self.task = Task::Idle;
                        return self.choose_other_than(v, &room, actions);
                    } else {
                        return self.go(actions, Action::GoTo(room));
                    }
                }
                Task::Fetch { pos, block, room } => {
                    if !self.holds_claim(pos) || !Self::window(v).contains(&pos) {
                        self.release(pos);
                        self.task = Task::Idle;
                    } else if v.holding == Some(block) {
                        self.task = Task::Deliver { pos };
                    } else if v.holding.is_some() || !self.known.contains_key(&block) {
                        self.release(pos);
                        self.task = Task::Idle;
                    } else if v.room.as_ref() == Some(&room) {
                        if v.at_block == Some(block) {
                            return actions.push(Action::PickUp(Some(block)));
                        }
                        if v.visible.contains_key(&block) {
                            return self.go(actions, Action::GoToBlock(block));
                        }
                        self.known.remove(&block);
                        self.release(pos);
                        self.task = Task::Idle;
                    } else if v.occupied.contains(&room) {
                        return self.wait_outside(v, actions);
                    } else {
                        return self.go(actions, Action::GoTo(room));
                    }
                }
                Task::Deliver { pos } => {
                    let Some(held) = v.holding else {
                        self.release(pos);
                        self.task = Task::Idle;
                        continue;
                    };
                    if !self.holds_claim(pos) || !Self::window(v).contains(&pos) {
                        // Lost, filled some other way, or out of the window (the team
                        // shrank): Idle re-claims within the window or puts the block back.
                        self.release(pos);
                        self.task = Task::Idle;
                        continue;
                    }
                    // An earlier open position of the same colour comes first.
                    let colour = self.colours.get(&held).copied();
                    let earlier = (v.index..pos)
                        .find(|p| Some(v.sequence[*p]) == colour && !self.claims.contains_key(p));
                    if let Some(earlier) = earlier {
                        self.release(pos);
                        self.claim(earlier, held);
                        self.task = Task::Deliver { pos: earlier };
                        continue;
                    }
                    if v.in_drop_zone() {
                        if v.index == pos {
                            self.claims.remove(&pos);
                            self.task = Task::Idle;
                            return actions.push(Action::PutDown);
                        }
                        let place = v.waiting_place(self.last_hall.as_ref());
                        return self.go(actions, Action::GoTo(place));
                    }
                    if v.index == pos {
                        if v.occupied.contains(DROP_ZONE) {
                            return self.wait_outside(v, actions);
                        }
                        return self.go(actions, Action::GoTo(DROP_ZONE.to_string()));
                    }
                    let place = v.waiting_place(self.last_hall.as_ref());
                    if v.at.as_ref() != Some(&place) || v.room.is_some() {
                        self.go(actions, Action::GoTo(place));
                    }
                    return;
                }
                Task::PutBack => {
                    let Some(held) = v.holding else {
                        self.task = Task::Idle;
                        continue;
                    };
                    if let Some(pos) = self.open_position(v, self.colours.get(&held).copied()) {
                        // Needed again on the way: keep it.
                        self.claim(pos, held);
                        self.task = Task::Deliver { pos };
                    } else if v.room.is_some() && !v.in_drop_zone() {
                        self.task = Task::Idle;
                        return actions.push(Action::PutDown);
                    } else {
                        let room = self.put_back_room(v);
                        return self.go(actions, Action::GoTo(room));
                    }
                }
            }
        }
    }

    /// Waiting happens in a hall, never in a room: a robot waiting in a room would keep
    /// out whoever it is waiting for.
    fn wait_outside(&mut self, v: &View, actions: &mut Vec<Action>) {
        if v.room.is_some() {
            let place = if v.in_drop_zone() {
                v.waiting_place(self.last_hall.as_ref())
            } else {
                self.last_hall.clone().unwrap_or_else(|| v.waiting_place(None))
            };
            self.go(actions, Action::GoTo(place));
        }
    }

    /// A room to put a block back into: the first of this robot's rooms nobody is in.
    fn put_back_room(&self, v: &View) -> String {
        let rooms: Vec<String> = v.rooms().into_iter().filter(|r| r != DROP_ZONE).collect();
        let rooms = rotated(&rooms, &self.name, &v.players);
        rooms.iter().find(|r| !v.occupied.contains(*r)).or(rooms.first()).cloned().unwrap_or_default()
    }

    fn choose_other_than(&mut self, v: &View, skip: &str, actions: &mut Vec<Action>) {
        self.choose_with(v, Some(skip));
        if self.task != Task::Idle {
            self.step(v, actions);
        }
    }

    fn choose(&mut self, v: &View) {
        self.choose_with(v, None);
    }

    /// Picks the next task: use a held block, fetch for the earliest open position, or
    /// explore a room nobody has.
    fn choose_with(&mut self, v: &View, skip: Option<&str>) {
        let rooms: Vec<String> = rotated(
            &v.rooms().into_iter().filter(|r| r != DROP_ZONE).collect::<Vec<_>>(),
            &self.name,
            &v.players,
        );
        if let Some(held) = v.holding {
            // A block in hand is bound by the window like a new fetch.
            self.task = match self.open_position(v, self.colours.get(&held).copied()) {
                Some(pos) => {
                    self.claim(pos, held);
                    Task::Deliver { pos }
                }
                None => Task::PutBack,
            };
            return;
        }
        let claimed: BTreeSet<u32> = self.claims.values().map(|(_, b)| *b).collect();
        let rank = |room: &str| rooms.iter().position(|r| r == room).unwrap_or(usize::MAX);
        for pos in Self::window(v) {
            if self.claims.contains_key(&pos) {
                continue;
            }
            let colour = v.sequence[pos];
            let best = self
                .known
                .iter()
                .filter(|(id, (room, c))| {
                    *c == colour && !claimed.contains(id) && Some(room.as_str()) != skip
                })
                .min_by_key(|(id, (room, _))| (v.room.as_ref() != Some(room), rank(room), **id))
                .map(|(id, (room, _))| (*id, room.clone()));
            if let Some((block, room)) = best {
                self.claim(pos, block);
                self.task = Task::Fetch { pos, block, room };
                return;
            }
        }
        let free = rooms.iter().find(|r| {
            !self.explored.contains(*r)
                && self.exploring.get(*r).is_none_or(|who| *who == self.name)
                && !v.occupied.contains(*r)
                && Some(r.as_str()) != skip
        });
        if let Some(room) = free.cloned() {
            self.exploring.insert(room.clone(), self.name.clone());
            self.say(format!("explore {room}"));
            self.task = Task::Explore(room);
            return;
        }
        // Everything is explored yet the next position has no known block: what rooms hold
        // may have changed unseen, so look again.
        let next_open = v.index < v.sequence.len() && !self.claims.contains_key(&v.index);
        let nobody_exploring = self.exploring.is_empty();
        if next_open && nobody_exploring && rooms.iter().all(|r| self.explored.contains(r)) {
            self.explored.clear();
        }
    }
}

impl Agent for Cooperative {
    fn decide(&mut self, obs: &Observation) -> Vec<Action> {
        for delta in &obs.percepts {
            self.beliefs.apply(delta);
        }
        for (from, text) in self.beliefs.take_messages() {
            self.hear(&from, &text);
        }
        for ack in &obs.acks {
            if ack.result.is_err() && Some(ack.action) == self.moving {
                self.moving = None;
            }
        }
        for done in &obs.done {
            if Some(done.action) == self.moving {
                self.moving = None;
                if done.outcome == OrderOutcome::Collided {
                    if let Task::Explore(room) = &self.task {
                        self.exploring.remove(room);
                        self.task = Task::Idle;
                    }
                }
            }
        }
        let v = View::read(&self.beliefs);
        if v.room.is_none() {
            self.last_hall.clone_from(&v.at);
        }
        // Forget what players who left had claimed.
        let present: BTreeSet<&String> = v.players.iter().chain([&self.name]).collect();
        self.claims.retain(|p, (who, _)| present.contains(who) && *p >= v.index);
        self.exploring.retain(|_, who| present.contains(who));
        self.observe_room(&v);
        let mut actions = Vec::new();
        if !v.complete() {
            if self.moving.is_none() {
                self.step(&v, &mut actions);
            } else if self.task == Task::Idle {
                // On the way somewhere without a task (or a message took it away): take up
                // new work if there is some, else keep going.
                self.choose(&v);
                if self.task != Task::Idle {
                    self.step(&v, &mut actions);
                }
            }
        }
        let messages: Vec<Action> = std::mem::take(&mut self.outbox)
            .into_iter()
            .map(|text| Action::SendMessage { to: Receiver::All, text })
            .collect();
        if !messages.is_empty() {
            // Messages go first; a move decided above keeps its number after them.
            if let Some(m) = self.moving.as_mut().filter(|m| **m >= self.next_action) {
                *m += messages.len() as u64;
            }
            actions.splice(0..0, messages);
        }
        self.next_action += actions.len() as u64;
        actions
    }
}
