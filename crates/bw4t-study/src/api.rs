//! The study's HTTP API (`/api/study/...`, JSON): the study's name and conditions; a
//! participant's arrival, state, answers, trial starts and events; the operator's list
//! of participants. Every refusal is a 4xx whose `error` names the problem.
//!
//! A participant's routes need their credential (`credential.rs`): `401` without it,
//! `403` with a wrong one. Every `POST` must say `Content-Type: application/json`, which a
//! cross-site form or `text/plain` request cannot, so another site cannot make participants
//! or write in their name (the `SameSite=Strict` cookie is not sent cross-site either).

use bw4t_protocol::{
    ErrorReply, EventsRecorded, MatchState, MatchSummary, ParticipantList, ParticipantRow, ParticipantState,
    StepConflict, StudyPage,
};
use bw4t_server::WebRequest;
use http::{HeaderMap, Method, StatusCode};
use serde::Serialize;
use serde_json::{Value, json};

use super::assign::{Holder, slot_for};
use super::credential::{self, Proof};
use super::flow::{Participant, Record, event_size, group_of, order_for, valid_id};
use super::{Ended, Slot, StudyServer, TrialRefusal, lock, now_ms};

/// What a study request is answered with.
pub(crate) enum Answer {
    /// A JSON body with a status.
    Json(StatusCode, String),
    /// A participant's arrival: a JSON body, a status and the credential's `Set-Cookie`.
    Arrived(StatusCode, String, String),
    /// The operator's token is needed.
    Unauthorized,
    /// A file of the export, to be saved under its name.
    Download(String, String),
}

/// The body of a JSON answer. Made through a `Value`, so the keys come in alphabetical
/// order at every depth, as the study's answers always have.
pub(crate) fn reply_body(body: &impl Serialize) -> Result<String, serde_json::Error> {
    serde_json::to_value(body).map(|value| value.to_string())
}

/// A JSON answer (one of `bw4t_protocol`'s study replies) with a status.
pub(crate) fn reply(status: StatusCode, body: &impl Serialize) -> Answer {
    match reply_body(body) {
        Ok(text) => Answer::Json(status, text),
        Err(e) => error(StatusCode::INTERNAL_SERVER_ERROR, format!("reply not serialisable: {e}")),
    }
}

pub(crate) fn error(status: StatusCode, message: impl Into<String>) -> Answer {
    let body = ErrorReply { error: message.into() };
    Answer::Json(status, serde_json::to_string(&body).unwrap_or_default())
}

/// The parameters of a link that may carry the participant's id, in the order looked at.
const ID_PARAMS: &[&str] = &["PROLIFIC_PID", "participant", "pid", "workerId", "PARTICIPANT_ID"];

/// The kinds of event the page sends.
const EVENT_KINDS: &[&str] = &[
    "page_shown",
    "key",
    "click",
    "act",
    "ack",
    "done",
    "message_sent",
    "message_received",
    "percepts",
    "focus",
    "blur",
    "visibility",
    "lobby",
    "welcome",
    "match_over",
];

/// The most events one request may carry.
const MAX_EVENTS: usize = 1000;
/// How long a trial's end waits for its match to be recorded as ended (see `is_running`).
const END_WAIT: std::time::Duration = std::time::Duration::from_secs(3);

