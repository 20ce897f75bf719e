//! `bw4t replay`: check a replay by re-simulating it, or summarise it.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use bw4t_runner::{Verdict, verify_replay};
use clap::{Args, Subcommand};

/// Options of `bw4t replay`.
#[derive(Args)]
pub struct ReplayArgs {
    #[command(subcommand)]
    command: ReplayCommand,
}

#[derive(Subcommand)]
enum ReplayCommand {
    /// Re-simulate and report the first tick whose state differs, or that all match.
    Verify {
        /// The replay file.
        file: PathBuf,
    },
    /// Print what the replay holds.
    Show {
        /// The replay file.
        file: PathBuf,
    },
}

/// Runs a replay command.
pub fn run(args: &ReplayArgs) -> Result<()> {
    let (file, verify) = match &args.command {
        ReplayCommand::Verify { file } => (file, true),
        ReplayCommand::Show { file } => (file, false),
    };
    let text = std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    let (verdict, summary) =
        verify_replay(&text).with_context(|| format!("{} is not a usable replay", file.display()))?;
    if verify {
        return match verdict {
            Verdict::Matches { digests, ticks } => {
                println!("ok: all {digests} digests match ({ticks} ticks re-simulated)");
                Ok(())
            }
            Verdict::Differs { tick, expected, found } => {
                bail!("the replay differs at tick {tick}: recorded {expected}, re-simulated {found}")
            }
        };
    }
    let h = &summary.header;
    println!("{} (format {}), map '{}', seed {}", h.program, h.format, h.map, h.seed);
    println!(
        "config: {} ticks/s, speed {}, robot collisions {}",
        h.ticks_per_second,
        h.speed,
        if h.robot_collisions { "on" } else { "off" }
    );
    println!("players: {}", summary.players.join(", "));
    println!(
        "{} ticks, {} actions, end: {}",
        summary.game_ticks,
        summary.actions,
        summary.reason.as_deref().unwrap_or("(none recorded)")
    );
    println!(
        "sequence {}/{}: {}",
        summary.sequence_index,
        summary.sequence.len(),
        summary.sequence.join(" ")
    );
    match verdict {
        Verdict::Matches { digests, .. } => println!("verified: all {digests} digests match"),
        Verdict::Differs { tick, .. } => println!("NOT verified: differs at tick {tick}"),
    }
    Ok(())
}
