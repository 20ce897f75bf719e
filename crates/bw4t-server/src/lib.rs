//! The BW4T match server: every TCP or WebSocket client gets a robot, sends JSON-lines
//! actions and receives percept deltas each tick.
//!
//! Layers, each using only those below it: the server's policy and errors (`config`),
//! places per source address (`budget`),
//! the channel vocabulary (`events`) and each connection's queue of outgoing lines
//! (`queue`), the driver that runs one sans-IO
//! [`MatchHost`](bw4t_host::MatchHost) as a task (`driver`), the [`Arena`] of every match
//! (`arena`), the connections (`connection`), HTTP on hyper (`http`: the page, the API,
//! WebSockets, and the [`Routes`] mounted beside them), and
//! serving (`serve`). The caller binds the listeners and supplies the shutdown signal, so
//! tests bind `127.0.0.1:0`.

mod arena;
mod budget;
mod config;
mod connection;
mod driver;
mod events;
mod http;
mod lateness;
mod queue;
mod secret;
mod serve;

pub use arena::{
    Arena, ArenaConfig, ArenaError, CreateRequest, FirstReplay, MapLookup, MatchSpec, OnEnd, ResultsStore,
    Template, Totals, check_match_name,
};
pub use budget::{RateBudget, source_key};
pub use bw4t_agents::{AgentFactory, MatchSetup, Player, Seat};
pub use bw4t_host::{DEFAULT_MATCH, HostConfig, HostStatus, REPLAY_DIGEST_EVERY};
pub use config::{ServerConfig, ServerError, program};
pub use connection::{LISTEN_BACKLOG, listen};
pub use http::websocket::parse_origin;
pub use http::{
    Answering, FrameSource, MAX_REQUESTS, ReplayAsk, Reply, Routes, Site, WebRequest, query_value, serve_site,
};
pub use lateness::TickLateness;
pub use secret::random_token;
pub use serve::{Extras, Web, serve, serve_arena, serve_with};
