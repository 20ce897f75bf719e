//! `bw4t eval`: an agent on a tier of the named suite (`bw4t-suite`), scored against the
//! built-in team on the same tasks, as one leaderboard row.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bw4t_protocol::{AgentInfo, LeaderboardRow};
use bw4t_runner::tournament::{Options, Outcome as Played, run_tournament};
use bw4t_tournament::suite::{self, Outcome, Plays, Split, TIERS, Tier};
use bw4t_tournament::{ReplayPolicy, Resolved};
use clap::{Args, Subcommand};

use crate::runs::{default_out, shell_quote};
use crate::status;

/// Options of `bw4t eval`.
#[derive(Args)]
#[command(args_conflicts_with_subcommands = true)]
pub(crate) struct EvalArgs {
    #[command(subcommand)]
    command: Option<EvalCommand>,
    /// The tier to play (`bw4t eval tiers` lists them, easiest first).
    tier: Option<String>,
    /// Who plays the agent's robots: builtin:STRATEGY, or a command line started once per
    /// robot with BW4T_HOST, BW4T_PORT, BW4T_NAME and BW4T_TOKEN (a TCP client, a harness
    /// driving `bw4t mcp --served`, a Python policy on the client).
    #[arg(long)]
    agent: Option<String>,
    #[command(flatten)]
    split: SplitArgs,
    #[command(flatten)]
    meta: MetaArgs,
    /// An external agent's lockstep deadline per tick in milliseconds (0: forever; a
    /// language model needs 0 or a wall budget).
    #[arg(long, default_value_t = 1000)]
    deadline_ms: u64,
    /// Wall seconds a match with external agents may take before it ends unfinished.
    #[arg(long)]
    wall_budget_s: Option<u64>,
    /// Seconds external agents have to connect.
    #[arg(long, default_value_t = 10)]
    connect_timeout_s: u64,
    /// Matches played at once (default: the number of cores).
    #[arg(long)]
    concurrency: Option<usize>,
    /// Finish an evaluation in --out that was stopped (the matches played are kept).
    #[arg(long)]
    resume: bool,
}

/// The tier's half and how often each task is played.
#[derive(Args)]
struct SplitArgs {
    /// `dev` (for developing an agent) or `test` (held out: the numbers to report).
    #[arg(long, default_value = "dev", value_parser = parse_split)]
    split: Split,
    /// Times each task is played (pass^k needs k of them; a deterministic agent plays the
    /// same match each time).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    repetitions: u32,
}

/// What the row says about the agent and where it goes.
#[derive(Args)]
struct MetaArgs {
    /// The agent's name in the row (default: the --agent entry).
    #[arg(long)]
    name: Option<String>,
    /// The language model, for a model-driven agent.
    #[arg(long)]
    model: Option<String>,
    /// Who served the model.
    #[arg(long)]
    provider: Option<String>,
    /// The model's sampling temperature.
    #[arg(long)]
    temperature: Option<f64>,
    /// The harness between the model and `bw4t mcp`, with its version.
    #[arg(long)]
    harness: Option<String>,
    /// Output directory: the agent's matches (agent/), the built-in team's (reference/)
    /// and the row (row.json). Default: a new folder under runs/.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also append the row as a JSON line to this leaderboard file.
    #[arg(long)]
    leaderboard: Option<PathBuf>,
}

