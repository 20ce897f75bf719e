//! `bw4t tournament`: many matches over teams, maps and seeds, with a statistical summary.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bw4t_protocol::EndReason;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use bw4t_agents::Player;
use bw4t_runner::tournament::{self, Options, Progress, merge, run_tournament};
use bw4t_runner::{check_command, plural};
use bw4t_tournament::{
    Agents, ReplayPolicy, Resolved, Row, Seeds, Setup, Shard, TeamConfig, TournamentConfig, seats,
};
use clap::{Args, Subcommand, ValueEnum};

use crate::runs::{default_out, shell_quote};
use crate::status;

/// Options of `bw4t tournament`.
#[derive(Args)]
#[command(args_conflicts_with_subcommands = true)]
pub(crate) struct TournamentArgs {
    #[command(subcommand)]
    command: Option<TournamentCommand>,
    /// The tournament configuration (TOML); flags below override or replace it.
    config: Option<PathBuf>,
    /// A map (shipped name or path); repeat for more. Replaces the config's maps.
    #[arg(long = "map", value_name = "MAP")]
    maps: Vec<String>,
    /// A team as NAME=AGENTS, AGENTS being builtin, builtin:STRATEGY or a command line;
    /// repeat for more. Replaces the config's teams.
    #[arg(long = "team", value_name = "NAME=AGENTS")]
    teams: Vec<String>,
    /// Robots per team given with --team.
    #[arg(long, default_value_t = 3)]
    robots: usize,
    /// Seeds per team and map, derived from the master seed.
    #[arg(long)]
    seeds: Option<u64>,
    /// The master seed the match seeds are derived from.
    #[arg(long)]
    master_seed: Option<u64>,
    /// Times every (team, map, seed) is played.
    #[arg(long)]
    repetitions: Option<u32>,
    /// The last tick of every match (default: each map's own, at least 20000; docs/PLAYING.md).
    #[arg(long)]
    max_ticks: Option<u64>,
    /// External agents' lockstep deadline in milliseconds (0: forever).
    #[arg(long)]
    deadline_ms: Option<u64>,
    /// Wall seconds a match with external agents may take before it is ended (its row
    /// says out_of_time); none by default.
    #[arg(long)]
    wall_budget_s: Option<u64>,
    /// Matches played at once (default: the number of cores).
    #[arg(long)]
    concurrency: Option<usize>,
    /// Output directory (default: a new folder under runs/).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Which replays to keep.
    #[arg(long, value_enum, default_value_t = KeepReplays::Failed)]
    replays: KeepReplays,
    /// Skip the matches already in the output directory's matches.jsonl.
    #[arg(long)]
    resume: bool,
    /// Run only every n-th match, as i/n (1 <= i <= n), for spreading over machines; or
    /// `auto`: the task's share of a Slurm job array or a Kubernetes Indexed Job (from
    /// their variables), written to OUT/shard-I-of-N, which `merge OUT` finds.
    #[arg(long, value_parser = parse_shard, value_name = "i/n|auto")]
    shard: Option<ShardArg>,
    /// Seconds external agents have to connect.
    #[arg(long, default_value_t = CONNECT_TIMEOUT_S)]
    connect_timeout_s: u64,
}

