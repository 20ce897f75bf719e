//! Perception: the facts a robot perceives now, and the delta between them and what its
//! player was last told.
//!
//! The cost of a poll follows what changed, not the size of the match. A robot's own facts
//! (where it is, what it holds, the blocks in its room) are few and diffed per robot. The
//! facts every robot perceives alike (the players, the sequence index, the occupied rooms)
//! are kept once, as [`SharedFacts`], rebuilt only after a change, and a robot that was told
//! the previous version gets just the change.

use std::sync::Arc;

use super::{Match, Robot};
use crate::action::RobotId;
use crate::percept::{BlockId, Fact, Percept, PerceptDelta, diff};

/// One version of the shared facts, sorted; robots told the same version hold the same one.
pub(super) type Version = Arc<[Fact]>;

/// The facts every robot perceives alike, each robot's own `player` fact included (it is
/// skipped when a robot is told).
#[derive(Default)]
pub(super) struct SharedFacts {
    /// The facts as they hold now, unless `stale`.
    now: Version,
    /// The version before `now`.
    before: Version,
    /// What turned `before` into `now`: facts added and negatable facts gone, sorted.
    added: Vec<Fact>,
    removed: Vec<Fact>,
    /// Something shared changed since `now` was built.
    stale: bool,
}

impl SharedFacts {
    /// Notes that a shared fact changed; the next poll rebuilds them.
    pub(super) fn changed(&mut self) {
        self.stale = true;
    }
}

