//! `bw4t`: the command line of Blocks World for Teams.

// Standard output goes through `out!`/`outln!`, which end quietly on a closed pipe.
#![deny(clippy::print_stdout)]

#[macro_use]
mod output;
mod arena_config;
mod bench;
mod bench_arena;
mod bench_net;
mod map_cmd;
mod maps;
mod replay;
mod run;
mod serve;
mod signals;
mod status;
mod study;
mod tournament;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Blocks World for Teams: a deterministic multi-agent teamwork testbed.
#[derive(Parser)]
#[command(name = "bw4t", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run one match as fast as possible, with the built-in team and/or your agent programs.
    #[command(after_help = status::RUN_HELP)]
    Run(run::RunArgs),
    /// Import, check, show, render or generate maps.
    Map(map_cmd::MapArgs),
    /// Check (re-simulate) or summarise a replay.
    Replay(replay::ReplayArgs),
    /// Play many matches over teams, maps and seeds, and summarise them.
    #[command(after_help = status::TOURNAMENT_HELP)]
    Tournament(tournament::TournamentArgs),
    /// Serve matches over TCP (JSON lines; see protocol/PROTOCOL.md) until stopped: one
    /// restarted as it ends, or the templates of a --config file; --once: one match.
    Serve(serve::ServeArgs),
    /// Serve a study (consent, instructions, trials in counterbalanced conditions,
    /// questionnaires) to participants in the browser, recording everything; or export its data.
    Study(study::StudyArgs),
    /// Measure performance; prints one JSON object per line per case.
    Bench(bench::BenchArgs),
}

/// A seed for when the user gives none, printed so the match can be replayed.
pub fn random_seed() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos()),
    );
    // Small enough to type back in.
    h.finish() % 1_000_000_000
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let done = |result: anyhow::Result<()>| result.map(|()| status::SUCCESS);
    let result = match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Map(args) => done(map_cmd::run(&args)),
        // Its exit status says the verdict.
        Command::Replay(args) => replay::run(&args),
        Command::Serve(args) => done(serve::run(&args)),
        Command::Tournament(args) => tournament::run(&args),
        Command::Study(args) => done(study::run(&args)),
        Command::Bench(args) => done(bench::run(&args)),
    };
    match result {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            eprintln!("bw4t: error: {e:#}");
            ExitCode::from(status::ERROR)
        }
    }
}
