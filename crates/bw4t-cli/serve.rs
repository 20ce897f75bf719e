//! `bw4t serve`: a server of many matches until it is told to stop, from the command
//! line's one match (restarted when it ends) or a file of templates (`--config`); with
//! `--once`, one match and exit.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use std::sync::Arc;

use anyhow::{Context, Result, bail};
use bw4t_agents::{MatchSetup, Seat, Strategy, bot_name};
use bw4t_protocol::Mode;
use bw4t_server::{ArenaConfig, HostConfig, OnEnd, Template};
use bw4t_sim::MatchConfig;
use clap::{Args, ValueEnum};

use crate::serving::{LogArgs, init_logs, listen, stop_signal};

/// Options of `bw4t serve`.
#[derive(Args)]
pub(crate) struct ServeArgs {
    /// Serve the match templates of this TOML file (every key: examples/arena.toml); the options that
    /// describe one match cannot be given with it.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Serve one match and exit when it ends (as scripts expect); without it the server
    /// runs until stopped, starting the match again when it ends.
    #[arg(long)]
    once: bool,
    /// Write every finished match's result, an index (`matches.jsonl`, one row per match)
    /// and kept replays into this directory.
    #[arg(long, value_name = "DIR")]
    results_dir: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) log: LogArgs,
    /// Map: a shipped map's name or a file path.
    #[arg(long, default_value = "default", conflicts_with = "config")]
    map: String,
    /// Match seed (random content); a random one is chosen and printed when omitted.
    #[arg(long, conflicts_with = "config")]
    seed: Option<u64>,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1")]
    bind: std::net::IpAddr,
    /// Port to listen on; 0 picks a free one.
    #[arg(long, default_value_t = 12300)]
    port: u16,
    /// Pacing: ticks on the wall clock, or as fast as every player answers.
    #[arg(long, value_enum, default_value_t = PaceArg::Realtime, conflicts_with = "config")]
    mode: PaceArg,
    /// Ticks per simulated second (and per wall-clock second in realtime mode), 1 to 1000.
    #[arg(long, default_value_t = 20, conflicts_with = "config")]
    tick_hz: u32,
    /// Players the match waits for before its first tick, and admits at most (built-in
    /// agents included); more get `match_full`.
    #[arg(long, default_value_t = 1, conflicts_with = "config")]
    robots: usize,
    /// End the match after this many ticks (default: derived from the map, at least 20000;
    /// see docs/PLAYING.md, "Tick limits"); 0 for no limit.
    #[arg(long, conflicts_with = "config")]
    max_ticks: Option<u64>,
    /// Lockstep: milliseconds to wait for a player's `ready` before counting it late (0: forever;
    /// at most 3600000).
    #[arg(long, default_value_t = 1000, conflicts_with = "config")]
    deadline_ms: u64,
    /// The player token: a secret players must send in `hello`. With it set, watching
    /// needs the spectator or operator token.
    #[arg(long, conflicts_with = "config")]
    token: Option<String>,
    /// The spectator token: a secret spectators must send in `hello` (without it or
    /// --token, anyone may watch). Spectators see public messages only.
    #[arg(long, conflicts_with = "config")]
    spectator_token: Option<String>,
    /// The operator token: the secret of the `operator` role, which watches and sees every
    /// message, private ones included.
    #[arg(long)]
    operator_token: Option<String>,
    /// Spectators see private (addressed) messages too.
    #[arg(long, conflicts_with = "config")]
    spectators_see_private: bool,
    /// Send every player `percepts` every tick, even empty ones (lockstep then waits every tick).
    #[arg(long, conflicts_with = "config")]
    every_tick: bool,
    /// Seconds a dropped player's robot waits for its session to reconnect (at most 86400).
    #[arg(long, default_value_t = 30, conflicts_with = "config")]
    grace_s: u64,
    /// Connections accepted at once (default 256, or the --config file's
    /// max_connections); more are refused with `server_full`.
    #[arg(long, value_name = "N")]
    max_connections: Option<usize>,
    /// Connections one source address may have open at once (default 32, or the --config
    /// file's max_per_source): as many on the protocol port and as many WebSockets on
    /// --http; more are refused (`source_full`, HTTP `429`). Raise it for players who
    /// share one address (a classroom behind one NAT).
    #[arg(long, value_name = "N")]
    max_per_source: Option<usize>,
    /// A reverse proxy in front of --http, whose `X-Forwarded-For` names the client a
    /// WebSocket's address budget is counted for; repeatable (the --config file's
    /// trusted_proxies are added).
    #[arg(long, value_name = "IP")]
    trust_proxy: Vec<std::net::IpAddr>,
    /// Actions and messages a player may send per tick, 1 to 1000; more are rejected
    /// (`rate_limited`).
    #[arg(long, default_value_t = 16, conflicts_with = "config")]
    max_actions: u32,
    /// Seconds a new connection has to say `hello`.
    #[arg(long, default_value_t = 10)]
    hello_timeout_s: u64,
    /// Robots block each other outside rooms.
    #[arg(long, conflicts_with = "config")]
    robot_collisions: bool,
    /// Write the match result as JSON to this file when the match ends.
    #[arg(long)]
    results: Option<PathBuf>,
    /// Write a replay (JSON lines) of the match to this file.
    #[arg(long, conflicts_with = "config")]
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
    #[arg(long, default_value_t = 0, conflicts_with = "config")]
    builtin: usize,
}

