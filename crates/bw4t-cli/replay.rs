//! `bw4t replay`: check a replay by re-simulating it, summarise it, serve the page on it,
//! or export its trajectories (`trajectories.rs`).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use anyhow::{Context, Result};
use bw4t_protocol::EndReason;
use bw4t_runner::{ReplayFrames, ReplaySummary, Verdict, verify_replay};
use clap::{Args, Subcommand};

use crate::status::{self, REPLAY_DIFFERS, REPLAY_INCOMPLETE};

/// The exit statuses of `bw4t replay verify`, for its `--help`.
const VERIFY_EXIT_STATUS: &str = "Exit status:
  0  ok: the replay is complete and every digest matches
  1  the file cannot be read or is not a valid replay (the error names the line)
  2  bad command line
  3  the re-simulation differs (the error names the first tick)
  4  incomplete: no end record (its writer was stopped, or the file cut); everything up to
     its last tick matches";

/// Options of `bw4t replay`.
#[derive(Args)]
pub(crate) struct ReplayArgs {
    #[command(subcommand)]
    command: ReplayCommand,
}

#[derive(Subcommand)]
enum ReplayCommand {
    /// Re-simulate and report the first tick whose state differs, that all match, or that
    /// the replay is incomplete.
    #[command(after_help = VERIFY_EXIT_STATUS)]
    Verify {
        /// The replay file.
        file: PathBuf,
    },
    /// Print what the replay holds (exits 0 whenever it can read the replay).
    Show {
        /// The replay file.
        file: PathBuf,
    },
    /// Serve the browser page on a replay: play, pause, speed, scrub to any tick. A replay
    /// that differs is refused (exit status 3); an incomplete one is shown up to its end.
    View {
        /// The replay file.
        file: PathBuf,
        /// Port for the page; 0 picks a free one.
        #[arg(long, default_value_t = 12380)]
        http: u16,
        /// Address to listen on.
        #[arg(long, default_value = "127.0.0.1")]
        bind: std::net::IpAddr,
    },
    /// Re-simulate replays into each robot's trajectory for learners: per robot, JSON lines
    /// of what it was told (percepts and their plain-English words) and did (actions,
    /// messages sent and received), or (--format env) the single-learner environment's
    /// observations, masks, action indices, rewards and episode ends. A replay that does
    /// not verify is refused.
    #[command(after_help = TRAJECTORIES_HELP)]
    Trajectories(crate::trajectories::ReplayTrajectoriesArgs),
}

/// What `bw4t replay trajectories` writes, for its `--help`.
const TRAJECTORIES_HELP: &str =
    "Writes, per replay, OUT/STEM/ (STEM: the replay's file name without .jsonl) with
