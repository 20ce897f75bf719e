//! The server's own policy (how many connections, how long a `hello` may take, how many
//! lines a client's queue holds, which pages may open WebSockets), why a match could not
//! be served, and the name the server gives itself in what it writes. How each match runs is its [`HostConfig`](bw4t_host::HostConfig).

use std::net::IpAddr;
use std::time::Duration;

use bw4t_host::HostError;

/// The program name written into replays and exports: `bw4t VERSION`.
pub fn program() -> String {
    format!("bw4t {}", env!("CARGO_PKG_VERSION"))
}

/// How the server treats connections, whatever match they join.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// The operator's secret: the HTTP API's credential, and each match's operator token
    /// where the match has none of its own.
    pub operator_token: Option<String>,
    /// Connections accepted at once (protocol port; as many WebSockets on the web port).
    pub max_connections: usize,
    /// Connections one source address may have open at once: as many on the protocol
    /// port and as many WebSockets (plain HTTP requests have their own share, a quarter
    /// of their places).
    pub max_per_source: usize,
    /// Reverse proxies whose `X-Forwarded-For` names a web request's source address.
    pub trusted_proxies: Vec<IpAddr>,
    /// The time a new connection has to say `hello`.
    pub hello_timeout: Duration,
    /// Lines queued per connection before it counts as not reading.
    pub queue: usize,
    /// Web pages, besides the server's own, that may open WebSockets (see
    /// [`parse_origin`](crate::parse_origin); `*`: any).
    pub allowed_origins: Vec<String>,
    /// A closed server (a study's): only the operator lists and inspects matches; there is
    /// no lobby for anyone else.
    pub closed: bool,
}

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig {
            operator_token: None,
            max_connections: 256,
            max_per_source: 32,
            trusted_proxies: Vec::new(),
            hello_timeout: Duration::from_secs(10),
            queue: 1024,
            allowed_origins: Vec::new(),
            closed: false,
        }
    }
}

/// Why a match could not be served.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// The match could not be made (its settings, content or seats).
    #[error(transparent)]
    Host(#[from] HostError),
    /// A seat could not be had (a name taken, the server stopping).
    #[error("cannot seat a player: {0}")]
    Seat(String),
    /// The match failed inside the server (a panic), with its message.
    #[error("the match failed: {0}")]
    Failed(String),
}
