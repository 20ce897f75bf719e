//! Before any match starts: whether an agent's command line names a program that exists, so
//! a misspelt command is a clear error up front rather than a run of matches nobody played.

use std::path::Path;
use std::process::{Command, Stdio};

/// Checks that the program `command` starts (its first word, after any `NAME=value`
/// assignments) is a shell built-in, a program on `PATH` or an executable file. A command
/// whose first word is only known when the shell runs it (`$AGENT`, `` `...` ``) passes.
pub fn check_command(command: &str) -> Result<(), String> {
    let Some(program) = first_program(command) else { return Ok(()) };
    let found = if program.contains('/') {
        is_executable(Path::new(&program))
    } else {
        // `command -v` knows the shell's built-ins and searches PATH as `sh -c` will.
        Command::new("sh")
            .args(["-c", "command -v \"$1\"", "sh", &program])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if found {
        Ok(())
    } else if program.contains('/') {
        Err(format!("'{program}' is not an executable file"))
    } else {
        Err(format!("program '{program}' is not found (neither a shell built-in nor on PATH)"))
    }
}

fn is_executable(path: &Path) -> bool {
    let Ok(meta) = std::fs::metadata(path) else { return false };
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        meta.is_file() && meta.permissions().mode() & 0o111 != 0
    }
    #[cfg(not(unix))]
    {
        meta.is_file()
    }
}

/// The first word of `command` as `sh` would read it, unquoted; `None` when it cannot be
/// known without running the shell (expansions) or the command starts with shell syntax.
fn first_program(command: &str) -> Option<String> {
    let mut chars = command.chars().peekable();
    loop {
        while chars.next_if(|c| c.is_whitespace()).is_some() {}
        let mut word = String::new();
        let mut quoted = false;
        while let Some(&c) = chars.peek() {
            if c.is_whitespace() || ";&|()<>{}".contains(c) {
                break;
            }
            chars.next();
            match c {
                '\'' => {
                    quoted = true;
                    word.extend(chars.by_ref().take_while(|&q| q != '\''));
                }
                '"' => {
                    quoted = true;
                    for q in chars.by_ref() {
                        match q {
                            '"' => break,
                            '$' | '`' => return None,
                            _ => word.push(q),
                        }
                    }
                }
                '\\' => word.extend(chars.next()),
                '$' | '`' | '*' | '?' | '[' | '~' => return None,
                _ => word.push(c),
            }
        }
        if word.is_empty() {
            return None;
        }
        if !quoted && is_assignment(&word) {
            continue;
        }
        return Some(word);
    }
}

/// `NAME=value`, which sets a variable for the command that follows.
fn is_assignment(word: &str) -> bool {
    word.split_once('=').is_some_and(|(name, _)| {
        name.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_word_is_found_as_the_shell_reads_it() {
        let cases = [
            ("python3 agent.py", Some("python3")),
            ("  PYTHONPATH=lib  DEBUG=1 python3 -u a.py", Some("python3")),
            ("'my agent' --fast", Some("my agent")),
            ("\"./run it.sh\"", Some("./run it.sh")),
            ("echo starting; exit 7", Some("echo")),
            ("sleep 1 & python3 x.py", Some("sleep")),
            ("$AGENT --x", None),
            ("\"$HOME/agent\"", None),
            ("(cd dir && ./a)", None),
            ("", None),
        ];
        for (command, expected) in cases {
            assert_eq!(first_program(command).as_deref(), expected, "{command}");
        }
    }

    #[test]
    fn missing_programs_are_named() {
        assert!(check_command("sh -c true").is_ok());
        assert!(check_command("echo hi; exit 3").is_ok());
        let err = check_command("biultin --fast").expect_err("no such program");
        assert!(err.contains("program 'biultin' is not found"), "{err}");
        let err = check_command("./no/such/agent.sh").expect_err("no such file");
        assert!(err.contains("'./no/such/agent.sh' is not an executable file"), "{err}");
    }
}
