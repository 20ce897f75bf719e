//! The networked benchmark cases: lockstep round trips and a served match's CPU use.

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use bw4t_map::{Map, MapParts, Spawn, Vec2};
use bw4t_protocol::{ClientSession, Mode, SessionEvent, SessionOptions};
use bw4t_server::{HostConfig, MatchSetup, Seat};
use bw4t_sim::{Action, MoveState, Percept};
use serde_json::{Value, json};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader, Lines};
use tokio::net::TcpStream;
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};

/// `lockstep`: players that answer at once, with a message each tick.
pub(crate) fn lockstep(map: &str, seed: u64, players: usize, ticks: u64) -> Result<Value> {
    let map = crate::maps::load(map)?;
    let seats = std::iter::repeat_with(Seat::open).take(players).collect();
    let setup = MatchSetup { seed, seats, max_ticks: Some(ticks), ..MatchSetup::new(map) };
    let mut config = HostConfig::new();
    config.mode = Mode::Lockstep;
    config.every_tick = true;
    config.deadline = Some(Duration::from_secs(10));
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
        let addr = listener.local_addr()?;
        // Every player connects from this machine.
        let server = bw4t_server::ServerConfig { max_per_source: players.max(1), ..Default::default() };
        let extras = bw4t_server::Extras { server, ..Default::default() };
        let served = bw4t_server::serve_with(listener, setup, config, extras, std::future::pending());
        let server = tokio::spawn(served);
        let mut clients = Vec::new();
        for i in 0..players {
            clients.push(tokio::spawn(lockstep_player(addr, i, seed)));
        }
        let started = Instant::now();
        let result = server.await.context("server task")??;
        let seconds = started.elapsed().as_secs_f64();
        let mut gaps = Vec::new();
        for client in clients {
            gaps.extend(client.await.context("client task")??);
        }
        gaps.sort_unstable();
        let median = gaps.get(gaps.len() / 2).copied().unwrap_or_default();
        Ok(json!({
            "case": "lockstep",
            "players": players,
            "ticks": result.ticks,
            "ticks_per_s": (result.ticks as f64 / seconds).round(),
            "rtt_us": median.as_micros() as u64,
            "late_ticks": result.per_robot.iter().map(|r| r.late_ticks).sum::<u64>(),
        }))
    })
}

/// A player that moves now and then, says something every tick and answers `ready` at
/// once. Returns the times between consecutive ticks' percepts.
async fn lockstep_player(addr: SocketAddr, index: usize, seed: u64) -> Result<Vec<Duration>> {
    let (mut session, mut lines, mut writer) = join(addr, index).await?;
    let places = ["RoomA1", "RoomB2", "RoomC3", "DropZone", "RoomA3", "RoomC1"];
    let mut rng = bw4t_map::SeededRng::new(seed ^ index as u64);
    let (mut gaps, mut last) = (Vec::new(), None::<Instant>);
    while let Some(line) = lines.next_line().await? {
        session.handle_line(&line)?;
        while let Some(event) = session.poll_event() {
            let SessionEvent::Percepts { delta, .. } = event else { continue };
            let now = Instant::now();
            if let Some(before) = last {
                gaps.push(now - before);
            }
            last = Some(now);
            session.say("all", Some(format!("tick {}", delta.tick)), None);
            if rng.below(20) == 0 {
                let place = places[rng.index(places.len())];
                session.act(&Action::GoTo(place.into()));
            }
            session.ready();
        }
        flush(&mut session, &mut writer).await?;
    }
    Ok(gaps)
}

/// Connects as player `Bench{index}` and says `hello`.
async fn join(
    addr: SocketAddr,
    index: usize,
) -> Result<(ClientSession, Lines<BufReader<OwnedReadHalf>>, OwnedWriteHalf)> {
    let stream = TcpStream::connect(addr).await?;
    stream.set_nodelay(true)?;
    let (reader, mut writer) = stream.into_split();
    let mut session = ClientSession::new(SessionOptions::agent(format!("Bench{index}"), None));
    flush(&mut session, &mut writer).await?;
    Ok((session, BufReader::new(reader).lines(), writer))
}

/// Writes what the session has to send, in one write.
async fn flush(session: &mut ClientSession, writer: &mut OwnedWriteHalf) -> Result<()> {
    let out: String = std::iter::from_fn(|| session.poll_transmit()).collect();
    if !out.is_empty() {
        writer.write_all(out.as_bytes()).await?;
    }
    Ok(())
}

