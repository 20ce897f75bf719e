//! Serving: one match on a listener ([`serve`], [`serve_with`]), or an arena of many
//! ([`serve_arena`]) with the page, the API and `/ws` beside it.

use std::future::Future;
use std::sync::Arc;

use bw4t_agents::MatchSetup;
use bw4t_host::HostConfig;
use bw4t_protocol::MatchResult;
use tokio::net::TcpListener;
use tokio::sync::mpsc;

use crate::arena::{Arena, ArenaConfig, ArenaError, MatchSpec};
use crate::config::{ServerConfig, ServerError};
use crate::connection;
use crate::http::{self, Routes, Served, Site};

/// What a served match has besides its configuration.
#[derive(Default)]
pub struct Extras {
    /// How the server treats connections.
    pub server: ServerConfig,
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

/// Serves one match of `setup`, run as `config` says, on `listener` until it ends
/// (sequence complete, the tick limit, or `shutdown` resolving) and returns its result.
/// Every client gets `match_end` and `bye`.
pub async fn serve(
    listener: TcpListener,
    setup: MatchSetup,
    config: HostConfig,
    shutdown: impl Future<Output = ()>,
) -> Result<MatchResult, ServerError> {
    serve_with(listener, setup, config, Extras::default(), shutdown).await
}

/// [`serve`] with a replay, the web port, and seats whose players will not come: a
/// server of this one match, which it stops after.
pub async fn serve_with(
    listener: TcpListener,
    setup: MatchSetup,
    config: HostConfig,
    mut extras: Extras,
    shutdown: impl Future<Output = ()>,
) -> Result<MatchResult, ServerError> {
    let mut settings = ArenaConfig::new(Vec::new());
    settings.server = std::mem::take(&mut extras.server);
    if settings.server.operator_token.is_none() {
        settings.server.operator_token.clone_from(&config.operator_token);
    }
    settings.default = Some(config.name.clone());
    settings.once = true;
    let arena = Arena::start(settings).map_err(one_match_error)?;
    let spec = MatchSpec {
        replay: extras.replay.take().map(|out| (out, std::mem::take(&mut extras.program))),
        gone_seats: extras.gone_seats.take(),
        setup,
        config,
    };
    arena.spawn(spec).await.map_err(one_match_error)?;
    serve_arena(&arena, listener, extras.http.take().map(Web::from), shutdown).await;
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

/// The web port of a live server: its listener, and the routes mounted beside the
/// server's own (a study's pages and API).
pub struct Web {
    /// Where the page, the API and `/ws` are served.
    pub listener: TcpListener,
    /// Asked first, in order, for the paths they serve.
    pub routes: Vec<Arc<dyn Routes>>,
}

impl From<TcpListener> for Web {
    fn from(listener: TcpListener) -> Web {
        Web { listener, routes: Vec::new() }
    }
}

/// Serves `arena`'s matches on `listener`, and the page, the API and `/ws` on `http`,
/// until `shutdown` resolves (every match then ends as `interrupted`) or, for a server
/// run `once`, until no match is live any more. Returns when every match has recorded
/// its end.
pub async fn serve_arena(
    arena: &Arena,
    listener: TcpListener,
    http: Option<Web>,
    shutdown: impl Future<Output = ()>,
) {
    let site = http.map(|web| {
        let site = Arc::new(Site { map_json: String::new(), info_json: String::new(), replay: None });
        let served = Served { site, live: Some(http::live(arena)), mounted: web.routes };
        tokio::spawn(http::serve(web.listener, served, http::MAX_REQUESTS))
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
