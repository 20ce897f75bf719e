//! Statistics over tournament rows: completion rates, ticks to complete, paired differences
//! between teams on the same matches, and an overall ranking.
//!
//! Everything here is a pure function of the rows and the elapsed time. The bootstrap draws
//! from a generator with a fixed seed, so the same rows always give the same summary (and
//! the same `summary.json`, `summary.md` and `summary.svg` bytes). The renderings live in
//! `report.rs` (Markdown, terminal) and `chart.rs` (SVG).

use std::collections::BTreeMap;

use bw4t_map::SeededRng;
use bw4t_protocol::EndReason;
use serde::{Deserialize, Serialize};

use crate::Row;

/// Confidence level of every interval in the summary.
const CONFIDENCE: f64 = 0.95;
/// The standard normal quantile for a two-sided 95% interval, Φ⁻¹(0.975).
const Z: f64 = 1.959_963_984_540_054;
/// Resamples per bootstrap interval.
const BOOTSTRAP_RESAMPLES: usize = 2000;
/// Seed of the generator behind every bootstrap interval ("bw4tboot" in ASCII). Each
/// interval starts a fresh generator from it, so an interval depends only on its own values,
/// not on which other teams or maps are in the tournament.
const BOOTSTRAP_SEED: u64 = 0x6277_3474_626f_6f74;

/// A two-sided interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Interval {
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
}

impl Interval {
    /// Whether `x` lies within the interval, bounds included.
    pub fn contains(&self, x: f64) -> bool {
        self.lo <= x && x <= self.hi
    }
}

/// How the figures were computed, written into `summary.json` so the file explains itself.
#[derive(Clone, Debug, Serialize)]
pub struct Method {
    /// Confidence level of every interval.
    pub confidence: f64,
    /// What "ticks to complete" means.
    pub ticks_to_complete: &'static str,
    /// The interval given for completion rates.
    pub rate_interval: &'static str,
    /// The interval given for means of ticks and of paired differences.
    pub mean_interval: &'static str,
    /// Resamples per bootstrap interval.
    pub bootstrap_resamples: usize,
    /// Seed of the bootstrap generator (SplitMix64, fresh for each interval).
    pub bootstrap_seed: u64,
    /// How medians, p90 and bootstrap percentiles are taken.
    pub percentiles: &'static str,
}

impl Method {
    fn current() -> Self {
        Self {
            confidence: CONFIDENCE,
            ticks_to_complete: "completed_tick (or ticks when absent) of completed matches only",
            rate_interval: "Wilson score interval",
            mean_interval: "percentile bootstrap; none with fewer than 2 values",
            bootstrap_resamples: BOOTSTRAP_RESAMPLES,
            bootstrap_seed: BOOTSTRAP_SEED,
            percentiles: "linear interpolation between order statistics (Hyndman-Fan type 7)",
        }
    }
}

/// How many matches ended for one reason.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EndReasonCount {
    /// The end reason, as in the rows.
    pub reason: EndReason,
    /// Matches that ended so.
    pub matches: usize,
}

/// Sums over every row.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Totals {
    /// Teams.
    pub teams: usize,
    /// Maps.
    pub maps: usize,
    /// Ticks simulated, over all matches.
    pub ticks: u64,
    /// Blocks delivered in order.
    pub good_drops: u64,
    /// Blocks delivered out of order.
    pub wrong_drops: u64,
    /// Messages sent.
    pub messages: u64,
    /// Agents that missed deadlines.
    pub late_agents: u64,
    /// Agents that crashed, never connected, hung or talked garbage.
    pub crashed_agents: u64,
    /// Wall-clock milliseconds of the matches added up (more than the tournament's elapsed
    /// time when matches ran in parallel).
    pub match_wall_ms: u64,
    /// Matches per end reason, in the order the reasons first appear.
    pub end_reasons: Vec<EndReasonCount>,
}

