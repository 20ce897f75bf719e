//! One served BW4T match, sans-IO: [`MatchHost`] admits players, spectators and the
//! operator, buffers actions until the next tick boundary, paces ticks (realtime or
//! lockstep), holds percepts back from clients that do not read, throttles spectator
//! frames, records the replay and makes the result.
//!
//! It reads no clock and touches no socket or file (its `clippy.toml` bans them, and CI
//! checks that no async runtime is in its dependencies): a driver hands it events and the
//! time ([`MatchHost::handle_event`], [`MatchHost::handle_timeout`]), sends what it
//! returns ([`MatchHost::poll_transmit`]) and wakes it when it asks
//! ([`MatchHost::poll_timeout`]). Tests drive it on a simulated clock.

mod config;
mod host;
mod lines;

pub use config::{
    DEFAULT_MATCH, HostConfig, MAX_ACTIONS_PER_TICK, MAX_DEADLINE, MAX_SPECTATOR_HZ, MAX_WAIT,
    REPLAY_DIGEST_EVERY,
};
pub use host::{ConnId, HostEvent, HostStatus, MatchHost, RESYNC_INTERVAL, Transmit, same_secret};
pub use lines::{bye_line, error_line, pong_line};

/// Why a match could not be hosted.
#[derive(Debug, thiserror::Error)]
pub enum HostError {
    /// The match could not be created (bad configuration or content).
    #[error(transparent)]
    Match(#[from] bw4t_sim::MatchError),
    /// A seat could not be taken (a bad name, more seats than players or spawn points).
    #[error("cannot seat a player: {0}")]
    Seat(String),
    /// A figure of the host's configuration is out of its range.
    #[error("{0}")]
    Config(String),
    /// Two roles were given the same token, so one role's secret would open the other's.
    #[error("the {0} and {1} tokens must differ")]
    SameToken(&'static str, &'static str),
}
