//! `bw4t run`: one whole match as fast as possible, with built-in and external agents.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bw4t_agents::{MatchSetup, Player, Seat, Strategy, named_seats};
use bw4t_protocol::{EndReason, MatchResult};
use bw4t_runner::{AgentReport, ServedRun, TickLimit, check_command, play, play_served, plural};
use bw4t_sim::MatchConfig;
use clap::Args;

use crate::status;

/// Options of `bw4t run`.
#[derive(Args)]
pub(crate) struct RunArgs {
    /// Map: a shipped map's name, a native map file or an original BW4T map file.
    #[arg(long, default_value = "default")]
    map: String,
    /// Match seed; a random one is chosen and printed when omitted.
    #[arg(long)]
    seed: Option<u64>,
    /// Robots in the match (default 3, or one per --agent).
    #[arg(long)]
    robots: Option<usize>,
    /// The built-in team filling the seats no --agent takes: `builtin` or `builtin:STRATEGY`
    /// (coop, silent, ignoring, baseline, random).
    #[arg(long)]
    team: Option<String>,
    /// An agent program, run with `sh -c`; repeat for more. One --agent with --robots N and
    /// no --team starts N copies. Each gets BW4T_HOST, BW4T_PORT, BW4T_NAME, BW4T_TOKEN.
    #[arg(long = "agent", value_name = "COMMAND")]
    agents: Vec<String>,
    /// End the match after this many ticks (default: derived from the map, at least 20000;
    /// see docs/PLAYING.md, "Tick limits").
    #[arg(long)]
    max_ticks: Option<u64>,
    /// Milliseconds an external agent has to answer each tick (0: forever).
    #[arg(long, default_value_t = 1000)]
    deadline_ms: u64,
    /// Seconds external agents have to connect.
    #[arg(long, default_value_t = 10)]
    connect_timeout_s: u64,
    /// With external agents: end the match as `interrupted` after this many seconds of
    /// wall time (for agents that think slowly, such as language models; 0: no limit).
    #[arg(long, default_value_t = 0)]
    wall_budget_s: u64,
    /// Print the result as JSON instead of the summary.
    #[arg(long)]
    json: bool,
    /// Also write the result as JSON to this file.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write a replay (JSON lines) to this file.
    #[arg(long)]
    replay: Option<PathBuf>,
    /// Directory for external agents' logs (default: a new one under the system's temp dir).
    #[arg(long)]
    log_dir: Option<PathBuf>,
}

/// Runs one match and reports it; returns the exit status (see `status`).
pub(crate) fn run(args: &RunArgs) -> Result<u8> {
    let map = crate::maps::load(&args.map)?;
    let seed = args.seed.unwrap_or_else(crate::random_seed);
    let seats = seats(args)?;
    if seats.len() > map.spawns().len() {
        bail!(
            "{} but map '{}' has {}",
            plural(seats.len(), "robot"),
            map.name(),
            plural(map.spawns().len(), "spawn point")
        );
    }
    if seats.is_empty() {
        bail!("a match needs at least one robot");
    }
    for seat in &seats {
        if let Player::Program(command) = &seat.player {
            if let Err(e) = check_command(command) {
                bail!("--agent '{command}' cannot start: {e}");
            }
        }
    }
    let limit = Limit::of(args.max_ticks, &map);
    if !args.json {
        eprintln!(
            "bw4t: map '{}', seed {seed} (rerun with --seed {seed}), {}, tick limit {}",
            map.name(),
            plural(seats.len(), "robot"),
            limit.ticks
        );
    }
    let replay = crate::runs::replay_writer(args.replay.as_deref())?;
    let external = seats.iter().any(|s| matches!(s.player, Player::Program(_)));
    let setup = MatchSetup { seed, seats, max_ticks: Some(limit.ticks), ..MatchSetup::new(map) };
    let mut out_of_time = false;
    let (result, agents) = if external {
        let log_dir = args
            .log_dir
            .clone()
            .unwrap_or_else(|| std::env::temp_dir().join(format!("bw4t-run-{}-{seed}", std::process::id())));
        let served = play_served(ServedRun {
            setup,
            deadline: (args.deadline_ms > 0).then(|| Duration::from_millis(args.deadline_ms)),
            connect_timeout: Duration::from_secs(args.connect_timeout_s),
            log_dir: &log_dir,
            replay,
            stop: None,
            wall_budget: (args.wall_budget_s > 0).then(|| Duration::from_secs(args.wall_budget_s)),
            language: bw4t_protocol::MessagePolicy::default(),
        })?;
        out_of_time = served.out_of_time;
        (served.result, served.agents)
    } else {
        play(&setup, replay)?
    };
    let mut json = serde_json::to_value(&result)?;
    json["agents"] = serde_json::to_value(&agents)?;
    json["max_ticks"] = limit.ticks.into();
    json["max_ticks_from"] = limit.from.into();
    if out_of_time {
        json["out_of_time"] = true.into();
        eprintln!("bw4t: the match used up its wall-time budget of {} s and was ended", args.wall_budget_s);
    }
    if let Some(path) = &args.out {
        let text = serde_json::to_string_pretty(&json)? + "\n";
        std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))?;
    }
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&json)?);
    } else {
        out!("{}", summary(&result, &agents, &limit));
    }
    Ok(exit_status(&result, &agents))
}