/// Answers `request` on `/api/study/REST...`.
pub(crate) async fn respond(study: &StudyServer, request: &WebRequest, rest: &[&str]) -> Answer {
    let (method, body, operator, headers) =
        (&request.method, &request.body[..], request.operator, &request.headers);
    if method == Method::POST && !is_json(headers) {
        return error(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "Content-Type: a POST to the study must be application/json",
        );
    }
    match (method, rest) {
        (&Method::GET, []) => reply(StatusCode::OK, &study.study().info()),
        (_, ["participants"] | ["export", ..]) if !operator && method == Method::GET => Answer::Unauthorized,
        (&Method::POST, ["export"]) if !operator => Answer::Unauthorized,
        (&Method::POST, ["export"]) => study.export_now().await,
        (&Method::GET, ["export", file]) => study.exported(file),
        (&Method::GET, ["participants"]) => reply(StatusCode::OK, &study.list().await),
        (&Method::POST, ["participants"]) => match parse(body) {
            Ok(body) => study.arrive(&body, headers, request.source),
            Err(answer) => answer,
        },
        (&Method::GET, ["participants", id]) => {
            with_participant(study, id, headers, |slot| reply(StatusCode::OK, &study.state_of(&slot.state)))
        }
        (&Method::POST, ["participants", id, what @ ("answer" | "trial" | "events")]) => {
            let body = match parse(body) {
                Ok(body) => body,
                Err(answer) => return answer,
            };
            match *what {
                "answer" => study.answer(id, &body, headers).await,
                "trial" => {
                    let mut body = body;
                    if let (None, Some(name)) =
                        (body.get("match_id"), body.get("match").and_then(Value::as_str).map(str::to_string))
                    {
                        if let Some(id) = study.match_id_of(&name).await {
                            body["match_id"] = id.into();
                        }
                    }
                    study.trial_started(id, &body, headers)
                }
                _ => study.events(id, &body, headers),
            }
        }
        (&Method::GET | &Method::POST, _) => {
            error(StatusCode::NOT_FOUND, format!("no such route: {method} /api/study/{}", rest.join("/")))
        }
        _ => error(StatusCode::METHOD_NOT_ALLOWED, "only GET and POST"),
    }
}

fn parse(body: &[u8]) -> Result<Value, Answer> {
    match serde_json::from_slice::<Value>(body) {
        Ok(value @ Value::Object(_)) => Ok(value),
        Ok(_) => Err(error(StatusCode::BAD_REQUEST, "the body must be a JSON object")),
        Err(e) => Err(error(StatusCode::BAD_REQUEST, format!("the body is not JSON: {e}"))),
    }
}

fn bad_id(id: &str) -> Answer {
    let shown: String = id.chars().take(80).collect();
    error(
        StatusCode::BAD_REQUEST,
        format!("participant: '{shown}' is not a participant id (1 to 64 letters, digits, '-' or '_')"),
    )
}

/// Whether the request says its body is JSON.
fn is_json(headers: &HeaderMap) -> bool {
    headers
        .get(http::header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.split(';').next())
        .is_some_and(|kind| kind.trim().eq_ignore_ascii_case("application/json"))
}

/// Participant `id`'s slot, if the request proves to be theirs.
fn authorized(
    study: &StudyServer,
    id: &str,
    headers: &HeaderMap,
) -> Result<std::sync::Arc<std::sync::Mutex<Slot>>, Answer> {
    if !valid_id(id) {
        return Err(bad_id(id));
    }
    if credential::presented(headers, id).is_none() {
        return Err(error(
            StatusCode::UNAUTHORIZED,
            format!("participant '{id}': no credential (this browser did not arrive as them)"),
        ));
    }
    let Some(slot) = study.slot(id) else {
        return Err(error(StatusCode::NOT_FOUND, format!("no participant '{id}'")));
    };
    let proof = credential::check(headers, id, lock(&slot).state.secret_sha256.as_deref());
    match proof {
        Proof::Valid => Ok(slot),
        Proof::Missing | Proof::Wrong => {
            Err(error(StatusCode::FORBIDDEN, format!("participant '{id}': the credential is not theirs")))
        }
    }
}

fn with_participant(
    study: &StudyServer,
    id: &str,
    headers: &HeaderMap,
    f: impl FnOnce(&mut Slot) -> Answer,
) -> Answer {
    match authorized(study, id, headers) {
        Ok(slot) => f(&mut lock(&slot)),
        Err(answer) => answer,
    }
}

fn write_failed(e: &std::io::Error) -> Answer {
    tracing::error!(target: "bw4t::study", error = %e, "cannot write to the study's database");
    error(StatusCode::INTERNAL_SERVER_ERROR, "the server could not record this; please try again")
}

/// The `step` of a body, which must be the participant's current one.
fn check_step(study: &StudyServer, p: &Participant, body: &Value) -> Result<(), Answer> {
    let Some(step) = body.get("step").and_then(Value::as_u64) else {
        return Err(error(StatusCode::BAD_REQUEST, "step: expected the step's number"));
    };
    if p.stopped() || step != p.step as u64 {
        let why = if p.declined {
            "the participant declined consent; the study has ended for them".to_string()
        } else if p.screened_out {
            "the participant was screened out; the study has ended for them".to_string()
        } else {
            format!("step {step} is not the participant's current step ({})", p.step)
        };
        return Err(conflict(why, p, study));
    }
    Ok(())
}

