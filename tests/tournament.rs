use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

use serde_json::Value;

/// How long one tournament in these tests may take before it counts as hung.
const LIMIT: Duration = Duration::from_secs(120);

fn bw4t(args: &[&str]) -> Output {
    let out = crate::util::bw4t_within(args, LIMIT);
    assert!(out.status.success(), "bw4t {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out
}

fn temp(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bw4t-tournament-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

const CONFIG: &str = r#"
maps = ["default", "fixed"]
seeds = 3
max_ticks = 20000

[[team]]
name = "coop"
agents = "builtin"
robots = 3

[[team]]
name = "solo"
agents = "builtin:baseline"
robots = 3
"#;

fn write_config(dir: &Path, text: &str) -> String {
    let path = dir.join("tournament.toml");
    std::fs::write(&path, text).expect("config");
    path.to_string_lossy().into_owned()
}

/// The rows of a tournament directory in match order (the file has them in the order
/// matches ended, which depends on the threads).
fn rows(dir: &Path) -> Vec<Value> {
    let text = std::fs::read_to_string(dir.join("matches.jsonl")).expect("matches.jsonl");
    let mut rows: Vec<Value> = text.lines().map(|l| serde_json::from_str(l).expect("a row")).collect();
    rows.sort_by_key(|r| r["index"].as_u64());
    rows
}

/// Asserts two lists of rows are equal, naming the first difference.
fn same_rows(a: &[Value], b: &[Value]) {
    if let Some(i) = a.iter().zip(b).position(|(x, y)| x != y) {
        panic!("row {i} differs:\n {}\n {}", a[i], b[i]);
    }
    assert_eq!(a.len(), b.len(), "different numbers of rows");
}

/// Rows without the fields that depend on the machine's speed.
fn stable(rows: &[Value]) -> Vec<Value> {
    rows.iter()
        .map(|r| {
            let mut r = r.clone();
            r["wall_ms"] = Value::Null;
            r
        })
        .collect()
}

fn run_to(config: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["tournament", config, "--out", out.to_str().expect("utf-8")];
    args.extend_from_slice(extra);
    bw4t(&args)
}

#[test]
fn a_small_tournament_writes_consistent_files_and_is_reproducible() {
    let dir = temp("small");
    let config = write_config(&dir, CONFIG);
    let (first, second) = (dir.join("first"), dir.join("second"));
    let out = run_to(&config, &first, &["--replays", "all"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.lines().last().is_some_and(|l| l.contains("matches_per_min")), "{stdout}");
    for file in ["manifest.json", "matches.jsonl", "matches.csv", "summary.md", "summary.json", "summary.svg"]
    {
        assert!(first.join(file).is_file(), "{file} missing");
    }
    let all = rows(&first);
    assert_eq!(all.len(), 2 * 2 * 3);
    let csv = std::fs::read_to_string(first.join("matches.csv")).expect("csv");
    assert_eq!(csv.lines().count(), all.len() + 1);
    assert!(csv.starts_with("index,team,map,seed"));
    // Every team played the same (map, seed) pairs.
    let pairs = |team: &str| {
        let mut p: Vec<(String, u64)> = all
            .iter()
            .filter(|r| r["team"] == team)
            .map(|r| (r["map"].as_str().unwrap_or("").to_string(), r["seed"].as_u64().unwrap_or(0)))
            .collect();
        p.sort();
        p
    };
    assert_eq!(pairs("coop"), pairs("solo"));
    // The summary agrees with the rows.
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(first.join("summary.json")).expect("summary"))
            .expect("json");
    assert_eq!(summary["matches"], 12);
    assert!(summary["matches_per_min"].as_f64().is_some_and(|m| m > 0.0));
    for cell in summary["cells"].as_array().expect("cells") {
        let (team, map) = (cell["team"].as_str().expect("team"), cell["map"].as_str().expect("map"));
        let mine: Vec<&Value> = all.iter().filter(|r| r["team"] == team && r["map"] == map).collect();
        let done: Vec<f64> = mine
            .iter()
            .filter(|r| r["completed"] == true)
            .map(|r| r["completed_tick"].as_f64().expect("tick"))
            .collect();
        assert_eq!(cell["matches"].as_u64(), Some(mine.len() as u64), "{cell}");
        assert_eq!(cell["completed"].as_u64(), Some(done.len() as u64), "{cell}");
        let mean = done.iter().sum::<f64>() / done.len() as f64;
        assert!((cell["ticks_mean"].as_f64().expect("mean") - mean).abs() < 1e-6, "{cell} vs {mean}");
    }
    let svg = std::fs::read_to_string(first.join("summary.svg")).expect("svg");
    assert!(svg.starts_with("<svg") && svg.contains("coop") && svg.contains("solo"));
    // Replays were kept and verify.
    let replay = all[0]["replay"].as_str().expect("replay path");
    let verify = bw4t(&["replay", "verify", first.join(replay).to_str().expect("utf-8")]);
    assert!(String::from_utf8_lossy(&verify.stdout).starts_with("ok"));
    // The same configuration again gives the same rows.
    run_to(&config, &second, &["--replays", "none"]);
    let again = rows(&second);
    let no_replay = |rs: &[Value]| {
        stable(rs)
            .into_iter()
            .map(|mut r| {
                r["replay"] = Value::Null;
                r
            })
            .collect::<Vec<_>>()
    };
    same_rows(&no_replay(&again), &no_replay(&all));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn resume_plays_only_what_is_missing_even_after_a_kill() {
    let dir = temp("resume");
    let config = write_config(&dir, &CONFIG.replace("seeds = 3", "seeds = 40"));
    let (whole, killed) = (dir.join("whole"), dir.join("killed"));
    run_to(&config, &whole, &["--replays", "none", "--concurrency", "1"]);
    let expected = stable(&rows(&whole));
    // Kill a run once some rows are on disk.
    let mut child = Command::new(env!("CARGO_BIN_EXE_bw4t"))
        .args([
            "tournament",
            &config,
            "--out",
            killed.to_str().expect("utf-8"),
            "--replays",
            "none",
            "--concurrency",
            "1",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start");
    // Each row is flushed before its progress line (`[N/M] ...`) is printed: wait for the
    // fifth line, or for the run to end, whichever comes first.
    let stderr = child.stderr.take().expect("piped");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        use std::io::BufRead;
        for line in std::io::BufReader::new(stderr).lines().map_while(Result::ok) {
            if line.starts_with("[5/") && tx.send(()).is_err() {
                break;
            }
        }
        // The run ended (or the test stopped listening): wake the test either way.
        let _ = tx.send(());
    });
    rx.recv_timeout(LIMIT).expect("five rows or the end of the run in time");
    let _ = child.kill();
    let _ = child.wait();
    // A kill can also leave half a line: the resume must cope.
    let partial = rows(&killed).len();
    assert!((5..expected.len()).contains(&partial), "killed mid-run: {partial} of {} rows", expected.len());
    let mut file = std::fs::OpenOptions::new().append(true).open(killed.join("matches.jsonl")).expect("open");
    std::io::Write::write_all(&mut file, b"{\"key\":\"coop/def").expect("append");
    drop(file);
    let out = run_to(&config, &killed, &["--replays", "none", "--resume"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains(&format!("({} played now, {partial} already done)", expected.len() - partial)),
        "{stdout}"
    );
    same_rows(&stable(&rows(&killed)), &expected);
    let csv = std::fs::read_to_string(killed.join("matches.csv")).expect("csv");
    assert_eq!(csv.lines().count(), expected.len() + 1);
    // Without --resume the directory is refused.
    let again = Command::new(env!("CARGO_BIN_EXE_bw4t"))
        .args(["tournament", &config, "--out", killed.to_str().expect("utf-8")])
        .output()
        .expect("run");
    assert!(!again.status.success() && String::from_utf8_lossy(&again.stderr).contains("--resume"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A merge reads rows anyone could have written: a row's `replay` that points outside its
/// shard's `replays/` is neither read nor written.
#[test]
fn a_merge_copies_no_replay_from_or_to_outside_the_shards() {
    let dir = temp("stray");
    let config = write_config(
        &dir,
        "maps = [\"fixed\"]\nseeds = 3\n[[team]]\nname = \"solo\"\nagents = \"builtin:baseline\"\nrobots = 2\n",
    );
    let (shard, merged) = (dir.join("shard"), dir.join("merged"));
    run_to(&config, &shard, &["--replays", "all"]);
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, "keep me").expect("victim");
    let index = shard.join("matches.jsonl");
    let mut lines: Vec<Value> = std::fs::read_to_string(&index)
        .expect("matches.jsonl")
        .lines()
        .map(|l| serde_json::from_str(l).expect("a row"))
        .collect();
    assert_eq!(lines.len(), 3);
    lines[0]["replay"] = Value::from(victim.to_str().expect("utf-8"));
    lines[1]["replay"] = Value::from("../escaped.jsonl");
    let text: String = lines.iter().map(|l| format!("{l}\n")).collect();
    std::fs::write(&index, text).expect("tampered rows");
    let out = crate::util::bw4t_within(
        &["tournament", "merge", shard.to_str().expect("utf-8"), "-o", merged.to_str().expect("utf-8")],
        LIMIT,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("2 matches name a replay outside their shard's replays/"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&victim).expect("victim"), "keep me");
    assert!(!dir.join("escaped.jsonl").exists(), "nothing written outside --out");
    let kept = rows(&merged);
    let replays: Vec<bool> = kept.iter().map(|r| r["replay"].is_string()).collect();
    assert_eq!(
        replays.iter().filter(|r| **r).count(),
        1,
        "only the untouched row keeps its replay: {kept:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn shards_merged_equal_the_whole_tournament() {
    let dir = temp("shards");
    let config = write_config(&dir, CONFIG);
    let whole = dir.join("whole");
    run_to(&config, &whole, &["--replays", "none"]);
    let (a, b, merged) = (dir.join("a"), dir.join("b"), dir.join("merged"));
    run_to(&config, &a, &["--replays", "none", "--shard", "1/2"]);
    run_to(&config, &b, &["--replays", "none", "--shard", "2/2"]);
    assert_eq!(rows(&a).len() + rows(&b).len(), rows(&whole).len());
    // Interleaved: each shard plays half of every team's matches, on every map, so a slow
    // team is not all on one machine.
    for shard in [&a, &b] {
        let mine = rows(shard);
        for team in ["coop", "solo"] {
            let of_team: Vec<&Value> = mine.iter().filter(|r| r["team"] == team).collect();
            assert_eq!(of_team.len(), 3, "{team} in {}: {mine:?}", shard.display());
            let maps: std::collections::BTreeSet<&str> =
                of_team.iter().filter_map(|r| r["map"].as_str()).collect();
            assert_eq!(maps.len(), 2, "{team} in {} plays both maps", shard.display());
        }
    }
    bw4t(&[
        "tournament",
        "merge",
        a.to_str().expect("utf-8"),
        b.to_str().expect("utf-8"),
        "-o",
        merged.to_str().expect("utf-8"),
    ]);
    same_rows(&stable(&rows(&merged)), &stable(&rows(&whole)));
    let summary = |d: &Path| {
        let mut s: Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("summary.json")).expect("summary"))
                .expect("json");
        for volatile in ["matches_per_min", "wall_seconds"] {
            s[volatile] = Value::Null;
        }
        s["totals"]["match_wall_ms"] = Value::Null;
        if let Some(cells) = s["cells"].as_array_mut() {
            cells.iter_mut().for_each(|c| c["mean_wall_ms"] = Value::Null);
        }
        s
    };
    assert_eq!(summary(&merged), summary(&whole));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_team_whose_agent_crashes_is_reported_and_the_tournament_finishes() {
    let dir = temp("crash");
    let config = write_config(
        &dir,
        r#"
maps = ["fixed"]
seeds = [1, 2]
max_ticks = 300

[[team]]
name = "good"
agents = "builtin"
robots = 1

[[team]]
name = "broken"
agents = "echo starting; exit 7"
robots = 1
"#,
    );
    let out_dir = dir.join("out");
    let out = crate::util::bw4t_within(
        &[
            "tournament",
            &config,
            "--out",
            out_dir.to_str().expect("utf-8"),
            "--replays",
            "failed",
            "--connect-timeout-s",
            "5",
        ],
        LIMIT,
    );
    // The tournament finishes, and its exit status says a team's agents never played.
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(4), "{stderr}");
    assert!(stderr.contains("team 'broken': its agents played in none of its 2 matches"), "{stderr}");
    let all = rows(&out_dir);
    assert_eq!(all.len(), 4);
    for row in all.iter().filter(|r| r["team"] == "broken") {
        assert_eq!(
            (row["completed"].as_bool(), row["crashed_agents"].as_u64()),
            (Some(false), Some(1)),
            "{row}"
        );
    }
    let log = out_dir.join("logs");
    assert!(log.is_dir(), "agent logs are kept");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("broken") && stdout.contains("matches_per_min"), "{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn flags_alone_describe_a_tournament_and_mistakes_are_named() {
    let dir = temp("flags");
    let out_dir = dir.join("out");
    bw4t(&[
        "tournament",
        "--map",
        "fixed",
        "--team",
        "coop=builtin",
        "--robots",
        "2",
        "--seeds",
        "2",
        "--out",
        out_dir.to_str().expect("utf-8"),
    ]);
    assert_eq!(rows(&out_dir).len(), 2);
    let cases: [(&[&str], &str); 4] = [
        (&["tournament"], "give a configuration file"),
        (&["tournament", "--map", "fixed", "--team", "coop"], "expected NAME=AGENTS"),
        (&["tournament", "--map", "fixed", "--team", "a=builtin", "--shard", "3/2"], "not i/n"),
        (
            &["tournament", "--map", "fixed", "--team", "a=builtin:magic", "--seeds", "1"],
            "unknown strategy 'magic'",
        ),
    ];
    for (args, expected) in cases {
        let out = Command::new(env!("CARGO_BIN_EXE_bw4t")).args(args).output().expect("run");
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(expected),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_agent_command_that_cannot_start_is_refused_before_any_match() {
    let dir = temp("preflight");
    let team = |agents: &str| {
        format!(
            "maps = [\"fixed\"]\nseeds = 2\n\n[[team]]\nname = \"good\"\nagents = \"builtin\"\n\n[[team]]\nname = \"typo\"\nagents = {agents}\nrobots = 1\n"
        )
    };
    let cases = [
        ("\"biultin\"", "team 'typo': agents \"biultin\" looks like a misspelt built-in team"),
        ("[\"builtin\", \"biultin:coop\"]", "team 'typo': agents \"biultin:coop\" looks like a misspelt"),
        (
            "\"no-such-agent-program --fast\"",
            "team 'typo': agents \"no-such-agent-program --fast\": program 'no-such-agent-program' is not found",
        ),
    ];
    for (agents, expected) in cases {
        let text =
            team(agents).replace("robots = 1\n", if agents.starts_with('[') { "" } else { "robots = 1\n" });
        let config = write_config(&dir, &text);
        let out_dir = dir.join("out");
        let out = Command::new(env!("CARGO_BIN_EXE_bw4t"))
            .args(["tournament", &config, "--out", out_dir.to_str().expect("utf-8")])
            .output()
            .expect("run");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{agents}: {stderr}");
        assert!(stderr.contains(expected), "{agents}: {stderr}");
        assert!(!out_dir.join("matches.jsonl").exists(), "{agents}: no match may run");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_map_with_fixed_content_over_many_seeds_is_warned_of_and_the_limits_are_named() {
    let dir = temp("fixed-content");
    let config = write_config(
        &dir,
        "maps = [\"rooms12\", \"fixed\"]\nseeds = 3\n\n[[team]]\nname = \"coop\"\nagents = \"builtin\"\nrobots = 2\n",
    );
    let out_dir = dir.join("out");
    let out = run_to(&config, &out_dir, &["--replays", "none"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("bw4t: warning: map 'rooms12' fixes its own seed"), "{stderr}");
    assert!(!stderr.contains("'fixed' fixes"), "{stderr}");
    // The warning is true: every seed plays the same match (the digest also covers the seed).
    let plays: std::collections::BTreeSet<String> = rows(&out_dir)
        .iter()
        .filter(|r| r["map"] == "rooms12")
        .map(|r| format!("{} {} {} {}", r["ticks"], r["completed_tick"], r["messages"], r["wrong_drops"]))
        .collect();
    assert_eq!(plays.len(), 1, "{plays:?}");
    let md = std::fs::read_to_string(out_dir.join("summary.md")).expect("summary.md");
    assert!(md.contains("**Warning:** map 'rooms12' fixes its own seed"), "{md}");
    assert!(md.contains("Tick limits: rooms12 20000 (derived from the map: one robot needs about"), "{md}");
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).expect("json"))
            .expect("json");
    assert_eq!(summary["setup"]["fixed_content_maps"], serde_json::json!(["rooms12"]));
    let limits = summary["setup"]["tick_limits"].as_array().expect("limits");
    assert!(limits.iter().all(|l| l["from"] == "map" && l["max_ticks"] == 20_000), "{limits:?}");
    // A limit from the configuration is reported as such.
    let given = dir.join("given");
    run_to(&config, &given, &["--replays", "none", "--max-ticks", "500", "--seeds", "1"]);
    let md = std::fs::read_to_string(given.join("summary.md")).expect("summary.md");
    assert!(md.contains("Tick limits: rooms12 500 (from the configuration); fixed 500"), "{md}");
    assert!(!md.contains("Warning"), "one seed: nothing to warn of\n{md}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_team_can_mix_builtin_and_external_agents() {
    let dir = temp("mixed");
    let config = write_config(
        &dir,
        "maps = [\"fixed\"]\nseeds = [2]\n\n[[team]]\nname = \"mixed\"\nagents = [\"builtin\", \"python3 tests/agents/tiny_agent.py\"]\n",
    );
    let out_dir = dir.join("out");
    run_to(&config, &out_dir, &["--replays", "none"]);
    let all = rows(&out_dir);
    assert_eq!(all.len(), 1);
    assert_eq!(
        (all[0]["robots"].as_u64(), all[0]["completed"].as_bool(), all[0]["crashed_agents"].as_u64()),
        (Some(2), Some(true), Some(0)),
        "{}",
        all[0]
    );
    let logs: Vec<String> = std::fs::read_dir(out_dir.join("logs").join("mixed_fixed_2_0"))
        .expect("the external agent's logs")
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect();
    assert_eq!(logs, ["Agent1.log"], "one external seat, one built-in");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ctrl_c_keeps_the_rows_and_prints_the_command_that_resumes() {
    use std::io::{BufRead, BufReader, Read};
    let dir = temp("interrupt");
    // The second team's agents wait for a gate file, so a match is under way when the
    // signal comes, however fast the machine.
    let gate = dir.join("gate");
    let script = dir.join("gated.sh");
    std::fs::write(
        &script,
        format!(
            "while [ ! -e '{}' ]; do sleep 0.05; done\nexec python3 tests/agents/tiny_agent.py\n",
            gate.display()
        ),
    )
    .expect("script");
    let config = write_config(
        &dir,
        &format!(
            "maps = [\"fixed\"]\nseeds = [2, 3]\n\n[[team]]\nname = \"coop\"\nagents = \"builtin\"\nrobots = 1\n\n[[team]]\nname = \"gated\"\nagents = \"sh {}\"\nrobots = 1\n",
            script.display()
        ),
    );
    let out_dir = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_bw4t"))
        .args(["tournament", &config, "--out", out_dir.to_str().expect("utf-8")])
        .args(["--concurrency", "1", "--replays", "none", "--connect-timeout-s", "100"])
        .current_dir(repo_root!())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start");
    let pid = child.id();
    let (finished, watch) = std::sync::mpsc::channel::<()>();
    std::thread::spawn(move || {
        // Fails the test (by ending the child) if it hangs; never its synchronisation.
        if watch.recv_timeout(LIMIT) == Err(std::sync::mpsc::RecvTimeoutError::Timeout) {
            let _ = Command::new("kill").args(["-KILL", &pid.to_string()]).status();
        }
    });
    let mut stderr = BufReader::new(child.stderr.take().expect("stderr"));
    let mut said = String::new();
    let mut line = String::new();
    while !line.starts_with("[1/4]") {
        line.clear();
        assert!(stderr.read_line(&mut line).expect("stderr") > 0, "ended before a row: {said}");
        said.push_str(&line);
    }
    let sent = Command::new("kill").args(["-INT", &pid.to_string()]).status().expect("kill");
    assert!(sent.success());
    stderr.read_to_string(&mut said).expect("stderr");
    let status = child.wait().expect("exit");
    let _ = finished.send(());
    assert_eq!(status.code(), Some(130), "{said}");
    assert_eq!(rows(&out_dir).len(), 1, "the first row is kept, the interrupted match is not: {said}");
    let resume = said
        .split("to play the rest, run:\n")
        .nth(1)
        .and_then(|rest| rest.lines().next())
        .map(str::trim)
        .unwrap_or_else(|| panic!("no resume command in: {said}"));
    assert!(resume.ends_with("--resume"), "{resume}");
    std::fs::write(&gate, "").expect("open the gate");
    let resumed = Command::new("sh")
        .args(["-c", resume])
        .current_dir(repo_root!())
        .output()
        .expect("run the resume command");
    let out = String::from_utf8_lossy(&resumed.stdout);
    assert!(resumed.status.success(), "{out}{}", String::from_utf8_lossy(&resumed.stderr));
    assert!(out.contains("(3 played now, 1 already done)"), "{out}");
    let all = rows(&out_dir);
    assert_eq!(all.len(), 4);
    assert!(all.iter().all(|r| r["completed"] == true), "{all:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_match_past_its_wall_budget_is_ended_and_its_row_says_so() {
    let dir = temp("budget");
    // A player that takes its seat and then never answers a tick: with no deadline, only
    // the budget ends its match.
    let silent = dir.join("silent.py");
    std::fs::write(
        &silent,
        "import json, os, socket, time\n\
         s = socket.create_connection((os.environ['BW4T_HOST'], int(os.environ['BW4T_PORT'])))\n\
         hello = {'type': 'hello', 'protocol': 'bw4t', 'versions': [1], 'name': os.environ['BW4T_NAME'], 'token': os.environ['BW4T_TOKEN']}\n\
         s.sendall((json.dumps(hello) + '\\n').encode())\n\
         time.sleep(600)\n",
    )
    .expect("agent");
    let config = write_config(
        &dir,
        &format!(
            "maps = [\"fixed\"]\nseeds = [2]\ndeadline_ms = 0\nwall_budget_s = 1\n\n[[team]]\nname = \"slow\"\nagents = [\"builtin\", \"python3 {}\"]\n",
            silent.display()
        ),
    );
    let out_dir = dir.join("out");
    run_to(&config, &out_dir, &["--replays", "none"]);
    let all = rows(&out_dir);
    assert_eq!(
        (all[0]["out_of_time"].as_bool(), all[0]["end_reason"].as_str(), all[0]["completed"].as_bool()),
        (Some(true), Some("interrupted"), Some(false)),
        "{}",
        all[0]
    );
    let csv = std::fs::read_to_string(out_dir.join("matches.csv")).expect("matches.csv");
    let header: Vec<&str> = csv.lines().next().expect("a header").split(',').collect();
    let columns = [
        "out_of_time",
        "tool_calls",
        "invalid_calls",
        "result_tokens",
        "think_ms",
        "prompt_tokens",
        "completion_tokens",
    ];
    for column in columns {
        assert!(header.contains(&column), "{column} in {header:?}");
    }
    let bad = write_config(
        &dir,
        "maps = [\"fixed\"]\nseeds = [2]\nwall_budget_s = 0\n\n[[team]]\nname = \"a\"\nagents = \"builtin\"\n",
    );
    let refused = crate::util::bw4t_within(
        &["tournament", &bad, "--out", dir.join("x").to_str().expect("utf-8")],
        LIMIT,
    );
    assert!(
        !refused.status.success() && String::from_utf8_lossy(&refused.stderr).contains("wall_budget_s"),
        "{}",
        String::from_utf8_lossy(&refused.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
