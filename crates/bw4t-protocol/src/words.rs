//! A robot's situation in plain English: [`Knowledge`] keeps what one robot knows from its
//! own percept deltas, and says it in a few short lines, so that language-model agents,
//! people at the page and the message sentences all describe it the same way.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::mem::discriminant;
use std::sync::Arc;

use bw4t_map::{Colour, DROP_ZONE};
use bw4t_sim::{Beliefs, BlockId, MoveState, Percept, PerceptDelta};

use crate::language::Said;

/// How many messages [`Knowledge`] keeps (the oldest are forgotten first).
const KEPT_MESSAGES: usize = 20;
/// How many of the latest messages a description shows.
const SHOWN_MESSAGES: usize = 5;
/// How many rooms a description lists, each way (known, and not yet known).
const SHOWN_ROOMS: usize = 24;

/// What one robot knows, kept from its own percept deltas: the current facts (a
/// [`Beliefs`]) and what the facts alone forget: what it saw in each room the last time it
/// was inside, every block colour it has seen, what teammates said about rooms, and the
/// latest messages.
#[derive(Clone, Debug, Default)]
pub struct Knowledge {
    beliefs: Beliefs,
    /// The tick of the latest delta applied.
    tick: Option<u64>,
    /// Every block's colour once seen: a held block is no longer perceived with its colour.
    colours: BTreeMap<BlockId, Colour>,
    seen: BTreeMap<Arc<str>, RoomSeen>,
    told: BTreeMap<Arc<str>, RoomTold>,
    /// The latest messages, oldest first, at most [`KEPT_MESSAGES`].
    heard: Vec<Heard>,
    /// Messages heard in all, so a [`Snapshot`] knows which are new.
    n_heard: u64,
}

/// What a robot saw in a room the last time it was inside.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RoomSeen {
    /// The last tick it was inside (or the tick it left).
    pub tick: u64,
    /// The blocks it saw there, ascending by id; empty when the room was empty.
    pub blocks: Vec<(BlockId, Colour)>,
}

/// What a teammate said about a room's contents: its latest report (`contains`,
/// `contains_many`, `empty`, `checked`), all the messages of one sender in one tick.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RoomTold {
    /// When it was said.
    pub tick: u64,
    /// Who said it.
    pub from: Arc<str>,
    /// The messages of the report, in the order they came.
    pub said: Vec<Said>,
}

/// A message a teammate sent.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Heard {
    /// The tick it arrived.
    pub tick: u64,
    /// The sender's name.
    pub from: Arc<str>,
    /// The text as the match carries it (a [`Said`]'s text form, or free text).
    pub text: Arc<str>,
}

impl Heard {
    /// The message of the language it is, if it is one.
    pub fn said(&self) -> Option<Said> {
        Said::from_text(&self.text)
    }

    /// What the page's message list shows: a message of the language as its sentence,
    /// free text as it is.
    pub fn sentence(&self) -> String {
        self.said().and_then(|said| said.sentence().ok()).unwrap_or_else(|| self.text.to_string())
    }
}

