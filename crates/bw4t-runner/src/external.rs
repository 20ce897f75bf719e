//! Matches with external agent programs: a lockstep server on loopback, one child process
//! per external seat, built-in agents playing in-process beside them.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use bw4t_agents::{MatchSetup, Player, Seat, Strategy};
use bw4t_protocol::{AgentStatus, MatchResult, MessagePolicy, Mode};
use bw4t_server::{Extras, HostConfig, ServerConfig};
use serde::Serialize;

/// How an agent fared.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct AgentReport {
    /// Player name.
    pub name: String,
    /// `builtin:STRATEGY` or `external`.
    pub kind: String,
    /// The command, for external agents.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub command: Option<String>,
    /// How it fared.
    pub status: AgentStatus,
    /// A sentence saying what happened.
    pub detail: String,
    /// The exit code, when the program exited by itself.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exit_code: Option<i32>,
    /// Where its standard output and error went.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub log: Option<PathBuf>,
}

impl AgentReport {
    /// The report of a built-in seat: it always plays.
    pub fn builtin(name: &str, strategy: Strategy) -> AgentReport {
        AgentReport {
            name: name.to_string(),
            kind: format!("builtin:{}", strategy.name()),
            command: None,
            status: AgentStatus::Ok,
            detail: "played in-process".into(),
            exit_code: None,
            log: None,
        }
    }
}

/// Everything a served run needs.
pub struct ServedRun<'a> {
    /// The match: its seats are built-in agents and programs.
    pub setup: MatchSetup,
    /// Lockstep deadline (`None`: wait forever).
    pub deadline: Option<Duration>,
    /// How long agents have to connect before the match starts without them.
    pub connect_timeout: Duration,
    /// Where agent logs go.
    pub log_dir: &'a Path,
    /// Where the replay goes.
    pub replay: Option<Box<dyn std::io::Write + Send>>,
    /// When set, the match ends early (`interrupted`) and its agents are stopped.
    pub stop: Option<Arc<AtomicBool>>,
    /// Wall time the match may take from its start (agents connecting included); past
    /// it the match ends as `interrupted` and [`Served::out_of_time`] says so.
    pub wall_budget: Option<Duration>,
    /// Which messages the agent programs may send.
    pub language: MessagePolicy,
}

/// A served run's outcome.
pub struct Served {
    /// The match's result.
    pub result: MatchResult,
    /// How each seat's agent fared.
    pub agents: Vec<AgentReport>,
    /// Whether the match was ended because its wall-time budget ran out.
    pub out_of_time: bool,
}

