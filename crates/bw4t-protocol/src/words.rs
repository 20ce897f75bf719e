//! A robot's situation in plain English: [`Knowledge`] says what one robot knows in a few
//! short lines, so that language-model agents, people at the page and the message
//! sentences all describe it the same way.

use std::fmt::Write as _;
use std::sync::Arc;

use bw4t_map::{Colour, DROP_ZONE};
use bw4t_sim::{BlockId, MoveState};

use crate::knowledge::Knowledge;
use crate::language::Said;

/// How many of the latest messages a description shows.
const SHOWN_MESSAGES: usize = 5;
/// How many rooms a description lists, each way (known, and not yet known).
const SHOWN_ROOMS: usize = 24;

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

impl Knowledge {
    /// What the robot knows, in a few short lines of English.
    pub fn describe(&self) -> String {
        self.lines().join("\n")
    }

    /// A cheap copy of the present, for [`Knowledge::changes_since`].
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            introduced: self.name().is_some(),
            at: self.at().map(Arc::from),
            room: self.room().map(Arc::from),
            state: self.state(),
            holding: self.holding().map(|(b, _)| b),
            at_block: self.at_block().map(|(b, _)| b),
            visible: self.visible().to_vec(),
            sequence_index: self.sequence_index(),
            occupied: self.occupied().map(Arc::from).collect(),
            players: self.players().map(Arc::from).collect(),
            n_heard: self.heard_count(),
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
        let heard = self.messages();
        let new = now.n_heard.saturating_sub(before.n_heard).min(heard.len() as u64) as usize;
        for heard in &heard[heard.len() - new..] {
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
                format!("Here I see {}.", block_list(visible))
            };
            if let Some((block, colour)) = self.at_block() {
                let _ = write!(here, " I can pick up {}.", block_name(block, colour));
            }
            lines.push(here);
        }
        lines.push(self.goal());
        lines.push(self.room_lines());
        let others: Vec<&str> = self.occupied().filter(|r| Some(*r) != self.room()).collect();
        lines.push(format!("Other robots are in: {}.", list_or_none(&others)));
        lines.push(format!("Other players: {}.", list_or_none(&self.players().collect::<Vec<_>>())));
        let heard = self.messages();
        let shown = &heard[heard.len().saturating_sub(SHOWN_MESSAGES)..];
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
        for room in self.rooms().filter(|r| Some(*r) != here && *r != DROP_ZONE) {
            let seen = self.seen(room);
            // What a teammate said counts only when it is newer than what the robot saw.
            let told = self.told(room).filter(|t| seen.is_none_or(|s| t.tick > s.tick));
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
