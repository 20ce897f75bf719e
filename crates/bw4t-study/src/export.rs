//! `bw4t study export`: a study's data directory as tidy CSV (one row per event, per trial
//! and per answer, one per participant), `metadata.json`, and each trial's replay with
//! the participant, condition and trial in its header's labels. Rows are ordered by
//! participant id, then by their records' `seq`, so two exports of the same data are
//! equal. The data is read from the study's database (read only, in one transaction, so a
//! study being served can be exported); a directory an older version wrote, with only its
//! participants' logs, is read by importing them into a database in memory.
//!
//! A cell a participant could have written cannot become a spreadsheet formula: one that
//! begins with `=`, `+`, `-`, `@`, a tab or a carriage return (and is not a plain number)
//! gets a `'` in front, as OWASP's CSV-injection guidance says; the raw values stay in the
//! database.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use super::answers::Shown;
use super::flow::{Participant, Record};
use super::store::{DATABASE, Store, Stored};

/// What an export wrote, and where.
#[derive(Clone, Debug, Default)]
pub struct ExportSummary {
    /// Where it went.
    pub out: PathBuf,
    /// How many of each thing.
    pub counts: bw4t_protocol::ExportCounts,
}

/// One trial attempt.
#[derive(Default)]
struct Trial {
    step: usize,
    trial: usize,
    condition: String,
    r#match: String,
    match_id: String,
    started_ms: Option<u64>,
    ended_ms: Option<u64>,
    result: Option<Value>,
    incomplete: Option<String>,
    practice: bool,
    /// A practice with a pass mark: passed or not.
    passed: Option<bool>,
}

const EVENT_COLUMNS: &[&str] =
    &["participant", "seq", "server_ms", "wall_ms", "step", "tick", "kind", "data"];
const TRIAL_COLUMNS: &[&str] = &[
    "participant",
    "step",
    "trial",
    "condition",
    "match",
    "match_id",
    "started_ms",
    "ended_ms",
    "complete",
    "incomplete_reason",
    "end_reason",
    "completed",
    "ticks",
    "completed_tick",
    "wall_ms",
    "sequence_index",
    "sequence_length",
    "good_drops",
    "wrong_drops",
    "messages",
    "seed",
    "map",
    "players",
    "replay",
    "disconnections",
    "absent_s",
    "pauses",
    "practice",
    "passed",
    "own_deliveries",
    "own_messages",
    "own_idle_s",
];
const ANSWER_COLUMNS: &[&str] = &[
    "participant",
    "step",
    "page",
    "questionnaire",
    "after_condition",
    "item",
    "value",
    "server_ms",
    "passed",
    "position",
];
const PARTICIPANT_COLUMNS: &[&str] = &[
    "participant",
    "number",
    "order",
    "created_ms",
    "last_ms",
    "step",
    "declined",
    "completed",
    "trials_complete",
    "trials_incomplete",
    "params",
    "slot",
    "group",
    "screened_out",
    "screen_out_reason",
    "own_deliveries",
    "own_messages",
    "idle_s",
    "team_deliveries",
    "bonus",
];

/// What a participant's complete trials add up to.
#[derive(Default)]
struct Performance {
    own_deliveries: u64,
    own_messages: u64,
    idle_s: f64,
    team_deliveries: u64,
}

/// An answer's rows of answers.csv: each item's id, value and the place it was shown at
/// (from 1, on a shuffled questionnaire: `shown`); a matrix gives one row per answered row,
/// its item `ITEM.KEY` (the row's place in the file's list, from 1: an item id has no `.`),
/// its place the row's in the grid.
fn answer_rows<'a>(given: &'a Value, shown: Option<&Shown>) -> Vec<(String, &'a Value, Option<usize>)> {
    let place = |list: &[String], key: &str| list.iter().position(|k| k == key).map(|at| at + 1);
    let mut rows = Vec::new();
    for (item, value) in given.as_object().into_iter().flatten() {
        match value.as_object() {
            Some(grid) => {
                // Row 10 after row 9, not after row 1.
                let mut grid: Vec<(&String, &Value)> = grid.iter().collect();
                grid.sort_by_key(|(key, _)| (key.len(), key.as_str()));
                for (key, value) in grid {
                    let position = shown.map(|s| match s.rows.get(item) {
                        Some(order) => place(order, key),
                        None => key.parse().ok(),
                    });
                    rows.push((format!("{item}.{key}"), value, position.flatten()));
                }
            }
            None => rows.push((item.clone(), value, shown.and_then(|s| place(&s.items, item)))),
        }
    }
    rows
}

