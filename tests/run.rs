use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

use serde_json::Value;

/// How long one `bw4t` invocation in these tests may take before it counts as hung.
const RUN_LIMIT: Duration = Duration::from_secs(90);

/// Runs `bw4t ARGS` from the repository root, failing the test if it does not end in time.
fn bw4t(args: &[&str]) -> Output {
    crate::util::bw4t_within(args, RUN_LIMIT)
}

/// The JSON a run printed, whatever its exit status (which says how the match went).
fn json_of(out: &Output) -> Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!("{e}: {}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
    })
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bw4t-run-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

const TINY_AGENT: &str = "python3 tests/agents/tiny_agent.py";

#[test]
fn run_without_options_plays_the_builtin_team_and_names_the_seed() {
    let out = bw4t(&["run"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(stderr.contains("map 'default'") && stderr.contains("rerun with --seed"), "{stderr}");
    assert!(
        stdout.contains("completed") && stdout.contains("sequence 6/6") && stdout.contains("Bot3"),
        "{stdout}"
    );
}

#[test]
fn run_json_reports_the_whole_result_and_is_reproducible() {
    let result = json_of(&bw4t(&["run", "--map", "fixed", "--seed", "5", "--json"]));
    for field in [
        "map",
        "seed",
        "robots",
        "completed",
        "ticks",
        "sim_seconds",
        "wall_ms",
        "sequence",
        "sequence_index",
        "good_drops",
        "wrong_drops",
        "messages",
        "per_robot",
        "digest",
        "agents",
    ] {
        assert!(result.get(field).is_some(), "no '{field}' in {result}");
    }
    assert_eq!(
        (result["completed"].as_bool(), result["robots"].as_u64(), result["seed"].as_u64()),
        (Some(true), Some(3), Some(5))
    );
    assert_eq!(result["good_drops"], 6);
    let agents = result["agents"].as_array().expect("agents");
    assert!(agents.iter().all(|a| a["kind"] == "builtin:coop" && a["status"] == "ok"), "{agents:?}");
    let again = json_of(&bw4t(&["run", "--map", "fixed", "--seed", "5", "--json"]));
    assert_eq!((&again["digest"], &again["ticks"]), (&result["digest"], &result["ticks"]));
    let baseline =
        json_of(&bw4t(&["run", "--map", "fixed", "--seed", "5", "--json", "--team", "builtin:baseline"]));
    assert_eq!(baseline["completed"], true);
    assert!(
        baseline["ticks"].as_u64() > result["ticks"].as_u64(),
        "teamwork shows: {} vs {}",
        baseline["ticks"],
        result["ticks"]
    );
}

#[test]
fn an_external_agent_completes_a_match_alone_and_beside_the_builtin_team() {
    let dir = temp_dir("tiny");
    let logs = dir.to_str().expect("utf-8");
    let alone = json_of(&bw4t(&[
        "run",
        "--map",
        "fixed",
        "--seed",
        "2",
        "--agent",
        TINY_AGENT,
        "--json",
        "--log-dir",
        logs,
    ]));
    assert_eq!(alone["completed"], true, "{alone}");
    let agent = &alone["agents"][0];
    assert_eq!((agent["kind"].as_str(), agent["status"].as_str()), (Some("external"), Some("ok")), "{agent}");
    assert!(Path::new(agent["log"].as_str().expect("log path")).is_file());
    let mixed = json_of(&bw4t(&[
        "run",
        "--map",
        "fixed",
        "--seed",
        "2",
        "--agent",
        TINY_AGENT,
        "--team",
        "builtin",
        "--robots",
        "3",
        "--json",
        "--log-dir",
        logs,
    ]));
    assert_eq!(mixed["completed"], true, "{mixed}");
    let kinds: Vec<&str> = mixed["agents"]
        .as_array()
        .expect("agents")
        .iter()
        .map(|a| a["kind"].as_str().unwrap_or(""))
        .collect();
    assert_eq!(kinds, ["external", "builtin:coop", "builtin:coop"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Python one-liner that joins properly, then does `then` (Python statements).
fn python_agent(then: &str) -> String {
    format!(
        "python3 -c 'import os,socket,json,time\ns=socket.create_connection((os.environ[\"BW4T_HOST\"],int(os.environ[\"BW4T_PORT\"])))\ns.sendall((json.dumps({{\"type\":\"hello\",\"protocol\":\"bw4t\",\"versions\":[1],\"name\":os.environ[\"BW4T_NAME\"],\"token\":os.environ[\"BW4T_TOKEN\"]}})+\"\\n\").encode())\n{then}'"
    )
}

#[test]
fn agents_that_crash_hang_talk_garbage_or_never_connect_get_clear_statuses() {
    let dir = temp_dir("bad");
    let hang = format!("sleep 62.31 & {}", python_agent("time.sleep(120)"));
    let garbage = python_agent("[s.sendall(b\"garbage\\n\") or time.sleep(0.01) for i in range(3000)]");
    let out = bw4t(&[
        "run",
        "--map",
        "fixed",
        "--seed",
        "1",
        "--json",
        "--max-ticks",
        "300",
        "--deadline-ms",
        "200",
        "--connect-timeout-s",
        "3",
        "--log-dir",
        dir.to_str().expect("utf-8"),
        "--team",
        "builtin",
        "--robots",
        "5",
        "--agent",
        "echo about to fail; exit 3",
        "--agent",
        &hang,
        "--agent",
        &garbage,
        "--agent",
        "sleep 61.73",
    ]);
    let result = json_of(&out);
    assert_eq!(out.status.code(), Some(4), "none of the external agents played");
    let status = |name: &str| {
        let agent = result["agents"].as_array().expect("agents").iter().find(|a| a["name"] == name).cloned();
        let agent = agent.unwrap_or_else(|| panic!("no agent {name}"));
        (agent["status"].as_str().unwrap_or("").to_string(), agent)
    };
    assert_eq!(status("Agent1").0, "crashed", "{}", status("Agent1").1);
    assert_eq!(status("Agent1").1["exit_code"], 3);
    assert_eq!(status("Agent2").0, "unresponsive", "{}", status("Agent2").1);
    assert_eq!(status("Agent3").0, "bad_protocol", "{}", status("Agent3").1);
    assert_eq!(status("Agent4").0, "never_connected", "{}", status("Agent4").1);
    let advice = status("Agent4").1["detail"].as_str().unwrap_or_default().to_string();
    assert!(advice.contains("BW4T_HOST") && advice.contains("bw4t mcp --served"), "{advice}");
    assert_eq!(status("Bot1").0, "ok");
    let log = std::fs::read_to_string(status("Agent1").1["log"].as_str().expect("log")).expect("log file");
    assert!(log.contains("about to fail"), "{log}");
    // The match went on without them, and nothing they started is left running.
    assert_eq!(result["end_reason"], "max_ticks");
    for marker in ["sleep 61.73", "sleep 62.31"] {
        let left = Command::new("pgrep").args(["-f", marker]).output().expect("pgrep");
        assert!(
            left.stdout.is_empty(),
            "'{marker}' is still running: {}",
            String::from_utf8_lossy(&left.stdout)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn replays_verify_and_a_tampered_one_names_the_tick() {
    let dir = temp_dir("replay");
    let headless = dir.join("headless.jsonl");
    let served = dir.join("served.jsonl");
    let out = bw4t(&["run", "--map", "fixed", "--seed", "3", "--replay", headless.to_str().expect("utf-8")]);
    assert!(out.status.success());
    let out = bw4t(&[
        "run",
        "--map",
        "fixed",
        "--seed",
        "2",
        "--agent",
        TINY_AGENT,
        "--team",
        "builtin",
        "--robots",
        "2",
        "--replay",
        served.to_str().expect("utf-8"),
        "--log-dir",
        dir.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for file in [&headless, &served] {
        let verify = bw4t(&["replay", "verify", file.to_str().expect("utf-8")]);
        assert!(verify.status.success(), "{}", String::from_utf8_lossy(&verify.stderr));
        assert!(String::from_utf8_lossy(&verify.stdout).starts_with("ok: all"));
        let show = bw4t(&["replay", "show", file.to_str().expect("utf-8")]);
        let text = String::from_utf8_lossy(&show.stdout);
        assert!(
            text.contains("map 'fixed'") && text.contains("sequence 6/6") && text.contains("verified"),
            "{text}"
        );
    }
    // Send one robot somewhere else at its first recorded goTo.
    let text = std::fs::read_to_string(&headless).expect("replay");
    let (line_no, line) = text.lines().enumerate().find(|(_, l)| l.contains("\"goTo\"")).expect("a goTo");
    let tick: u64 = serde_json::from_str::<Value>(line).expect("json")["tick"].as_u64().expect("tick");
    let place = ["RoomA1", "RoomB3"].into_iter().find(|p| !line.contains(p)).expect("another place");
    let changed = regex_free_replace_place(line, place);
    let tampered: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| if i == line_no { changed.clone() } else { l.to_string() })
        .collect();
    let bad = dir.join("tampered.jsonl");
    std::fs::write(&bad, tampered.join("\n")).expect("write");
    let verify = bw4t(&["replay", "verify", bad.to_str().expect("utf-8")]);
    assert_eq!(verify.status.code(), Some(EXIT_DIFFERS));
    let err = String::from_utf8_lossy(&verify.stderr);
    assert!(err.contains("differs at tick"), "{err}");
    let reported: u64 = err
        .split("differs at tick ")
        .nth(1)
        .and_then(|r| r.split(':').next())
        .and_then(|t| t.trim().parse().ok())
        .expect("a tick");
    assert!(reported > tick, "reported {reported}, tampered at {tick}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bw4t replay verify`'s exit status for a replay that differs, and for an incomplete one.
const EXIT_DIFFERS: i32 = 3;
const EXIT_INCOMPLETE: i32 = 4;

/// Records a headless match on the fixed map and returns the replay's lines.
fn recorded_replay(dir: &Path) -> Vec<String> {
    let file = dir.join("whole.jsonl");
    let out = bw4t(&["run", "--map", "fixed", "--seed", "3", "--replay", file.to_str().expect("utf-8")]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::read_to_string(&file).expect("replay").lines().map(str::to_string).collect()
}

fn tick_of(line: &str) -> u64 {
    serde_json::from_str::<Value>(line).expect("json")["tick"].as_u64().expect("tick")
}

#[test]
fn a_replay_cut_short_is_incomplete_not_ok() {
    let dir = temp_dir("replay-cut");
    let lines = recorded_replay(&dir);
    assert!(lines.last().expect("lines").contains("\"type\":\"end\""));
    let middle = lines.len() / 2;
    let torn = format!("{}\n{}", lines[..middle].join("\n"), &lines[middle][..lines[middle].len() / 2]);
    let cases = [
        ("header", format!("{}\n", lines[0]), 0),
        ("middle", format!("{}\n", lines[..middle].join("\n")), tick_of(&lines[middle - 1])),
        ("torn", torn, tick_of(&lines[middle - 1])),
    ];
    for (name, text, ticks) in cases {
        let file = dir.join(format!("{name}.jsonl"));
        std::fs::write(&file, text).expect("write");
        let verify = bw4t(&["replay", "verify", file.to_str().expect("utf-8")]);
        let said = String::from_utf8_lossy(&verify.stdout);
        assert_eq!(verify.status.code(), Some(EXIT_INCOMPLETE), "{name}: {said}");
        let expected = format!("incomplete: verified {ticks} of 20000 ticks, no end record");
        assert!(said.starts_with(&expected), "{name}: {said}");
        let show = bw4t(&["replay", "show", file.to_str().expect("utf-8")]);
        assert!(String::from_utf8_lossy(&show.stdout).contains(&expected), "{name}: show says so too");
    }
    // A complete replay without a tick limit in its header (as older files) is still ok.
    let unlimited = dir.join("unlimited.jsonl");
    let header = lines[0].replace(",\"max_ticks\":20000", "");
    assert_ne!(header, lines[0], "the header names its tick limit");
    std::fs::write(&unlimited, [&[header], &lines[1..]].concat().join("\n")).expect("write");
    let verify = bw4t(&["replay", "verify", unlimited.to_str().expect("utf-8")]);
    assert!(verify.status.success(), "{}", String::from_utf8_lossy(&verify.stderr));
    assert!(String::from_utf8_lossy(&verify.stdout).starts_with("ok: all"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_replay_of_a_killed_server_is_incomplete() {
    use std::io::{BufRead, BufReader, Write};
    use std::process::{Command, Stdio};
    let dir = temp_dir("replay-killed");
    let file = dir.join("served.jsonl");
    let mut server = Command::new(env!("CARGO_BIN_EXE_bw4t"))
        .args(["serve", "--port", "0", "--map", "fixed", "--seed", "4", "--builtin", "1", "--robots", "1"])
        .args(["--tick-hz", "200", "--max-ticks", "100000", "--replay", file.to_str().expect("utf-8")])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start bw4t serve");
    // The recorder flushes at every digest, before the tick's frames go out: watch the match
    // as a spectator until a frame shows tick 300 passed.
    let mut stdout = BufReader::new(server.stdout.take().expect("stdout"));
    let mut first = String::new();
    stdout.read_line(&mut first).expect("address line");
    let addr = first.trim().strip_prefix("listening on ").expect("listening on ADDR").to_string();
    let stream = std::net::TcpStream::connect(&addr).expect("connect");
    stream.set_read_timeout(Some(Duration::from_secs(30))).expect("timeout");
    let mut writer = stream.try_clone().expect("clone");
    writeln!(writer, r#"{{"type":"hello","protocol":"bw4t","versions":[1],"role":"spectator"}}"#)
        .expect("hello");
    let frames = BufReader::new(stream).lines().map(|l| l.expect("a frame within 30 s"));
    let past_300 = frames
        .filter_map(|l| serde_json::from_str::<Value>(&l).ok())
        .any(|m| m["type"] == "frame" && m["tick"].as_u64().is_some_and(|t| t > 300));
    assert!(past_300, "the match ended before tick 300");
    server.kill().expect("kill the server");
    server.wait().expect("the server ended");
    let text = std::fs::read_to_string(&file).expect("replay");
    let last =
        text.lines().filter_map(|l| serde_json::from_str::<Value>(l).ok()).next_back().expect("a line");
    let ticks = last["tick"].as_u64().expect("a tick");
    let verify = bw4t(&["replay", "verify", file.to_str().expect("utf-8")]);
    let said = String::from_utf8_lossy(&verify.stdout);
    assert_eq!(verify.status.code(), Some(EXIT_INCOMPLETE), "{said}");
    assert!(
        said.starts_with(&format!("incomplete: verified {ticks} of 100000 ticks, no end record")),
        "{said}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn replays_with_ticks_beyond_their_limits_are_refused_before_any_work() {
    let dir = temp_dir("replay-huge");
    let lines = recorded_replay(&dir);
    let last = lines.len() - 1;
    let tick_line = lines.iter().rposition(|l| l.contains("\"type\":\"tick\"")).expect("a tick line");
    let set_tick = |lines: &[String], at: usize, tick: u64| -> Vec<String> {
        let mut lines = lines.to_vec();
        let mut line: Value = serde_json::from_str(&lines[at]).expect("json");
        line["tick"] = tick.into();
        lines[at] = line.to_string();
        lines
    };
    let unlimited: Vec<String> = [&[lines[0].replace(",\"max_ticks\":20000", "")], &lines[1..]].concat();
    let cases = [
        (
            "tick",
            set_tick(&lines, tick_line, 1_000_000_000),
            tick_line,
            "tick 1000000000 is beyond the header's max_ticks 20000",
        ),
        (
            "end",
            set_tick(&lines, last, 1_000_000_000_000),
            last,
            "tick 1000000000000 is beyond the header's max_ticks 20000",
        ),
        (
            "unlimited",
            set_tick(&unlimited, tick_line, 1_000_000_000),
            tick_line,
            "tick 1000000000 skips the digest due at tick",
        ),
        ("back", set_tick(&lines, tick_line, 3), tick_line, "tick 3 goes back"),
    ];
    for (name, text, at, expected) in cases {
        let file = dir.join(format!("{name}.jsonl"));
        std::fs::write(&file, text.join("\n") + "\n").expect("write");
        let path = file.to_str().expect("utf-8");
        for command in [
            &["replay", "verify", path][..],
            &["replay", "show", path],
            &["replay", "view", path, "--http", "0"],
        ] {
            // Quickly: a hostile tick number must cost no work.
            let out = crate::util::bw4t_within(command, Duration::from_secs(10));
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{name} {command:?}: {err}");
            assert!(err.contains(&format!("line {}: {expected}", at + 1)), "{name} {command:?}: {err}");
            assert!(!String::from_utf8_lossy(&out.stdout).contains("http on"), "{name}: view served");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn regex_free_replace_place(line: &str, place: &str) -> String {
    let at = line.find("\"goTo\",\"args\":[\"").expect("goTo args") + "\"goTo\",\"args\":[\"".len();
    let end = at + line[at..].find('"').expect("end of place");
    format!("{}{place}{}", &line[..at], &line[end..])
}

#[test]
fn run_refuses_bad_options() {
    let cases: [(&[&str], &str); 4] = [
        (&["run", "--team", "builtin:genius"], "unknown strategy 'genius'"),
        (&["run", "--team", "solo"], "expected builtin or builtin:STRATEGY"),
        (&["run", "--robots", "40"], "40 robots but map 'default' has 12 spawn points"),
        (&["run", "--robots", "0"], "at least one robot"),
    ];
    for (args, expected) in cases {
        let out = bw4t(args);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(expected),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[test]
fn bench_match_reports_matches_per_second() {
    let out = bw4t(&["bench", "match", "--matches", "3"]);
    let line = json_of(&out);
    assert_eq!(
        (line["case"].as_str(), line["matches"].as_u64(), line["completed"].as_u64()),
        (Some("match"), Some(3), Some(3))
    );
    assert!(
        line["matches_per_s"].as_f64().is_some_and(|m| m > 0.0)
            && line["median_ticks"].as_u64().is_some_and(|t| t > 0)
    );
}

#[test]
fn bench_scale_reports_ticks_per_second_on_small_and_largest_maps() {
    let out = bw4t(&["bench", "scale", "--scale-ticks", "20"]);
    let lines: Vec<Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    // Rooms, robots and ticks of each line.
    let cases: Vec<[u64; 3]> = lines
        .iter()
        .inspect(|l| assert_eq!(l["case"], "scale", "{l}"))
        .map(|l| ["rooms", "robots", "ticks"].map(|k| l[k].as_u64().unwrap_or(0)))
        .collect();
    let largest = (bw4t_map::MAX_ROWS * bw4t_map::MAX_COLUMNS) as u64;
    assert_eq!(cases, [[100, 100, 20], [largest, 10, 20], [largest, 30, 20], [largest, 100, 20]]);
    for line in &lines {
        assert!(line["ticks_per_s"].as_f64().is_some_and(|t| t > 0.0), "{line}");
        assert!(line["ms_per_tick"].as_f64().is_some_and(|t| t > 0.0), "{line}");
    }
}

/// Runs `bw4t ARGS` with extra environment variables, bounded like [`bw4t`].
fn bw4t_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_bw4t"));
    command.args(args).current_dir(repo_root!()).envs(env.iter().copied());
    crate::util::output_within(command, RUN_LIMIT, &format!("bw4t {args:?}"))
}

#[test]
fn the_exit_status_tells_completed_not_completed_no_agent_and_errors_apart() {
    let dir = temp_dir("status");
    let logs = dir.to_str().expect("utf-8");
    let code = |args: &[&str]| bw4t(args).status.code();
    assert_eq!(code(&["run", "--map", "fixed", "--seed", "1"]), Some(0), "completed");
    assert_eq!(code(&["run", "--map", "fixed", "--seed", "1", "--max-ticks", "100"]), Some(3), "tick limit");
    let crashing = ["--agent", "echo giving up; exit 3", "--connect-timeout-s", "5", "--log-dir", logs];
    let alone = [&["run", "--map", "fixed", "--seed", "1", "--max-ticks", "200"][..], &crashing].concat();
    assert_eq!(code(&alone), Some(4), "the only agent crashed");
    // Beside a built-in team that completes the match, an agent that never played still shows.
    let beside =
        [&["run", "--map", "fixed", "--seed", "1", "--team", "builtin", "--robots", "3"][..], &crashing]
            .concat();
    let out = bw4t(&beside);
    assert_eq!(out.status.code(), Some(4), "{}", String::from_utf8_lossy(&out.stdout));
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("completed"));
    assert_eq!(code(&["run", "--team", "builtin:genius"]), Some(1), "bad option value");
    assert_eq!(code(&["run", "--agent", "no-such-program-here"]), Some(1), "agent cannot start");
    assert_eq!(code(&["run", "--no-such-flag"]), Some(2), "unreadable command line");
    let help = String::from_utf8_lossy(&bw4t(&["run", "--help"]).stdout).into_owned();
    assert!(
        help.contains("Exit status: 0 the match completed") && help.contains("3 the match did not complete"),
        "{help}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn completed_tick_and_wall_ms_mean_the_same_in_the_percepts_match_end_and_run_json() {
    let dir = temp_dir("meaning");
    let record = dir.join("seen.json");
    let out = bw4t_env(
        &[
            "run",
            "--map",
            "fixed",
            "--seed",
            "2",
            "--agent",
            TINY_AGENT,
            "--json",
            "--log-dir",
            dir.to_str().expect("utf-8"),
        ],
        &[("TINY_AGENT_RECORD", record.to_str().expect("utf-8"))],
    );
    let result = json_of(&out);
    let seen: Value =
        serde_json::from_str(&std::fs::read_to_string(&record).expect("the agent's record")).expect("json");
    let length = result["sequence"].as_array().expect("sequence").len() as u64;
    let first_complete = seen["percepts"]
        .as_array()
        .expect("percepts")
        .iter()
        .find(|p| p[1].as_u64() == Some(length))
        .and_then(|p| p[0].as_u64())
        .expect("percepts showing the sequence complete");
    assert_eq!(
        result["completed_tick"].as_u64(),
        Some(first_complete),
        "completed_tick is the tick the player saw it"
    );
    let end = &seen["result"];
    for field in ["completed_tick", "ticks", "wall_ms", "digest", "completed"] {
        assert_eq!(result[field], end[field], "{field}: run --json and match_end differ");
    }
    // Headless matches use the same meaning: completion shows in the last tick.
    let headless = json_of(&bw4t(&["run", "--map", "fixed", "--seed", "2", "--json"]));
    assert_eq!(headless["completed_tick"], headless["ticks"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_default_tick_limit_follows_the_map_so_one_robot_finishes_a_large_one() {
    let dir = temp_dir("limit");
    let file = dir.join("large.toml");
    let path = file.to_str().expect("utf-8");
    let made = bw4t(&["map", "generate", "--rooms", "26x40", "--robots", "1", "-o", path]);
    assert!(made.status.success(), "{}", String::from_utf8_lossy(&made.stderr));
    let map = bw4t_map::Map::from_native(&std::fs::read_to_string(&file).expect("map")).expect("valid");
    let expected = bw4t_runner::TickLimit::for_map(&map, &bw4t_sim::MatchConfig::default());
    assert!(expected.ticks > 20_000, "{expected:?}");
    let out = bw4t(&["run", "--map", path, "--seed", "1", "--robots", "1"]);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{stdout}{stderr}");
    let ticks: u64 = stdout
        .strip_prefix("completed after ")
        .and_then(|rest| rest.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(ticks > 20_000, "one robot needs more than the old fixed limit here: {ticks}");
    assert!(stdout.contains(&format!("tick limit {}: derived from the map", expected.ticks)), "{stdout}");
    assert!(stderr.contains(&format!("tick limit {}", expected.ticks)), "{stderr}");
    // A small map keeps the customary limit, and says so; a given limit wins.
    let small = json_of(&bw4t(&["run", "--map", "fixed", "--seed", "1", "--json"]));
    assert_eq!((small["max_ticks"].as_u64(), small["max_ticks_from"].as_str()), (Some(20_000), Some("map")));
    let given = json_of(&bw4t(&["run", "--map", "fixed", "--seed", "1", "--json", "--max-ticks", "9"]));
    assert_eq!((given["max_ticks"].as_u64(), given["ticks"].as_u64()), (Some(9), Some(9)));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn replay_trajectories_writes_each_robots_file_and_refuses_a_replay_that_does_not_verify() {
    let dir = temp_dir("trajectories");
    let replay = dir.join("m.jsonl");
    let out = bw4t(&[
        "run",
        "--map",
        "fixed",
        "--seed",
        "3",
        "--robots",
        "2",
        "--replay",
        replay.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let export = dir.join("export");
    let args =
        ["replay", "trajectories", replay.to_str().expect("utf-8"), "--out", export.to_str().expect("utf-8")];
    let done = bw4t(&args);
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    let meta: Value =
        serde_json::from_str(&std::fs::read_to_string(export.join("m/meta.json")).expect("meta"))
            .expect("json");
    let robots = meta["robots"].as_array().expect("robots");
    assert_eq!(robots.len(), 2);
    for robot in robots {
        let file = export.join("m").join(robot["file"].as_str().expect("file"));
        let text = std::fs::read_to_string(&file).expect("a robot's file");
        assert_eq!(text.lines().count() as u64, robot["lines"].as_u64().expect("lines"));
    }
    // A replay changed after it was written is refused, named, with the tick it differs at.
    let text = std::fs::read_to_string(&replay).expect("replay");
    let line = text.lines().find(|l| l.contains("\"goTo\"")).expect("a goTo");
    let place = ["RoomA1", "RoomB3"].into_iter().find(|p| !line.contains(p)).expect("another place");
    let bad = dir.join("bad.jsonl");
    std::fs::write(&bad, text.replacen(line, &regex_free_replace_place(line, place), 1)).expect("write");
    let refused = bw4t(&[
        "replay",
        "trajectories",
        bad.to_str().expect("utf-8"),
        "--out",
        export.to_str().expect("utf-8"),
    ]);
    assert_eq!(refused.status.code(), Some(1));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("bad.jsonl") && err.contains("does not verify") && err.contains("differs at tick"),
        "{err}"
    );
    assert!(!export.join("bad").exists(), "nothing written for a refused replay");
    // A format that does not exist is a command line clap refuses.
    let wrong =
        bw4t(&["replay", "trajectories", replay.to_str().expect("utf-8"), "--out", "x", "--format", "csv"]);
    assert_eq!(wrong.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}