/// `409`: why, and the participant's state.
fn conflict(why: String, p: &Participant, study: &StudyServer) -> Answer {
    reply(StatusCode::CONFLICT, &StepConflict { error: why, state: study.state_of(p) })
}

impl StudyServer {
    /// The participant's state as the API answers it: on a trial (or practice), with the
    /// seat token that binds their seat in the condition's matches to them and makes a
    /// match made for them play the seed of their slot and the trial's position.
    fn state_of(&self, p: &Participant) -> ParticipantState {
        let mut state = p.state(self.study());
        let seed = p.played_at(self.study(), p.step).map(|played| played.seed);
        if let Some(StudyPage::Trial { hello, view, .. } | StudyPage::Practice { hello, view, .. }) =
            &mut state.page
        {
            let arena = &self.inner.arena;
            hello.seat = arena.invite_seeded(&hello.template, &hello.name, seed).ok();
            if view.as_str() == "overview" {
                let template = arena.config().templates.iter().find(|t| t.name == hello.template);
                hello.watch_token = template.and_then(|t| t.config.spectator_token.clone());
            }
            // A trial under way: any page of theirs (a reload, a new tab) takes the robot back.
            if let (Some((name, _)), Some(session)) = (&p.playing, &p.playing_session) {
                hello.match_name = Some(name.clone());
                hello.session = Some(session.clone());
            }
        }
        state
    }

    /// `POST /api/study/participants`: a new participant, or one coming back.
    fn arrive(&self, body: &Value, headers: &HeaderMap, source: std::net::IpAddr) -> Answer {
        let params = body.get("params").cloned().unwrap_or_else(|| json!({}));
        let Some(map) = params.as_object() else {
            return error(StatusCode::BAD_REQUEST, "params: expected an object (the link's query)");
        };
        let given = ID_PARAMS.iter().find_map(|k| map.get(*k).and_then(Value::as_str).map(|v| (*k, v)));
        if let Some((key, id)) = given {
            if !valid_id(id) {
                let shown: String = id.chars().take(80).collect();
                return error(
                    StatusCode::BAD_REQUEST,
                    format!("{key}: '{shown}' is not a participant id (1 to 64 letters, digits, '-' or '_')"),
                );
            }
        }
        let mut all = lock(&self.inner.participants);
        let id = match given {
            Some((_, id)) => id.to_string(),
            None => loop {
                let id = generated_id();
                if !all.contains_key(&id) {
                    break id;
                }
            },
        };
        if all.contains_key(&id) {
            // Coming back: only the browser that arrived as them, with its credential.
            drop(all);
            let slot = match authorized(self, &id, headers) {
                Ok(slot) => slot,
                Err(Answer::Json(status, _)) if status == StatusCode::UNAUTHORIZED => {
                    return error(
                        StatusCode::FORBIDDEN,
                        format!(
                            "participant '{id}' has started the study in another browser; only that \
                             browser can continue (ask the experimenter)"
                        ),
                    );
                }
                Err(answer) => return answer,
            };
            let mut slot = lock(&slot);
            return match self.append(&mut slot, &[Record::Resumed { params }]) {
                Ok(()) => reply(StatusCode::OK, &self.state_of(&slot.state)),
                Err(e) => write_failed(&e),
            };
        }
        // Only a new participant counts against the address's arrivals.
        if let Err(wait) = self.inner.arrivals.take(source, std::time::Instant::now()) {
            return error(
                StatusCode::TOO_MANY_REQUESTS,
                format!(
                    "too many new participants from your address: at most {} a minute; try again in {} s",
                    self.inner.arrivals.limit(),
                    wait.as_secs().max(1)
                ),
            );
        }
        let secret = match credential::new_secret() {
            Ok(secret) => secret,
            Err(e) => return write_failed(&e),
        };
        let number = match self.inner.store.next_number() {
            Ok(number) => number,
            Err(e) => return write_failed(&e),
        };
        let study = self.study();
        // Who holds a slot now (the lock on everyone keeps two arrivals from taking one).
        let now = now_ms();
        let holders: Vec<Holder> = all
            .values()
            .filter_map(|slot| {
                let p = &lock(slot).state;
                p.holds_slot(study, now).then(|| Holder { slot: p.slot, conditions: p.order.clone() })
            })
            .collect();
        let Some(taken) = slot_for(study, number, &holders) else {
            // No participant is made: a later arrival may find a slot given up.
            return error(StatusCode::SERVICE_UNAVAILABLE, study.full_text.clone());
        };
        let order = order_for(study, taken, &id);
        let names = order.iter().map(|c| study.conditions[*c].name.clone()).collect();
        let mut slot = Slot { state: Participant::new(&id, number, order, now) };
        let mut records = vec![Record::Created {
            participant: id.clone(),
            number,
            order: names,
            params,
            secret_sha256: Some(credential::digest(&secret)),
        }];
        if taken != number || study.groups.len() > 1 {
            let group = study.groups[group_of(study, taken)].name.clone();
            records.push(Record::Assigned { slot: taken, group });
        }
        if let Err(e) = self.append(&mut slot, &records) {
            return write_failed(&e);
        }
        let state = self.state_of(&slot.state);
        let cookie = credential::set_cookie(&id, &secret, headers);
        all.insert(id, std::sync::Arc::new(std::sync::Mutex::new(slot)));
        match reply(StatusCode::CREATED, &state) {
            Answer::Json(status, body) => Answer::Arrived(status, body, cookie),
            other => other,
        }
    }

