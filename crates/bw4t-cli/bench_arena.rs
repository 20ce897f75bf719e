//! `bw4t bench arena`: many matches in one arena server. Realtime matches played by
//! loopback TCP clients (tick lateness, CPU, memory and descriptors per match), study-sized
//! matches (two people and two built-in teammates each: lateness and the people's
//! input-to-acknowledgement latency), lockstep
//! matches of built-in teams on one and on two worker threads, and a churn soak (players
//! joining by template, dropping and coming back, leaving, while others keep playing).

use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use bw4t_map::{Map, SeededRng, ZoneKind};
use bw4t_protocol::{ClientSession, ErrorCode, Mode, Outcome, SessionEvent, SessionOptions};
use bw4t_server::{Arena, ArenaConfig, HostConfig, OnEnd, SeatPlan, ServerConfig, Template, TickLateness};
use bw4t_sim::Action;
use clap::{Args, ValueEnum};
use serde_json::{Value, json};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader, Lines};
use tokio::net::TcpStream;
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};
use tokio::runtime::Runtime;
use tokio::sync::{oneshot, watch};

/// Options of `bw4t bench arena`.
#[derive(Args)]
pub(crate) struct ArenaArgs {
    /// `arena`: which figures to make (all when none is given).
    #[arg(long = "arena-kind", value_enum)]
    arena_kinds: Vec<Kind>,
    /// `arena` realtime: matches of 3 players served at once.
    #[arg(long, default_value_t = 1000)]
    arena_matches: usize,
    /// `arena` realtime: seconds measured, once every match has started.
    #[arg(long, default_value_t = 10.0)]
    arena_seconds: f64,
    /// `arena` lockstep: matches of 3 built-in agents run at once.
    #[arg(long, default_value_t = 8)]
    arena_lockstep_matches: usize,
    /// `arena` lockstep: each match's tick limit.
    #[arg(long, default_value_t = 3000)]
    arena_lockstep_ticks: u64,
    /// `arena` lockstep: seconds measured on each number of workers (each match that ends
    /// is replaced by the next, on the next seed).
    #[arg(long, default_value_t = 3.0)]
    arena_lockstep_seconds: f64,
    /// `arena` study: matches of 2 participants (TCP players that move and talk) and 2
    /// built-in cooperative teammates.
    #[arg(long, default_value_t = 100)]
    study_matches: usize,
    /// `arena` soak: seconds of churn (the long run: 10 minutes by default).
    #[arg(long, default_value_t = 600.0)]
    soak_seconds: f64,
    /// `arena` soak: well-behaved players (a multiple of 3: they fill whole matches).
    #[arg(long, default_value_t = 12)]
    soak_players: usize,
    /// `arena` soak: players that drop and come back, or leave (half each).
    #[arg(long, default_value_t = 12)]
    soak_churners: usize,
}

/// The figures `bench arena` makes.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Kind {
    /// Realtime matches of 3 TCP players at 20 ticks/s on a 2-worker server: tick
    /// lateness, CPU, memory and descriptors.
    Realtime,
    /// A study's load: matches of 2 participants, who move and send a message of the
    /// language every second, and 2 built-in teammates, at 20 ticks/s: tick lateness and
    /// the time from a participant's action to its acknowledgement.
    Study,
    /// Lockstep matches of 3 built-in agents (no sockets) on 1 then 2 worker threads.
    Lockstep,
    /// Matches that end and restart while players join, drop, come back and leave.
    Soak,
}

/// Players per match.
const ROBOTS: usize = 3;
/// Realtime ticks per second.
const TICK_HZ: u32 = 20;
/// The server's worker threads in the realtime and soak figures.
const SERVER_WORKERS: usize = 2;
/// Thread names, to tell the server's CPU time from the clients'.
const SERVER_THREADS: &str = "arena-server";
const CLIENT_THREADS: &str = "arena-clients";
const LOCKSTEP_THREADS: &str = "arena-lockstep";
/// Clients connecting at once (below the listener's backlog).
const CONNECTING: usize = 64;

/// Makes the chosen figures, printing one JSON line each.
pub(crate) fn run(args: &ArenaArgs, map: &str, seed: u64) -> Result<()> {
    let map = crate::maps::load(map)?;
    let kinds =
        if args.arena_kinds.is_empty() { Kind::value_variants().to_vec() } else { args.arena_kinds.clone() };
    for kind in kinds {
        let line = match kind {
            Kind::Realtime => realtime(args, &map, seed, Shape::players(args.arena_matches))?,
            Kind::Study => realtime(args, &map, seed, Shape::study(args.study_matches))?,
            Kind::Lockstep => lockstep(args, &map, seed)?,
            Kind::Soak => soak(args, &map, seed)?,
        };
        outln!("{line}");
    }
    Ok(())
}

