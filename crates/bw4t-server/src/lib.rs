//! The BW4T match server: every TCP client gets a robot, sends JSON-lines actions and
//! receives percept deltas each tick.
//!
//! One task owns the match: a sans-IO [`MatchHost`] run by its tokio driver; each
//! connection has a reader and a writer task that talk to it through bounded channels.
//! The caller binds the listener and supplies the shutdown signal, so tests bind
//! `127.0.0.1:0`.

mod api;
mod arena;
mod connection;
mod host;
mod http;
mod lateness;
mod secret;
pub mod study;
mod websocket;

pub use arena::{
    AgentFactory, Arena, ArenaConfig, ArenaError, CreateRequest, FirstReplay, MapLookup, MatchSpec, OnEnd,
    ResultsStore, SeatPlan, Template, Totals, check_match_name,
};
pub use connection::{ConnId, LISTEN_BACKLOG, listen};
pub use host::{HostEvent, HostStatus, MatchHost, QueueRoom, Transmit};
pub use http::{FrameSource, MAX_REQUESTS, ReplayAsk, Site, serve_site};
pub use lateness::TickLateness;
pub use secret::random_token;
pub use websocket::parse_origin;

use std::future::Future;
use std::sync::Arc;
use std::time::Duration;

use bw4t_map::Map;
use bw4t_protocol::{MatchResult, Mode};
use bw4t_sim::MatchConfig;
use tokio::net::TcpListener;
use tokio::sync::mpsc;

/// How a served match runs.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// The match's name on the server (`hello.match`, `welcome.match.name`).
    pub name: String,
    /// This run's id (`NAME.RUN`, `welcome.match.id`), under which its result is filed;
    /// set by the arena.
    pub id: String,
    /// The template the match was made from, if any.
    pub template: Option<String>,
    /// At the start timeout, seat built-in agents of this strategy in the empty seats.
    pub fill: Option<bw4t_agents::Strategy>,
    /// Where realtime ticks' lateness is counted, if anywhere.
    pub lateness: Option<Arc<TickLateness>>,
    /// The map.
    pub map: Map,
    /// The match seed.
    pub seed: u64,
    /// Simulation settings; `ticks_per_second` is also the realtime tick rate.
    pub game: MatchConfig,
    /// Realtime or lockstep pacing.
    pub mode: Mode,
    /// How many players the match waits for before its first tick, and admits at most.
    pub robots: usize,
    /// End the match after this many ticks.
    pub max_ticks: Option<u64>,
    /// Lockstep: how long to wait for `ready` (`None`: forever).
    pub deadline: Option<Duration>,
    /// The player token: a secret players must present.
    pub token: Option<String>,
    /// The spectator token: with it (or the player token) set, spectators must present it.
    pub spectator_token: Option<String>,
    /// The operator token: the secret of the `operator` role, which sees every message.
    pub operator_token: Option<String>,
    /// Spectators see private (addressed) messages too.
    pub spectators_see_private: bool,
    /// Send every player `percepts` every tick, even empty ones.
    pub every_tick: bool,
    /// How long a dropped player's robot waits for its session to come back.
    pub grace: Duration,
    /// Connections that have not said `hello` by then are closed.
    pub hello_timeout: Duration,
    /// Connections beyond this are refused (counted apart on the protocol port and, as
    /// WebSockets, on the web port).
    pub max_connections: usize,
    /// Web pages, besides the server's own, that may open WebSockets (see
    /// [`parse_origin`]; `*`: any).
    pub allowed_origins: Vec<String>,
    /// Actions and messages a player may send per tick; more are rejected.
    pub max_actions_per_tick: u32,
    /// Messages queued for one client before it counts as not reading.
    pub queue: usize,
    /// A client whose queue stays full this long is disconnected.
    pub slow_limit: Duration,
    /// Spectator frames per wall-clock second, at most.
    pub spectator_hz: u32,
    /// Start even if fewer than `robots` players are connected after this long.
    pub start_timeout: Option<Duration>,
    /// Lockstep: disconnect a player that misses this many deadlines in a row.
    pub max_late_in_row: Option<u32>,
    /// Lockstep: with no player connected, wait for one instead of running on. Off for
    /// matches whose players are programs that will not come back once gone.
    pub pause_when_empty: bool,
    /// Which messages players may send.
    pub language: bw4t_protocol::MessagePolicy,
    /// Free-form labels (e.g. a study's condition), written into the replay and the result.
    pub labels: std::collections::BTreeMap<String, String>,
}

impl ServerConfig {
    /// Defaults for everything but the map.
    pub fn new(map: Map) -> Self {
        ServerConfig {
            name: DEFAULT_MATCH.to_string(),
            id: String::new(),
            template: None,
            fill: None,
            lateness: None,
            map,
            seed: 0,
            game: MatchConfig::default(),
            mode: Mode::Realtime,
            robots: 1,
            max_ticks: None,
            deadline: Some(Duration::from_millis(1000)),
            token: None,
            spectator_token: None,
            operator_token: None,
            spectators_see_private: false,
            every_tick: false,
            grace: Duration::from_secs(30),
            hello_timeout: Duration::from_secs(10),
            max_connections: 256,
            allowed_origins: Vec::new(),
            max_actions_per_tick: 16,
            queue: 1024,
            slow_limit: Duration::from_secs(5),
            spectator_hz: 20,
            start_timeout: None,
            max_late_in_row: None,
            pause_when_empty: true,
            language: bw4t_protocol::MessagePolicy::default(),
            labels: std::collections::BTreeMap::new(),
        }
    }
}

