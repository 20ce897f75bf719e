//! Percepts as the spec defines them, the per-robot deltas that carry them, and a belief
//! base that rebuilds the current facts from those deltas.
//!
//! How each send type shows in a [`PerceptDelta`]:
//! - *once* (`place`, `ownName`, `sequence`, `bot`, `player`): in `add` of the first delta
//!   (and of every full snapshot). `player(X)` also arrives when X joins later, and
//!   `not player(X)` when X leaves, so the roster stays true.
//! - *on change* (`at`, `sequenceIndex`, `state`): in `add` whenever the value changes.
//!   They are single-valued: a new `at(P)` replaces the old one. They never appear in `not`.
//! - *on change with negation* (`in`, `atBlock`, `occupied`, `color`, `holding`, `block`):
//!   in `add` when they start to hold, in `not` when they stop.
//! - *events* (`message`): in `add` exactly once; never in `not`, never part of the state.
//!
//! A client keeps the state by applying `not`, then `add`, of each delta in order (a `full`
//! delta first clears everything); `bw4t_protocol::Knowledge` is the model that does.

use std::fmt;
use std::sync::Arc;

use bw4t_map::Colour;

/// A block's id, a natural number unique within a match.
pub type BlockId = u32;

/// The state a robot is in, as in the `state` percept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum MoveState {
    /// No remaining waypoints (also the initial state).
    Arrived,
    /// On its way.
    Traveling,
    /// The last move failed at a closed door (or another robot); the plan was dropped.
    Collided,
}

impl MoveState {
    /// The spec's lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            MoveState::Arrived => "arrived",
            MoveState::Traveling => "traveling",
            MoveState::Collided => "collided",
        }
    }
}

/// How the spec sends a percept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SendType {
    /// At the start (and, for `player`, on joins and leaves).
    Once,
    /// Whenever its single value changes.
    OnChange,
    /// When it starts to hold, and as `not` when it stops.
    OnChangeWithNegation,
    /// Delivered exactly once, not part of the state.
    Event,
}

/// One percept, with names resolved.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Percept {
    /// `place(PlaceID)`: a place of the map.
    Place(Arc<str>),
    /// `player(PlayerID)`: another player in the match.
    Player(Arc<str>),
    /// `ownName(PlayerID)`: this player's name.
    OwnName(Arc<str>),
    /// `bot(BotID)`: this player's robot id.
    Bot(u32),
    /// `sequence([ColorID])`: the goal colours in order.
    Sequence(Arc<[Colour]>),
    /// `at(PlaceID)`: the place the robot is at (or nearest to, in free space).
    At(Arc<str>),
    /// `sequenceIndex(N)`: the index of the next colour needed.
    SequenceIndex(u32),
    /// `state(State)`: arrived, traveling or collided.
    State(MoveState),
    /// `in(RoomID)`: the robot is in this room.
    In(Arc<str>),
    /// `atBlock(BlockID)`: the robot can pick this block up.
    AtBlock(BlockId),
    /// `occupied(RoomID)`: some robot is in this room.
    Occupied(Arc<str>),
    /// `color(BlockID, ColorID)`: a block visible from this robot's room.
    Color(BlockId, Colour),
    /// `holding(BlockID)`: the block this robot holds.
    Holding(BlockId),
    /// `block(BlockID)`: a block visible from this robot's room.
    Block(BlockId),
    /// `message(Sender, Text)`: a message from another player.
    Message {
        /// The sender's name.
        from: Arc<str>,
        /// The text.
        text: Arc<str>,
    },
}

impl Percept {
    /// The predicate name, as the spec spells it.
    pub fn name(&self) -> &'static str {
        match self {
            Percept::Place(_) => "place",
            Percept::Player(_) => "player",
            Percept::OwnName(_) => "ownName",
            Percept::Bot(_) => "bot",
            Percept::Sequence(_) => "sequence",
            Percept::At(_) => "at",
            Percept::SequenceIndex(_) => "sequenceIndex",
            Percept::State(_) => "state",
            Percept::In(_) => "in",
            Percept::AtBlock(_) => "atBlock",
            Percept::Occupied(_) => "occupied",
            Percept::Color(..) => "color",
            Percept::Holding(_) => "holding",
            Percept::Block(_) => "block",
            Percept::Message { .. } => "message",
        }
    }

    /// How the percept is sent.
    pub fn send_type(&self) -> SendType {
        match self {
            Percept::Place(_)
            | Percept::Player(_)
            | Percept::OwnName(_)
            | Percept::Bot(_)
            | Percept::Sequence(_) => SendType::Once,
            Percept::At(_) | Percept::SequenceIndex(_) | Percept::State(_) => SendType::OnChange,
            Percept::Message { .. } => SendType::Event,
            _ => SendType::OnChangeWithNegation,
        }
    }
}

