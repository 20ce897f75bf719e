//! What the simple strategies (baseline, random) keep between calls: the robot's knowledge
//! and the one move order under way, which ends when it is done or refused.

use bw4t_protocol::Knowledge;

use crate::Observation;

/// A robot's knowledge and the move order it waits for.
pub(crate) struct Orders {
    pub(crate) knowledge: Knowledge,
    /// The number the next action returned will have.
    next_action: u64,
    /// The move order under way, by number.
    moving: Option<u64>,
}

impl Orders {
    pub(crate) fn new() -> Self {
        Orders { knowledge: Knowledge::new(), next_action: 0, moving: None }
    }

    /// Takes in what the player was told: percepts into the knowledge; the move order
    /// ended if it was refused or is done.
    pub(crate) fn observe(&mut self, obs: &Observation) {
        for delta in &obs.percepts {
            self.knowledge.apply(delta.tick, delta);
        }
        let refused = obs.acks.iter().any(|ack| ack.result.is_err() && Some(ack.action) == self.moving);
        if refused || obs.done.iter().any(|done| Some(done.action) == self.moving) {
            self.moving = None;
        }
    }

    /// Whether a move order is under way.
    pub(crate) fn moving(&self) -> bool {
        self.moving.is_some()
    }

    /// The first of the actions about to be returned is a move order to wait for.
    pub(crate) fn move_first(&mut self) {
        self.moving = Some(self.next_action);
    }

    /// `count` actions were returned (they are numbered in that order).
    pub(crate) fn returned(&mut self, count: usize) {
        self.next_action += count as u64;
    }
}
