//! Stand-in for the shared renderer of a robot's knowledge (to be replaced).

use bw4t_sim::{Beliefs, Percept, PerceptDelta};
use std::collections::BTreeSet;

/// What the robot knows.
#[derive(Debug, Default)]
pub(crate) struct Knowledge {
    beliefs: Beliefs,
}

/// What the robot knew at one moment.
#[derive(Debug, Clone)]
pub(crate) struct Snapshot(BTreeSet<Percept>);

impl Knowledge {
    pub(crate) fn apply(&mut self, _tick: u64, delta: &PerceptDelta) {
        self.beliefs.apply(delta);
    }
    pub(crate) fn beliefs(&self) -> &Beliefs {
        &self.beliefs
    }
    pub(crate) fn snapshot(&self) -> Snapshot {
        Snapshot(self.beliefs.facts().clone())
    }
    pub(crate) fn changes_since(&self, before: &Snapshot) -> Vec<String> {
        self.beliefs.facts().difference(&before.0).map(|p| format!("{p:?}")).collect()
    }
    pub(crate) fn describe(&self) -> String {
        self.beliefs.facts().iter().map(|p| format!("{p:?}")).collect::<Vec<_>>().join("\n")
    }
}
