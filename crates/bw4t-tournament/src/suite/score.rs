//! Scoring an agent's matches on a tier against the built-in team's on the same tasks:
//! the normalised score, completion, pass^k, usage and a digest of what was played.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use bw4t_protocol::{AgentInfo, LeaderboardRow, UsageTotals};
use sha2::{Digest, Sha256};

use super::{SUITE, SUITE_VERSION, Split, Tier};
use crate::Row;
use crate::stats::{bootstrap_mean, mean, wilson};

/// One match as the scorer needs it: from a tournament row, or from a line a learning
/// environment's evaluation writes (`bw4t.eval`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Outcome {
    /// `TEAM/MAP/SEED/REPETITION`, as the tier's tournament names its matches.
    pub key: String,
    /// Whether the sequence was completed.
    pub completed: bool,
    /// The tick it was completed at, or the tick the match ended at.
    pub ticks: u64,
    /// An agent program crashed, never connected or was dropped.
    #[serde(default)]
    pub crashed: bool,
    /// The match could not be played.
    #[serde(default)]
    pub failed: bool,
    /// What model-driven players reported.
    #[serde(default)]
    pub usage: UsageTotals,
    /// The match's state digest (empty: none given).
    #[serde(default)]
    pub digest: String,
}

impl From<&Row> for Outcome {
    fn from(row: &Row) -> Outcome {
        Outcome {
            key: row.key.clone(),
            completed: row.completed,
            ticks: row.completed_tick.filter(|_| row.completed).unwrap_or(row.ticks),
            crashed: row.crashed_agents > 0,
            failed: row.error.is_some(),
            usage: UsageTotals {
                tool_calls: row.tool_calls,
                invalid_calls: row.invalid_calls,
                prompt_tokens: row.prompt_tokens,
                completion_tokens: row.completion_tokens,
                result_tokens: row.result_tokens,
            },
            digest: row.digest.clone(),
        }
    }
}

/// Matches that do not make up the tier's split.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ScoreError {
    /// A planned match has no outcome (or the reference team's has none).
    #[error("{whose} outcome is missing for {key} (and {more} more); play them (or resume) first")]
    Missing {
        /// `the agent's` or `the built-in team's`.
        whose: &'static str,
        /// The first missing match's key.
        key: String,
        /// How many more are missing.
        more: usize,
    },
    /// An outcome names no match of the split.
    #[error("outcome {0} is not a match of this tier and split")]
    Unplanned(String),
}

/// `C(n, k)` as a float (small arguments only: repetitions).
fn choose(n: u32, k: u32) -> f64 {
    if k > n {
        return 0.0;
    }
    (0..k).fold(1.0, |acc, i| acc * f64::from(n - i) / f64::from(i + 1))
}

/// SHA-256 over each outcome's key and digest, in key order; empty when any lacks a digest.
pub fn digest_of(outcomes: &[Outcome]) -> String {
    if outcomes.is_empty() || outcomes.iter().any(|o| o.digest.is_empty()) {
        return String::new();
    }
    let mut lines: Vec<String> = outcomes.iter().map(|o| format!("{} {}\n", o.key, o.digest)).collect();
    lines.sort();
    let hash = Sha256::digest(lines.concat().as_bytes());
    hash.iter().fold(String::new(), |mut hex, b| {
        let _ = write!(hex, "{b:02x}");
        hex
    })
}

