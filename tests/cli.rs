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
}
