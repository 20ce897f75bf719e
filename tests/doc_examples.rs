//! The documents' shell examples are run: every `sh` and `console` block of README.md and
//! docs/*.md. Each `bw4t` command runs for real (the binary under test) in a sandbox of its
//! own; every other program must be named in [`ELSEWHERE`] with the test that covers it.
//!
//! - `sh` blocks: one command a line (`\` continues a line, `#` starts a comment, `&&` and
//!   `;` chain commands); each must exit 0, or stop as documented when it serves.
//! - `console` blocks, in trycmd's format: `$ COMMAND`, then optionally `? STATUS` (a number,
//!   or `failed` for any but 0), then the output it shows (standard output and error as a
//!   terminal shows them), where a `...` line stands for any lines and `[..]` for any text
//!   within a line.
//!
//! The trycmd crate itself is not used: it runs each command to its end, so it cannot start
//! a server, wait for its address and stop it, and it finds programs by name only, so
//! `./target/release/bw4t` would not be the binary under test. One runner for both kinds of
//! block keeps one answer to "how is an example run" (sandbox, ports, the tables below).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, mpsc};
use std::time::{Duration, Instant};

/// Programs of the examples that are not `bw4t`, by the words they start with, and where the
/// test suite does what they do instead. A command matching none fails this test: a new kind
/// of example must say here how it is covered.
const ELSEWHERE: &[(&str, &str)] = &[
    ("./test.sh", "is the test command itself"),
    (
        "cargo build",
        "./test.sh builds the release binary the same way; this test runs the binary cargo built",
    ),
    ("python3 -m venv", "./test.sh's python stage makes its virtualenv (under target/) the same way"),
    (
        ". .venv/bin/activate",
        "./test.sh's python stage calls the virtualenv's programs by their path instead",
    ),
    ("pip install", "./test.sh's python stage installs maturin and the built wheel with pip the same way"),
    ("maturin build", "./test.sh's python stage builds the wheel with `maturin build --release`"),
    (
        "python3 python/examples/llm_agent.py",
        "needs a language model's endpoint: python/tests/test_llm_agent.py plays it against a scripted one",
    ),
    (
        "sh /shared/runs/ladder/slurm/submit.sh",
        "needs a Slurm cluster: ./test.sh's slurm stage (tests/cluster/slurm-tournament.sh) submits the written submit.sh on a one-node cluster",
    ),
    (
        "kubectl",
        "needs a Kubernetes cluster: container/build.sh (./test.sh's container stage) runs the written jobs' commands in the image, python/tests/test_cluster.py validates the manifests against the Kubernetes schemas",
    ),
    (
        "buildah build",
        "./test.sh's container stage (container/build.sh) builds the Containerfile with buildah the same way, then runs the image",
    ),
    ("buildah push", "needs a registry: ./test.sh's container stage builds and runs the image locally"),
    // DEPLOY.md's host set-up: system accounts, packages and services of a real host.
    ("sudo apt-get install caddy", "./test.sh's browser stage installs Debian's Caddy the same way"),
    ("sudo useradd", "a host's service account: nothing to test without one"),
    ("sudo install", "a host's /usr/local/bin: this test runs the same binary from target/"),
    (
        "sudo -u bw4t bw4t study",
        "the service account and its /srv directories: tests/browser/deploy.test.js runs the same `bw4t study` flags behind Caddy",
    ),
    (
        "sudo -u bw4t bw4t serve",
        "the service account and its /srv directories: tests/cli.rs serves --config files, tests/web.rs checks --allow-origin",
    ),
    (
        "sudo cp deploy/Caddyfile",
        "tests/browser/deploy.test.js runs Caddy on deploy/Caddyfile (its site name and upstream replaced)",
    ),
    ("sudo systemctl reload caddy", "a host's systemd: tests/browser/deploy.test.js starts Caddy itself"),
    (
        "claude mcp add",
        "an MCP host's own command: python/tests/test_mcp.py drives `bw4t mcp` over stdio and HTTP through the MCP SDK as a host does",
    ),
    (
        "npx @modelcontextprotocol/inspector",
        "python/tests/test_mcp.py runs the Inspector's CLI (tests/browser's npm packages) against `bw4t mcp`",
    ),
];

