//! A seeded random player for benchmarks and property tests: keeps every robot busy with
//! `goTo` orders, pick-ups, put-downs and the odd message. Not a strategy, just load.

use bw4t_map::SeededRng;

use crate::action::{Action, Receiver};
use crate::game::{BlockPlace, Match};
use crate::percept::MoveState;

/// Chooses actions for every robot of a match from one seeded generator.
pub struct RandomPlay {
    rng: SeededRng,
    accepted: PlayCounts,
}

/// Accepted actions by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlayCounts {
    /// `goTo` and `goToBlock`.
    pub moves: u64,
    /// `pickUp`.
    pub pick_ups: u64,
    /// `putDown`.
    pub put_downs: u64,
    /// `sendMessage`.
    pub messages: u64,
}

impl RandomPlay {
    /// A player whose choices are fixed by `seed`.
    pub fn new(seed: u64) -> Self {
        RandomPlay { rng: SeededRng::new(seed), accepted: PlayCounts::default() }
    }

    /// What has been accepted so far.
    pub fn accepted(&self) -> PlayCounts {
        self.accepted
    }

    /// Gives each robot (in id order) at most one action; returns how many were accepted.
    pub fn act(&mut self, game: &mut Match) -> usize {
        let robots: Vec<_> = game.robots().collect();
        let mut accepted = 0;
        for robot in robots {
            let roll = self.rng.below(100);
            let drop_zone = game.map().drop_zone();
            let idle = robot.state != MoveState::Traveling;
            let action = if robot.holding.is_some() {
                if robot.room == Some(drop_zone) || (roll == 0 && self.rng.below(20) == 0) {
                    Some(Action::PutDown)
                } else if idle {
                    Some(Action::GoTo(game.map().zones()[drop_zone].name.clone()))
                } else {
                    None
                }
            } else if robot.room.is_some() && idle && roll < 60 {
                self.near_block_action(game, robot.room, robot.pos)
            } else if roll < 4 {
                let others: Vec<_> = game.robots().filter(|r| r.id != robot.id).collect();
                let to = match others.len() {
                    0 => Receiver::All,
                    n => Receiver::Player(others[self.rng.index(n)].name.to_string()),
                };
                Some(Action::SendMessage { to, text: format!("tick {}", game.tick()) })
            } else if idle || (roll == 5 && self.rng.below(8) == 0) {
                let zones = game.map().zones();
                Some(Action::GoTo(zones[self.rng.index(zones.len())].name.clone()))
            } else {
                None
            };
            if let Some(action) = action {
                let counter = match action {
                    Action::GoTo(_) | Action::GoToBlock(_) => &mut self.accepted.moves,
                    Action::PickUp(_) => &mut self.accepted.pick_ups,
                    Action::PutDown => &mut self.accepted.put_downs,
                    Action::SendMessage { .. } => &mut self.accepted.messages,
                };
                if game.handle_action(robot.id, &action).is_ok() {
                    *counter += 1;
                    accepted += 1;
                }
            }
        }
        accepted
    }

    /// Picks up the block within reach, or heads for a random block of the room.
    fn near_block_action(
        &mut self,
        game: &Match,
        room: Option<usize>,
        pos: bw4t_map::Vec2,
    ) -> Option<Action> {
        let here: Vec<_> = game
            .blocks()
            .filter_map(|(id, _, place)| match place {
                BlockPlace::Room { zone, pos: at } if Some(zone) == room => Some((id, at)),
                _ => None,
            })
            .collect();
        if here.iter().any(|(_, at)| at.distance(pos) <= crate::game::REACH) {
            return Some(Action::PickUp(None));
        }
        (!here.is_empty()).then(|| Action::GoToBlock(here[self.rng.index(here.len())].0))
    }
}