    /// `POST .../ID/answer`.
    async fn answer(&self, id: &str, body: &Value, headers: &HeaderMap) -> Answer {
        let slot = match authorized(self, id, headers) {
            Ok(slot) => slot,
            Err(answer) => return answer,
        };
        let mut answers = body.get("answers").cloned().unwrap_or_else(|| json!({}));
        // A page that knows only the match's name gets the id of its latest run.
        if let (None, Some(name)) =
            (answers.get("match_id"), answers.get("match").and_then(Value::as_str).map(str::to_string))
        {
            if let Some(id) = self.match_id_of(&name).await {
                answers["match_id"] = id.into();
            }
        }
        // A trial's match is asked about before the participant is locked (it may wait).
        let page = {
            let slot = lock(&slot);
            if let Err(answer) = check_step(self, &slot.state, body) {
                return answer;
            }
            self.study().pages[slot.state.step].clone()
        };
        let running = match (&page, answers.get("match_id").and_then(Value::as_str)) {
            (super::Page::Trial { .. } | super::Page::Practice { .. }, Some(match_id)) => {
                self.is_running(match_id).await
            }
            _ => false,
        };
        let mut slot = lock(&slot);
        if let Err(answer) = check_step(self, &slot.state, body) {
            return answer;
        }
        let step = slot.state.step;
        let records = match &page {
            super::Page::Consent { .. } => match answers.get("consent") {
                Some(Value::Bool(consent)) => {
                    vec![Record::Answer {
                        step,
                        page: "consent".into(),
                        questionnaire: None,
                        answers: json!({"consent": consent}),
                        passed: None,
                        shown: None,
                    }]
                }
                _ => return error(StatusCode::BAD_REQUEST, "consent: expected true or false"),
            },
            super::Page::Instructions { .. } => {
                vec![Record::Answer {
                    step,
                    page: "instructions".into(),
                    questionnaire: None,
                    answers: json!({}),
                    passed: None,
                    shown: None,
                }]
            }
            super::Page::Questionnaire { id: questionnaire, items, pass, attempts, shuffle, .. } => {
                match super::answers::check(items, &answers) {
                    Ok(checked) => {
                        let passed = pass.map(|pass| super::answers::correct(items, &checked) >= pass);
                        let mut records = vec![Record::Answer {
                            step,
                            page: "questionnaire".into(),
                            questionnaire: Some(questionnaire.clone()),
                            answers: checked,
                            passed,
                            shown: super::answers::shown(
                                self.study().seed,
                                &slot.state.id,
                                questionnaire,
                                items,
                                *shuffle,
                            ),
                        }];
                        let tries = slot.state.failed + 1;
                        if passed == Some(false) && tries >= *attempts {
                            let reason =
                                format!("failed questionnaire '{questionnaire}' {tries} of {attempts} times");
                            records.push(Record::ScreenedOut { step, reason });
                        }
                        records
                    }
                    Err(why) => return error(StatusCode::BAD_REQUEST, why),
                }
            }
            super::Page::Trial { .. } | super::Page::Practice { .. } => {
                let Some(match_id) = answers.get("match_id").and_then(Value::as_str) else {
                    return error(
                        StatusCode::BAD_REQUEST,
                        "match_id: expected the match's id (welcome.match.id)",
                    );
                };
                if running {
                    return error(StatusCode::CONFLICT, "the trial's match is still running");
                }
                match self.ended_trial(&slot.state, match_id) {
                    Ok(Ended { failed: None, result }) => {
                        self.trial_end_records(&slot.state, step, match_id, result)
                    }
                    Ok(Ended { failed: Some(why), .. }) => {
                        // The trial is given again.
                        vec![self.incomplete(&slot.state, step, match_id, &why)]
                    }
                    Err(TrialRefusal::Unknown) => {
                        return error(
                            StatusCode::NOT_FOUND,
                            format!("match_id: no match '{match_id}' has ended on this server"),
                        );
                    }
                    Err(TrialRefusal::Bad(why)) => return error(StatusCode::BAD_REQUEST, why),
                }
            }
            super::Page::Final { .. } => {
                return conflict("the final page takes no answer".into(), &slot.state, self);
            }
        };
        match self.append(&mut slot, &records) {
            Ok(()) => reply(StatusCode::OK, &self.state_of(&slot.state)),
            Err(e) => write_failed(&e),
        }
    }