/// The leaderboard row of `agent`'s `outcomes` on `tier`'s `split`, `repetitions` of each
/// task, against the built-in team's `reference` outcomes (one per task).
pub fn score(
    tier: &Tier,
    split: Split,
    repetitions: u32,
    agent: AgentInfo,
    bw4t_version: &str,
    outcomes: &[Outcome],
    reference: &[Outcome],
) -> Result<LeaderboardRow, ScoreError> {
    let plan = tier.tournament(split, "agent", repetitions, 0, None).plan();
    let task_of = |key: &str| key.rsplit_once('/').map(|(task, _)| task.to_string());
    let by_key: BTreeMap<&str, &Outcome> = outcomes.iter().map(|o| (o.key.as_str(), o)).collect();
    if let Some(stray) = outcomes.iter().find(|o| !plan.iter().any(|p| p.key == o.key)) {
        return Err(ScoreError::Unplanned(stray.key.clone()));
    }
    let missing: Vec<&str> =
        plan.iter().map(|p| p.key.as_str()).filter(|k| !by_key.contains_key(k)).collect();
    if let Some(first) = missing.first() {
        return Err(ScoreError::Missing {
            whose: "the agent's",
            key: first.to_string(),
            more: missing.len() - 1,
        });
    }
    let reference_ticks: BTreeMap<String, u64> =
        reference.iter().filter_map(|o| Some((task_of(&o.key)?, o.ticks))).collect();
    // Each task's repetitions, in plan order.
    let mut tasks: BTreeMap<String, Vec<&Outcome>> = BTreeMap::new();
    for p in &plan {
        let task = task_of(&p.key).unwrap_or_default();
        tasks.entry(task).or_default().push(by_key[p.key.as_str()]);
    }
    let absent: Vec<&String> = tasks.keys().filter(|t| !reference_ticks.contains_key(*t)).collect();
    if let Some(first) = absent.first() {
        return Err(ScoreError::Missing {
            whose: "the built-in team's",
            key: format!("{first}/0"),
            more: absent.len() - 1,
        });
    }
    let normalised = |o: &Outcome, reference: u64| {
        if o.completed { reference as f64 / o.ticks.max(1) as f64 } else { 0.0 }
    };
    let task_scores: Vec<f64> = tasks
        .iter()
        .map(|(task, played)| {
            let scores: Vec<f64> = played.iter().map(|o| normalised(o, reference_ticks[task])).collect();
            mean(&scores).unwrap_or(0.0)
        })
        .collect();
    let pass_k = (1..=repetitions)
        .map(|k| {
            let per_task: Vec<f64> = tasks
                .values()
                .map(|played| {
                    let completed = played.iter().filter(|o| o.completed).count() as u32;
                    choose(completed, k) / choose(played.len() as u32, k)
                })
                .collect();
            mean(&per_task).unwrap_or(0.0)
        })
        .collect();
    let completed = outcomes.iter().filter(|o| o.completed).count();
    let completed_ticks: Vec<f64> = outcomes.iter().filter(|o| o.completed).map(|o| o.ticks as f64).collect();
    let interval = |i: crate::Interval| [i.lo, i.hi];
    let usage = outcomes.iter().fold(UsageTotals::default(), |sum, o| UsageTotals {
        tool_calls: sum.tool_calls + o.usage.tool_calls,
        invalid_calls: sum.invalid_calls + o.usage.invalid_calls,
        prompt_tokens: sum.prompt_tokens + o.usage.prompt_tokens,
        completion_tokens: sum.completion_tokens + o.usage.completion_tokens,
        result_tokens: sum.result_tokens + o.usage.result_tokens,
    });
    let reference_all: Vec<f64> = tasks.keys().map(|t| reference_ticks[t] as f64).collect();
    Ok(LeaderboardRow {
        suite: SUITE.into(),
        suite_version: SUITE_VERSION,
        tier: tier.name.into(),
        split: split.name().into(),
        agent,
        bw4t_version: bw4t_version.into(),
        tasks: tasks.len() as u32,
        repetitions,
        matches: outcomes.len() as u32,
        score: mean(&task_scores).unwrap_or(0.0),
        score_interval: bootstrap_mean(&task_scores).map(interval),
        completion: completed as f64 / outcomes.len().max(1) as f64,
        completion_interval: interval(wilson(completed, outcomes.len())),
        pass_k,
        mean_ticks: mean(&completed_ticks),
        reference_mean_ticks: mean(&reference_all).unwrap_or(0.0),
        crashed_matches: outcomes.iter().filter(|o| o.crashed).count() as u32,
        failed_matches: outcomes.iter().filter(|o| o.failed).count() as u32,
        usage,
        digest: digest_of(outcomes),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::suite::tier;

    fn outcomes(tier: &Tier, repetitions: u32, play: impl Fn(&str, u32) -> Option<u64>) -> Vec<Outcome> {
        let plan = tier.tournament(Split::Dev, "agent", repetitions, 0, None).plan();
        plan.iter()
            .map(|p| {
                let ticks = play(&p.key, p.repetition);
                Outcome {
                    key: p.key.clone(),
                    completed: ticks.is_some(),
                    ticks: ticks.unwrap_or(20_000),
                    crashed: false,
                    failed: false,
                    usage: UsageTotals { tool_calls: 3, ..UsageTotals::default() },
                    digest: format!("d{}", p.index),
                }
            })
            .collect()
    }

    #[test]
    fn the_reference_scores_one_and_half_speed_scores_a_half() {
        let solo = tier("solo").expect("as made");
        let reference = outcomes(solo, 1, |_, _| Some(1000));
        let same =
            score(solo, Split::Dev, 1, AgentInfo::default(), "v", &reference, &reference).expect("as made");
        assert_eq!((same.score, same.completion, same.pass_k.clone()), (1.0, 1.0, vec![1.0]));
        assert_eq!(same.usage.tool_calls, 3 * u64::from(same.matches));
        let slow = outcomes(solo, 1, |_, _| Some(2000));
        let half = score(solo, Split::Dev, 1, AgentInfo::default(), "v", &slow, &reference).expect("as made");
        assert_eq!(half.score, 0.5);
        assert_eq!(half.mean_ticks, Some(2000.0));
        assert_eq!(half.reference_mean_ticks, 1000.0);
        assert_ne!(half.digest, "");
    }

    #[test]
    fn pass_k_counts_tasks_every_repetition_completes() {
        let solo = tier("solo").expect("as made");
        let reference = outcomes(solo, 1, |_, _| Some(1000));
        // Every task: repetition 0 completes, repetition 1 does not: pass^1 = 1/2, pass^2 = 0.
        let flaky = outcomes(solo, 2, |_, rep| (rep == 0).then_some(1000));
        let row = score(solo, Split::Dev, 2, AgentInfo::default(), "v", &flaky, &reference).expect("as made");
        assert_eq!(row.pass_k, vec![0.5, 0.0]);
        assert_eq!(row.score, 0.5);
        let [lo, hi] = row.completion_interval;
        assert!(lo < 0.5 && 0.5 < hi);
    }

    #[test]
    fn missing_and_stray_matches_are_named() {
        let solo = tier("solo").expect("as made");
        let reference = outcomes(solo, 1, |_, _| Some(1000));
        let mut partial = reference.clone();
        let gone = partial.pop().expect("as made");
        let err =
            score(solo, Split::Dev, 1, AgentInfo::default(), "v", &partial, &reference).expect_err("refused");
        assert_eq!(err, ScoreError::Missing { whose: "the agent's", key: gone.key.clone(), more: 0 });
        let err =
            score(solo, Split::Dev, 1, AgentInfo::default(), "v", &reference, &partial).expect_err("refused");
        assert!(matches!(err, ScoreError::Missing { whose: "the built-in team's", .. }), "{err}");
        let mut stray = reference.clone();
        stray[0].key = "solo1/default/1/0".into();
        assert!(matches!(
            score(solo, Split::Dev, 1, AgentInfo::default(), "v", &stray, &reference),
            Err(ScoreError::Unplanned(_))
        ));
    }
}