/// `bw4t` commands that cannot run here, by a text that their line contains, and why.
const NOT_RUN: &[(&str, &str)] = &[
    (
        "python/examples/llm_agent.py",
        "the agent needs a language model's endpoint: python/tests/test_llm_agent.py plays it against a scripted one",
    ),
    (
        "python3 agent.py",
        "README's agent needs the Python package: python/tests/test_readme_examples.py saves README's block as agent.py and plays it with this command, in the virtualenv that has the package",
    ),
    (
        "/shared/",
        "a cluster's shared file system: tests/cluster.rs writes, merges and resumes shards in a temporary directory",
    ),
];

/// The names a document calls the binary under test by.
const BW4T: [&str; 3] = ["bw4t", "./target/release/bw4t", "target/release/bw4t"];

/// How long one command may run, and how long a server may take to say it is listening or,
/// once told to stop, to end.
const LIMIT: Duration = Duration::from_secs(120);

/// Where the repository is.
fn root() -> &'static Path {
    Path::new(repo_root!())
}

/// The documents whose examples run: README.md and every docs/*.md.
fn documents() -> Vec<String> {
    let mut docs = vec!["README.md".to_string()];
    let mut in_docs: Vec<String> = std::fs::read_dir(root().join("docs"))
        .expect("the docs folder")
        .map(|entry| entry.expect("an entry").file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".md"))
        .map(|name| format!("docs/{name}"))
        .collect();
    in_docs.sort();
    docs.extend(in_docs);
    docs
}

/// The two kinds of example block.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Kind {
    /// Commands only.
    Shell,
    /// Commands after `$ `, each followed by the output it shows.
    Console,
}

/// A fenced example: its document, the line of its first command line, its text.
#[derive(Debug)]
struct Block {
    file: String,
    first_line: usize,
    kind: Kind,
    text: String,
}

/// The `sh` and `console` blocks of a Markdown text, list items' indented ones included
/// (the Markdown parser strips their indentation).
fn blocks(file: &str, markdown: &str) -> Vec<Block> {
    use pulldown_cmark::{CodeBlockKind, Event, Parser, Tag, TagEnd};
    let mut found = Vec::new();
    let mut open: Option<Block> = None;
    for (event, range) in Parser::new(markdown).into_offset_iter() {
        match event {
            Event::Start(Tag::CodeBlock(CodeBlockKind::Fenced(info))) => {
                let kind = match info.split_whitespace().next() {
                    Some("sh") => Kind::Shell,
                    Some("console") => Kind::Console,
                    _ => continue,
                };
                // The fence's own line, then the block's first line.
                let fence_line = markdown[..range.start].matches('\n').count() + 1;
                open = Some(Block {
                    file: file.to_string(),
                    first_line: fence_line + 1,
                    kind,
                    text: String::new(),
                });
            }
            Event::Text(text) => {
                if let Some(block) = &mut open {
                    block.text.push_str(&text);
                }
            }
            Event::End(TagEnd::CodeBlock) => found.extend(open.take()),
            _ => {}
        }
    }
    found
}

/// One command of a block, as the document writes it and as words.
#[derive(Debug, Default, PartialEq)]
struct Step {
    /// Its line in the document.
    line: usize,
    /// The line(s) it was split from, joined.
    text: String,
    /// `NAME=value` words before the program.
    env: Vec<(String, String)>,
    /// The program and its arguments.
    words: Vec<String>,
    /// `> FILE`: where its standard output goes.
    stdout_to: Option<String>,
    /// The exit status it must end with: 0 unless a `console` block's `? STATUS` line says
    /// otherwise; `None` (`? failed`): any but 0.
    status: Option<i32>,
    /// The output it must show (`console` blocks), line by line.
    expected: Option<Vec<String>>,
}

