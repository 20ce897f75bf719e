use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

use serde_json::Value;

const LIMIT: Duration = Duration::from_secs(120);

const CONFIG: &str = r#"
maps = ["fixed", "default"]
seeds = 3

[[team]]
name = "coop"
agents = "builtin"
robots = 3

[[team]]
name = "solo"
agents = "builtin:baseline"
robots = 2
"#;

fn temp(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bw4t-cluster-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// `bw4t ARGS` with the variables `env` set (and no job-array variables of the caller).
fn bw4t_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_bw4t"));
    command.args(args).current_dir(repo_root!());
    for var in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_COUNT",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_STEP",
        "JOB_COMPLETION_INDEX",
        "BW4T_SHARDS",
    ] {
        command.env_remove(var);
    }
    command.envs(env.iter().copied());
    crate::util::output_within(command, LIMIT, &format!("bw4t {args:?}"))
}

fn ok(out: Output) -> Output {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    out
}

fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Each match's digest, by key.
fn digests(dir: &Path) -> Vec<(String, String)> {
    let text = std::fs::read_to_string(dir.join("matches.jsonl")).expect("matches.jsonl");
    let mut rows: Vec<(String, String)> = text
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).expect("a row"))
        .map(|r| {
            (
                r["key"].as_str().unwrap_or_default().to_string(),
                r["digest"].as_str().unwrap_or_default().to_string(),
            )
        })
        .collect();
    rows.sort();
    rows
}