/// One team on one map.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TeamMapStats {
    /// The team.
    pub team: String,
    /// The map.
    pub map: String,
    /// Matches played.
    pub matches: usize,
    /// Matches that completed the sequence.
    pub completed: usize,
    /// `completed / matches`.
    pub completion_rate: f64,
    /// 95% Wilson score interval of the completion rate.
    pub completion_interval: Interval,
    /// Mean ticks to complete; none without completed matches.
    pub ticks_mean: Option<f64>,
    /// 95% percentile-bootstrap interval of the mean ticks to complete; none with fewer
    /// than 2 completed matches.
    pub ticks_mean_interval: Option<Interval>,
    /// Median ticks to complete.
    pub ticks_median: Option<f64>,
    /// 90th percentile of ticks to complete (linear interpolation, type 7).
    pub ticks_p90: Option<f64>,
    /// Fewest ticks to complete.
    pub ticks_min: Option<u64>,
    /// Most ticks to complete.
    pub ticks_max: Option<u64>,
    /// Mean wrong drops per match.
    pub mean_wrong_drops: f64,
    /// Blocks delivered in order, in all matches.
    pub good_drops: u64,
    /// Messages sent, in all matches.
    pub messages: u64,
    /// `messages / good_drops`; none when no block was delivered in order.
    pub messages_per_good_drop: Option<f64>,
    /// Late agents, summed over the matches.
    pub late_agents: u64,
    /// Crashed agents, summed over the matches.
    pub crashed_agents: u64,
    /// Mean wall-clock milliseconds per match.
    pub mean_wall_ms: f64,
    /// Ticks to complete of each completed match, ascending (for the chart; the rows hold
    /// them too, so `summary.json` leaves them out).
    #[serde(skip)]
    pub completion_ticks: Vec<u64>,
}

/// Two teams compared on one map, match by match.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PairStats {
    /// The first team (earlier in team order).
    pub team_a: String,
    /// The second team.
    pub team_b: String,
    /// The map.
    pub map: String,
    /// (seed, repetition) combinations both teams played on this map.
    pub common: usize,
    /// Of those, how many both completed: the paired differences.
    pub pairs: usize,
    /// Mean of (A's ticks to complete - B's) over the pairs; negative means A was faster.
    pub mean_difference: Option<f64>,
    /// 95% percentile-bootstrap interval of the mean difference; none with fewer than 2
    /// pairs.
    pub difference_interval: Option<Interval>,
    /// Matches only A completed.
    pub only_a: usize,
    /// Matches only B completed.
    pub only_b: usize,
    /// Matches neither completed.
    pub neither: usize,
    /// Each pair's difference (A - B), in (seed, repetition) order.
    #[serde(skip)]
    pub differences: Vec<f64>,
}

/// One team's place in the overall ranking.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TeamRank {
    /// Place, from 1; ties get consecutive places in name order.
    pub rank: usize,
    /// The team.
    pub team: String,
    /// Matches played, on all maps.
    pub matches: usize,
    /// Matches completed.
    pub completed: usize,
    /// `completed / matches`.
    pub completion_rate: f64,
    /// 95% Wilson score interval of the completion rate.
    pub completion_interval: Interval,
    /// Mean ticks to complete over all completed matches, pooled over maps.
    pub ticks_mean: Option<f64>,
}

/// The tick limit matches on one map ran with.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct MapLimit {
    /// The map, as in the rows.
    pub map: String,
    /// The last tick of its matches.
    pub max_ticks: u64,
    /// `config` when the configuration (or `--max-ticks`) gave it, `map` when derived from
    /// the map (see `TickLimit`).
    pub from: String,
    /// For a derived limit, how it was found.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub explanation: Option<String>,
}

/// What the summary says about how the matches were set up, beside what the rows hold.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Setup {
    /// Each map's tick limit.
    pub tick_limits: Vec<MapLimit>,
    /// Maps that fix their own seed: every match seed gives them the same blocks and
    /// sequence, so a deterministic team plays the same match on each and its intervals
    /// there have no width.
    pub fixed_content_maps: Vec<String>,
}

impl Setup {
    /// The warning for maps whose content ignores the match seed; none when there are none.
    pub fn fixed_content_warning(&self) -> Option<String> {
        if self.fixed_content_maps.is_empty() {
            return None;
        }
        let names: Vec<String> = self.fixed_content_maps.iter().map(|m| format!("'{m}'")).collect();
        let (them, fix) = if names.len() == 1 { ("map", "fixes its") } else { ("maps", "fix their") };
        Some(format!(
            "{them} {} {fix} own seed: every match seed gives the same blocks and sequence, so a \
             deterministic team plays the same match on each, and its intervals there have no width",
            names.join(", ")
        ))
    }
}

