//! [`Problem`]: one thing wrong with a map and where it is, and how places and points are
//! named in problems.

use std::fmt;

use crate::geometry::Vec2;
use crate::parts::Zone;

/// How bad a [`Problem`] is; errors sort before warnings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    /// The map is refused, or a match on it cannot be completed.
    Error,
    /// The map loads and plays, but something looks unintended.
    Warning,
}

impl Severity {
    /// The lower-case word used in reports: `error` or `warning`.
    pub fn name(self) -> &'static str {
        match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
        }
    }
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One thing wrong with a map, and where it is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Problem {
    /// Error or warning.
    pub severity: Severity,
    /// The part of the map concerned, e.g. `zone 'RoomA1'`, `spawn 2 'Bot2'`, `sequence`.
    pub place: String,
    /// What is wrong there.
    pub message: String,
}

impl Problem {
    /// An error at `place`.
    pub fn error(place: impl Into<String>, message: impl Into<String>) -> Problem {
        Problem { severity: Severity::Error, place: place.into(), message: message.into() }
    }

    /// A warning at `place`.
    pub fn warning(place: impl Into<String>, message: impl Into<String>) -> Problem {
        Problem { severity: Severity::Warning, place: place.into(), message: message.into() }
    }

    /// Whether this is an error (not a warning).
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// The place and the message, without the severity: `zone 'RoomA1': ...`.
    pub fn located(&self) -> String {
        format!("{}: {}", self.place, self.message)
    }
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.severity, self.located())
    }
}

/// How a zone is named in problems: by name, or by position in the file when it has none.
pub(crate) fn zone_place(idx: usize, zone: &Zone) -> String {
    if zone.name.is_empty() { format!("zone {}", idx + 1) } else { format!("zone '{}'", zone.name) }
}

/// A point as `(x, y)`; whole numbers print without a fraction.
pub(crate) fn point(p: Vec2) -> String {
    format!("({}, {})", p.x, p.y)
}
