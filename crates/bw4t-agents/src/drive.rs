//! Driving an in-process [`Agent`]: what it was told, numbering its actions, tracking its orders.

use std::collections::BTreeMap;

use crate::{ActionAck, Agent, Observation, OrderDone};
use bw4t_sim::{Accepted, Action, Match, OrderEnd, OrderId, Rejection, RobotId};

/// One in-process agent and its robot.
pub struct Driver {
    /// The robot.
    pub robot: RobotId,
    agent: Box<dyn Agent>,
    next_action: u64,
    orders: BTreeMap<OrderId, u64>,
    told: Observation,
    queued: Vec<(u64, Action)>,
}

impl Driver {
    /// A driver for `agent` playing `robot`.
    pub fn new(robot: RobotId, agent: Box<dyn Agent>) -> Self {
        Driver {
            robot,
            agent,
            next_action: 0,
            orders: BTreeMap::new(),
            told: Observation::default(),
            queued: Vec::new(),
        }
    }

    /// Polls the robot's percepts and, if it was told something, lets the agent decide.
    /// The actions wait in the queue for the next boundary.
    pub fn observe(&mut self, game: &mut Match) {
        let Some(delta) = game.poll_percepts(self.robot) else { return };
        let told = !delta.is_empty() || !self.told.done.is_empty();
        if !delta.is_empty() {
            self.told.percepts.push(delta);
        }
        if told {
            self.told.tick = game.tick();
            let actions = self.agent.decide(&self.told);
            self.told = Observation::default();
            for action in actions {
                self.queued.push((self.next_action, action));
                self.next_action += 1;
            }
        }
    }

    /// Takes the actions to apply at this boundary, in the order decided.
    pub fn take_queued(&mut self) -> Vec<(u64, Action)> {
        std::mem::take(&mut self.queued)
    }

    /// Records how the match answered action number `n`.
    pub fn answered(&mut self, n: u64, outcome: &Result<Accepted, Rejection>) {
        if let Ok(Accepted { order: Some(order) }) = outcome {
            self.orders.insert(*order, n);
        }
        let result = outcome.as_ref().map(|_| ()).map_err(|r| r.code().to_string());
        self.told.acks.push(ActionAck { action: n, result });
    }

    /// Records the end of one of this robot's orders.
    pub fn ended(&mut self, end: &OrderEnd) {
        if let Some(n) = self.orders.remove(&end.order) {
            self.told.done.push(OrderDone { action: n, outcome: end.outcome });
        }
    }
}
