use std::path::Path;
use std::time::Duration;

use bw4t_protocol::Mode;
use serde_json::Value;
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};

use crate::util::{TestServer, WAIT, open_seats, shipped_map};

/// Whether `got` matches `expected`: objects by the fields `expected` names (extra fields
/// are ignored, as the protocol's versioning rules say), arrays element by element, and
/// `"<any>"` matches anything.
fn matches(expected: &Value, got: &Value) -> bool {
    match (expected, got) {
        (Value::String(s), _) if s == "<any>" => true,
        (Value::Object(e), Value::Object(g)) => {
            e.iter().all(|(k, v)| g.get(k).is_some_and(|gv| matches(v, gv)))
        }
        (Value::Array(e), Value::Array(g)) => {
            e.len() == g.len() && e.iter().zip(g).all(|(a, b)| matches(a, b))
        }
        (Value::Number(a), Value::Number(b)) => a.as_f64() == b.as_f64(),
        _ => expected == got,
    }
}

/// Replays one transcript against a fresh server; panics naming the file and line.
async fn replay(file: &Path) {
    let name = file.display().to_string();
    let text = std::fs::read_to_string(file).expect("transcript");
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((_, first)) = lines.next() else { return };
    let header: Value = serde_json::from_str(first).expect("json");
    let Some(server) = header.get("server") else { return };
    let mut setup = bw4t_server::MatchSetup::new(shipped_map(server["map"].as_str().expect("map")));
    setup.seats = open_seats(1);
    let mut config = bw4t_server::HostConfig::new();
    setup.seed = server["seed"].as_u64().expect("seed");
    config.mode = if server["mode"] == "realtime" { Mode::Realtime } else { Mode::Lockstep };
    setup.max_ticks = server["max_ticks"].as_u64();
    config.deadline = match server["deadline_ms"].as_u64() {
        Some(0) => None,
        Some(ms) => Some(Duration::from_millis(ms)),
        None => config.deadline,
    };
    let server = TestServer::start(setup, config).await;
    let stream = tokio::net::TcpStream::connect(server.addr).await.expect("connect");
    let (reader, mut writer) = stream.into_split();
    let mut from_server = BufReader::new(reader).lines();
    for (i, line) in lines {
        let at = format!("{name}:{}", i + 1);
        let value: Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{at}: {e}"));
        if let Some(message) = value.get("send") {
            writer.write_all(format!("{message}\n").as_bytes()).await.expect("send");
        } else if let Some(raw) = value.get("raw").and_then(Value::as_str) {
            writer.write_all(format!("{raw}\n").as_bytes()).await.expect("send");
        } else if let Some(expected) = value.get("recv") {
            let got = tokio::time::timeout(WAIT, from_server.next_line())
                .await
                .unwrap_or_else(|_| panic!("{at}: nothing received"));
            let got = got.ok().flatten().unwrap_or_else(|| panic!("{at}: the server closed the connection"));
            let got: Value = serde_json::from_str(&got).expect("server sends JSON");
            assert!(matches(expected, &got), "{at}: expected {expected}\n got {got}");
        }
    }
    drop(writer);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_example_transcripts_replay_against_the_server() {
    let dir = Path::new(repo_root!()).join("protocol/examples");
    let mut files: Vec<_> =
        std::fs::read_dir(&dir).expect("examples").filter_map(|e| Some(e.ok()?.path())).collect();
    files.sort();
    let mut replayed = 0;
    for file in files.iter().filter(|f| f.extension().is_some_and(|e| e == "jsonl")) {
        let first =
            std::fs::read_to_string(file).expect("read").lines().next().unwrap_or_default().to_string();
        if first.contains("\"server\"") {
            replay(file).await;
            replayed += 1;
        }
    }
    assert!(replayed >= 4, "only {replayed} transcripts have a server line");
}

#[test]
fn matching_ignores_unknown_fields_but_not_wrong_values() {
    let expected: Value = serde_json::json!({"type": "ack", "ok": true, "session": "<any>", "list": [1, 2]});
    let cases = [
        (serde_json::json!({"type": "ack", "ok": true, "session": "x1", "list": [1, 2], "new": 3}), true),
        (serde_json::json!({"type": "ack", "ok": false, "session": "x1", "list": [1, 2]}), false),
        (serde_json::json!({"type": "ack", "ok": true, "list": [1, 2]}), false),
        (serde_json::json!({"type": "ack", "ok": true, "session": 5, "list": [2, 1]}), false),
    ];
    for (got, want) in cases {
        assert_eq!(matches(&expected, &got), want, "{got}");
    }
}
