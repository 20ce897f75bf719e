//! The `realtime` and `study` figures: matches of TCP players (and, in a study, built-in
//! teammates) at 20 ticks/s; tick lateness, acknowledgement latency, CPU, memory, descriptors.

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use bw4t_map::Map;
use bw4t_protocol::{ClientSession, Mode, SessionOptions};
use bw4t_server::{OnEnd, Template, TickLateness};
use serde_json::{Value, json};
use tokio::sync::watch;

use super::player::{Heard, PlayCounts, Player};
use super::{
    ArenaArgs, CLIENT_THREADS, CONNECTING, ROBOTS, SERVER_THREADS, SERVER_WORKERS, Served, TICK_HZ,
    arena_config, check_descriptors, finish_clients, host_config, load_average, match_setup, mb, millis,
    open_fds, room_names, round, rss_kb, runtime, settled_fds, thread_cpu_seconds,
};

/// What the realtime matches are made of.
pub(super) struct Shape {
    kind: &'static str,
    matches: usize,
    /// TCP players per match.
    players: usize,
    /// Built-in cooperative teammates per match.
    teammates: usize,
    /// Players send a message of the language this often (participants do; bench players
    /// only move).
    talk_every: Option<Duration>,
}

impl Shape {
    pub(super) fn players(matches: usize) -> Shape {
        Shape { kind: "realtime", matches, players: ROBOTS, teammates: 0, talk_every: None }
    }

    pub(super) fn study(matches: usize) -> Shape {
        Shape { kind: "study", matches, players: 2, teammates: 2, talk_every: Some(Duration::from_secs(1)) }
    }
}

/// `realtime` and `study`: matches of TCP players (and built-in teammates), every player
/// keeping its robot moving; lateness, acknowledgement latency and costs over
/// `arena_seconds` once all have started.
pub(super) fn realtime(args: &ArenaArgs, map: &Map, seed: u64, shape: Shape) -> Result<Value> {
    let n = shape.matches;
    if n == 0 {
        bail!("--arena-matches and --study-matches must be at least 1");
    }
    let connections = n * shape.players;
    check_descriptors(2 * connections, &format!("--arena-matches {n}"))?;
    let (server_rt, client_rt) = (runtime(SERVER_WORKERS, SERVER_THREADS)?, runtime(1, CLIENT_THREADS)?);
    let (rss_start, fds_start) = (rss_kb()?, open_fds()?);

    let lateness = Arc::new(TickLateness::default());
    let names: Vec<String> = (1..=n).map(|i| format!("m{i}")).collect();
    let template = Template {
        name: "bench".into(),
        maps: vec![map.clone()],
        setup: match_setup(map, seed, shape.teammates, shape.players),
        config: host_config(Mode::Realtime),
        names: names.clone(),
        max_running: n,
        on_end: OnEnd::Stay,
        replays: false,
        lateness: Some(lateness.clone()),
        invited_only: false,
    };
    let server = Served::start(&server_rt, arena_config(vec![template], connections + 16))?;
    let (rss_matches, fds_matches) = (rss_kb()?, open_fds()?);

    let rooms = room_names(map)?;
    let (progress, mut watch_progress) = watch::channel(Progress::default());
    let progress = Arc::new(progress);
    let counts = Arc::new(PlayCounts { talk_every: shape.talk_every, ..PlayCounts::default() });
    let addr = server.addr;
    let players = client_rt.block_on(async {
        let gate = Arc::new(tokio::sync::Semaphore::new(CONNECTING));
        let mut players = Vec::with_capacity(connections);
        for (m, name) in names.iter().enumerate() {
            for p in 0..shape.players {
                let permit = gate.clone().acquire_owned().await?;
                let mut hello = SessionOptions::agent(format!("P{}", p + 1), None);
                hello.match_name = Some(name.clone());
                let player_seed = seed ^ ((m * shape.players + p) as u64).wrapping_mul(0x9e37_79b9);
                let (progress, counts, rooms) = (progress.clone(), counts.clone(), rooms.clone());
                players.push(tokio::spawn(async move {
                    let outcome =
                        realtime_player(addr, hello, rooms, player_seed, &progress, &counts, permit).await;
                    if let Err(e) = &outcome {
                        progress.send_modify(|p| {
                            p.failed += 1;
                            p.first_error.get_or_insert_with(|| format!("{e:#}"));
                        });
                    }
                }));
            }
        }
        let limit = Duration::from_secs(30) + Duration::from_millis(20 * connections as u64);
        let all = |p: &Progress| p.started >= connections || p.failed > 0;
        let waited = tokio::time::timeout(limit, watch_progress.wait_for(all)).await.is_ok();
        let p = watch_progress.borrow().clone();
        if let Some(e) = p.first_error {
            bail!("a player failed: {e}");
        }
        if !waited {
            bail!(
                "not every match started within {limit:?}: {} of {connections} players welcomed, \
                 {} saw their match start",
                p.connected,
                p.started
            );
        }
        anyhow::Ok(players)
    })?;
    let (rss_connected, fds_connected) = (rss_kb()?, open_fds()?);

    // The window: every match is playing.
    lateness.reset();
    counts.latencies.lock().map_err(|_| anyhow::anyhow!("a player panicked"))?.clear();
    let before = Usage::now(&counts)?;
    std::thread::sleep(Duration::from_secs_f64(args.arena_seconds));
    let after = Usage::now(&counts)?;
    let load = load_average()?;
    let window = after.since(&before);
    let (ticks, skipped) = (lateness.ticks(), lateness.skipped());
    let quantiles = [lateness.quantile(0.5), lateness.quantile(0.99), lateness.quantile(1.0)];
    let mut acks = counts.latencies.lock().map_err(|_| anyhow::anyhow!("a player panicked"))?.clone();
    acks.sort_unstable();
    let ack_quantile =
        |q: f64| acks.get(((acks.len() as f64 - 1.0) * q).round() as usize).copied().map(millis);

    server.stop(&server_rt)?;
    finish_clients(&client_rt, players);
    let fds_end = settled_fds(fds_start)?;

    let per_match = |cpu: f64| round(cpu * 100.0 / n as f64, 3);
    Ok(json!({
        "case": "arena",
        "kind": shape.kind,
        "map": map.name(),
        "matches": n,
        "robots": shape.players + shape.teammates,
        "players_per_match": shape.players,
        "builtin_teammates_per_match": shape.teammates,
        "tick_hz": TICK_HZ,
        "connections": connections,
        "server_workers": SERVER_WORKERS,
        "clients": "in this process, on a runtime of their own with 1 worker thread",
        "players_welcomed": progress.borrow().connected,
        "matches_started": progress.borrow().started / shape.players,
        "seconds": round(window.wall, 2),
        "ticks": ticks,
        "ticks_expected": (n as f64 * f64::from(TICK_HZ) * window.wall).round(),
        "skipped_ticks": skipped,
        // Other processes' demand on the machine's cores shows in the lateness.
        "load_average_1m": load,
        "lateness_p50_ms": millis(quantiles[0]),
        "lateness_p99_ms": millis(quantiles[1]),
        "lateness_max_ms": millis(quantiles[2]),
        "cpu_s_per_s": round(window.process / window.wall, 3),
        "server_cpu_s_per_s": round(window.server / window.wall, 3),
        "client_cpu_s_per_s": round(window.clients / window.wall, 3),
        "cpu_percent_per_match": per_match(window.process / window.wall),
        "server_cpu_percent_per_match": per_match(window.server / window.wall),
        "orders": window.orders,
        "messages_sent": window.messages,
        // From a player's action leaving to its ack arriving: a realtime action waits for
        // the next tick boundary, up to one period (50 ms at 20 ticks/s).
        "acks_measured": acks.len(),
        "input_to_ack_p50_ms": ack_quantile(0.5),
        "input_to_ack_p99_ms": ack_quantile(0.99),
        "percepts_received": window.percepts,
        "rss_start_mb": mb(rss_start),
        "rss_matches_mb": mb(rss_matches),
        "rss_connected_mb": mb(rss_connected),
        "kb_per_match": rss_matches.saturating_sub(rss_start) / n as u64,
        // Both ends of each connection, and what a started match adds, are in this process.
        "kb_per_connection": rss_connected.saturating_sub(rss_matches) / connections as u64,
        "fds_start": fds_start,
        "fds_matches": fds_matches,
        "fds_connected": fds_connected,
        "fds_end": fds_end,
    }))
}