impl fmt::Display for Percept {
    /// The spec's notation: `at(FrontC1)`, `color(3,Yellow)`, `sequence([Red,Blue])`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}(", self.name())?;
        match self {
            Percept::Place(s) | Percept::Player(s) | Percept::OwnName(s) | Percept::At(s) => {
                f.write_str(s)?
            }
            Percept::In(s) | Percept::Occupied(s) => f.write_str(s)?,
            Percept::Bot(n) | Percept::SequenceIndex(n) => write!(f, "{n}")?,
            Percept::AtBlock(b) | Percept::Holding(b) | Percept::Block(b) => write!(f, "{b}")?,
            Percept::Sequence(colours) => {
                let names: Vec<&str> = colours.iter().map(|c| c.name()).collect();
                write!(f, "[{}]", names.join(","))?
            }
            Percept::State(s) => f.write_str(s.name())?,
            Percept::Color(b, c) => write!(f, "{b},{c}")?,
            Percept::Message { from, text } => write!(f, "{from},{text}")?,
        }
        f.write_str(")")
    }
}

/// What one robot learns in one poll: facts that now hold and facts that stopped holding.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PerceptDelta {
    /// The tick the delta describes.
    pub tick: u64,
    /// A full snapshot: the receiver should forget everything it held before.
    pub full: bool,
    /// Facts that started to hold (or changed value), and new messages.
    pub add: Vec<Percept>,
    /// Facts that stopped holding.
    pub not: Vec<Percept>,
}

impl PerceptDelta {
    /// Whether the delta carries nothing.
    pub fn is_empty(&self) -> bool {
        !self.full && self.add.is_empty() && self.not.is_empty()
    }
}

/// The changeable facts of one robot, in a compact form that is cheap to compare.
/// Variant order is the order facts are generated in, so generated lists come out sorted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Fact {
    Player(u32),
    At(u32),
    SequenceIndex(u32),
    State(MoveState),
    In(u32),
    AtBlock(BlockId),
    Occupied(u32),
    Color(BlockId),
    Holding(BlockId),
    Block(BlockId),
}

impl Fact {
    fn single_valued(self) -> bool {
        matches!(self, Fact::At(_) | Fact::SequenceIndex(_) | Fact::State(_))
    }
}

/// Walks two sorted fact lists, reporting facts new in `now` and negatable facts gone from `before`.
pub(crate) fn diff(
    before: &[Fact],
    now: &[Fact],
    mut added: impl FnMut(Fact),
    mut removed: impl FnMut(Fact),
) {
    let (mut i, mut j) = (0, 0);
    while i < before.len() || j < now.len() {
        match (before.get(i), now.get(j)) {
            (Some(a), Some(b)) if a == b => {
                i += 1;
                j += 1;
            }
            (Some(a), Some(b)) if a < b => {
                if !a.single_valued() {
                    removed(*a);
                }
                i += 1;
            }
            (Some(a), None) => {
                if !a.single_valued() {
                    removed(*a);
                }
                i += 1;
            }
            (_, Some(b)) => {
                added(*b);
                j += 1;
            }
            (None, None) => break,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diff_reports_changes_and_negates_only_negatable_facts() {
        let before = [Fact::At(1), Fact::In(4), Fact::Occupied(4), Fact::Color(7)];
        let now = [Fact::At(2), Fact::Occupied(4), Fact::Holding(7)];
        let (mut added, mut removed) = (Vec::new(), Vec::new());
        diff(&before, &now, |f| added.push(f), |f| removed.push(f));
        assert_eq!(added, [Fact::At(2), Fact::Holding(7)]);
        assert_eq!(removed, [Fact::In(4), Fact::Color(7)]);
    }
}
