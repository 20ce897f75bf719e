//! Any robot of any match encoded as a learner's would be, for play recorded elsewhere
//! (a replay re-simulated into a dataset): its view kept from its percept deltas, its
//! observation and mask, and the index of an action it took, where one stands for it.

use std::sync::Arc;

use bw4t_map::Map;
use bw4t_sim::{Action, Match, PerceptDelta};

use crate::encode::Codec;
use crate::seen::Seen;
use crate::spaces::{Dims, Spaces};

/// One robot's view in the environment's encoding ([`Env`](crate::Env)'s observation and
/// action spaces for the map and `slots`), fed the robot's percept deltas from outside.
/// A step is what the caller makes it: [`RecordedView::start_step`] forgets the message
/// counts, as [`Env::step`](crate::Env::step) does at each step's start.
#[derive(Clone, Debug)]
pub struct RecordedView {
    codec: Arc<Codec>,
    seen: Seen,
}

impl RecordedView {
    /// A view of a robot on `map` that has been told nothing yet, with `slots`
    /// visible-block slots (the environment's `K`).
    pub fn new(map: &Map, slots: usize) -> RecordedView {
        let codec = Codec::new(Spaces::new(Dims::of(map, slots)), map);
        RecordedView { seen: codec.blank_view(), codec: Arc::new(codec) }
    }

    /// The spaces (observation and action segments) this view encodes into.
    pub fn spaces(&self) -> &Spaces {
        self.codec.spaces()
    }

    /// A new step: the message counts start again from zero.
    pub fn start_step(&mut self) {
        self.seen.start_step();
    }

    /// Applies one of the robot's percept deltas (as polled from the match).
    pub fn apply(&mut self, delta: &PerceptDelta) {
        self.seen.apply(delta);
    }

    /// Writes the observation into `out` (of [`Spaces::obs_len`]); `max_ticks` is the tick
    /// the `time` segment divides by.
    pub fn observe(&self, game: &Match, max_ticks: u64, out: &mut [f32]) {
        self.codec.observe(&self.seen, game, max_ticks, out);
    }

    /// Writes the action mask into `out` (of [`Spaces::n_actions`]); `others`: whether
    /// another robot is in the match (messages need someone to hear them).
    pub fn mask(&self, others: bool, out: &mut [u8]) {
        self.codec.mask(&self.seen, others, out);
    }

    /// The action index that stands for `action` now, given the `mask` written for this
    /// moment: the inverse of the action encoding. `None` when no index does: a message to
    /// one player, free text or a kind without a segment, a block beyond the slots, or an
    /// action the mask rules out (a learner could not have chosen it).
    pub fn index_of(&self, game: &Match, mask: &[u8], action: &Action) -> Option<u32> {
        let index = self.codec.index_of(&self.seen, game, mask, action)?;
        u32::try_from(index).ok()
    }

    /// The action index `index` stands for now (`None`: wait or no such action): the
    /// encoding [`RecordedView::index_of`] inverts.
    pub fn action_at(&self, game: &Match, index: u32) -> Option<Action> {
        self.codec.action(&self.seen, game, index as usize)
    }
}
