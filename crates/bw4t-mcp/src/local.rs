//! A match of its own: a one-match lockstep server on loopback, with built-in teammates
//! playing in-process, which the robot joins over TCP like any player.

use std::net::SocketAddr;
use std::time::Duration;

use bw4t_agents::Strategy;
use bw4t_map::Map;
use bw4t_protocol::{MatchResult, Mode, SessionOptions};
use bw4t_server::{Extras, HostConfig, Seat, ServerError};
use bw4t_sim::MatchConfig;
use tokio::task::JoinHandle;

/// Everything a match of its own needs.
pub struct LocalMatch {
    /// The map.
    pub map: Map,
    /// The seed.
    pub seed: u64,
    /// Simulation settings.
    pub game: MatchConfig,
    /// The robot's player name.
    pub player: String,
    /// The built-in teammates, in robot-id order after the robot.
    pub teammates: Vec<Strategy>,
    /// The last tick.
    pub max_ticks: u64,
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
    /// Starts the server on a free loopback port.
    pub async fn start(self) -> std::io::Result<Started> {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
        let addr = listener.local_addr()?;
        let token = bw4t_server::random_token();
        let mut config = HostConfig::new(self.map);
        config.seed = self.seed;
        config.game = self.game;
        config.mode = Mode::Lockstep;
        config.robots = 1 + self.teammates.len();
        config.max_ticks = Some(self.max_ticks);
        config.deadline = self.deadline;
        config.token = Some(token.clone());
        config.pause_when_empty = false;
        let mut seats = vec![Seat::Remote(self.player.clone())];
        for (i, strategy) in self.teammates.iter().enumerate() {
            let name = format!("Bot{}", i + 1);
            seats.push(Seat::Local(name.clone(), strategy.agent(&name)));
        }
        let extras = Extras { seats, replay: self.replay, program: program(), ..Extras::default() };
        let result = tokio::spawn(bw4t_server::serve_with(listener, config, extras, std::future::pending()));
        Ok(Started { addr, hello: SessionOptions::agent(self.player, Some(token)), result })
    }
}

fn program() -> String {
    format!("bw4t {} (mcp)", env!("CARGO_PKG_VERSION"))
}