    /// The id of the live match named `name`, else of its latest finished run.
    async fn match_id_of(&self, name: &str) -> Option<String> {
        let summary = self.inner.arena.summary(name, true).await?;
        summary.id
    }

    /// Whether the live match of `match_id`'s name is that very match. The page reports a
    /// trial's end as soon as it sees `match_end`, which can come before the arena has
    /// recorded the end: a running match is given up to `END_WAIT` to end first.
    async fn is_running(&self, match_id: &str) -> bool {
        let Some((name, _)) = match_id.rsplit_once('.') else { return false };
        let arena = &self.inner.arena;
        let deadline = tokio::time::Instant::now() + END_WAIT;
        loop {
            // Counted before looking, so an end in between is not waited for.
            let ended = arena.ended_so_far();
            let summary = arena.summary(name, true).await;
            if !summary.is_some_and(|s| is_live_run(&s, match_id)) {
                return false;
            }
            if tokio::time::timeout_at(deadline, arena.ended(ended + 1)).await.is_err() {
                return true;
            }
        }
    }

    /// `POST .../ID/trial`: the page's word that the trial's match started.
    fn trial_started(&self, id: &str, body: &Value, headers: &HeaderMap) -> Answer {
        with_participant(self, id, headers, |slot| {
            if let Err(answer) = check_step(self, &slot.state, body) {
                return answer;
            }
            let step = slot.state.step;
            let Some(played) = slot.state.played_at(self.study(), step) else {
                return conflict(format!("step {step} is not a trial"), &slot.state, self);
            };
            let (Some(name), Some(match_id)) =
                (body.get("match").and_then(Value::as_str), body.get("match_id").and_then(Value::as_str))
            else {
                return error(
                    StatusCode::BAD_REQUEST,
                    "match, match_id: expected the match's name and id (welcome.match)",
                );
            };
            if !is_match_id(name, match_id) || bw4t_server::check_match_name(name).is_err() {
                return error(
                    StatusCode::BAD_REQUEST,
                    format!("match_id: '{match_id}' is not an id of match '{name}'"),
                );
            }
            if slot.state.playing.as_ref().is_some_and(|(_, playing)| playing == match_id) {
                // Said again (a page that retried, or took the robot back): recorded already.
                return reply(StatusCode::OK, &self.state_of(&slot.state));
            }
            let session = match body.get("session") {
                None | Some(Value::Null) => None,
                Some(Value::String(s))
                    if (1..=64).contains(&s.len()) && s.bytes().all(|b| b.is_ascii_hexdigit()) =>
                {
                    Some(s.clone())
                }
                Some(_) => {
                    return error(StatusCode::BAD_REQUEST, "session: expected the welcome's session token");
                }
            };
            let record = Record::TrialStarted {
                step,
                trial: played.trial,
                condition: played.condition.name.clone(),
                r#match: name.to_string(),
                match_id: match_id.to_string(),
                practice: played.practice,
                session,
            };
            match self.append(slot, &[record]) {
                Ok(()) => reply(StatusCode::OK, &self.state_of(&slot.state)),
                Err(e) => write_failed(&e),
            }
        })
    }

