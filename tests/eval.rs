//! `bw4t eval` through the real binary: the committed reference rows of the easiest tier
//! reproduce from their seeds, an agent program is scored like a built-in, outcomes played
//! elsewhere score the same, and bad input is named.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

use serde_json::Value;

const LIMIT: Duration = Duration::from_secs(300);

fn bw4t(args: &[&str]) -> Output {
    crate::util::bw4t_within(args, LIMIT)
}

fn temp(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bw4t-eval-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The row a successful evaluation printed, checked against the one it wrote.
fn row_of(out: &Output, dir: &Path) -> Value {
    assert!(out.status.success(), "{}", stderr(out));
    let printed: Value = serde_json::from_slice(&out.stdout).expect("one JSON row on stdout");
    let written: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("row.json")).expect("row.json"))
            .expect("JSON");
    assert_eq!(printed, written);
    printed
}

/// A row without what legitimately differs between builds: the version.
fn comparable(mut row: Value) -> Value {
    row.as_object_mut().expect("an object").remove("bw4t_version");
    row
}

#[test]
fn the_reference_rows_of_the_easiest_tier_reproduce_from_their_seeds() {
    let text = std::fs::read_to_string(Path::new(repo_root!()).join("eval/reference.jsonl"))
        .expect("eval/reference.jsonl");
    let rows: Vec<Value> = text.lines().map(|l| serde_json::from_str(l).expect("a row")).collect();
    let solo: Vec<&Value> = rows.iter().filter(|r| r["tier"] == "solo").collect();
    assert_eq!(solo.len(), 10, "five agents on two splits");
    for (i, committed) in solo.into_iter().enumerate() {
        let (agent, split) = (
            committed["agent"]["command"].as_str().expect("present"),
            committed["split"].as_str().expect("present"),
        );
        let dir = temp(&format!("reference-{i}"));
        let out = bw4t(&[
            "eval",
            "solo",
            "--agent",
            agent,
            "--split",
            split,
            "--out",
            dir.to_str().expect("present"),
        ]);
        let row = row_of(&out, &dir);
        assert_eq!(comparable(row), comparable(committed.clone()), "{agent} on solo {split}");
        let _ = std::fs::remove_dir_all(dir);
    }
}