/// Lines joined where one ends with `\`, each with the number of its first line.
fn logical_lines(text: &str, first_line: usize) -> Vec<(usize, String)> {
    let mut lines = Vec::new();
    let mut pending: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        let (start, mut joined, line) = match pending.take() {
            Some((start, joined)) => (start, joined, line.trim_start()),
            None => (first_line + i, String::new(), line),
        };
        match line.trim_end().strip_suffix('\\') {
            Some(continued) => {
                joined.push_str(continued.trim_end());
                joined.push(' ');
                pending = Some((start, joined));
            }
            None => {
                joined.push_str(line);
                lines.push((start, joined));
            }
        }
    }
    lines.extend(pending);
    lines
}

/// The commands of one logical line: split into shell words (quotes and `#` comments as the
/// shell reads them), then at `&&` and `;`; a subshell's parentheses are dropped.
fn steps_of(line: usize, text: &str) -> Result<Vec<Step>, String> {
    let mut lexer = shlex::Shlex::new(text);
    let words: Vec<String> = lexer.by_ref().collect();
    if lexer.had_error {
        return Err(format!("line {line}: unbalanced quotes or a trailing backslash: {text}"));
    }
    let mut steps = Vec::new();
    for mut chunk in words.split(|w| w == "&&" || w == ";").map(<[String]>::to_vec) {
        if let Some(first) = chunk.first_mut().and_then(|w| w.strip_prefix('(').map(str::to_string)) {
            chunk[0] = first;
        }
        if let Some(last) = chunk.last_mut() {
            if let Some(inner) = last.strip_suffix(')').filter(|_| !last.contains('(')) {
                *last = inner.to_string();
            }
        }
        chunk.retain(|w| !w.is_empty());
        if chunk.is_empty() {
            continue;
        }
        let mut step = Step { line, text: text.trim().to_string(), status: Some(0), ..Step::default() };
        let mut rest = chunk.into_iter().peekable();
        while let Some(assignment) = rest.next_if(|w| is_assignment(w)) {
            let (name, value) = assignment.split_once('=').expect("an assignment has '='");
            step.env.push((name.to_string(), value.to_string()));
        }
        while let Some(word) = rest.next() {
            match word.as_str() {
                ">" => step.stdout_to = Some(rest.next().ok_or(format!("line {line}: '>' names no file"))?),
                "|" | "||" | ">>" | "<" | "&" | "2>" | "2>&1" => {
                    return Err(format!(
                        "line {line}: `{word}` is not supported by tests/doc_examples.rs: {text}"
                    ));
                }
                _ => step.words.push(word),
            }
        }
        steps.push(step);
    }
    Ok(steps)
}

/// Whether a word is a `NAME=value` variable assignment.
fn is_assignment(word: &str) -> bool {
    word.split_once('=').is_some_and(|(name, _)| {
        !name.is_empty()
            && !name.starts_with(|c: char| c.is_ascii_digit())
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    })
}

/// A block's commands; in a `console` block with the status and output each shows.
fn steps(block: &Block) -> Result<Vec<Step>, String> {
    let lines = logical_lines(&block.text, block.first_line);
    if block.kind == Kind::Shell {
        let mut steps = Vec::new();
        for (line, text) in lines {
            steps.extend(steps_of(line, &text)?);
        }
        return Ok(steps);
    }
    let mut steps: Vec<Step> = Vec::new();
    for (line, text) in lines {
        if let Some(command) = text.strip_prefix("$ ") {
            let mut these = steps_of(line, command)?;
            let Some(mut step) = these.pop().filter(|_| these.is_empty()) else {
                return Err(format!("line {line}: one command per `$` line in a console block: {command}"));
            };
            step.expected = Some(Vec::new());
            steps.push(step);
            continue;
        }
        let Some(step) = steps.last_mut() else {
            return Err(format!("line {line}: a console block starts with `$ COMMAND`, not: {text}"));
        };
        let expected = step.expected.get_or_insert_with(Vec::new);
        match text.strip_prefix("? ") {
            Some(status) if expected.is_empty() && step.status == Some(0) => {
                step.status = match status.trim() {
                    "failed" => None,
                    number => Some(number.parse().map_err(|_| format!("line {line}: bad status: {text}"))?),
                }
            }
            _ => expected.push(text),
        }
    }
    for step in &mut steps {
        if let Some(expected) = &mut step.expected {
            while expected.last().is_some_and(|l| l.trim().is_empty()) {
                expected.pop();
            }
        }
    }
    Ok(steps)
}

