//! `bw4t map`: import, check, show, render and generate maps.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use bw4t_map::{Content, Map, ZoneKind, check_text, parse_parts, render_svg};
use bw4t_runner::plural;
use clap::{Args, Subcommand};

use crate::maps;

/// Options of `bw4t map`.
#[derive(Args)]
pub(crate) struct MapArgs {
    #[command(subcommand)]
    command: MapCommand,
}

#[derive(Subcommand)]
enum MapCommand {
    /// Check map files and name every problem; fails when any file has an error.
    Check {
        /// Map files (native or original BW4T XML) or shipped maps' names.
        #[arg(required = true, value_name = "FILE")]
        files: Vec<String>,
        /// Also require spawn points for this many robots.
        #[arg(long)]
        robots: Option<usize>,
    },
    /// Summarise a map: zones, rooms and their blocks, random content, sequence, spawn points.
    Show {
        /// A map file or a shipped map's name.
        #[arg(value_name = "FILE")]
        map: String,
        /// Also show the content drawn for this match seed.
        #[arg(long)]
        seed: Option<u64>,
    },
    /// Draw a map as SVG, with the blocks and sequence of one match seed.
    Render {
        /// A map file or a shipped map's name.
        #[arg(value_name = "FILE")]
        map: String,
        /// Output file (standard output when omitted).
        #[arg(short, long)]
        out: Option<PathBuf>,
        /// Match seed the random content is drawn from.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Convert a map (an original BW4T XML file, or any map) to the native format.
    Import {
        /// The map file; the map is named after it unless it names itself.
        #[arg(value_name = "FILE")]
        file: String,
        /// Output file (standard output when omitted).
        #[arg(short, long)]
        out: Option<PathBuf>,
    },
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
pub(crate) fn run(args: &MapArgs) -> Result<()> {
    match &args.command {
        MapCommand::Check { files, robots } => check(files, *robots),
        MapCommand::Show { map, seed } => {
            let map = maps::load_as_is(map)?;
            let content = match seed {
                Some(seed) => Some((content(&map, *seed)?, map.seed().unwrap_or(*seed))),
                None => None,
            };
            out!("{}", summary(&map, content.as_ref().map(|(c, s)| (c, *s))));
            Ok(())
        }
        MapCommand::Render { map: spec, out, seed } => {
            let map = maps::load_as_is(spec)?;
            let content = content(&map, *seed).with_context(|| format!("cannot render {spec}"))?;
            write_out(out.as_deref(), &render_svg(&map, Some((&content, map.seed().unwrap_or(*seed)))))
        }
        MapCommand::Import { file, out } => {
            let source = maps::read(file)?;
            // The readers' own warnings (e.g. dropped neighbour names) say what changes on import.
            if let Ok((_, problems)) = parse_parts(&source.text, &source.name) {
                for problem in problems.iter().filter(|p| !p.is_error()) {
                    eprintln!("{file}: {problem}");
                }
            }
            let map = Map::parse(&source.text, &source.name)
                .with_context(|| format!("{file} is not a valid map"))?;
            write_out(out.as_deref(), &map.to_native())
        }
        MapCommand::Generate { rooms, robots, seed, out } => {
            let (rows, cols) = parse_rooms(rooms)?;
            let map = bw4t_map::generate(cols, rows, *robots, *seed)?;
            write_out(out.as_deref(), &map.to_native())
        }
    }
}

/// Prints every problem of every file (or `FILE: ok`); fails when any file has an error or
/// cannot be read, after reporting all of them.
fn check(files: &[String], robots: Option<usize>) -> Result<()> {
    let mut failed = 0;
    for file in files {
        let problems = maps::read(file).and_then(|source| {
            check_text(&source.text, &source.name, robots)
                .with_context(|| format!("{file} cannot be read as a map"))
        });
        match problems {
            Ok(problems) if problems.is_empty() => outln!("{file}: ok"),
            Ok(problems) => {
                for problem in &problems {
                    outln!("{file}: {problem}");
                }
                failed += usize::from(problems.iter().any(|p| p.is_error()));
            }
            Err(e) => {
                outln!("{file}: error: {e:#}");
                failed += 1;
            }
        }
    }
    if failed > 0 {
        bail!("{failed} of {} failed the check", plural(files.len(), "map"));
    }
    Ok(())
}

/// The blocks and sequence of a match on `map` with `seed`.
fn content(map: &Map, seed: u64) -> Result<Content> {
    map.content(seed).with_context(|| format!("the random content of map '{}' cannot be placed", map.name()))
}

/// A text summary of `map` (and, with `content`, of one match's blocks and sequence).
fn summary(map: &Map, content: Option<(&Content, u64)>) -> String {
    let mut out = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(out, "map '{}'", map.name());
    let _ = writeln!(out, "area: {} x {}", map.area().x, map.area().y);
    let kinds = [ZoneKind::Room, ZoneKind::Corridor, ZoneKind::Charging, ZoneKind::Blockade].map(|kind| {
        let n = map.zones().iter().filter(|z| z.kind == kind).count();
        let word = match kind {
            ZoneKind::Room => "room",
            ZoneKind::Corridor => "corridor",
            ZoneKind::Charging => "charging zone",
            ZoneKind::Blockade => "blockade",
        };
        (n > 0).then(|| plural(n, word))
    });
    let kinds: Vec<String> = kinds.into_iter().flatten().collect();
    let _ = writeln!(out, "zones: {} ({})", map.zones().len(), kinds.join(", "));
    let _ = writeln!(out, "rooms:");
    let width = map.zones().iter().map(|z| z.name.chars().count()).max().unwrap_or(0);
    for (idx, zone) in map.zones().iter().enumerate().filter(|(_, z)| z.kind == ZoneKind::Room) {
        let r = zone.rect;
        let what = if idx == map.drop_zone() {
            "the drop zone".to_string()
        } else if zone.blocks.is_empty() {
            "no fixed blocks".to_string()
        } else {
            format!("blocks: {}", words(zone.blocks.iter()))
        };
        let _ = writeln!(
            out,
            "  {:width$}  at ({}, {}), {} x {}, {}; {what}",
            zone.name,
            r.centre.x,
            r.centre.y,
            r.size.x,
            r.size.y,
            plural(zone.doors.len(), "door"),
        );
    }
    let fixed: usize = map.zones().iter().map(|z| z.blocks.len()).sum();
    let _ = writeln!(out, "fixed blocks: {fixed}");
    let seed = match map.seed() {
        Some(seed) => format!("seed {seed}, fixed by the map"),
        None => "drawn from the match seed".to_string(),
    };
    let _ = match (map.random_sequence(), map.random_blocks()) {
        (0, 0) => writeln!(out, "random content: none"),
        (s, b) => writeln!(
            out,
            "random content: {} (each with a block), {}; {seed}",
            plural(s as usize, "sequence colour"),
            plural(b as usize, "more block")
        ),
    };
    let fixed_sequence =
        if map.sequence().is_empty() { "(none)".to_string() } else { words(map.sequence().iter()) };
    let _ = match map.random_sequence() {
        0 => writeln!(out, "sequence: {fixed_sequence}"),
        n => writeln!(out, "sequence: {fixed_sequence}, then {}", plural(n as usize, "random colour")),
    };
    let _ = writeln!(out, "spawn points: {}", map.spawns().len());
    for spawn in map.spawns() {
        let _ = writeln!(out, "  {} at ({}, {})", spawn.name, spawn.pos.x, spawn.pos.y);
    }
    if let Some((content, seed)) = content {
        let _ = writeln!(out, "with seed {seed}:");
        let _ = writeln!(out, "  sequence: {}", words(content.sequence.iter()));
        for (idx, zone) in map.zones().iter().enumerate() {
            let here: Vec<_> = content.blocks.iter().filter(|b| b.zone == idx).map(|b| b.colour).collect();
            if !here.is_empty() {
                let _ = writeln!(out, "  {:width$}  {}", zone.name, words(here.iter()));
            }
        }
    }
    out
}

/// Items separated by spaces.
fn words<T: std::fmt::Display>(items: impl Iterator<Item = T>) -> String {
    items.map(|c| c.to_string()).collect::<Vec<_>>().join(" ")
}

/// `RxC` as (rows, columns).
fn parse_rooms(text: &str) -> Result<(usize, usize)> {
    let parsed =
        text.split_once(['x', 'X']).and_then(|(r, c)| Some((r.trim().parse().ok()?, c.trim().parse().ok()?)));
    match parsed {
        Some((r, c)) if r > 0 && c > 0 => Ok((r, c)),
        _ => anyhow::bail!("--rooms '{text}': expected ROWSxCOLUMNS with both at least 1, e.g. 3x4"),
    }
}

/// Writes `text` to `path`, or to standard output.
fn write_out(path: Option<&Path>, text: &str) -> Result<()> {
    match path {
        Some(p) => std::fs::write(p, text).with_context(|| format!("cannot write {}", p.display())),
        None => {
            out!("{text}");
            Ok(())
        }
    }
}
