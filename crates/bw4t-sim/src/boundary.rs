//! The tick boundary, in one place for every front end: what players asked for is applied
//! in robot-id order, the match steps, ended orders go back to whoever gave them, and a
//! [`Journal`] (the replay) hears everything applied. Headless runs, the server's host and
//! replays (which [`Match::reapply`] what was recorded) all go through here, so a served
//! match equals the same actions played headless by construction.

use crate::action::{Accepted, Action, OrderEnd, Rejection, RobotId};
use crate::game::{JoinError, Match, StepReport};

/// Something applied to a match between two ticks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Applied<'a> {
    /// A robot joined for player `name` and got id `robot`.
    Join {
        /// The player's name.
        name: &'a str,
        /// The id it got.
        robot: RobotId,
    },
    /// A robot left the match.
    Leave {
        /// Its id.
        robot: RobotId,
    },
    /// A robot's order was stopped (its player's connection dropped).
    Stop {
        /// Its id.
        robot: RobotId,
    },
    /// An action was handled, accepted (`ok`) or rejected.
    Act {
        /// The acting robot.
        robot: RobotId,
        /// The action.
        action: &'a Action,
        /// Whether it was accepted.
        ok: bool,
    },
}

/// Hears what is applied to a match and each step: a replay recorder, or nothing (`()`).
pub trait Journal {
    /// `what` was applied after tick `tick`.
    fn applied(&mut self, tick: u64, what: Applied<'_>);
    /// The match has stepped to its next tick.
    fn stepped(&mut self, game: &Match);
}

impl Journal for () {
    fn applied(&mut self, _: u64, _: Applied<'_>) {}
    fn stepped(&mut self, _: &Match) {}
}

impl<J: Journal> Journal for Option<J> {
    fn applied(&mut self, tick: u64, what: Applied<'_>) {
        if let Some(j) = self {
            j.applied(tick, what);
        }
    }

    fn stepped(&mut self, game: &Match) {
        if let Some(j) = self {
            j.stepped(game);
        }
    }
}

impl<J: Journal + ?Sized> Journal for &mut J {
    fn applied(&mut self, tick: u64, what: Applied<'_>) {
        (**self).applied(tick, what);
    }

    fn stepped(&mut self, game: &Match) {
        (**self).stepped(game);
    }
}

/// What a player asked to happen at the next boundary; `T` tells the player's side which
/// request an outcome answers.
#[derive(Debug)]
pub enum Intent<T> {
    /// Handle this action.
    Act(T, Action),
    /// Stop the robot where it stands (its player's connection dropped).
    Stop,
}

/// The players of a match as the boundary sees them: who has what queued, and where
/// outcomes and ended orders go.
pub trait Seats {
    /// Tells the player which of its requests an outcome answers.
    type Tag;
    /// Appends the robots that may have something queued, in ascending id order.
    fn robots(&self, into: &mut Vec<RobotId>);
    /// Takes `robot`'s queued intents, in the order given, into `into`.
    fn take(&mut self, robot: RobotId, into: &mut Vec<Intent<Self::Tag>>);
    /// `robot`'s `action`, tagged `tag`, was handled with `outcome`.
    fn answered(
        &mut self,
        robot: RobotId,
        tag: Self::Tag,
        action: &Action,
        outcome: &Result<Accepted, Rejection>,
    );
    /// A durative order ended in the step to tick `tick`.
    fn ended(&mut self, end: &OrderEnd, tick: u64);
}

impl Match {
    /// One tick boundary: every robot's queued intents applied in robot-id order, then one
    /// step, then the orders that ended routed back to their seats. Returns the new tick.
    pub fn boundary<S: Seats>(&mut self, seats: &mut S, journal: &mut impl Journal) -> u64 {
        let mut robots = Vec::new();
        seats.robots(&mut robots);
        let mut intents = Vec::new();
        for robot in robots {
            seats.take(robot, &mut intents);
            for intent in intents.drain(..) {
                match intent {
                    Intent::Act(tag, action) => {
                        let outcome = self.act_logged(robot, &action, journal);
                        seats.answered(robot, tag, &action, &outcome);
                    }
                    Intent::Stop => {
                        if self.stop(robot).is_ok() {
                            journal.applied(self.tick(), Applied::Stop { robot });
                        }
                    }
                }
            }
        }
        let StepReport { tick, ended } = self.step();
        journal.stepped(self);
        for end in &ended {
            seats.ended(end, tick);
        }
        tick
    }

    /// Handles `action` for `robot` and tells `journal`.
    fn act_logged(
        &mut self,
        robot: RobotId,
        action: &Action,
        journal: &mut impl Journal,
    ) -> Result<Accepted, Rejection> {
        let outcome = self.handle_action(robot, action);
        journal.applied(self.tick(), Applied::Act { robot, action, ok: outcome.is_ok() });
        outcome
    }

    /// Joins a robot for player `name`, as [`Match::join`], and tells `journal`.
    pub fn join_logged(&mut self, name: &str, journal: &mut impl Journal) -> Result<RobotId, JoinError> {
        let robot = self.join(name)?;
        journal.applied(self.tick(), Applied::Join { name, robot });
        Ok(robot)
    }

    /// Removes a robot, as [`Match::leave`], and tells `journal`.
    pub fn leave_logged(&mut self, robot: RobotId, journal: &mut impl Journal) -> Result<(), Rejection> {
        self.leave(robot)?;
        journal.applied(self.tick(), Applied::Leave { robot });
        Ok(())
    }

    /// Applies a recorded event again; the error says how it went otherwise than recorded.
    pub fn reapply(&mut self, what: Applied<'_>) -> Result<(), String> {
        match what {
            Applied::Join { name, robot } => match self.join(name) {
                Ok(id) if id == robot => Ok(()),
                Ok(id) => Err(format!("{name} joined as robot {}, recorded {}", id.0, robot.0)),
                Err(e) => Err(format!("{name} cannot join: {e}")),
            },
            Applied::Leave { robot } => self.leave(robot).map_err(|e| e.to_string()),
            Applied::Stop { robot } => self.stop(robot).map_err(|e| e.to_string()),
            Applied::Act { robot, action, ok } => {
                let got = self.handle_action(robot, action).is_ok();
                if got == ok {
                    Ok(())
                } else {
                    Err(format!("robot {}'s action accepted: {got}, recorded {ok}", robot.0))
                }
            }
        }
    }
}