/// The tick limit of a run and where it came from.
struct Limit {
    ticks: u64,
    /// `option` (given with --max-ticks) or `map` (derived from the map).
    from: &'static str,
    /// How it was found, for the summary.
    explanation: String,
}

impl Limit {
    fn of(given: Option<u64>, map: &bw4t_map::Map) -> Limit {
        match given {
            Some(ticks) => Limit { ticks, from: "option", explanation: "given with --max-ticks".into() },
            None => {
                let derived = TickLimit::for_map(map, &MatchConfig::default());
                Limit { ticks: derived.ticks, from: "map", explanation: derived.explain() }
            }
        }
    }
}

/// 0 completed; 4 when external agents were given and none of them played; 3 otherwise.
fn exit_status(result: &MatchResult, agents: &[AgentReport]) -> u8 {
    let external: Vec<&AgentReport> = agents.iter().filter(|a| a.kind == "external").collect();
    if !external.is_empty() && external.iter().all(|a| a.status != "ok") {
        status::NO_AGENT_PLAYED
    } else if result.completed {
        status::SUCCESS
    } else {
        status::NOT_COMPLETED
    }
}

/// The seats a run's options describe: external agents first, the built-in team after.
fn seats(args: &RunArgs) -> Result<Vec<Seat>> {
    let strategy = match args.team.as_deref() {
        None | Some("builtin") => Strategy::Cooperative,
        Some(team) => {
            let name = team
                .strip_prefix("builtin:")
                .with_context(|| format!("--team '{team}': expected builtin or builtin:STRATEGY"))?;
            let names: Vec<&str> = Strategy::ALL.iter().map(|s| s.name()).collect();
            Strategy::named(name)
                .with_context(|| format!("unknown strategy '{name}' (known: {})", names.join(", ")))?
        }
    };
    let commands: Vec<String> = if args.agents.len() == 1 && args.team.is_none() {
        vec![args.agents[0].clone(); args.robots.unwrap_or(1)]
    } else {
        args.agents.clone()
    };
    let total = args.robots.unwrap_or(if args.agents.is_empty() { 3 } else { commands.len() });
    if commands.len() > total {
        bail!("{} but --robots {total}", plural(commands.len(), "agent command"));
    }
    let builtins = total - commands.len();
    let players = commands.into_iter().map(Player::Program);
    Ok(named_seats(players.chain(std::iter::repeat_n(Player::Builtin(strategy), builtins))))
}

/// The readable report of a match.
fn summary(r: &MatchResult, agents: &[AgentReport], limit: &Limit) -> String {
    let mut out = String::new();
    let outcome = match r.end_reason {
        EndReason::Completed => "completed".to_string(),
        EndReason::MaxTicks => "NOT completed: the tick limit was reached".to_string(),
        other => format!("NOT completed: {other}"),
    };
    let at = r.completed_tick.unwrap_or(r.ticks);
    out += &format!(
        "{outcome} after {at} ticks ({:.1} s simulated, {} ms wall)\n",
        at as f64 * r.sim_seconds / r.ticks.max(1) as f64,
        r.wall_ms
    );
    out += &format!("tick limit {}: {}\n", limit.ticks, limit.explanation);
    let marked: Vec<String> = r
        .sequence
        .iter()
        .enumerate()
        .map(|(i, c)| if i < r.sequence_index as usize { format!("[{c}]") } else { c.clone() })
        .collect();
    out += &format!("sequence {}/{}: {}\n", r.sequence_index, r.sequence.len(), marked.join(" "));
    out += &format!("drops: {} good, {} wrong; messages: {}\n", r.good_drops, r.wrong_drops, r.messages);
    out += &format!(
        "{:<4} {:<10} {:>5} {:>6} {:>5} {:>6} {:>6} {:>9}  {}\n",
        "id", "name", "good", "wrong", "msgs", "idle", "rooms", "distance", "agent"
    );
    for robot in &r.per_robot {
        let agent = agents.iter().find(|a| a.name == robot.name);
        let agent = agent.map_or(String::new(), |a| format!("{} {} ({})", a.kind, a.status, a.detail));
        out += &format!(
            "{:<4} {:<10} {:>5} {:>6} {:>5} {:>6} {:>6} {:>9.1}  {agent}\n",
            robot.id,
            robot.name,
            robot.good_drops,
            robot.wrong_drops,
            robot.messages_sent,
            robot.idle_ticks,
            robot.rooms_entered,
            robot.distance
        );
    }
    for agent in agents.iter().filter_map(|a| a.log.as_ref().map(|l| (a, l))) {
        out += &format!("log of {}: {}\n", agent.0.name, agent.1.display());
    }
    out += &format!("digest {}\n", r.digest);
    out
}