/// Whether `actual` shows what `expected` does: line by line, where a `...` line stands for
/// any number of lines and `[..]` for any text within a line; trailing spaces don't count.
fn output_matches(expected: &[String], actual: &[&str]) -> bool {
    match expected.split_first() {
        None => actual.is_empty(),
        Some((first, rest)) if first.trim() == "..." => {
            (0..=actual.len()).any(|skipped| output_matches(rest, &actual[skipped..]))
        }
        Some((first, rest)) => actual
            .split_first()
            .is_some_and(|(line, others)| line_matches(first, line) && output_matches(rest, others)),
    }
}

/// Whether one line shows what a pattern line does (`[..]`: any text).
fn line_matches(pattern: &str, line: &str) -> bool {
    let (pattern, line) = (pattern.trim_end(), line.trim_end());
    let mut parts = pattern.split("[..]");
    let first = parts.next().unwrap_or_default();
    let Some(mut rest) = line.strip_prefix(first) else { return false };
    let middle: Vec<&str> = parts.collect();
    let Some((last, between)) = middle.split_last() else { return rest.is_empty() };
    for part in between {
        match rest.find(part) {
            Some(at) => rest = &rest[at + part.len()..],
            None => return false,
        }
    }
    rest.ends_with(last)
}

/// A command that serves until stopped: the line it prints once it serves, and the status
/// it ends with on SIGTERM.
struct Serving {
    ready: &'static str,
    stop_status: i32,
}

/// Whether `bw4t ARGS` serves until stopped; if so, `args` get port 0 wherever they name a
/// port, and where the command would listen on a fixed default port, so that examples (and
/// other tests) running at once never collide.
fn serving(args: &mut Vec<String>) -> Option<Serving> {
    let has =
        |args: &[String], flag: &str| args.iter().any(|a| a == flag || a.starts_with(&format!("{flag}=")));
    let (serving, ports): (Serving, &[&str]) = match args.first().map(String::as_str) {
        // `--once` too: it serves until its players have come and played.
        Some("serve") => (Serving { ready: "listening on ", stop_status: 0 }, &["--port"]),
        Some("study") if args.get(1).is_none_or(|a| a != "export") && !has(args, "--simulate") => {
            (Serving { ready: "dashboard: ", stop_status: 0 }, &["--port", "--http"])
        }
        Some("replay") if args.get(1).is_some_and(|a| a == "view") => {
            (Serving { ready: "http on ", stop_status: 0 }, &["--http"])
        }
        // No handler for SIGTERM: it ends as the signal's default does (128 + 15 in a shell).
        Some("mcp") if has(args, "--http") => {
            (Serving { ready: "MCP over streamable HTTP at ", stop_status: 143 }, &[])
        }
        _ => return None,
    };
    let mut i = 0;
    while i < args.len() {
        let (flag, inline) = match args[i].split_once('=') {
            Some((flag, value)) => (flag.to_string(), Some(value.to_string())),
            None => (args[i].clone(), None),
        };
        if flag != "--port" && flag != "--http" {
            i += 1;
            continue;
        }
        let value_at = if inline.is_some() { i } else { i + 1 };
        if value_at < args.len() {
            let value = inline.unwrap_or_else(|| args[value_at].clone());
            // A port, or HOST:PORT (`bw4t mcp --http 127.0.0.1:8765`).
            let zero = match value.rsplit_once(':') {
                Some((host, _)) => format!("{host}:0"),
                None => "0".to_string(),
            };
            args[value_at] = if value_at == i { format!("{flag}={zero}") } else { zero };
        }
        i = value_at + 1;
    }
    for flag in ports {
        if !has(args, flag) {
            args.extend([flag.to_string(), "0".to_string()]);
        }
    }
    Some(serving)
}