#[derive(Clone, Copy, ValueEnum)]
enum PaceArg {
    Realtime,
    Lockstep,
}

/// Serves matches until stopped (or, with `--once`, one match) and writes the last result.
pub(crate) fn run(args: &ServeArgs) -> Result<()> {
    init_logs(&args.log);
    let seed = args.seed.unwrap_or_else(crate::random_seed);
    let mut settings = ArenaConfig::new(Vec::new());
    settings.server.hello_timeout = Duration::from_secs(args.hello_timeout_s);
    settings.server.allowed_origins = args.allow_origin.clone();
    settings.server.operator_token = args.operator_token.clone();
    settings.server.trusted_proxies = args.trust_proxy.clone();
    if let Some(max) = args.max_per_source {
        settings.server.max_per_source = max;
    }
    let (templates, default, results_dir) = match &args.config {
        Some(path) => {
            let file = crate::arena_config::load(path, seed)?;
            // The command line wins over the file, which wins over the default.
            if let Some(max) = args.max_connections.or(file.max_connections) {
                settings.server.max_connections = max;
            }
            if let Some(max) = args.max_per_source.or(file.max_per_source) {
                settings.server.max_per_source = max;
            }
            settings.server.trusted_proxies.extend(file.trusted_proxies);
            if settings.server.operator_token.is_none() {
                settings.server.operator_token = file.operator_token;
            }
            for t in &file.templates {
                let matches = if t.names.is_empty() {
                    format!("made on demand, at most {} at once", t.max_running)
                } else {
                    bw4t_runner::plural(t.names.len(), "match")
                };
                announce(
                    args,
                    format!(
                        "template '{}': map '{}', {} mode, {}, {matches}",
                        t.name,
                        t.setup.map.name(),
                        t.config.mode.name(),
                        bw4t_runner::plural(t.setup.robots(), "player")
                    ),
                );
            }
            (file.templates, file.default, args.results_dir.clone().or(file.results_dir))
        }
        None => {
            if let Some(max) = args.max_connections {
                settings.server.max_connections = max;
            }
            let template = single_match(args, seed)?;
            (vec![template], Some(bw4t_server::DEFAULT_MATCH.to_string()), args.results_dir.clone())
        }
    };
    settings.templates = templates;
    settings.default = default;
    settings.once = args.once;
    if let Some(dir) = &results_dir {
        settings.results = bw4t_server::ResultsStore::in_dir(dir)
            .with_context(|| format!("cannot write results into {}", dir.display()))?;
    }
    if let Some(replay) = crate::runs::replay_writer(args.replay.as_deref())? {
        *settings.first_replay.lock().map_err(|_| anyhow::anyhow!("replay lock"))? =
            Some((replay, bw4t_runner::program()));
    }
    // Matches made through the API may use the shipped maps besides the templates' own.
    settings.maps = Some(Arc::new(|name: &str| {
        if crate::maps::BUILTIN.iter().any(|(shipped, _)| *shipped == name) {
            crate::maps::load(name).map_err(|e| format!("{e:#}"))
        } else {
            Err(format!("no shipped map named '{name}'"))
        }
    }));
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the runtime")?;
    let outcomes = runtime.block_on(async {
        let stop = stop_signal();
        let (listener, local) = listen(SocketAddr::new(args.bind, args.port))?;
        outln!("listening on {local}");
        let http = match args.http {
            Some(port) => {
                let (http, local) = listen(SocketAddr::new(args.bind, port))?;
                outln!("http on {local}");
                Some(http)
            }
            None => None,
        };
        let arena = bw4t_server::Arena::start(settings).context("cannot start the matches")?;
        bw4t_server::serve_arena(&arena, listener, http.map(bw4t_server::Web::from), stop).await;
        anyhow::Ok(arena.outcomes())
    })?;
    let Some((id, last)) = outcomes.into_iter().last() else { return Ok(()) };
    let result = match last {
        Ok(result) => result,
        Err(why) => anyhow::bail!("match {id} failed: {why}"),
    };
    announce(
        args,
        format!(
            "match over ({}): {} ticks, sequence {}/{}, digest {}",
            result.end_reason,
            result.ticks,
            result.sequence_index,
            result.sequence.len(),
            result.digest
        ),
    );
    if let Some(path) = &args.results {
        let json = serde_json::to_string_pretty(&result)?;
        std::fs::write(path, json + "\n")
            .with_context(|| format!("cannot write results to {}", path.display()))?;
    }
    Ok(())
}

