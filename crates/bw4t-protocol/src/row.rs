//! One finished match as a row of a results index: a line of a tournament's or a server's
//! `matches.jsonl`, a line of `matches.csv`, an element of `/api/results`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::result::MatchResult;
use crate::vocabulary::EndReason;

/// One finished match. `bw4t_tournament` names it `Row`; the tournament runner and the
/// server's results store write it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ResultRow {
    /// Identifies the match within the tournament: `team/map/seed/repetition`.
    pub key: String,
    /// The match's index in the tournament's fixed order (for sharding).
    pub index: u64,
    /// The team's name.
    pub team: String,
    /// The map as given in the config (name or path).
    pub map: String,
    /// The match seed.
    pub seed: u64,
    /// Repetition number, from 0.
    pub repetition: u32,
    /// Robots in the team.
    pub robots: usize,
    /// Whether the sequence was completed.
    pub completed: bool,
    /// Ticks simulated.
    pub ticks: u64,
    /// The first tick whose percepts showed the sequence complete, when completed (`null`
    /// otherwise).
    pub completed_tick: Option<u64>,
    /// Wall-clock milliseconds from the match's first tick to its end, as in its result; 0
    /// for a match that could not run.
    pub wall_ms: u64,
    /// Blocks delivered in order.
    pub good_drops: u32,
    /// Blocks delivered out of order.
    pub wrong_drops: u32,
    /// Messages sent.
    pub messages: u32,
    /// Agents that missed deadlines (external agents only).
    pub late_agents: u32,
    /// Agents that crashed, never connected, hung or talked garbage.
    pub crashed_agents: u32,
    /// Whether the match was ended because its wall-time budget ran out.
    #[serde(default)]
    pub out_of_time: bool,
    /// Tool calls of the team's players that report them (`bw4t mcp` does).
    #[serde(default)]
    pub tool_calls: u64,
    /// Of those, calls refused for their arguments (answered as tool errors), summed.
    #[serde(default)]
    pub invalid_calls: u64,
    /// Estimated tokens of the tool results those players returned to their models, summed.
    #[serde(default)]
    pub result_tokens: u64,
    /// Wall milliseconds those players spent deciding, summed over the team.
    #[serde(default)]
    pub think_ms: u64,
    /// Model input tokens, summed over the players that report them.
    #[serde(default)]
    pub prompt_tokens: u64,
    /// Model output tokens, summed over the players that report them.
    #[serde(default)]
    pub completion_tokens: u64,
    /// Why the match ended; `error` when it could not be played.
    pub end_reason: EndReason,
    /// Why the match could not be played, when `end_reason` is `error`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The final state digest.
    pub digest: String,
    /// The replay file, relative to the tournament directory, when kept (`null` otherwise).
    pub replay: Option<String>,
}

/// How a row fills one column of `matches.csv`.
pub(crate) type CsvField = fn(&ResultRow) -> String;

/// The columns of `matches.csv`, in order, each with how a row fills it.
pub const CSV_COLUMNS: &[(&str, CsvField)] = &[
    ("index", |r| r.index.to_string()),
    ("team", |r| csv_field(&r.team)),
    ("map", |r| csv_field(&r.map)),
    ("seed", |r| r.seed.to_string()),
    ("repetition", |r| r.repetition.to_string()),
    ("robots", |r| r.robots.to_string()),
    ("completed", |r| r.completed.to_string()),
    ("ticks", |r| r.ticks.to_string()),
    ("completed_tick", |r| r.completed_tick.map(|t| t.to_string()).unwrap_or_default()),
    ("wall_ms", |r| r.wall_ms.to_string()),
    ("good_drops", |r| r.good_drops.to_string()),
    ("wrong_drops", |r| r.wrong_drops.to_string()),
    ("messages", |r| r.messages.to_string()),
    ("late_agents", |r| r.late_agents.to_string()),
    ("crashed_agents", |r| r.crashed_agents.to_string()),
    ("out_of_time", |r| r.out_of_time.to_string()),
    ("tool_calls", |r| r.tool_calls.to_string()),
    ("invalid_calls", |r| r.invalid_calls.to_string()),
    ("result_tokens", |r| r.result_tokens.to_string()),
    ("think_ms", |r| r.think_ms.to_string()),
    ("prompt_tokens", |r| r.prompt_tokens.to_string()),
    ("completion_tokens", |r| r.completion_tokens.to_string()),
    ("end_reason", |r| r.end_reason.to_string()),
    ("error", |r| csv_field(r.error.as_deref().unwrap_or(""))),
    ("digest", |r| r.digest.clone()),
    ("replay", |r| csv_field(r.replay.as_deref().unwrap_or(""))),
];

impl ResultRow {
    /// The row of a match not (yet) played: end reason `error`, no figures; [`ResultRow::record`]
    /// fills in a result.
    pub fn unplayed(
        key: String,
        index: u64,
        team: String,
        map: String,
        seed: u64,
        robots: usize,
    ) -> ResultRow {
        ResultRow {
            key,
            index,
            team,
            map,
            seed,
            repetition: 0,
            robots,
            completed: false,
            ticks: 0,
            completed_tick: None,
            wall_ms: 0,
            good_drops: 0,
            wrong_drops: 0,
            messages: 0,
            late_agents: 0,
            crashed_agents: 0,
            out_of_time: false,
            tool_calls: 0,
            invalid_calls: 0,
            result_tokens: 0,
            think_ms: 0,
            prompt_tokens: 0,
            completion_tokens: 0,
            end_reason: EndReason::Error,
            error: None,
            digest: String::new(),
            replay: None,
        }
    }

