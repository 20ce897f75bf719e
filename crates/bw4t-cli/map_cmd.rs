//! `bw4t map`: import, check, show, render and generate maps.

use anyhow::Result;
use clap::{Args, Subcommand};

/// Options of `bw4t map`.
#[derive(Args)]
pub struct MapArgs {
    #[command(subcommand)]
    command: MapCommand,
}

#[derive(Subcommand)]
enum MapCommand {
    /// Make a valid, solvable map of R x C rooms in the style of the default map.
    Generate {
        /// Rooms as ROWSxCOLUMNS, e.g. 3x4.
        #[arg(long)]
        rooms: String,
        /// Spawn points to provide.
        #[arg(long, default_value_t = 10)]
        robots: usize,
        /// Seed for the generated content.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output file (standard output when omitted).
        #[arg(short, long)]
        out: Option<std::path::PathBuf>,
    },
}

/// Runs a map command.
pub fn run(args: &MapArgs) -> Result<()> {
    match &args.command {
        MapCommand::Generate { rooms, robots, seed, out } => {
            let (rows, cols) = parse_rooms(rooms)?;
            let map = bw4t_map::generate(cols, rows, *robots, *seed)?;
            write_out(out.as_deref(), &map.to_native())
        }
    }
}

/// `RxC` as (rows, columns).
fn parse_rooms(text: &str) -> Result<(usize, usize)> {
    let parsed = text.split_once(['x', 'X']).and_then(|(r, c)| Some((r.trim().parse().ok()?, c.trim().parse().ok()?)));
    match parsed {
        Some((r, c)) if r > 0 && c > 0 => Ok((r, c)),
        _ => anyhow::bail!("--rooms '{text}': expected ROWSxCOLUMNS with both at least 1, e.g. 3x4"),
    }
}

/// Writes `text` to `path`, or to standard output.
fn write_out(path: Option<&std::path::Path>, text: &str) -> Result<()> {
    use anyhow::Context;
    match path {
        Some(p) => std::fs::write(p, text).with_context(|| format!("cannot write {}", p.display())),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}
