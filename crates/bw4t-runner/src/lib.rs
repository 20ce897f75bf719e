//! Whole matches: headless with built-in agents, or served to external agent processes
//! mixed with built-in ones; and replays (verify, show, frames for the viewer, trajectories
//! for learners).

mod external;
mod headless;
mod limit;
mod preflight;
mod remote;
mod replay;
pub mod tournament;
mod trajectory;

/// `1 robot`, `2 robots`: the one rule for counts in messages (the tournament summary's too).
pub use bw4t_tournament::plural;
pub use external::{AgentReport, Served, ServedError, ServedRun, play_served};
pub use headless::{RunError, play, play_headless};
pub use limit::{MIN_DEFAULT_TICKS, TickLimit};
pub use preflight::check_command;
pub use remote::{RemoteError, play_remote, play_remote_told};
pub use replay::{
    FRAME_CACHE_BYTES, MAX_DIGEST_EVERY, ReplayError, ReplayFrames, ReplayMessage, ReplaySummary, Verdict,
    read_replay, verify_replay,
};
pub use trajectory::{Trajectories, TrajectoryError, TrajectoryKind, TrajectoryOptions, trajectories};

pub use bw4t_server::program;
