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

fn json_of(out: &Output) -> Value {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stdout)))
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
    assert!(!verify.status.success());
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

/// The line with the first goTo's place replaced by `place`.
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
fn bench_scale_reports_ticks_per_second_with_100_robots() {
    let line = json_of(&bw4t(&["bench", "scale", "--scale-ticks", "20"]));
    assert_eq!(
        (line["case"].as_str(), line["robots"].as_u64(), line["ticks"].as_u64()),
        (Some("scale"), Some(100), Some(20))
    );
    assert!(line["ticks_per_s"].as_f64().is_some_and(|t| t > 0.0), "{line}");
}