/// A cheap copy of what a [`Knowledge`] holds at one moment, for
/// [`Knowledge::changes_since`]: take one, apply any number of deltas, then ask what
/// changed.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Snapshot {
    introduced: bool,
    at: Option<Arc<str>>,
    room: Option<Arc<str>>,
    state: Option<MoveState>,
    holding: Option<BlockId>,
    at_block: Option<BlockId>,
    visible: Vec<(BlockId, Colour)>,
    sequence_index: u32,
    occupied: Vec<Arc<str>>,
    players: Vec<Arc<str>>,
    n_heard: u64,
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

    /// Applies one delta the robot was sent for `tick` (normally `delta.tick`): the facts
    /// as [`Beliefs::apply`] does, then the memory of rooms and messages.
    pub fn apply(&mut self, tick: u64, delta: &PerceptDelta) {
        let room_before = self.room_name();
        self.beliefs.apply(delta);
        self.tick = Some(tick);
        for percept in &delta.add {
            if let Percept::Color(block, colour) = percept {
                self.colours.insert(*block, *colour);
            }
        }
        // Messages move out of the beliefs, which would keep every one for the whole match.
        for (from, text) in self.beliefs.take_messages() {
            self.hear(tick, from, text);
        }
        let room_now = self.room_name();
        if let Some(left) = room_before.filter(|r| Some(r) != room_now.as_ref()) {
            if let Some(seen) = self.seen.get_mut(&left) {
                seen.tick = tick;
            }
        }
        if let Some(room) = room_now {
            let blocks = self.visible();
            self.seen.insert(room, RoomSeen { tick, blocks });
        }
    }

    /// The current facts. Its messages are always empty: [`Knowledge::messages`] keeps them.
    pub fn beliefs(&self) -> &Beliefs {
        &self.beliefs
    }

    /// The tick of the latest delta applied.
    pub fn tick(&self) -> Option<u64> {
        self.tick
    }

    /// The robot's player name (`ownName`).
    pub fn name(&self) -> Option<&str> {
        match self.first(Percept::OwnName(Arc::from(""))) {
            Some(Percept::OwnName(name)) => Some(name),
            _ => None,
        }
    }

    /// The robot's id (`bot`).
    pub fn robot(&self) -> Option<u32> {
        match self.first(Percept::Bot(0)) {
            Some(Percept::Bot(id)) => Some(*id),
            _ => None,
        }
    }

    /// The place the robot is at, or nearest to (`at`).
    pub fn at(&self) -> Option<&str> {
        match self.first(Percept::At(Arc::from(""))) {
            Some(Percept::At(place)) => Some(place),
            _ => None,
        }
    }

    /// The room the robot is in (`in`), if it is in one.
    pub fn room(&self) -> Option<&str> {
        match self.first(Percept::In(Arc::from(""))) {
            Some(Percept::In(room)) => Some(room),
            _ => None,
        }
    }

    /// The block the robot holds, with its colour if it was seen.
    pub fn holding(&self) -> Option<(BlockId, Option<Colour>)> {
        match self.first(Percept::Holding(0)) {
            Some(Percept::Holding(block)) => Some((*block, self.colour_of(*block))),
            _ => None,
        }
    }

    /// The block the robot is at and can pick up (`atBlock`), with its colour if seen.
    pub fn at_block(&self) -> Option<(BlockId, Option<Colour>)> {
        match self.first(Percept::AtBlock(0)) {
            Some(Percept::AtBlock(block)) => Some((*block, self.colour_of(*block))),
            _ => None,
        }
    }

    /// Whether the robot stands, travels or was stopped (`state`).
    pub fn state(&self) -> Option<MoveState> {
        match self.first(Percept::State(MoveState::Arrived)) {
            Some(Percept::State(state)) => Some(*state),
            _ => None,
        }
    }

    /// The blocks visible from the robot's room, ascending by id.
    pub fn visible(&self) -> Vec<(BlockId, Colour)> {
        self.all(Percept::Color(0, Colour::ALL[0]))
            .filter_map(|p| if let Percept::Color(b, c) = p { Some((*b, *c)) } else { None })
            .collect()
    }

    /// The colour of a block the robot has seen.
    pub fn colour_of(&self, block: BlockId) -> Option<Colour> {
        self.colours.get(&block).copied()
    }

    /// The goal colours in order (`sequence`); empty before the first delta.
    pub fn sequence(&self) -> &[Colour] {
        match self.first(Percept::Sequence(Arc::from([]))) {
            Some(Percept::Sequence(colours)) => colours,
            _ => &[],
        }
    }

    /// The index of the next colour needed (`sequenceIndex`): how many are delivered.
    pub fn sequence_index(&self) -> u32 {
        match self.first(Percept::SequenceIndex(0)) {
            Some(Percept::SequenceIndex(index)) => *index,
            _ => 0,
        }
    }

    /// The next colour the team needs, if the sequence is not complete.
    pub fn next_colour(&self) -> Option<Colour> {
        self.sequence().get(self.sequence_index() as usize).copied()
    }

    /// The rooms some robot is in (`occupied`, the robot's own room included), by name.
    pub fn occupied(&self) -> Vec<&str> {
        self.all(Percept::Occupied(Arc::from("")))
            .filter_map(|p| if let Percept::Occupied(r) = p { Some(&**r) } else { None })
            .collect()
    }

    /// Every place of the map (`place`), by name.
    pub fn places(&self) -> Vec<&str> {
        self.all(Percept::Place(Arc::from("")))
            .filter_map(|p| if let Percept::Place(name) = p { Some(&**name) } else { None })
            .collect()
    }

    /// The places that are rooms (see [`is_room`]), by name.
    pub fn rooms(&self) -> Vec<&str> {
        self.places().into_iter().filter(|p| is_room(p)).collect()
    }

    /// The other players in the match (`player`), by name.
    pub fn players(&self) -> Vec<&str> {
        self.all(Percept::Player(Arc::from("")))
            .filter_map(|p| if let Percept::Player(name) = p { Some(&**name) } else { None })
            .collect()
    }

    /// What the robot saw in `room` the last time it was inside.
    pub fn seen(&self, room: &str) -> Option<&RoomSeen> {
        self.seen.get(room)
    }

    /// What a teammate last said about `room`'s contents.
    pub fn told(&self, room: &str) -> Option<&RoomTold> {
        self.told.get(room)
    }

    /// The latest messages from teammates, oldest first (a bounded number).
    pub fn messages(&self) -> &[Heard] {
        &self.heard
    }

    /// What the robot knows, in a few short lines of English.
    pub fn describe(&self) -> String {
        self.lines().join("\n")
    }

    /// A cheap copy of the present, for [`Knowledge::changes_since`].
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            introduced: self.name().is_some(),
            at: self.at().map(Arc::from),
            room: self.room_name(),
            state: self.state(),
            holding: self.holding().map(|(b, _)| b),
            at_block: self.at_block().map(|(b, _)| b),
            visible: self.visible(),
            sequence_index: self.sequence_index(),
            occupied: self.occupied().into_iter().map(Arc::from).collect(),
            players: self.players().into_iter().map(Arc::from).collect(),
            n_heard: self.n_heard,
        }
    }

    /// What changed since `before`, one short English line each: moves, blocks seen and
    /// gone, pick-ups, put-downs and deliveries, rooms occupied and freed, players joining
    /// and leaving, messages. A robot that knew nothing before gets its whole description.
    pub fn changes_since(&self, before: &Snapshot) -> Vec<String> {
        if !before.introduced {
            return self.lines();
        }
        let now = self.snapshot();
        let mut lines = Vec::new();
        self.moves(before, &now, &mut lines);
        self.blocks(before, &now, &mut lines);
        let sequence = self.sequence();
        if now.sequence_index > before.sequence_index {
            lines.push(match self.next_colour() {
                Some(next) => format!(
                    "Delivered: the team is now at {} of {}; next needed: {next}.",
                    now.sequence_index,
                    sequence.len()
                ),
                None => {
                    format!("Delivered: the team is now at {0} of {0}, the goal is complete.", sequence.len())
                }
            });
        }
        let mine = now.room.as_ref();
        for room in added(&before.occupied, &now.occupied).filter(|r| Some(*r) != mine) {
            lines.push(format!("{room} is now occupied."));
        }
        for room in added(&now.occupied, &before.occupied).filter(|r| Some(*r) != before.room.as_ref()) {
            lines.push(format!("{room} is free now."));
        }
        for player in added(&before.players, &now.players) {
            lines.push(format!("{player} joined."));
        }
        for player in added(&now.players, &before.players) {
            lines.push(format!("{player} left."));
        }
        let new = now.n_heard.saturating_sub(before.n_heard).min(self.heard.len() as u64) as usize;
        for heard in &self.heard[self.heard.len() - new..] {
            lines.push(format!("{} said: \"{}\"", heard.from, heard.sentence()));
        }
        lines
    }

    /// The description's lines.
    fn lines(&self) -> Vec<String> {
        let Some(name) = self.name() else {
            return vec!["I know nothing yet: no percepts have arrived.".to_string()];
        };
        let mut lines = Vec::new();
        let mut me = format!("I am {name}");
        if let Some(robot) = self.robot() {
            let _ = write!(me, " (robot {robot})");
        }
        match (self.room(), self.at()) {
            (Some(room), Some(at)) if room != at => {
                let _ = write!(me, ", in {room}, near {at}.");
            }
            (Some(room), _) => {
                let _ = write!(me, ", in {room}.");
            }
            (None, Some(at)) => {
                let _ = write!(me, ", at {at}, not in a room.");
            }
            (None, None) => me.push_str(", somewhere unknown."),
        }
        match self.holding() {
            Some((block, colour)) => {
                let _ = write!(me, " I hold {}.", block_name(block, colour));
            }
            None => me.push_str(" I hold nothing."),
        }
        me.push_str(match self.state() {
            Some(MoveState::Arrived) | None => " I am standing still.",
            Some(MoveState::Traveling) => " I am on my way.",
            Some(MoveState::Collided) => " I am stuck: my last move was blocked.",
        });
        lines.push(me);
        if self.room().is_some() {
            let visible = self.visible();
            let mut here = if visible.is_empty() {
                "Here I see no blocks.".to_string()
            } else {
                format!("Here I see {}.", block_list(&visible))
            };
            if let Some((block, colour)) = self.at_block() {
                let _ = write!(here, " I can pick up {}.", block_name(block, colour));
            }
            lines.push(here);
        }
        lines.push(self.goal());
        lines.push(self.room_lines());
        let others: Vec<&str> = self.occupied().into_iter().filter(|r| Some(*r) != self.room()).collect();
        lines.push(format!("Other robots are in: {}.", list_or_none(&others)));
        lines.push(format!("Other players: {}.", list_or_none(&self.players())));
        let shown = &self.heard[self.heard.len().saturating_sub(SHOWN_MESSAGES)..];
        if shown.is_empty() {
            lines.push("Teammates said nothing yet.".to_string());
        }
        for heard in shown {
            lines.push(format!("{} said at tick {}: \"{}\"", heard.from, heard.tick, heard.sentence()));
        }
        lines
    }

    /// `Goal: Yellow, Red, Blue (2 of 3 left); next needed: Red.`
    fn goal(&self) -> String {
        let sequence = self.sequence();
        let names: Vec<&str> = sequence.iter().map(|c| c.name()).collect();
        let names = names.join(", ");
        match self.next_colour() {
            Some(next) => {
                let left = sequence.len() - self.sequence_index() as usize;
                format!("Goal: {names} ({left} of {} left); next needed: {next}.", sequence.len())
            }
            None => format!("Goal: {names} (all {} delivered).", sequence.len()),
        }
    }

    /// What is known of each room but the one the robot is in, and which are not known.
    fn room_lines(&self) -> String {
        let here = self.room();
        let mut known: Vec<(u64, &str, String)> = Vec::new();
        let mut unknown = Vec::new();
        // The drop zone is where blocks go, not a room to search.
        for room in self.rooms().into_iter().filter(|r| Some(*r) != here && *r != DROP_ZONE) {
            let seen = self.seen.get(room);
            // What a teammate said counts only when it is newer than what the robot saw.
            let told = self.told.get(room).filter(|t| seen.is_none_or(|s| t.tick > s.tick));
            let mut text = String::new();
            if let Some(seen) = seen {
                text = match seen.blocks.as_slice() {
                    [] => format!("{room} was empty at tick {}", seen.tick),
                    blocks => format!("{room} had {} at tick {}", block_list(blocks), seen.tick),
                };
            }
            if let Some(told) = told {
                let said = format!("{} said it {} at tick {}", told.from, report(&told.said), told.tick);
                text =
                    if text.is_empty() { format!("{room}: {said}") } else { format!("{text}, then {said}") };
            }
            match (seen, told) {
                (None, None) => unknown.push(room),
                _ => known.push((told.map_or(0, |t| t.tick).max(seen.map_or(0, |s| s.tick)), room, text)),
            }
        }
        // On a large map, the most recent news, still listed by name.
        let mut more = String::new();
        if known.len() > SHOWN_ROOMS {
            known.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(b.1)));
            more = format!("; and {} more", known.len() - SHOWN_ROOMS);
            known.truncate(SHOWN_ROOMS);
            known.sort_by(|a, b| a.1.cmp(b.1));
        }
        let mut line = if known.is_empty() {
            "Rooms: none seen yet.".to_string()
        } else {
            let texts: Vec<&str> = known.iter().map(|k| k.2.as_str()).collect();
            format!("Rooms: {}{more}.", texts.join("; "))
        };
        if !unknown.is_empty() {
            let extra = unknown.len().saturating_sub(SHOWN_ROOMS);
            unknown.truncate(SHOWN_ROOMS);
            let _ = write!(line, " Not yet known: {}", unknown.join(", "));
            if extra > 0 {
                let _ = write!(line, " and {extra} more");
            }
            line.push('.');
        }
        line
    }

    /// Lines about the robot's place and state.
    fn moves(&self, before: &Snapshot, now: &Snapshot, lines: &mut Vec<String>) {
        let at = now.at.as_deref().unwrap_or("an unknown place");
        let moved = now.at != before.at;
        if let Some(left) = before.room.as_ref().filter(|r| Some(*r) != now.room.as_ref()) {
            lines.push(format!("I left {left}."));
        }
        match now.state {
            Some(MoveState::Arrived) if moved || before.state != now.state => {
                lines.push(format!("I arrived at {at}."));
            }
            Some(MoveState::Traveling) if moved => lines.push(format!("I am on my way, now at {at}.")),
            Some(MoveState::Traveling) if before.state != now.state => lines.push("I am on my way.".into()),
            Some(MoveState::Collided) if moved || before.state != now.state => {
                lines.push(format!("I was stopped at {at}: a closed door or a robot is in the way."));
            }
            _ => {}
        }
        // Entering a room the robot is not yet `at` (it still stands in the doorway).
        if let Some(room) = now
            .room
            .as_deref()
            .filter(|r| before.room.as_deref() != Some(*r) && now.at.as_deref() != Some(*r))
        {
            lines.push(format!("I entered {room}."));
        }
    }

    /// Lines about the blocks the robot sees, holds and can pick up.
    fn blocks(&self, before: &Snapshot, now: &Snapshot, lines: &mut Vec<String>) {
        let same_room = before.room.is_some() && before.room == now.room;
        // A block just put down is not news as a block seen.
        let new: Vec<(BlockId, Colour)> = now
            .visible
            .iter()
            .filter(|b| !before.visible.contains(b) && before.holding != Some(b.0))
            .copied()
            .collect();
        if !new.is_empty() {
            lines.push(format!("I now see {}.", block_list(&new)));
        } else if now.room.is_some() && !same_room && now.visible.is_empty() {
            lines.push(format!("{} is empty.", now.room.as_deref().unwrap_or_default()));
        }
        if before.holding != now.holding {
            if let Some(block) = before.holding {
                lines.push(format!("I put down {}.", block_name(block, self.colour_of(block))));
            }
            if let Some(block) = now.holding {
                lines.push(format!("I picked up {}.", block_name(block, self.colour_of(block))));
            }
        }
        if same_room {
            // Blocks gone from the room the robot stays in, but not into its hands.
            let gone: Vec<(BlockId, Colour)> = before
                .visible
                .iter()
                .filter(|b| !now.visible.contains(b) && now.holding != Some(b.0))
                .copied()
                .collect();
            if !gone.is_empty() {
                lines.push(format!("No longer here: {}.", block_list(&gone)));
            }
        }
        if let Some(block) = now.at_block.filter(|b| before.at_block != Some(*b) && now.holding != Some(*b)) {
            lines.push(format!("I can pick up {}.", block_name(block, self.colour_of(block))));
        }
    }

    /// Takes in one message: kept, and read for what it says about a room.
    fn hear(&mut self, tick: u64, from: Arc<str>, text: Arc<str>) {
        if let Some((room, said)) = Said::from_text(&text).and_then(|said| Some((said.room.clone()?, said))) {
            if matches!(said.kind.as_str(), "contains" | "contains_many" | "empty" | "checked") {
                let room: Arc<str> = room.into();
                match self.told.get_mut(&room) {
                    // One sender's messages of one tick are one report: they add up.
                    Some(told) if told.tick == tick && told.from == from => {
                        if !told.said.contains(&said) {
                            told.said.push(said);
                        }
                    }
                    _ => {
                        self.told.insert(room, RoomTold { tick, from: from.clone(), said: vec![said] });
                    }
                }
            }
        }
        if self.heard.len() == KEPT_MESSAGES {
            self.heard.remove(0);
        }
        self.heard.push(Heard { tick, from, text });
        self.n_heard += 1;
    }

    /// The room the robot is in, as a shared name.
    fn room_name(&self) -> Option<Arc<str>> {
        match self.first(Percept::In(Arc::from(""))) {
            Some(Percept::In(room)) => Some(room.clone()),
            _ => None,
        }
    }

    /// The facts of `least`'s kind, in order; `least` must be the smallest fact of its kind,
    /// since facts are sorted by kind first.
    fn all(&self, least: Percept) -> impl Iterator<Item = &Percept> {
        let kind = discriminant(&least);
        self.beliefs.facts().range(least..).take_while(move |p| discriminant(*p) == kind)
    }

    /// The first fact of `least`'s kind (the only one, for single-valued facts).
    fn first(&self, least: Percept) -> Option<&Percept> {
        self.all(least).next()
    }
}