#[derive(Subcommand)]
enum EvalCommand {
    /// List the tiers, easiest first, with their tasks.
    Tiers {
        /// One JSON object per tier instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Print a tier's tasks as JSON lines (key, map, seed, repetition, seats, tick limit),
    /// for evaluators that play them themselves (`bw4t.eval` in Python), then `score`.
    Tasks {
        /// The tier.
        tier: String,
        #[command(flatten)]
        split: SplitArgs,
    },
    /// Score outcomes played elsewhere (JSON lines of key, completed, ticks, ...; see
    /// docs/EVAL.md) against the built-in team on the same tasks.
    Score {
        /// The tier.
        tier: String,
        /// The outcomes file.
        #[arg(long)]
        outcomes: PathBuf,
        /// What played them (as the row's `agent.command`), e.g. python:train_ppo.
        #[arg(long)]
        agent: String,
        #[command(flatten)]
        split: SplitArgs,
        #[command(flatten)]
        meta: Box<MetaArgs>,
    },
}

fn parse_split(text: &str) -> Result<Split, String> {
    text.parse()
}

pub(crate) fn run(args: &EvalArgs) -> Result<u8> {
    match &args.command {
        Some(EvalCommand::Tiers { json }) => return tiers(*json).map(|()| status::SUCCESS),
        Some(EvalCommand::Tasks { tier, split }) => {
            return tasks(suite::tier(tier).map_err(anyhow::Error::msg)?, split);
        }
        Some(EvalCommand::Score { tier, outcomes, agent, split, meta }) => {
            return score_file(suite::tier(tier).map_err(anyhow::Error::msg)?, outcomes, agent, split, meta);
        }
        None => {}
    }
    let Some(name) = &args.tier else {
        bail!("name a tier: bw4t eval TIER --agent AGENT (tiers: {})", tier_names());
    };
    let tier = suite::tier(name).map_err(anyhow::Error::msg)?;
    let Some(agent) = &args.agent else {
        bail!("--agent is required: builtin:STRATEGY or the command line of an agent program");
    };
    tier.admits(agent).map_err(anyhow::Error::msg)?;
    let split = args.split.split;
    let out = args.meta.out.clone().unwrap_or_else(|| default_out(&format!("eval-{}-{split}", tier.name)));
    let played = Playing {
        out: out.join("agent"),
        resume: args.resume,
        concurrency: args.concurrency,
        connect_timeout: Duration::from_secs(args.connect_timeout_s),
        announce: true,
    };
    let resolved =
        tier.tournament(split, agent, args.split.repetitions, args.deadline_ms, args.wall_budget_s);
    crate::tournament::check_agents(&resolved)?;
    let reference = reference(tier, split, &out)?;
    eprintln!("bw4t: {agent} on tier '{}' ({split}): {} matches", tier.name, resolved.plan().len());
    let (outcome, signal) = play(&resolved, &played)?;
    if outcome.stopped {
        let mut again = vec![
            crate::tournament::program_name(),
            "eval".into(),
            tier.name.into(),
            "--agent".into(),
            shell_quote(agent),
        ];
        again.extend([
            "--split".into(),
            split.name().into(),
            "--out".into(),
            shell_quote(&out.display().to_string()),
        ]);
        again.extend(["--repetitions".into(), args.split.repetitions.to_string(), "--resume".into()]);
        eprintln!("bw4t: stopped; to play the rest and score, run:\n  {}", again.join(" "));
        return Ok(status::SIGNAL_BASE + signal.unwrap_or(2));
    }
    let outcomes: Vec<Outcome> = outcome.rows.iter().map(Outcome::from).collect();
    let row = score(tier, &args.split, agent, &args.meta, &outcomes, &reference)?;
    finish(&row, &out, args.meta.leaderboard.as_deref())?;
    let external = resolved.teams.iter().any(|t| {
        bw4t_tournament::seats(t)
            .is_ok_and(|s| s.iter().any(|s| matches!(s.player, bw4t_agents::Player::Program(_))))
    });
    if external && row.crashed_matches == row.matches {
        eprintln!(
            "bw4t: error: the agent played in none of its matches (see the logs in {})",
            out.join("agent").join("logs").display()
        );
        return Ok(status::NO_AGENT_PLAYED);
    }
    Ok(status::SUCCESS)
}

fn tier_names() -> String {
    TIERS.iter().map(|t| t.name).collect::<Vec<_>>().join(", ")
}

/// `eval tiers`: the table the docs show.
fn tiers(json: bool) -> Result<()> {
    let mixes = |tier: &Tier, split: Split| {
        let mixes: Vec<String> = tier
            .teammates(split)
            .iter()
            .map(|mix| mix.iter().map(|s| s.name()).collect::<Vec<_>>().join("+"))
            .collect();
        if mixes.iter().all(String::is_empty) { "-".to_string() } else { mixes.join("; ") }
    };
    if !json {
        outln!(
            "{} v{}: {} seeds per map in dev, {} in test\n",
            suite::SUITE,
            suite::SUITE_VERSION,
            suite::DEV_SEEDS,
            suite::TEST_SEEDS
        );
        outln!(
            "| tier | maps | robots | agent plays | teammates (dev) | teammates (test) | messages | what it asks |"
        );
        outln!("|---|---|---|---|---|---|---|---|");
    }
    for tier in &TIERS {
        let plays = match tier.plays {
            Plays::One => "robot 1",
            Plays::All => "every robot",
        };
        if json {
            let line = serde_json::json!({
                "tier": tier.name, "maps": tier.maps, "robots": tier.robots, "agent_plays": plays,
                "teammates_dev": mixes(tier, Split::Dev), "teammates_test": mixes(tier, Split::Test),
                "messages": tier.messages, "about": tier.about,
                "tasks_dev": tier.tournament(Split::Dev, "agent", 1, 0, None).plan().len(),
                "tasks_test": tier.tournament(Split::Test, "agent", 1, 0, None).plan().len(),
            });
            outln!("{line}");
        } else {
            outln!(
                "| {} | {} | {} | {plays} | {} | {} | {} | {} |",
                tier.name,
                tier.maps.join(", "),
                tier.robots,
                mixes(tier, Split::Dev),
                mixes(tier, Split::Test),
                if tier.messages { "on" } else { "off" },
                tier.about
            );
        }
    }
    Ok(())
}

/// `eval tasks`: every match of the tier's split, with its seats and tick limit.
fn tasks(tier: &Tier, split: &SplitArgs) -> Result<u8> {
    let resolved = tier.tournament(split.split, "agent", split.repetitions, 0, None);
    let maps = load_maps(&resolved)?;
    let limits = bw4t_runner::tournament::setup(&resolved, &maps).tick_limits;
    for p in resolved.plan() {
        let team = &resolved.teams[p.team];
        let seats = match &team.agents {
            bw4t_tournament::Agents::PerRobot(list) => list.clone(),
            bw4t_tournament::Agents::Each(entry) => vec![entry.clone(); team.robots],
        };
        let line = serde_json::json!({
            "key": p.key, "team": team.name, "map": resolved.maps[p.map], "seed": p.seed,
            "repetition": p.repetition, "seats": seats, "max_ticks": limits[p.map].max_ticks,
            "messages": resolved.messages,
        });
        outln!("{line}");
    }
    Ok(status::SUCCESS)
}

/// `eval score`: outcomes played elsewhere.
fn score_file(tier: &Tier, path: &Path, agent: &str, split: &SplitArgs, meta: &MetaArgs) -> Result<u8> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let outcomes = text
        .lines()
        .enumerate()
        .filter(|(_, line)| !line.trim().is_empty())
        .map(|(i, line)| {
            serde_json::from_str::<Outcome>(line)
                .with_context(|| format!("{} line {}: not an outcome", path.display(), i + 1))
        })
        .collect::<Result<Vec<_>>>()?;
    let out = meta.out.clone().unwrap_or_else(|| default_out(&format!("eval-{}-{}", tier.name, split.split)));
    let reference = reference(tier, split.split, &out)?;
    let row = score(tier, split, agent, meta, &outcomes, &reference)?;
    finish(&row, &out, meta.leaderboard.as_deref())?;
    Ok(status::SUCCESS)
}

