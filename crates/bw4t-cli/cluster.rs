//! `bw4t tournament slurm|k8s`: a tournament as a cluster job. Each writes what the
//! cluster runs (a Slurm job array and a merge job that waits for it; a Kubernetes
//! Indexed Job, a merge Job and the ConfigMap of the configuration), in which every task
//! plays `tournament CONFIG --shard auto --out DIR`, and says how to submit it.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use bw4t_tournament::{SHARDS_VAR, TournamentConfig};
use clap::Args;
use serde_json::json;

use crate::runs::shell_quote;

/// Options of `bw4t tournament slurm`.
#[derive(Args)]
pub(crate) struct SlurmArgs {
    /// The tournament configuration (TOML).
    config: PathBuf,
    /// Tasks of the job array: the shards the matches are dealt into.
    #[arg(long)]
    array: u64,
    /// The directory every shard writes under (shard-I-of-N), the merge into
    /// DIR/merged, and the scripts into DIR/slurm (default: runs/slurm-SECONDS).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Cores per task; each task plays that many matches at once.
    #[arg(long, default_value_t = 1)]
    cpus_per_task: u32,
    /// The partition (#SBATCH --partition); the cluster's default when omitted.
    #[arg(long)]
    partition: Option<String>,
    /// A task's time limit (#SBATCH --time, e.g. 02:00:00); the partition's when omitted.
    #[arg(long)]
    time: Option<String>,
    /// More #SBATCH options for both jobs, e.g. --account=lab (repeat for more).
    #[arg(long = "sbatch", value_name = "OPTION", allow_hyphen_values = true)]
    sbatch: Vec<String>,
    /// The command that runs bw4t on the cluster's nodes (default: this one).
    #[arg(long, value_name = "COMMAND")]
    bw4t: Option<String>,
}

/// Options of `bw4t tournament k8s`.
#[derive(Args)]
pub(crate) struct K8sArgs {
    /// The tournament configuration (TOML).
    config: PathBuf,
    /// Completions of the Indexed Job: the shards the matches are dealt into.
    #[arg(long)]
    completions: u64,
    /// Pods running at once (default: all).
    #[arg(long)]
    parallelism: Option<u64>,
    /// Where the manifests go (default: runs/k8s-SECONDS).
    #[arg(long)]
    out: Option<PathBuf>,
    /// The container image; it must have `bw4t` on its PATH (and any agent programs the
    /// configuration names).
    #[arg(long, default_value = concat!("bw4t:", env!("CARGO_PKG_VERSION")))]
    image: String,
    /// The PersistentVolumeClaim (ReadWriteMany) every pod writes its shard to and the
    /// merge reads.
    #[arg(long, default_value = "bw4t-results")]
    claim: String,
    /// The name of the jobs and the ConfigMap (lower-case letters, digits and '-').
    #[arg(long, default_value = "bw4t-tournament")]
    name: String,
    /// CPU each pod asks for; each plays that many matches at once.
    #[arg(long, default_value_t = 1)]
    cpus: u32,
}

/// The command line of this program, for scripts that run it again.
fn this_bw4t(given: Option<&str>) -> Result<String> {
    if let Some(command) = given {
        return Ok(command.to_string());
    }
    let command = crate::self_command()?;
    let mut words = vec![command.get_program().to_string_lossy().into_owned()];
    words.extend(command.get_args().map(|a| a.to_string_lossy().into_owned()));
    Ok(words.iter().map(|w| shell_quote(w)).collect::<Vec<_>>().join(" "))
}

/// The configuration, checked as a tournament would check it, and its text.
fn read_config(path: &Path) -> Result<(String, String)> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let resolved = TournamentConfig::parse(&text)
        .and_then(|c| c.resolve())
        .with_context(|| format!("{} is not a valid tournament configuration", path.display()))?;
    Ok((text, resolved.config_hash()))
}

fn absolute(path: &Path) -> Result<PathBuf> {
    std::path::absolute(path).with_context(|| format!("cannot make {} absolute", path.display()))
}

