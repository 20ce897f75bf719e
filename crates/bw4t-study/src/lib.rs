//! Studies of people teaming with agents: a study file (`config.rs`) of conditions, each
//! an arena template, and pages every participant goes through in order (consent,
//! instructions, practice rounds, trials in a counterbalanced order, questionnaires, a
//! final page). Each participant takes a slot (`assign.rs`): their group of conditions
//! (within, between or mixed subjects), their order and their matches' seeds.
//!
//! Each participant's every step and event is a record (`flow.rs`) in the study's SQLite
//! database, `DIR/study.sqlite3` (`store.rs`): one connection for the whole server, each
//! request's records one transaction committed before the request is answered, so a killed
//! server loses nothing already answered; at start each participant's state is rebuilt
//! from their records, after the logs of an older version are imported (`legacy.rs`). A
//! participant's routes need the secret their arrival set as a cookie (`credential.rs`).
//! The HTTP side is `api.rs` and the study's pages (`web.rs`), mounted on the server's web
//! port as [`Routes`]; [`export`] makes tidy CSV of a data directory.

mod answers;
mod api;
mod assign;
mod bonus;
mod config;
mod credential;
mod download;
mod export;
mod flow;
mod legacy;
mod markdown;
mod shuffle;
mod store;
mod values;
mod web;

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, Mutex, MutexGuard};

use serde_json::{Value, json};

pub use config::{
    Assignment, Balance, Condition, Group, Item, MapLoader, Order, Page, PracticePass, ScreenOut, Study,
    load, parse,
};
pub use export::{ExportSummary, export};

use bw4t_server::{Answering, Arena, Reply, Routes, WebRequest};
use flow::{Participant, Record};
use store::{Store, Stored};

/// A study being served: its participants, their records, the arena its trials play in.
#[derive(Clone)]
pub struct StudyServer {
    inner: Arc<Shared>,
}

struct Shared {
    study: Study,
    budget: StudyBudget,
    /// Arrivals counted per source address, against `budget.arrivals_per_minute`.
    arrivals: bw4t_server::RateBudget,
    /// Held while the dashboard's export runs.
    exporting: tokio::sync::Mutex<()>,
    store: Store,
    arena: Arena,
    participants: Mutex<BTreeMap<String, Arc<Mutex<Slot>>>>,
}

/// What anonymous clients may cost the study: how much of the page's events one
/// participant may have recorded (past either, more are refused: `429` for the count, `413`
/// for the bytes), so no client fills the disk; and how many new participants one source
/// address may make a minute (more get `429`), so no client makes thousands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StudyBudget {
    /// The most events.
    pub events: u64,
    /// The most bytes of events (each as compact JSON).
    pub bytes: u64,
    /// The most arrivals (new participants) from one source address a minute.
    pub arrivals_per_minute: u32,
}

impl StudyBudget {
    /// The default arrivals a minute from one address: a lab session's worth behind one
    /// address (a classroom's NAT) arriving at once, far below a flood.
    pub const ARRIVALS_PER_MINUTE: u32 = 60;
}

impl Default for StudyBudget {
    /// Events far above a long session's (a 30-minute trial logs some tens of thousands of
    /// events, a few MB), far below what fills a disk.
    fn default() -> StudyBudget {
        StudyBudget {
            events: 200_000,
            bytes: 32 * 1024 * 1024,
            arrivals_per_minute: StudyBudget::ARRIVALS_PER_MINUTE,
        }
    }
}

/// A participant's state, locked while a request of theirs is answered.
struct Slot {
    state: Participant,
}

/// The milliseconds since the Unix epoch (the records' `server_ms`).
pub fn now_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_millis()).unwrap_or(u64::MAX))
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(|p| p.into_inner())
}

