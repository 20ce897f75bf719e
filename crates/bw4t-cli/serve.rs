//! `bw4t serve`: one match on a TCP server, until it ends or the process is told to stop.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result};
use bw4t_protocol::Mode;
use bw4t_server::ServerConfig;
use bw4t_sim::MatchConfig;
use clap::{Args, ValueEnum};

/// Options of `bw4t serve`.
#[derive(Args)]
pub(crate) struct ServeArgs {
    /// Map: a shipped map's name or a file path.
    #[arg(long, default_value = "default")]
    map: String,
    /// Match seed (random content); a random one is chosen and printed when omitted.
    #[arg(long)]
    seed: Option<u64>,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1")]
    bind: std::net::IpAddr,
    /// Port to listen on; 0 picks a free one.
    #[arg(long, default_value_t = 12300)]
    port: u16,
    /// Pacing: ticks on the wall clock, or as fast as every player answers.
    #[arg(long, value_enum, default_value_t = PaceArg::Realtime)]
    mode: PaceArg,
    /// Ticks per simulated second (and per wall-clock second in realtime mode).
    #[arg(long, default_value_t = 20)]
    tick_hz: u32,
    /// Players the match waits for before its first tick, and admits at most (built-in
    /// agents included); more get `match_full`.
    #[arg(long, default_value_t = 1)]
    robots: usize,
    /// End the match after this many ticks (default: derived from the map, at least 20000;
    /// see the README); 0 for no limit.
    #[arg(long)]
    max_ticks: Option<u64>,
    /// Lockstep: milliseconds to wait for a player's `ready` before counting it late (0: forever).
    #[arg(long, default_value_t = 1000)]
    deadline_ms: u64,
    /// The player token: a secret players must send in `hello`. With it set, watching
    /// needs the spectator or operator token.
    #[arg(long)]
    token: Option<String>,
    /// The spectator token: a secret spectators must send in `hello` (without it or
    /// --token, anyone may watch). Spectators see public messages only.
    #[arg(long)]
    spectator_token: Option<String>,
    /// The operator token: the secret of the `operator` role, which watches and sees every
    /// message, private ones included.
    #[arg(long)]
    operator_token: Option<String>,
    /// Spectators see private (addressed) messages too.
    #[arg(long)]
    spectators_see_private: bool,
    /// Send every player `percepts` every tick, even empty ones (lockstep then waits every tick).
    #[arg(long)]
    every_tick: bool,
    /// Seconds a dropped player's robot waits for its session to reconnect.
    #[arg(long, default_value_t = 30)]
    grace_s: u64,
    /// Connections accepted at once; more are refused with `server_full`.
    #[arg(long, default_value_t = 256)]
    max_connections: usize,
    /// Actions and messages a player may send per tick; more are rejected (`rate_limited`).
    #[arg(long, default_value_t = 16)]
    max_actions: u32,
    /// Seconds a new connection has to say `hello`.
    #[arg(long, default_value_t = 10)]
    hello_timeout_s: u64,
    /// Robots block each other outside rooms.
    #[arg(long)]
    robot_collisions: bool,
    /// Write the match result as JSON to this file when the match ends.
    #[arg(long)]
    results: Option<PathBuf>,
    /// Write a replay (JSON lines) of the match to this file.
    #[arg(long)]
    replay: Option<PathBuf>,
    /// Also serve the browser page (overview, human players) on this port, bound like the
    /// TCP port; 0 picks a free one. Off by default.
    #[arg(long, value_name = "PORT")]
    http: Option<u16>,
    /// Let pages from this origin (like `http://example.org:8080`) open WebSockets on the
    /// --http port, besides the page's own; repeatable; `*` lets any page in.
    #[arg(long, value_name = "URL", value_parser = bw4t_server::parse_origin)]
    allow_origin: Vec<String>,
    /// Add this many built-in agents (cooperative) to the match; they count toward --robots.
    #[arg(long, default_value_t = 0)]
    builtin: usize,
}

#[derive(Clone, Copy, ValueEnum)]
enum PaceArg {
    Realtime,
    Lockstep,
}

