//! The random player, the floor of the evaluation suite: whenever no order of its own is
//! running it takes one action drawn uniformly from those that could be valid now.

use bw4t_map::{SeededRng, fnv1a};
use bw4t_sim::Action;

use crate::orders::Orders;
use crate::view::View;
use crate::{Agent, Observation};

/// A player that acts at random: go to a place, go to or pick up a block it sees, put
/// down what it holds (which, outside a room, removes the block from the match).
pub struct RandomPlayer {
    name: String,
    orders: Orders,
    /// Made at the first call, from the player's name and the sequence it is told, so the
    /// same match seed and seat give the same play without the seed being passed in.
    rng: Option<SeededRng>,
}

impl RandomPlayer {
    /// A random player for player `name`.
    pub fn new(name: &str) -> Self {
        RandomPlayer { name: name.to_string(), orders: Orders::new(), rng: None }
    }

    /// A hash of the name and the sequence's colour names, stable across versions.
    fn seed(&self, view: &View) -> u64 {
        let colours = view.sequence.iter().map(|c| c.name());
        fnv1a(std::iter::once(self.name.as_str()).chain(colours).flat_map(|s| s.bytes().chain([0])))
    }

    fn choices(view: &View) -> Vec<Action> {
        let mut choices: Vec<Action> = view.places.iter().map(|p| Action::GoTo(p.to_string())).collect();
        match view.holding {
            Some(_) => choices.push(Action::PutDown),
            None => {
                for &block in view.visible.keys() {
                    choices.push(if view.at_block == Some(block) {
                        Action::PickUp(Some(block))
                    } else {
                        Action::GoToBlock(block)
                    });
                }
            }
        }
        choices
    }
}

impl Agent for RandomPlayer {
    fn decide(&mut self, obs: &Observation) -> Vec<Action> {
        self.orders.observe(obs);
        let view = View::read(&self.orders.knowledge);
        if view.complete() || self.orders.moving() || view.places.is_empty() || view.sequence.is_empty() {
            return Vec::new();
        }
        let seed = self.seed(&view);
        let rng = self.rng.get_or_insert_with(|| SeededRng::new(seed));
        let choices = Self::choices(&view);
        let action = choices[rng.index(choices.len())].clone();
        if matches!(action, Action::GoTo(_) | Action::GoToBlock(_)) {
            self.orders.move_first();
        }
        self.orders.returned(1);
        vec![action]
    }
}