/// The summary of a tournament.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Matches summarised.
    pub matches: usize,
    /// Matches that completed the sequence.
    pub completed: usize,
    /// The tournament's elapsed time, in seconds (0 when not known or not positive).
    pub wall_seconds: f64,
    /// `matches / (wall_seconds / 60)`; 0 when `wall_seconds` is 0.
    pub matches_per_min: f64,
    /// Sums over every row.
    pub totals: Totals,
    /// Teams, in the order they first appear in the rows.
    pub teams: Vec<String>,
    /// Maps, in the order they first appear in the rows.
    pub maps: Vec<String>,
    /// One entry per team and map that has rows, teams first, in the orders above.
    pub cells: Vec<TeamMapStats>,
    /// One entry per unordered pair of teams (in team order) and map both played.
    pub pairs: Vec<PairStats>,
    /// Teams from best to worst.
    pub ranking: Vec<TeamRank>,
    /// How the figures were computed.
    pub method: Method,
    /// Tick limits and maps with fixed content (empty unless given with
    /// [`Summary::with_setup`]).
    pub setup: Setup,
}

impl Summary {
    /// Every figure as JSON (`summary.json`).
    pub fn to_json(&self) -> serde_json::Value {
        // Serialising cannot fail: every map key is a string and floats are finite (a
        // non-finite one would become null). Should it ever fail, say so in the file rather
        // than panic at the end of a long run.
        serde_json::to_value(self)
            .unwrap_or_else(|e| serde_json::json!({ "error": format!("summary not serialisable: {e}") }))
    }

    /// The summary with what is known of the set-up beside the rows.
    pub fn with_setup(mut self, setup: Setup) -> Summary {
        self.setup = setup;
        self
    }

    /// The entry for `team` on `map`, if that team played that map.
    pub fn cell(&self, team: &str, map: &str) -> Option<&TeamMapStats> {
        self.cells.iter().find(|c| c.team == team && c.map == map)
    }
}

/// Summarises `rows`; `wall_seconds` is the tournament's elapsed time.
///
/// Rows are taken as given: a (team, map, seed, repetition) that appears twice counts twice
/// in the per-team figures, and its first row is the one paired.
pub fn summarize(rows: &[Row], wall_seconds: f64) -> Summary {
    let wall_seconds = if wall_seconds.is_finite() && wall_seconds > 0.0 { wall_seconds } else { 0.0 };
    let matches_per_min = if wall_seconds > 0.0 { rows.len() as f64 / (wall_seconds / 60.0) } else { 0.0 };

    let teams = first_appearances(rows.iter().map(|r| r.team.as_str()));
    let maps = first_appearances(rows.iter().map(|r| r.map.as_str()));
    let team_index = index_of(&teams);
    let map_index = index_of(&maps);
    // groups[t][m]: the rows of team t on map m, in row order.
    let mut groups: Vec<Vec<Vec<&Row>>> = vec![vec![Vec::new(); maps.len()]; teams.len()];
    for row in rows {
        if let (Some(&t), Some(&m)) = (team_index.get(row.team.as_str()), map_index.get(row.map.as_str())) {
            groups[t][m].push(row);
        }
    }

    let mut cells = Vec::new();
    for (t, team) in teams.iter().enumerate() {
        for (m, map) in maps.iter().enumerate() {
            if !groups[t][m].is_empty() {
                cells.push(team_map_stats(team, map, &groups[t][m]));
            }
        }
    }

    let mut pairs = Vec::new();
    for a in 0..teams.len() {
        for b in a + 1..teams.len() {
            for (m, map) in maps.iter().enumerate() {
                if !groups[a][m].is_empty() && !groups[b][m].is_empty() {
                    pairs.push(pair_stats(&teams[a], &teams[b], map, &groups[a][m], &groups[b][m]));
                }
            }
        }
    }

    let ranking = rank_teams(&teams, &groups);
    let totals = totals(rows, teams.len(), maps.len());
    Summary {
        matches: rows.len(),
        completed: rows.iter().filter(|r| r.completed).count(),
        wall_seconds,
        matches_per_min,
        totals,
        teams,
        maps,
        cells,
        pairs,
        ranking,
        method: Method::current(),
        setup: Setup::default(),
    }
}

/// Ticks to complete of a match: its completion tick, or its last tick when the row does
/// not record one; none when it did not complete.
fn ticks_to_complete(row: &Row) -> Option<u64> {
    row.completed.then(|| row.completed_tick.unwrap_or(row.ticks))
}

/// Distinct values in the order they first appear.
fn first_appearances<'a>(values: impl Iterator<Item = &'a str>) -> Vec<String> {
    let mut seen = std::collections::BTreeSet::new();
    values.filter(|v| seen.insert(*v)).map(str::to_string).collect()
}

