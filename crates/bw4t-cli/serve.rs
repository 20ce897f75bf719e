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
pub struct ServeArgs {
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
    /// Players the match waits for before its first tick.
    #[arg(long, default_value_t = 1)]
    robots: usize,
    /// End the match after this many ticks.
    #[arg(long)]
    max_ticks: Option<u64>,
    /// Lockstep: milliseconds to wait for a player's `ready` before counting it late (0: forever).
    #[arg(long, default_value_t = 1000)]
    deadline_ms: u64,
    /// A shared secret players must send in `hello`.
    #[arg(long)]
    token: Option<String>,
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
pub fn run(args: &ServeArgs) -> Result<()> {
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
    config.max_ticks = args.max_ticks;
    config.deadline = (args.deadline_ms > 0).then(|| Duration::from_millis(args.deadline_ms));
    config.token = args.token.clone();
    config.every_tick = args.every_tick;
    config.grace = Duration::from_secs(args.grace_s);
    config.max_connections = args.max_connections;
    config.max_actions_per_tick = args.max_actions;
    config.hello_timeout = Duration::from_secs(args.hello_timeout_s);
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
        let addr = SocketAddr::new(args.bind, args.port);
        let listener =
            tokio::net::TcpListener::bind(addr).await.with_context(|| format!("cannot listen on {addr}"))?;
        let local = listener.local_addr().context("no local address")?;
        println!("listening on {local}");
        if let Some(port) = args.http {
            let addr = SocketAddr::new(args.bind, port);
            let http = tokio::net::TcpListener::bind(addr)
                .await
                .with_context(|| format!("cannot listen on {addr}"))?;
            println!("http on {}", http.local_addr().context("no local address")?);
            extras.http = Some(http);
        }
        eprintln!(
            "bw4t: map '{}', seed {seed}, {} mode; waiting for {} player(s)",
            config.map.name(),
            config.mode.name(),
            config.robots
        );
        bw4t_server::serve_with(listener, config, extras, stop_signal()).await.context("the match failed")
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

/// Resolves on Ctrl-C or SIGTERM.
pub async fn stop_signal() {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        match signal(SignalKind::terminate()) {
            Ok(mut term) => {
                tokio::select! {
                    _ = tokio::signal::ctrl_c() => {}
                    _ = term.recv() => {}
                }
            }
            Err(_) => {
                let _ = tokio::signal::ctrl_c().await;
            }
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
    }
}
