use std::process::{Command, Output};

fn bw4t(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bw4t")).args(args).output().expect("run bw4t")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn bench_sim_prints_one_json_object_per_case() {
    let out = bw4t(&["bench", "sim", "--ticks", "300"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON object per line"))
        .collect();
    assert_eq!(lines.len(), 2);
    for (line, robots) in lines.iter().zip([3, 10]) {
        assert_eq!(line["case"], "sim");
        assert_eq!(line["robots"], robots);
        assert_eq!(line["ticks"], 300);
        assert!(line["ticks_per_s"].as_f64().is_some_and(|t| t > 0.0), "{line}");
        assert!(line["moves"].as_u64().is_some_and(|m| m > 0), "{line}");
    }
}

#[test]
fn bad_input_gets_a_clear_error() {
    let cases: [(&[&str], &str); 3] = [
        (&["bench", "sim", "--ticks", "ten"], "invalid value 'ten'"),
        (&["bench", "--map", "nowhere", "--ticks", "1"], "no map file 'nowhere' and no built-in map"),
        (&["bench", "teleport"], "invalid value 'teleport'"),
    ];
    for (args, expected) in cases {
        let out = bw4t(args);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr(&out).contains(expected), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn a_broken_map_file_is_named_in_the_error() {
    let dir = std::env::temp_dir().join(format!("bw4t-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("broken.toml");
    std::fs::write(&path, "area = [10, 10]\n[[zone]]\nname = \"A\"\n").expect("write");
    let out = bw4t(&["bench", "--map", path.to_str().expect("utf-8 path"), "--ticks", "1"]);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("broken.toml is not a valid map") && err.contains("missing field `type`"), "{err}");
}

#[test]
fn help_describes_the_commands() {
    let out = bw4t(&["--help"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("bench"));
    let out = bw4t(&["replay", "verify", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    for status in ["0  ok", "1  the file cannot be read", "3  the re-simulation differs", "4  incomplete"] {
        assert!(help.contains(status), "verify's exit statuses: {help}");
    }
}

fn json_lines(out: &Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON object per line"))
        .collect()
}

#[test]
fn bench_lockstep_and_realtime_report_their_figures() {
    let out = bw4t(&["bench", "lockstep", "--lockstep-ticks", "200"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let lines = json_lines(&out);
    let players: Vec<u64> = lines.iter().map(|l| l["players"].as_u64().expect("players")).collect();
    assert_eq!(players, [1, 3, 10]);
    for line in &lines {
        assert_eq!(line["ticks"], 200, "every tick is played: {line}");
        assert!(
            line["ticks_per_s"].as_f64().is_some_and(|t| t > 0.0) && line["rtt_us"].as_u64().is_some(),
            "{line}"
        );
    }
    let out = bw4t(&["bench", "realtime", "--realtime-seconds", "0.5"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let line = &json_lines(&out)[0];
    assert_eq!((line["case"].as_str(), line["robots"].as_u64()), (Some("realtime"), Some(100)));
    assert!(
        line["cpu_percent"].as_f64().is_some() && line["percepts_received"].as_u64().is_some_and(|n| n > 0),
        "{line}"
    );
}

#[test]
fn bench_env_reports_steps_per_second_and_memory() {
    let out = bw4t(&["bench", "env", "--env-steps", "2"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let lines = json_lines(&out);
    assert_eq!(lines[0]["case"], "env_memory", "{lines:?}");
    assert!(lines[0]["kb_per_env"].as_f64().is_some_and(|kb| kb > 0.0), "{}", lines[0]);
    let runs: Vec<(u64, u64, u64)> = lines[1..]
        .iter()
        .map(|l| {
            let number = |key: &str| l[key].as_u64().unwrap_or_else(|| panic!("{key} in {l}"));
            (number("envs"), number("threads"), number("ticks_per_step"))
        })
        .collect();
    assert_eq!(
        runs,
        [
            (1, 1, 10),
            (1, 1, 1),
            (1, 1, 10),
            (64, 1, 10),
            (64, 2, 10),
            (256, 1, 10),
            (256, 2, 10),
            (256, 2, 1)
        ]
    );
    for line in &lines[1..] {
        let steps = line["steps"].as_u64().expect("steps") * line["envs"].as_u64().expect("envs");
        assert_eq!(
            line["agent_steps"].as_u64(),
            Some(steps * line["agents"].as_u64().expect("agents")),
            "{line}"
        );
        assert!(line["agent_steps_per_s"].as_f64().is_some_and(|r| r > 0.0), "{line}");
    }
}

/// Starts `serve` (a `bw4t serve` command), connects to the address it prints and says
/// `hello` as Ann; returns the child and the connection (reads time out after 20 s).
fn serve_and_say_hello(mut serve: Command) -> (std::process::Child, std::net::TcpStream) {
    use std::io::{BufRead, BufReader, Write};
    let mut child = serve
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("start bw4t serve");
    let mut stdout = BufReader::new(child.stdout.take().expect("stdout"));
    let mut first = String::new();
    stdout.read_line(&mut first).expect("address line");
    let addr = first.trim().strip_prefix("listening on ").expect("listening on ADDR").to_string();
    let stream = std::net::TcpStream::connect(&addr).expect("connect");
    stream.set_read_timeout(Some(std::time::Duration::from_secs(20))).expect("timeout");
    let mut writer = stream.try_clone().expect("clone");
    writeln!(writer, r#"{{"type":"hello","protocol":"bw4t","versions":[1],"name":"Ann"}}"#).expect("hello");
    (child, stream)
}

/// `bw4t serve` as a user runs it: prints its address, plays, stops on SIGTERM, exits 0
/// and writes the result file.
#[test]
fn serve_runs_until_terminated_and_writes_its_result() {
    use std::io::{BufRead, BufReader};
    let dir = std::env::temp_dir().join(format!("bw4t-serve-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let results = dir.join("result.json");
    let mut serve = Command::new(env!("CARGO_BIN_EXE_bw4t"));
    serve
        .args(["serve", "--port", "0", "--map", "fixed", "--seed", "9", "--mode", "lockstep", "--results"])
        .arg(&results);
    let (mut child, stream) = serve_and_say_hello(serve);
    let mut reader = BufReader::new(stream);
    let mut line = String::new();
    reader.read_line(&mut line).expect("welcome");
    assert!(line.contains("\"welcome\""), "{line}");
    let status = Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().expect("kill");
    assert!(status.success());
    let mut rest = String::new();
    while reader.read_line(&mut line).is_ok_and(|n| n > 0) {
        rest.push_str(&line);
        line.clear();
    }
    assert!(rest.contains("\"match_end\"") && rest.contains("\"bye\""), "{rest}");
    let exit = child.wait().expect("exit");
    assert!(exit.success(), "{exit:?}");
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&results).expect("result file")).expect("json");
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(
        (result["end_reason"].as_str(), result["seed"].as_u64(), result["map"].as_str()),
        (Some("interrupted"), Some(9), Some("fixed"))
    );
}

/// A server whose output reader has gone (a supervisor, a `tee` that died) still stops on
/// SIGTERM and files its match as interrupted: a log line it cannot write is dropped.
#[test]
fn serve_whose_output_reader_is_gone_still_stops_on_sigterm() {
    use std::io::{BufRead, BufReader};
    let dir = std::env::temp_dir().join(format!("bw4t-serve-gone-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let results = dir.join("result.json");
    let mut serve = Command::new(env!("CARGO_BIN_EXE_bw4t"));
    serve.args(["serve", "--port", "0", "--map", "fixed", "--seed", "4", "-v", "--results"]).arg(&results);
    let (mut child, stream) = serve_and_say_hello(serve);
    let mut reader = BufReader::new(stream);
    let mut line = String::new();
    reader.read_line(&mut line).expect("welcome");
    // The reader of standard output and error goes away: every later write fails.
    drop(child.stderr.take());
    let status = Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().expect("kill");
    assert!(status.success());
    let mut rest = String::new();
    while reader.read_line(&mut line).is_ok_and(|n| n > 0) {
        rest.push_str(&line);
        line.clear();
    }
    if !rest.contains("\"match_end\"") {
        let _ = child.kill();
        panic!("the server did not end its match on SIGTERM: {rest}");
    }
    let exit = child.wait().expect("exit");
    let result = std::fs::read_to_string(&results).expect("result file");
    let _ = std::fs::remove_dir_all(&dir);
    assert!(exit.success(), "{exit:?}");
    assert!(result.contains("\"end_reason\": \"interrupted\""), "{result}");
}

#[test]
fn serve_refuses_bad_options() {
    let cases: [(&[&str], &str); 6] = [
        (&["serve", "--mode", "warp"], "invalid value 'warp'"),
        (&["serve", "--robots", "50", "--port", "0"], "map 'default' has 12 spawn points"),
        (&["serve", "--tick-hz", "0", "--port", "0"], "bad --tick-hz"),
        // A realtime match this fast would have a tick period of zero.
        (&["serve", "--tick-hz", "2000000000", "--port", "0"], "must be from 1 to 1000, got 2000000000"),
        // A grace the clock cannot add, an allowance of no actions at all.
        (&["serve", "--grace-s", "99999999999", "--port", "0"], "the reconnect grace must be from"),
        (&["serve", "--max-actions", "0", "--port", "0"], "actions per tick must be from 1 to 1000, got 0"),
    ];
    for (args, expected) in cases {
        let out = bw4t(args);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr(&out).contains(expected), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn map_generate_makes_a_map_that_checks_clean_and_refuses_bad_sizes() {
    let dir = std::env::temp_dir().join(format!("bw4t-generate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let file = dir.join("g.toml");
    let out = bw4t(&[
        "map",
        "generate",
        "--rooms",
        "2x5",
        "--robots",
        "7",
        "--seed",
        "3",
        "-o",
        file.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let check = bw4t(&["map", "check", file.to_str().expect("utf-8"), "--robots", "7"]);
    assert!(check.status.success(), "{}{}", String::from_utf8_lossy(&check.stdout), stderr(&check));
    let map = bw4t_map::Map::from_native(&std::fs::read_to_string(&file).expect("read")).expect("valid");
    let rooms = map.zones().iter().filter(|z| z.name.starts_with("Room")).count();
    assert_eq!((rooms, map.spawns().len()), (10, 7));
    let again = bw4t(&["map", "generate", "--rooms", "2x5", "--robots", "7", "--seed", "3"]);
    assert_eq!(
        String::from_utf8_lossy(&again.stdout),
        std::fs::read_to_string(&file).expect("read"),
        "same seed, same map"
    );
    let _ = std::fs::remove_dir_all(&dir);
    for (rooms, expected) in [
        ("0x3", "expected ROWSxCOLUMNS"),
        ("3by4", "expected ROWSxCOLUMNS"),
        ("41x3", "rooms must be 1x1 to"),
    ] {
        let out = bw4t(&["map", "generate", "--rooms", rooms]);
        assert!(!out.status.success() && stderr(&out).contains(expected), "{rooms}: {}", stderr(&out));
    }
}

/// Runs `bw4t ARGS` with standard output a pipe whose reading end is closed after
/// `lines_read` lines (with 0, before bw4t starts, so that even a short output cannot slip
/// into the pipe first), and returns how it ended and what it said on standard error.
fn with_closed_stdout(args: &[&str], lines_read: usize) -> (std::process::ExitStatus, String) {
    use std::io::{BufRead, BufReader, Read};
    use std::process::Stdio;
    let (reader, writer) = std::io::pipe().expect("a pipe");
    let mut command = Command::new(env!("CARGO_BIN_EXE_bw4t"));
    command.args(args).current_dir(repo_root!()).stderr(Stdio::piped());
    if lines_read == 0 {
        drop(reader);
        command.stdout(writer);
    } else {
        command.stdout(Stdio::piped());
    }
    let mut child = command.spawn().expect("start bw4t");
    if lines_read > 0 {
        let mut stdout = BufReader::new(child.stdout.take().expect("stdout"));
        for _ in 0..lines_read {
            let mut line = String::new();
            stdout.read_line(&mut line).expect("a line");
        }
    }
    // The command holds the pipe's writing end; dropping it leaves the child the only writer.
    drop(command);
    let mut stderr = child.stderr.take().expect("stderr");
    let pid = child.id();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut text = String::new();
        let _ = stderr.read_to_string(&mut text);
        let _ = tx.send((child.wait(), text));
    });
    match rx.recv_timeout(std::time::Duration::from_secs(120)) {
        Ok((status, text)) => (status.expect("exit status"), text),
        Err(_) => {
            let _ = Command::new("kill").args(["-KILL", &pid.to_string()]).status();
            panic!("bw4t {args:?} did not end after its output was closed");
        }
    }
}

#[test]
fn output_into_a_closed_pipe_ends_quietly_with_the_sigpipe_status() {
    let dir = std::env::temp_dir().join(format!("bw4t-pipe-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.join("t");
    let cases: [(&[&str], usize); 6] = [
        (&["bench", "sim", "--ticks", "50"], 0),
        (&["run", "--map", "fixed", "--seed", "1"], 0),
        (&["run", "--map", "fixed", "--seed", "1", "--json"], 0),
        (&["map", "show", "default"], 0),
        // Far more than a pipe holds, so the write fails after the first line is read.
        (&["map", "generate", "--rooms", "26x40"], 1),
        (
            &[
                "tournament",
                "--map",
                "fixed",
                "--team",
                "a=builtin",
                "--seeds",
                "1",
                "--out",
                out.to_str().expect("utf-8"),
            ],
            0,
        ),
    ];
    for (args, lines) in cases {
        let (status, stderr) = with_closed_stdout(args, lines);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert_eq!(status.code(), Some(141), "{args:?}: {status:?} {stderr}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_configuration_error_is_said_once_and_counts_read_as_english() {
    let dir = std::env::temp_dir().join(format!("bw4t-once-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let config = dir.join("t.toml");
    std::fs::write(&config, "maps = [\"fixed\"]\nseeds = 2\nmax_tick = 5\n").expect("write");
    let out = bw4t(&["tournament", config.to_str().expect("utf-8")]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.matches("unknown field `max_tick`").count(), 1, "{err}");
    let run = bw4t(&["run", "--map", "fixed", "--seed", "1", "--robots", "1"]);
    let (text, err) = (String::from_utf8_lossy(&run.stdout), stderr(&run));
    assert!(err.contains(", 1 robot,") && !err.contains("1 robots"), "{err}");
    assert!(text.starts_with("completed after ") && !text.contains("(completed)"), "{text}");
    let tournament = bw4t(&[
        "tournament",
        "--map",
        "fixed",
        "--team",
        "a=builtin",
        "--seeds",
        "1",
        "--out",
        dir.join("out").to_str().expect("utf-8"),
    ]);
    assert!(tournament.status.success(), "{}", stderr(&tournament));
    assert!(String::from_utf8_lossy(&tournament.stdout).contains("\n1 match (1 played now"));
    let md = std::fs::read_to_string(dir.join("out").join("summary.md")).expect("summary");
    assert!(md.contains("**1 match**, ") && md.contains("1 team on 1 map,"), "{md}");
    let svg = std::fs::read_to_string(dir.join("out").join("summary.svg")).expect("chart");
    assert!(svg.contains("1 match on 1 map,"), "{svg}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bw4t serve` without `--max-ticks` tells players the map's own limit in `welcome`.
#[test]
fn serve_gives_the_map_s_tick_limit_by_default() {
    use std::io::{BufRead, BufReader};
    let mut serve = Command::new(env!("CARGO_BIN_EXE_bw4t"));
    serve.args(["serve", "--port", "0", "--map", "fixed", "--seed", "9", "--mode", "lockstep"]);
    let (child, stream) = serve_and_say_hello(serve);
    let mut line = String::new();
    BufReader::new(stream).read_line(&mut line).expect("welcome");
    let _ = Command::new("kill").arg("-TERM").arg(child.id().to_string()).status();
    let out = child.wait_with_output().expect("exit");
    let welcome: serde_json::Value = serde_json::from_str(&line).expect("json");
    assert_eq!(welcome["match"]["max_ticks"], 20_000, "{line}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("tick limit 20000, derived from the map: one robot needs about")
            && err.contains("for 1 player"),
        "{err}"
    );
}

/// A server configuration with a mistake is refused before anything is served, with the
/// file, the template and the key named; match options cannot be mixed with `--config`.
#[test]
fn serve_refuses_a_bad_configuration_naming_the_problem() {
    let dir = std::env::temp_dir().join(format!("bw4t-arena-config-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let cases = [
        ("[[template]]\nname = \"lab\"\ncolour = 1\n", "unknown field `colour`"),
        ("[[template]]\nname = \"lab\"\non_end = \"forever\"\n", "template 'lab': on_end = 'forever'"),
        ("[[template]]\nname = \"lab\"\nfill = true\n", "fill = true needs start_timeout_s"),
        ("[[template]]\nname = \"lab\"\nrobots = 2\nbuiltin = 3\n", "builtin = 3 but robots = 2"),
        ("[[template]]\nname = \"lab\"\nmap = \"nowhere\"\n", "nowhere"),
        (
            "[[template]]\nname = \"a\"\nnames = [\"x\"]\n[[template]]\nname = \"b\"\nnames = [\"x\"]\n",
            "two matches are named 'x'",
        ),
        ("default = \"lab\"\n", "no [[template]]"),
    ];
    for (i, (text, expected)) in cases.iter().enumerate() {
        let file = dir.join(format!("arena{i}.toml"));
        std::fs::write(&file, text).expect("write");
        let out = bw4t(&["serve", "--port", "0", "--config", file.to_str().expect("utf-8")]);
        assert_eq!(out.status.code(), Some(1), "{text}: {}", stderr(&out));
        let err = stderr(&out);
        assert!(err.contains(expected), "{text}: {err}");
        if *expected != "two matches are named 'x'" {
            assert!(err.contains(&format!("arena{i}.toml")), "the file is named: {err}");
        }
    }
    let file = dir.join("arena0.toml");
    let out = bw4t(&["serve", "--port", "0", "--map", "fixed", "--config", file.to_str().expect("utf-8")]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("cannot be used with"), "{}", stderr(&out));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bw4t serve --once` exits when its match ends; without it the match starts again, so
/// a second visitor finds a match where the first saw one end.
#[test]
fn serve_once_exits_after_its_match_and_otherwise_starts_it_again() {
    use std::io::{BufRead, BufReader, Write};
    // One match of a built-in robot, ending at tick 30.
    const MATCH: [&str; 8] = ["--port", "0", "--map", "fixed", "--builtin", "1", "--max-ticks", "30"];
    let results = std::env::temp_dir().join(format!("bw4t-serve-once-{}", std::process::id()));
    let results_arg = results.to_str().expect("utf-8");
    let once_args: Vec<&str> = ["serve", "--once", "--mode", "lockstep", "--results-dir", results_arg]
        .into_iter()
        .chain(MATCH)
        .collect();
    let once = crate::util::bw4t_within(&once_args, crate::util::WAIT);
    assert!(once.status.success(), "{}", stderr(&once));
    assert!(stderr(&once).contains("match over (max_ticks): 30 ticks"), "{}", stderr(&once));
    // The index of results reads as a tournament's rows.
    let summary = bw4t(&["tournament", "summary", results_arg]);
    assert!(summary.status.success(), "{}", stderr(&summary));
    let table = String::from_utf8_lossy(&summary.stdout);
    assert!(table.contains("default") && table.contains("1 match in"), "{table}");
    let _ = std::fs::remove_dir_all(&results);
    let mut serve = Command::new(env!("CARGO_BIN_EXE_bw4t"));
    // Realtime at 200 ticks/s, so that each run lasts long enough to be watched.
    serve.args(["serve", "--log-json", "-v"]).args(MATCH).args(["--tick-hz", "200"]);
    // The log goes to a file: a pipe nobody reads would fill and stall the server.
    let log_path = std::env::temp_dir().join(format!("bw4t-serve-again-{}.log", std::process::id()));
    let log_file = std::fs::File::create(&log_path).expect("log file");
    let mut child =
        KillOnDrop(serve.stdout(std::process::Stdio::piped()).stderr(log_file).spawn().expect("start"));
    let mut first = String::new();
    BufReader::new(child.0.stdout.take().expect("stdout")).read_line(&mut first).expect("address line");
    let addr = first.trim().strip_prefix("listening on ").expect("listening on ADDR").to_string();
    // Visitors come one after the other; one that arrives just as a run ends is told `bye`
    // `match_over` and comes again.
    let (mut seen_ends, mut visits) = (0, 0);
    while seen_ends < 2 && visits < 10 {
        visits += 1;
        let stream = std::net::TcpStream::connect(&addr).expect("the server is still there");
        stream.set_read_timeout(Some(crate::util::WAIT)).expect("timeout");
        let mut writer = stream.try_clone().expect("clone");
        writeln!(writer, r#"{{"type":"hello","protocol":"bw4t","versions":[1],"role":"spectator"}}"#)
            .expect("hello");
        let ended = BufReader::new(stream).lines().map_while(Result::ok).any(|l| l.contains("\"match_end\""));
        seen_ends += usize::from(ended);
    }
    assert_eq!(seen_ends, 2, "two visitors in {visits} watched a match to its end");
    let _ = Command::new("kill").arg("-TERM").arg(child.0.id().to_string()).status();
    let status = child.0.wait().expect("exit");
    assert!(status.success(), "{status:?}");
    let log = std::fs::read_to_string(&log_path).expect("the log");
    let _ = std::fs::remove_file(&log_path);
    // The log is JSON lines with the match named in each event.
    let events: Vec<serde_json::Value> = log
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}")))
        .collect();
    let with = |message: &'static str| events.iter().filter(move |e| e["fields"]["message"] == message);
    assert!(with("match made").any(|e| e["fields"]["id"] == "default.2"), "{log}");
    assert!(
        with("watcher joined").all(|e| e["fields"]["match"] == "default" && e["level"] == "DEBUG"),
        "{log}"
    );
    assert!(with("watcher joined").count() >= 2, "{log}");
}

/// A child process that is killed if the test ends before it does (a failed assertion
/// must not leave a server running).
struct KillOnDrop(std::process::Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// What a second connection to a server started with `args` gets for its `ping` while a
/// first one is open: `pong`, or the refusal `server_full`.
fn second_connection_answer(args: &[&str]) -> String {
    use std::io::{BufRead, BufReader, Write};
    let mut serve = Command::new(env!("CARGO_BIN_EXE_bw4t"));
    serve.arg("serve").args(args).stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::null());
    let mut child = KillOnDrop(serve.spawn().expect("start"));
    let mut first = String::new();
    BufReader::new(child.0.stdout.take().expect("stdout")).read_line(&mut first).expect("address line");
    let addr = first.trim().strip_prefix("listening on ").expect("listening on ADDR").to_string();
    let _held = std::net::TcpStream::connect(&addr).expect("first connection");
    let second = std::net::TcpStream::connect(&addr).expect("second connection");
    second.set_read_timeout(Some(crate::util::WAIT)).expect("timeout");
    writeln!(&second, r#"{{"type":"ping"}}"#).expect("ping");
    let mut answer = String::new();
    BufReader::new(second).read_line(&mut answer).expect("an answer");
    answer
}

/// `--max-connections` given on the command line wins over the `--config` file's.
#[test]
fn the_connection_limit_comes_from_the_file_unless_the_command_line_gives_one() {
    let dir = std::env::temp_dir().join(format!("bw4t-limit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let file = dir.join("arena.toml");
    std::fs::write(&file, "max_connections = 1\n[[template]]\nname = \"lab\"\nnames = [\"lab\"]\n")
        .expect("write");
    let config = file.to_str().expect("utf-8");
    let from_file = second_connection_answer(&["--port", "0", "--config", config]);
    assert!(from_file.contains("server_full"), "{from_file}");
    let from_flag = second_connection_answer(&["--port", "0", "--config", config, "--max-connections", "2"]);
    assert!(from_flag.contains("\"pong\""), "{from_flag}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bench_merge_merges_every_made_up_row_with_none_missing() {
    let out = bw4t(&["bench", "merge", "--merge-rows", "301", "--merge-shards", "4"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let lines = json_lines(&out);
    assert_eq!(
        (lines[0]["case"].as_str(), lines[0]["rows"].as_u64(), lines[0]["missing"].as_u64()),
        (Some("merge"), Some(302), Some(0)),
        "{}",
        lines[0]
    );
    assert!(lines[0]["seconds"].as_f64().is_some_and(|s| s >= 0.0));
}

#[test]
fn bench_sim_counts_the_same_play_under_both_motions() {
    let counts = |motion: &str| -> Vec<serde_json::Value> {
        let out = bw4t(&["bench", "sim", "--ticks", "400", "--motion", motion]);
        assert!(out.status.success(), "{}", stderr(&out));
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .map(|l| {
                let mut line: serde_json::Value = serde_json::from_str(l).expect("a JSON object per line");
                assert_eq!(line["motion"], motion);
                let object = line.as_object_mut().expect("an object");
                object.remove("ticks_per_s");
                object.remove("motion");
                line
            })
            .collect()
    };
    let kinematic = counts("kinematic");
    assert!(kinematic.iter().all(|l| l["moves"].as_u64().is_some_and(|m| m > 0)), "{kinematic:?}");
    assert_eq!(kinematic, counts("stepped"));
    let out = bw4t(&["bench", "sim", "--motion", "sideways"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("sideways"), "{}", stderr(&out));
}

/// `./test.sh` refuses a stage it does not have, naming every one it has, and says how
/// to choose them; neither sets anything up.
#[test]
fn test_sh_names_an_unknown_stage_and_lists_its_stages() {
    let script = concat!(repo_root!(), "/test.sh");
    // Without the caller's BW4T_ORIGINAL_MAPS, which test.sh checks first (CI gives it
    // relative to the repository, not to this package's folder the test runs in).
    let test_sh = |args: &[&str]| {
        Command::new("bash")
            .arg(script)
            .args(args)
            .env_remove("BW4T_ORIGINAL_MAPS")
            .current_dir(repo_root!())
            .output()
            .expect("run test.sh")
    };
    let out = test_sh(&["rust", "nope"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let said = stderr(&out);
    assert!(said.contains("unknown stage 'nope'"), "{said}");
    for stage in ["rust", "python", "javascript", "browser", "slurm", "container", "install"] {
        assert!(said.contains(stage), "{stage} missing from: {said}");
    }
    let help = test_sh(&["--help"]);
    assert!(help.status.success(), "{}", stderr(&help));
    assert!(String::from_utf8_lossy(&help.stdout).contains("./test.sh STAGE..."));
}