/// Exports the study data in `dir` into `out` (made if missing).
pub fn export(dir: &Path, out: &Path) -> Result<ExportSummary, String> {
    let study_text = std::fs::read_to_string(dir.join("study.toml"))
        .map_err(|e| format!("{}: not a study's data directory: {e}", dir.display()))?;
    let study: toml::Table =
        toml::from_str(&study_text).map_err(|e| format!("{}/study.toml: {e}", dir.display()))?;
    let pages = study.get("page").and_then(toml::Value::as_array).map_or(0, Vec::len);
    let conditions: Vec<String> = study
        .get("condition")
        .and_then(toml::Value::as_array)
        .into_iter()
        .flatten()
        .filter_map(|c| c.get("name").and_then(toml::Value::as_str).map(str::to_string))
        .collect();
    let bonus = crate::bonus::Bonus::of(&study);
    let study_name =
        study.get("study").and_then(|s| s.get("name")).and_then(toml::Value::as_str).unwrap_or("");
    let logs = read(dir).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(out.join("replays"))
        .map_err(|e| format!("cannot write {}: {e}", out.display()))?;

    let mut summary = ExportSummary {
        out: out.to_path_buf(),
        counts: bw4t_protocol::ExportCounts { participants: logs.len(), ..Default::default() },
    };
    let (mut events, mut trials_csv, mut answers, mut people) =
        (header(EVENT_COLUMNS), header(TRIAL_COLUMNS), header(ANSWER_COLUMNS), header(PARTICIPANT_COLUMNS));
    let mut incomplete = Vec::new();
    for (id, lines) in &logs {
        let mut state: Option<Participant> = None;
        let mut created = (0u64, Vec::new(), Value::Null);
        // The slot and group, when assigned otherwise than by the arrival number alone.
        let mut assigned: Option<(u64, String)> = None;
        let mut screened_out = String::new();
        let mut trials: Vec<Trial> = Vec::new();
        // The condition of the latest trial, for the answers after it.
        let mut last_condition = String::new();
        for line in lines {
            match &line.record {
                Record::Created { number, order, params, .. } => {
                    created = (*number, order.clone(), params.clone());
                    state = Some(Participant::new(id, *number, Vec::new(), line.server_ms));
                }
                Record::Event { event } => {
                    summary.counts.events += 1;
                    let mut data = event.as_object().cloned().unwrap_or_default();
                    let mut take = |key: &str| cell(&data.remove(key).unwrap_or(Value::Null));
                    let (wall, step, tick, kind) =
                        (take("wall_ms"), take("step"), take("tick"), take("kind"));
                    row(
                        &mut events,
                        &[
                            id.clone(),
                            line.seq.to_string(),
                            line.server_ms.to_string(),
                            wall,
                            step,
                            tick,
                            kind,
                            Value::Object(data).to_string(),
                        ],
                    );
                }
                Record::TrialStarted { step, trial, condition, r#match, match_id, practice, .. } => {
                    if !practice {
                        last_condition.clone_from(condition);
                    }
                    trials.push(Trial {
                        step: *step,
                        trial: *trial,
                        condition: condition.clone(),
                        r#match: r#match.clone(),
                        match_id: match_id.clone(),
                        started_ms: Some(line.server_ms),
                        practice: *practice,
                        ..Trial::default()
                    });
                }
                Record::TrialEnded { step, trial, condition, match_id, result, practice } => {
                    if !practice {
                        last_condition.clone_from(condition);
                    }
                    let t = attempt(&mut trials, *step, *trial, condition, match_id);
                    t.ended_ms = Some(line.server_ms);
                    t.result = Some(result.clone());
                    t.practice = *practice;
                }
                Record::TrialIncomplete { step, trial, condition, match_id, reason, practice } => {
                    let t = attempt(&mut trials, *step, *trial, condition, match_id);
                    t.incomplete = Some(reason.clone());
                    t.practice = *practice;
                }
                Record::Assigned { slot, group } => assigned = Some((*slot, group.clone())),
                Record::ScreenedOut { reason, .. } => screened_out.clone_from(reason),
                Record::Answer { step, page, answers: given, passed, .. } if page == "practice" => {
                    if let Some(match_id) = given.get("match_id").and_then(Value::as_str) {
                        let t = trials.iter_mut().rfind(|t| t.step == *step && t.match_id == match_id);
                        if let Some(t) = t {
                            t.passed = *passed;
                        }
                    }
                }
                Record::Answer { step, page, questionnaire, answers: given, passed, shown }
                    if page != "trial" =>
                {
                    for (item, value, position) in answer_rows(given, shown.as_ref()) {
                        summary.counts.answers += 1;
                        row(
                            &mut answers,
                            &[
                                id.clone(),
                                step.to_string(),
                                page.clone(),
                                questionnaire.clone().unwrap_or_default(),
                                last_condition.clone(),
                                item,
                                cell(value),
                                line.server_ms.to_string(),
                                passed.map(|p| p.to_string()).unwrap_or_default(),
                                position.map(|p| p.to_string()).unwrap_or_default(),
                            ],
                        );
                    }
                }
                Record::Answer { .. } | Record::Resumed { .. } => {}
            }
            if let Some(state) = state.as_mut() {
                state.apply(&line.record, line.server_ms);
            }
        }
        let Some(state) = state else { continue };
        // Trials (practice rounds apart): complete, and not; what the complete ones add up to.
        let (mut complete, mut unfinished) = (0, 0);
        let mut performance = Performance::default();
        for t in &mut trials {
            if t.result.is_none() && t.incomplete.is_none() {
                t.incomplete = Some("no end recorded (the server was killed or the participant left)".into());
            }
            let replay = match t.result.is_some() || t.incomplete.is_some() {
                true => copy_replay(dir, out, id, t)?,
                false => None,
            };
            if replay.is_some() {
                summary.counts.replays += 1;
            }
            let r = t.result.clone().unwrap_or(Value::Null);
            let done = t.result.is_some();
            summary.counts.incomplete += usize::from(!done);
            if !t.practice {
                complete += usize::from(done);
                unfinished += usize::from(!done);
            }
            if let Some(reason) = t.incomplete.as_ref().filter(|_| !done) {
                incomplete.push(json!({
                    "participant": id, "step": t.step, "trial": t.trial, "condition": t.condition,
                    "match_id": t.match_id, "reason": reason,
                }));
            }
            let field = |key: &str| cell(r.get(key).unwrap_or(&Value::Null));
            row(
                &mut trials_csv,
                &[
                    id.clone(),
                    t.step.to_string(),
                    t.trial.to_string(),
                    t.condition.clone(),
                    t.r#match.clone(),
                    t.match_id.clone(),
                    t.started_ms.map(|m| m.to_string()).unwrap_or_default(),
                    t.ended_ms.map(|m| m.to_string()).unwrap_or_default(),
                    done.to_string(),
                    if done { String::new() } else { t.incomplete.clone().unwrap_or_default() },
                    field("end_reason"),
                    field("completed"),
                    field("ticks"),
                    field("completed_tick"),
                    field("wall_ms"),
                    field("sequence_index"),
                    field("sequence_length"),
                    field("good_drops"),
                    field("wrong_drops"),
                    field("messages"),
                    field("seed"),
                    field("map"),
                    r.get("players").and_then(Value::as_array).map_or(String::new(), |p| {
                        p.iter().filter_map(Value::as_str).collect::<Vec<_>>().join(";")
                    }),
                    replay.unwrap_or_default(),
                    field("disconnections"),
                    field("absent_s"),
                    field("pauses"),
                    t.practice.to_string(),
                    t.passed.map(|p| p.to_string()).unwrap_or_default(),
                    field("own_deliveries"),
                    field("own_messages"),
                    field("own_idle_s"),
                ],
            );
            if done && !t.practice {
                let figure = |key: &str| r.get(key).and_then(Value::as_f64).unwrap_or(0.0);
                performance.own_deliveries += figure("own_deliveries") as u64;
                performance.own_messages += figure("own_messages") as u64;
                performance.idle_s += figure("own_idle_s");
                performance.team_deliveries += figure("good_drops") as u64;
            }
        }
        summary.counts.trials += trials.len();
        let finished = pages > 0 && state.step + 1 == pages && !state.declined && !state.screened_out;
        // Without an assignment record: the arrival number's slot of the only group.
        let (slot, group) = assigned.unwrap_or_else(|| (created.0, String::new()));
        row(
            &mut people,
            &[
                id.clone(),
                created.0.to_string(),
                created.1.join(";"),
                state.started_ms.to_string(),
                state.last_ms.to_string(),
                state.step.to_string(),
                state.declined.to_string(),
                finished.to_string(),
                complete.to_string(),
                unfinished.to_string(),
                created.2.to_string(),
                slot.to_string(),
                group,
                state.screened_out.to_string(),
                screened_out,
                performance.own_deliveries.to_string(),
                performance.own_messages.to_string(),
                format!("{}", (performance.idle_s * 10.0).round() / 10.0),
                performance.team_deliveries.to_string(),
                bonus.as_ref().map_or(String::new(), |b| {
                    format!("{:.2}", b.amount(performance.own_deliveries, performance.team_deliveries))
                }),
            ],
        );
    }
    let write = |name: &str, text: &str| {
        std::fs::write(out.join(name), text)
            .map_err(|e| format!("cannot write {}: {e}", out.join(name).display()))
    };
    write("events.csv", &events)?;
    write("trials.csv", &trials_csv)?;
    write("answers.csv", &answers)?;
    write("participants.csv", &people)?;
    let metadata = json!({
        "study": study_name,
        "bw4t": bw4t_server::program(),
        "conditions": conditions,
        "pages": pages,
        "participants": summary.counts.participants,
        "trials": summary.counts.trials,
        "incomplete_trials": incomplete,
        "files": {
            "events.csv": EVENT_COLUMNS,
            "trials.csv": TRIAL_COLUMNS,
            "answers.csv": ANSWER_COLUMNS,
            "participants.csv": PARTICIPANT_COLUMNS,
        },
        "study_file": study_text,
    });
    let text = serde_json::to_string_pretty(&metadata).unwrap_or_default() + "\n";
    write("metadata.json", &text)?;
    Ok(summary)
}