fn index_of(names: &[String]) -> BTreeMap<&str, usize> {
    names.iter().enumerate().map(|(i, n)| (n.as_str(), i)).collect()
}

fn team_map_stats(team: &str, map: &str, rows: &[&Row]) -> TeamMapStats {
    let matches = rows.len();
    let mut completion_ticks: Vec<u64> = rows.iter().filter_map(|r| ticks_to_complete(r)).collect();
    completion_ticks.sort_unstable();
    let completed = completion_ticks.len();
    let ticks: Vec<f64> = completion_ticks.iter().map(|&t| t as f64).collect();
    let good_drops: u64 = rows.iter().map(|r| u64::from(r.good_drops)).sum();
    let messages: u64 = rows.iter().map(|r| u64::from(r.messages)).sum();
    let wrong: Vec<f64> = rows.iter().map(|r| f64::from(r.wrong_drops)).collect();
    let wall: Vec<f64> = rows.iter().map(|r| r.wall_ms as f64).collect();
    TeamMapStats {
        team: team.to_string(),
        map: map.to_string(),
        matches,
        completed,
        completion_rate: rate(completed, matches),
        completion_interval: wilson(completed, matches),
        ticks_mean: mean(&ticks),
        ticks_mean_interval: bootstrap_mean(&ticks),
        ticks_median: quantile(&ticks, 0.5),
        ticks_p90: quantile(&ticks, 0.9),
        ticks_min: completion_ticks.first().copied(),
        ticks_max: completion_ticks.last().copied(),
        mean_wrong_drops: mean(&wrong).unwrap_or(0.0),
        good_drops,
        messages,
        messages_per_good_drop: (good_drops > 0).then(|| messages as f64 / good_drops as f64),
        late_agents: rows.iter().map(|r| u64::from(r.late_agents)).sum(),
        crashed_agents: rows.iter().map(|r| u64::from(r.crashed_agents)).sum(),
        mean_wall_ms: mean(&wall).unwrap_or(0.0),
        completion_ticks,
    }
}

fn pair_stats(team_a: &str, team_b: &str, map: &str, a_rows: &[&Row], b_rows: &[&Row]) -> PairStats {
    // Keyed by (seed, repetition) so pairs come out in a fixed order whatever the row order.
    fn by_match<'r>(rows: &[&'r Row]) -> BTreeMap<(u64, u32), &'r Row> {
        let mut out = BTreeMap::new();
        for row in rows {
            out.entry((row.seed, row.repetition)).or_insert(*row);
        }
        out
    }
    let b_by_match = by_match(b_rows);
    let (mut common, mut only_a, mut only_b, mut neither) = (0, 0, 0, 0);
    let mut differences = Vec::new();
    for (key, a) in by_match(a_rows) {
        let Some(b) = b_by_match.get(&key) else { continue };
        common += 1;
        match (ticks_to_complete(a), ticks_to_complete(b)) {
            (Some(ta), Some(tb)) => differences.push(ta as f64 - tb as f64),
            (Some(_), None) => only_a += 1,
            (None, Some(_)) => only_b += 1,
            (None, None) => neither += 1,
        }
    }
    PairStats {
        team_a: team_a.to_string(),
        team_b: team_b.to_string(),
        map: map.to_string(),
        common,
        pairs: differences.len(),
        mean_difference: mean(&differences),
        difference_interval: bootstrap_mean(&differences),
        only_a,
        only_b,
        neither,
        differences,
    }
}

fn rank_teams(teams: &[String], groups: &[Vec<Vec<&Row>>]) -> Vec<TeamRank> {
    let mut ranking: Vec<TeamRank> = teams
        .iter()
        .zip(groups)
        .map(|(team, by_map)| {
            let rows: Vec<&Row> = by_map.iter().flatten().copied().collect();
            let ticks: Vec<f64> =
                rows.iter().filter_map(|r| ticks_to_complete(r)).map(|t| t as f64).collect();
            TeamRank {
                rank: 0,
                team: team.clone(),
                matches: rows.len(),
                completed: ticks.len(),
                completion_rate: rate(ticks.len(), rows.len()),
                completion_interval: wilson(ticks.len(), rows.len()),
                ticks_mean: mean(&ticks),
            }
        })
        .collect();
    ranking.sort_by(|x, y| {
        y.completion_rate
            .total_cmp(&x.completion_rate)
            // A team that never completed has no mean and goes after those that did.
            .then_with(|| match (x.ticks_mean, y.ticks_mean) {
                (Some(a), Some(b)) => a.total_cmp(&b),
                (Some(_), None) => std::cmp::Ordering::Less,
                (None, Some(_)) => std::cmp::Ordering::Greater,
                (None, None) => std::cmp::Ordering::Equal,
            })
            .then_with(|| x.team.cmp(&y.team))
    });
    for (i, entry) in ranking.iter_mut().enumerate() {
        entry.rank = i + 1;
    }
    ranking
}

