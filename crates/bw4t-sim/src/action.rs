//! Actions a player can take, and what the match answers.

use std::fmt;

use crate::percept::BlockId;

/// A robot's id within a match: the lowest id no robot in the match has when it joins,
/// so an id freed by a leave is given again.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct RobotId(pub u32);

impl fmt::Display for RobotId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Identifies one durative order (`goTo`, `goToBlock`) within a match.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct OrderId(pub u64);

/// Who a message goes to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Receiver {
    /// Every other player (not the sender).
    All,
    /// One player, by name.
    Player(String),
}

/// One action of the spec.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Action {
    /// `goTo(PlaceID)`: travel to a place's centre.
    GoTo(String),
    /// `goToBlock(BlockID)`: travel to a block visible in the robot's room.
    GoToBlock(BlockId),
    /// `pickUp`: take the block the robot is at (or the named one, if within reach).
    PickUp(Option<BlockId>),
    /// `putDown`: put the held block down where the robot is.
    PutDown,
    /// `sendMessage(Receiver, Text)`.
    SendMessage {
        /// A player or everyone else.
        to: Receiver,
        /// The text.
        text: String,
    },
}

impl Action {
    /// The spec's action name.
    pub fn name(&self) -> &'static str {
        match self {
            Action::GoTo(_) => "goTo",
            Action::GoToBlock(_) => "goToBlock",
            Action::PickUp(_) => "pickUp",
            Action::PutDown => "putDown",
            Action::SendMessage { .. } => "sendMessage",
        }
    }
}

/// An accepted action. Durative actions carry the order whose end a later
/// [`OrderEnd`] reports; the others are complete when accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Accepted {
    /// The order started, for `goTo` and `goToBlock`.
    pub order: Option<OrderId>,
}

/// Why an action was refused. Nothing in the world changed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Rejection {
    /// The robot is not (or no longer) in the match.
    #[error("robot {0} is not in the match")]
    UnknownRobot(RobotId),
    /// `goTo` to a name that is not a place.
    #[error("'{0}' is not a place")]
    UnknownPlace(String),
    /// A place no robot can reach from here (a blockade, or cut off).
    #[error("'{0}' cannot be reached from here")]
    Unreachable(String),
    /// A block id that does not exist (or has left the world).
    #[error("block {0} does not exist")]
    UnknownBlock(BlockId),
    /// A block that exists but is not visible from this robot's room.
    #[error("block {0} is not visible from here")]
    BlockNotVisible(BlockId),
    /// `pickUp` with no block within reach (or not the named one).
    #[error("not at a block")]
    NotAtBlock,
    /// `pickUp` while holding a block.
    #[error("already holding block {0}")]
    AlreadyHolding(BlockId),
    /// `putDown` while holding nothing.
    #[error("not holding a block")]
    NotHolding,
    /// `putDown` in a room with no free spot near the robot.
    #[error("no free spot to put the block down here")]
    NoSpace,
    /// `sendMessage` to a name that is not another player.
    #[error("'{0}' is not another player")]
    UnknownReceiver(String),
}

impl Rejection {
    /// A stable, machine-readable code for the rejection.
    pub fn code(&self) -> &'static str {
        match self {
            Rejection::UnknownRobot(_) => "unknown_robot",
            Rejection::UnknownPlace(_) => "unknown_place",
            Rejection::Unreachable(_) => "unreachable",
            Rejection::UnknownBlock(_) => "unknown_block",
            Rejection::BlockNotVisible(_) => "block_not_visible",
            Rejection::NotAtBlock => "not_at_block",
            Rejection::AlreadyHolding(_) => "already_holding",
            Rejection::NotHolding => "not_holding",
            Rejection::NoSpace => "no_space",
            Rejection::UnknownReceiver(_) => "unknown_receiver",
        }
    }
}

/// How a durative order ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OrderOutcome {
    /// The robot reached its target.
    Arrived,
    /// The robot was stopped (a closed door, or another robot) and dropped its plan.
    Collided,
    /// A newer order replaced it before it ended.
    Superseded,
}

impl OrderOutcome {
    /// Lower-case name for reports.
    pub fn name(self) -> &'static str {
        match self {
            OrderOutcome::Arrived => "arrived",
            OrderOutcome::Collided => "collided",
            OrderOutcome::Superseded => "superseded",
        }
    }
}

/// The end of a durative order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OrderEnd {
    /// Whose order.
    pub robot: RobotId,
    /// Which order.
    pub order: OrderId,
    /// How it ended.
    pub outcome: OrderOutcome,
}
