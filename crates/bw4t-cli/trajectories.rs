//! `bw4t replay trajectories` (and `bw4t study export --trajectories`): replays
//! re-simulated into each robot's trajectory, for learners (the files are described in
//! python/README.md, "Datasets", and protocol/schema/trajectory/).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use bw4t_runner::{TrajectoryKind, TrajectoryOptions, trajectories};
use clap::{Args, ValueEnum};

/// What `--format` takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum Format {
    /// NAME.jsonl per robot: per tick it was told something or acted, its percepts, the
    /// words a language model reads, its actions and the messages it sent and received.
    Symbolic,
    /// NAME.env.jsonl per robot: the single-learner environment's observation, mask,
    /// action index, reward and episode end, step by step (`bw4t.datasets` makes a Minari
    /// dataset of them).
    Env,
}

impl Format {
    pub(crate) fn kind(self) -> TrajectoryKind {
        match self {
            Format::Symbolic => TrajectoryKind::Symbolic,
            Format::Env => TrajectoryKind::Env,
        }
    }
}

/// How trajectories are made, shared by `replay trajectories` and `study export`.
#[derive(Args, Clone, Debug)]
pub(crate) struct TrajectoryFlags {
    /// Which files: per robot, symbolic lines or the environment's encoding.
    #[arg(long, value_enum, default_value_t = Format::Symbolic)]
    pub(crate) format: Format,
    /// `env`: simulated ticks per step, as the environment's `ticks_per_step` (1: every
    /// tick is a step, and no action is lost to another in the same step).
    #[arg(long, default_value_t = bw4t_env::DEFAULT_TICKS_PER_STEP, value_name = "N")]
    pub(crate) ticks_per_step: u32,
    /// `env`: visible-block slots, as the environment's `slots`.
    #[arg(long, default_value_t = bw4t_env::DEFAULT_SLOTS, value_name = "K")]
    pub(crate) slots: usize,
}

impl Default for TrajectoryFlags {
    /// The command line's defaults.
    fn default() -> Self {
        TrajectoryFlags {
            format: Format::Symbolic,
            ticks_per_step: bw4t_env::DEFAULT_TICKS_PER_STEP,
            slots: bw4t_env::DEFAULT_SLOTS,
        }
    }
}

impl TrajectoryFlags {
    fn options(&self, allow_incomplete: bool) -> Result<TrajectoryOptions> {
        if self.ticks_per_step == 0 {
            bail!("--ticks-per-step must be at least 1");
        }
        if self.slots == 0 {
            bail!("--slots must be at least 1");
        }
        Ok(TrajectoryOptions {
            kind: self.format.kind(),
            ticks_per_step: self.ticks_per_step,
            slots: self.slots,
            allow_incomplete,
            ..TrajectoryOptions::default()
        })
    }
}

/// Options of `bw4t replay trajectories`.
#[derive(Args)]
pub(crate) struct ReplayTrajectoriesArgs {
    /// Replay files; each becomes a directory under --out named after the file.
    #[arg(required = true, value_name = "REPLAY")]
    replays: Vec<PathBuf>,
    /// Where to write.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    flags: TrajectoryFlags,
    /// Also export a replay without its end record (its writer was stopped), up to its
    /// last tick; otherwise it is refused.
    #[arg(long)]
    incomplete: bool,
}

/// Runs `bw4t replay trajectories`.
pub(crate) fn run(args: &ReplayTrajectoriesArgs) -> Result<()> {
    let options = args.flags.options(args.incomplete)?;
    let written = export(&args.replays, &args.out, &options)?;
    outln!(
        "wrote {} ({}) of {} into {}",
        bw4t_runner::plural(written, "robot trajectory"),
        args.flags.format.kind().as_str(),
        bw4t_runner::plural(args.replays.len(), "replay"),
        args.out.display()
    );
    Ok(())
}

/// A study's exported trial replays (`OUT/replays/*.jsonl`) as trajectories under
/// `OUT/trajectories/`; a trial's replay carries its participant, condition and trial as
/// labels, which each `meta.json` keeps. Trials whose replay has no end are exported up to it.
pub(crate) fn export_study(out: &Path, flags: &TrajectoryFlags) -> Result<usize> {
    let dir = out.join("replays");
    let mut replays: Vec<PathBuf> = std::fs::read_dir(&dir)
        .with_context(|| format!("cannot read {}", dir.display()))?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "jsonl"))
        .collect();
    replays.sort();
    export(&replays, &out.join("trajectories"), &flags.options(true)?)
}

/// Exports every replay into `out/STEM/`, one after another; returns how many robots'
/// files were written. A replay that cannot be exported stops the export, named.
fn export(replays: &[PathBuf], out: &Path, options: &TrajectoryOptions) -> Result<usize> {
    let mut stems = BTreeSet::new();
    for replay in replays {
        let stem = stem(replay)?;
        if !stems.insert(stem.clone()) {
            bail!("two replays are named {stem}: each is written to a directory of its name under --out");
        }
    }
    let mut robots = 0;
    for replay in replays {
        let text =
            std::fs::read_to_string(replay).with_context(|| format!("cannot read {}", replay.display()))?;
        let name = replay.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let trajectories = trajectories(&text, &name, options)
            .with_context(|| format!("{} cannot be exported", replay.display()))?;
        let dir = out.join(stem(replay)?);
        trajectories.write(&dir).with_context(|| format!("cannot write {}", dir.display()))?;
        robots += trajectories.files.len();
    }
    Ok(robots)
}

/// A replay file's name without `.jsonl`.
fn stem(replay: &Path) -> Result<String> {
    replay
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .with_context(|| format!("{} is not a file name", replay.display()))
}