/// The attempt of `match_id` at `step`, made if the page never said it started.
fn attempt<'a>(
    trials: &'a mut Vec<Trial>,
    step: usize,
    trial: usize,
    condition: &str,
    match_id: &str,
) -> &'a mut Trial {
    let at = trials.iter().rposition(|t| t.step == step && t.match_id == match_id);
    let at = at.unwrap_or_else(|| {
        let r#match = match_id.rsplit_once('.').map_or(match_id, |(n, _)| n).to_string();
        trials.push(Trial {
            step,
            trial,
            condition: condition.into(),
            r#match,
            match_id: match_id.into(),
            ..Trial::default()
        });
        trials.len() - 1
    });
    &mut trials[at]
}

/// Every participant's records, by id, in `seq` order: from the database, else from the
/// logs of an older version.
fn read(dir: &Path) -> std::io::Result<BTreeMap<String, Vec<Stored>>> {
    let database = dir.join(DATABASE);
    let store = if database.exists() {
        Store::open_read_only(&database)?
    } else if dir.join(super::legacy::LOGS).is_dir() {
        let store = Store::in_memory()?;
        super::legacy::import(&store, dir)?;
        store
    } else {
        return Err(std::io::Error::other(format!("{}: no study data (no {DATABASE})", dir.display())));
    };
    store.everything()
}

