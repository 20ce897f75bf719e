//! The `soak` figure: matches that end and restart while players join by template, drop
//! and come back with their session, or leave, as others keep playing.

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use anyhow::{Result, bail};
use bw4t_map::{Map, SeededRng};
use bw4t_protocol::{ClientSession, Mode, SessionOptions};
use bw4t_server::{HostConfig, MatchSetup, OnEnd, Template, TickLateness};
use serde_json::{Value, json};
use tokio::sync::watch;

use super::player::{Heard, PlayCounts, Player};
use super::{
    ArenaArgs, CLIENT_THREADS, ROBOTS, SERVER_THREADS, SERVER_WORKERS, Served, TICK_HZ, arena_config,
    check_descriptors, host_config, match_setup, mb, millis, open_fds, room_names, rss_kb, runtime,
    settled_fds,
};

/// `soak`: for `soak_seconds`, well-behaved players play realtime matches of one template
/// that restart when they end, while churners join another such template and drop and
/// come back with their session, or leave.
pub(super) fn soak(args: &ArenaArgs, map: &Map, seed: u64) -> Result<Value> {
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

    let steady = host_config(Mode::Realtime);
    let mut steady_setup = match_setup(map, seed, 0, ROBOTS);
    steady_setup.max_ticks = Some(steady_ticks);
    let mut churn = steady.clone();
    let mut churn_setup = steady_setup.clone();
    churn_setup.max_ticks = Some(churn_ticks);
    // A churn match starts without whoever left, its empty seats played by built-in agents.
    churn.start_timeout = Some(Duration::from_secs(1));
    churn.fill = Some(bw4t_agents::Strategy::Cooperative);
    churn.grace = Duration::from_secs(2);
    let template = |name: &str,
                    (setup, config): (&MatchSetup, &HostConfig),
                    lateness: &Arc<TickLateness>,
                    running: usize| Template {
        name: name.into(),
        maps: vec![map.clone()],
        setup: setup.clone(),
        config: config.clone(),
        names: Vec::new(),
        max_running: running,
        on_end: OnEnd::Restart,
        replays: false,
        lateness: Some(lateness.clone()),
        invited_only: false,
    };
    let templates = vec![
        template(STEADY, (&steady_setup, &steady), &steady_lateness, args.soak_players / ROBOTS),
        template(CHURN, (&churn_setup, &churn), &churn_lateness, (args.soak_churners / ROBOTS).max(1)),
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
