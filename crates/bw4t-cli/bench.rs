//! `bw4t bench`: performance figures, one JSON object per line per case.

use std::time::Instant;

use anyhow::{Context, Result};
use bw4t_agents::MatchSetup;
use bw4t_sim::{Match, MatchConfig, Motion, PlayCounts, RandomPlay, RobotId};
use clap::{Args, ValueEnum};
use serde_json::json;

/// Options of `bw4t bench`.
#[derive(Args)]
pub(crate) struct BenchArgs {
    /// Cases to run (all but `arena` when none is given).
    #[arg(value_enum)]
    cases: Vec<Case>,
    /// Simulated ticks per `sim` measurement.
    #[arg(long, default_value_t = 200_000)]
    ticks: u64,
    /// Map to play on: a shipped map's name or a file path.
    #[arg(long, default_value = "default")]
    map: String,
    /// Seed for the map's content and the random players.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Ticks per `lockstep` measurement.
    #[arg(long, default_value_t = 5_000)]
    lockstep_ticks: u64,
    /// Ticks per `scale` measurement.
    #[arg(long, default_value_t = 5_000)]
    scale_ticks: u64,
    /// Matches played by the `match` case.
    #[arg(long, default_value_t = 200)]
    matches: u64,
    /// Steps of each environment per `env` vector measurement (a lone environment takes
    /// 20 times as many).
    #[arg(long, default_value_t = 200)]
    env_steps: u64,
    /// Rows the `merge` case merges.
    #[arg(long, default_value_t = 100_000)]
    merge_rows: u64,
    /// Shard directories the `merge` case's rows are in.
    #[arg(long, default_value_t = 10)]
    merge_shards: u64,
    /// Wall-clock seconds the `realtime` case measures for.
    #[arg(long, default_value_t = 5.0)]
    realtime_seconds: f64,
    /// How robots' moves reach the physics in the `sim`, `match` and `scale` cases:
    /// `stepped` is the reference motion that steps the whole world every tick.
    #[arg(long, value_enum, default_value_t = MotionArg::Kinematic)]
    motion: MotionArg,
    #[command(flatten)]
    arena: crate::bench_arena::ArenaArgs,
}

/// [`Motion`] on the command line.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum MotionArg {
    Kinematic,
    Stepped,
}

impl BenchArgs {
    /// The match configuration of the `sim`, `match` and `scale` cases.
    fn config(&self) -> MatchConfig {
        let motion = match self.motion {
            MotionArg::Kinematic => Motion::Kinematic,
            MotionArg::Stepped => Motion::Stepped,
        };
        MatchConfig { motion, ..MatchConfig::default() }
    }

    /// The motion's name in figures.
    fn motion_name(&self) -> String {
        self.motion.to_possible_value().map(|v| v.get_name().to_string()).unwrap_or_default()
    }
}

/// A benchmark case.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Case {
    /// Simulated ticks per second with 3 and with 10 robots kept moving by random orders,
    /// pick-ups and put-downs, every robot's percepts polled every tick. One thread.
    Sim,
    /// Lockstep ticks per second with 1, 3 and 10 players on real loopback sockets, each
    /// answering `ready` at once with a message every tick (so no tick is skipped), and
    /// the median time from one tick's percepts to the next tick's.
    Lockstep,
    /// CPU use of a `bw4t serve` process with 100 connected robots at 20 ticks/s.
    Realtime,
    /// Whole default-map matches played headless by the built-in team of 3, one thread.
    Match,
    /// Generated maps with many robots kept moving, every robot polled every tick: 100
    /// robots on 10 x 10 rooms, and 10, 30 and 100 on the largest map `bw4t map generate`
    /// makes. One thread.
    Scale,
    /// The learning environments (`bw4t-env`): learner steps per second of one environment
    /// (3 learners, at 10 and at 1 tick a step; 1 learner among 2 built-in teammates) and of
    /// vectors of 64 and 256 environments of 3 learners on 1 and 2 threads (and 256 on 2 at
    /// 1 tick a step), every learner taking a random allowed action, and the resident memory
    /// per environment.
    Env,
    /// `tournament merge` of `--merge-rows` made-up rows (100,000) in `--merge-shards`
    /// shard directories (10): the configuration checks, the missing and doubled matches,
    /// and the merged files written.
    Merge,
    /// Many matches in one arena server: realtime matches of 3 TCP players (tick lateness,
    /// CPU, memory and descriptors per match), lockstep matches of built-in agents on 1 and
    /// 2 worker threads, and a churn soak (`--soak-seconds`, 10 minutes by default).
    Arena,
}

