//! `bw4t bench merge`: the time `tournament merge` takes over many rows, on shard
//! directories of made-up rows (a real tournament of 100,000 matches would take hours).

use std::time::Instant;

use anyhow::{Context, Result};
use bw4t_protocol::EndReason;
use bw4t_runner::tournament::{merge, setup};
use bw4t_tournament::{Machine, Manifest, ReplayPolicy, Row, Shard, TournamentConfig};
use serde_json::json;

/// Writes `shards` shard directories holding `rows` rows in all of a two-team tournament
/// on the fixed map, merges them, and reports how long the merge took.
pub(crate) fn run(rows: u64, shards: u64) -> Result<serde_json::Value> {
    let text = format!(
        "maps = [\"fixed\"]\nseeds = {}\n\n[[team]]\nname = \"coop\"\nagents = \"builtin\"\n\n[[team]]\nname = \"solo\"\nagents = \"builtin:baseline\"\n",
        rows.div_ceil(2)
    );
    let resolved = TournamentConfig::parse(&text)?.resolve()?;
    let maps = [crate::maps::load("fixed")?];
    let dir = std::env::temp_dir().join(format!("bw4t-bench-merge-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let plan = resolved.plan();
    for index in 1..=shards {
        let shard = Shard { index, count: shards };
        let out = dir.join(shard.dir_name());
        std::fs::create_dir_all(&out)?;
        let manifest = Manifest {
            program: bw4t_runner::program(),
            created_unix: 0,
            machine: Machine {
                os: String::new(),
                arch: String::new(),
                cores: 1,
                concurrency: 1,
                host: String::new(),
            },
            config_hash: resolved.config_hash(),
            config: resolved.clone(),
            setup: setup(&resolved, &maps),
            shard: Some(shard),
            concurrency: 1,
            replays: ReplayPolicy::None,
            elapsed_seconds: 1.0,
            merged_from: None,
        };
        std::fs::write(out.join("manifest.json"), manifest.to_json())?;
        let mut lines = String::new();
        for p in plan.iter().filter(|p| shard.plays(&resolved, p)) {
            let team = &resolved.teams[p.team];
            let mut row =
                Row::unplayed(p.key.clone(), p.index, team.name.clone(), "fixed".into(), p.seed, team.robots);
            row.completed = p.index % 7 != 0;
            row.ticks = 800 + p.index % 1000;
            row.completed_tick = row.completed.then_some(row.ticks);
            row.good_drops = 6;
            row.end_reason = if row.completed { EndReason::Completed } else { EndReason::MaxTicks };
            row.digest = format!("{:016x}", p.index);
            lines.push_str(&serde_json::to_string(&row)?);
            lines.push('\n');
        }
        std::fs::write(out.join("matches.jsonl"), lines)?;
    }
    let merged = dir.join("merged");
    let started = Instant::now();
    let (outcome, report) = merge(std::slice::from_ref(&dir), &merged).context("the merge failed")?;
    let seconds = started.elapsed().as_secs_f64();
    let _ = std::fs::remove_dir_all(&dir);
    Ok(json!({
        "case": "merge",
        "rows": outcome.rows.len(),
        "shards": shards,
        "missing": report.missing.len(),
        "seconds": (seconds * 1000.0).round() / 1000.0,
        "rows_per_s": (outcome.rows.len() as f64 / seconds).round(),
    }))
}