/// Why a served run failed to start.
#[derive(Debug, thiserror::Error)]
pub enum ServedError {
    /// A local resource (socket, runtime, log file) is unavailable.
    #[error("{0}")]
    Io(String),
    /// The match could not be set up.
    #[error(transparent)]
    Server(#[from] bw4t_server::ServerError),
    /// A seat's player cannot play in such a run.
    #[error(transparent)]
    Setup(#[from] bw4t_agents::SetupError),
}

/// What a report says of an agent program that never joined its seat: the usual cause,
/// and what to do about it.
const NEVER_CONNECTED: &str = "never connected to this match (was it given BW4T_HOST, BW4T_PORT, \
BW4T_NAME and BW4T_TOKEN? a program that drops them, such as an MCP host with an environment of its \
own, plays elsewhere or not at all: pass them on, and start `bw4t mcp --served` so that it fails \
loudly without them)";

/// Deadlines a player may miss in a row before it is dropped as unresponsive.
const MAX_LATE_IN_ROW: u32 = 3;

/// Plays a match with external agent processes; every child (and its children) is gone
/// when this returns.
pub fn play_served(run: ServedRun<'_>) -> Result<Served, ServedError> {
    let io = |what: &str, e: std::io::Error| ServedError::Io(format!("{what}: {e}"));
    run.setup.check()?;
    run.setup.only_players("in a run with agent programs", |p| {
        matches!(p, Player::Builtin(_) | Player::Program(_))
    })?;
    let seats = run.setup.seats.clone();
    std::fs::create_dir_all(run.log_dir)
        .map_err(|e| io(&format!("cannot create {}", run.log_dir.display()), e))?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| io("runtime", e))?;
    let token = bw4t_server::random_token();
    runtime.block_on(async {
        let listener =
            tokio::net::TcpListener::bind("127.0.0.1:0").await.map_err(|e| io("cannot listen", e))?;
        let addr = listener.local_addr().map_err(|e| io("no address", e))?;
        let mut config = HostConfig::new();
        config.mode = Mode::Lockstep;
        config.deadline = run.deadline;
        config.token = Some(token.clone());
        config.start_timeout = Some(run.connect_timeout);
        config.max_late_in_row = Some(MAX_LATE_IN_ROW);
        config.pause_when_empty = false;
        config.language = run.language;
        // The server keeps each program's seat for it; the program connects under its name.
        let mut setup = run.setup;
        for seat in &mut setup.seats {
            if matches!(seat.player, Player::Program(_)) {
                seat.player = Player::Remote;
            }
        }
        let (gone_tx, gone_rx) = tokio::sync::mpsc::channel(seats.len().max(1));
        let extras = Extras {
            // Every player is a program started here: one address holds every seat.
            server: ServerConfig {
                hello_timeout: run.connect_timeout,
                max_per_source: ServerConfig::default().max_connections,
                ..ServerConfig::default()
            },
            replay: run.replay,
            program: crate::program(),
            gone_seats: Some(gone_rx),
            http: None,
        };
        let (interrupt, interrupted) = tokio::sync::oneshot::channel::<()>();
        let mut interrupt = Some(interrupt);
        let shutdown = async move {
            // A dropped sender (the match ended first) must not end anything.
            if interrupted.await.is_err() {
                std::future::pending::<()>().await;
            }
        };
        let server = tokio::spawn(bw4t_server::serve_with(listener, setup, config, extras, shutdown));
        let mut children = Vec::new();
        for seat in &seats {
            if let Player::Program(command) = &seat.player {
                let log = run.log_dir.join(format!("{}.log", seat.name));
                let child = spawn(command, &seat.name, &addr, &token, &log);
                children.push(Running { name: seat.name.clone(), log, child, exited: None });
            }
        }
        // Watch the children: one that dies before connecting must not hold up the start.
        tokio::pin!(server);
        let out_of_time_at = run.wall_budget.map(|budget| tokio::time::Instant::now() + budget);
        let mut out_of_time = false;
        let outcome = loop {
            tokio::select! {
                outcome = &mut server => break outcome,
                () = tokio::time::sleep(Duration::from_millis(50)) => {
                    let over = out_of_time_at.is_some_and(|at| tokio::time::Instant::now() >= at);
                    if over && interrupt.is_some() {
                        out_of_time = true;
                    }
                    if over || run.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst)) {
                        if let Some(interrupt) = interrupt.take() {
                            let _ = interrupt.send(());
                        }
                    }
                    for c in children.iter_mut().filter(|c| c.exited.is_none()) {
                        if let Some(code) = c.poll() {
                            c.exited = Some(code);
                            let _ = gone_tx.try_send(c.name.clone());
                        }
                    }
                }
            }
        };
        for c in &mut children {
            c.stop().await;
        }
        let result = match outcome {
            Ok(Ok(result)) => result,
            Ok(Err(e)) => return Err(ServedError::Server(e)),
            Err(e) => return Err(ServedError::Io(format!("the server task failed: {e}"))),
        };
        let agents = seats.iter().map(|seat| report(seat, &result, &children)).collect();
        Ok(Served { result, agents, out_of_time })
    })
}

struct Running {
    name: String,
    log: PathBuf,
    child: Result<Child, String>,
    /// Exit code (or -signal) if it exited before the match ended.
    exited: Option<Result<i32, String>>,
}

impl Running {
    fn poll(&mut self) -> Option<Result<i32, String>> {
        match &mut self.child {
            Err(e) => Some(Err(e.clone())),
            Ok(child) => match child.try_wait() {
                Ok(Some(status)) => Some(Ok(status.code().unwrap_or(-1))),
                Ok(None) => None,
                Err(e) => Some(Err(e.to_string())),
            },
        }
    }