#[derive(Subcommand)]
enum TournamentCommand {
    /// Join the output directories of shards (or of separate runs of one configuration):
    /// a directory without a manifest stands for its shard-I-of-N subdirectories. The
    /// configurations must be the same (by hash); missing and duplicated matches are named.
    #[command(after_help = status::MERGE_HELP)]
    Merge {
        /// The directories to join.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// The merged directory (default: a new folder under runs/).
        #[arg(short, long)]
        out: Option<PathBuf>,
        /// Then play the matches no directory has, into the merged one.
        #[arg(long)]
        play_missing: bool,
    },
    /// Play what a tournament directory still lacks, from the configuration its manifest
    /// records (no configuration file needed): an interrupted run, or a merge with
    /// missing matches.
    Resume {
        /// The tournament directory.
        dir: PathBuf,
        /// Matches played at once (default: the number of cores).
        #[arg(long)]
        concurrency: Option<usize>,
    },
    /// Write a Slurm job array for a tournament (one shard per task, then a merge job
    /// that waits for them) and say how to submit it.
    Slurm(crate::cluster::SlurmArgs),
    /// Write a Kubernetes Indexed Job for a tournament (one shard per completion index),
    /// a merge Job and the ConfigMap of its configuration, and say how to run them.
    K8s(crate::cluster::K8sArgs),
    /// Summarise the rows of a `matches.jsonl` (a tournament's, or the index of a
    /// server's results, `bw4t serve --results-dir`): completion rates, ticks, ranking.
    Summary {
        /// The file, or the directory that holds it.
        path: PathBuf,
        /// Also print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum KeepReplays {
    All,
    Failed,
    None,
}

/// Seconds external agents have to connect, unless `--connect-timeout-s` says otherwise.
const CONNECT_TIMEOUT_S: u64 = 10;

/// `--shard`: a fixed share, or the job array's.
#[derive(Clone, Copy)]
enum ShardArg {
    Fixed(Shard),
    Auto,
}

fn parse_shard(text: &str) -> Result<ShardArg, String> {
    match text {
        "auto" => Ok(ShardArg::Auto),
        _ => text.parse().map(ShardArg::Fixed).map_err(|e| format!("{e}, or auto")),
    }
}

/// Runs a tournament command; returns the exit status (see `status`).
pub(crate) fn run(args: &TournamentArgs) -> Result<u8> {
    match &args.command {
        Some(TournamentCommand::Merge { dirs, out, play_missing }) => {
            return merge_command(dirs, out.as_deref(), *play_missing);
        }
        Some(TournamentCommand::Resume { dir, concurrency }) => return resume(dir, *concurrency),
        Some(TournamentCommand::Slurm(cluster)) => {
            return crate::cluster::slurm(cluster).map(|()| status::SUCCESS);
        }
        Some(TournamentCommand::K8s(cluster)) => {
            return crate::cluster::k8s(cluster).map(|()| status::SUCCESS);
        }
        Some(TournamentCommand::Summary { path, json }) => return summary(path, *json),
        None => {}
    }
    let config = config(args)?;
    let resolved = config.resolve().context("invalid tournament configuration")?;
    let (shard, out) = match args.shard {
        Some(ShardArg::Auto) => {
            let auto = bw4t_tournament::shard_from_env(|name| std::env::var(name).ok())
                .map_err(anyhow::Error::msg)?;
            let Some(out) = &args.out else {
                bail!(
                    "--shard auto needs --out DIR: every task writes under it (DIR/{}), where merge finds them",
                    auto.shard.dir_name()
                );
            };
            eprintln!("bw4t: shard {} of this job array (from {})", auto.shard, auto.from);
            (Some(auto.shard), out.join(auto.shard.dir_name()))
        }
        Some(ShardArg::Fixed(shard)) => {
            (Some(shard), args.out.clone().unwrap_or_else(|| default_out("tournament")))
        }
        None => (None, args.out.clone().unwrap_or_else(|| default_out("tournament"))),
    };
    let replays = match args.replays {
        KeepReplays::All => ReplayPolicy::All,
        KeepReplays::Failed => ReplayPolicy::Failed,
        KeepReplays::None => ReplayPolicy::None,
    };
    let how = How {
        out,
        shard,
        resume: args.resume,
        replays,
        concurrency: args.concurrency,
        connect_timeout: Duration::from_secs(args.connect_timeout_s),
    };
    let resume_hint = |out: &Path| resume_command(args, out);
    play(&resolved, how, &resume_hint)
}

/// How to play a resolved tournament.
struct How {
    out: PathBuf,
    shard: Option<Shard>,
    resume: bool,
    replays: ReplayPolicy,
    concurrency: Option<usize>,
    connect_timeout: Duration,
}

/// Plays (or finishes) `resolved` into `how.out` and reports it; `resume_hint` is the
/// command that finishes it after a stop.
fn play(resolved: &Resolved, how: How, resume_hint: &dyn Fn(&Path) -> String) -> Result<u8> {
    check_agents(resolved)?;
    let maps = resolved.maps.iter().map(|spec| crate::maps::load(spec)).collect::<Result<Vec<_>>>()?;
    for team in &resolved.teams {
        for (spec, map) in resolved.maps.iter().zip(&maps) {
            if team.robots > map.spawns().len() {
                bail!(
                    "team '{}' has {} but map '{spec}' has {}",
                    team.name,
                    plural(team.robots, "robot"),
                    plural(map.spawns().len(), "spawn point")
                );
            }
        }
    }
    let setup = tournament::setup(resolved, &maps);
    describe_limits(&setup);
    if let Some(warning) = setup.fixed_content_warning() {
        eprintln!("bw4t: warning: {warning}");
    }
    let concurrency =
        how.concurrency.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let out = how.out;
    let stop = Arc::new(AtomicBool::new(false));
    let signal = crate::signals::watch(stop.clone());
    let options = Options {
        out: out.clone(),
        concurrency,
        replays: how.replays,
        resume: how.resume,
        shard: how.shard,
        connect_timeout: how.connect_timeout,
        stop,
    };
    let terminal = std::io::stderr().is_terminal();
    let mut show = |p: &Progress| progress(p, terminal);
    let outcome = run_tournament(resolved, &maps, &options, &mut show)?;
    if terminal {
        eprintln!();
    }
    out!("{}", outcome.summary.terminal_table());
    let json = outcome.summary.to_json();
    let per_min = json.get("matches_per_min").and_then(serde_json::Value::as_f64).unwrap_or(0.0);
    outln!(
        "{} ({} played now, {} already done) in {}; matches_per_min {:.0}",
        plural(outcome.rows.len(), "match"),
        outcome.played,
        outcome.skipped,
        out.display(),
        per_min
    );
    if outcome.stopped {
        let left = outcome.summary.matches;
        eprintln!(
            "bw4t: stopped with {} recorded; to play the rest, run:\n  {}",
            plural(left, "match"),
            resume_hint(&out)
        );
        return Ok(status::SIGNAL_BASE + signal.number().unwrap_or(2));
    }
    let silent = teams_without_play(resolved, &outcome.rows);
    if !silent.is_empty() {
        for (team, matches) in &silent {
            eprintln!(
                "bw4t: error: team '{team}': its agents played in none of its {} (see the logs in {})",
                plural(*matches, "match"),
                out.join("logs").display()
            );
        }
        return Ok(status::NO_AGENT_PLAYED);
    }
    Ok(status::SUCCESS)
}

/// `tournament merge`: joins, names what is missing or doubled, and plays the missing
/// matches when asked.
fn merge_command(dirs: &[PathBuf], out: Option<&Path>, play_missing: bool) -> Result<u8> {
    let out = out.map(Path::to_path_buf).unwrap_or_else(|| default_out("merged"));
    let started = std::time::Instant::now();
    let (outcome, report) = merge(dirs, &out)?;
    out!("{}", outcome.summary.terminal_table());
    outln!(
        "merged {} from {} (configuration {}) into {} in {:.2} s",
        plural(outcome.rows.len(), "match"),
        plural(report.sources.len(), "directory"),
        report.config_hash,
        out.display(),
        started.elapsed().as_secs_f64()
    );
    let some = |keys: &[String]| {
        let shown: Vec<&str> = keys.iter().take(5).map(String::as_str).collect();
        let more = keys.len().saturating_sub(shown.len());
        if more > 0 { format!("{} and {more} more", shown.join(", ")) } else { shown.join(", ") }
    };
    if !report.duplicates.is_empty() {
        eprintln!(
            "bw4t: {} played more than once, alike (one kept): {}",
            plural(report.duplicates.len(), "match"),
            some(&report.duplicates)
        );
    }
    if !report.conflicting.is_empty() {
        eprintln!(
            "bw4t: warning: {} played more than once with different results (the first kept): {}",
            plural(report.conflicting.len(), "match"),
            some(&report.conflicting)
        );
    }
    if !report.stray_replays.is_empty() {
        eprintln!(
            "bw4t: warning: {} name a replay outside their shard's replays/ (not copied): {}",
            plural(report.stray_replays.len(), "match"),
            some(&report.stray_replays)
        );
    }
    if report.missing.is_empty() {
        return Ok(status::SUCCESS);
    }
    eprintln!(
        "bw4t: {} of the configuration missing: {}",
        plural(report.missing.len(), "match"),
        some(&report.missing)
    );
    if play_missing {
        return resume(&out, None);
    }
    eprintln!(
        "bw4t: to play them: {} tournament resume {}",
        program_name(),
        shell_quote(&out.display().to_string())
    );
    Ok(status::MERGE_INCOMPLETE)
}

/// `tournament resume DIR`: plays what the directory lacks of its manifest's configuration.
fn resume(dir: &Path, concurrency: Option<usize>) -> Result<u8> {
    let manifest = tournament::read_manifest(dir)?;
    eprintln!("bw4t: resuming {} (configuration {})", dir.display(), manifest.config.config_hash());
    let how = How {
        out: dir.to_path_buf(),
        shard: manifest.shard,
        resume: true,
        replays: manifest.replays,
        concurrency,
        connect_timeout: Duration::from_secs(CONNECT_TIMEOUT_S),
    };
    let hint = |out: &Path| {
        format!("{} tournament resume {}", program_name(), shell_quote(&out.display().to_string()))
    };
    play(&manifest.config, how, &hint)
}

/// `tournament summary`.
fn summary(path: &Path, json: bool) -> Result<u8> {
    let file = if path.is_dir() { path.join("matches.jsonl") } else { path.to_path_buf() };
    let rows = tournament::read_rows(&file)?;
    if rows.is_empty() {
        bail!("{} holds no finished matches", file.display());
    }
    let summary = bw4t_tournament::summarize(&rows, 0.0);
    if json {
        outln!("{}", summary.to_json());
    } else {
        out!("{}", summary.terminal_table());
        outln!("{} in {}", plural(rows.len(), "match"), file.display());
    }
    Ok(status::SUCCESS)
}

/// How this program was started, for commands it prints (`bw4t` when unknown).
pub(crate) fn program_name() -> String {
    std::env::args().next().map(|p| shell_quote(&p)).unwrap_or_else(|| "bw4t".into())
}

/// Refuses, before anything runs, a team whose agent command cannot start: a misspelt
/// `builtin` is caught when the configuration resolves; here, a program that is not found.
pub(crate) fn check_agents(resolved: &Resolved) -> Result<()> {
    let mut problems = Vec::new();
    for team in &resolved.teams {
        let mut commands: Vec<String> = Vec::new();
        for seat in seats(team).map_err(anyhow::Error::msg)? {
            if let Player::Program(command) = seat.player {
                if !commands.contains(&command) {
                    if let Err(e) = check_command(&command) {
                        problems.push(format!("team '{}': agents \"{command}\": {e}", team.name));
                    }
                    commands.push(command);
                }
            }
        }
    }
    if problems.is_empty() { Ok(()) } else { bail!("{}", problems.join("\n")) }
}

/// Says on standard error what tick limits the matches run with.
fn describe_limits(setup: &Setup) {
    let limits: Vec<String> = setup
        .tick_limits
        .iter()
        .map(|l| match &l.explanation {
            Some(how) => format!("'{}' {} ({how})", l.map, l.max_ticks),
            None => format!("'{}' {} (from the configuration)", l.map, l.max_ticks),
        })
        .collect();
    eprintln!("bw4t: tick limits: {}", limits.join("; "));
}

/// Teams with external agents none of which played in any of the team's matches, with
/// their match counts.
fn teams_without_play(resolved: &Resolved, rows: &[Row]) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    for team in &resolved.teams {
        let external =
            seats(team).map_or(0, |s| s.iter().filter(|s| matches!(s.player, Player::Program(_))).count());
        let mine: Vec<&Row> = rows.iter().filter(|r| r.team == team.name).collect();
        let none_played =
            mine.iter().all(|r| r.crashed_agents as usize >= external || r.end_reason == EndReason::Error);
        if external > 0 && !mine.is_empty() && none_played {
            out.push((team.name.clone(), mine.len()));
        }
    }
    out
}

