//! `bw4t`: the command line of Blocks World for Teams, as a library, so the `bw4t`
//! executable and the Python package's `bw4t` command run the same code.

// Standard output goes through `out!`/`outln!`, which end quietly on a closed pipe.
#![deny(clippy::print_stdout)]

#[macro_use]
mod output;
mod arena_config;
mod bench;
mod bench_arena;
mod bench_merge;
mod bench_net;
mod cluster;
mod eval;
mod map_cmd;
mod maps;
mod mcp;
mod replay;
mod run;
mod runs;
mod serve;
mod serving;
mod signals;
mod status;
mod study;
mod study_simulate;
mod tournament;
mod trajectories;

use std::ffi::OsString;
use std::sync::OnceLock;

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
    /// Evaluate an agent on a tier of the named suite (bw4t-suite): its matches, the
    /// built-in team's on the same tasks, and a leaderboard row.
    #[command(after_help = status::EVAL_HELP)]
    Eval(eval::EvalArgs),
    /// Serve matches over TCP (JSON lines; see protocol/PROTOCOL.md) until stopped: one
    /// restarted as it ends, or the templates of a --config file; --once: one match.
    Serve(serve::ServeArgs),
    /// Serve a study (consent, instructions, trials in counterbalanced conditions,
    /// questionnaires) to participants in the browser, recording everything; or export its data.
    Study(study::StudyArgs),
    /// Drive one robot through the Model Context Protocol (tools, resources, a role
    /// prompt) over stdio or streamable HTTP, in a match of its own or a served one.
    Mcp(mcp::McpArgs),
    /// Measure performance; prints one JSON object per line per case.
    Bench(bench::BenchArgs),
}

/// Loads a map for a match as every command does: a file path, else the name of a map
/// shipped with bw4t; it must pass the map check (warnings go to standard error).
pub fn load_map(spec: &str) -> anyhow::Result<bw4t_map::Map> {
    maps::load(spec)
}

/// The names of the maps shipped with bw4t.
pub fn shipped_maps() -> impl Iterator<Item = &'static str> {
    maps::BUILTIN.iter().map(|(name, _)| *name)
}

/// A seed for when the user gives none, printed so the match can be replayed.
pub(crate) fn random_seed() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos()),
    );
    // Small enough to type back in.
    h.finish() % 1_000_000_000
}

/// How to start this same command line again (for a child `bw4t serve`).
static SELF_COMMAND: OnceLock<Vec<OsString>> = OnceLock::new();

/// The program and leading arguments that start this command line again: the `bw4t`
/// executable itself, or what the embedding front end (the Python package) said.
pub(crate) fn self_command() -> anyhow::Result<std::process::Command> {
    let argv = match SELF_COMMAND.get() {
        Some(argv) => argv.clone(),
        None => vec![std::env::current_exe()?.into_os_string()],
    };
    let (program, leading) = argv.split_first().ok_or_else(|| anyhow::anyhow!("empty self command"))?;
    let mut command = std::process::Command::new(program);
    command.args(leading);
    Ok(command)
}

/// Runs the command line `args` (the first is the program's name) and returns the exit
/// status (docs/COMMANDS.md: 0 success, 1 error, 2 unreadable command line, ...). `self_command` is how to start it again as a child
/// process; `None`: this executable.
pub fn main(args: impl IntoIterator<Item = OsString>, self_command: Option<Vec<OsString>>) -> u8 {
    if let Some(argv) = self_command {
        let _ = SELF_COMMAND.set(argv);
    }
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            // Help and version go to standard output with status 0, the rest to standard
            // error with status 2, as `Cli::parse` would do.
            let _ = e.print();
            return if e.use_stderr() { status::USAGE } else { status::SUCCESS };
        }
    };
    let done = |result: anyhow::Result<()>| result.map(|()| status::SUCCESS);
    let result = match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Map(args) => done(map_cmd::run(&args)),
        // Its exit status says the verdict.
        Command::Replay(args) => replay::run(&args),
        Command::Serve(args) => done(serve::run(&args)),
        Command::Tournament(args) => tournament::run(&args),
        Command::Eval(args) => eval::run(&args),
        Command::Study(args) => done(study::run(&args)),
        Command::Mcp(args) => done(mcp::run(&args)),
        Command::Bench(args) => done(bench::run(&args)),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("bw4t: error: {e:#}");
            status::ERROR
        }
    }
}
