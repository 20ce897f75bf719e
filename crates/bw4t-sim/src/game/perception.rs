//! Perception: the facts a robot perceives now, and the delta between them and what its
//! player was last told.

use super::{Match, Robot};
use crate::action::RobotId;
use crate::percept::{BlockId, Fact, Percept, PerceptDelta, diff};

impl Match {
    /// What robot `id` has not been told yet: the first call also carries the once-only
    /// percepts. `None` for a robot not in the match.
    pub fn poll_percepts(&mut self, id: RobotId) -> Option<PerceptDelta> {
        self.percepts(id, false)
    }

    /// Everything robot `id` perceives now, as a full delta; later deltas build on it.
    pub fn snapshot(&mut self, id: RobotId) -> Option<PerceptDelta> {
        self.percepts(id, true)
    }

    /// Every fact robot `id` perceives now (no messages), without changing what it was told.
    pub fn perceived(&self, id: RobotId) -> Option<Vec<Percept>> {
        let robot = self.robot(id)?;
        let mut facts = Vec::new();
        self.current_facts(robot, &mut facts);
        let mut out = self.once_percepts(robot);
        out.extend(facts.into_iter().map(|f| self.resolve(f)));
        Some(out)
    }

    fn once_percepts(&self, robot: &Robot) -> Vec<Percept> {
        let mut out: Vec<Percept> = self.zone_names.iter().map(|n| Percept::Place(n.clone())).collect();
        out.push(Percept::OwnName(robot.name.clone()));
        out.push(Percept::Bot(robot.id.0));
        out.push(Percept::Sequence(self.sequence.clone()));
        out
    }

    fn percepts(&mut self, id: RobotId, full: bool) -> Option<PerceptDelta> {
        let mut now = std::mem::take(&mut self.facts_scratch);
        now.clear();
        self.current_facts(self.robot(id)?, &mut now);
        let mut robot = self.robots[id.0 as usize].take()?;
        let mut delta = PerceptDelta { tick: self.tick, full, ..PerceptDelta::default() };
        if full || !robot.introduced {
            delta.add = self.once_percepts(&robot);
            robot.introduced = true;
        }
        if full {
            robot.left.clear();
            delta.add.extend(now.iter().map(|&f| self.resolve(f)));
        } else {
            // Players that left come first, as `player` facts sort first.
            let (mut added, mut removed) = (Vec::new(), std::mem::take(&mut robot.left));
            diff(&robot.told, &now, |f| added.push(self.resolve(f)), |f| removed.push(self.resolve(f)));
            delta.add.append(&mut added);
            delta.not = removed;
        }
        delta.add.append(&mut robot.inbox);
        std::mem::swap(&mut robot.told, &mut now);
        self.robots[id.0 as usize] = Some(robot);
        self.facts_scratch = now;
        Some(delta)
    }

    /// The changeable facts that hold for `robot` now, sorted.
    fn current_facts(&self, robot: &Robot, out: &mut Vec<Fact>) {
        out.extend(self.live_robots().filter(|r| r.id != robot.id).map(|r| Fact::Player(r.id.0)));
        out.push(Fact::At(robot.at as u32));
        out.push(Fact::SequenceIndex(self.sequence_index));
        out.push(Fact::State(robot.state));
        if let Some(room) = robot.room {
            out.push(Fact::In(room as u32));
        }
        if let Some(block) = self.block_at(robot) {
            out.push(Fact::AtBlock(block));
        }
        let occupied = self.occupant.iter().enumerate().filter(|(_, o)| o.is_some());
        out.extend(occupied.map(|(zone, _)| Fact::Occupied(zone as u32)));
        let visible: &[BlockId] = robot.room.map_or(&[], |room| &self.room_blocks[room]);
        out.extend(visible.iter().map(|&b| Fact::Color(b)));
        if let Some(block) = robot.holding {
            out.push(Fact::Holding(block));
        }
        out.extend(visible.iter().map(|&b| Fact::Block(b)));
        debug_assert!(out.is_sorted(), "facts must be generated in order");
    }

    fn resolve(&self, fact: Fact) -> Percept {
        let name = |zone: u32| self.zone_names[zone as usize].clone();
        match fact {
            // Facts name only robots in the match: a leave takes its fact out of `told`.
            Fact::Player(r) => {
                Percept::Player(self.robot(RobotId(r)).map(|r| r.name.clone()).unwrap_or_default())
            }
            Fact::At(zone) => Percept::At(name(zone)),
            Fact::SequenceIndex(i) => Percept::SequenceIndex(i),
            Fact::State(s) => Percept::State(s),
            Fact::In(zone) => Percept::In(name(zone)),
            Fact::AtBlock(b) => Percept::AtBlock(b),
            Fact::Occupied(zone) => Percept::Occupied(name(zone)),
            Fact::Color(b) => Percept::Color(b, self.blocks[b as usize - 1].colour),
            Fact::Holding(b) => Percept::Holding(b),
            Fact::Block(b) => Percept::Block(b),
        }
    }
}
