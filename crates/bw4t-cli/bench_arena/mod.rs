//! `bw4t bench arena`: many matches in one arena server. Realtime matches played by
//! loopback TCP clients (tick lateness, CPU, memory and descriptors per match), study-sized
//! matches (two people and two built-in teammates each: lateness and the people's
//! input-to-acknowledgement latency), lockstep
//! matches of built-in teams on one and on two worker threads, and a churn soak (players
//! joining by template, dropping and coming back, leaving, while others keep playing).
//! Each figure has its module; `player` is the TCP client they share.

mod lockstep;
mod player;
mod realtime;
mod soak;

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use bw4t_map::{Map, ZoneKind};
use bw4t_protocol::Mode;
use bw4t_server::{Arena, ArenaConfig, HostConfig, MatchSetup, Seat, ServerConfig, Template};
use clap::{Args, ValueEnum};
use tokio::runtime::Runtime;
use tokio::sync::oneshot;

use realtime::Shape;

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
            Kind::Realtime => realtime::realtime(args, &map, seed, Shape::players(args.arena_matches))?,
            Kind::Study => realtime::realtime(args, &map, seed, Shape::study(args.study_matches))?,
            Kind::Lockstep => lockstep::lockstep(args, &map, seed)?,
            Kind::Soak => soak::soak(args, &map, seed)?,
        };
        outln!("{line}");
    }
    Ok(())
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

/// An arena of `templates` that takes `connections` at once.
fn arena_config(templates: Vec<Template>, connections: usize) -> ArenaConfig {
    let mut config = ArenaConfig::new(templates);
    // Every simulated client comes from this machine: one address may take every place.
    config.server =
        ServerConfig { max_connections: connections, max_per_source: connections, ..ServerConfig::default() };
    config
}

/// A match on `map` of `builtin` built-in cooperative agents, then `open` seats for
/// players, at the benchmarks' tick rate.
fn match_setup(map: &Map, seed: u64, builtin: usize, open: usize) -> MatchSetup {
    let mut setup = MatchSetup::builtin_team(map.clone(), builtin, bw4t_agents::Strategy::Cooperative);
    setup.seats.extend(std::iter::repeat_with(Seat::open).take(open));
    setup.seed = seed;
    setup.game.ticks_per_second = TICK_HZ;
    setup
}

/// How a benchmark's matches are run: `mode`, and one server's limits and all.
fn host_config(mode: Mode) -> HostConfig {
    let mut config = HostConfig::new();
    config.mode = mode;
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