/// What `bw4t mcp` over stdio is given: an MCP host's opening (`initialize`, then
/// `initialized`) and then the end of its input, as when the host goes away; it then ends
/// with status 0. Input that ends before the opening is an error (status 1, "connection
/// closed: initialize request"), as a host that never spoke is.
const MCP_OPENING: &str = concat!(
    r#"{"jsonrpc":"2.0","id":1,"method":"initialize","params":{"protocolVersion":"2025-06-18","capabilities":{},"clientInfo":{"name":"doc-examples","version":"1"}}}"#,
    "\n",
    r#"{"jsonrpc":"2.0","method":"notifications/initialized"}"#,
    "\n"
);

/// A fresh directory in which every top-level entry of the repository (but the made
/// folders, [`crate::util::MADE_FOLDERS`]) is a link to the real one, so examples find maps/, examples/, tests/... and write
/// their own files beside them.
fn sandbox(tag: usize) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bw4t-doc-examples-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a sandbox directory");
    for entry in std::fs::read_dir(root()).expect("the repository") {
        let name = entry.expect("an entry").file_name();
        if !crate::util::MADE_FOLDERS.contains(&name.to_str().unwrap_or_default()) {
            std::os::unix::fs::symlink(root().join(&name), dir.join(&name)).expect("a link in the sandbox");
        }
    }
    dir
}

/// What a command printed and how it ended.
struct Ran {
    /// Standard output and error, as a terminal would show them.
    lines: Vec<String>,
    /// The exit status, 128 + N when signal N ended it.
    status: Option<i32>,
}

impl Ran {
    /// The last `n` lines of its output, for a failure message.
    fn last(&self, n: usize) -> String {
        let from = self.lines.len().saturating_sub(n);
        self.lines[from..].iter().map(|l| format!("    | {l}\n")).collect()
    }

    /// The last lines of its output, for a failure message.
    fn tail(&self) -> String {
        self.last(20)
    }
}

/// The exit status as a shell reports it.
fn shell_status(status: std::process::ExitStatus) -> Option<i32> {
    use std::os::unix::process::ExitStatusExt;
    status.code().or_else(|| status.signal().map(|signal| 128 + signal))
}

/// An exit status for a message.
fn shown(status: Option<i32>) -> String {
    status.map_or("none".to_string(), |s| s.to_string())
}

/// Runs `bw4t ARGS` in `dir` with a minimal environment and `input` (none: no input): to
/// its end, or, for a server, until it prints its ready line and then until SIGTERM stops it.
fn run_bw4t(
    dir: &Path,
    step: &Step,
    args: &[String],
    input: Option<&str>,
    serving: Option<&Serving>,
) -> Result<Ran, String> {
    let (reader, writer) = std::io::pipe().map_err(|e| format!("a pipe: {e}"))?;
    let mut command = Command::new(env!("CARGO_BIN_EXE_bw4t"));
    command
        .args(args)
        .current_dir(dir)
        .env_clear()
        .env("PATH", std::env::var_os("PATH").unwrap_or_default())
        .env("HOME", dir)
        .env("LC_ALL", "C")
        .envs(step.env.iter().map(|(k, v)| (k, v)))
        .stdin(if input.is_some() { Stdio::piped() } else { Stdio::null() })
        .stderr(writer.try_clone().map_err(|e| format!("a pipe: {e}"))?);
    let stdout = match &step.stdout_to {
        Some(file) => {
            // Only the child may hold the pipe's writing end, or its end is never seen.
            drop(writer);
            Stdio::from(std::fs::File::create(dir.join(file)).map_err(|e| format!("{file}: {e}"))?)
        }
        None => Stdio::from(writer),
    };
    command.stdout(stdout);
    let mut child = command.spawn().map_err(|e| format!("cannot start bw4t: {e}"))?;
    // The pipe's writing ends are the child's only now, so its end of output is the pipe's.
    drop(command);
    if let (Some(input), Some(mut stdin)) = (input, child.stdin.take()) {
        // Small enough for the pipe's buffer; closed at once after.
        std::io::Write::write_all(&mut stdin, input.as_bytes()).map_err(|e| format!("its input: {e}"))?;
    }
    let (lines_tx, lines_rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(reader).lines() {
            let Ok(line) = line else { break };
            if lines_tx.send(line).is_err() {
                break;
            }
        }
    });
    let started = Instant::now();
    let mut lines = Vec::new();
    let mut stopped = false;
    loop {
        let left = (LIMIT * if stopped { 2 } else { 1 }).saturating_sub(started.elapsed());
        match lines_rx.recv_timeout(left) {
            Ok(line) => {
                let ready = serving.is_some_and(|s| line.contains(s.ready));
                lines.push(line);
                if ready && !stopped {
                    let sent = Command::new("kill").arg("-TERM").arg(child.id().to_string()).status();
                    if !sent.is_ok_and(|s| s.success()) {
                        let _ = child.kill();
                        return Err("cannot send SIGTERM".to_string());
                    }
                    stopped = true;
                }
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                let _ = child.kill();
                let _ = child.wait();
                let ran = Ran { lines, status: None };
                let waited = if serving.is_some() && !stopped { "said it serves" } else { "ended" };
                return Err(format!("never {waited} within {LIMIT:?}; its output ended:\n{}", ran.tail()));
            }
        }
    }
    let status = shell_status(child.wait().map_err(|e| format!("wait: {e}"))?);
    if serving.is_some() && !stopped {
        let ran = Ran { lines, status };
        return Err(format!(
            "exited with status {} before it said it serves; its output ended:\n{}",
            shown(ran.status),
            ran.tail()
        ));
    }
    Ok(Ran { lines, status })
}