/// How far the realtime players have got.
#[derive(Clone, Default)]
struct Progress {
    /// Players welcomed.
    connected: usize,
    /// Players told their match started.
    started: usize,
    failed: usize,
    first_error: Option<String>,
}

/// A realtime player: joins its match by name and keeps its robot moving until the match
/// ends.
async fn realtime_player(
    addr: SocketAddr,
    hello: SessionOptions,
    rooms: Arc<[String]>,
    seed: u64,
    progress: &watch::Sender<Progress>,
    counts: &Arc<PlayCounts>,
    permit: tokio::sync::OwnedSemaphorePermit,
) -> Result<()> {
    let name = hello.name.clone();
    let mut player = Player::connect(addr, ClientSession::new(hello), rooms, seed, counts.clone()).await?;
    let (mut permit, mut started) = (Some(permit), false);
    loop {
        match player.next().await? {
            Heard::Welcome => {
                permit.take();
                progress.send_modify(|p| p.connected += 1);
            }
            Heard::Started if !started => {
                started = true;
                progress.send_modify(|p| p.started += 1);
            }
            Heard::Refused(code, why) => bail!("{name} refused ({code}): {why}"),
            Heard::Ended => return Ok(()),
            Heard::Queued | Heard::Started | Heard::Playing => {}
        }
    }
}

/// CPU and play counted at one moment.
struct Usage {
    at: Instant,
    process: f64,
    server: f64,
    clients: f64,
    orders: u64,
    percepts: u64,
    messages: u64,
}

/// What happened between two [`Usage`]s.
struct Window {
    wall: f64,
    process: f64,
    server: f64,
    clients: f64,
    orders: u64,
    percepts: u64,
    messages: u64,
}

impl Usage {
    fn now(counts: &PlayCounts) -> Result<Usage> {
        Ok(Usage {
            at: Instant::now(),
            process: crate::bench_net::cpu_seconds(std::process::id())?,
            server: thread_cpu_seconds(SERVER_THREADS)?,
            clients: thread_cpu_seconds(CLIENT_THREADS)?,
            orders: counts.orders.load(Ordering::Relaxed),
            percepts: counts.percepts.load(Ordering::Relaxed),
            messages: counts.messages.load(Ordering::Relaxed),
        })
    }

    fn since(&self, before: &Usage) -> Window {
        Window {
            wall: (self.at - before.at).as_secs_f64(),
            process: self.process - before.process,
            server: self.server - before.server,
            clients: self.clients - before.clients,
            orders: self.orders - before.orders,
            percepts: self.percepts - before.percepts,
            messages: self.messages - before.messages,
        }
    }
}
