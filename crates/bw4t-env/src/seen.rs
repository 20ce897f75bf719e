//! What a learning robot knows, kept from its percept deltas as a remote player keeps them
//! (a [`Knowledge`] numbered by the map's zones), and the messages of the current step by
//! kind, which the observation counts.

use bw4t_map::Map;
use bw4t_protocol::{KINDS, Knowledge};
use bw4t_sim::PerceptDelta;

/// One learner's view.
#[derive(Clone, Debug)]
pub(crate) struct Seen {
    pub(crate) knowledge: Knowledge,
    /// Per message kind (in [`KINDS`] order), then free text: messages this step.
    pub(crate) messages: Vec<u32>,
}

impl Seen {
    pub(crate) fn new(map: &Map) -> Seen {
        Seen { knowledge: Knowledge::for_map(map).latest_only(), messages: vec![0; KINDS.len() + 1] }
    }

    /// Forgets the messages of the previous step.
    pub(crate) fn start_step(&mut self) {
        self.messages.iter_mut().for_each(|n| *n = 0);
    }

    /// Applies one delta, and counts its messages by kind.
    pub(crate) fn apply(&mut self, delta: &PerceptDelta) {
        if delta.full {
            // A snapshot starts the view afresh, its messages included.
            self.start_step();
        }
        self.knowledge.apply(delta.tick, delta);
        for heard in self.knowledge.latest_messages() {
            let kind = heard.said().and_then(|said| KINDS.iter().position(|row| row.word == said.kind));
            self.messages[kind.unwrap_or(KINDS.len())] += 1;
        }
    }
}
