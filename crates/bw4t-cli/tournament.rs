//! `bw4t tournament`: many matches over teams, maps and seeds, with a statistical summary.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bw4t_runner::tournament::{
    Options, Progress, ReplayPolicy, Seeds, TeamConfig, TournamentConfig, merge, run_tournament,
};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;

/// Options of `bw4t tournament`.
#[derive(Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct TournamentArgs {
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
    /// The last tick of every match.
    #[arg(long)]
    max_ticks: Option<u64>,
    /// External agents' lockstep deadline in milliseconds (0: forever).
    #[arg(long)]
    deadline_ms: Option<u64>,
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
    /// Run only every n-th match, as i/n (1 <= i <= n), for spreading over machines.
    #[arg(long, value_parser = parse_shard)]
    shard: Option<(u64, u64)>,
    /// Seconds external agents have to connect.
    #[arg(long, default_value_t = 10)]
    connect_timeout_s: u64,
}

#[derive(Subcommand)]
enum TournamentCommand {
    /// Join the output directories of shards (or of separate runs of one configuration).
    Merge {
        /// The directories to join.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// The merged directory (default: a new folder under runs/).
        #[arg(short, long)]
        out: Option<PathBuf>,
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum KeepReplays {
    All,
    Failed,
    None,
}

fn parse_shard(text: &str) -> Result<(u64, u64), String> {
    let parsed =
        text.split_once('/').and_then(|(i, n)| Some((i.trim().parse().ok()?, n.trim().parse().ok()?)));
    match parsed {
        Some((i, n)) if n >= 1 && (1..=n).contains(&i) => Ok((i, n)),
        _ => Err(format!("'{text}' is not i/n with 1 <= i <= n (e.g. 1/4)")),
    }
}

/// Runs a tournament command.
pub fn run(args: &TournamentArgs) -> Result<()> {
    if let Some(TournamentCommand::Merge { dirs, out }) = &args.command {
        let out = out.clone().unwrap_or_else(|| default_out("merged"));
        let outcome = merge(dirs, &out)?;
        print!("{}", outcome.summary.terminal_table());
        println!("merged {} matches into {}", outcome.rows.len(), out.display());
        return Ok(());
    }
    let config = config(args)?;
    let resolved = config.resolve().context("invalid tournament configuration")?;
    let maps = resolved.maps.iter().map(|spec| crate::maps::load(spec)).collect::<Result<Vec<_>>>()?;
    for team in &resolved.teams {
        for (spec, map) in resolved.maps.iter().zip(&maps) {
            if team.robots > map.spawns().len() {
                bail!(
                    "team '{}' has {} robots but map '{spec}' has {} spawn points",
                    team.name,
                    team.robots,
                    map.spawns().len()
                );
            }
        }
    }
    let concurrency =
        args.concurrency.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let out = args.out.clone().unwrap_or_else(|| default_out("tournament"));
    let options = Options {
        out: out.clone(),
        concurrency,
        replays: match args.replays {
            KeepReplays::All => ReplayPolicy::All,
            KeepReplays::Failed => ReplayPolicy::Failed,
            KeepReplays::None => ReplayPolicy::None,
        },
        resume: args.resume,
        shard: args.shard,
        connect_timeout: Duration::from_secs(args.connect_timeout_s),
    };
    let manifest = json!({
        "program": bw4t_runner::program(),
        "created_unix": std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs()),
        "machine": machine(concurrency),
    });
    let terminal = std::io::stderr().is_terminal();
    let mut show = |p: &Progress| progress(p, terminal);
    let outcome = run_tournament(&resolved, &maps, manifest, &options, &mut show)?;
    if terminal {
        eprintln!();
    }
    print!("{}", outcome.summary.terminal_table());
    let json = outcome.summary.to_json();
    let per_min = json.get("matches_per_min").and_then(serde_json::Value::as_f64).unwrap_or(0.0);
    println!(
        "{} matches ({} played now, {} already done) in {}; matches_per_min {:.0}",
        outcome.rows.len(),
        outcome.played,
        outcome.skipped,
        out.display(),
        per_min
    );
    Ok(())
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
            max_ticks: 20_000,
            repetitions: 1,
            deadline_ms: 1000,
            teams: Vec::new(),
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
                Some((name, agents)) => {
                    Ok(TeamConfig { name: name.into(), agents: agents.into(), robots: args.robots })
                }
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
    if let Some(t) = args.max_ticks {
        config.max_ticks = t;
    }
    if let Some(d) = args.deadline_ms {
        config.deadline_ms = d;
    }
    if config.maps.is_empty() && config.teams.is_empty() && args.config.is_none() {
        bail!("give a configuration file, or --map and --team (see bw4t tournament --help)");
    }
    Ok(config)
}

fn default_out(what: &str) -> PathBuf {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    PathBuf::from("runs").join(format!("{what}-{secs}"))
}

fn machine(concurrency: usize) -> serde_json::Value {
    let host = std::fs::read_to_string("/etc/hostname").map(|h| h.trim().to_string()).unwrap_or_default();
    json!({
        "os": std::env::consts::OS,
        "arch": std::env::consts::ARCH,
        "cores": std::thread::available_parallelism().map_or(1, |n| n.get()),
        "concurrency": concurrency,
        "host": host,
    })
}

/// A progress bar on a terminal; a line per finished match otherwise.
fn progress(p: &Progress, terminal: bool) {
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
        let outcome =
            if row.completed { format!("completed in {} ticks", row.ticks) } else { row.end_reason.clone() };
        eprintln!(
            "[{}/{}] {} on {} seed {}: {outcome} ({} ms)",
            p.done, p.total, row.team, row.map, row.seed, row.wall_ms
        );
    } else {
        eprintln!("{} matches to play ({} already done)", p.to_play, p.done);
    }
}

fn clock(seconds: f64) -> String {
    let s = seconds.round() as u64;
    format!("{}:{:02}", s / 60, s % 60)
}