/// The built-in team's outcomes on the tier's split (played once into OUT/reference, or
/// read back from there).
fn reference(tier: &Tier, split: Split, out: &Path) -> Result<Vec<Outcome>> {
    let resolved = tier.tournament(split, &tier.reference_entry(), 1, 0, None);
    let playing = Playing {
        out: out.join("reference"),
        resume: true,
        concurrency: None,
        connect_timeout: Duration::from_secs(10),
        announce: false,
    };
    let (outcome, _) = play(&resolved, &playing)?;
    if outcome.stopped {
        bail!("stopped while playing the built-in team's matches");
    }
    Ok(outcome.rows.iter().map(Outcome::from).collect())
}

fn score(
    tier: &Tier,
    split: &SplitArgs,
    agent: &str,
    meta: &MetaArgs,
    outcomes: &[Outcome],
    reference: &[Outcome],
) -> Result<LeaderboardRow> {
    let info = AgentInfo {
        name: meta.name.clone().unwrap_or_else(|| agent.to_string()),
        command: agent.to_string(),
        model: meta.model.clone(),
        provider: meta.provider.clone(),
        temperature: meta.temperature,
        harness: meta.harness.clone(),
    };
    Ok(suite::score(
        tier,
        split.split,
        split.repetitions,
        info,
        env!("CARGO_PKG_VERSION"),
        outcomes,
        reference,
    )?)
}