/// What became of the commands: how many ran and were covered elsewhere, and the failures.
#[derive(Default)]
struct Tally {
    ran: AtomicUsize,
    served: AtomicUsize,
    elsewhere: AtomicUsize,
    not_run: AtomicUsize,
    failures: Mutex<Vec<String>>,
}

impl Tally {
    fn fail(&self, message: String) {
        self.failures.lock().expect("the failures").push(message);
    }
}

/// Whether a command's words start with those of `prefix`.
fn starts_with_words(words: &[String], prefix: &str) -> bool {
    let prefix: Vec<&str> = prefix.split_whitespace().collect();
    words.len() >= prefix.len() && words.iter().zip(&prefix).all(|(w, p)| w == p)
}

/// Whether an argument reaches outside the sandbox: an absolute path, or a path not yet
/// there inside one of the repository's folders (linked, not copied, so it would be made in
/// the repository).
fn reaches_outside(dir: &Path, value: &str) -> bool {
    if value.starts_with('/') {
        return value != "/dev/null";
    }
    let path = Path::new(value);
    let Some(std::path::Component::Normal(first)) = path.components().next() else { return false };
    path.components().count() > 1
        && dir.join(first).is_symlink()
        && dir.join(first).is_dir()
        && !dir.join(path).exists()
}

/// Runs one document's blocks in order in a sandbox of their own, as a reader following the
/// guide would (a later block may use what an earlier one wrote); records what became of
/// each command.
fn run_document(blocks: &[Block], tag: usize, tally: &Tally) {
    let dir = sandbox(tag);
    let mut failures = Vec::new();
    for block in blocks {
        match steps(block) {
            Ok(steps) => run_steps(block, &steps, &dir, tally, &mut failures),
            Err(why) => failures.push(format!("{}: {why}", block.file)),
        }
    }
    if failures.is_empty() {
        let _ = std::fs::remove_dir_all(&dir);
    } else {
        failures.push(format!("  (its sandbox is kept in {})", dir.display()));
        tally.fail(failures.join("\n"));
    }
}