/// The program name written into replays: `bw4t VERSION`.
pub fn program() -> String {
    format!("bw4t {}", env!("CARGO_PKG_VERSION"))
}

/// The name of the match that clients naming none join.
pub const DEFAULT_MATCH: &str = "default";

/// How often a served match's replay records a digest, in ticks.
pub const REPLAY_DIGEST_EVERY: u64 = 100;

/// A seat taken before any client connects, so robot ids follow a fixed order.
pub enum Seat {
    /// Kept for a remote player, who claims it with `hello` and this name.
    Remote(String),
    /// Played in-process by a built-in agent.
    Local(String, Box<dyn bw4t_agents::Agent>),
}

impl Seat {
    /// The player's name.
    pub fn name(&self) -> &str {
        match self {
            Seat::Remote(name) | Seat::Local(name, _) => name,
        }
    }
}

/// What a served match has besides its configuration.
#[derive(Default)]
pub struct Extras {
    /// Seats taken at the start, in robot-id order.
    pub seats: Vec<Seat>,
    /// Where to write the replay.
    pub replay: Option<Box<dyn std::io::Write + Send>>,
    /// The program name written into the replay.
    pub program: String,
    /// Names of reserved seats whose player will never come (e.g. its process exited),
    /// so the match need not wait for them to start.
    pub gone_seats: Option<mpsc::Receiver<String>>,
    /// Serve the browser page here too; `/ws` joins the match over WebSocket.
    pub http: Option<TcpListener>,
}

/// Why a match could not be served.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// The match could not be created (bad configuration or content).
    #[error(transparent)]
    Match(#[from] bw4t_sim::MatchError),
    /// A seat could not be taken (a bad name, more seats than players or spawn points).
    #[error("cannot seat a player: {0}")]
    Seat(String),
    /// Two roles were given the same token, so one role's secret would open the other's.
    #[error("the {0} and {1} tokens must differ")]
    SameToken(&'static str, &'static str),
    /// The match failed inside the server (a panic), with its message.
    #[error("the match failed: {0}")]
    Failed(String),
}

/// Serves one match on `listener` until it ends (sequence complete, `max_ticks`, or
/// `shutdown` resolving) and returns its result. Every client gets `match_end` and `bye`.
pub async fn serve(
    listener: TcpListener,
    config: ServerConfig,
    shutdown: impl Future<Output = ()>,
) -> Result<MatchResult, ServerError> {
    serve_with(listener, config, Extras::default(), shutdown).await
}

/// [`serve`] with seats taken in advance (built-in agents and reserved names) and a replay:
/// a server of this one match, which it stops after.
pub async fn serve_with(
    listener: TcpListener,
    config: ServerConfig,
    mut extras: Extras,
    shutdown: impl Future<Output = ()>,
) -> Result<MatchResult, ServerError> {
    let mut settings = ArenaConfig::new(Vec::new()).with_limits_of(&config);
    settings.default = Some(config.name.clone());
    settings.once = true;
    let arena = Arena::start(settings).map_err(one_match_error)?;
    let spec = MatchSpec {
        replay: extras.replay.take().map(|out| (out, std::mem::take(&mut extras.program))),
        seats: std::mem::take(&mut extras.seats),
        gone_seats: extras.gone_seats.take(),
        config,
    };
    arena.spawn(spec).map_err(one_match_error)?;
    serve_arena(&arena, listener, extras.http.take(), shutdown).await;
    match arena.outcomes().into_iter().next() {
        Some((_, outcome)) => outcome.map_err(ServerError::Failed),
        None => Err(ServerError::Failed("the match did not end".into())),
    }
}

/// Why a server of one match could not make it: the match's own error, or (a name
/// taken, the server stopping) why its seat could not be had.
fn one_match_error(e: ArenaError) -> ServerError {
    match e {
        ArenaError::Server(e) => e,
        e => ServerError::Seat(e.to_string()),
    }
}

/// Serves `arena`'s matches on `listener`, and the page, the API and `/ws` on `http`,
/// until `shutdown` resolves (every match then ends as `interrupted`) or, for a server
/// run `once`, until no match is live any more. Returns when every match has recorded
/// its end.
pub async fn serve_arena(
    arena: &Arena,
    listener: TcpListener,
    http: Option<TcpListener>,
    shutdown: impl Future<Output = ()>,
) {
    let site = http.map(|listener| {
        let site = Arc::new(Site { map_json: String::new(), info_json: String::new(), replay: None });
        let live = Arc::new(websocket::Live::new(arena.clone()));
        tokio::spawn(http::serve(listener, site, http::MAX_REQUESTS, Some(live)))
    });
    let acceptor = tokio::spawn(connection::accept_loop(listener, arena.clone()));
    let once = arena.config().once;
    tokio::select! {
        () = shutdown => {}
        () = arena.idle(), if once => {}
    }
    arena.shutdown().await;
    acceptor.abort();
    if let Some(site) = site {
        site.abort();
    }
}
