//! Standard output for every command. A reader that stops early (`bw4t bench | head -1`)
//! ends bw4t quietly with the status a shell reports for a process ended by SIGPIPE,
//! instead of the panic `println!` gives (Rust ignores SIGPIPE, so the write fails).

use std::io::Write;

/// Writes `args` to standard output; exits on a closed pipe, or with an error on any other
/// failure to write.
pub(crate) fn write(args: std::fmt::Arguments<'_>) {
    let Err(e) = std::io::stdout().lock().write_fmt(args) else { return };
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        std::process::exit(crate::status::BROKEN_PIPE);
    }
    eprintln!("bw4t: error: cannot write to standard output: {e}");
    std::process::exit(i32::from(crate::status::ERROR));
}

/// Writes a line to standard error and goes on if it cannot: a server whose log reader
/// has gone must still serve and stop (`eprintln!` would panic).
pub(crate) fn note(args: std::fmt::Arguments<'_>) {
    let _ = std::io::stderr().lock().write_fmt(format_args!("{args}\n"));
}

/// `print!` that ends bw4t quietly when standard output is closed.
macro_rules! out {
    ($($arg:tt)*) => { $crate::output::write(format_args!($($arg)*)) };
}

/// `println!` that ends bw4t quietly when standard output is closed.
macro_rules! outln {
    ($($arg:tt)*) => { $crate::output::write(format_args!("{}\n", format_args!($($arg)*))) };
}