/// `block 11 (Yellow)`, or `block 11` when its colour was never seen.
fn block_name(block: BlockId, colour: Option<Colour>) -> String {
    match colour {
        Some(colour) => format!("block {block} ({colour})"),
        None => format!("block {block}"),
    }
}

/// `block 11 (Yellow), block 12 (Blue)`.
fn block_list(blocks: &[(BlockId, Colour)]) -> String {
    let names: Vec<String> = blocks.iter().map(|(b, c)| block_name(*b, Some(*c))).collect();
    names.join(", ")
}

fn list_or_none(names: &[&str]) -> String {
    if names.is_empty() { "none".to_string() } else { names.join(", ") }
}

/// What a report says of its room: `contains 2 Blue, Red`, `is empty`, `has been checked`.
fn report(said: &[Said]) -> String {
    let colours: Vec<String> = said
        .iter()
        .filter_map(|s| match (s.kind.as_str(), &s.colour, s.count) {
            ("contains", Some(colour), _) => Some(colour.clone()),
            ("contains_many", Some(colour), Some(count)) => Some(format!("{count} {colour}")),
            _ => None,
        })
        .collect();
    if !colours.is_empty() {
        format!("contains {}", colours.join(", "))
    } else if said.iter().any(|s| s.kind == "empty") {
        "is empty".to_string()
    } else {
        "has been checked".to_string()
    }
}

/// The items of `now` that are not in `before` (both sorted).
fn added<'a>(before: &'a [Arc<str>], now: &'a [Arc<str>]) -> impl Iterator<Item = &'a Arc<str>> {
    now.iter().filter(move |x| before.binary_search(x).is_err())
}

#[cfg(test)]
mod tests;