meta.json (the map, seed, labels such as a study trial's participant and condition, the
robots and their files; for env the spaces' layouts and rewards), map.toml, and per robot
NAME.jsonl (symbolic) or NAME.env.jsonl (env). Line shapes: protocol/schema/trajectory/.
In env, a step's action is the first action of the robot in the step that an index stands
for (moves and block actions before messages), else 0 (wait); each step says how many
actions were taken and left out. python -m bw4t.datasets (or bw4t.datasets.minari_dataset)
makes a Minari dataset of an env export.
Exit status: 0 written; 1 a replay that cannot be read, does not verify, or is incomplete
(without --incomplete), or a bad option; 2 a command line that cannot be read.";

/// Runs a replay command; its exit status says the verdict (`VERIFY_EXIT_STATUS`).
pub(crate) fn run(args: &ReplayArgs) -> Result<u8> {
    match &args.command {
        ReplayCommand::Verify { file } => {
            let (verdict, _) = verified(file)?;
            Ok(match verdict {
                Verdict::Matches { digests, ticks } => {
                    outln!("ok: all {digests} digests match ({ticks} ticks re-simulated)");
                    status::SUCCESS
                }
                Verdict::Incomplete { .. } => incomplete(&verdict),
                Verdict::Differs { .. } => differs(&verdict),
            })
        }
        ReplayCommand::Show { file } => {
            let (verdict, summary) = verified(file)?;
            show(&verdict, &summary);
            Ok(status::SUCCESS)
        }
        ReplayCommand::View { file, http, bind } => view(file, *bind, *http),
        ReplayCommand::Trajectories(args) => {
            crate::trajectories::run(args)?;
            Ok(status::SUCCESS)
        }
    }
}

/// Reads and re-simulates a replay file.
fn verified(file: &Path) -> Result<(Verdict, ReplaySummary)> {
    let text = std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    verify_replay(&text).with_context(|| format!("{} is not a usable replay", file.display()))
}

fn incomplete(verdict: &Verdict) -> u8 {
    outln!("{}", verdict.incomplete_report().unwrap_or_default());
    REPLAY_INCOMPLETE
}

fn differs(verdict: &Verdict) -> u8 {
    if let Verdict::Differs { tick, expected, found } = verdict {
        eprintln!(
            "bw4t: error: the replay differs at tick {tick}: recorded {expected}, re-simulated {found}"
        );
    }
    REPLAY_DIFFERS
}

fn show(verdict: &Verdict, summary: &ReplaySummary) {
    let h = &summary.header;
    outln!("{} (format {}), map '{}', seed {}", h.program, h.format, h.map, h.seed);
    outln!(
        "config: {} ticks/s, speed {}, robot collisions {}, tick limit {}",
        h.ticks_per_second,
        h.speed,
        if h.robot_collisions { "on" } else { "off" },
        h.max_ticks.map_or("none".to_string(), |m| m.to_string())
    );
    outln!("players: {}", summary.players.join(", "));
    outln!(
        "{} ticks, {} actions, end: {}",
        summary.game_ticks,
        summary.actions,
        summary.reason.map_or("(none recorded)", EndReason::as_str)
    );
    outln!("sequence {}/{}: {}", summary.sequence_index, summary.sequence.len(), summary.sequence.join(" "));
    match verdict {
        Verdict::Matches { digests, .. } => outln!("verified: all {digests} digests match"),
        Verdict::Incomplete { .. } => outln!("{}", verdict.incomplete_report().unwrap_or_default()),
        Verdict::Differs { tick, .. } => outln!("NOT verified: differs at tick {tick}"),
    }
}

/// Serves the page on a replay until interrupted, once it verifies.
fn view(file: &Path, bind: std::net::IpAddr, port: u16) -> Result<u8> {
    let text = std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    let usable = || format!("{} is not a usable replay", file.display());
    // The frames are re-simulated on demand; a replay that does not re-simulate as
    // recorded would show another match.
    let (verdict, _) = verify_replay(&text).with_context(usable)?;
    match verdict {
        Verdict::Differs { .. } => return Ok(differs(&verdict)),
        Verdict::Incomplete { .. } => {
            eprintln!("bw4t: {}; showing what there is", verdict.incomplete_report().unwrap_or_default())
        }
        Verdict::Matches { .. } => {}
    }
    let frames = ReplayFrames::open(&text).with_context(usable)?;
    drop(text);
    let header = frames.header().clone();
    let last = frames.last_tick();
    let messages: Vec<serde_json::Value> = frames
        .messages()
        .iter()
        .map(|m| serde_json::json!({"tick": m.tick, "from": m.message.from, "to": m.message.to, "text": m.message.text}))
        .collect();
    let info = serde_json::json!({
        "ticks": last,
        "complete": frames.complete(),
        "tick_hz": header.ticks_per_second,
        "map": header.map,
        "seed": header.seed,
        "players": header.robots,
        "messages": messages,
    });
    let map_json = serde_json::to_string(&bw4t_protocol::MapLayout::of(frames.map()))?;
    let frames = Mutex::new(frames);
    let source: bw4t_server::FrameSource = Arc::new(move |ask| {
        let mut frames = frames.lock().ok()?;
        match ask {
            bw4t_server::ReplayAsk::Frame(tick) => frames.frame_json(tick),
            bw4t_server::ReplayAsk::View { robot, tick } => frames.view_json(robot, tick),
        }
    });
    let site = bw4t_server::Site {
        map_json,
        info_json: serde_json::to_string(&bw4t_protocol::ServerInfo::Replay {
            protocol: bw4t_protocol::VERSION,
            map: header.map.clone(),
        })?,
        replay: Some((info.to_string(), source)),
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the runtime")?;
    runtime.block_on(async {
        let stop = crate::serving::stop_signal();
        let (listener, local) = crate::serving::listen(std::net::SocketAddr::new(bind, port))?;
        outln!("http on {local}");
        eprintln!(
            "bw4t: replay of map '{}', seed {}, {last} ticks; Ctrl-C (or SIGTERM) stops",
            header.map, header.seed
        );
        let site = std::sync::Arc::new(site);
        let served = tokio::spawn(bw4t_server::serve_site(listener, site, bw4t_server::MAX_REQUESTS));
        stop.await;
        served.abort();
        anyhow::Ok(())
    })?;
    Ok(status::SUCCESS)
}
