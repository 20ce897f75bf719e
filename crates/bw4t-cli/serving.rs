//! What the serving commands (`serve`, `study`, `replay view`) share: the structured log,
//! their listeners, and the signal that stops them.

use std::net::SocketAddr;

use anyhow::{Context, Result};

/// The log options of the commands that serve.
#[derive(clap::Args)]
pub(crate) struct LogArgs {
    /// More log lines (-v: each connection's events, -vv: everything).
    #[arg(short, long, action = clap::ArgAction::Count, conflicts_with = "quiet")]
    verbose: u8,
    /// Only warnings and errors in the log.
    #[arg(short, long)]
    quiet: bool,
    /// Log lines as JSON objects (one per line) instead of text.
    #[arg(long = "log-json")]
    pub(crate) json: bool,
}

/// Sends log lines to standard error: as text or JSON, at the level `-v`/`-q` choose.
pub(crate) fn init_logs(log: &LogArgs) {
    use tracing_subscriber::fmt;
    let level = match (log.quiet, log.verbose) {
        (true, _) => tracing::Level::WARN,
        (false, 0) => tracing::Level::INFO,
        (false, 1) => tracing::Level::DEBUG,
        (false, _) => tracing::Level::TRACE,
    };
    let colour = std::io::IsTerminal::is_terminal(&std::io::stderr());
    // A line that cannot be written is dropped: the default would print the failure with
    // `eprintln!`, which panics when standard error is gone, and a task that panics
    // while ending its match would hold up the server's shutdown.
    let builder = fmt()
        .with_writer(std::io::stderr)
        .with_max_level(level)
        .with_target(false)
        .with_ansi(colour)
        .log_internal_errors(false);
    // A second subscriber (tests calling this twice in one process) is simply not installed.
    let _ = if log.json { builder.json().try_init() } else { builder.try_init() };
}

/// Listens on `addr` (with a deep queue, see [`bw4t_server::listen`]); returns the listener
/// and its address, the port chosen if `addr` had port 0.
pub(crate) fn listen(addr: SocketAddr) -> Result<(tokio::net::TcpListener, SocketAddr)> {
    let listener = bw4t_server::listen(addr).with_context(|| format!("cannot listen on {addr}"))?;
    let local = listener.local_addr().context("no local address")?;
    Ok((listener, local))
}

/// Installs the Ctrl-C and SIGTERM handlers now, so that a signal sent as soon as the
/// address is printed is not missed, and returns what resolves at the first of them.
/// Must be called inside the runtime.
pub(crate) fn stop_signal() -> impl std::future::Future<Output = ()> {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{Signal, SignalKind, signal};
        // A handler that cannot be installed leaves its signal's default effect.
        async fn received(handler: Option<Signal>) {
            match handler {
                Some(mut handler) => {
                    handler.recv().await;
                }
                None => std::future::pending().await,
            }
        }
        let interrupt = signal(SignalKind::interrupt()).ok();
        let terminate = signal(SignalKind::terminate()).ok();
        async move {
            tokio::select! {
                () = received(interrupt) => {}
                () = received(terminate) => {}
            }
        }
    }
    #[cfg(not(unix))]
    {
        async {
            let _ = tokio::signal::ctrl_c().await;
        }
    }
}