impl StudyServer {
    /// Serves `study` on `arena` (made from [`Study::templates`]), its data in `dir`'s
    /// database (`study.sqlite3`, made if missing; the logs of an older version in
    /// `participants/` are imported into it). Every participant's state is rebuilt from
    /// their records; a trial whose match did not end before the server stopped is marked
    /// incomplete and given again. The study answers on the arena's HTTP API for as
    /// long as it is mounted on the server's web port (its [`Routes`]).
    pub fn open(study: Study, dir: &Path, arena: Arena) -> std::io::Result<StudyServer> {
        StudyServer::open_with(study, dir, arena, StudyBudget::default())
    }

    /// [`StudyServer::open`] with a budget for anonymous clients.
    pub fn open_with(
        study: Study,
        dir: &Path,
        arena: Arena,
        budget: StudyBudget,
    ) -> std::io::Result<StudyServer> {
        std::fs::create_dir_all(dir)?;
        let store = Store::open(dir)?;
        legacy::import(&store, dir)?;
        let ids = store.participants()?;
        let server = StudyServer {
            inner: Arc::new(Shared {
                study,
                arrivals: bw4t_server::RateBudget::new(
                    budget.arrivals_per_minute,
                    std::time::Duration::from_secs(60),
                ),
                budget,
                exporting: tokio::sync::Mutex::new(()),
                store,
                arena,
                participants: Mutex::new(BTreeMap::new()),
            }),
        };
        for id in ids {
            match server.reload(&id) {
                Ok(Some(slot)) => {
                    lock(&server.inner.participants).insert(id, Arc::new(Mutex::new(slot)));
                }
                Ok(None) => {}
                Err(e) => {
                    tracing::error!(target: "bw4t::study", participant = %id, error = %e, "cannot rebuild a participant's state");
                }
            }
        }
        Ok(server)
    }

    /// The study.
    pub fn study(&self) -> &Study {
        &self.inner.study
    }

    /// How many participants there are.
    pub fn participants(&self) -> usize {
        lock(&self.inner.participants).len()
    }

    /// A participant's state rebuilt from their records; a trial left running is settled.
    fn reload(&self, id: &str) -> std::io::Result<Option<Slot>> {
        let mut state: Option<Participant> = None;
        for Stored { seq, server_ms: ms, record } in self.inner.store.records(id)? {
            if let Record::Created { participant, number, order, .. } = &record {
                let order = order
                    .iter()
                    .filter_map(|c| self.inner.study.conditions.iter().position(|k| &k.name == c))
                    .collect::<Vec<_>>();
                let group = self.inner.study.groups.iter().find(|g| g.conditions.contains(&order[0]));
                let theirs = group.is_some_and(|g| {
                    let mut sorted = order.clone();
                    sorted.sort_unstable();
                    sorted == g.conditions
                });
                if order.is_empty() || !theirs {
                    return Err(std::io::Error::other("its conditions are not a group of this study's"));
                }
                state = Some(Participant::new(participant, *number, order, ms));
            }
            if let Some(state) = state.as_mut() {
                state.apply(&record, ms);
                state.seq = state.seq.max(seq);
            }
        }
        let Some(state) = state else { return Ok(None) };
        let mut slot = Slot { state };
        if let Some((_, match_id)) = slot.state.playing.clone() {
            // The server stopped during this trial. Its match either ended (the page had
            // not answered yet) or was interrupted by the stop.
            let step = slot.state.step;
            let records = match self.ended_trial(&slot.state, &match_id) {
                Ok(Ended { result, failed: None }) => {
                    self.trial_end_records(&slot.state, step, &match_id, result)
                }
                Ok(Ended { result, failed: Some(why) })
                    if result.get("end_reason") != Some(&json!("interrupted")) =>
                {
                    vec![self.incomplete(&slot.state, step, &match_id, &why)]
                }
                _ => {
                    vec![self.incomplete(&slot.state, step, &match_id, "the server stopped during the trial")]
                }
            };
            self.append(&mut slot, &records)?;
        }
        Ok(Some(slot))
    }

    fn incomplete(&self, p: &Participant, step: usize, match_id: &str, reason: &str) -> Record {
        let played = p.played_at(&self.inner.study, step);
        Record::TrialIncomplete {
            step,
            trial: played.as_ref().map_or(0, |p| p.trial),
            condition: played.as_ref().map_or_else(String::new, |p| p.condition.name.clone()),
            match_id: match_id.to_string(),
            reason: reason.to_string(),
            practice: played.is_some_and(|p| p.practice),
        }
    }

