//! `bw4t bench arena` on small figures: every line's fields and the invariants that do not
//! depend on timing (no lateness or speed is asserted).

use std::process::Command;

use serde_json::Value;

/// Runs `bw4t bench arena` with `args` and returns its lines, by kind.
fn bench_arena(args: &[&str]) -> Vec<Value> {
    let out = Command::new(env!("CARGO_BIN_EXE_bw4t"))
        .args(["bench", "arena"])
        .args(args)
        .output()
        .expect("run bw4t");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not a JSON line: {e}: {l}")))
        .collect()
}

fn number(line: &Value, field: &str) -> f64 {
    line[field].as_f64().unwrap_or_else(|| panic!("{field} is not a number: {line}"))
}

fn count(line: &Value, field: &str) -> u64 {
    line[field].as_u64().unwrap_or_else(|| panic!("{field} is not a count: {line}"))
}

/// Descriptors a run may leave open beyond those it started with: none are expected (the
/// counts are taken with the same runtimes up); one allows for a socket still closing.
const FD_SLACK: u64 = 1;

#[test]
fn realtime_matches_are_all_made_joined_and_measured() {
    let lines = bench_arena(&["--arena-kind", "realtime", "--arena-matches", "3", "--arena-seconds", "1"]);
    assert_eq!(lines.len(), 1, "{lines:?}");
    let line = &lines[0];
    assert_eq!((line["case"].as_str(), line["kind"].as_str()), (Some("arena"), Some("realtime")));
    assert_eq!(count(line, "matches"), 3);
    assert_eq!(count(line, "matches_started"), 3, "every match started: {line}");
    assert_eq!(count(line, "connections"), 9);
    assert_eq!(count(line, "players_welcomed"), 9, "every player joined its match by name: {line}");
    assert!(count(line, "ticks") > 0, "ticks were made in the window: {line}");
    for field in [
        "lateness_p50_ms",
        "lateness_p99_ms",
        "lateness_max_ms",
        "cpu_s_per_s",
        "server_cpu_s_per_s",
        "cpu_percent_per_match",
        "load_average_1m",
    ] {
        assert!(number(line, field) >= 0.0, "{field}: {line}");
    }
    assert!(number(line, "lateness_p50_ms") <= number(line, "lateness_max_ms"), "{line}");
    for field in ["skipped_ticks", "ticks_expected", "orders", "percepts_received", "kb_per_match"] {
        assert!(line[field].is_number(), "{field}: {line}");
    }
    assert!(number(line, "rss_start_mb") > 0.0 && number(line, "rss_connected_mb") > 0.0, "{line}");
    // Both ends of the 9 connections are in the process while the matches play.
    assert!(count(line, "fds_connected") >= count(line, "fds_matches") + 18, "{line}");
    assert!(count(line, "fds_end") <= count(line, "fds_start") + FD_SLACK, "every socket closed: {line}");
}

#[test]
fn a_study_load_has_people_talking_beside_built_in_teammates_and_measures_their_acks() {
    let lines = bench_arena(&["--arena-kind", "study", "--study-matches", "2", "--arena-seconds", "2"]);
    assert_eq!(lines.len(), 1, "{lines:?}");
    let line = &lines[0];
    assert_eq!(line["kind"].as_str(), Some("study"));
    assert_eq!((count(line, "matches"), count(line, "robots")), (2, 4));
    assert_eq!(count(line, "connections"), 4, "two people per match: {line}");
    assert_eq!(count(line, "matches_started"), 2, "the teammates are built in, so both started: {line}");
    assert!(count(line, "messages_sent") > 0 && count(line, "acks_measured") > 0, "{line}");
    let (p50, p99) = (number(line, "input_to_ack_p50_ms"), number(line, "input_to_ack_p99_ms"));
    assert!(0.0 < p50 && p50 <= p99, "{line}");
}

#[test]
fn lockstep_matches_run_on_one_and_on_two_workers() {
    let lines = bench_arena(&[
        "--arena-kind",
        "lockstep",
        "--arena-lockstep-matches",
        "2",
        "--arena-lockstep-ticks",
        "300",
        "--arena-lockstep-seconds",
        "0.5",
    ]);
    assert_eq!(lines.len(), 1, "{lines:?}");
    let line = &lines[0];
    assert_eq!((line["case"].as_str(), line["kind"].as_str()), (Some("arena"), Some("lockstep")));
    assert_eq!((count(line, "matches"), count(line, "max_ticks")), (2, 300));
    for workers in ["1_worker", "2_workers"] {
        let ended = count(line, &format!("matches_ended_{workers}"));
        // Both matches end at the latest when the measurement stops them.
        assert!(ended >= 2, "{workers}: {line}");
        assert!(count(line, &format!("completed_{workers}")) <= ended, "{workers}: {line}");
        // No match plays past its tick limit.
        let ticks = count(line, &format!("ticks_{workers}"));
        assert!(ticks > 0 && ticks <= ended * 300, "{workers}: {line}");
        assert!(number(line, &format!("ticks_per_s_{workers}")) > 0.0, "{workers}: {line}");
        assert!(number(line, &format!("worker_cpu_percent_{workers}")) >= 0.0, "{workers}: {line}");
    }
    assert!(number(line, "speedup") > 0.0, "{line}");
}

#[test]
fn a_short_soak_ends_matches_and_leaves_no_descriptor_open() {
    let lines = bench_arena(&[
        "--arena-kind",
        "soak",
        "--soak-seconds",
        "4",
        "--soak-players",
        "6",
        "--soak-churners",
        "6",
    ]);
    assert_eq!(lines.len(), 1, "{lines:?}");
    let line = &lines[0];
    assert_eq!((line["case"].as_str(), line["kind"].as_str()), (Some("arena"), Some("soak")));
    assert_eq!((count(line, "steady_players"), count(line, "churners")), (6, 6));
    assert!(count(line, "matches_ended") > 0, "{line}");
    assert_eq!(
        count(line, "matches_ended"),
        count(line, "steady_matches_ended") + count(line, "churn_matches_ended"),
        "{line}"
    );
    assert_eq!(count(line, "matches_failed"), 0, "{line}");
    assert!(count(line, "steady_joins") >= 6, "every well-behaved player joined: {line}");
    assert!(count(line, "joins") > 0 && count(line, "drops") + count(line, "leaves") > 0, "{line}");
    assert!(count(line, "reconnects") + count(line, "reconnects_refused") <= count(line, "drops"), "{line}");
    assert!(count(line, "steady_ticks") > 0, "{line}");
    for field in ["rss_start_mb", "rss_warm_mb", "rss_end_mb", "rss_after_mb"] {
        assert!(number(line, field) > 0.0, "{field}: {line}");
    }
    assert!(count(line, "fds_end") > count(line, "fds_start"), "connections were open at the end: {line}");
    assert!(count(line, "fds_after") <= count(line, "fds_start") + FD_SLACK, "every socket closed: {line}");
}

#[test]
fn too_few_descriptors_are_named_with_the_limit() {
    // 20 matches need 120 sockets: more than a limit of 64 allows.
    let out = Command::new("sh")
        .args(["-c", "ulimit -n 64 && exec \"$0\" bench arena --arena-kind realtime --arena-matches 20"])
        .arg(env!("CARGO_BIN_EXE_bw4t"))
        .output()
        .expect("run sh");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("the limit on open files is 64") && err.contains("ulimit -n"), "{err}");
}