fn totals(rows: &[Row], teams: usize, maps: usize) -> Totals {
    let mut totals = Totals { teams, maps, ..Totals::default() };
    for row in rows {
        totals.ticks += row.ticks;
        totals.good_drops += u64::from(row.good_drops);
        totals.wrong_drops += u64::from(row.wrong_drops);
        totals.messages += u64::from(row.messages);
        totals.late_agents += u64::from(row.late_agents);
        totals.crashed_agents += u64::from(row.crashed_agents);
        totals.match_wall_ms += row.wall_ms;
        match totals.end_reasons.iter_mut().find(|c| c.reason == row.end_reason) {
            Some(count) => count.matches += 1,
            None => totals.end_reasons.push(EndReasonCount { reason: row.end_reason, matches: 1 }),
        }
    }
    totals
}

/// `part / whole`, 0 when `whole` is 0.
fn rate(part: usize, whole: usize) -> f64 {
    if whole == 0 { 0.0 } else { part as f64 / whole as f64 }
}

/// The arithmetic mean; none for no values.
pub(crate) fn mean(values: &[f64]) -> Option<f64> {
    (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
}

/// The 95% Wilson score interval of a proportion `successes / trials`.
///
/// Unlike the normal approximation it stays within [0, 1] and is not degenerate at 0 or n
/// successes. With no trials nothing is known, and the interval is all of [0, 1].
pub(crate) fn wilson(successes: usize, trials: usize) -> Interval {
    if trials == 0 {
        return Interval { lo: 0.0, hi: 1.0 };
    }
    let n = trials as f64;
    let p = successes as f64 / n;
    let z2 = Z * Z;
    let denominator = 1.0 + z2 / n;
    let centre = (p + z2 / (2.0 * n)) / denominator;
    let half = Z * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt() / denominator;
    // Clamped because rounding can put a bound a hair outside [0, 1] at 0 or n successes.
    Interval { lo: (centre - half).max(0.0), hi: (centre + half).min(1.0) }
}

/// The `p` quantile (`0 <= p <= 1`) of values sorted ascending, by linear interpolation
/// between order statistics: position `h = (n - 1) p`, value `x[⌊h⌋] + (h - ⌊h⌋)(x[⌊h⌋+1] -
/// x[⌊h⌋])` (Hyndman and Fan's type 7, the default of R and NumPy). The median this gives
/// is the usual one. None for no values.
pub(super) fn quantile(sorted: &[f64], p: f64) -> Option<f64> {
    let last = sorted.len().checked_sub(1)?;
    let h = p.clamp(0.0, 1.0) * last as f64;
    let below = (h.floor() as usize).min(last);
    let above = (below + 1).min(last);
    let (a, b) = (sorted[below], sorted[above]);
    Some(a + (h - below as f64) * (b - a))
}

/// The 95% percentile-bootstrap interval of the mean of `values`: 2000 resamples of the
/// same size drawn with replacement, and the 2.5% and 97.5% quantiles of their means.
///
/// The generator is seeded with a constant, so the interval is reproducible. None with
/// fewer than 2 values, whose resamples would all be the same.
pub(crate) fn bootstrap_mean(values: &[f64]) -> Option<Interval> {
    let n = values.len();
    if n < 2 {
        return None;
    }
    let mut rng = SeededRng::new(BOOTSTRAP_SEED);
    let mut means: Vec<f64> = (0..BOOTSTRAP_RESAMPLES)
        .map(|_| (0..n).map(|_| values[rng.index(n)]).sum::<f64>() / n as f64)
        .collect();
    means.sort_by(f64::total_cmp);
    let tail = (1.0 - CONFIDENCE) / 2.0;
    Some(Interval { lo: quantile(&means, tail)?, hi: quantile(&means, 1.0 - tail)? })
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A row of `team` on `map`; completed at `done` ticks, or ran out at 5000.
    pub(crate) fn row(team: &str, map: &str, seed: u64, done: Option<u64>) -> Row {
        let mut row = Row::unplayed(format!("{team}/{map}/{seed}/0"), seed, team.into(), map.into(), seed, 3);
        row.completed = done.is_some();
        row.ticks = done.unwrap_or(5000);
        row.completed_tick = done;
        row.wall_ms = 100;
        row.good_drops = if done.is_some() { 6 } else { 2 };
        row.messages = 30;
        row.end_reason = if done.is_some() { EndReason::Completed } else { EndReason::MaxTicks };
        row.digest = "0".to_string();
        row
    }

    /// A small hand-made tournament: two teams, two maps, four seeds.
    ///
    /// On `default`, coop completes every seed (1000, 1100, 1200, 1300) and baseline seeds
    /// 1-3 (1500, 1400, 1600); on `fixed`, coop completes seeds 1-2 (800, 900) and baseline
    /// none.
    pub(crate) fn sample() -> Vec<Row> {
        let mut rows = Vec::new();
        for (seed, coop, baseline) in [
            (1, Some(1000), Some(1500)),
            (2, Some(1100), Some(1400)),
            (3, Some(1200), Some(1600)),
            (4, Some(1300), None),
        ] {
            rows.push(row("coop", "default", seed, coop));
            rows.push(row("baseline", "default", seed, baseline));
        }
        for (seed, coop) in [(1, Some(800)), (2, Some(900)), (3, None), (4, None)] {
            rows.push(row("coop", "fixed", seed, coop));
            rows.push(row("baseline", "fixed", seed, None));
        }
        rows
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-3
    }

    #[test]
    fn matches_that_could_not_be_played_count_as_one_end_reason_whatever_their_error() {
        let mut rows = sample();
        for (i, message) in ["cannot start `x`: no such file", "port in use"].into_iter().enumerate() {
            let mut failed = row("coop", "default", 10 + i as u64, None);
            failed.end_reason = EndReason::Error;
            failed.error = Some(message.to_string());
            rows.push(failed);
        }
        let s = summarize(&rows, 1.0);
        let errors: Vec<_> = s.totals.end_reasons.iter().filter(|c| c.reason == EndReason::Error).collect();
        assert_eq!(errors, [&EndReasonCount { reason: EndReason::Error, matches: 2 }]);
        assert_eq!(s.totals.end_reasons.len(), 3, "{:?}", s.totals.end_reasons);
    }

    #[test]
    fn wilson_matches_the_formula() {
        // By hand: z = 1.96, z²/n = 0.38415, denominator 1.38415.
        // 8/10: centre (0.8 + 0.19207) / 1.38415 = 0.71674, half 1.95996 * sqrt(0.016 +
        // 0.0096037) / 1.38415 = 0.22658.
        let w = wilson(8, 10);
        assert!(close(w.lo, 0.4902) && close(w.hi, 0.9433), "{w:?}");
        // 0/10: centre 0.13877 and half 0.13877.
        let w = wilson(0, 10);
        assert!(close(w.lo, 0.0) && close(w.hi, 0.2775), "{w:?}");
        let w = wilson(10, 10);
        assert!(close(w.lo, 0.7225) && close(w.hi, 1.0), "{w:?}");
        // 1/2: symmetric around 0.5.
        let w = wilson(1, 2);
        assert!(close(w.lo, 0.0945) && close(w.hi, 0.9055), "{w:?}");
        assert_eq!(wilson(0, 0), Interval { lo: 0.0, hi: 1.0 });
    }

    #[test]
    fn median_and_p90_interpolate() {
        assert_eq!(quantile(&[], 0.5), None);
        assert_eq!(quantile(&[7.0], 0.5), Some(7.0));
        assert_eq!(quantile(&[7.0], 0.9), Some(7.0));
        assert_eq!(quantile(&[1.0, 2.0, 3.0], 0.5), Some(2.0));
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), Some(2.5));
        // h = 0.9 * 9 = 8.1 between 9 and 10.
        let ten: Vec<f64> = (1..=10).map(f64::from).collect();
        assert!(close(quantile(&ten, 0.9).unwrap_or(0.0), 9.1));
        // h = 0.9 * 4 = 3.6: 40 + 0.6 * (100 - 40).
        assert!(close(quantile(&[10.0, 20.0, 30.0, 40.0, 100.0], 0.9).unwrap_or(0.0), 76.0));
        assert_eq!(quantile(&ten, 0.0), Some(1.0));
        assert_eq!(quantile(&ten, 1.0), Some(10.0));
    }

    #[test]
    fn bootstrap_is_reproducible_and_brackets_the_mean() {
        let values = [1000.0, 1100.0, 1250.0, 900.0, 1700.0, 1050.0, 980.0, 1320.0];
        let m = mean(&values).unwrap_or(0.0);
        let a = bootstrap_mean(&values);
        assert_eq!(a, bootstrap_mean(&values));
        let a = a.unwrap_or(Interval { lo: f64::NAN, hi: f64::NAN });
        assert!(a.contains(m) && a.lo < m && m < a.hi, "{a:?} around {m}");
        // Within the range of the data, and narrower than it.
        assert!(a.lo >= 900.0 && a.hi <= 1700.0 && a.hi - a.lo < 800.0, "{a:?}");
        assert_eq!(bootstrap_mean(&[5.0]), None);
        assert_eq!(bootstrap_mean(&[]), None);
        assert_eq!(bootstrap_mean(&[3.0, 3.0]), Some(Interval { lo: 3.0, hi: 3.0 }));
    }

    #[test]
    fn per_team_and_map_figures() {
        let s = summarize(&sample(), 60.0);
        assert_eq!(s.teams, ["coop", "baseline"]);
        assert_eq!(s.maps, ["default", "fixed"]);
        let order: Vec<(&str, &str)> = s.cells.iter().map(|c| (c.team.as_str(), c.map.as_str())).collect();
        assert_eq!(
            order,
            [("coop", "default"), ("coop", "fixed"), ("baseline", "default"), ("baseline", "fixed")]
        );

        let Some(c) = s.cell("coop", "default") else { panic!("no cell") };
        assert_eq!((c.matches, c.completed), (4, 4));
        assert_eq!(c.completion_rate, 1.0);
        assert_eq!(c.ticks_mean, Some(1150.0));
        assert_eq!(c.ticks_median, Some(1150.0));
        // h = 0.9 * 3 = 2.7: 1200 + 0.7 * 100.
        assert!(close(c.ticks_p90.unwrap_or(0.0), 1270.0));
        assert_eq!(c.completion_ticks, [1000, 1100, 1200, 1300]);
        assert_eq!(c.messages_per_good_drop, Some(120.0 / 24.0));
        assert!(c.ticks_mean_interval.is_some_and(|i| i.contains(1150.0)));

        let Some(b) = s.cell("baseline", "fixed") else { panic!("no cell") };
        assert_eq!((b.matches, b.completed), (4, 0));
        assert_eq!(
            (b.ticks_mean, b.ticks_median, b.ticks_p90, b.ticks_mean_interval),
            (None, None, None, None)
        );
        assert_eq!(b.messages_per_good_drop, Some(120.0 / 8.0));
        assert_eq!(b.completion_interval, wilson(0, 4));

        assert_eq!((s.matches, s.completed), (16, 9));
        assert_eq!(s.matches_per_min, 16.0);
        assert_eq!(s.totals.end_reasons[0], EndReasonCount { reason: EndReason::Completed, matches: 9 });
        assert_eq!(s.totals.end_reasons[1], EndReasonCount { reason: EndReason::MaxTicks, matches: 7 });
    }

    #[test]
    fn completion_tick_falls_back_to_ticks() {
        let mut r = row("t", "m", 1, Some(700));
        r.completed_tick = None;
        r.ticks = 750;
        let s = summarize(&[r], 0.0);
        assert_eq!(s.cells[0].ticks_mean, Some(750.0));
        assert_eq!(s.matches_per_min, 0.0);
    }

    #[test]
    fn paired_differences_use_only_matches_both_completed() {
        let mut rows = sample();
        // A seed only coop played on default is not a pair at all.
        rows.push(row("coop", "default", 9, Some(10)));
        let s = summarize(&rows, 1.0);
        assert_eq!(s.pairs.len(), 2);
        let p = &s.pairs[0];
        assert_eq!((p.team_a.as_str(), p.team_b.as_str(), p.map.as_str()), ("coop", "baseline", "default"));
        assert_eq!(p.common, 4);
        assert_eq!(p.differences, [-500.0, -300.0, -400.0]);
        assert_eq!((p.pairs, p.only_a, p.only_b, p.neither), (3, 1, 0, 0));
        assert_eq!(p.mean_difference, Some(-400.0));
        let i = p.difference_interval.unwrap_or(Interval { lo: 0.0, hi: 0.0 });
        assert!(i.lo >= -500.0 && i.hi <= -300.0 && i.contains(-400.0), "{i:?}");

        let p = &s.pairs[1];
        assert_eq!(p.map, "fixed");
        assert_eq!((p.pairs, p.only_a, p.only_b, p.neither), (0, 2, 0, 2));
        assert_eq!((p.mean_difference, p.difference_interval), (None, None));
    }

    #[test]
    fn paired_differences_match_seed_and_repetition_not_row_order() {
        let mut a1 = row("a", "m", 1, Some(100));
        a1.repetition = 1;
        let a0 = row("a", "m", 1, Some(200));
        let mut b1 = row("b", "m", 1, Some(150));
        b1.repetition = 1;
        let b0 = row("b", "m", 1, Some(220));
        let s = summarize(&[a1, b0, a0, b1], 1.0);
        // (seed 1, rep 0): 200 - 220; (seed 1, rep 1): 100 - 150.
        assert_eq!(s.pairs[0].differences, [-20.0, -50.0]);
    }

    #[test]
    fn ranking_orders_by_rate_then_ticks_then_name() {
        let rows = vec![
            row("slow", "m", 1, Some(900)),
            row("slow", "m", 2, Some(900)),
            row("fast", "m", 1, Some(500)),
            row("fast", "m", 2, Some(700)),
            row("flaky", "m", 1, Some(100)),
            row("flaky", "m", 2, None),
            row("never", "m", 1, None),
            row("never", "m", 2, None),
            row("also-never", "m", 1, None),
            row("also-never", "m", 2, None),
            row("same", "m", 1, Some(600)),
            row("same", "m", 2, Some(600)),
        ];
        let s = summarize(&rows, 1.0);
        let order: Vec<&str> = s.ranking.iter().map(|r| r.team.as_str()).collect();
        assert_eq!(order, ["fast", "same", "slow", "flaky", "also-never", "never"]);
        assert_eq!(s.ranking.iter().map(|r| r.rank).collect::<Vec<_>>(), [1, 2, 3, 4, 5, 6]);
        assert_eq!(s.ranking[0].ticks_mean, Some(600.0));
        assert_eq!(s.ranking[3].completion_rate, 0.5);
        assert_eq!(s.ranking[5].ticks_mean, None);
    }

    #[test]
    fn ranking_pools_maps() {
        let s = summarize(&sample(), 1.0);
        let coop = &s.ranking[0];
        assert_eq!((coop.team.as_str(), coop.matches, coop.completed), ("coop", 8, 6));
        // (1000 + 1100 + 1200 + 1300 + 800 + 900) / 6.
        assert_eq!(coop.ticks_mean, Some(1050.0));
        assert_eq!(coop.completion_interval, wilson(6, 8));
        assert_eq!(s.ranking[1].team, "baseline");
    }

    #[test]
    fn empty_input() {
        let s = summarize(&[], 12.0);
        assert_eq!((s.matches, s.completed, s.matches_per_min), (0, 0, 0.0));
        assert!(s.cells.is_empty() && s.pairs.is_empty() && s.ranking.is_empty());
        let json = s.to_json();
        assert_eq!(json["matches"], 0);
        assert_eq!(json["matches_per_min"], 0.0);
    }

    #[test]
    fn odd_wall_times_give_zero_rate() {
        for wall in [0.0, -3.0, f64::NAN, f64::INFINITY] {
            let s = summarize(&sample(), wall);
            assert_eq!((s.wall_seconds, s.matches_per_min), (0.0, 0.0));
        }
    }

    #[test]
    fn json_has_every_figure() {
        let json = summarize(&sample(), 120.0).to_json();
        assert_eq!(json["matches"], 16);
        assert_eq!(json["completed"], 9);
        assert_eq!(json["matches_per_min"], 8.0);
        assert_eq!(json["totals"]["teams"], 2);
        let cell = &json["cells"][0];
        assert_eq!(cell["team"], "coop");
        assert_eq!(cell["map"], "default");
        assert_eq!(cell["completed"], 4);
        assert_eq!(cell["ticks_mean"], 1150.0);
        assert_eq!(cell["ticks_median"], 1150.0);
        assert!(cell["ticks_mean_interval"]["lo"].is_f64());
        assert!(cell["completion_interval"]["hi"].is_f64());
        assert!(cell.get("completion_ticks").is_none());
        assert_eq!(json["cells"][3]["ticks_mean"], serde_json::Value::Null);
        assert_eq!(json["pairs"][0]["mean_difference"], -400.0);
        assert_eq!(json["pairs"][0]["only_a"], 1);
        assert_eq!(json["ranking"][0]["team"], "coop");
        assert_eq!(json["method"]["bootstrap_resamples"], 2000);
    }
}