    /// `POST .../ID/events`: events the page saw, appended with the server's time.
    fn events(&self, id: &str, body: &Value, headers: &HeaderMap) -> Answer {
        let Some(events) = body.get("events").and_then(Value::as_array) else {
            return error(StatusCode::BAD_REQUEST, "events: expected a list of events");
        };
        if events.len() > MAX_EVENTS {
            return error(StatusCode::BAD_REQUEST, format!("events: at most {MAX_EVENTS} in one request"));
        }
        for (i, event) in events.iter().enumerate() {
            let kind = event.get("kind").and_then(Value::as_str);
            match kind {
                _ if !event.is_object() => {
                    return error(StatusCode::BAD_REQUEST, format!("events[{i}]: expected an object"));
                }
                Some(kind) if EVENT_KINDS.contains(&kind) => {}
                Some(kind) => {
                    return error(
                        StatusCode::BAD_REQUEST,
                        format!("events[{i}]: kind '{kind}' is not one of {}", EVENT_KINDS.join(", ")),
                    );
                }
                None => return error(StatusCode::BAD_REQUEST, format!("events[{i}]: kind: expected a word")),
            }
        }
        let (bytes, study_budget): (u64, _) = (events.iter().map(event_size).sum(), self.inner.budget);
        with_participant(self, id, headers, |slot| {
            let (p, budget) = (&slot.state, study_budget);
            if p.events + events.len() as u64 > budget.events {
                return error(
                    StatusCode::TOO_MANY_REQUESTS,
                    format!("events: participant '{id}' may record at most {} events", budget.events),
                );
            }
            if p.event_bytes + bytes > budget.bytes {
                return error(
                    StatusCode::PAYLOAD_TOO_LARGE,
                    format!("events: participant '{id}' may record at most {} bytes of events", budget.bytes),
                );
            }
            let records: Vec<Record> = events.iter().map(|e| Record::Event { event: e.clone() }).collect();
            match self.append(slot, &records) {
                Ok(()) => reply(StatusCode::OK, &EventsRecorded { recorded: records.len() }),
                Err(e) => write_failed(&e),
            }
        })
    }

    /// `GET /api/study/participants` (operator): everyone, by id.
    async fn list(&self) -> ParticipantList {
        let slots: Vec<_> = lock(&self.inner.participants).values().cloned().collect();
        let mut participants = Vec::with_capacity(slots.len());
        for slot in slots {
            let mut row = {
                let slot = lock(&slot);
                let p = &slot.state;
                let study = self.study();
                let page = study.pages.get(p.step);
                ParticipantRow {
                    participant: p.id.clone(),
                    number: p.number,
                    step: p.step,
                    steps: study.pages.len(),
                    page_kind: if p.declined {
                        "declined"
                    } else if p.screened_out {
                        "screened_out"
                    } else {
                        page.map_or("", |p| p.kind())
                    }
                    .to_string(),
                    completed: p.completed(study),
                    started_ms: p.started_ms,
                    last_ms: p.last_ms,
                    condition: p.played_at(study, p.step).map(|played| played.condition.name.clone()),
                    match_name: p.playing.as_ref().map(|(name, _)| name.clone()),
                    match_id: p.playing.as_ref().map(|(_, id)| id.clone()),
                    conditions: p.order.iter().map(|c| study.conditions[*c].name.clone()).collect(),
                }
            };
            // A match that has ended is no longer live.
            if let (Some(name), Some(id)) = (&row.match_name, &row.match_id) {
                let live = self.inner.arena.summary(name, true).await;
                if !live.is_some_and(|s| is_live_run(&s, id)) {
                    row.match_name = None;
                }
            }
            participants.push(row);
        }
        ParticipantList { participants }
    }
}

/// Whether `summary` (the operator's) is of the live run `id`.
fn is_live_run(summary: &MatchSummary, id: &str) -> bool {
    summary.id.as_deref() == Some(id) && summary.state != MatchState::Finished
}

/// Whether `id` is what a run of match `name` is called: the name, `.`, the run number.
fn is_match_id(name: &str, id: &str) -> bool {
    let run = id.strip_prefix(name).and_then(|rest| rest.strip_prefix('.'));
    run.is_some_and(|run| (1..=20).contains(&run.len()) && run.bytes().all(|b| b.is_ascii_digit()))
}

/// A participant id for a link that carries none: `anon-` and 12 hex digits.
fn generated_id() -> String {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(now_ms());
    format!("anon-{:012x}", h.finish() & 0xffff_ffff_ffff)
}