/// Serves one match and writes its result.
pub(crate) fn run(args: &ServeArgs) -> Result<()> {
    let map = crate::maps::load(&args.map)?;
    let seed = args.seed.unwrap_or_else(crate::random_seed);
    let mut config = ServerConfig::new(map);
    config.seed = seed;
    config.game = MatchConfig {
        ticks_per_second: args.tick_hz,
        robot_collisions: args.robot_collisions,
        ..MatchConfig::default()
    };
    config.game.validate().context("bad --tick-hz")?;
    config.mode = match args.mode {
        PaceArg::Realtime => Mode::Realtime,
        PaceArg::Lockstep => Mode::Lockstep,
    };
    config.robots = args.robots;
    let derived = bw4t_runner::TickLimit::for_map(&config.map, &config.game);
    config.max_ticks = match args.max_ticks {
        Some(0) => None,
        Some(ticks) => Some(ticks),
        None => Some(derived.ticks),
    };
    let limit = match (args.max_ticks, config.max_ticks) {
        (_, None) => "no tick limit".to_string(),
        (Some(_), Some(ticks)) => format!("tick limit {ticks} (--max-ticks)"),
        (None, Some(ticks)) => format!("tick limit {ticks}, {}", derived.explain()),
    };
    config.deadline = (args.deadline_ms > 0).then(|| Duration::from_millis(args.deadline_ms));
    config.token = args.token.clone();
    config.spectator_token = args.spectator_token.clone();
    config.operator_token = args.operator_token.clone();
    config.spectators_see_private = args.spectators_see_private;
    config.every_tick = args.every_tick;
    config.grace = Duration::from_secs(args.grace_s);
    config.max_connections = args.max_connections;
    config.max_actions_per_tick = args.max_actions;
    config.hello_timeout = Duration::from_secs(args.hello_timeout_s);
    config.allowed_origins = args.allow_origin.clone();
    if args.robots > config.map.spawns().len() {
        anyhow::bail!(
            "--robots {} but map '{}' has {} spawn points",
            args.robots,
            config.map.name(),
            config.map.spawns().len()
        );
    }
    let replay = crate::replay::writer(args.replay.as_deref())?;
    if args.builtin > config.map.spawns().len() {
        anyhow::bail!(
            "--builtin {} but map '{}' has {} spawn points",
            args.builtin,
            config.map.name(),
            config.map.spawns().len()
        );
    }
    if args.builtin > args.robots {
        anyhow::bail!(
            "--builtin {} but --robots {}: --robots counts every player, built-in ones included \
             (use --robots {} or more)",
            args.builtin,
            args.robots,
            args.builtin
        );
    }
    let seats = (1..=args.builtin)
        .map(|i| {
            let name = format!("Bot{i}");
            bw4t_server::Seat::Local(name.clone(), bw4t_agents::Strategy::Cooperative.agent(&name))
        })
        .collect();
    let mut extras = bw4t_server::Extras {
        replay,
        seats,
        program: bw4t_runner::program(),
        ..bw4t_server::Extras::default()
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the runtime")?;
    let result = runtime.block_on(async {
        let stop = stop_signal();
        let (listener, local) = listen(SocketAddr::new(args.bind, args.port))?;
        outln!("listening on {local}");
        if let Some(port) = args.http {
            let (http, local) = listen(SocketAddr::new(args.bind, port))?;
            outln!("http on {local}");
            extras.http = Some(http);
        }
        eprintln!(
            "bw4t: map '{}', seed {seed}, {} mode, {limit}; waiting for {}",
            config.map.name(),
            config.mode.name(),
            bw4t_runner::plural(config.robots, "player")
        );
        bw4t_server::serve_with(listener, config, extras, stop).await.context("the match failed")
    })?;
    eprintln!(
        "bw4t: match over ({}): {} ticks, sequence {}/{}, digest {}",
        result.end_reason,
        result.ticks,
        result.sequence_index,
        result.sequence.len(),
        result.digest
    );
    if let Some(path) = &args.results {
        let json = serde_json::to_string_pretty(&result)?;
        std::fs::write(path, json + "\n")
            .with_context(|| format!("cannot write results to {}", path.display()))?;
    }
    Ok(())
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