/// Runs one block's commands in order in `dir`, adding what failed to `failures`.
fn run_steps(block: &Block, steps: &[Step], dir: &Path, tally: &Tally, failures: &mut Vec<String>) {
    for step in steps {
        let at = format!("{}:{}: `{}`", block.file, step.line, step.text);
        let Some((program, args)) = step.words.split_first() else { continue };
        if !BW4T.contains(&program.as_str()) {
            match ELSEWHERE.iter().find(|(prefix, _)| starts_with_words(&step.words, prefix)) {
                Some(_) => tally.elsewhere.fetch_add(1, Ordering::Relaxed),
                None => {
                    failures.push(format!(
                        "{at}: `{program}` is not bw4t and no entry of ELSEWHERE (tests/doc_examples.rs) says which test does what it does"
                    ));
                    continue;
                }
            };
            continue;
        }
        if NOT_RUN.iter().any(|(text, _)| step.text.contains(text)) {
            tally.not_run.fetch_add(1, Ordering::Relaxed);
            continue;
        }
        // An example must not reach outside its sandbox, through an absolute path or by
        // making a file inside one of the repository's own folders (linked, not copied).
        let outside = args
            .iter()
            .map(|a| a.split_once('=').map_or(a.as_str(), |(_, value)| value))
            .find(|value| reaches_outside(dir, value));
        if let Some(path) = outside {
            failures.push(format!(
                "{at}: names {path}, outside its sandbox or new inside the repository's folders: use a path of its own, or list it in NOT_RUN with the reason"
            ));
            continue;
        }
        let mut args = args.to_vec();
        let serves = serving(&mut args);
        if serves.is_some() && step.expected.is_some() {
            failures.push(format!("{at}: a command that serves until stopped belongs in an `sh` block"));
            continue;
        }
        let expected_status = match &serves {
            Some(serving) => Some(serving.stop_status),
            None => step.status,
        };
        let input = (serves.is_none() && args.first().is_some_and(|a| a == "mcp")).then_some(MCP_OPENING);
        let ran = match run_bw4t(dir, step, &args, input, serves.as_ref()) {
            Ok(ran) => ran,
            Err(why) => {
                failures.push(format!("{at}: {why}"));
                continue;
            }
        };
        let status_ok = match expected_status {
            Some(expected) => ran.status == Some(expected),
            None => ran.status.is_some_and(|s| s != 0),
        };
        if !status_ok {
            let wanted = expected_status.map_or("any but 0".to_string(), |s| s.to_string());
            failures.push(format!(
                "{at}: exit status {}, expected {wanted}; its output ended:\n{}",
                shown(ran.status),
                ran.tail()
            ));
            continue;
        }
        if let Some(expected) = &step.expected {
            let actual: Vec<&str> = ran.lines.iter().map(String::as_str).collect();
            if !output_matches(expected, &actual) {
                failures.push(format!(
                    "{at}: its output differs from the document's.\n  expected:\n{}  actual:\n{}",
                    expected.iter().map(|l| format!("    | {l}\n")).collect::<String>(),
                    ran.last(80)
                ));
                continue;
            }
        }
        let counter = if serves.is_some() { &tally.served } else { &tally.ran };
        counter.fetch_add(1, Ordering::Relaxed);
    }
}

/// Every example block of the documents, run (several at once): each `bw4t` command exits
/// as its document says, or serves and stops on SIGTERM; every other program is covered.
#[test]
fn every_shell_example_of_the_documents_runs() {
    let mut all: Vec<Vec<Block>> = Vec::new();
    for file in documents() {
        let text = std::fs::read_to_string(root().join(&file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        all.push(blocks(&file, &text));
    }
    let tally = Tally::default();
    let next = AtomicUsize::new(0);
    let workers = std::thread::available_parallelism().map_or(2, |n| n.get()).clamp(2, 4);
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(document) = all.get(i) else { break };
                    run_document(document, i, &tally);
                }
            });
        }
    });
    let (ran, served) = (tally.ran.into_inner(), tally.served.into_inner());
    let block_count: usize = all.iter().map(Vec::len).sum();
    eprintln!(
        "{} example blocks: {ran} bw4t commands ran to their end, {served} served and stopped, {} covered elsewhere (ELSEWHERE), {} not run (NOT_RUN)",
        block_count,
        tally.elsewhere.into_inner(),
        tally.not_run.into_inner()
    );
    let mut failures = tally.failures.into_inner().expect("the failures");
    failures.sort();
    assert!(failures.is_empty(), "document examples that fail:\n{}", failures.join("\n"));
    assert!(
        ran + served > 0,
        "no bw4t command ran from {block_count} example blocks: is the extraction broken?"
    );
}