fn write(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

/// `tournament slurm`: `shards.sbatch` (the array), `merge.sbatch` (after it, whatever
/// became of its tasks, so that missing matches are named) and `submit.sh`.
pub(crate) fn slurm(args: &SlurmArgs) -> Result<()> {
    if args.array == 0 {
        bail!("--array must be at least 1");
    }
    if args.cpus_per_task == 0 {
        bail!("--cpus-per-task must be at least 1");
    }
    let (_, hash) = read_config(&args.config)?;
    let out = absolute(&args.out.clone().unwrap_or_else(|| crate::runs::default_out("slurm")))?;
    let config = absolute(&args.config)?;
    let here = std::env::current_dir().context("no current directory")?;
    let scripts = out.join("slurm");
    std::fs::create_dir_all(&scripts).with_context(|| format!("cannot create {}", scripts.display()))?;
    let bw4t = this_bw4t(args.bw4t.as_deref())?;
    let quote = |p: &Path| shell_quote(&p.display().to_string());
    let mut common = vec![format!("#SBATCH --chdir={}", here.display())];
    if let Some(partition) = &args.partition {
        common.push(format!("#SBATCH --partition={partition}"));
    }
    common.extend(args.sbatch.iter().map(|option| format!("#SBATCH {option}")));
    let mut shards = vec![
        "#!/bin/bash".to_string(),
        format!(
            "# bw4t tournament {} (configuration {hash}) as a job array: task i plays shard i+1 of {}.",
            config.display(),
            args.array
        ),
        "#SBATCH --job-name=bw4t-shards".into(),
        format!("#SBATCH --array=0-{}", args.array - 1),
        format!("#SBATCH --cpus-per-task={}", args.cpus_per_task),
        format!("#SBATCH --output={}/shard-%a.log", scripts.display()),
    ];
    if let Some(time) = &args.time {
        shards.push(format!("#SBATCH --time={time}"));
    }
    shards.extend(common.iter().cloned());
    shards.extend([
        "set -euo pipefail".into(),
        "# --resume: a task that is requeued goes on where it stopped.".into(),
        format!(
            "exec {bw4t} tournament {} --shard auto --out {} --concurrency {} --resume",
            quote(&config),
            quote(&out),
            args.cpus_per_task
        ),
    ]);
    let mut merge = vec![
        "#!/bin/bash".to_string(),
        format!(
            "# Joins the shards of {} into {}/merged, naming any missing match.",
            config.display(),
            out.display()
        ),
        "#SBATCH --job-name=bw4t-merge".into(),
        "#SBATCH --cpus-per-task=1".into(),
        format!("#SBATCH --output={}/merge.log", scripts.display()),
    ];
    merge.extend(common);
    merge.extend([
        "set -euo pipefail".into(),
        format!("exec {bw4t} tournament merge {} --out {}", quote(&out), quote(&out.join("merged"))),
    ]);
    let submit = [
        "#!/bin/sh".to_string(),
        "# Submits the job array, then the merge job to run when every task has ended.".into(),
        "set -eu".into(),
        format!("array=$(sbatch --parsable {})", quote(&scripts.join("shards.sbatch"))),
        "array=${array%%;*}".into(),
        format!(
            "merge=$(sbatch --parsable --dependency=afterany:\"$array\" {})",
            quote(&scripts.join("merge.sbatch"))
        ),
        "merge=${merge%%;*}".into(),
        format!(
            "echo \"bw4t: job array $array ({} tasks), merge job $merge; results in {}/merged\"",
            args.array,
            out.display()
        ),
    ];
    write(&scripts.join("shards.sbatch"), &(shards.join("\n") + "\n"))?;
    write(&scripts.join("merge.sbatch"), &(merge.join("\n") + "\n"))?;
    write(&scripts.join("submit.sh"), &(submit.join("\n") + "\n"))?;
    outln!("wrote {}/{{shards.sbatch, merge.sbatch, submit.sh}} (configuration {hash})", scripts.display());
    outln!("submit with:\n  sh {}", quote(&scripts.join("submit.sh")));
    outln!("then follow it with squeue --me; the merged results will be in {}/merged", out.display());
    Ok(())
}

/// The user and group id the image runs as: the Containerfile's `USER`.
const IMAGE_USER_ID: u32 = 10001;

/// `tournament k8s`: `configmap.json`, `shards-job.json` (the Indexed Job) and
/// `merge-job.json`, JSON being YAML that `kubectl apply -f` reads as it is.
pub(crate) fn k8s(args: &K8sArgs) -> Result<()> {
    if args.completions == 0 {
        bail!("--completions must be at least 1");
    }
    let valid_name = !args.name.is_empty()
        && args.name.len() <= 52
        && args.name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
        && !args.name.starts_with('-')
        && !args.name.ends_with('-');
    if !valid_name {
        bail!(
            "--name '{}': use lower-case letters, digits and '-', at most 52, not starting or ending with '-'",
            args.name
        );
    }
    let (text, hash) = read_config(&args.config)?;
    let out = args.out.clone().unwrap_or_else(|| crate::runs::default_out("k8s"));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let name = &args.name;
    let results = format!("/results/{name}");
    let labels = json!({"app.kubernetes.io/name": "bw4t", "bw4t/config-hash": hash});
    let volumes = json!([
        {"name": "config", "configMap": {"name": format!("{name}-config")}},
        {"name": "results", "persistentVolumeClaim": {"claimName": args.claim}},
    ]);
    let mounts = json!([
        {"name": "config", "mountPath": "/config", "readOnly": true},
        {"name": "results", "mountPath": "/results"},
    ]);
    let cpu = args.cpus.to_string();
    let job = |job_name: String,
               spec_extra: serde_json::Value,
               command: Vec<String>,
               env: serde_json::Value| {
        let mut spec = json!({
            "backoffLimit": 2,
            "template": {
                "metadata": {"labels": labels},
                "spec": {
                    "restartPolicy": "Never",
                    // The image's numeric user (the Containerfile's 10001) lets the kubelet
                    // check it is not root; fsGroup makes the shared volume writable by it.
                    "securityContext": {
                        "runAsNonRoot": true,
                        "fsGroup": IMAGE_USER_ID,
                        "seccompProfile": {"type": "RuntimeDefault"},
                    },
                    "containers": [{
                        "name": "bw4t",
                        "image": args.image,
                        "command": command,
                        "env": env,
                        "resources": {"requests": {"cpu": cpu}},
                        "securityContext": {
                            "allowPrivilegeEscalation": false,
                            "capabilities": {"drop": ["ALL"]},
                        },
                        "volumeMounts": mounts,
                    }],
                    "volumes": volumes,
                },
            },
        });
        if let (Some(spec), Some(extra)) = (spec.as_object_mut(), spec_extra.as_object()) {
            spec.extend(extra.clone());
        }
        json!({"apiVersion": "batch/v1", "kind": "Job", "metadata": {"name": job_name, "labels": labels}, "spec": spec})
    };
    let words = |w: &[&str]| w.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let shards = job(
        format!("{name}-shards"),
        json!({
            "completionMode": "Indexed",
            "completions": args.completions,
            "parallelism": args.parallelism.unwrap_or(args.completions).clamp(1, args.completions),
        }),
        words(&[
            "bw4t",
            "tournament",
            "/config/tournament.toml",
            "--shard",
            "auto",
            "--out",
            &results,
            "--resume",
            "--concurrency",
            &cpu,
        ]),
        json!([{"name": SHARDS_VAR, "value": args.completions.to_string()}]),
    );
    let merge = job(
        format!("{name}-merge"),
        json!({"completions": 1}),
        words(&["bw4t", "tournament", "merge", &results, "--out", &format!("{results}/merged")]),
        json!([]),
    );
    let config_map = json!({
        "apiVersion": "v1",
        "kind": "ConfigMap",
        "metadata": {"name": format!("{name}-config"), "labels": labels},
        "data": {"tournament.toml": text},
    });
    for (file, value) in
        [("configmap.json", config_map), ("shards-job.json", shards), ("merge-job.json", merge)]
    {
        write(&out.join(file), &(serde_json::to_string_pretty(&value)? + "\n"))?;
    }
    let dir = shell_quote(&out.display().to_string());
    outln!("wrote {dir}/{{configmap.json, shards-job.json, merge-job.json}} (configuration {hash})");
    outln!(
        "the pods share the PersistentVolumeClaim '{}' (ReadWriteMany, e.g. NFS): shards write {results}/shard-I-of-N",
        args.claim
    );
    outln!(
        "the image '{}' must have bw4t on its PATH, and the configuration's maps and agent programs",
        args.image
    );
    outln!("run with:");
    outln!("  kubectl apply -f {dir}/configmap.json -f {dir}/shards-job.json");
    outln!("  kubectl wait --for=condition=complete --timeout=24h job/{name}-shards");
    outln!("  kubectl apply -f {dir}/merge-job.json   # then read {results}/merged from the volume");
    Ok(())
}