/// Copies a trial's replay with the participant, condition and trial added to its
/// header's labels; returns its path relative to `out`.
fn copy_replay(dir: &Path, out: &Path, participant: &str, t: &Trial) -> Result<Option<String>, String> {
    let from = dir.join("matches").join("replays").join(format!("{}.jsonl", t.match_id));
    let Ok(text) = std::fs::read_to_string(&from) else { return Ok(None) };
    let (first, rest) = text.split_once('\n').unwrap_or((&text, ""));
    let header = match serde_json::from_str::<bw4t_protocol::ReplayLine>(first) {
        Ok(bw4t_protocol::ReplayLine::Header(mut header)) => {
            header.labels.insert("participant".into(), participant.into());
            header.labels.insert("condition".into(), t.condition.clone());
            header.labels.insert("trial".into(), t.trial.to_string());
            serde_json::to_string(&bw4t_protocol::ReplayLine::Header(header))
                .unwrap_or_else(|_| first.to_string())
        }
        _ => first.to_string(),
    };
    let name = format!("replays/{participant}-trial{}-{}.jsonl", t.trial, t.match_id);
    std::fs::write(out.join(&name), format!("{header}\n{rest}"))
        .map_err(|e| format!("cannot write {}: {e}", out.join(&name).display()))?;
    Ok(Some(name))
}

fn header(columns: &[&str]) -> String {
    let mut csv = String::new();
    let cells: Vec<String> = columns.iter().map(|c| (*c).to_string()).collect();
    row(&mut csv, &cells);
    csv
}

/// Appends one record to `csv`: quoted by the `csv` crate, every cell made spreadsheet-safe.
fn row(csv: &mut String, cells: &[String]) {
    let mut writer = csv::WriterBuilder::new().from_writer(Vec::new());
    let safe = cells.iter().map(|c| bw4t_protocol::spreadsheet_safe(c));
    // Writing into memory cannot fail, and the cells are text.
    if writer.write_record(safe.map(|c| c.into_owned())).is_ok() {
        if let Ok(bytes) = writer.into_inner() {
            csv.push_str(&String::from_utf8_lossy(&bytes));
        }
    }
}

/// A JSON value as a CSV cell: strings bare, `null` empty, the rest as JSON.
fn cell(value: &Value) -> String {
    match value {
        Value::Null => String::new(),
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::row;

    #[test]
    fn cells_that_a_spreadsheet_would_run_are_neutralised() {
        let mut csv = String::new();
        let cells =
            ["=HYPERLINK(\"http://x\",\"y\")", "+1+1", "-2+3", "@SUM(A1)", "\tx", "\rx", "-12.5", "a=b"];
        row(&mut csv, &cells.map(String::from));
        assert_eq!(
            csv,
            "\"'=HYPERLINK(\"\"http://x\"\",\"\"y\"\")\",'+1+1,'-2+3,'@SUM(A1),'\tx,\"'\rx\",-12.5,a=b\n"
        );
    }
}
