//! A match of its own: a one-match lockstep server on loopback, with built-in teammates
//! playing in-process, which the robot joins over TCP like any player.

use std::net::SocketAddr;
use std::time::Duration;

use bw4t_agents::{MatchSetup, Player, Seat, Strategy, bot_name};
use bw4t_map::Map;
use bw4t_protocol::{MatchResult, Mode, SessionOptions};
use bw4t_server::{Extras, HostConfig, ServerError};
use tokio::task::JoinHandle;

/// Everything a match of its own needs.
pub struct LocalMatch {
    /// The match: the robot's seat (remote, robot 0) and its built-in teammates.
    pub setup: MatchSetup,
    /// How long the match waits for the robot's driver in a tick (`None`: for ever).
    pub deadline: Option<Duration>,
    /// Where the replay goes.
    pub replay: Option<Box<dyn std::io::Write + Send>>,
}

/// A started match of its own: where to join it and its outcome to come.
pub struct Started {
    /// The server's address on loopback.
    pub addr: SocketAddr,
    /// What the robot's `hello` says.
    pub hello: SessionOptions,
    /// The match, ending with its result.
    pub result: JoinHandle<Result<MatchResult, ServerError>>,
}

impl LocalMatch {
    /// The robot (remote, named `player`) and `teammates` (`Bot1`, `Bot2`, ...) on `map`,
    /// with the default settings and no tick limit.
    pub fn setup(map: Map, player: &str, teammates: &[Strategy]) -> MatchSetup {
        let mut seats = vec![Seat::remote(player)];
        seats.extend(teammates.iter().enumerate().map(|(i, s)| Seat::builtin(bot_name(i), *s)));
        MatchSetup { seats, ..MatchSetup::new(map) }
    }

    /// Starts the server on a free loopback port.
    pub async fn start(self) -> std::io::Result<Started> {
        let player = match self.setup.seats.first() {
            Some(seat) if matches!(seat.player, Player::Remote) => seat.name.clone(),
            _ => return Err(std::io::Error::other("robot 0 of a match of its own must be the remote robot")),
        };
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
        let addr = listener.local_addr()?;
        let token = bw4t_server::random_token();
        let mut config = HostConfig::new();
        config.mode = Mode::Lockstep;
        config.deadline = self.deadline;
        config.token = Some(token.clone());
        config.pause_when_empty = false;
        let extras = Extras { replay: self.replay, program: program(), ..Extras::default() };
        let serving = bw4t_server::serve_with(listener, self.setup, config, extras, std::future::pending());
        let result = tokio::spawn(serving);
        Ok(Started { addr, hello: SessionOptions::agent(player, Some(token)), result })
    }
}

fn program() -> String {
    format!("bw4t {} (mcp)", env!("CARGO_PKG_VERSION"))
}