/// The template of the one match the command line describes: restarted when it ends,
/// unless `--once`.
fn single_match(args: &ServeArgs, seed: u64) -> Result<Template> {
    let map = crate::maps::load(&args.map)?;
    let mut setup = MatchSetup::new(map);
    setup.seed = seed;
    setup.game = MatchConfig {
        ticks_per_second: args.tick_hz,
        robot_collisions: args.robot_collisions,
        ..MatchConfig::default()
    };
    setup.game.validate().context("bad --tick-hz")?;
    let mut config = HostConfig::new();
    config.mode = match args.mode {
        PaceArg::Realtime => Mode::Realtime,
        PaceArg::Lockstep => Mode::Lockstep,
    };
    let derived = bw4t_runner::TickLimit::for_map(&setup.map, &setup.game);
    setup.max_ticks = match args.max_ticks {
        Some(0) => None,
        Some(ticks) => Some(ticks),
        None => Some(derived.ticks),
    };
    let limit = match (args.max_ticks, setup.max_ticks) {
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
    config.max_actions_per_tick = args.max_actions;
    config.check().map_err(|e| anyhow::anyhow!("bad option: {e}"))?;
    let spawns = setup.map.spawns().len();
    if args.robots > spawns {
        bail!("--robots {} but map '{}' has {spawns} spawn points", args.robots, setup.map.name());
    }
    if args.builtin > spawns {
        bail!("--builtin {} but map '{}' has {spawns} spawn points", args.builtin, setup.map.name());
    }
    if args.builtin > args.robots {
        bail!(
            "--builtin {} but --robots {}: --robots counts every player, built-in ones included \
             (use --robots {} or more)",
            args.builtin,
            args.robots,
            args.builtin
        );
    }
    announce(
        args,
        format!(
            "map '{}', seed {seed}, {} mode, {limit}; waiting for {}",
            setup.map.name(),
            config.mode.name(),
            bw4t_runner::plural(args.robots, "player")
        ),
    );
    // A lockstep match of built-in agents only would be replayed back to back at full
    // speed for ever: it is played once, and the server stays up for its page.
    let unattended = config.mode == Mode::Lockstep && args.builtin == args.robots;
    if unattended && !args.once {
        announce(args, "every seat is built-in and the match is lockstep: it is played once".into());
    }
    let on_end = if args.once || unattended { OnEnd::Stay } else { OnEnd::Restart };
    let builtin = (0..args.builtin).map(|i| Seat::builtin(bot_name(i), Strategy::Cooperative));
    setup.seats = builtin.chain(std::iter::repeat_with(Seat::open)).take(args.robots).collect();
    Ok(Template::single(bw4t_server::DEFAULT_MATCH, setup, config, on_end))
}

/// Says what the server does on standard error: a `bw4t:` line, or with `--log-json` a log
/// event, so that the log stays one JSON object per line.
fn announce(args: &ServeArgs, text: String) {
    if args.log.json {
        tracing::info!("{text}");
    } else {
        crate::output::note(format_args!("bw4t: {text}"));
    }
}