/// The command that finishes this tournament: the one given, with `--out` and `--resume`.
fn resume_command(args: &TournamentArgs, out: &Path) -> String {
    let mut words: Vec<String> = std::env::args().collect();
    if args.out.is_none() {
        words.extend(["--out".to_string(), out.display().to_string()]);
    }
    if !args.resume {
        words.push("--resume".into());
    }
    words.iter().map(|w| shell_quote(w)).collect::<Vec<_>>().join(" ")
}

/// The configuration file merged with the flags.
fn config(args: &TournamentArgs) -> Result<TournamentConfig> {
    let mut config = match &args.config {
        Some(path) => {
            let text =
                std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
            TournamentConfig::parse(&text)
                .with_context(|| format!("{} is not a valid tournament configuration", path.display()))?
        }
        None => TournamentConfig {
            maps: Vec::new(),
            seeds: None,
            master_seed: None,
            games: None,
            max_ticks: None,
            repetitions: 1,
            deadline_ms: 1000,
            wall_budget_s: None,
            teams: Vec::new(),
            messages: true,
        },
    };
    if !args.maps.is_empty() {
        config.maps = args.maps.clone();
    }
    if !args.teams.is_empty() {
        config.teams = args
            .teams
            .iter()
            .map(|t| match t.split_once('=') {
                Some((name, agents)) => Ok(TeamConfig {
                    name: name.into(),
                    agents: Agents::Each(agents.into()),
                    robots: Some(args.robots),
                }),
                None => bail!("--team '{t}': expected NAME=AGENTS, e.g. coop=builtin"),
            })
            .collect::<Result<_>>()?;
    }
    if let Some(n) = args.seeds {
        config.seeds = Some(Seeds::Count(n));
    }
    if args.master_seed.is_some() {
        config.master_seed = args.master_seed;
    }
    if let Some(r) = args.repetitions {
        config.repetitions = r;
    }
    if args.max_ticks.is_some() {
        config.max_ticks = args.max_ticks;
    }
    if let Some(d) = args.deadline_ms {
        config.deadline_ms = d;
    }
    if args.wall_budget_s.is_some() {
        config.wall_budget_s = args.wall_budget_s;
    }
    if config.maps.is_empty() && config.teams.is_empty() && args.config.is_none() {
        bail!("give a configuration file, or --map and --team (see bw4t tournament --help)");
    }
    Ok(config)
}