/// Writes `row.json`, appends to the leaderboard, prints the row and a sentence.
fn finish(row: &LeaderboardRow, out: &Path, leaderboard: Option<&Path>) -> Result<()> {
    let line = serde_json::to_string(row)?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let path = out.join("row.json");
    std::fs::write(&path, format!("{line}\n")).with_context(|| format!("cannot write {}", path.display()))?;
    if let Some(board) = leaderboard {
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(board)
            .with_context(|| format!("cannot open leaderboard {}", board.display()))?;
        writeln!(file, "{line}").with_context(|| format!("cannot append to {}", board.display()))?;
    }
    let interval = row.score_interval.map_or(String::new(), |[lo, hi]| format!(" (95% CI {lo:.3}-{hi:.3})"));
    eprintln!(
        "bw4t: {} on {} ({}): score {:.3}{interval}, completed {}/{} matches; row in {}",
        row.agent.name,
        row.tier,
        row.split,
        row.score,
        (row.completion * f64::from(row.matches)).round(),
        row.matches,
        path.display()
    );
    outln!("{line}");
    Ok(())
}

/// Where and how one tournament of an evaluation is played.
struct Playing {
    out: PathBuf,
    resume: bool,
    concurrency: Option<usize>,
    connect_timeout: Duration,
    /// Show progress (the agent's matches; the built-in team's are quick and quiet).
    announce: bool,
}

fn load_maps(resolved: &Resolved) -> Result<Vec<bw4t_map::Map>> {
    resolved.maps.iter().map(|spec| crate::maps::load(spec)).collect()
}

/// Plays (or finishes) `resolved`; with the signal that stopped it, if one did.
fn play(resolved: &Resolved, how: &Playing) -> Result<(Played, Option<u8>)> {
    let maps = load_maps(resolved)?;
    let concurrency =
        how.concurrency.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let stop = Arc::new(AtomicBool::new(false));
    let signal = crate::signals::watch(stop.clone());
    let options = Options {
        out: how.out.clone(),
        concurrency,
        replays: ReplayPolicy::Failed,
        resume: how.resume || !how.out.join("matches.jsonl").exists(),
        shard: None,
        connect_timeout: how.connect_timeout,
        stop,
    };
    let terminal = std::io::stderr().is_terminal();
    let announce = how.announce;
    let mut show = |p: &bw4t_runner::tournament::Progress| {
        if announce {
            crate::tournament::progress(p, terminal);
        }
    };
    let outcome = run_tournament(resolved, &maps, &options, &mut show)?;
    if terminal && announce {
        eprintln!();
    }
    Ok((outcome, signal.number()))
}