/// `realtime`: a `bw4t serve` child process with `robots` connected players at 20 ticks/s;
/// its CPU time (from `/proc`) over `seconds` of wall-clock time.
pub(crate) fn realtime(seed: u64, robots: usize, seconds: f64) -> Result<Value> {
    let dir = std::env::temp_dir().join(format!("bw4t-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let map_path = dir.join("crowded.toml");
    std::fs::write(&map_path, crowded_default(robots)?.to_native())?;
    let mut child = crate::self_command()?
        .args(["serve", "--port", "0", "--mode", "realtime", "--tick-hz", "20"])
        .args(["--robots", &robots.to_string(), "--seed", &seed.to_string()])
        // Every robot connects from this machine.
        .args(["--max-per-source", &robots.max(1).to_string()])
        .arg("--map")
        .arg(&map_path)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .context("cannot start bw4t serve")?;
    let stdout = child.stdout.take().context("no stdout")?;
    let mut first = String::new();
    std::io::BufRead::read_line(&mut std::io::BufReader::new(stdout), &mut first)?;
    let addr: SocketAddr = first.trim().trim_start_matches("listening on ").parse().context("no address")?;
    let pid = child.id();
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    let received = Arc::new(AtomicU64::new(0));
    let measured = runtime.block_on(async {
        let mut players = Vec::new();
        for i in 0..robots {
            players.push(tokio::spawn(realtime_player(addr, i, seed, received.clone())));
        }
        // Let every player join and the match start before measuring.
        tokio::time::sleep(Duration::from_millis(500)).await;
        let (cpu0, wall0, seen0) = (cpu_seconds(pid)?, Instant::now(), received.load(Ordering::SeqCst));
        tokio::time::sleep(Duration::from_secs_f64(seconds)).await;
        let (cpu1, wall1, seen1) = (cpu_seconds(pid)?, Instant::now(), received.load(Ordering::SeqCst));
        if seen1 == seen0 {
            bail!("the served match did not run (no percepts while measuring)");
        }
        players.iter().for_each(|p| p.abort());
        anyhow::Ok(((cpu1 - cpu0) / (wall1 - wall0).as_secs_f64(), seen1 - seen0))
    });
    let _ = std::process::Command::new("kill").arg("-TERM").arg(pid.to_string()).status();
    let _ = child.wait();
    let _ = std::fs::remove_dir_all(&dir);
    let (cpu, percepts) = measured?;
    Ok(json!({
        "case": "realtime",
        "robots": robots,
        "tick_hz": 20,
        "seconds": seconds,
        "cpu_percent": (cpu * 1000.0).round() / 10.0,
        "percepts_received": percepts,
    }))
}

/// A realtime player: joins, and sends a new `goTo` whenever its robot stops.
async fn realtime_player(addr: SocketAddr, index: usize, seed: u64, received: Arc<AtomicU64>) -> Result<()> {
    let (mut session, mut lines, mut writer) = join(addr, index).await?;
    let places = ["RoomA1", "RoomB2", "RoomC3", "DropZone", "RoomA3", "RoomC1", "LeftHallA", "RightHallC"];
    let mut rng = bw4t_map::SeededRng::new(seed ^ index as u64);
    while let Some(line) = lines.next_line().await? {
        session.handle_line(&line)?;
        while let Some(event) = session.poll_event() {
            let SessionEvent::Percepts { delta, .. } = event else { continue };
            received.fetch_add(1, Ordering::SeqCst);
            let stopped =
                delta.add.iter().any(|p| matches!(p, Percept::State(s) if *s != MoveState::Traveling));
            if stopped {
                let place = places[rng.index(places.len())];
                session.act(&Action::GoTo(place.into()));
            }
        }
        flush(&mut session, &mut writer).await?;
    }
    Ok(())
}

/// The default map with `n` spawn points spread over its halls, for crowd benchmarks.
fn crowded_default(n: usize) -> Result<Map> {
    let base = crate::maps::load("default")?;
    let mut parts: MapParts = base.parts().clone();
    parts.name = "default-crowded".into();
    // A 10 x 10 grid in FrontDropZone and the halls below the rooms: robots may overlap.
    parts.spawns = (0..n)
        .map(|i| {
            let (col, row) = ((i % 10) as f32, (i / 10) as f32);
            Spawn { name: format!("S{i}"), pos: Vec2::new(11.5 + col * 3.0, 61.0 + (row % 5.0) * 2.0) }
        })
        .collect();
    Ok(Map::new(parts)?)
}

/// User plus system CPU seconds of a process, from `/proc/PID/stat` (Linux).
pub(crate) fn cpu_seconds(pid: u32) -> Result<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .context("the realtime case needs /proc (Linux)")?;
    // Fields after the command name (which may contain spaces) start after the last ')'.
    let Some(rest) = stat.rsplit_once(')').map(|(_, r)| r) else { bail!("unreadable /proc/{pid}/stat") };
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 =
        fields.get(11).context("utime")?.parse::<f64>()? + fields.get(12).context("stime")?.parse::<f64>()?;
    // USER_HZ is 100 on every Linux configuration in use.
    Ok(ticks / 100.0)
}