    /// Ends the program and everything it started: a second to leave by itself after
    /// `match_end` (to write down its result), then TERM to its process group, KILL after
    /// another second, and up to a second more for the group to be gone.
    async fn stop(&mut self) {
        let Ok(child) = &mut self.child else { return };
        if self.exited.is_none() {
            if let Ok(Some(status)) = child.try_wait() {
                self.exited = Some(Ok(status.code().unwrap_or(-1)));
            }
        }
        for _ in 0..20 {
            if matches!(child.try_wait(), Ok(Some(_))) {
                break;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let group = format!("-{}", child.id());
        let _ = Command::new("kill").args(["-TERM", "--", &group]).stderr(Stdio::null()).status();
        for _ in 0..20 {
            if matches!(child.try_wait(), Ok(Some(_))) {
                break;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let _ = Command::new("kill").args(["-KILL", "--", &group]).stderr(Stdio::null()).status();
        let _ = child.wait();
        // The group's other processes (a shell's children) die on their own time: wait, a
        // while at most, until none is left, so nothing it started outlives the run.
        for _ in 0..20 {
            let alive = Command::new("kill").args(["-0", "--", &group]).stderr(Stdio::null()).status();
            if !alive.is_ok_and(|status| status.success()) {
                break;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
}

fn spawn(
    command: &str,
    name: &str,
    addr: &std::net::SocketAddr,
    token: &str,
    log: &Path,
) -> Result<Child, String> {
    let file = std::fs::File::create(log).map_err(|e| format!("cannot create {}: {e}", log.display()))?;
    let err = file.try_clone().map_err(|e| e.to_string())?;
    let mut cmd = Command::new("sh");
    cmd.arg("-c")
        .arg(command)
        .env("BW4T_HOST", addr.ip().to_string())
        .env("BW4T_PORT", addr.port().to_string())
        .env("BW4T_NAME", name)
        .env("BW4T_TOKEN", token)
        .stdin(Stdio::null())
        .stdout(file)
        .stderr(err);
    #[cfg(unix)]
    {
        // Its own process group, so the whole tree can be ended at once.
        use std::os::unix::process::CommandExt;
        cmd.process_group(0);
    }
    cmd.spawn().map_err(|e| format!("cannot start `{command}`: {e}"))
}

fn report(seat: &Seat, result: &MatchResult, children: &[Running]) -> AgentReport {
    let name = &seat.name;
    let robot = result.per_robot.iter().find(|r| &r.name == name);
    match &seat.player {
        Player::Builtin(strategy) => AgentReport::builtin(name, *strategy),
        // Only built-in agents and programs are let in (checked at the start).
        player => {
            let command = match player {
                Player::Program(command) => command.clone(),
                other => other.kind(),
            };
            let running = children.iter().find(|c| &c.name == name);
            let exited = running.and_then(|c| c.exited.clone());
            let (late, errors, connected) =
                robot.map_or((0, 0, false), |r| (r.late_ticks, r.errors, r.connected));
            let (status, detail) = match (&exited, connected) {
                (Some(Err(e)), _) => (AgentStatus::Crashed, format!("could not run: {e}")),
                (Some(Ok(code)), false) if *code != 0 => {
                    (AgentStatus::Crashed, format!("exited with code {code} before connecting"))
                }
                (_, false) if errors > 0 => {
                    (AgentStatus::BadProtocol, format!("never completed hello; {errors} invalid lines"))
                }
                (_, false) => (AgentStatus::NeverConnected, NEVER_CONNECTED.to_string()),
                // Causes before consequences: a program dropped for garbage or silence often
                // exits with an error afterwards.
                _ if errors > 0 => (AgentStatus::BadProtocol, format!("sent {errors} invalid lines")),
                _ if late >= u64::from(MAX_LATE_IN_ROW) => {
                    (AgentStatus::Unresponsive, format!("missed {late} deadlines"))
                }
                (Some(Ok(code)), true) if *code != 0 && !result.completed => {
                    (AgentStatus::Crashed, format!("exited with code {code} during the match"))
                }
                _ => (
                    AgentStatus::Ok,
                    if late > 0 { format!("missed {late} deadlines") } else { "played".to_string() },
                ),
            };
            AgentReport {
                name: name.clone(),
                kind: "external".into(),
                command: Some(command.clone()),
                status,
                detail,
                exit_code: exited.and_then(Result::ok),
                log: running.map(|c| c.log.clone()),
            }
        }
    }
}