/// Runs the chosen cases and prints their figures.
pub(crate) fn run(args: &BenchArgs) -> Result<()> {
    // `arena` runs for many minutes: only when asked for.
    let cases = if args.cases.is_empty() {
        Case::value_variants().iter().copied().filter(|c| *c != Case::Arena).collect()
    } else {
        args.cases.clone()
    };
    for case in cases {
        match case {
            Case::Sim => {
                for robots in [3, 10] {
                    outln!("{}", sim(args, robots)?);
                }
            }
            Case::Lockstep => {
                for players in [1, 3, 10] {
                    outln!(
                        "{}",
                        crate::bench_net::lockstep(&args.map, args.seed, players, args.lockstep_ticks)?
                    );
                }
            }
            Case::Realtime => {
                outln!("{}", crate::bench_net::realtime(args.seed, 100, args.realtime_seconds)?)
            }
            Case::Match => outln!("{}", matches(args)?),
            Case::Scale => {
                for (rows, cols, robots) in SCALE_CASES {
                    outln!("{}", scale(args, rows, cols, robots)?);
                }
            }
            Case::Env => env(args)?,
            Case::Merge => outln!("{}", crate::bench_merge::run(args.merge_rows, args.merge_shards.max(1))?),
            Case::Arena => crate::bench_arena::run(&args.arena, &args.map, args.seed)?,
        }
    }
    Ok(())
}

/// Ticks per match in the `sim` case: long enough to matter, short enough that the blocks
/// (which deliveries and drops in halls use up) never run out.
const SIM_EPISODE: u64 = 5_000;

fn sim(args: &BenchArgs, n_robots: usize) -> Result<serde_json::Value> {
    let map = crate::maps::load(&args.map)?;
    let mut totals = PlayCounts::default();
    let (mut facts, mut good, mut wrong, mut done, mut episode) = (0usize, 0, 0, 0u64, 0u64);
    let started = Instant::now();
    while done < args.ticks {
        let seed = args.seed.wrapping_add(episode);
        let mut game = Match::new(&map, &args.config(), seed).context("cannot create the match")?;
        let robots: Vec<RobotId> = (0..n_robots)
            .map(|i| game.join(&format!("Bot{}", i + 1)))
            .collect::<Result<_, _>>()
            .context("the map has too few spawn points")?;
        let mut play = RandomPlay::new(seed);
        let ticks = SIM_EPISODE.min(args.ticks - done);
        for _ in 0..ticks {
            play.act(&mut game);
            game.step();
            for &r in &robots {
                if let Some(delta) = game.poll_percepts(r) {
                    facts += delta.add.len() + delta.not.len();
                }
            }
        }
        let counts = play.accepted();
        totals.moves += counts.moves;
        totals.pick_ups += counts.pick_ups;
        totals.put_downs += counts.put_downs;
        totals.messages += counts.messages;
        good += game.stats().good_drops;
        wrong += game.stats().wrong_drops;
        done += ticks;
        episode += 1;
    }
    let seconds = started.elapsed().as_secs_f64();
    Ok(json!({
        "case": "sim",
        "map": map.name(),
        "motion": args.motion_name(),
        "robots": n_robots,
        "ticks": args.ticks,
        "ticks_per_s": (args.ticks as f64 / seconds).round(),
        "matches": episode,
        "moves": totals.moves,
        "pick_ups": totals.pick_ups,
        "put_downs": totals.put_downs,
        "messages": totals.messages,
        "percepts": facts,
        "good_drops": good,
        "wrong_drops": wrong,
    }))
}

fn matches(args: &BenchArgs) -> Result<serde_json::Value> {
    let map = crate::maps::load(&args.map)?;
    let mut setup = MatchSetup::builtin_team(map, 3, bw4t_agents::Strategy::Cooperative);
    setup.max_ticks = Some(20_000);
    setup.game = args.config();
    let mut ticks = Vec::new();
    let mut completed = 0;
    let started = Instant::now();
    for i in 0..args.matches {
        setup.seed = args.seed.wrapping_add(i);
        let (game, reason) = bw4t_runner::play_headless(&setup, None)?;
        completed += u64::from(reason == bw4t_protocol::EndReason::Completed);
        ticks.push(game.tick());
    }
    let seconds = started.elapsed().as_secs_f64();
    ticks.sort_unstable();
    Ok(json!({
        "case": "match",
        "map": setup.map.name(),
        "motion": args.motion_name(),
        "robots": 3,
        "matches": args.matches,
        "completed": completed,
        "matches_per_s": (args.matches as f64 / seconds * 10.0).round() / 10.0,
        "median_ticks": ticks.get(ticks.len() / 2).copied().unwrap_or(0),
    }))
}

/// The `scale` case's maps (rows x columns of rooms) and robot counts.
const SCALE_CASES: [(usize, usize, usize); 4] = [
    (10, 10, 100),
    (bw4t_map::MAX_ROWS, bw4t_map::MAX_COLUMNS, 10),
    (bw4t_map::MAX_ROWS, bw4t_map::MAX_COLUMNS, 30),
    (bw4t_map::MAX_ROWS, bw4t_map::MAX_COLUMNS, 100),
];