#[test]
fn shards_from_slurm_and_kubernetes_variables_merge_into_the_whole_tournament() {
    let dir = temp("auto");
    let config = dir.join("t.toml");
    std::fs::write(&config, CONFIG).expect("config");
    let whole = dir.join("whole");
    ok(bw4t_env(&["tournament", path(&config), "--out", path(&whole), "--replays", "none"], &[]));
    let slurm = dir.join("slurm");
    for task in ["0", "1", "2"] {
        let out = ok(bw4t_env(
            &["tournament", path(&config), "--shard", "auto", "--out", path(&slurm), "--replays", "none"],
            &[("SLURM_ARRAY_TASK_ID", task), ("SLURM_ARRAY_TASK_COUNT", "3")],
        ));
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(
            said.contains(&format!("SLURM_ARRAY_TASK_ID={task}")),
            "says where its shard came from: {said}"
        );
    }
    let k8s = dir.join("k8s");
    for index in ["0", "1"] {
        ok(bw4t_env(
            &["tournament", path(&config), "--shard", "auto", "--out", path(&k8s), "--replays", "none"],
            &[("JOB_COMPLETION_INDEX", index), ("BW4T_SHARDS", "2")],
        ));
    }
    let names: Vec<String> = std::fs::read_dir(&slurm)
        .expect("shard dirs")
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    assert_eq!(names, ["shard-1-of-3", "shard-2-of-3", "shard-3-of-3"]);
    for (shards, merged) in [(&slurm, dir.join("slurm-merged")), (&k8s, dir.join("k8s-merged"))] {
        let out = ok(bw4t_env(&["tournament", "merge", path(shards), "--out", path(&merged)], &[]));
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("merged 12 matches from"),
            "{}",
            String::from_utf8_lossy(&out.stdout)
        );
        assert_eq!(digests(&merged), digests(&whole), "every row equals the unsharded run's");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn merge_names_missing_and_doubled_matches_refuses_other_configurations_and_resume_plays_the_rest() {
    let dir = temp("merge");
    let config = dir.join("t.toml");
    std::fs::write(&config, CONFIG).expect("config");
    let shards = dir.join("shards");
    for shard in ["1/3", "3/3"] {
        let out_dir = shards.join(if shard == "1/3" { "shard-1-of-3" } else { "shard-3-of-3" });
        ok(bw4t_env(
            &["tournament", path(&config), "--shard", shard, "--out", path(&out_dir), "--replays", "none"],
            &[],
        ));
    }
    // Shard 2 never ran, and shard 1 is given twice.
    let merged = dir.join("merged");
    let first = shards.join("shard-1-of-3");
    let out = bw4t_env(&["tournament", "merge", path(&shards), path(&first), "--out", path(&merged)], &[]);
    let said = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "missing matches: {said}");
    assert!(said.contains("4 matches of the configuration missing"), "{said}");
    assert!(said.contains("4 matches played more than once, alike"), "{said}");
    assert!(said.contains("tournament resume"), "says how to play them: {said}");
    ok(bw4t_env(&["tournament", "resume", path(&merged)], &[]));
    let whole = dir.join("whole");
    ok(bw4t_env(&["tournament", path(&config), "--out", path(&whole), "--replays", "none"], &[]));
    assert_eq!(digests(&merged), digests(&whole), "the resumed merge is the whole tournament");

    let other = dir.join("other");
    let other_config = dir.join("other.toml");
    std::fs::write(&other_config, CONFIG.replace("seeds = 3", "seeds = 2")).expect("config");
    ok(bw4t_env(&["tournament", path(&other_config), "--out", path(&other), "--replays", "none"], &[]));
    let out =
        bw4t_env(&["tournament", "merge", path(&whole), path(&other), "--out", path(&dir.join("x"))], &[]);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.code() == Some(1) && said.contains("not shards of one tournament"), "{said}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn shard_auto_without_its_variables_or_without_out_is_refused_with_the_reason() {
    let out = bw4t_env(
        &["tournament", "--map", "fixed", "--team", "a=builtin", "--seeds", "1", "--shard", "auto"],
        &[],
    );
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("neither a Slurm array task"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = bw4t_env(
        &["tournament", "--map", "fixed", "--team", "a=builtin", "--seeds", "1", "--shard", "auto"],
        &[("SLURM_ARRAY_TASK_ID", "0"), ("SLURM_ARRAY_TASK_COUNT", "2")],
    );
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--shard auto needs --out"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_slurm_and_kubernetes_job_files_run_every_shard_then_the_merge() {
    let dir = temp("files");
    let config = dir.join("t.toml");
    std::fs::write(&config, CONFIG).expect("config");
    let run = dir.join("run");
    let out = ok(bw4t_env(
        &[
            "tournament",
            "slurm",
            path(&config),
            "--array",
            "4",
            "--out",
            path(&run),
            "--partition",
            "short",
            "--time",
            "01:00:00",
            "--cpus-per-task",
            "2",
            "--sbatch=--account=lab",
        ],
        &[],
    ));
    assert!(String::from_utf8_lossy(&out.stdout).contains("submit.sh"), "says how to submit");
    let read = |name: &str| std::fs::read_to_string(run.join("slurm").join(name)).expect(name);
    let shards = read("shards.sbatch");
    for line in [
        "#SBATCH --array=0-3",
        "#SBATCH --cpus-per-task=2",
        "#SBATCH --partition=short",
        "#SBATCH --time=01:00:00",
        "#SBATCH --account=lab",
    ] {
        assert!(shards.lines().any(|l| l == line), "{line} in\n{shards}");
    }
    assert!(
        shards.contains(&format!("--shard auto --out {} --concurrency 2 --resume", path(&run))),
        "{shards}"
    );
    assert!(read("merge.sbatch").contains(&format!(
        "tournament merge {} --out {}/merged",
        path(&run),
        path(&run)
    )));
    assert!(read("submit.sh").contains("--dependency=afterany:\"$array\""), "{}", read("submit.sh"));

    let k8s = dir.join("k8s");
    ok(bw4t_env(
        &[
            "tournament",
            "k8s",
            path(&config),
            "--completions",
            "5",
            "--parallelism",
            "2",
            "--out",
            path(&k8s),
            "--image",
            "lab/bw4t:1",
        ],
        &[],
    ));
    let json = |name: &str| -> Value {
        serde_json::from_str(&std::fs::read_to_string(k8s.join(name)).expect(name)).expect("json")
    };
    let job = json("shards-job.json");
    assert_eq!(
        (
            job["spec"]["completionMode"].as_str(),
            job["spec"]["completions"].as_u64(),
            job["spec"]["parallelism"].as_u64()
        ),
        (Some("Indexed"), Some(5), Some(2))
    );
    let container = &job["spec"]["template"]["spec"]["containers"][0];
    assert_eq!(container["env"][0], serde_json::json!({"name": "BW4T_SHARDS", "value": "5"}));
    assert_eq!(container["image"], "lab/bw4t:1");
    // The pods run as the image's own user, which the Containerfile makes numeric.
    let containerfile =
        std::fs::read_to_string(concat!(repo_root!(), "/Containerfile")).expect("Containerfile");
    let image_user = containerfile.lines().find_map(|line| line.strip_prefix("USER ")).expect("a USER line");
    let pod_security = &job["spec"]["template"]["spec"]["securityContext"];
    assert_eq!(pod_security["runAsNonRoot"], true);
    assert_eq!(
        format!("{0}:{0}", pod_security["fsGroup"]),
        image_user,
        "fsGroup is the image's user and group"
    );
    assert_eq!(container["securityContext"]["allowPrivilegeEscalation"], false);
    let command: Vec<&str> =
        container["command"].as_array().expect("command").iter().filter_map(Value::as_str).collect();
    assert_eq!(command[..6], ["bw4t", "tournament", "/config/tournament.toml", "--shard", "auto", "--out"]);
    assert_eq!(json("configmap.json")["data"]["tournament.toml"], CONFIG);
    assert_eq!(json("merge-job.json")["spec"]["template"]["spec"]["containers"][0]["command"][2], "merge");
    let bad = bw4t_env(
        &[
            "tournament",
            "k8s",
            path(&config),
            "--completions",
            "2",
            "--name",
            "Bad_Name",
            "--out",
            path(&k8s),
        ],
        &[],
    );
    assert!(
        String::from_utf8_lossy(&bad.stderr).contains("--name 'Bad_Name'"),
        "{}",
        String::from_utf8_lossy(&bad.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