/// The extraction finds fenced blocks in list items, joins continued lines, drops comments
/// and splits chains; the output pattern's wildcards match what they stand for only.
#[test]
fn examples_are_read_as_the_shell_and_trycmd_read_them() {
    let markdown = "Text\n\n- item:\n\n  ```sh\n  bw4t run --map 'a b' \\\n      --seed 7   # why\n  cargo build && ./target/release/bw4t map show fixed > out.txt\n  ```\n\n```toml\nx = 1\n```\n\n```console\n$ bw4t map show fixed\n? 2\nmap [..]\n...\nend\n```\n";
    let found = blocks("x.md", markdown);
    assert_eq!(
        found.iter().map(|b| (b.first_line, b.kind)).collect::<Vec<_>>(),
        [(6, Kind::Shell), (16, Kind::Console)]
    );
    let shell = steps(&found[0]).expect("steps");
    let words: Vec<Vec<&str>> = shell.iter().map(|s| s.words.iter().map(String::as_str).collect()).collect();
    assert_eq!(
        words,
        [
            vec!["bw4t", "run", "--map", "a b", "--seed", "7"],
            vec!["cargo", "build"],
            vec!["./target/release/bw4t", "map", "show", "fixed"]
        ]
    );
    assert_eq!((shell[0].line, shell[2].line, shell[2].stdout_to.as_deref()), (6, 8, Some("out.txt")));
    let console = steps(&found[1]).expect("steps");
    assert_eq!(console.len(), 1);
    assert_eq!(console[0].status, Some(2));
    let expected = console[0].expected.clone().expect("an expected output");
    assert!(output_matches(&expected, &["map fixed: 3 rooms", "a", "b", "end"]));
    assert!(output_matches(&expected, &["map x", "end"]));
    assert!(!output_matches(&expected, &["mop fixed", "end"]));
    assert!(!output_matches(&expected, &["map fixed", "end", "more"]));
    let env = steps_of(1, "OPENAI_MODEL=m python3 x.py | head").expect_err("a pipe is refused");
    assert!(env.contains('|'), "{env}");
}

/// Servers' ports become 0, given or defaulted, and `mcp --http HOST:PORT` keeps its host.
#[test]
fn servers_listen_on_free_ports() {
    let rewrite = |line: &str| {
        let mut args: Vec<String> = line.split_whitespace().map(str::to_string).collect();
        let serving = serving(&mut args).map(|s| s.ready);
        (serving, args.join(" "))
    };
    assert_eq!(
        rewrite("serve --http 8080 --map fixed"),
        (Some("listening on "), "serve --http 0 --map fixed --port 0".into())
    );
    assert_eq!(
        rewrite("study s.toml --http=8080"),
        (Some("dashboard: "), "study s.toml --http=0 --port 0".into())
    );
    assert_eq!(rewrite("mcp --http 127.0.0.1:8765 --seed 1").1, "mcp --http 127.0.0.1:0 --seed 1");
    assert_eq!(rewrite("replay view m.jsonl").1, "replay view m.jsonl --http 0");
    assert_eq!(rewrite("study s.toml --simulate 10"), (None, "study s.toml --simulate 10".into()));
    assert_eq!(rewrite("mcp --map fixed"), (None, "mcp --map fixed".into()));
}

/// An example may write beside the links of its sandbox, but not through them into the
/// repository's folders, nor anywhere by an absolute path.
#[test]
fn examples_stay_in_their_sandbox() {
    let dir = sandbox(usize::MAX);
    let verdicts: Vec<bool> = [
        "/shared/runs/ladder",
        "/dev/null",
        "maps/new.toml",
        "maps/README.md",
        "k8s/",
        "python3 tests/agents/tiny_agent.py",
    ]
    .iter()
    .map(|value| reaches_outside(&dir, value))
    .collect();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(verdicts, [true, false, true, false, false, false]);
}
