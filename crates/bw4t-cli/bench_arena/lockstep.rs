//! The `lockstep` figure: matches of built-in agents, no sockets, on 1 then 2 worker
//! threads; ticks per second of them all together.

use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use bw4t_map::Map;
use bw4t_protocol::Mode;
use bw4t_server::{Arena, ArenaConfig, OnEnd, Template};
use serde_json::{Value, json};

use super::{
    ArenaArgs, LOCKSTEP_THREADS, ROBOTS, host_config, match_setup, round, runtime, thread_cpu_seconds,
};

/// `lockstep`: `arena_lockstep_matches` matches of 3 built-in agents at any time in one
/// arena (each that ends replaced by the next), on a runtime of 1 worker thread, then of
/// 2; ticks per second of all of them together.
pub(super) fn lockstep(args: &ArenaArgs, map: &Map, seed: u64) -> Result<Value> {
    let m = args.arena_lockstep_matches;
    if m == 0 {
        bail!("--arena-lockstep-matches must be at least 1");
    }
    let one = lockstep_run(args, map, seed, 1)?;
    let two = lockstep_run(args, map, seed, 2)?;
    let rate = |run: &LockstepRun| run.ticks as f64 / run.seconds;
    Ok(json!({
        "case": "arena",
        "kind": "lockstep",
        "map": map.name(),
        "matches": m,
        "robots": ROBOTS,
        "max_ticks": args.arena_lockstep_ticks,
        "seconds_1_worker": round(one.seconds, 2),
        "seconds_2_workers": round(two.seconds, 2),
        "ticks_1_worker": one.ticks,
        "ticks_2_workers": two.ticks,
        "matches_ended_1_worker": one.ended,
        "matches_ended_2_workers": two.ended,
        "completed_1_worker": one.completed,
        "completed_2_workers": two.completed,
        "ticks_per_s_1_worker": rate(&one).round(),
        "ticks_per_s_2_workers": rate(&two).round(),
        "speedup": round(rate(&two) / rate(&one), 2),
        // Below 200 with 2 workers: the workers waited, or other processes had a core.
        "worker_cpu_percent_1_worker": (one.cpu / one.seconds * 100.0).round(),
        "worker_cpu_percent_2_workers": (two.cpu / two.seconds * 100.0).round(),
    }))
}

/// What one lockstep run made.
struct LockstepRun {
    ticks: u64,
    /// Matches ended, those interrupted at the end of the measurement included.
    ended: usize,
    completed: usize,
    seconds: f64,
    /// CPU seconds of the worker threads.
    cpu: f64,
}

fn lockstep_run(args: &ArenaArgs, map: &Map, seed: u64, workers: usize) -> Result<LockstepRun> {
    let m = args.arena_lockstep_matches;
    let mut setup = match_setup(map, seed, ROBOTS, 0);
    setup.max_ticks = Some(args.arena_lockstep_ticks);
    // Each match that ends is followed by the next of its template: M run at any time.
    let template = Template {
        name: "bench".into(),
        maps: vec![map.clone()],
        setup,
        config: host_config(Mode::Lockstep),
        names: (1..=m).map(|i| format!("m{i}")).collect(),
        max_running: m,
        on_end: OnEnd::Restart,
        replays: false,
        lateness: None,
        invited_only: false,
    };
    let arena_config = ArenaConfig::new(vec![template]);
    let rt = runtime(workers, LOCKSTEP_THREADS)?;
    let (started, cpu) = (Instant::now(), thread_cpu_seconds(LOCKSTEP_THREADS)?);
    let totals = rt.block_on(async {
        // Made on a worker, so that making the matches counts against the workers too.
        let arena = tokio::spawn(async { Arena::start(arena_config) }).await??;
        tokio::time::sleep(Duration::from_secs_f64(args.arena_lockstep_seconds)).await;
        // The matches still running end here (interrupted); their ticks count too.
        arena.shutdown().await;
        anyhow::Ok(arena.totals().values().copied().fold(bw4t_server::Totals::default(), |a, t| {
            bw4t_server::Totals {
                ended: a.ended + t.ended,
                completed: a.completed + t.completed,
                failed: a.failed + t.failed,
                ticks: a.ticks + t.ticks,
            }
        }))
    })?;
    let seconds = started.elapsed().as_secs_f64();
    let cpu = thread_cpu_seconds(LOCKSTEP_THREADS)? - cpu;
    if totals.failed > 0 {
        anyhow::bail!("{} of the lockstep matches failed in the server", totals.failed);
    }
    Ok(LockstepRun {
        ticks: totals.ticks,
        ended: totals.ended as usize,
        completed: totals.completed as usize,
        seconds,
        cpu,
    })
}