/// A sorted list of facts merged from two sorted lists.
fn merge(a: &[Fact], b: &[Fact], out: &mut Vec<Fact>) {
    let (mut i, mut j) = (0, 0);
    out.reserve(a.len() + b.len());
    while i < a.len() && j < b.len() {
        if a[i] <= b[j] {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
}

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
    /// Built from scratch, so tests can hold the incremental deltas against it.
    pub fn perceived(&self, id: RobotId) -> Option<Vec<Percept>> {
        let robot = self.robot(id)?;
        let (mut own, mut shared, mut all) = (Vec::new(), Vec::new(), Vec::new());
        self.own_facts(robot, &mut own);
        self.shared_facts(&mut shared);
        shared.retain(|&f| f != Fact::Player(id.0));
        merge(&own, &shared, &mut all);
        let mut out = self.once_percepts(robot);
        out.extend(all.into_iter().map(|f| self.resolve(f)));
        Some(out)
    }

    /// Takes a leaving robot's `player` fact out of what every other robot was told, so a
    /// robot that reuses the id is new to them, and queues its `not` for their next delta.
    pub(super) fn forget_player(&mut self, leaving: RobotId, name: &Arc<str>) {
        let gone = Fact::Player(leaving.0);
        // Most robots were told the same version: strip each version once.
        let mut stripped: Option<(Version, Version)> = None;
        for other in self.robots.iter_mut().flatten() {
            if other.told_shared.binary_search(&gone).is_err() {
                continue;
            }
            let without = match &stripped {
                Some((from, to)) if Arc::ptr_eq(from, &other.told_shared) => to.clone(),
                _ => {
                    let to: Version = other.told_shared.iter().copied().filter(|&f| f != gone).collect();
                    stripped = Some((other.told_shared.clone(), to.clone()));
                    to
                }
            };
            other.told_shared = without;
            other.left.push(Percept::Player(name.clone()));
        }
        self.shared.changed();
    }

    fn once_percepts(&self, robot: &Robot) -> Vec<Percept> {
        let mut out: Vec<Percept> = self.zone_names.iter().map(|n| Percept::Place(n.clone())).collect();
        out.push(Percept::OwnName(robot.name.clone()));
        out.push(Percept::Bot(robot.id.0));
        out.push(Percept::Sequence(self.sequence.clone()));
        out
    }

    /// Brings the shared facts up to date after a change, keeping the change itself.
    fn refresh_shared(&mut self) {
        if !self.shared.stale {
            return;
        }
        let mut facts = Vec::new();
        self.shared_facts(&mut facts);
        let shared = &mut self.shared;
        shared.stale = false;
        if *shared.now == *facts {
            return;
        }
        let (mut added, mut removed) =
            (std::mem::take(&mut shared.added), std::mem::take(&mut shared.removed));
        added.clear();
        removed.clear();
        diff(&shared.now, &facts, |f| added.push(f), |f| removed.push(f));
        shared.before = std::mem::replace(&mut shared.now, facts.into());
        (shared.added, shared.removed) = (added, removed);
    }

    fn percepts(&mut self, id: RobotId, full: bool) -> Option<PerceptDelta> {
        // Before the scratch list is taken, so an unknown robot leaves it in place.
        self.robot(id)?;
        self.refresh_shared();
        let mut own = std::mem::take(&mut self.facts_scratch);
        own.clear();
        // Read with the robot in place (it is large, so it is not moved out), then update.
        let robot = self.robot(id)?;
        self.own_facts(robot, &mut own);
        let me = Fact::Player(id.0);
        let not_me = |f: &Fact| *f != me;
        let mut delta = PerceptDelta { tick: self.tick, full, ..PerceptDelta::default() };
        if full || !robot.introduced {
            delta.add = self.once_percepts(robot);
        }
        let shared = &self.shared;
        let (mut added, mut removed) = (Vec::new(), Vec::new());
        if full {
            let others: Vec<Fact> = shared.now.iter().copied().filter(not_me).collect();
            merge(&own, &others, &mut added);
        } else {
            let (mut own_added, mut own_removed) = (Vec::new(), Vec::new());
            diff(&robot.told, &own, |f| own_added.push(f), |f| own_removed.push(f));
            let (mut shared_added, mut shared_removed) = (Vec::new(), Vec::new());
            if Arc::ptr_eq(&robot.told_shared, &shared.now) {
                // Told the current version: nothing shared is new.
            } else if Arc::ptr_eq(&robot.told_shared, &shared.before) {
                shared_added.extend(shared.added.iter().copied().filter(not_me));
                shared_removed.extend(shared.removed.iter().copied().filter(not_me));
            } else {
                let mut add = |f: Fact| shared_added.extend(not_me(&f).then_some(f));
                let mut remove = |f: Fact| shared_removed.extend(not_me(&f).then_some(f));
                diff(&robot.told_shared, &shared.now, &mut add, &mut remove);
            }
            merge(&own_added, &shared_added, &mut added);
            merge(&own_removed, &shared_removed, &mut removed);
        }
        delta.add.extend(added.into_iter().map(|f| self.resolve(f)));
        let removed: Vec<Percept> = removed.into_iter().map(|f| self.resolve(f)).collect();
        let robot = self.robots[id.0 as usize].as_mut()?;
        robot.introduced = true;
        // Players that left come first, as `player` facts sort first; a snapshot has no `not`.
        let left = std::mem::take(&mut robot.left);
        if !full {
            delta.not = left;
        }
        delta.not.extend(removed);
        delta.add.append(&mut robot.inbox);
        if !Arc::ptr_eq(&robot.told_shared, &self.shared.now) {
            robot.told_shared = self.shared.now.clone();
        }
        std::mem::swap(&mut robot.told, &mut own);
        self.facts_scratch = own;
        Some(delta)
    }

    /// The facts that hold for `robot` alone now, sorted.
    fn own_facts(&self, robot: &Robot, out: &mut Vec<Fact>) {
        out.push(Fact::At(robot.at as u32));
        out.push(Fact::State(robot.state));
        if let Some(room) = robot.room {
            out.push(Fact::In(room as u32));
        }
        if let Some(block) = self.block_at(robot) {
            out.push(Fact::AtBlock(block));
        }
        let visible: &[BlockId] = robot.room.map_or(&[], |room| &self.room_blocks[room]);
        out.extend(visible.iter().map(|&b| Fact::Color(b)));
        if let Some(block) = robot.holding {
            out.push(Fact::Holding(block));
        }
        out.extend(visible.iter().map(|&b| Fact::Block(b)));
        debug_assert!(out.is_sorted(), "facts must be generated in order");
    }

    /// The facts every robot perceives alike now, sorted.
    fn shared_facts(&self, out: &mut Vec<Fact>) {
        out.extend(self.live_robots().map(|r| Fact::Player(r.id.0)));
        out.push(Fact::SequenceIndex(self.sequence_index));
        out.extend(self.occupied.iter().map(|&zone| Fact::Occupied(zone as u32)));
        debug_assert!(out.is_sorted(), "facts must be generated in order");
    }

    fn resolve(&self, fact: Fact) -> Percept {
        let name = |zone: u32| self.zone_names[zone as usize].clone();
        match fact {
            // Facts name only robots in the match: a leave takes its fact out of what the
            // others were told (`forget_player`).
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
