//! Whole matches: headless with built-in agents, or served to external agent processes
//! mixed with built-in ones; and replays (verify, show).

mod external;
mod headless;
mod remote;
mod replay;
pub mod tournament;

pub use external::{AgentReport, SeatSpec, ServedError, ServedRun, play_served};
pub use headless::{RunError, Seat, play_builtin, play_headless};
pub use remote::{RemoteError, play_remote};
pub use replay::{ReplayError, ReplaySummary, Verdict, read_replay, replay_frames, verify_replay};

/// The program name and version written into replays.
pub fn program() -> String {
    format!("bw4t {}", env!("CARGO_PKG_VERSION"))
}
