//! `bw4t`: the command line of Blocks World for Teams (the code is the `bw4t_cli` library).

use std::process::ExitCode;

fn main() -> ExitCode {
    ExitCode::from(bw4t_cli::main(std::env::args_os(), None))
}