fn scale(args: &BenchArgs, rows: usize, cols: usize, robots: usize) -> Result<serde_json::Value> {
    let map = bw4t_map::generate(cols, rows, robots, args.seed)?;
    let mut game = Match::new(&map, &args.config(), args.seed).context("cannot create the match")?;
    let ids: Vec<RobotId> = (0..robots)
        .map(|i| game.join(&format!("Bot{}", i + 1)))
        .collect::<Result<_, _>>()
        .context("joining")?;
    let mut play = RandomPlay::new(args.seed);
    let started = Instant::now();
    for _ in 0..args.scale_ticks {
        play.act(&mut game);
        game.step();
        for &r in &ids {
            game.poll_percepts(r);
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    let per_tick_ms = seconds * 1000.0 / args.scale_ticks as f64;
    Ok(json!({
        "case": "scale",
        "map": map.name(),
        "motion": args.motion_name(),
        "rooms": rows * cols,
        "robots": robots,
        "ticks": args.scale_ticks,
        "ticks_per_s": (args.scale_ticks as f64 / seconds).round(),
        "ms_per_tick": (per_tick_ms * 1000.0).round() / 1000.0,
        // Share of one core a match at 20 ticks/s would use: 20 ticks' time per second.
        "core_percent_at_20_hz": (per_tick_ms * 20.0 / 1000.0 * 100.0 * 100.0).round() / 100.0,
        "moves": play.accepted().moves,
    }))
}

/// The `env` case: one JSON line per measurement.
fn env(args: &BenchArgs) -> Result<()> {
    use bw4t_env::{EnvConfig, Figures};
    let map = crate::maps::load(&args.map)?;
    let line = |setting: &str, config: &EnvConfig, f: &Figures| {
        json!({
            "case": "env",
            "setting": setting,
            "map": map.name(),
            "envs": f.envs,
            "threads": f.threads,
            "agents": f.agents,
            "steps": f.steps,
            "agent_steps": f.agent_steps,
            "episodes_ended": f.episodes_ended,
            "agent_steps_per_s": f.agent_steps_per_s().round(),
            "ticks_per_step": config.ticks_per_step,
        })
    };
    let parallel = EnvConfig::parallel(map.clone(), 3);
    outln!("{}", env_memory(&parallel, args.seed)?);
    let single = EnvConfig::single(map.clone(), 2, bw4t_agents::Strategy::Cooperative);
    let one_tick = EnvConfig { ticks_per_step: 1, ..parallel.clone() };
    let steps = args.env_steps * 20;
    for config in [&parallel, &one_tick] {
        outln!("{}", line("parallel", config, &bw4t_env::bench_single(config.clone(), steps, args.seed)?));
    }
    outln!(
        "{}",
        line("single_among_coop", &single, &bw4t_env::bench_single(single.clone(), steps, args.seed)?)
    );
    for (envs, threads, config) in [
        (64, 1, &parallel),
        (64, 2, &parallel),
        (256, 1, &parallel),
        (256, 2, &parallel),
        (256, 2, &one_tick),
    ] {
        let figures = bw4t_env::bench_vector(config.clone(), envs, threads, args.env_steps, args.seed)?;
        outln!("{}", line("parallel", config, &figures));
    }
    Ok(())
}

/// Resident memory per environment: a vector of 256 environments of `config`, reset and
/// stepped 20 times, measured while it is alive.
fn env_memory(config: &bw4t_env::EnvConfig, seed: u64) -> Result<serde_json::Value> {
    let envs = 256;
    let before = resident_kb()?;
    let mut vec_env = bw4t_env::VecEnv::new(config.clone(), envs, seed, 1)?;
    let n = vec_env.spaces().n_actions();
    let mut buffers = bw4t_env::VecBuffers::for_vec(&vec_env);
    buffers.reset(&mut vec_env)?;
    // Every learner heads for the last place: robots move, percepts flow.
    let actions = vec![n as u32 - 1; envs * vec_env.agents()];
    for _ in 0..20 {
        buffers.step(&mut vec_env, &actions)?;
    }
    let after = resident_kb()?;
    Ok(json!({
        "case": "env_memory",
        "envs": envs,
        "agents": vec_env.agents(),
        "kb_per_env": (after.saturating_sub(before) as f64 / envs as f64).round(),
        "obs_len": vec_env.spaces().obs_len(),
        "n_actions": n,
    }))
}

/// This process's resident memory in kB (`VmRSS` of `/proc/self/status`).
fn resident_kb() -> Result<u64> {
    let status = std::fs::read_to_string("/proc/self/status").context("reading /proc/self/status")?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .context("no VmRSS in /proc/self/status")
}
