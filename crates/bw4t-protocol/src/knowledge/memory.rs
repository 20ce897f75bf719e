//! What a robot remembers beyond the current facts: what it saw in each room the last time
//! it was inside, what teammates said about rooms in the message language, and the latest
//! messages.

use std::sync::Arc;

use bw4t_map::Colour;
use bw4t_sim::BlockId;

use super::Knowledge;
use super::places::PlaceIdx;
use crate::language::Said;

/// How many messages [`Knowledge::messages`] keeps (the oldest are forgotten first).
pub(super) const KEPT_MESSAGES: usize = 20;

/// The kinds of message that report on a room's contents.
const REPORTS: [&str; 4] = ["contains", "contains_many", "empty", "checked"];

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
    /// The text read as a message of the language, once.
    said: Option<Said>,
}

impl Heard {
    /// The message of the language it is, if it is one.
    pub fn said(&self) -> Option<&Said> {
        self.said.as_ref()
    }

    /// What the page's message list shows: a message of the language as its sentence,
    /// free text as it is.
    pub fn sentence(&self) -> String {
        self.said().and_then(|said| said.sentence().ok()).unwrap_or_else(|| self.text.to_string())
    }
}

impl Knowledge {
    /// What the robot saw in `room` the last time it was inside.
    pub fn seen(&self, room: &str) -> Option<&RoomSeen> {
        self.places.named(room)?.seen.as_deref()
    }

    /// What a teammate last said about `room`'s contents.
    pub fn told(&self, room: &str) -> Option<&RoomTold> {
        self.places.named(room)?.told.as_deref()
    }

    /// The latest messages from teammates, oldest first (a bounded number).
    pub fn messages(&self) -> &[Heard] {
        if self.latest_only {
            return self.latest_messages();
        }
        &self.heard[self.heard.len().saturating_sub(KEPT_MESSAGES)..]
    }

    /// How many messages are kept before a delta brings new ones.
    fn kept_messages(&self) -> usize {
        if self.latest_only { 0 } else { KEPT_MESSAGES }
    }

    /// Every message of the latest delta applied, in the order they came.
    pub fn latest_messages(&self) -> &[Heard] {
        &self.heard[self.heard.len() - self.latest..]
    }

    /// How many messages the robot has heard in all.
    pub fn heard_count(&self) -> u64 {
        self.n_heard
    }

    /// Forgets the oldest messages beyond the bound, before a delta brings new ones.
    pub(super) fn start_hearing(&mut self) {
        let over = self.heard.len().saturating_sub(self.kept_messages());
        self.heard.drain(..over);
        self.latest = 0;
    }

    /// Takes in one message: kept, and read for what it says about a room.
    pub(super) fn hear(&mut self, tick: u64, from: &Arc<str>, text: &Arc<str>) {
        let said = Said::from_text(text);
        let report = said.as_ref().filter(|s| REPORTS.contains(&s.kind.as_str()));
        if let Some((room, said)) = report.and_then(|s| Some((s.room.as_deref()?, s))) {
            let i = self.places.number(room);
            let told = &mut self.places.get_mut(i).told;
            match told {
                // One sender's messages of one tick are one report: they add up.
                Some(told) if told.tick == tick && told.from == *from => {
                    if !told.said.contains(said) {
                        told.said.push(said.clone());
                    }
                }
                _ => *told = Some(Box::new(RoomTold { tick, from: from.clone(), said: vec![said.clone()] })),
            }
        }
        self.heard.push(Heard { tick, from: from.clone(), text: text.clone(), said });
        self.latest += 1;
        self.n_heard += 1;
    }

    /// Keeps what the robot sees in its room, and the tick it left the room it was in.
    pub(super) fn remember_room(&mut self, tick: u64, before: Option<PlaceIdx>) {
        if let Some(left) = before.filter(|r| Some(*r) != self.room) {
            if let Some(seen) = self.places.get_mut(left).seen.as_mut() {
                seen.tick = tick;
            }
        }
        let Some(room) = self.room else { return };
        match &mut self.places.get_mut(room).seen {
            Some(seen) => {
                seen.tick = tick;
                if seen.blocks != self.visible {
                    seen.blocks.clone_from(&self.visible);
                }
            }
            none => *none = Some(Box::new(RoomSeen { tick, blocks: self.visible.clone() })),
        }
    }
}
