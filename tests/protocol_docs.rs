use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use bw4t_protocol::{decode_client, decode_server, schemas};
use serde_json::Value;

fn protocol_dir() -> PathBuf {
    Path::new(repo_root!()).join("protocol")
}

fn files_under(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n == "node_modules") {
                continue;
            }
            files_under(&path, out);
        } else {
            out.push(path);
        }
    }
}

/// The committed schemas are exactly what the Rust types generate. To update them after
/// changing a message: `BW4T_BLESS=1 cargo test --test main schemas`.
#[test]
fn schemas_match_the_rust_types() {
    let dir = protocol_dir().join("schema");
    let expected: BTreeMap<String, String> = schemas()
        .into_iter()
        .map(|(path, schema)| (path, serde_json::to_string_pretty(&schema).expect("json") + "\n"))
        .collect();
    if std::env::var_os("BW4T_BLESS").is_some() {
        let _ = std::fs::remove_dir_all(&dir);
        for (path, text) in &expected {
            let file = dir.join(path);
            std::fs::create_dir_all(file.parent().expect("parent")).expect("mkdir");
            std::fs::write(file, text).expect("write schema");
        }
    }
    let mut files = Vec::new();
    files_under(&dir, &mut files);
    let found: BTreeMap<String, String> = files
        .iter()
        .map(|f| {
            let rel = f.strip_prefix(&dir).expect("under schema").to_string_lossy().replace('\\', "/");
            (rel, std::fs::read_to_string(f).expect("read"))
        })
        .collect();
    assert_eq!(found.keys().collect::<Vec<_>>(), expected.keys().collect::<Vec<_>>(), "schema files");
    for (path, text) in &expected {
        assert!(&found[path] == text, "protocol/schema/{path} is out of date (BW4T_BLESS=1 regenerates it)");
    }
    for name in ["client/hello.json", "client/act.json", "server/percepts.json", "server/match_end.json"] {
        assert!(expected.contains_key(name), "{name}");
    }
}

/// Every JSON example in `protocol/` is a message of this protocol version: the fenced
/// ```json blocks of the Markdown files, and the transcripts' `send`/`recv` lines.
#[test]
fn every_json_example_in_protocol_parses() {
    let mut files = Vec::new();
    files_under(&protocol_dir(), &mut files);
    let mut checked = 0;
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap_or_default();
        let name = file.display().to_string();
        match file.extension().and_then(|e| e.to_str()) {
            Some("md") => {
                for block in text.split("```json\n").skip(1) {
                    let json = block.split("\n```").next().expect("fenced block");
                    let value: Value =
                        serde_json::from_str(json).unwrap_or_else(|e| panic!("{name}: {e}\n{json}"));
                    let line = value.to_string();
                    if decode_client(&line).is_err() {
                        decode_server(&line).unwrap_or_else(|e| panic!("{name}: not a message: {e}\n{json}"));
                    }
                    checked += 1;
                }
            }
            Some("jsonl") => {
                let lines: Vec<(usize, Value)> = text
                    .lines()
                    .enumerate()
                    .filter(|(_, l)| !l.trim().is_empty())
                    .map(|(i, l)| {
                        (i + 1, serde_json::from_str(l).unwrap_or_else(|e| panic!("{name}:{}: {e}", i + 1)))
                    })
                    .collect();
                for (k, (at, value)) in lines.iter().enumerate() {
                    if value.get("server").is_some() {
                        // The conformance suite's server settings (see PROTOCOL.md).
                    } else if let Some(received) = value.get("recv") {
                        // `"<any>"` stands for a volatile value; a number is where one goes.
                        let concrete = received.to_string().replace("\"wall_ms\":\"<any>\"", "\"wall_ms\":0");
                        decode_server(&concrete).unwrap_or_else(|e| panic!("{name}:{at}: {e}"));
                    } else if let Some(sent) = value
                        .get("send")
                        .map(Value::to_string)
                        .or_else(|| value.get("raw").and_then(Value::as_str).map(str::to_string))
                    {
                        // Bad input is shown on purpose: then the server's next line answers it.
                        if decode_client(&sent).is_err() {
                            let reply =
                                lines.get(k + 1).and_then(|(_, v)| v.get("recv")).map(Value::to_string);
                            let answered =
                                reply.as_deref().and_then(|r| decode_server(r).ok()).is_some_and(|m| {
                                    matches!(m, bw4t_protocol::ServerMessage::Error(_))
                                        || matches!(m, bw4t_protocol::ServerMessage::Ack(ref a) if !a.ok)
                                });
                            assert!(
                                answered,
                                "{name}:{at}: an invalid message must be followed by the error it gets"
                            );
                        }
                    } else {
                        panic!(
                            "{name}:{at}: a transcript line is {{\"send\": ..}}, {{\"raw\": \"..\"}} or {{\"recv\": ..}}"
                        );
                    }
                    checked += 1;
                }
            }
            Some("json") => {
                serde_json::from_str::<Value>(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
            }
            _ => {}
        }
    }
    assert!(checked > 0, "no examples found in protocol/");
}

#[test]
fn the_message_language_table_in_the_protocol_document_is_the_code_table() {
    let doc = std::fs::read_to_string(protocol_dir().join("PROTOCOL.md")).expect("PROTOCOL.md");
    let section = doc.split("## The message language").nth(1).expect("a message language section");
    let section = section.split("\n## ").next().unwrap_or_default();
    let rows: Vec<&str> = section.lines().filter(|l| l.starts_with("| `")).collect();
    assert_eq!(rows.len(), bw4t_protocol::KINDS.len(), "one row per kind");
    for (row, kind) in rows.iter().zip(bw4t_protocol::KINDS) {
        let cells: Vec<&str> = row.split(" | ").collect();
        assert_eq!(cells[0], format!("| `{}`", kind.word), "{row}");
        assert_eq!(cells[2], kind.sentence, "{row}");
    }
}