/// What the realtime matches are made of.
struct Shape {
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
    fn players(matches: usize) -> Shape {
        Shape { kind: "realtime", matches, players: ROBOTS, teammates: 0, talk_every: None }
    }

    fn study(matches: usize) -> Shape {
        Shape { kind: "study", matches, players: 2, teammates: 2, talk_every: Some(Duration::from_secs(1)) }
    }
}

/// `realtime` and `study`: matches of TCP players (and built-in teammates), every player
/// keeping its robot moving; lateness, acknowledgement latency and costs over
/// `arena_seconds` once all have started.
fn realtime(args: &ArenaArgs, map: &Map, seed: u64, shape: Shape) -> Result<Value> {
    let n = shape.matches;
    if n == 0 {
        bail!("--arena-matches and --study-matches must be at least 1");
    }
    let connections = n * shape.players;
    check_descriptors(2 * connections, &format!("--arena-matches {n}"))?;
    let (server_rt, client_rt) = (runtime(SERVER_WORKERS, SERVER_THREADS)?, runtime(1, CLIENT_THREADS)?);
    let (rss_start, fds_start) = (rss_kb()?, open_fds()?);

    let lateness = Arc::new(TickLateness::default());
    let mut config = match_config(map, seed, Mode::Realtime);
    config.robots = shape.players + shape.teammates;
    let names: Vec<String> = (1..=n).map(|i| format!("m{i}")).collect();
    let template = Template {
        name: "bench".into(),
        maps: vec![map.clone()],
        config: config.clone(),
        seats: (1..=shape.teammates)
            .map(|i| SeatPlan::builtin(format!("Bot{i}"), bw4t_agents::Strategy::Cooperative))
            .collect(),
        names: names.clone(),
        max_running: n,
        on_end: OnEnd::Stay,
        replays: false,
        lateness: Some(lateness.clone()),
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

/// What the players did, counted across all of them.
#[derive(Default)]
struct PlayCounts {
    orders: AtomicU64,
    percepts: AtomicU64,
    messages: AtomicU64,
    /// How often each player sends a message, if it talks.
    talk_every: Option<Duration>,
    /// Times from sending an action to its ack.
    latencies: Mutex<Vec<Duration>>,
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

/// `lockstep`: `arena_lockstep_matches` matches of 3 built-in agents at any time in one
/// arena (each that ends replaced by the next), on a runtime of 1 worker thread, then of
/// 2; ticks per second of all of them together.
fn lockstep(args: &ArenaArgs, map: &Map, seed: u64) -> Result<Value> {
    let m = args.arena_lockstep_matches;
    if m == 0 {
        bail!("--arena-lockstep-matches must be at least 1");
    }
    let one = lockstep_run(args, map, seed, 1)?;
    let two = lockstep_run(args, map, seed, 2)?;
    let rate = |run: &LockstepRun| run.ticks as f64 / run.seconds;
    Ok(json!({
        "case": "arena",
        "kind": "lockstep",
        "map": map.name(),
        "matches": m,
        "robots": ROBOTS,
        "max_ticks": args.arena_lockstep_ticks,
        "seconds_1_worker": round(one.seconds, 2),
        "seconds_2_workers": round(two.seconds, 2),
        "ticks_1_worker": one.ticks,
        "ticks_2_workers": two.ticks,
        "matches_ended_1_worker": one.ended,
        "matches_ended_2_workers": two.ended,
        "completed_1_worker": one.completed,
        "completed_2_workers": two.completed,
        "ticks_per_s_1_worker": rate(&one).round(),
        "ticks_per_s_2_workers": rate(&two).round(),
        "speedup": round(rate(&two) / rate(&one), 2),
        // Below 200 with 2 workers: the workers waited, or other processes had a core.
        "worker_cpu_percent_1_worker": (one.cpu / one.seconds * 100.0).round(),
        "worker_cpu_percent_2_workers": (two.cpu / two.seconds * 100.0).round(),
    }))
}

/// What one lockstep run made.
struct LockstepRun {
    ticks: u64,
    /// Matches ended, those interrupted at the end of the measurement included.
    ended: usize,
    completed: usize,
    seconds: f64,
    /// CPU seconds of the worker threads.
    cpu: f64,
}

fn lockstep_run(args: &ArenaArgs, map: &Map, seed: u64, workers: usize) -> Result<LockstepRun> {
    let m = args.arena_lockstep_matches;
    let mut config = match_config(map, seed, Mode::Lockstep);
    config.max_ticks = Some(args.arena_lockstep_ticks);
    // Each match that ends is followed by the next of its template: M run at any time.
    let template = Template {
        name: "bench".into(),
        maps: vec![map.clone()],
        config: config.clone(),
        seats: (1..=ROBOTS)
            .map(|i| SeatPlan::builtin(format!("Bot{i}"), bw4t_agents::Strategy::Cooperative))
            .collect(),
        names: (1..=m).map(|i| format!("m{i}")).collect(),
        max_running: m,
        on_end: OnEnd::Restart,
        replays: false,
        lateness: None,
    };
    let arena_config = ArenaConfig::new(vec![template]);
    let rt = runtime(workers, LOCKSTEP_THREADS)?;
    let (started, cpu) = (Instant::now(), thread_cpu_seconds(LOCKSTEP_THREADS)?);
    let totals = rt.block_on(async {
        // Made on a worker, so that making the matches counts against the workers too.
        let arena = tokio::spawn(async { Arena::start(arena_config) }).await??;
        tokio::time::sleep(Duration::from_secs_f64(args.arena_lockstep_seconds)).await;
        // The matches still running end here (interrupted); their ticks count too.
        arena.shutdown().await;
        anyhow::Ok(arena.totals().values().copied().fold(bw4t_server::Totals::default(), |a, t| {
            bw4t_server::Totals {
                ended: a.ended + t.ended,
                completed: a.completed + t.completed,
                failed: a.failed + t.failed,
                ticks: a.ticks + t.ticks,
            }
        }))
    })?;
    let seconds = started.elapsed().as_secs_f64();
    let cpu = thread_cpu_seconds(LOCKSTEP_THREADS)? - cpu;
    if totals.failed > 0 {
        anyhow::bail!("{} of the lockstep matches failed in the server", totals.failed);
    }
    Ok(LockstepRun {
        ticks: totals.ticks,
        ended: totals.ended as usize,
        completed: totals.completed as usize,
        seconds,
        cpu,
    })
}

/// `soak`: for `soak_seconds`, well-behaved players play realtime matches of one template
/// that restart when they end, while churners join another such template and drop and
/// come back with their session, or leave.
fn soak(args: &ArenaArgs, map: &Map, seed: u64) -> Result<Value> {
    if args.soak_players == 0 || !args.soak_players.is_multiple_of(ROBOTS) {
        bail!("--soak-players must be a positive multiple of {ROBOTS}: they fill whole matches");
    }
    let connections = args.soak_players + args.soak_churners;
    check_descriptors(2 * connections, "the soak")?;
    let (server_rt, client_rt) = (runtime(SERVER_WORKERS, SERVER_THREADS)?, runtime(1, CLIENT_THREADS)?);
    let (fds_start, rss_start) = (open_fds()?, rss_kb()?);
    // Matches short enough that several generations end within the soak.
    let steady_ticks = ((args.soak_seconds * f64::from(TICK_HZ) / 10.0) as u64).clamp(20, 1200);
    let churn_ticks = (steady_ticks / 2).max(10);
    let steady_lateness = Arc::new(TickLateness::default());
    let churn_lateness = Arc::new(TickLateness::default());

    let mut steady = match_config(map, seed, Mode::Realtime);
    steady.max_ticks = Some(steady_ticks);
    let mut churn = steady.clone();
    churn.max_ticks = Some(churn_ticks);
    // A churn match starts without whoever left, its empty seats played by built-in agents.
    churn.start_timeout = Some(Duration::from_secs(1));
    churn.fill = Some(bw4t_agents::Strategy::Cooperative);
    churn.grace = Duration::from_secs(2);
    let template = |name: &str, config: &HostConfig, lateness: &Arc<TickLateness>, running: usize| Template {
        name: name.into(),
        maps: vec![map.clone()],
        config: config.clone(),
        seats: Vec::new(),
        names: Vec::new(),
        max_running: running,
        on_end: OnEnd::Restart,
        replays: false,
        lateness: Some(lateness.clone()),
    };
    let templates = vec![
        template(STEADY, &steady, &steady_lateness, args.soak_players / ROBOTS),
        template(CHURN, &churn, &churn_lateness, (args.soak_churners / ROBOTS).max(1)),
    ];

    let server = Served::start(&server_rt, arena_config(templates, 2 * connections + 16))?;
    let ctx = Arc::new(SoakContext {
        addr: server.addr,
        rooms: room_names(map)?,
        counts: SoakCounts::default(),
        play: Arc::new(PlayCounts::default()),
        match_time: Duration::from_secs_f64(churn_ticks as f64 / f64::from(TICK_HZ)),
        seed,
    });
    let (stop, stopped) = watch::channel(false);
    let mut tasks = Vec::new();
    {
        let _entered = client_rt.enter();
        for i in 0..args.soak_players {
            tasks.push(tokio::spawn(steady_player(ctx.clone(), i, stopped.clone())));
        }
        for i in 0..args.soak_churners {
            let churner = if i % 2 == 0 { Churner::Returns } else { Churner::Leaves };
            tasks.push(tokio::spawn(churner_player(ctx.clone(), i, churner, stopped.clone())));
        }
    }

    let warm = Duration::from_secs_f64(args.soak_seconds / 10.0);
    std::thread::sleep(warm);
    let (rss_warm, fds_warm) = (rss_kb()?, open_fds()?);
    std::thread::sleep(Duration::from_secs_f64(args.soak_seconds) - warm);
    let (rss_end, fds_end) = (rss_kb()?, open_fds()?);
    let totals = server.arena.totals();

    let _ = stop.send(true);
    client_rt.block_on(async {
        for task in tasks {
            let _ = tokio::time::timeout(Duration::from_secs(10), task).await;
        }
    });
    server.stop(&server_rt)?;
    let (fds_after, rss_after) = (settled_fds(fds_start)?, rss_kb()?);

    let ended_of = |template: &str| totals.get(template).map_or(0, |t| t.ended);
    let c = &ctx.counts;
    let count = |n: &AtomicU64| n.load(Ordering::Relaxed);
    Ok(json!({
        "case": "arena",
        "kind": "soak",
        "map": map.name(),
        "seconds": args.soak_seconds,
        "steady_players": args.soak_players,
        "churners": args.soak_churners,
        "steady_max_ticks": steady_ticks,
        "churn_max_ticks": churn_ticks,
        "matches_ended": totals.values().map(|t| t.ended).sum::<u64>(),
        "steady_matches_ended": ended_of(STEADY),
        "churn_matches_ended": ended_of(CHURN),
        "matches_failed": totals.values().map(|t| t.failed).sum::<u64>(),
        "steady_joins": count(&c.steady_joins),
        "joins": count(&c.joins),
        "queued": count(&c.queued),
        "drops": count(&c.drops),
        "reconnects": count(&c.reconnects),
        "reconnects_refused": count(&c.reconnects_refused),
        "leaves": count(&c.leaves),
        "client_errors": count(&c.errors),
        "steady_ticks": steady_lateness.ticks(),
        "steady_skipped_ticks": steady_lateness.skipped(),
        "steady_lateness_p99_ms": millis(steady_lateness.quantile(0.99)),
        "churn_skipped_ticks": churn_lateness.skipped(),
        "rss_start_mb": mb(rss_start),
        "rss_warm_mb": mb(rss_warm),
        "rss_end_mb": mb(rss_end),
        "rss_after_mb": mb(rss_after),
        "fds_start": fds_start,
        "fds_warm": fds_warm,
        "fds_end": fds_end,
        "fds_after": fds_after,
    }))
}

/// The soak's templates.
const STEADY: &str = "steady";
const CHURN: &str = "churn";

/// What every soak client shares.
struct SoakContext {
    addr: SocketAddr,
    rooms: Arc<[String]>,
    counts: SoakCounts,
    play: Arc<PlayCounts>,
    /// How long a churn match lasts: churners stay a random part of it.
    match_time: Duration,
    seed: u64,
}

/// What the soak's clients did.
#[derive(Default)]
struct SoakCounts {
    /// Well-behaved players welcomed into a match.
    steady_joins: AtomicU64,
    /// Churners welcomed by template.
    joins: AtomicU64,
    /// Churners told to wait in a template's queue.
    queued: AtomicU64,
    /// Churners that dropped their connection meaning to come back.
    drops: AtomicU64,
    /// Churners welcomed back with their session.
    reconnects: AtomicU64,
    /// Churners whose session's match had ended (or the session expired) when they came back.
    reconnects_refused: AtomicU64,
    /// Churners that left for good (half with `bye`, half by closing).
    leaves: AtomicU64,
    /// Connections that failed or were refused unexpectedly.
    errors: AtomicU64,
}

fn add(counter: &AtomicU64) {
    counter.fetch_add(1, Ordering::Relaxed);
}

/// A well-behaved player: joins the steady template, plays each match to its end, joins again.
async fn steady_player(ctx: Arc<SoakContext>, index: usize, mut stop: watch::Receiver<bool>) {
    let mut hello = SessionOptions::agent(format!("Steady{index}"), None);
    hello.template = Some(STEADY.into());
    let seed = ctx.seed ^ (index as u64 + 1).wrapping_mul(0x5851_f42d);
    while !*stop.borrow() {
        let session = ClientSession::new(hello.clone());
        let Ok(mut player) =
            Player::connect(ctx.addr, session, ctx.rooms.clone(), seed, ctx.play.clone()).await
        else {
            add(&ctx.counts.errors);
            pause(&mut stop, Duration::from_millis(100)).await;
            continue;
        };
        loop {
            let heard = tokio::select! {
                heard = player.next() => heard,
                _ = stop.wait_for(|s| *s) => return,
            };
            match heard {
                Ok(Heard::Welcome) => add(&ctx.counts.steady_joins),
                Ok(Heard::Ended) => break,
                Ok(Heard::Refused(..)) | Err(_) => {
                    add(&ctx.counts.errors);
                    break;
                }
                Ok(Heard::Queued | Heard::Started | Heard::Playing) => {}
            }
        }
    }
}

/// How a churner misbehaves.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Churner {
    /// Drops its connection and comes back with its session.
    Returns,
    /// Leaves for good; a new player of another name takes its place.
    Leaves,
}

/// A churner: joins the churn template, plays a random part of a match, then drops (and
/// comes back to its match with its session) or leaves; after its match ends it joins by
/// template again.
async fn churner_player(ctx: Arc<SoakContext>, index: usize, kind: Churner, mut stop: watch::Receiver<bool>) {
    let mut rng = SeededRng::new(ctx.seed ^ (index as u64 + 1).wrapping_mul(0x2545_f491));
    let mut generation = 0u64;
    // The session to come back with.
    let mut back_to: Option<ClientSession> = None;
    while !*stop.borrow() {
        let returning = back_to.is_some();
        let session = match back_to.take() {
            Some(mut session) => {
                session.reconnect();
                session
            }
            None => {
                let name = match kind {
                    Churner::Returns => format!("Back{index}"),
                    Churner::Leaves => format!("Gone{index}x{generation}"),
                };
                let mut hello = SessionOptions::agent(name, None);
                hello.template = Some(CHURN.into());
                ClientSession::new(hello)
            }
        };
        let seed = rng.next_u64();
        let Ok(mut player) =
            Player::connect(ctx.addr, session, ctx.rooms.clone(), seed, ctx.play.clone()).await
        else {
            add(&ctx.counts.errors);
            pause(&mut stop, Duration::from_millis(100)).await;
            continue;
        };
        let (mut leave_at, mut coming_back) = (None::<tokio::time::Instant>, false);
        loop {
            let stay = leave_at.unwrap_or_else(|| tokio::time::Instant::now() + Duration::from_secs(3600));
            let heard = tokio::select! {
                heard = player.next() => Some(heard),
                () = tokio::time::sleep_until(stay), if leave_at.is_some() => None,
                _ = stop.wait_for(|s| *s) => return,
            };
            let Some(heard) = heard else {
                match kind {
                    Churner::Returns => {
                        add(&ctx.counts.drops);
                        coming_back = true;
                    }
                    Churner::Leaves => {
                        add(&ctx.counts.leaves);
                        generation += 1;
                        if generation.is_multiple_of(2) {
                            player.bye().await;
                        }
                    }
                }
                break;
            };
            match heard {
                Ok(Heard::Welcome) => {
                    add(if returning { &ctx.counts.reconnects } else { &ctx.counts.joins });
                    let part = 0.1 + 0.4 * (rng.below(1000) as f64 / 1000.0);
                    leave_at = Some(tokio::time::Instant::now() + ctx.match_time.mul_f64(part));
                }
                Ok(Heard::Queued) => add(&ctx.counts.queued),
                Ok(Heard::Ended) => break,
                Ok(Heard::Refused(..)) if returning => {
                    add(&ctx.counts.reconnects_refused);
                    break;
                }
                Ok(Heard::Refused(..)) | Err(_) => {
                    add(&ctx.counts.errors);
                    break;
                }
                Ok(Heard::Started | Heard::Playing) => {}
            }
        }
        let session = player.into_session();
        back_to = coming_back.then_some(session);
        // A dropped player is away for a moment before it comes back.
        if back_to.is_some() {
            let away = Duration::from_millis(50 + rng.below(250));
            pause(&mut stop, away).await;
        }
    }
}

/// Waits `time`, or less if the soak stops.
async fn pause(stop: &mut watch::Receiver<bool>, time: Duration) {
    let _ = tokio::time::timeout(time, stop.wait_for(|s| *s)).await;
}

/// A bench client's connection: it orders its robot to a random room whenever it is
/// welcomed and whenever its last order ends (arrived or collided) or is refused.
struct Player {
    session: ClientSession,
    lines: Lines<BufReader<OwnedReadHalf>>,
    writer: OwnedWriteHalf,
    rooms: Arc<[String]>,
    rng: SeededRng,
    counts: Arc<PlayCounts>,
    /// When each action still awaiting its ack was sent.
    sent: std::collections::HashMap<u64, Instant>,
    /// When the player sends its next message, if it talks.
    next_talk: Option<tokio::time::Instant>,
}

/// What a player heard, as far as the benchmark cares.
enum Heard {
    /// Welcomed into a match.
    Welcome,
    /// Waiting in a template's queue.
    Queued,
    /// The match started (the last `lobby`).
    Started,
    /// Anything else while the match goes on.
    Playing,
    /// The match ended, or the server said `bye` or closed the connection.
    Ended,
    /// A fatal `error`.
    Refused(ErrorCode, String),
}

impl Player {
    /// Connects and says the session's `hello`.
    async fn connect(
        addr: SocketAddr,
        session: ClientSession,
        rooms: Arc<[String]>,
        seed: u64,
        counts: Arc<PlayCounts>,
    ) -> Result<Player> {
        let stream = TcpStream::connect(addr).await.with_context(|| format!("cannot connect to {addr}"))?;
        stream.set_nodelay(true)?;
        let (reader, writer) = stream.into_split();
        let mut player = Player {
            session,
            lines: BufReader::new(reader).lines(),
            writer,
            rooms,
            rng: SeededRng::new(seed),
            counts,
            sent: std::collections::HashMap::new(),
            next_talk: None,
        };
        player.flush().await?;
        player.plan_talk();
        Ok(player)
    }

    /// Reads one line and plays on it.
    async fn next(&mut self) -> Result<Heard> {
        let line = match self.next_talk {
            // A person's input comes at any moment, not in step with the ticks.
            Some(at) => tokio::select! {
                line = self.lines.next_line() => line?,
                () = tokio::time::sleep_until(at) => {
                    self.talk();
                    self.flush().await?;
                    return Ok(Heard::Playing);
                }
            },
            None => self.lines.next_line().await?,
        };
        let Some(line) = line else { return Ok(Heard::Ended) };
        self.session.handle_line(&line)?;
        let mut heard = Heard::Playing;
        while let Some(event) = self.session.poll_event() {
            heard = match event {
                SessionEvent::Percepts { .. } => {
                    self.counts.percepts.fetch_add(1, Ordering::Relaxed);
                    Heard::Playing
                }
                SessionEvent::Welcome(_) => {
                    self.go();
                    Heard::Welcome
                }
                SessionEvent::Lobby(lobby) if lobby.queued.is_some() => Heard::Queued,
                SessionEvent::Lobby(lobby) if lobby.started => Heard::Started,
                SessionEvent::Ack { ack, request } => {
                    if let Some(sent) = request.and_then(|r| self.sent.remove(&r.id)) {
                        if let Ok(mut latencies) = self.counts.latencies.lock() {
                            latencies.push(sent.elapsed());
                        }
                    }
                    if !ack.ok {
                        self.go();
                    }
                    Heard::Playing
                }
                SessionEvent::Result { result, .. } if result.outcome != Outcome::Superseded => {
                    self.go();
                    Heard::Playing
                }
                SessionEvent::Error(error) if error.fatal => Heard::Refused(error.code, error.message),
                SessionEvent::MatchEnd(_) | SessionEvent::Bye(_) => Heard::Ended,
                _ => Heard::Playing,
            };
        }
        self.flush().await?;
        Ok(heard)
    }

    /// Orders the robot to a random room.
    fn go(&mut self) {
        let room = self.rooms[self.rng.index(self.rooms.len())].clone();
        self.send(&Action::GoTo(room));
        self.counts.orders.fetch_add(1, Ordering::Relaxed);
    }

    /// Tells the team where it is going, as a person would from the page's menu.
    fn talk(&mut self) {
        self.plan_talk();
        let mut said = bw4t_protocol::Said::new("going_to");
        said.room = Some(self.rooms[self.rng.index(self.rooms.len())].clone());
        self.send(&Action::SendMessage { to: bw4t_sim::Receiver::All, text: said.to_text() });
        self.counts.messages.fetch_add(1, Ordering::Relaxed);
    }

    /// Picks when to talk next: `talk_every` on average, at a random moment.
    fn plan_talk(&mut self) {
        self.next_talk = self.counts.talk_every.map(|every| {
            let jitter = every.mul_f64(self.rng.index(1000) as f64 / 1000.0);
            tokio::time::Instant::now() + every / 2 + jitter
        });
    }

    /// Queues an action, noting when, for its ack's latency.
    fn send(&mut self, action: &Action) {
        let id = self.session.act(action);
        self.sent.insert(id, Instant::now());
    }

    /// Writes what the session has to send.
    async fn flush(&mut self) -> Result<()> {
        let out: String = std::iter::from_fn(|| self.session.poll_transmit()).collect();
        if !out.is_empty() {
            self.writer.write_all(out.as_bytes()).await?;
        }
        Ok(())
    }

    /// Closes the connection; the session stays, to come back with.
    fn into_session(self) -> ClientSession {
        self.session
    }

    /// Says `bye` (best effort: the connection is dropped next anyway).
    async fn bye(&mut self) {
        self.session.bye();
        let _ = self.flush().await;
    }
}

/// The rooms of `map`, where players send their robots.
fn room_names(map: &Map) -> Result<Arc<[String]>> {
    let rooms: Vec<String> =
        map.zones().iter().filter(|z| z.kind == ZoneKind::Room).map(|z| z.name.clone()).collect();
    if rooms.is_empty() {
        bail!("map '{}' has no rooms to send robots to", map.name());
    }
    Ok(rooms.into())
}

/// A match of 3 players on `map` (one server's limits and all).
/// An arena of `templates` that takes `connections` at once.
fn arena_config(templates: Vec<Template>, connections: usize) -> ArenaConfig {
    let mut config = ArenaConfig::new(templates);
    config.server = ServerConfig { max_connections: connections, ..ServerConfig::default() };
    config
}

fn match_config(map: &Map, seed: u64, mode: Mode) -> HostConfig {
    let mut config = HostConfig::new(map.clone());
    config.seed = seed;
    config.mode = mode;
    config.robots = ROBOTS;
    config.game.ticks_per_second = TICK_HZ;
    config
}

/// A multi-thread runtime of `workers` threads named `name`.
fn runtime(workers: usize, name: &str) -> Result<Runtime> {
    Ok(tokio::runtime::Builder::new_multi_thread()
        .worker_threads(workers)
        .thread_name(name)
        .enable_all()
        .build()?)
}

/// An arena served on a loopback port.
struct Served {
    arena: Arena,
    addr: SocketAddr,
    stop: oneshot::Sender<()>,
    task: tokio::task::JoinHandle<()>,
}

impl Served {
    /// Makes the arena's matches and serves them on `runtime`.
    fn start(runtime: &Runtime, config: ArenaConfig) -> Result<Served> {
        runtime.block_on(async {
            let arena = Arena::start(config).context("cannot start the arena")?;
            let listener = bw4t_server::listen(([127, 0, 0, 1], 0).into())?;
            let addr = listener.local_addr()?;
            let (stop, stopped) = oneshot::channel::<()>();
            let served = arena.clone();
            let task = tokio::spawn(async move {
                bw4t_server::serve_arena(&served, listener, None, async {
                    let _ = stopped.await;
                })
                .await;
            });
            Ok(Served { arena, addr, stop, task })
        })
    }

    /// Ends every match and waits until each has recorded its end.
    fn stop(self, runtime: &Runtime) -> Result<()> {
        let _ = self.stop.send(());
        runtime
            .block_on(async { tokio::time::timeout(Duration::from_secs(30), self.task).await })
            .context("the server did not stop within 30 s")?
            .context("the server task")?;
        Ok(())
    }
}

/// Waits (a bounded time) for the clients to see their matches end.
fn finish_clients(runtime: &Runtime, clients: Vec<tokio::task::JoinHandle<()>>) {
    runtime.block_on(async {
        let all = async {
            for client in clients {
                let _ = client.await;
            }
        };
        let _ = tokio::time::timeout(Duration::from_secs(10), all).await;
    });
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

/// User plus system CPU seconds of this process's threads whose name starts with `name`
/// (`/proc/self/task/*/stat`).
fn thread_cpu_seconds(name: &str) -> Result<f64> {
    let mut total = 0.0;
    for task in std::fs::read_dir("/proc/self/task").context("the arena bench needs /proc (Linux)")? {
        // A thread may end between the listing and the read.
        let Ok(stat) = std::fs::read_to_string(task?.path().join("stat")) else { continue };
        let Some((head, rest)) = stat.rsplit_once(')') else { continue };
        if !head.split_once('(').is_some_and(|(_, comm)| comm.starts_with(name)) {
            continue;
        }
        let fields: Vec<&str> = rest.split_whitespace().collect();
        let field = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
        // utime and stime, in USER_HZ (100 on every Linux configuration in use).
        total += (field(11) + field(12)) / 100.0;
    }
    Ok(total)
}

/// The machine's load average over the last minute (`/proc/loadavg`).
fn load_average() -> Result<f64> {
    let text = std::fs::read_to_string("/proc/loadavg").context("the arena bench needs /proc (Linux)")?;
    text.split_whitespace().next().and_then(|l| l.parse().ok()).context("unreadable /proc/loadavg")
}

/// This process's resident memory in kB (`VmRSS` of `/proc/self/status`).
fn rss_kb() -> Result<u64> {
    let status =
        std::fs::read_to_string("/proc/self/status").context("the arena bench needs /proc (Linux)")?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .context("no VmRSS in /proc/self/status")
}

/// This process's open descriptors (`/proc/self/fd`, less the one listing it).
fn open_fds() -> Result<usize> {
    let listed = std::fs::read_dir("/proc/self/fd").context("the arena bench needs /proc (Linux)")?.count();
    Ok(listed.saturating_sub(1))
}

/// Descriptors open once the server has stopped, the runtimes still up as at the start:
/// sockets close as their tasks finish, so this waits (up to 2 s) for the count to fall
/// back to `start`; what stays open beyond is reported as it is.
fn settled_fds(start: usize) -> Result<usize> {
    let until = Instant::now() + Duration::from_secs(2);
    loop {
        let open = open_fds()?;
        if open <= start || Instant::now() >= until {
            return Ok(open);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Fails, naming the limit and how to raise it, if this process may not open `needed`
/// more descriptors (besides those open now).
fn check_descriptors(needed: usize, what: &str) -> Result<()> {
    let limits =
        std::fs::read_to_string("/proc/self/limits").context("the arena bench needs /proc (Linux)")?;
    let Some(line) = limits.lines().find(|l| l.starts_with("Max open files")) else { return Ok(()) };
    let values: Vec<&str> = line["Max open files".len()..].split_whitespace().collect();
    let (Some(soft), hard) = (values.first().and_then(|v| v.parse::<usize>().ok()), values.get(1)) else {
        // "unlimited"
        return Ok(());
    };
    let wanted = needed + open_fds()? + 64;
    if wanted > soft {
        bail!(
            "{what} needs about {wanted} open descriptors (one for each end of every connection, both ends \
             in this process), but the limit on open files is {soft} (`ulimit -n`; the hard limit is {}): \
             raise it with `ulimit -n {wanted}` in this shell (past the hard limit only as root, e.g. \
             LimitNOFILE= for a systemd service or /etc/security/limits.conf), or ask for fewer",
            hard.copied().unwrap_or("unknown")
        );
    }
    Ok(())
}

fn mb(kb: u64) -> f64 {
    round(kb as f64 / 1024.0, 1)
}

fn millis(d: Duration) -> f64 {
    round(d.as_secs_f64() * 1000.0, 1)
}

fn round(x: f64, places: i32) -> f64 {
    let scale = 10f64.powi(places);
    (x * scale).round() / scale
}