    /// The records of a trial (or practice) answered with its ended match: a practice
    /// with a pass mark is passed or failed by its result, and failed with no attempt
    /// left, screens the participant out.
    fn trial_end_records(&self, p: &Participant, step: usize, match_id: &str, result: Value) -> Vec<Record> {
        let study = &self.inner.study;
        let Some(played) = p.played_at(study, step) else { return Vec::new() };
        let (condition, trial, practice) = (played.condition.name.clone(), played.trial, played.practice);
        let passed = match &study.pages[step] {
            Page::Practice { pass: Some(PracticePass::Completed), .. } => {
                Some(result["completed"] == json!(true))
            }
            Page::Practice { pass: Some(PracticePass::Sequence(n)), .. } => {
                Some(result["sequence_index"].as_u64().unwrap_or(0) >= u64::from(*n))
            }
            _ => None,
        };
        let mut records = vec![
            Record::TrialEnded {
                step,
                trial,
                condition: condition.clone(),
                match_id: match_id.to_string(),
                result,
                practice,
            },
            Record::Answer {
                step,
                page: if practice { "practice" } else { "trial" }.into(),
                questionnaire: None,
                answers: json!({"match_id": match_id}),
                passed,
                shown: None,
            },
        ];
        if let (Some(false), Page::Practice { attempts, .. }) = (passed, &study.pages[step]) {
            if p.failed + 1 >= *attempts {
                let reason = format!("failed practice '{condition}' {} of {attempts} times", p.failed + 1);
                records.push(Record::ScreenedOut { step, reason });
            }
        }
        records
    }

    /// The finished match `match_id` of the participant's current trial, checked: of
    /// the trial's condition, with the participant among its players.
    fn ended_trial(&self, p: &Participant, match_id: &str) -> Result<Ended, TrialRefusal> {
        let study = &self.inner.study;
        let Some(played) = p.played_at(study, p.step) else {
            return Err(TrialRefusal::Bad("this step is not a trial".into()));
        };
        let condition = &played.condition.name;
        let results = self.inner.arena.results();
        let Some(row) = results.rows().into_iter().find(|r| r.key == match_id) else {
            return Err(TrialRefusal::Unknown);
        };
        if &row.team != condition {
            return Err(TrialRefusal::Bad(format!(
                "match_id: match '{match_id}' is of '{}', not of this trial's condition '{condition}'",
                row.team
            )));
        }
        let Some(result) = results.result(match_id).and_then(|r| serde_json::from_str::<Value>(&r).ok())
        else {
            return Ok(Ended {
                result: Value::Null,
                failed: row.error.as_ref().map(|e| format!("the match failed: {e}")),
            });
        };
        let name = p.player_name();
        let robot = result["per_robot"]
            .as_array()
            .and_then(|robots| robots.iter().find(|r| r["name"].as_str() == Some(name.as_str())));
        let Some(robot) = robot else {
            return Err(TrialRefusal::Bad(format!(
                "match_id: '{name}' (this participant) did not play in match '{match_id}'"
            )));
        };
        if p.used_matches.iter().any(|m| m == match_id) {
            return Err(TrialRefusal::Bad(format!("match_id: match '{match_id}' answered an earlier trial")));
        }
        // In the result but not playing (left early, or never moved when asked to): the
        // trial is given again.
        let ticks = result["ticks"].as_u64().unwrap_or(0);
        let active = ticks.saturating_sub(robot["idle_ticks"].as_u64().unwrap_or(ticks));
        let least = played.condition.min_active_ticks;
        let failed = if result["end_reason"] == json!("interrupted") {
            Some("the match was stopped before its end by the operator or the server".to_string())
        } else if robot["present"] == json!(false) {
            Some("the participant did not play: they left the match before its end".to_string())
        } else if active < least {
            Some(format!(
                "the participant did not play: their robot moved in {active} of {ticks} ticks (at least {least} needed)"
            ))
        } else {
            None
        };
        let mut kept = trial_result(&result);
        // The participant's own absences: drops of their connection and the time away.
        let tick_hz = f64::from(played.condition.tick_hz);
        kept["disconnections"] = robot["disconnections"].as_u64().unwrap_or(0).into();
        kept["absent_s"] = (robot["absent_ticks"].as_u64().unwrap_or(0) as f64 / tick_hz).into();
        kept["pauses"] = result["pauses"].as_u64().unwrap_or(0).into();
        // What the participant did themselves (their share of the team's figures).
        kept["own_deliveries"] = robot["good_drops"].as_u64().unwrap_or(0).into();
        kept["own_messages"] = robot["messages_sent"].as_u64().unwrap_or(0).into();
        kept["own_idle_s"] = (robot["idle_ticks"].as_u64().unwrap_or(0) as f64 / tick_hz).into();
        Ok(Ended { result: kept, failed })
    }

