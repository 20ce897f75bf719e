//! Driving an in-process [`Agent`]: what it was told, numbering its actions, tracking its orders.

use std::collections::BTreeMap;

use crate::{ActionAck, Agent, Observation, OrderDone};
use bw4t_sim::{Accepted, Action, Intent, Match, OrderEnd, OrderId, Rejection, RobotId, Seats};

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
        let due = self.agent.wake_at().is_some_and(|tick| game.tick() >= tick);
        let told = !delta.is_empty() || !self.told.done.is_empty() || due;
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

    /// Takes the actions to apply at this boundary, in the order decided, each tagged by
    /// `tag` from its number (which [`Driver::answered`] takes back).
    pub fn take_intents<T>(&mut self, into: &mut Vec<Intent<T>>, tag: impl Fn(u64) -> T) {
        into.extend(self.queued.drain(..).map(|(n, action)| Intent::Act(tag(n), action)));
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

/// In-process agents playing their robots: the [`Seats`] of a match without remote players.
pub struct Team {
    /// Ascending by robot id.
    drivers: Vec<Driver>,
}

impl Team {
    /// A team of `drivers`, whatever their order.
    pub fn new(mut drivers: Vec<Driver>) -> Team {
        drivers.sort_by_key(|d| d.robot);
        Team { drivers }
    }

    /// Every agent sees what it was told and decides.
    pub fn observe(&mut self, game: &mut Match) {
        for driver in &mut self.drivers {
            driver.observe(game);
        }
    }

    fn driver(&mut self, robot: RobotId) -> Option<&mut Driver> {
        let at = self.drivers.binary_search_by_key(&robot, |d| d.robot).ok()?;
        self.drivers.get_mut(at)
    }
}

impl Seats for Team {
    type Tag = u64;

    fn robots(&self, into: &mut Vec<RobotId>) {
        into.extend(self.drivers.iter().map(|d| d.robot));
    }

    fn take(&mut self, robot: RobotId, into: &mut Vec<Intent<u64>>) {
        if let Some(driver) = self.driver(robot) {
            driver.take_intents(into, |n| n);
        }
    }

    fn answered(&mut self, robot: RobotId, n: u64, _: &Action, outcome: &Result<Accepted, Rejection>) {
        if let Some(driver) = self.driver(robot) {
            driver.answered(n, outcome);
        }
    }

    fn ended(&mut self, end: &OrderEnd, _: u64) {
        if let Some(driver) = self.driver(end.robot) {
            driver.ended(end);
        }
    }
}
