//! What a learning robot knows, kept from its percept deltas as a remote player would:
//! where it is, what it holds, the blocks it sees, the occupied rooms, and the messages
//! that arrived during the current step.

use bw4t_map::{Colour, Map, ZoneIdx};
use bw4t_protocol::{KINDS, Said, kind_row};
use bw4t_sim::{BlockId, MoveState, Percept, PerceptDelta};

/// One learner's view.
#[derive(Clone, Debug)]
pub(crate) struct Seen {
    pub(crate) at: Option<ZoneIdx>,
    pub(crate) room: Option<ZoneIdx>,
    pub(crate) holding: Option<BlockId>,
    pub(crate) at_block: Option<BlockId>,
    pub(crate) state: MoveState,
    /// The blocks visible in its room, ascending by id.
    pub(crate) visible: Vec<(BlockId, Colour)>,
    /// Per zone: whether some robot is in it.
    pub(crate) occupied: Vec<bool>,
    /// Per message kind (in [`KINDS`] order), then free text: messages this step.
    pub(crate) messages: Vec<u32>,
    /// Every block's colour once seen, by id (index 0 unused).
    colours: Vec<Option<Colour>>,
}

impl Seen {
    pub(crate) fn new(zones: usize) -> Seen {
        Seen {
            at: None,
            room: None,
            holding: None,
            at_block: None,
            state: MoveState::Arrived,
            visible: Vec::new(),
            occupied: vec![false; zones],
            messages: vec![0; KINDS.len() + 1],
            colours: Vec::new(),
        }
    }

    /// Forgets the messages of the previous step.
    pub(crate) fn start_step(&mut self) {
        self.messages.iter_mut().for_each(|n| *n = 0);
    }

    /// The colour of a block it has seen.
    pub(crate) fn colour_of(&self, block: BlockId) -> Option<Colour> {
        self.colours.get(block as usize).copied().flatten()
    }

    /// Applies one delta: `not`, then `add`, as a client does.
    pub(crate) fn apply(&mut self, map: &Map, delta: &PerceptDelta) {
        if delta.full {
            let colours = std::mem::take(&mut self.colours);
            *self = Seen::new(self.occupied.len());
            self.colours = colours;
        }
        for p in &delta.not {
            match p {
                Percept::In(_) => self.room = None,
                Percept::AtBlock(_) => self.at_block = None,
                Percept::Holding(_) => self.holding = None,
                Percept::Occupied(name) => self.set_occupied(map, name, false),
                Percept::Color(b, _) | Percept::Block(b) => self.visible.retain(|(v, _)| v != b),
                _ => {}
            }
        }
        for p in &delta.add {
            match p {
                Percept::At(name) => self.at = map.zone_named(name),
                Percept::In(name) => self.room = map.zone_named(name),
                Percept::AtBlock(b) => self.at_block = Some(*b),
                Percept::Holding(b) => self.holding = Some(*b),
                Percept::State(s) => self.state = *s,
                Percept::Occupied(name) => self.set_occupied(map, name, true),
                Percept::Color(b, c) => self.see(*b, *c),
                Percept::Message { text, .. } => self.heard(text),
                _ => {}
            }
        }
    }

    fn set_occupied(&mut self, map: &Map, name: &str, on: bool) {
        if let Some(z) = map.zone_named(name) {
            self.occupied[z] = on;
        }
    }

    fn see(&mut self, block: BlockId, colour: Colour) {
        let at = block as usize;
        if self.colours.len() <= at {
            self.colours.resize(at + 1, None);
        }
        self.colours[at] = Some(colour);
        match self.visible.binary_search_by_key(&block, |(b, _)| *b) {
            Ok(i) => self.visible[i].1 = colour,
            Err(i) => self.visible.insert(i, (block, colour)),
        }
    }

    fn heard(&mut self, text: &str) {
        let kind = Said::from_text(text)
            .and_then(|said| kind_row(&said.kind).map(|row| row.word))
            .and_then(|word| KINDS.iter().position(|r| r.word == word));
        let slot = kind.unwrap_or(KINDS.len());
        self.messages[slot] += 1;
    }
}