/// A progress bar on a terminal; a line per finished match otherwise.
pub(crate) fn progress(p: &Progress, terminal: bool) {
    let elapsed = p.elapsed.as_secs_f64();
    let eta = if p.played > 0 { elapsed / p.played as f64 * (p.to_play - p.played) as f64 } else { 0.0 };
    if terminal {
        let width = 30;
        let filled = (p.done * width).checked_div(p.total).unwrap_or(width).min(width);
        let bar: String = "#".repeat(filled) + &"-".repeat(width - filled);
        eprint!(
            "\r[{bar}] {}/{} matches, {} failed, {} elapsed, ETA {}   ",
            p.done,
            p.total,
            p.failures,
            clock(elapsed),
            clock(eta)
        );
        let _ = std::io::stderr().flush();
    } else if let Some(row) = &p.last {
        let outcome = match (&row.error, row.completed) {
            (Some(error), _) => format!("error: {error}"),
            (None, true) => format!("completed in {} ticks", row.ticks),
            (None, false) => row.end_reason.to_string(),
        };
        eprintln!(
            "[{}/{}] {} on {} seed {}: {outcome} ({} ms)",
            p.done, p.total, row.team, row.map, row.seed, row.wall_ms
        );
    } else {
        eprintln!("{} to play ({} already done)", plural(p.to_play, "match"), p.done);
    }
}

fn clock(seconds: f64) -> String {
    let s = seconds.round() as u64;
    format!("{}:{:02}", s / 60, s % 60)
}
