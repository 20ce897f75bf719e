//! `bw4t`: the command line of Blocks World for Teams.

mod bench;
mod maps;

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
    /// Measure performance; prints one JSON object per line per case.
    Bench(bench::BenchArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Bench(args) => bench::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("bw4t: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