#[test]
fn an_agent_program_is_scored_against_the_built_in_team_and_outcomes_score_alike() {
    let dir = temp("program");
    let out = bw4t(&[
        "eval",
        "solo",
        "--agent",
        "python3 tests/agents/tiny_agent.py",
        "--name",
        "tiny",
        "--model",
        "none",
        "--out",
        dir.to_str().expect("present"),
        "--leaderboard",
        dir.join("board.jsonl").to_str().expect("present"),
    ]);
    let row = row_of(&out, &dir);
    assert_eq!(
        (row["tier"].as_str(), row["split"].as_str(), row["matches"].as_u64()),
        (Some("solo"), Some("dev"), Some(10))
    );
    assert_eq!(row["agent"]["name"], "tiny");
    assert_eq!(row["agent"]["model"], "none");
    assert_eq!(row["crashed_matches"], 0, "{}", stderr(&out));
    assert!(row["completion"].as_f64().expect("present") > 0.0, "the tiny agent completes: {row}");
    assert!(row["score"].as_f64().expect("present") > 0.0);
    assert_eq!(row["digest"].as_str().map(str::len), Some(64));
    let board = std::fs::read_to_string(dir.join("board.jsonl")).expect("the leaderboard");
    assert_eq!(serde_json::from_str::<Value>(board.trim()).expect("a row"), row);

    // The same matches as outcomes (what a Python evaluation writes) score the same.
    let rows = std::fs::read_to_string(dir.join("agent/matches.jsonl")).expect("the agent's rows");
    let outcomes: Vec<String> = rows
        .lines()
        .map(|line| {
            let r: Value = serde_json::from_str(line).expect("present");
            let ticks = if r["completed"] == true { r["completed_tick"].clone() } else { r["ticks"].clone() };
            serde_json::json!({"key": r["key"], "completed": r["completed"], "ticks": ticks, "digest": r["digest"]})
                .to_string()
        })
        .collect();
    let file = dir.join("outcomes.jsonl");
    std::fs::write(&file, outcomes.join("\n")).expect("present");
    let scored = dir.join("scored");
    let again = bw4t(&[
        "eval",
        "score",
        "solo",
        "--outcomes",
        file.to_str().expect("present"),
        "--agent",
        "python3 tests/agents/tiny_agent.py",
        "--name",
        "tiny",
        "--model",
        "none",
        "--out",
        scored.to_str().expect("present"),
    ]);
    assert_eq!(row_of(&again, &scored), row);

    // One outcome short: the missing match is named.
    std::fs::write(&file, outcomes[1..].join("\n")).expect("present");
    let short = bw4t(&[
        "eval",
        "score",
        "solo",
        "--outcomes",
        file.to_str().expect("present"),
        "--agent",
        "x",
        "--out",
        scored.to_str().expect("present"),
    ]);
    assert_eq!(short.status.code(), Some(1));
    let first_key: Value = serde_json::from_str(&outcomes[0]).expect("present");
    assert!(stderr(&short).contains(first_key["key"].as_str().expect("present")), "{}", stderr(&short));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn an_agent_that_never_plays_exits_4_and_bad_input_is_named() {
    let dir = temp("crash");
    let out = bw4t(&[
        "eval",
        "solo",
        "--agent",
        "false",
        "--connect-timeout-s",
        "2",
        "--out",
        dir.to_str().expect("present"),
    ]);
    assert_eq!(out.status.code(), Some(4), "{}", stderr(&out));
    assert!(stderr(&out).contains("played in none of its matches"), "{}", stderr(&out));
    let row: Value = serde_json::from_slice(&out.stdout).expect("the row is still written");
    assert_eq!((row["crashed_matches"].as_u64(), row["score"].as_f64()), (Some(10), Some(0.0)));

    for (args, says) in [
        (vec!["eval", "nope", "--agent", "builtin"], "unknown tier 'nope'"),
        (vec!["eval", "silent", "--agent", "builtin:coop"], "allows no messages"),
        (vec!["eval", "solo", "--agent", "biultin:coop"], "misspelt"),
        (vec!["eval", "solo"], "--agent is required"),
    ] {
        let out = bw4t(&args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert!(stderr(&out).contains(says), "{args:?}: {}", stderr(&out));
    }
    let out = bw4t(&["eval", "solo", "--agent", "builtin", "--split", "train"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("unknown split 'train'"), "{}", stderr(&out));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn tasks_list_every_match_with_its_seats_and_tick_limit() {
    let out = bw4t(&["eval", "tasks", "adhoc", "--split", "test", "--repetitions", "2"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let tasks: Vec<Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("present"))
        .collect();
    // Two maps, ten held-out seeds, three teammate mixes, two repetitions.
    assert_eq!(tasks.len(), 2 * 10 * 3 * 2);
    assert!(
        tasks.iter().all(|t| t["seats"][0] == "agent" && t["seats"].as_array().expect("present").len() == 3)
    );
    assert!(tasks.iter().any(|t| t["seats"][1] == "builtin:ignoring"), "held-out teammates");
    assert!(
        tasks.iter().all(|t| t["max_ticks"].as_u64().expect("present") >= 20_000 && t["messages"] == true)
    );
    let dev = bw4t(&["eval", "tasks", "adhoc"]);
    let dev_seeds: Vec<u64> = String::from_utf8_lossy(&dev.stdout)
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).expect("present")["seed"].as_u64().expect("present"))
        .collect();
    assert!(
        tasks.iter().all(|t| !dev_seeds.contains(&t["seed"].as_u64().expect("present"))),
        "held-out seeds"
    );
}

#[test]
fn the_guide_shows_the_tiers_and_reference_rows_as_they_are() {
    let root = Path::new(repo_root!());
    let guide = std::fs::read_to_string(root.join("docs/EVAL.md")).expect("docs/EVAL.md");
    let tiers = bw4t(&["eval", "tiers"]);
    assert!(tiers.status.success());
    let table = String::from_utf8_lossy(&tiers.stdout);
    assert!(guide.contains(table.trim()), "docs/EVAL.md lacks the output of `bw4t eval tiers`:\n{table}");
    let rows = std::fs::read_to_string(root.join("eval/reference.jsonl")).expect("reference rows");
    let mut shown = 0;
    for line in rows.lines() {
        let r: Value = serde_json::from_str(line).expect("a row");
        let number = |v: &Value, places: usize| v.as_f64().map_or("-".into(), |x| format!("{x:.places$}"));
        let interval = match r["score_interval"].as_array() {
            Some(i) => format!("{}-{}", number(&i[0], 3), number(&i[1], 3)),
            None => "-".into(),
        };
        let expected = format!(
            "| {} | {} | {} | {} | {interval} | {} | {} | {} |",
            r["tier"].as_str().expect("tier"),
            r["split"].as_str().expect("split"),
            r["agent"]["name"].as_str().expect("name"),
            number(&r["score"], 3),
            number(&r["completion"], 2),
            number(&r["mean_ticks"], 0),
            number(&r["reference_mean_ticks"], 0),
        );
        assert!(guide.contains(&expected), "docs/EVAL.md lacks the row {expected}");
        shown += 1;
    }
    let split_of = |line: &str| line.split('|').nth(2).map(str::trim).map(str::to_string);
    let table_rows = guide
        .lines()
        .filter(|l| l.starts_with("| ") && matches!(split_of(l).as_deref(), Some("dev" | "test")))
        .count();
    assert_eq!(table_rows, shown, "the guide's reference table has rows the file does not");
}