    /// Takes the figures of a match's result (all but `crashed_agents`, which only the
    /// player of the agents knows).
    pub fn record(&mut self, result: &MatchResult) {
        self.completed = result.completed;
        self.ticks = result.ticks;
        self.completed_tick = result.completed_tick;
        self.wall_ms = result.wall_ms;
        self.good_drops = result.good_drops;
        self.wrong_drops = result.wrong_drops;
        self.messages = result.messages;
        self.late_agents = result.per_robot.iter().filter(|r| r.late_ticks > 0).count() as u32;
        // Players report their own usage: sums saturate rather than wrap on made-up figures.
        let usage = result.per_robot.iter().filter_map(|r| r.usage);
        for u in usage {
            self.tool_calls = self.tool_calls.saturating_add(u.tool_calls);
            self.invalid_calls = self.invalid_calls.saturating_add(u.invalid_calls);
            self.result_tokens = self.result_tokens.saturating_add(u.result_tokens);
            self.think_ms = self.think_ms.saturating_add(u.think_ms);
            self.prompt_tokens = self.prompt_tokens.saturating_add(u.prompt_tokens);
            self.completion_tokens = self.completion_tokens.saturating_add(u.completion_tokens);
        }
        self.end_reason = result.end_reason;
        self.digest = result.digest.clone();
    }

    /// The rows of a `matches.jsonl` text. A torn last line (its writer was killed
    /// mid-line) is dropped; any other line that is not a row is an error with its number.
    pub fn parse_lines(text: &str) -> Result<Vec<ResultRow>, (usize, serde_json::Error)> {
        let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
        let mut rows = Vec::with_capacity(lines.len());
        for (i, line) in lines.iter().enumerate() {
            match serde_json::from_str::<ResultRow>(line) {
                Ok(row) => rows.push(row),
                Err(_) if i + 1 == lines.len() => {}
                Err(e) => return Err((i + 1, e)),
            }
        }
        Ok(rows)
    }

    /// The names of `matches.csv`'s columns, in order.
    pub fn csv_header() -> impl Iterator<Item = &'static str> {
        CSV_COLUMNS.iter().map(|(name, _)| *name)
    }

    /// This row's cells of `matches.csv`, unquoted (a CSV writer quotes them), text made
    /// spreadsheet-safe.
    pub fn csv_record(&self) -> Vec<String> {
        CSV_COLUMNS.iter().map(|(_, field)| field(self)).collect()
    }
}

/// A text cell of `matches.csv`, made spreadsheet-safe.
fn csv_field(text: &str) -> String {
    spreadsheet_safe(text).into_owned()
}

/// A cell a spreadsheet will not run: one that begins with `=`, `+`, `-`, `@`, a tab or a
/// carriage return gets a leading `'`, as OWASP's guidance on CSV injection says (the JSON
/// keeps the raw value). A number (a negative one begins with `-`) is not a formula and
/// is left as it is.
pub fn spreadsheet_safe(text: &str) -> std::borrow::Cow<'_, str> {
    if text.starts_with(['=', '+', '-', '@', '\t', '\r']) && text.parse::<f64>().is_err() {
        format!("'{text}").into()
    } else {
        text.into()
    }
}

#[cfg(test)]
mod tests {
    use super::{ResultRow, spreadsheet_safe};

    #[test]
    fn text_a_spreadsheet_would_run_is_neutralised() {
        for (raw, safe) in [
            ("=HYPERLINK(\"http://x\")", "'=HYPERLINK(\"http://x\")"),
            ("+cmd|' /C calc'!A0", "'+cmd|' /C calc'!A0"),
            ("-2+3", "'-2+3"),
            ("@SUM(A1)", "'@SUM(A1)"),
            ("\tx", "'\tx"),
            ("\rx", "'\rx"),
            ("coop", "coop"),
            ("a=b", "a=b"),
            ("-12.5", "-12.5"),
        ] {
            assert_eq!(spreadsheet_safe(raw), safe, "{raw:?}");
        }
        let mut row = ResultRow::unplayed("k".into(), 1, "=1+1".into(), "fixed".into(), 1, 2);
        row.error = Some("@bad".into());
        let record = row.csv_record();
        assert_eq!((record[1].as_str(), record.last().map(String::as_str)), ("'=1+1", Some("")));
        assert!(record.contains(&"'@bad".to_string()), "{record:?}");
    }

    use crate::{EndReason, MatchResult, PlayerUsage, RobotExtra};

    #[test]
    fn usage_sums_saturate_instead_of_wrapping() {
        let map = bw4t_map::Map::from_native(include_str!("../../../maps/fixed.toml")).expect("map");
        let mut game = bw4t_sim::Match::new(&map, &bw4t_sim::MatchConfig::default(), 1).expect("match");
        for name in ["Ann", "Bob"] {
            game.join(name).expect("join");
        }
        let huge =
            PlayerUsage { tool_calls: u64::MAX, prompt_tokens: u64::MAX - 1, ..PlayerUsage::default() };
        let extra = |_| RobotExtra { usage: Some(huge), ..RobotExtra::LOCAL };
        let result = MatchResult::of(&game, None, EndReason::MaxTicks, 0, extra);
        let mut row = ResultRow::unplayed("k".into(), 1, "team".into(), "fixed".into(), 1, 2);
        row.record(&result);
        assert_eq!((row.tool_calls, row.prompt_tokens), (u64::MAX, u64::MAX));
    }
}