    fn slot(&self, id: &str) -> Option<Arc<Mutex<Slot>>> {
        lock(&self.inner.participants).get(id).cloned()
    }

    /// Writes `records` in one transaction and, once it is committed, applies them.
    fn append(&self, slot: &mut Slot, records: &[Record]) -> std::io::Result<()> {
        let now = now_ms();
        let first = slot.state.seq + 1;
        self.inner.store.append(&slot.state.id, first, now, records)?;
        slot.state.seq += records.len() as u64;
        for record in records {
            slot.state.apply(record, now);
        }
        Ok(())
    }
}

/// A trial's match, ended.
struct Ended {
    /// What the trial keeps of its result (`null` when the match failed).
    result: Value,
    /// Why the trial does not count (the match failed, the participant did not play).
    failed: Option<String>,
}

/// Why a trial's match cannot answer it.
enum TrialRefusal {
    /// No match of that id has ended.
    Unknown,
    /// It is not this trial's (the message says why).
    Bad(String),
}

/// What a trial keeps of its match's result.
fn trial_result(result: &Value) -> Value {
    let mut kept = serde_json::Map::new();
    for key in [
        "end_reason",
        "completed",
        "ticks",
        "completed_tick",
        "wall_ms",
        "sequence_index",
        "good_drops",
        "wrong_drops",
        "messages",
        "robots",
        "seed",
        "map",
        "digest",
    ] {
        if let Some(v) = result.get(key) {
            kept.insert(key.into(), v.clone());
        }
    }
    if let Some(sequence) = result.get("sequence").and_then(Value::as_array) {
        kept.insert("sequence_length".into(), sequence.len().into());
    }
    if let Some(robots) = result.get("per_robot").and_then(Value::as_array) {
        let names: Vec<Value> = robots.iter().map(|r| r["name"].clone()).collect();
        kept.insert("players".into(), names.into());
    }
    Value::Object(kept)
}

impl Routes for StudyServer {
    fn serves(&self, path: &str) -> bool {
        web::serves(path)
    }

    fn respond(&self, request: WebRequest) -> Answering<'_> {
        Box::pin(async move {
            let Some(rest) = request.path.trim_end_matches('/').strip_prefix("/api/study") else {
                return web::page(&request.method, &request.path);
            };
            let rest = rest.trim_start_matches('/');
            let rest: Vec<&str> = if rest.is_empty() { Vec::new() } else { rest.split('/').collect() };
            match api::respond(self, &request, &rest).await {
                api::Answer::Json(status, body) => Reply::json(status, body),
                api::Answer::Arrived(status, body, cookie) => {
                    Reply::json(status, body).with("Set-Cookie", cookie)
                }
                api::Answer::Unauthorized => {
                    Reply::unauthorized(self.inner.arena.config().server.operator_token.is_some())
                }
                api::Answer::Download(name, text) => {
                    Reply::new(http::StatusCode::OK, "text/csv; charset=utf-8", text)
                        .with("Content-Disposition", format!("attachment; filename=\"{name}\""))
                }
            }
        })
    }
}
