//! The exit statuses of `bw4t`, in one place (docs/COMMANDS.md lists them), so a
//! script or grader can tell outcomes apart without reading JSON.

/// The match completed the sequence (`run`); the command did what was asked (all others).
pub(crate) const SUCCESS: u8 = 0;
/// An error: a bad option value, map or configuration, or a file that cannot be read or
/// written. The message on standard error names it. (A command line clap cannot read at
/// all, such as an unknown option, exits with clap's status 2.)
pub(crate) const ERROR: u8 = 1;
/// A command line that cannot be read (an unknown option).
pub(crate) const USAGE: u8 = 2;
/// `run`: the match ended without completing the sequence (tick limit reached).
pub(crate) const NOT_COMPLETED: u8 = 3;
/// `run`: none of the external agents played (each crashed, never connected, broke the
/// protocol or stopped answering). `tournament`: a team's external agents played in none of
/// its matches.
pub(crate) const NO_AGENT_PLAYED: u8 = 4;
/// `tournament merge`: the merged directories lack matches of their configuration.
pub(crate) const MERGE_INCOMPLETE: u8 = 3;
/// `replay verify`: the re-simulation differs from the recording.
pub(crate) const REPLAY_DIFFERS: u8 = 3;
/// `replay verify`: the replay has no end record (everything up to its last tick matched).
pub(crate) const REPLAY_INCOMPLETE: u8 = 4;
/// Stopped by SIGINT (Ctrl-C) or SIGTERM: 128 plus the signal's number (130, 143).
pub(crate) const SIGNAL_BASE: u8 = 128;
/// Standard output was closed early: 128 + SIGPIPE (13), what a shell reports for a
/// program ended by SIGPIPE.
pub(crate) const BROKEN_PIPE: i32 = 141;

/// The exit statuses of `bw4t run`, for its `--help`.
pub(crate) const RUN_HELP: &str = "Exit status: 0 the match completed the sequence; 1 an error (bad option, map, \
     file); 2 a command line that cannot be read; 3 the match did not complete (tick limit \
     reached); 4 none of the external agents played (crashed, never connected, broke the \
     protocol or stopped answering); 130/143 stopped by SIGINT/SIGTERM; 141 standard output \
     closed early.";

/// The exit statuses of `bw4t tournament`, for its `--help`.
pub(crate) const TOURNAMENT_HELP: &str = "Exit status: 0 every match was played (whatever its outcome); 1 an error (bad \
     configuration, map, agent command or output directory); 2 a command line that cannot \
     be read; 4 a team's external agents played in none of its matches; 130/143 stopped by \
     SIGINT/SIGTERM (the rows so far are kept; the message says how to resume); 141 \
     standard output closed early.";

/// The exit statuses of `bw4t eval`, for its `--help`.
pub(crate) const EVAL_HELP: &str = "Exit status: 0 the tier was played and scored (whatever the score); 1 an error \
     (bad tier, split, agent command, outcomes file or output directory); 2 a command line \
     that cannot be read; 4 the agent's programs played in none of its matches; 130/143 \
     stopped by SIGINT/SIGTERM (the matches so far are kept; the message says how to \
     resume); 141 standard output closed early.";

/// The exit statuses of `bw4t tournament merge`, for its `--help`.
pub(crate) const MERGE_HELP: &str = "Exit status: 0 every match of the configuration is in the merged directory; 1 an \
     error (a directory that is not a tournament, configurations that differ, a file that \
     cannot be read or written); 3 matches are missing (named; `tournament resume DIR` or \
     --play-missing plays them); with --play-missing, the statuses of the tournament run.";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_help_texts_name_every_status() {
        for code in [SUCCESS, ERROR, NOT_COMPLETED, NO_AGENT_PLAYED] {
            assert!(RUN_HELP.contains(&format!("{code} ")), "run help lacks {code}");
        }
        for code in [SUCCESS, ERROR, NO_AGENT_PLAYED] {
            assert!(EVAL_HELP.contains(&format!("{code} ")), "eval help lacks {code}");
        }
        for code in [SUCCESS, ERROR, NO_AGENT_PLAYED] {
            assert!(TOURNAMENT_HELP.contains(&format!("{code} ")), "tournament help lacks {code}");
        }
        for code in [SUCCESS, ERROR, MERGE_INCOMPLETE] {
            assert!(MERGE_HELP.contains(&format!("{code} ")), "merge help lacks {code}");
        }
        for help in [RUN_HELP, TOURNAMENT_HELP] {
            assert!(help.contains(&format!("{}/{}", SIGNAL_BASE + 2, SIGNAL_BASE + 15)));
            assert!(help.contains(&BROKEN_PIPE.to_string()));
        }
    }
}
