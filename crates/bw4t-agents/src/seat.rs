//! Who plays a seat of a match: a built-in agent, or a program started for it.

use crate::Strategy;

/// Who plays a seat.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SeatSpec {
    /// A built-in agent.
    Builtin {
        /// Player name.
        name: String,
        /// Its strategy.
        strategy: Strategy,
    },
    /// A program, started with `sh -c COMMAND`.
    External {
        /// Player name.
        name: String,
        /// The command line.
        command: String,
    },
}

impl SeatSpec {
    /// The player's name.
    pub fn name(&self) -> &str {
        match self {
            SeatSpec::Builtin { name, .. } | SeatSpec::External { name, .. } => name,
        }
    }
}
