//! Studies: a participant's whole way through the HTTP API with a scripted player over
//! the protocol, counterbalancing, resuming (reload, restart, a killed server), the
//! export's rows, and refusals of bad study files and bad requests; and what a hostile
//! visitor tries (acting as a participant whose id they know, cross-site requests, open
//! files, event floods, match ids that are paths) refused; the study's database read by a
//! connection of its own, as a researcher would, and an older version's logs imported.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use bw4t_protocol::{
    ErrorReply, EventsRecorded, ParticipantList, ParticipantState, QuestionItem, QuestionKind,
    ScreenRequirement, StepConflict, StudyInfo, StudyPage, TrialHello, TrialLanguage,
};
use bw4t_server::{Arena, ArenaConfig, ResultsStore};
use bw4t_study::{self as study, StudyBudget, StudyServer};
use serde_json::{Value, json};
use tokio::sync::oneshot;

use crate::util::{AutoPlayer, Client, WAIT, http, shipped_map, welcomed};

const TOKEN: &str = "op-secret";

/// Two conditions of lockstep matches of 20 ticks (one person, one built-in teammate), and
/// every kind of page.
const STUDY: &str = r##"
[study]
name = "pilot"
title = "Pilot"
seed = 7
order = "counterbalanced"
mode = "lockstep"
tick_hz = 20
time_limit_s = 1

[[condition]]
name = "alpha"
teammates = 1
strategy = "coop"
# The scripted player only says `ready`: staying to the end is its playing.
min_active_ticks = 0
free_text = false
kinds = ["going_to", "have"]
briefing = "Your teammate **talks**."

[[condition]]
name = "beta"
teammates = 1
strategy = "baseline"
min_active_ticks = 0
view = "overview"

[[page]]
kind = "consent"
text = "Do you agree? <b>raw</b>"

[[page]]
kind = "instructions"
text = "# Play"

[[page]]
kind = "trial"

[[page]]
kind = "questionnaire"
id = "after"

[[page.item]]
id = "teamwork"
kind = "likert"
text = "We worked well together."
scale = 7
labels = ["no", "yes"]

[[page.item]]
id = "load"
kind = "choice"
text = "How hard?"
options = ["easy", "hard"]

[[page.item]]
id = "note"
kind = "text"
text = "Anything else?"
required = false

[[page]]
kind = "trial"

[[page]]
kind = "final"
text = "Code {code} for {participant}."
completion_code = "ABC123"
redirect = "https://example.org/done?cc={code}&p={participant}"
"##;

pub(crate) fn temp_dir(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bw4t-study-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// Shipped maps by name; anything else is not found.
pub(crate) fn maps(spec: &str) -> Result<bw4t_map::Map, String> {
    let known = Path::new(repo_root!()).join("maps").join(format!("{spec}.toml")).is_file();
    if known { Ok(shipped_map(spec)) } else { Err(format!("no shipped map named '{spec}'")) }
}

pub(crate) fn parse(text: &str) -> Result<study::Study, String> {
    study::parse(text, Path::new("study.toml"), &maps)
}

/// One browser: a cookie jar sent with every request and filled by every `Set-Cookie`.
#[derive(Clone, Default)]
pub(crate) struct Browser {
    jar: std::sync::Arc<std::sync::Mutex<std::collections::BTreeMap<String, String>>>,
}

/// An answer: its status, its head's lines, its body.
struct Answered {
    status: u16,
    head: Vec<String>,
    body: String,
}

impl Answered {
    /// The `Set-Cookie` values.
    fn cookies(&self) -> Vec<&str> {
        self.head
            .iter()
            .filter_map(|l| l.split_once(':'))
            .filter(|(name, _)| name.eq_ignore_ascii_case("set-cookie"))
            .map(|(_, value)| value.trim())
            .collect()
    }
}

impl Browser {
    /// `method path` with `headers` (and the jar's cookies), over a new connection.
    async fn send(
        &self,
        addr: SocketAddr,
        method: &str,
        path: &str,
        headers: &[(&str, &str)],
        body: &str,
    ) -> Answered {
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        let mut stream = tokio::net::TcpStream::connect(addr).await.expect("connect");
        let mut request = format!("{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n");
        let cookies: Vec<String> =
            self.jar.lock().expect("jar").iter().map(|(k, v)| format!("{k}={v}")).collect();
        if !cookies.is_empty() {
            request += &format!("Cookie: {}\r\n", cookies.join("; "));
        }
        for (name, value) in headers {
            request += &format!("{name}: {value}\r\n");
        }
        request += &format!("Content-Length: {}\r\n\r\n{body}", body.len());
        let _ = stream.write_all(request.as_bytes()).await;
        let mut answer = Vec::new();
        let _ = tokio::time::timeout(WAIT, stream.read_to_end(&mut answer)).await.expect("an answer in time");
        let answer = String::from_utf8_lossy(&answer).into_owned();
        let (head, body) = answer.split_once("\r\n\r\n").unwrap_or((&answer, ""));
        let head: Vec<String> = head.lines().map(str::to_string).collect();
        let status = head
            .first()
            .and_then(|l| l.split(' ').nth(1))
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("a status: {answer}"));
        let answered = Answered { status, head, body: body.to_string() };
        for cookie in answered.cookies() {
            let pair = cookie.split(';').next().unwrap_or("");
            if let Some((name, value)) = pair.split_once('=') {
                self.jar.lock().expect("jar").insert(name.trim().into(), value.trim().into());
            }
        }
        answered
    }

    /// A JSON request (`GET` without a body).
    async fn json(&self, addr: SocketAddr, method: &str, path: &str, body: Option<&Value>) -> (u16, Value) {
        let body = body.map(Value::to_string).unwrap_or_default();
        let got = self.send(addr, method, path, &[("Content-Type", "application/json")], &body).await;
        let reply =
            serde_json::from_str(&got.body).unwrap_or_else(|e| panic!("not JSON ({e}): {}", got.body));
        (got.status, reply)
    }
}

/// A study served in-process on loopback ports, its data in `dir`.
pub(crate) struct StudyRig {
    /// The one browser the test's participants use.
    pub(crate) browser: Browser,
    pub(crate) arena: Arena,
    pub(crate) addr: SocketAddr,
    http: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<()>,
    _study: StudyServer,
}

impl StudyRig {
    pub(crate) async fn start(dir: &Path, text: &str) -> StudyRig {
        StudyRig::start_as(dir, text, Browser::default(), StudyBudget::default()).await
    }

    /// A study whose participants use `browser`, each with `budget` of events.
    pub(crate) async fn start_as(dir: &Path, text: &str, browser: Browser, budget: StudyBudget) -> StudyRig {
        std::fs::write(dir.join("study.toml"), text).expect("study copy");
        let study = parse(text).expect("the study file is good");
        let mut config = ArenaConfig::new(study.templates());
        config.default = None;
        config.server.operator_token = Some(TOKEN.into());
        config.results = ResultsStore::in_dir(&dir.join("matches")).expect("results dir");
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let http = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let (addr, http_addr) = (listener.local_addr().expect("addr"), http.local_addr().expect("addr"));
        let arena = Arena::start(config).expect("the arena starts");
        let served = StudyServer::open_with(study, dir, arena.clone(), budget).expect("the study opens");
        let (stop, stopped) = oneshot::channel::<()>();
        let running = arena.clone();
        let routes: Vec<std::sync::Arc<dyn bw4t_server::Routes>> = vec![std::sync::Arc::new(served.clone())];
        let task = tokio::spawn(async move {
            let shutdown = async {
                let _ = stopped.await;
            };
            bw4t_server::serve_arena(
                &running,
                listener,
                Some(bw4t_server::Web { listener: http, routes }),
                shutdown,
            )
            .await;
        });
        StudyRig { browser, arena, addr, http: http_addr, stop: Some(stop), task, _study: served }
    }

    pub(crate) async fn shutdown(mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        tokio::time::timeout(WAIT, &mut self.task).await.expect("the server stops in time").expect("task");
    }

    pub(crate) async fn call(&self, method: &str, path: &str, body: Option<Value>) -> (u16, Value) {
        let body = body.map(|b| b.to_string()).unwrap_or_default();
        let json = [("Content-Type", "application/json")];
        let Answered { status, body: text, .. } =
            self.browser.send(self.http, method, path, &json, &body).await;
        let reply: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("not JSON ({e}): {text}"));
        assert_eq!(
            text,
            reply.to_string(),
            "the study answers with its keys in alphabetical order, as always"
        );
        (status, reply)
    }

    pub(crate) async fn operator(&self, method: &str, path: &str) -> (u16, Value) {
        let (status, text) = http(self.http, method, path, Some(TOKEN), Some("")).await;
        (status, serde_json::from_str(&text).unwrap_or_else(|e| panic!("not JSON ({e}): {text}")))
    }

    /// Answers step `step` of `id` and expects the state after it.
    pub(crate) async fn answer(&self, id: &str, step: usize, answers: Value) -> ParticipantState {
        let (status, state) = self
            .call(
                "POST",
                &format!("/api/study/participants/{id}/answer"),
                Some(json!({"step": step, "answers": answers})),
            )
            .await;
        assert_eq!(status, 200, "{state}");
        let state: ParticipantState = read(&state);
        assert_eq!(state.step, step + 1, "{state:?}");
        state
    }

    /// Plays the trial the state shows to its end with a player answering every tick, and
    /// answers it; returns the state after.
    async fn play_trial(&self, id: &str, state: &ParticipantState) -> ParticipantState {
        let Some(StudyPage::Trial { hello, .. }) = &state.page else { panic!("not a trial: {state:?}") };
        let ended: u64 = self.arena.totals().values().map(|t| t.ended).sum();
        let hello = player_fields(hello);
        let mut player = AutoPlayer::join_with(self.addr, hello).await;
        let name = player.welcome.match_info.name.clone();
        let step = state.step;
        // Said twice, as a page that retries does: one trial row all the same.
        for _ in 0..2 {
            let started = json!({"step": step, "match": name, "match_id": player.welcome.match_info.id});
            let path = format!("/api/study/participants/{id}/trial");
            let (status, answer) = self.call("POST", &path, Some(started)).await;
            assert_eq!(status, 200, "{answer}");
        }
        player.wait("the match's end", |s| s.ended.then_some(())).await;
        tokio::time::timeout(WAIT, self.arena.ended(ended + 1)).await.expect("the match is recorded in time");
        let (_, summary) = self.operator("GET", &format!("/api/matches/{name}")).await;
        let match_id = summary["id"].as_str().expect("the operator sees the id").to_string();
        self.answer(id, step, json!({"match_id": match_id})).await
    }
}

/// A reply read back as its type in `bw4t_protocol`.
pub(crate) fn read<T: serde::de::DeserializeOwned>(reply: &Value) -> T {
    serde_json::from_value(reply.clone()).unwrap_or_else(|e| panic!("not the expected reply ({e}): {reply}"))
}

/// The `kind` of a state's page (`none` past the last page).
pub(crate) fn kind_of(state: &ParticipantState) -> String {
    let page = serde_json::to_value(&state.page).expect("json");
    page["kind"].as_str().unwrap_or("none").to_string()
}

/// A CSV file's rows as maps of column to cell (no quoted commas in what these tests read).
pub(crate) fn csv_rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    lines
        .map(|l| header.iter().map(|h| h.to_string()).zip(l.split(',').map(str::to_string)).collect())
        .collect()
}

/// Participant `id`'s records as a connection of its own reads them from the study's
/// database in `dir`: `seq`, `type` and the record's fields, their `created` first.
pub(crate) fn stored(dir: &Path, id: &str) -> Vec<(u64, String, Value)> {
    let database = dir.join("study.sqlite3");
    assert!(database.is_file(), "{} is missing", database.display());
    let connection = rusqlite::Connection::open(&database).expect("open the database");
    let sql = "SELECT 1, 'created', json_object('participant', id, 'number', number, \
               'order', json(condition_order), 'params', json(params)) FROM participants WHERE id = ?1 \
               UNION ALL SELECT seq, type, data FROM records WHERE participant = ?1 ORDER BY 1";
    let mut statement = connection.prepare(sql).expect("the tables are there");
    let rows = statement.query_map([id], |r| {
        let row: (i64, String, String) = (r.get(0)?, r.get(1)?, r.get(2)?);
        Ok(row)
    });
    rows.expect("query")
        .map(|row| {
            let (seq, kind, data) = row.expect("a row");
            (seq as u64, kind, serde_json::from_str(&data).expect("JSON data"))
        })
        .collect()
}

/// The `type`s of what `stored` gives.
fn types(records: &[(u64, String, Value)]) -> Vec<&str> {
    records.iter().map(|(_, kind, _)| kind.as_str()).collect()
}

pub(crate) async fn arrive(rig: &StudyRig, id: &str) -> (u16, Value) {
    rig.call(
        "POST",
        "/api/study/participants",
        Some(json!({"params": {"PROLIFIC_PID": id, "STUDY_ID": "s1"}})),
    )
    .await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_study_pages_and_every_module_they_import_are_served() {
    let dir = temp_dir("pages");
    let rig = StudyRig::start(&dir, STUDY).await;
    let served = crate::web::modules_of(rig.http, &["/study", "/study/admin"]).await;
    crate::web::assert_every_module_in_use("crates/bw4t-study/web", &served);
    rig.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_participant_goes_through_the_whole_study_and_the_export_has_every_row() {
    let dir = temp_dir("flow");
    let rig = StudyRig::start(&dir, STUDY).await;
    let (status, info) = rig.call("GET", "/api/study", None).await;
    let info: StudyInfo = read(&info);
    assert_eq!(
        (status, info.name.as_str(), info.conditions),
        (200, "pilot", vec!["alpha".into(), "beta".into()])
    );
    // The file sets no device needs: a computer's window of 1024 x 640 at least.
    assert_eq!(info.screen, ScreenRequirement { min_width: 1024, min_height: 640, allow_touch_only: false });

    let (status, state) = arrive(&rig, "alice").await;
    assert_eq!(status, 201, "{state}");
    let state: ParticipantState = read(&state);
    assert_eq!((state.step, state.steps), (0, 6));
    let Some(StudyPage::Consent { html, .. }) = &state.page else { panic!("consent first: {state:?}") };
    assert!(html.contains("&lt;b&gt;raw&lt;/b&gt;") && !html.contains("<b>"), "raw HTML is escaped: {html}");
    // Coming back with the link, or asking again, gives the same step.
    let (status, again) = arrive(&rig, "alice").await;
    assert_eq!((status, read::<ParticipantState>(&again)), (200, state.clone()));
    let (_, got) = rig.call("GET", "/api/study/participants/alice", None).await;
    assert_eq!(read::<ParticipantState>(&got), state);

    // Refusals name the problem.
    let (status, wrong) = rig
        .call("POST", "/api/study/participants/alice/answer", Some(json!({"step": 1, "answers": {}})))
        .await;
    assert_eq!(status, 409, "{wrong}");
    let wrong: StepConflict = read(&wrong);
    assert!(wrong.error.contains("step 1"), "{wrong:?}");
    assert_eq!(wrong.state, state);
    let (status, bad) =
        rig.call("POST", "/api/study/participants", Some(json!({"params": {"pid": "a b/c"}}))).await;
    assert!(status == 400 && read::<ErrorReply>(&bad).error.contains("pid"), "{bad}");
    // No one arrived as 'nobody' in this browser: no credential, whether they exist or not.
    let (status, bad) = rig.call("GET", "/api/study/participants/nobody", None).await;
    assert_eq!(status, 401, "{bad}");
    let (status, bad) = rig
        .call(
            "POST",
            "/api/study/participants/alice/answer",
            Some(json!({"step": 0, "answers": {"consent": "yes"}})),
        )
        .await;
    assert!(status == 400 && read::<ErrorReply>(&bad).error.contains("consent"), "{bad}");
    let json = [("Content-Type", "application/json")];
    let path = "/api/study/participants/alice/answer";
    let got = rig.browser.send(rig.http, "POST", path, &json, "{not json").await;
    assert_eq!(got.status, 400, "{}", got.body);
    let big = format!("{{\"events\": [\"{}\"]}}", "x".repeat(70 * 1024));
    let got = rig.browser.send(rig.http, "POST", "/api/study/participants/alice/events", &json, &big).await;
    assert_eq!(got.status, 413, "a body over 64 KB is refused");
    let (status, _) = rig.call("GET", "/api/study/participants", None).await;
    assert_eq!(status, 401, "only the operator lists participants");

    rig.answer("alice", 0, json!({"consent": true})).await;
    let state = rig.answer("alice", 1, json!({})).await;
    let Some(StudyPage::Trial { trial, trials, hello, language, view, time_limit_s, html, .. }) = &state.page
    else {
        panic!("a trial: {state:?}")
    };
    assert_eq!((*trial, *trials), (1, 2));
    let alice_seat = hello.seat.clone().expect("a trial's hello carries a seat token");
    let first = TrialHello {
        template: "alpha".into(),
        name: "P1".into(),
        seat: Some(alice_seat.clone()),
        watch_token: None,
        match_name: None,
        session: None,
    };
    assert_eq!(hello, &first, "the first to arrive starts with alpha");
    assert!(alice_seat.len() == 32 && alice_seat.bytes().all(|b| b.is_ascii_hexdigit()), "{alice_seat}");
    assert_eq!(language, &TrialLanguage { kinds: vec!["going_to".into(), "have".into()], free_text: false });
    assert_eq!((view.as_str(), *time_limit_s), ("own", 1));
    assert!(html.as_deref().is_some_and(|h| h.contains("<strong>talks</strong>")), "{state:?}");

    // The second participant gets the other order.
    let (_, bob) = arrive(&rig, "bob").await;
    assert_eq!(bob["step"], 0);
    rig.answer("bob", 0, json!({"consent": true})).await;
    let bob = rig.answer("bob", 1, json!({})).await;
    let Some(StudyPage::Trial { hello, view, .. }) = &bob.page else { panic!("a trial: {bob:?}") };
    assert_eq!((hello.template.as_str(), hello.name.as_str()), ("beta", "P2"));
    assert!(hello.seat.as_ref().is_some_and(|seat| seat != &alice_seat), "each participant's own seat");
    let watch_token = hello.watch_token.clone().expect("an overview condition's watch token");
    assert_eq!(view, "overview");

    // Events: any content type, appended with the server's time; unknown kinds refused.
    let events = json!({"events": [
        {"wall_ms": 1, "tick": null, "step": 2, "kind": "page_shown"},
        {"wall_ms": 2, "tick": 3, "step": 2, "kind": "key", "key": "p"},
        {"wall_ms": 3, "tick": 4, "step": 2, "kind": "act", "id": 1, "action": "goTo", "args": ["RoomA1"]},
    ]});
    let (status, recorded) = rig.call("POST", "/api/study/participants/alice/events", Some(events)).await;
    assert_eq!((status, read::<EventsRecorded>(&recorded).recorded), (200, 3), "{recorded}");
    let (status, bad) = rig
        .call("POST", "/api/study/participants/alice/events", Some(json!({"events": [{"kind": "dance"}]})))
        .await;
    assert!(status == 400 && read::<ErrorReply>(&bad).error.contains("dance"), "{bad}");

    // The trial: an answer while its match runs is refused; a finished one is taken.
    let hello = json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "P1", "template": "alpha",
                       "seat": alice_seat});
    let (client, welcome) = welcomed(rig.addr, hello).await;
    let name = welcome.match_info.name.clone();
    // Nobody else sits in a participant's match or takes their name: not without a seat
    // token, not with someone else's or a made-up one, not by naming the match.
    for (fields, code) in [
        (json!({"name": "P1", "template": "alpha"}), "not_invited"),
        (json!({"name": "P9", "template": "alpha", "seat": alice_seat}), "bad_token"),
        (json!({"name": "P1", "template": "alpha", "seat": "0".repeat(32)}), "bad_token"),
        (json!({"name": "P1", "match": name}), "not_invited"),
        // Nor watches it: an own-view condition's match is the operator's to watch, and
        // another condition's watch token opens nothing here.
        (json!({"role": "spectator", "match": name}), "bad_token"),
        (json!({"role": "spectator", "match": name, "token": watch_token}), "bad_token"),
    ] {
        let mut outsider = Client::connect(rig.addr).await;
        let mut hello = json!({"type": "hello", "protocol": "bw4t", "versions": [1]});
        hello.as_object_mut().expect("object").extend(fields.as_object().expect("object").clone());
        outsider.send(hello.clone()).await;
        assert_eq!(outsider.error_code().await, code, "{hello}");
    }
    let (status, _) = rig
        .call("POST", "/api/study/participants/alice/trial", Some(json!({"step": 2, "match": name})))
        .await;
    assert_eq!(status, 200);
    // The operator pauses and resumes the live match.
    let (status, _) = http(rig.http, "POST", &format!("/api/matches/{name}/pause"), None, Some("")).await;
    assert_eq!(status, 401);
    let (status, paused) = rig.operator("POST", &format!("/api/matches/{name}/pause")).await;
    assert_eq!(
        (status, paused["paused"].as_bool(), paused["name"].as_str()),
        (200, Some(true), Some(name.as_str()))
    );
    // Paused, the match cannot end: an answer is refused (after the server's short wait
    // for an end it may not have recorded yet).
    let (status, running) = rig
        .call(
            "POST",
            "/api/study/participants/alice/answer",
            Some(json!({"step": 2, "answers": {"match": name}})),
        )
        .await;
    assert_eq!(status, 409, "{running}");
    assert!(read::<ErrorReply>(&running).error.contains("still running"), "{running}");
    let (status, resumed) = rig.operator("POST", &format!("/api/matches/{name}/resume")).await;
    assert_eq!((status, resumed["paused"].as_bool()), (200, Some(false)), "{resumed}");
    let (status, _) = rig.operator("POST", "/api/matches/nothing-here/pause").await;
    assert_eq!(status, 404);
    // Bob may not answer his trial with Alice's match.
    let (_, summary) = rig.operator("GET", &format!("/api/matches/{name}")).await;
    let alice_match = summary["id"].as_str().expect("id").to_string();
    let mut player = AutoPlayer::adopt(client, welcome);
    // The participant was told of the pause and of the resume.
    let pauses = player.wait("pause and resume", |s| (s.pauses.len() >= 2).then(|| s.pauses.clone())).await;
    assert_eq!(pauses, [true, false]);
    player.wait("the match's end", |s| s.ended.then_some(())).await;
    tokio::time::timeout(WAIT, rig.arena.ended(1)).await.expect("the match is recorded");
    let (status, bad) = rig
        .call(
            "POST",
            "/api/study/participants/bob/answer",
            Some(json!({"step": 2, "answers": {"match_id": alice_match}})),
        )
        .await;
    assert!(status == 400 && read::<ErrorReply>(&bad).error.contains("beta"), "{status} {bad}");
    let state = rig.answer("alice", 2, json!({"match_id": alice_match})).await;
    let Some(StudyPage::Questionnaire { id, items, .. }) = &state.page else {
        panic!("questions: {state:?}")
    };
    assert_eq!(id, "after");
    let teamwork = QuestionItem {
        id: "teamwork".into(),
        text: "We worked well together.".into(),
        required: true,
        show_if: None,
        kind: QuestionKind::Likert { scale: 7, labels: ["no".into(), "yes".into()] },
    };
    assert_eq!(items[0], teamwork);

    // Questionnaire checks name the item.
    for (answers, needle) in [
        (json!({"load": "easy"}), "teamwork"),
        (json!({"teamwork": 8, "load": "easy"}), "teamwork"),
        (json!({"teamwork": 3, "load": "medium"}), "load"),
        (json!({"teamwork": 3, "load": "easy", "extra": 1}), "extra"),
    ] {
        let (status, bad) = rig
            .call(
                "POST",
                "/api/study/participants/alice/answer",
                Some(json!({"step": 3, "answers": answers})),
            )
            .await;
        assert!(status == 400 && read::<ErrorReply>(&bad).error.contains(needle), "{answers}: {bad}");
    }
    let state = rig.answer("alice", 3, json!({"teamwork": 6, "load": "hard", "note": "fun"})).await;
    assert!(
        matches!(&state.page, Some(StudyPage::Trial { hello, .. }) if hello.template == "beta"),
        "{state:?}"
    );
    let state = rig.play_trial("alice", &state).await;
    let Some(StudyPage::Final { html, completion_code, redirect, .. }) = &state.page else {
        panic!("the final page: {state:?}")
    };
    assert_eq!(completion_code.as_deref(), Some("ABC123"));
    assert_eq!(redirect.as_deref(), Some("https://example.org/done?cc=ABC123&p=alice"));
    assert!(html.contains("Code ABC123 for alice."), "{html}");
    let (status, done) = rig
        .call("POST", "/api/study/participants/alice/answer", Some(json!({"step": 5, "answers": {}})))
        .await;
    assert_eq!(status, 409, "{done}");
    assert!(read::<StepConflict>(&done).error.contains("final page"), "{done}");

    let (status, list) = rig.operator("GET", "/api/study/participants").await;
    assert_eq!(status, 200, "{list}");
    let people = read::<ParticipantList>(&list).participants;
    assert_eq!(people.len(), 2);
    assert_eq!((people[0].participant.as_str(), people[0].completed), ("alice", true));
    assert_eq!((people[1].page_kind.as_str(), people[1].condition.as_deref()), ("trial", Some("beta")));
    rig.shutdown().await;

    let out = dir.join("export");
    let summary = study::export(&dir, &out).expect("export");
    assert_eq!(
        (summary.counts.participants, summary.counts.trials, summary.counts.incomplete),
        (2, 2, 0),
        "{summary:?}"
    );
    let trials = csv_rows(&out.join("trials.csv"));
    let conditions: Vec<(&str, &str, &str)> = trials
        .iter()
        .map(|t| (t["participant"].as_str(), t["condition"].as_str(), t["complete"].as_str()))
        .collect();
    assert_eq!(conditions, [("alice", "alpha", "true"), ("alice", "beta", "true")]);
    assert!(trials.iter().all(|t| t["end_reason"] == "max_ticks" && t["ticks"] == "20"), "{trials:?}");
    let marks: Vec<(&str, &str)> =
        trials.iter().map(|t| (t["pauses"].as_str(), t["disconnections"].as_str())).collect();
    assert_eq!(marks, [("1", "0"), ("0", "0")], "the operator paused alice's first trial once");
    let answers = csv_rows(&out.join("answers.csv"));
    let teamwork: Vec<(&str, &str)> = answers
        .iter()
        .filter(|a| a["item"] == "teamwork")
        .map(|a| (a["after_condition"].as_str(), a["value"].as_str()))
        .collect();
    assert_eq!(teamwork, [("alpha", "6")]);
    assert!(
        answers.iter().any(|a| a["participant"] == "bob" && a["item"] == "consent" && a["value"] == "true")
    );
    let events = csv_rows(&out.join("events.csv"));
    let kinds: Vec<&str> = events.iter().map(|e| e["kind"].as_str()).collect();
    assert_eq!(kinds, ["page_shown", "key", "act"]);
    let people = csv_rows(&out.join("participants.csv"));
    assert_eq!((people[0]["order"].as_str(), people[0]["completed"].as_str()), ("alpha;beta", "true"));
    assert_eq!((people[1]["order"].as_str(), people[1]["completed"].as_str()), ("beta;alpha", "false"));
    let metadata: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metadata.json")).expect("metadata"))
            .expect("json");
    assert_eq!(metadata["conditions"], json!(["alpha", "beta"]));
    assert!(metadata["study_file"].as_str().is_some_and(|t| t.contains("name = \"pilot\"")));
    // Each trial's replay, labelled with the participant, condition and trial.
    let replay = out.join(&trials[1]["replay"]);
    let header: Value = serde_json::from_str(
        std::fs::read_to_string(&replay).expect("replay copied").lines().next().expect("header"),
    )
    .expect("json");
    assert_eq!(header["labels"]["participant"], "alice");
    assert_eq!(
        (header["labels"]["condition"].as_str(), header["labels"]["trial"].as_str()),
        (Some("beta"), Some("2"))
    );
    // The same data exports the same rows.
    let again = dir.join("export2");
    study::export(&dir, &again).expect("export again");
    for file in ["trials.csv", "answers.csv", "events.csv", "participants.csv"] {
        assert_eq!(std::fs::read(out.join(file)).ok(), std::fs::read(again.join(file)).ok(), "{file}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_restarted_server_continues_each_participant_and_gives_a_lost_trial_again() {
    let dir = temp_dir("restart");
    let rig = StudyRig::start(&dir, STUDY).await;
    arrive(&rig, "carol").await;
    rig.answer("carol", 0, json!({"consent": true})).await;
    let state = rig.answer("carol", 1, json!({})).await;
    let Some(StudyPage::Trial { hello, .. }) = &state.page else { panic!("a trial: {state:?}") };
    // Carol's trial starts, and the server stops under it.
    let hello = json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "P1", "template": "alpha",
                       "seat": hello.seat});
    let (client, welcome) = welcomed(rig.addr, hello).await;
    let (status, _) = rig
        .call(
            "POST",
            "/api/study/participants/carol/trial",
            Some(json!({"step": 2, "match": welcome.match_info.name})),
        )
        .await;
    assert_eq!(status, 200);
    let browser = rig.browser.clone();
    rig.shutdown().await;
    drop(client);

    let rig = StudyRig::start_as(&dir, STUDY, browser, StudyBudget::default()).await;
    let (status, again) = rig.call("GET", "/api/study/participants/carol", None).await;
    let again: ParticipantState = read(&again);
    // With a new seat token: the one granted before the restart died with that server.
    let seat_of = |state: &ParticipantState| match &state.page {
        Some(StudyPage::Trial { hello, .. }) => hello.seat.clone(),
        _ => None,
    };
    assert_ne!(seat_of(&again), seat_of(&state), "a new server grants new seats");
    let mut same = again.clone();
    if let Some(StudyPage::Trial { hello, .. }) = &mut same.page {
        hello.seat = seat_of(&state);
    }
    assert_eq!((status, &same), (200, &state), "the same trial is given again");
    let records = stored(&dir, "carol");
    assert_eq!(
        types(&records),
        ["created", "answer", "answer", "trial_started", "trial_incomplete"],
        "{records:?}"
    );
    let seqs: Vec<u64> = records.iter().map(|(seq, _, _)| *seq).collect();
    assert_eq!(seqs, (1..=seqs.len() as u64).collect::<Vec<_>>(), "seq numbers go on across the restart");
    let state = rig.play_trial("carol", &again).await;
    assert_eq!(kind_of(&state), "questionnaire");
    // Declining consent ends the study for that participant.
    arrive(&rig, "dan").await;
    let body = json!({"step": 0, "answers": {"consent": false}});
    let (status, dan) = rig.call("POST", "/api/study/participants/dan/answer", Some(body.clone())).await;
    assert_eq!((status, kind_of(&read(&dan))), (200, "declined".into()), "{dan}");
    let (status, _) = rig.call("POST", "/api/study/participants/dan/answer", Some(body)).await;
    assert_eq!(status, 409);
    rig.shutdown().await;

    let out = dir.join("export");
    let summary = study::export(&dir, &out).expect("export");
    assert_eq!((summary.counts.trials, summary.counts.incomplete), (2, 1), "{summary:?}");
    let trials = csv_rows(&out.join("trials.csv"));
    assert_eq!(trials[0]["complete"], "false");
    assert!(trials[0]["incomplete_reason"].contains("server stopped"), "{trials:?}");
    assert_eq!((trials[1]["complete"].as_str(), trials[1]["trial"].as_str()), ("true", "1"));
    let metadata: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metadata.json")).expect("metadata"))
            .expect("json");
    assert_eq!(metadata["incomplete_trials"][0]["participant"], "carol");
    let people = csv_rows(&out.join("participants.csv"));
    assert_eq!((people[1]["participant"].as_str(), people[1]["declined"].as_str()), ("dan", "true"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Stops a child process when dropped.
struct KillOnDrop(std::process::Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `bw4t study FILE --data DATA` as its own process, on ports it picked.
struct StudyProcess {
    child: KillOnDrop,
    /// Its standard output, kept open so its writes go on succeeding.
    _lines: std::io::Lines<std::io::BufReader<std::process::ChildStdout>>,
    addr: SocketAddr,
    web: SocketAddr,
}

impl StudyProcess {
    fn spawn(file: &Path, data: &Path) -> StudyProcess {
        StudyProcess::spawn_with(file, data, &[])
    }

    /// Started with more options.
    fn spawn_with(file: &Path, data: &Path, options: &[&str]) -> StudyProcess {
        use std::io::BufRead;
        let mut child = KillOnDrop(
            std::process::Command::new(env!("CARGO_BIN_EXE_bw4t"))
                .args(["study", file.to_str().expect("path"), "--data", data.to_str().expect("path")])
                .args(["--port", "0", "--http", "0", "--operator-token", TOKEN, "-q"])
                .args(options)
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::null())
                .spawn()
                .expect("start bw4t study"),
        );
        let mut lines = std::io::BufReader::new(child.0.stdout.take().expect("stdout")).lines();
        let mut next = |prefix: &str| {
            let line = lines.next().expect("a line").expect("read");
            line.strip_prefix(prefix)
                .unwrap_or_else(|| panic!("expected '{prefix}...', got {line}"))
                .to_string()
        };
        let addr: SocketAddr = next("listening on ").parse().expect("address");
        let web: SocketAddr = next("http on ").parse().expect("address");
        let dashboard =
            (0..4).map(|_| next("")).find(|l| l.starts_with("dashboard: ")).expect("a dashboard line");
        assert!(dashboard.ends_with(&format!("/study/admin?token={TOKEN}")), "{dashboard}");
        StudyProcess { child, _lines: lines, addr, web }
    }

    /// Kills it (`SIGKILL`: nothing of it runs after) and waits for it to be gone.
    fn kill(mut self) {
        self.child.0.kill().expect("kill");
        self.child.0.wait().expect("wait");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_server_loses_nothing_acknowledged_and_a_restart_continues_from_it() {
    let dir = temp_dir("killed");
    let file = dir.join("pilot.toml");
    std::fs::write(
        &file,
        STUDY
            .replace("mode = \"lockstep\"", "mode = \"realtime\"")
            .replace("time_limit_s = 1", "time_limit_s = 600"),
    )
    .expect("study file");
    let data = dir.join("data");
    let server = StudyProcess::spawn(&file, &data);
    let web = server.web;
    let browser = Browser::default();
    let arrival = json!({"params": {"participant": "erin"}});
    let (status, _) = browser.json(web, "POST", "/api/study/participants", Some(&arrival)).await;
    assert_eq!(status, 201);
    let mut state = Value::Null;
    for (step, answers) in [(0, json!({"consent": true})), (1, json!({}))] {
        let body = json!({"step": step, "answers": answers});
        let (status, answered) =
            browser.json(web, "POST", "/api/study/participants/erin/answer", Some(&body)).await;
        assert_eq!(status, 200);
        state = answered;
    }
    let player = AutoPlayer::join_with(server.addr, state["page"]["hello"].clone()).await;
    let body = json!({"step": 2, "match": player.welcome.match_info.name});
    let (status, _) = browser.json(web, "POST", "/api/study/participants/erin/trial", Some(&body)).await;
    assert_eq!(status, 200);
    let events = json!({"events": [{"kind": "key", "key": "p", "step": 2}, {"kind": "blur", "step": 2}]});
    let (status, _) = browser.json(web, "POST", "/api/study/participants/erin/events", Some(&events)).await;
    assert_eq!(status, 200);
    let (status, before) = browser.json(web, "GET", "/api/study/participants/erin", None).await;
    assert_eq!(status, 200, "{before}");
    server.kill();

    // Everything acknowledged is in the database, whole.
    let killed = stored(&data, "erin");
    assert_eq!(
        types(&killed),
        ["created", "answer", "answer", "trial_started", "event", "event"],
        "{killed:?}"
    );
    assert_eq!(killed[5].2["event"]["kind"], "blur");
    let export = crate::util::bw4t_within(&["study", "export", data.to_str().expect("path")], WAIT);
    assert!(export.status.success(), "{}", String::from_utf8_lossy(&export.stderr));
    let printed = String::from_utf8_lossy(&export.stdout);
    assert!(printed.contains("1 trial (1 without an end)"), "{printed}");
    let trials = csv_rows(&data.join("export/trials.csv"));
    assert_eq!((trials[0]["participant"].as_str(), trials[0]["complete"].as_str()), ("erin", "false"));
    assert!(trials[0]["incomplete_reason"].contains("no end recorded"), "{trials:?}");
    drop(player);

    // Restarted: the participant is where they were (the lost trial given again), their
    // credential still theirs, and what was recorded is still there, unchanged.
    let server = StudyProcess::spawn(&file, &data);
    let (status, mut after) = browser.json(server.web, "GET", "/api/study/participants/erin", None).await;
    // But for the seat token: a restarted server grants new ones.
    let seat = &mut after["page"]["hello"]["seat"];
    assert!(seat.is_string() && seat != &before["page"]["hello"]["seat"], "{after}");
    *seat = before["page"]["hello"]["seat"].clone();
    assert_eq!((status, &after), (200, &before), "the same state after the restart");
    let restarted = stored(&data, "erin");
    assert_eq!(&restarted[..killed.len()], &killed[..], "nothing recorded is changed");
    assert_eq!(types(&restarted[killed.len()..]), ["trial_incomplete"], "{restarted:?}");
    let (status, _) =
        browser.json(server.web, "POST", "/api/study/participants/erin/events", Some(&events)).await;
    assert_eq!(status, 200);
    assert_eq!(stored(&data, "erin").len(), restarted.len() + 2, "numbered on after the restart");
    server.kill();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_study_files_are_refused_naming_the_problem() {
    let cases: [(&str, &str, &str, &[&str]); 10] = [
        ("an unknown key", "name = \"alpha\"\n", "name = \"alpha\"\ncolour = \"red\"\n", &["colour"]),
        (
            "an unknown strategy",
            "strategy = \"coop\"",
            "strategy = \"genius\"",
            &["condition 1 'alpha'", "strategy = 'genius'", "coop"],
        ),
        (
            "a bad map",
            "name = \"beta\"\n",
            "name = \"beta\"\nmap = \"nowhere\"\n",
            &["condition 2 'beta'", "map = 'nowhere'"],
        ),
        (
            "no trial pages",
            "kind = \"trial\"",
            "kind = \"instructions\"\ntext = \"x\"",
            &["1 trial page and 2 conditions"],
        ),
        ("a bad likert scale", "scale = 7", "scale = 1", &["page 4", "'teamwork'", "scale = 1"]),
        (
            "an unknown kind of message",
            "kinds = [\"going_to\", \"have\"]",
            "kinds = [\"dance\"]",
            &["condition 1", "kinds", "dance"],
        ),
        (
            "a tick rate out of range",
            "tick_hz = 20",
            "tick_hz = 5000",
            &["condition 1 'alpha'", "ticks per second must be from 1 to 1000, got 5000"],
        ),
        (
            "a partner timeout the clock cannot add",
            "name = \"alpha\"\n",
            "name = \"alpha\"\nhumans = 2\npartner_timeout_s = 99999999999\n",
            &["condition 'alpha'", "the start timeout must be from"],
        ),
        (
            "a final page not last",
            "[[page]]\nkind = \"final\"",
            "[[page]]\nkind = \"final\"\n[[page]]\nkind = \"instructions\"\ntext = \"x\"\n[[page]]\nkind = \"final\"",
            &["final must be the last page"],
        ),
        (
            "a negative bonus",
            "[[condition]]\nname = \"alpha\"",
            "[bonus]\nper_own_block = -0.5\n\n[[condition]]\nname = \"alpha\"",
            &["bonus: per_own_block = -0.5", "0 or more"],
        ),
    ];
    parse(STUDY).expect("the good file loads");
    for (what, from, to, needles) in cases {
        assert!(STUDY.contains(from), "{what}: the test's file has '{from}'");
        let text = STUDY.replacen(from, to, 1);
        let error = parse(&text).err().unwrap_or_else(|| panic!("{what}: accepted"));
        for needle in needles {
            assert!(error.contains(needle), "{what}: '{error}' should name '{needle}'");
        }
    }
    // Reading a file names it.
    let dir = temp_dir("bad");
    let path = dir.join("broken.toml");
    std::fs::write(&path, STUDY.replace("strategy = \"coop\"", "strategy = \"genius\"")).expect("write");
    let error = study::load(&path, &maps).expect_err("refused");
    assert!(error.starts_with(&path.display().to_string()), "{error}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_study_sets_the_device_it_needs_and_a_too_small_screen_is_refused() {
    let text =
        STUDY.replacen("seed = 7\n", "seed = 7\nmin_screen = [1280, 720]\nallow_touch_only = true\n", 1);
    let study = parse(&text).expect("the file loads");
    assert_eq!(
        study.info().screen,
        ScreenRequirement { min_width: 1280, min_height: 720, allow_touch_only: true }
    );
    let error =
        parse(&STUDY.replacen("seed = 7\n", "seed = 7\nmin_screen = [320, 200]\n", 1)).expect_err("refused");
    assert!(error.contains("min_screen = [320, 200]"), "{error}");
    let error =
        parse(&STUDY.replacen("seed = 7\n", "seed = 7\nmin_screen = 1024\n", 1)).expect_err("refused");
    assert!(error.contains("min_screen"), "{error}");
}

#[test]
fn the_example_study_loads() {
    let path = Path::new(repo_root!()).join("examples/study/study.toml");
    let study = study::load(&path, &maps).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = study.conditions.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["talking", "silent"]);
    assert_eq!(study.trials(), 2);
    assert!(matches!(study.pages.last(), Some(study::Page::Final { completion_code: Some(_), .. })));

    // Its between-subjects variant, with a practice round and a comprehension check.
    let path = Path::new(repo_root!()).join("examples/study/between.toml");
    let between = study::load(&path, &maps).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(between.assignment, study::Assignment::Between);
    assert_eq!(between.balance, study::Balance::Completers);
    let groups: Vec<&str> = between.groups.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(groups, ["talking", "silent"]);
    assert_eq!(between.practices.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["warm-up"]);
    let practice = between.pages.iter().find(|p| matches!(p, study::Page::Practice { .. }));
    assert!(
        matches!(
            practice,
            Some(study::Page::Practice { pass: Some(study::PracticePass::Sequence(1)), attempts: 2, .. })
        ),
        "{practice:?}"
    );
    assert!(between.templates().iter().any(|t| t.name == "warm-up" && t.invited_only));
    assert_eq!(between.screen_out.completion_code.as_deref(), Some("SCREENED1"));

    // Its questionnaires variant: numbers, a conditional item, a grid, shuffled pages.
    let path = Path::new(repo_root!()).join("examples/study/questionnaires.toml");
    let questions = study::load(&path, &maps).unwrap_or_else(|e| panic!("{e}"));
    let kinds: Vec<String> = questions
        .pages
        .iter()
        .filter_map(|p| match p {
            study::Page::Questionnaire { items, .. } => Some(items),
            _ => None,
        })
        .flatten()
        .map(|i| serde_json::to_value(&i.kind).expect("json")["kind"].as_str().unwrap_or("").to_string())
        .collect();
    assert_eq!(kinds, ["number", "choice", "number", "text", "matrix", "likert", "text"]);
}

/// One condition for two people and two built-in teammates; a person whose partner does
/// not come within a second plays with a built-in agent in the partner's seat.
const PAIRS: &str = r##"
[study]
name = "pairs"
seed = 3
mode = "lockstep"
time_limit_s = 1

[[condition]]
name = "together"
humans = 2
teammates = 2
strategy = "coop"
min_active_ticks = 0
partner_timeout_s = 1

[[page]]
kind = "trial"

[[page]]
kind = "final"
text = "Thank you."
"##;

/// The trial page's hello for `id`, who has just arrived.
async fn trial_hello(rig: &StudyRig, id: &str) -> Value {
    let (status, state) = arrive(rig, id).await;
    assert_eq!(status, 201, "a new participant: {state}");
    let state: ParticipantState = read(&state);
    let Some(StudyPage::Trial { hello, humans, .. }) = &state.page else {
        panic!("a trial first: {state:?}")
    };
    assert_eq!(*humans, 2, "{state:?}");
    player_fields(hello)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_people_meet_in_the_waiting_room_and_a_lone_one_gets_a_built_in_partner() {
    let dir = temp_dir("pairs");
    let rig = StudyRig::start(&dir, PAIRS).await;
    // The first waits: its match does not start until the second comes.
    let mut ann = AutoPlayer::join_with(rig.addr, trial_hello(&rig, "ann").await).await;
    ann.wait("the lobby", |s| s.lobbies.last().map(|l| (!l.started).then_some(()))).await;
    let mut bob = AutoPlayer::join_with(rig.addr, trial_hello(&rig, "bob").await).await;
    assert_eq!(ann.welcome.match_info.name, bob.welcome.match_info.name, "one match for the pair");
    for player in [&mut ann, &mut bob] {
        player.wait("the match's end", |s| s.ended.then_some(())).await;
    }
    let together = ann.welcome.match_info.name.clone();
    tokio::time::timeout(WAIT, rig.arena.ended(1)).await.expect("recorded");
    let (_, summary) = rig.operator("GET", &format!("/api/matches/{together}")).await;
    let players: Vec<&str> =
        summary["players"].as_array().expect("players").iter().filter_map(Value::as_str).collect();
    for name in [&ann.welcome.name, &bob.welcome.name] {
        assert!(players.contains(&name.as_deref().expect("a name")), "{summary}");
    }
    assert_eq!(players.len(), 4, "two people and two built-in teammates: {summary}");
    for (id, player) in [("ann", &ann), ("bob", &bob)] {
        let answer = json!({"match_id": player.welcome.match_info.id});
        let state = rig.answer(id, 0, answer).await;
        assert_eq!(kind_of(&state), "final", "{state:?}");
    }

    // Alone: after the partner timeout a built-in agent takes the empty seat.
    let mut cy = AutoPlayer::join_with(rig.addr, trial_hello(&rig, "cy").await).await;
    assert_ne!(cy.welcome.match_info.name, together);
    cy.wait("the match's end", |s| s.ended.then_some(())).await;
    tokio::time::timeout(WAIT, rig.arena.ended(2)).await.expect("recorded");
    let (_, summary) = rig.operator("GET", &format!("/api/matches/{}", cy.welcome.match_info.name)).await;
    assert_eq!(summary["players"].as_array().map(Vec::len), Some(4), "the empty seat filled: {summary}");
    let state = rig.answer("cy", 0, json!({"match_id": cy.welcome.match_info.id})).await;
    assert_eq!(kind_of(&state), "final", "{state:?}");
    rig.shutdown().await;
}

/// The study of one consent page, one trial and the end: what the attacks below need.
const SHORT: &str = r##"
[study]
name = "short"
mode = "lockstep"
time_limit_s = 1

[[condition]]
name = "alpha"
teammates = 1

[[page]]
kind = "consent"
text = "Agree?"

[[page]]
kind = "trial"

[[page]]
kind = "final"
text = "Thanks."
"##;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn knowing_a_participant_id_is_not_enough_to_act_as_them() {
    let dir = temp_dir("credential");
    let rig = StudyRig::start(&dir, SHORT).await;
    let json = [("Content-Type", "application/json")];
    let arrival = json!({"params": {"PROLIFIC_PID": "p017"}}).to_string();
    let got = rig.browser.send(rig.http, "POST", "/api/study/participants", &json, &arrival).await;
    assert_eq!(got.status, 201, "{}", got.body);
    let cookie = got.cookies().first().map(|c| c.to_string()).expect("the arrival sets a cookie");
    for part in ["bw4t_study_p017=", "HttpOnly", "SameSite=Strict", "Path=/api/study"] {
        assert!(cookie.contains(part), "{part} in {cookie}");
    }
    assert!(!cookie.contains("Secure"), "plain HTTP: not Secure: {cookie}");

    // A stranger who knows the id: no state, no consent declined, no events, no takeover.
    let stranger = Browser::default();
    let base = "/api/study/participants/p017";
    let decline = json!({"step": 0, "answers": {"consent": false}});
    let events = json!({"events": [{"kind": "click"}]});
    for (method, path, body) in [
        ("GET", base.to_string(), None),
        ("POST", format!("{base}/answer"), Some(&decline)),
        ("POST", format!("{base}/events"), Some(&events)),
        ("POST", format!("{base}/trial"), Some(&json!({"step": 0, "match": "alpha-1"}))),
    ] {
        let (status, answer) = stranger.json(rig.http, method, &path, body).await;
        assert_eq!(status, 401, "{method} {path}: {answer}");
        assert!(read::<ErrorReply>(&answer).error.contains("credential"), "{answer}");
    }
    let forged = Browser::default();
    forged.jar.lock().expect("jar").insert("bw4t_study_p017".into(), "0".repeat(64));
    let (status, answer) = forged.json(rig.http, "POST", &format!("{base}/answer"), Some(&decline)).await;
    assert_eq!(status, 403, "a made-up secret: {answer}");
    let (status, answer) = stranger
        .json(
            rig.http,
            "POST",
            "/api/study/participants",
            Some(&serde_json::from_str(&arrival).expect("json")),
        )
        .await;
    assert_eq!(status, 403, "arriving with their id in another browser: {answer}");
    assert!(read::<ErrorReply>(&answer).error.contains("another browser"), "{answer}");
    assert!(stranger.jar.lock().expect("jar").is_empty(), "no credential given to the stranger");
    // The participant is untouched, and their own browser goes on.
    let (status, state) = rig.call("GET", base, None).await;
    assert_eq!(
        (status, read::<ParticipantState>(&state).step, kind_of(&read(&state))),
        (200, 0, "consent".into())
    );
    let (status, again) = rig
        .call("POST", "/api/study/participants", Some(serde_json::from_str(&arrival).expect("json")))
        .await;
    assert_eq!(status, 200, "their own browser comes back: {again}");
    rig.answer("p017", 0, json!({"consent": true})).await;

    // Behind a TLS proxy the cookie is Secure.
    let tls = [("Content-Type", "application/json"), ("X-Forwarded-Proto", "https")];
    let got = Browser::default().send(rig.http, "POST", "/api/study/participants", &tls, "{}").await;
    assert_eq!(got.status, 201, "{}", got.body);
    assert!(got.cookies().iter().any(|c| c.ends_with("; Secure")), "{:?}", got.head);
    rig.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn another_site_cannot_make_participants_with_a_simple_request() {
    let dir = temp_dir("cross-site");
    let rig = StudyRig::start(&dir, SHORT).await;
    // What a cross-site form or fetch without a preflight can send.
    for kind in ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x"] {
        let headers = [("Content-Type", kind), ("Origin", "https://evil.example")];
        let got = Browser::default().send(rig.http, "POST", "/api/study/participants", &headers, "{}").await;
        assert_eq!(got.status, 415, "{kind}: {}", got.body);
        assert!(got.body.contains("application/json"), "{}", got.body);
        assert!(got.cookies().is_empty());
    }
    let got = Browser::default().send(rig.http, "POST", "/api/study/participants", &[], "{}").await;
    assert_eq!(got.status, 415, "no Content-Type: {}", got.body);
    let (_, list) = rig.operator("GET", "/api/study/participants").await;
    assert_eq!(read::<ParticipantList>(&list).participants.len(), 0, "no participant was made");
    rig.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// The descriptors process `pid` holds, and of those the files under `dir`.
fn descriptors(pid: u32, dir: &Path) -> (usize, Vec<PathBuf>) {
    let targets: Vec<PathBuf> = std::fs::read_dir(format!("/proc/{pid}/fd"))
        .expect("the process's descriptors")
        .filter_map(|fd| std::fs::read_link(fd.ok()?.path()).ok())
        .collect();
    let total = targets.len();
    (total, targets.into_iter().filter(|p| p.starts_with(dir)).collect())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn descriptors_do_not_grow_with_participants() {
    if !Path::new("/proc/self/fd").is_dir() {
        return; // Linux only: elsewhere the descriptors are not listed.
    }
    let dir = temp_dir("descriptors");
    let file = dir.join("short.toml");
    std::fs::write(&file, SHORT).expect("study file");
    let data = dir.join("data");
    // 2,000 arrivals from this one address: far beyond the default rate.
    let server = StudyProcess::spawn_with(&file, &data, &["--arrivals-per-minute", "1000000"]);
    let pid = server.child.0.id();
    let arrive_anonymously = || async {
        let (status, answer) =
            Browser::default().json(server.web, "POST", "/api/study/participants", Some(&json!({}))).await;
        assert_eq!(status, 201, "{answer}");
    };
    arrive_anonymously().await;
    let (first, _) = descriptors(pid, &data);
    const PARTICIPANTS: usize = 2_000;
    for _ in 1..PARTICIPANTS {
        arrive_anonymously().await;
    }
    let (status, list) = http(server.web, "GET", "/api/study/participants", Some(TOKEN), None).await;
    assert_eq!(status, 200, "{list}");
    let list: ParticipantList = serde_json::from_str(&list).expect("the list");
    assert_eq!(list.participants.len(), PARTICIPANTS);
    let data = data.canonicalize().expect("data");
    let (last, files) = descriptors(pid, &data);
    // A few connections may still be closing; a descriptor a participant would be 2,000.
    assert!(last <= first + 8, "{first} descriptors after one participant, {last} after {PARTICIPANTS}");
    // The arena's index of matches is open too (in matches/); the study holds only its database.
    let files: Vec<PathBuf> = files.into_iter().filter(|f| !f.starts_with(data.join("matches"))).collect();
    assert!(files.len() <= 3, "the database, its write-ahead log and its index at most: {files:?}");
    assert!(files.iter().any(|f| f.ends_with("study.sqlite3")), "{files:?}");
    server.kill();
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_participant_cannot_record_more_events_than_the_budget() {
    let dir = temp_dir("event-budget");
    let budget = StudyBudget { events: 5, bytes: 400, ..StudyBudget::default() };
    let rig = StudyRig::start_as(&dir, SHORT, Browser::default(), budget).await;
    let path = "/api/study/participants/flood/events";
    rig.call("POST", "/api/study/participants", Some(json!({"params": {"pid": "flood"}}))).await;
    let click = json!({"kind": "click"});
    let (status, answer) =
        rig.call("POST", path, Some(json!({"events": [click, click, click, click]}))).await;
    assert_eq!((status, read::<EventsRecorded>(&answer).recorded), (200, 4));
    // Acknowledged means committed: another connection reads them right after the answer.
    let events = types(&stored(&dir, "flood")).iter().filter(|t| **t == "event").count();
    assert_eq!(events, 4, "the acknowledged events are in the database");
    let (status, answer) = rig.call("POST", path, Some(json!({"events": [click, click]}))).await;
    assert_eq!(status, 429, "past the count: {answer}");
    assert!(read::<ErrorReply>(&answer).error.contains("at most 5 events"), "{answer}");
    let big = json!({"kind": "key", "key": "x".repeat(400)});
    let (status, answer) = rig.call("POST", path, Some(json!({"events": [big]}))).await;
    assert_eq!(status, 413, "past the bytes: {answer}");
    assert!(read::<ErrorReply>(&answer).error.contains("bytes"), "{answer}");
    let (status, _) = rig.call("POST", path, Some(json!({"events": [click]}))).await;
    assert_eq!(status, 200, "what fits is still taken");
    let events = types(&stored(&dir, "flood")).iter().filter(|t| **t == "event").count();
    assert_eq!(events, 5, "what was taken, and only that, is in the database");
    let browser = rig.browser.clone();
    rig.shutdown().await;

    // The count goes on across a restart: it is the log's.
    let rig = StudyRig::start_as(&dir, SHORT, browser, budget).await;
    let (status, answer) = rig.call("POST", path, Some(json!({"events": [click]}))).await;
    assert_eq!(status, 429, "the budget spent before the restart stays spent: {answer}");
    rig.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_trial_start_takes_only_what_a_match_id_looks_like() {
    let dir = temp_dir("match-id");
    let rig = StudyRig::start(&dir, SHORT).await;
    rig.call("POST", "/api/study/participants", Some(json!({"params": {"pid": "mallory"}}))).await;
    rig.answer("mallory", 0, json!({"consent": true})).await;
    let path = "/api/study/participants/mallory/trial";
    for (name, id) in
        [(".", "../matches"), ("alpha-1", "alpha-1./x"), ("alpha-1", "alpha-1."), ("alpha-1", "alpha-1.1e3")]
    {
        let (status, answer) =
            rig.call("POST", path, Some(json!({"step": 1, "match": name, "match_id": id}))).await;
        assert_eq!(status, 400, "{id}: {answer}");
        assert!(read::<ErrorReply>(&answer).error.contains("match_id"), "{answer}");
    }
    let (status, answer) =
        rig.call("POST", path, Some(json!({"step": 1, "match": "alpha-1", "match_id": "alpha-1.7"}))).await;
    assert_eq!(status, 200, "a real-looking id is taken: {answer}");
    rig.shutdown().await;
    // And the export, which names files after match ids, works.
    let summary = study::export(&dir, &dir.join("export")).expect("export");
    assert_eq!((summary.counts.participants, summary.counts.trials), (1, 1), "{summary:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Starts `id`'s trial at `step` with a player that leaves at once (or, with `stay`, only
/// says `ready`), waits for the match's end, and answers the trial with it.
/// How a trial without playing ends.
#[derive(Clone, Copy, PartialEq)]
enum Without {
    /// The player leaves at once.
    Leaving,
    /// The player stays to the end, never moving.
    Staying,
    /// The operator stops the match.
    Stopped,
}

async fn trial_without_playing(rig: &StudyRig, id: &str, step: usize, how: Without) -> ParticipantState {
    let (_, state) = rig.call("GET", &format!("/api/study/participants/{id}"), None).await;
    let state: ParticipantState = read(&state);
    let Some(StudyPage::Trial { hello, .. }) = &state.page else { panic!("a trial: {state:?}") };
    let ended: u64 = rig.arena.totals().values().map(|t| t.ended).sum();
    let mut player = AutoPlayer::join_with(rig.addr, player_fields(hello)).await;
    let (name, match_id) = (player.welcome.match_info.name.clone(), player.welcome.match_info.id.clone());
    let started = json!({"step": step, "match": name, "match_id": match_id});
    let (status, answer) =
        rig.call("POST", &format!("/api/study/participants/{id}/trial"), Some(started)).await;
    assert_eq!(status, 200, "{answer}");
    match how {
        Without::Staying => player.wait("the match's end", |s| s.ended.then_some(())).await,
        Without::Leaving => player.disconnect().await,
        Without::Stopped => {
            let (status, stopped) = rig.operator("POST", &format!("/api/matches/{name}/stop")).await;
            assert_eq!(status, 200, "{stopped}");
        }
    }
    tokio::time::timeout(WAIT, rig.arena.ended(ended + 1)).await.expect("the match is recorded in time");
    let body = json!({"step": step, "answers": {"match_id": match_id}});
    let (status, state) = rig.call("POST", &format!("/api/study/participants/{id}/answer"), Some(body)).await;
    assert_eq!(status, 200, "{state}");
    read(&state)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_trial_counts_only_if_the_participant_played() {
    let dir = temp_dir("played");
    // By default a robot that never moved was not played.
    let rig = StudyRig::start(&dir, SHORT).await;
    rig.call("POST", "/api/study/participants", Some(json!({"params": {"pid": "quitter"}}))).await;
    rig.answer("quitter", 0, json!({"consent": true})).await;
    // Left at tick 0: in the result, but the trial is given again.
    let state = trial_without_playing(&rig, "quitter", 1, Without::Leaving).await;
    assert_eq!((state.step, kind_of(&state)), (1, "trial".into()), "{state:?}");
    // Stayed, but never moved: again.
    let state = trial_without_playing(&rig, "quitter", 1, Without::Staying).await;
    assert_eq!((state.step, kind_of(&state)), (1, "trial".into()), "{state:?}");
    rig.shutdown().await;
    let records = stored(&dir, "quitter");
    let reasons: Vec<String> = records
        .iter()
        .filter(|(_, kind, _)| kind == "trial_incomplete")
        .map(|(_, _, data)| data["reason"].as_str().unwrap_or("").to_string())
        .collect();
    assert_eq!(reasons.len(), 2, "{records:?}");
    assert!(reasons.iter().all(|r| r.contains("did not play") && r.contains("moved in 0 of")), "{reasons:?}");
    assert!(!types(&records).contains(&"trial_ended"), "{records:?}");
    let _ = std::fs::remove_dir_all(&dir);

    // A trial the operator stops is no complete trial, even for one who need not move.
    let dir = temp_dir("played-stopped");
    // A realtime match of ten minutes: it is surely still running when the operator stops it.
    let long = SHORT
        .replace("teammates = 1", "teammates = 1\nmin_active_ticks = 0")
        .replace("mode = \"lockstep\"", "mode = \"realtime\"")
        .replace("time_limit_s = 1", "time_limit_s = 600");
    let rig = StudyRig::start(&dir, &long).await;
    rig.call("POST", "/api/study/participants", Some(json!({"params": {"pid": "stopped"}}))).await;
    rig.answer("stopped", 0, json!({"consent": true})).await;
    let state = trial_without_playing(&rig, "stopped", 1, Without::Stopped).await;
    assert_eq!((state.step, kind_of(&state)), (1, "trial".into()), "given again: {state:?}");
    rig.shutdown().await;
    let records = stored(&dir, "stopped");
    let last = records.last().expect("a record");
    assert_eq!(last.1, "trial_incomplete", "{records:?}");
    assert!(last.2["reason"].as_str().is_some_and(|r| r.contains("stopped before its end")), "{last:?}");
    let _ = std::fs::remove_dir_all(&dir);

    // A condition of talking alone asks for no moving: staying to the end is enough.
    let dir = temp_dir("played-talking");
    let rig =
        StudyRig::start(&dir, &SHORT.replace("teammates = 1", "teammates = 1\nmin_active_ticks = 0")).await;
    rig.call("POST", "/api/study/participants", Some(json!({"params": {"pid": "stayer"}}))).await;
    rig.answer("stayer", 0, json!({"consent": true})).await;
    let state = trial_without_playing(&rig, "stayer", 1, Without::Staying).await;
    assert_eq!(kind_of(&state), "final", "{state:?}");
    rig.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// Copies the files of `from` (and of its folders) into `to`.
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for entry in std::fs::read_dir(from).expect("read").map(|e| e.expect("entry")) {
        let path = entry.path();
        if path.is_dir() {
            copy_tree(&path, &to.join(entry.file_name()));
        } else {
            std::fs::copy(&path, to.join(entry.file_name())).expect("copy");
        }
    }
}

/// Each file's bytes under `dir`, by name.
fn contents(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .expect("read")
        .map(|e| e.expect("entry").path())
        .map(|p| {
            (p.file_name().expect("name").to_string_lossy().into_owned(), std::fs::read(&p).expect("read"))
        })
        .collect()
}

/// Each exported CSV is the expected one, byte for byte, but for the columns a later
/// version appended to every line (their header and cells after the last expected one).
fn same_but_appended(
    exported: &std::collections::BTreeMap<String, Vec<u8>>,
    expected: &std::collections::BTreeMap<String, Vec<u8>>,
    why: &str,
) {
    assert_eq!(exported.keys().collect::<Vec<_>>(), expected.keys().collect::<Vec<_>>(), "{why}");
    for (name, want) in expected {
        let (got, want) = (String::from_utf8_lossy(&exported[name]), String::from_utf8_lossy(want));
        let (got, want): (Vec<&str>, Vec<&str>) = (got.lines().collect(), want.lines().collect());
        assert_eq!(got.len(), want.len(), "{name}: {why}");
        for (got, want) in got.iter().zip(&want) {
            let appended =
                got.strip_prefix(want).is_some_and(|rest| rest.is_empty() || rest.starts_with(','));
            assert!(appended, "{name}: {why}:\n{got}\n is not\n{want}\n with columns appended");
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_older_versions_logs_are_imported_once_and_export_as_that_version_exported_them() {
    let fixture = Path::new(repo_root!()).join("tests/fixtures/study-jsonl");
    let dir = temp_dir("legacy");
    copy_tree(&fixture.join("participants"), &dir.join("participants"));
    let text = std::fs::read_to_string(fixture.join("study.toml")).expect("the study file");
    std::fs::write(dir.join("study.toml"), &text).expect("study copy");
    let logs = contents(&dir.join("participants"));
    // expected/ is what the version that wrote these logs exported from them (with the
    // columns trials.csv has gained since, empty for those trials, at the end).
    let expected = contents(&fixture.join("expected"));
    assert_eq!(expected.len(), 4, "the four CSV files");
    let exported = |out: &str| {
        let out = dir.join(out);
        study::export(&dir, &out).expect("export");
        expected.keys().map(|name| (name.clone(), std::fs::read(out.join(name)).expect("exported"))).collect()
    };
    let before: std::collections::BTreeMap<String, Vec<u8>> = exported("export-logs");
    same_but_appended(&before, &expected, "the logs export as before, without a server");
    assert!(!dir.join("study.sqlite3").exists(), "the export writes no database");

    // Ann continues in the browser that arrived as her (its cookie kept by that version).
    let browser = Browser::default();
    browser.jar.lock().expect("jar").insert("bw4t_study_ann".into(), "ann-secret".into());
    let rig = StudyRig::start_as(&dir, &text, browser.clone(), StudyBudget::default()).await;
    let (_, list) = rig.operator("GET", "/api/study/participants").await;
    let people: Vec<(String, usize)> =
        read::<ParticipantList>(&list).participants.into_iter().map(|p| (p.participant, p.step)).collect();
    assert_eq!(people, [("ann".into(), 3), ("bob".into(), 0), ("carl".into(), 1)]);
    rig.shutdown().await;
    same_but_appended(&exported("export-imported"), &expected, "imported, the data exports the same");
    let ann = stored(&dir, "ann");
    assert_eq!(ann.iter().map(|(seq, _, _)| *seq).collect::<Vec<_>>(), (1..=11).collect::<Vec<_>>());
    assert_eq!(types(&stored(&dir, "bob")), ["created", "event", "answer"], "the torn line is left out");

    // Started again: nothing is imported twice, and Ann's records go on from her log's.
    let rig = StudyRig::start_as(&dir, &text, browser, StudyBudget::default()).await;
    let (status, state) = rig.call("GET", "/api/study/participants/ann", None).await;
    assert_eq!((status, kind_of(&read(&state))), (200, "trial".into()), "{state}");
    let (status, _) = rig
        .call("POST", "/api/study/participants/ann/events", Some(json!({"events": [{"kind": "focus"}]})))
        .await;
    assert_eq!(status, 200);
    rig.shutdown().await;
    let ann = stored(&dir, "ann");
    assert_eq!((ann.len(), ann[11].0, ann[11].1.as_str()), (12, 12, "event"), "{ann:?}");
    assert_eq!(contents(&dir.join("participants")), logs, "the old logs are left as they were");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_database_that_is_not_a_studys_is_refused_naming_it() {
    let dir = temp_dir("foreign-database");
    let file = dir.join("short.toml");
    std::fs::write(&file, SHORT).expect("study file");
    let data = dir.join("data");
    std::fs::create_dir_all(&data).expect("mkdir");
    let database = data.join("study.sqlite3");
    std::fs::write(&database, "id,name\n1,ann\n".repeat(200)).expect("a CSV file by that name");
    let (data_arg, file_arg) = (data.to_str().expect("path"), file.to_str().expect("path"));
    let served = crate::util::bw4t_within(
        &["study", file_arg, "--data", data_arg, "--port", "0", "--http", "0"],
        WAIT,
    );
    let export = crate::util::bw4t_within(&["study", "export", data_arg], WAIT);
    for (what, output) in [("serving", served), ("the export", export)] {
        let error = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{what} refuses it");
        assert!(error.contains(&database.display().to_string()), "{what} names the file: {error}");
        assert!(error.contains("not a database"), "{what}: {error}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_address_cannot_make_participants_faster_than_its_rate() {
    let dir = temp_dir("arrivals");
    let file = dir.join("short.toml");
    std::fs::write(&file, SHORT).expect("study file");
    // The test's requests come through a "proxy" (this machine) naming the participant's address.
    let options = ["--arrivals-per-minute", "3", "--trust-proxy", "127.0.0.1"];
    let server = StudyProcess::spawn_with(&file, &dir.join("data"), &options);
    let arrive = |browser: Browser, from: &'static str, id: &'static str| async move {
        let headers = [("Content-Type", "application/json"), ("X-Forwarded-For", from)];
        let body = json!({"params": {"participant": id}}).to_string();
        let got = browser.send(server.web, "POST", "/api/study/participants", &headers, &body).await;
        (got.status, got.body)
    };
    let first = Browser::default();
    assert_eq!(arrive(first.clone(), "203.0.113.7", "a1").await.0, 201);
    for id in ["a2", "a3"] {
        assert_eq!(arrive(Browser::default(), "203.0.113.7", id).await.0, 201);
    }
    let (status, refused) = arrive(Browser::default(), "203.0.113.7", "a4").await;
    assert_eq!(status, 429, "{refused}");
    assert!(refused.contains("at most 3 a minute"), "{refused}");
    // Another address has its own rate; someone coming back is no new arrival.
    assert_eq!(arrive(Browser::default(), "198.51.100.1", "b1").await.0, 201);
    assert_eq!(arrive(first, "203.0.113.7", "a1").await.0, 200);
    let (status, list) = http(server.web, "GET", "/api/study/participants", Some(TOKEN), None).await;
    let list: ParticipantList = serde_json::from_str(&list).expect("the list");
    assert_eq!((status, list.participants.len()), (200, 4), "the refused arrival made nobody");
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_study_server_shows_its_matches_to_the_operator_only() {
    let dir = temp_dir("closed");
    let file = dir.join("short.toml");
    std::fs::write(&file, SHORT).expect("study file");
    let server = StudyProcess::spawn(&file, &dir.join("data"));
    let browser = Browser::default();
    let arrival = json!({"params": {"participant": "gus"}});
    assert_eq!(browser.json(server.web, "POST", "/api/study/participants", Some(&arrival)).await.0, 201);
    let body = json!({"step": 0, "answers": {"consent": true}});
    let (status, state) =
        browser.json(server.web, "POST", "/api/study/participants/gus/answer", Some(&body)).await;
    assert_eq!(status, 200, "{state}");
    let fields = state["page"]["hello"].clone();
    let hello = json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": fields["name"],
                       "template": fields["template"], "seat": fields["seat"], "every_tick": true});
    let (_player, welcome) = welcomed(server.addr, hello).await;
    let name = welcome.match_info.name.clone();
    // No lobby: the listing, a match's summary and the templates are not for outsiders.
    for path in ["/api/matches".to_string(), format!("/api/matches/{name}")] {
        let (status, body) = http(server.web, "GET", &path, None, None).await;
        assert_eq!(status, 401, "{path}: {body}");
        let (status, _) = http(server.web, "GET", &path, Some(TOKEN), None).await;
        assert_eq!(status, 200, "{path}: the operator's");
    }
    let (status, info) = http(server.web, "GET", "/info.json", None, None).await;
    let info: Value = serde_json::from_str(&info).expect("json");
    assert_eq!((status, &info["templates"]), (200, &json!([])), "no template to join: {info}");
    // Watching needs the operator's token.
    let mut outsider = Client::connect(server.addr).await;
    outsider
        .send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator",
                         "match": name}))
        .await;
    assert_eq!(outsider.error_code().await, "bad_token");
    let operator = json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "operator",
                          "match": name, "token": TOKEN});
    let (_operator, watching) = welcomed(server.addr, operator).await;
    assert_eq!(watching.match_info.name, name);
    // The dashboard's export, made and read by the operator only.
    let auth = format!("Bearer {TOKEN}");
    let json_body = ("Content-Type", "application/json");
    let refused = browser.send(server.web, "POST", "/api/study/export", &[json_body], "{}").await;
    assert_eq!(refused.status, 401, "{}", refused.body);
    let made = browser
        .send(server.web, "POST", "/api/study/export", &[json_body, ("Authorization", &auth)], "{}")
        .await;
    assert_eq!(made.status, 200, "{}", made.body);
    let exported: bw4t_protocol::StudyExported =
        serde_json::from_str(&made.body).expect("the export's summary");
    assert_eq!((exported.counts.participants, exported.files.len()), (1, 4), "{exported:?}");
    let (status, csv) =
        http(server.web, "GET", "/api/study/export/participants.csv", Some(TOKEN), None).await;
    assert!(
        status == 200 && csv.starts_with("participant,number,") && csv.contains("\ngus,"),
        "{status} {csv}"
    );
    let (status, _) = http(server.web, "GET", "/api/study/export/participants.csv", None, None).await;
    assert_eq!(status, 401);
    let (status, _) =
        http(server.web, "GET", "/api/study/export/..%2Fstudy.sqlite3", Some(TOKEN), None).await;
    assert_eq!(status, 404, "only the export's CSV files");
    let _ = std::fs::remove_dir_all(&dir);
}

/// What a trial page's hello asks of a player's session (the watch token is the overview's).
fn player_fields(hello: &TrialHello) -> Value {
    json!({"name": hello.name, "template": hello.template, "seat": hello.seat})
}

#[test]
fn a_dry_run_takes_scripted_participants_through_the_example_study_and_exports_them() {
    let dir = temp_dir("dry-run");
    let data = dir.join("data");
    let example = concat!(repo_root!(), "/examples/study/study.toml");
    let args = ["study", example, "--simulate", "10", "--data", data.to_str().expect("path"), "-q"];
    let out = crate::util::bw4t_within(&args, std::time::Duration::from_secs(120));
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{said}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        said.contains("dry run: 9 completed, 1 declined consent, 0 screened out, 18 trials played"),
        "{said}"
    );
    let participants = csv_rows(&data.join("export/participants.csv"));
    let completed = participants.iter().filter(|p| p["completed"] == "true").count();
    assert_eq!((participants.len(), completed), (10, 9), "{participants:?}");
    let trials = csv_rows(&data.join("export/trials.csv"));
    assert!(trials.len() == 18 && trials.iter().all(|t| t["complete"] == "true"), "{trials:?}");
    // Each completer played both conditions; the replays were kept.
    for p in participants.iter().filter(|p| p["completed"] == "true") {
        let mut played: Vec<&str> = trials
            .iter()
            .filter(|t| t["participant"] == p["participant"])
            .map(|t| t["condition"].as_str())
            .collect();
        played.sort_unstable();
        assert_eq!(played, ["silent", "talking"], "{}", p["participant"]);
    }
    assert!(trials.iter().all(|t| data.join("export").join(&t["replay"]).is_file()), "{trials:?}");
    // Each one's own figures and bonus are their trials' (the example's [bonus]: 0.10 per
    // own block, 0.05 per team block, at most 1.50).
    for p in participants.iter().filter(|p| p["completed"] == "true") {
        let sum = |column: &str| -> u64 {
            trials
                .iter()
                .filter(|t| t["participant"] == p["participant"])
                .map(|t| t[column].parse::<u64>().expect(column))
                .sum()
        };
        let (own, team) = (sum("own_deliveries"), sum("good_drops"));
        assert_eq!(
            (p["own_deliveries"].parse::<u64>().ok(), p["team_deliveries"].parse::<u64>().ok()),
            (Some(own), Some(team))
        );
        let bonus = (0.10 * own as f64 + 0.05 * team as f64).min(1.50);
        assert_eq!(p["bonus"], format!("{bonus:.2}"), "{p:?}");
    }
    assert!(
        participants.iter().any(|p| p["own_deliveries"].parse::<u64>().unwrap_or(0) > 0),
        "{participants:?}"
    );
    // A second dry run into the same directory is refused, naming it.
    let again = crate::util::bw4t_within(&args, std::time::Duration::from_secs(30));
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("not empty"), "{again:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn any_page_of_the_participant_takes_their_robot_back_and_the_first_is_told() {
    let dir = temp_dir("second-page");
    // A realtime match of ten minutes: it is surely still running while pages come and go.
    let long = SHORT
        .replace("mode = \"lockstep\"", "mode = \"realtime\"")
        .replace("time_limit_s = 1", "time_limit_s = 600");
    let rig = StudyRig::start(&dir, &long).await;
    rig.call("POST", "/api/study/participants", Some(json!({"params": {"pid": "hana"}}))).await;
    let state = rig.answer("hana", 0, json!({"consent": true})).await;
    let Some(StudyPage::Trial { hello, .. }) = &state.page else { panic!("a trial: {state:?}") };
    let (seat, name) = (hello.seat.clone(), hello.name.clone());
    let mut first = AutoPlayer::join_with(rig.addr, player_fields(hello)).await;
    let welcome = first.welcome.clone();
    let session = welcome.session.clone().expect("a session");
    let started = json!({"step": 1, "match": welcome.match_info.name, "match_id": welcome.match_info.id,
                         "session": session});
    let (status, answer) = rig.call("POST", "/api/study/participants/hana/trial", Some(started)).await;
    assert_eq!(status, 200, "{answer}");
    // Her state now says where her robot is: a reload, or a page in a new tab, goes back to it.
    let (_, state) = rig.call("GET", "/api/study/participants/hana", None).await;
    let state: ParticipantState = read(&state);
    let Some(StudyPage::Trial { hello, .. }) = &state.page else { panic!("a trial: {state:?}") };
    assert_eq!(hello.match_name.as_deref(), Some(welcome.match_info.name.as_str()));
    assert_eq!(hello.session.as_deref(), Some(session.as_str()));
    let back = json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": name, "seat": seat,
                      "match": hello.match_name, "session": hello.session});
    let (_second, again) = welcomed(rig.addr, back).await;
    assert_eq!(again.robot, welcome.robot, "the same robot");
    // The page it was taken from is told so (and leaves the robot alone).
    first.wait("replaced", |s| s.errors.iter().any(|e| e == "replaced").then_some(())).await;
    // Somebody without her session gets no robot of hers.
    let stranger = json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": name, "seat": seat,
                          "match": welcome.match_info.name, "session": "0123456789abcdef0123456789abcdef"});
    let mut outsider = Client::connect(rig.addr).await;
    outsider.send(stranger).await;
    assert_eq!(outsider.error_code().await, "bad_session");
    let (status, _) = rig.operator("POST", &format!("/api/matches/{}/stop", welcome.match_info.name)).await;
    assert_eq!(status, 200);
    rig.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_who_declines_gets_the_platforms_code_for_it() {
    let dir = temp_dir("declined-code");
    let with_code = SHORT.replace(
        "text = \"Agree?\"",
        "text = \"Agree?\"\ndeclined_code = \"NOCONSENT\"\ndeclined_redirect = \"https://x.invalid/done?cc={code}&p={participant}\"",
    );
    let rig = StudyRig::start(&dir, &with_code).await;
    rig.call("POST", "/api/study/participants", Some(json!({"params": {"pid": "ida"}}))).await;
    let body = json!({"step": 0, "answers": {"consent": false}});
    let (status, state) = rig.call("POST", "/api/study/participants/ida/answer", Some(body)).await;
    assert_eq!(status, 200, "{state}");
    let state: ParticipantState = read(&state);
    let Some(StudyPage::Declined { completion_code, redirect, .. }) = &state.page else {
        panic!("declined: {state:?}")
    };
    assert_eq!(completion_code.as_deref(), Some("NOCONSENT"));
    assert_eq!(redirect.as_deref(), Some("https://x.invalid/done?cc=NOCONSENT&p=ida"));
    rig.shutdown().await;
    // A way back that is not a web address is refused when the file is read.
    let bad =
        SHORT.replace("text = \"Agree?\"", "text = \"Agree?\"\ndeclined_redirect = \"javascript:alert(1)\"");
    let error = parse(&bad).expect_err("refused");
    assert!(error.contains("declined_redirect") && error.contains("http(s)"), "{error}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_dry_run_of_the_between_subjects_example_gives_each_completer_one_condition() {
    let dir = temp_dir("dry-run-between");
    let data = dir.join("data");
    let example = concat!(repo_root!(), "/examples/study/between.toml");
    let args = ["study", example, "--simulate", "8", "--data", data.to_str().expect("path"), "-q"];
    let out = crate::util::bw4t_within(&args, std::time::Duration::from_secs(180));
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{said}\n{}", String::from_utf8_lossy(&out.stderr));
    let participants = csv_rows(&data.join("export/participants.csv"));
    let trials = csv_rows(&data.join("export/trials.csv"));
    let count = |column: &str, value: &str| participants.iter().filter(|p| p[column] == value).count();
    let (completed, screened_out) = (count("completed", "true"), count("screened_out", "true"));
    // Scripted answers to the comprehension check are drawn: some miss its pass mark.
    let line = format!("dry run: {completed} completed, 0 declined consent, {screened_out} screened out");
    assert!(said.contains(&line), "{said}");
    assert_eq!(completed + screened_out, 8, "{participants:?}");
    for p in participants.iter().filter(|p| p["completed"] == "true") {
        let mut conditions: Vec<&str> = trials
            .iter()
            .filter(|t| t["participant"] == p["participant"] && t["practice"] == "false")
            .map(|t| t["condition"].as_str())
            .collect();
        conditions.dedup();
        assert_eq!(conditions, [p["group"].as_str()], "between subjects: one condition, the group's");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_dry_run_exported_as_trajectories_gives_every_trial_its_participant_and_condition() {
    let dir = temp_dir("dry-run-trajectories");
    let data = dir.join("data");
    let example = concat!(repo_root!(), "/examples/study/study.toml");
    let limit = std::time::Duration::from_secs(180);
    let args = ["study", example, "--simulate", "2", "--data", data.to_str().expect("path"), "-q"];
    let out = crate::util::bw4t_within(&args, limit);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let export = ["study", "export", data.to_str().expect("path"), "--trajectories"];
    let out = crate::util::bw4t_within(&export, limit);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let trials = csv_rows(&data.join("export/trials.csv"));
    assert!(!trials.is_empty());
    let root = data.join("export/trajectories");
    let mut exported = 0;
    for entry in std::fs::read_dir(&root).expect("the trajectories") {
        let trial = entry.expect("an entry").path();
        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(trial.join("meta.json")).expect("meta.json"))
                .expect("JSON");
        let labels = &meta["labels"];
        let row = trials
            .iter()
            .find(|t| {
                labels["participant"] == t["participant"].as_str()
                    && labels["condition"] == t["condition"].as_str()
                    && labels["trial"] == t["trial"].as_str()
            })
            .unwrap_or_else(|| panic!("{} is no trial of trials.csv: {labels}", trial.display()));
        assert!(!row["participant"].is_empty());
        for robot in meta["robots"].as_array().expect("robots") {
            let file = trial.join(robot["file"].as_str().expect("a file"));
            let lines = std::fs::read_to_string(&file).expect("the robot's lines").lines().count();
            assert_eq!(Some(lines as u64), robot["lines"].as_u64(), "{}", file.display());
            assert!(lines > 0);
        }
        exported += 1;
    }
    assert_eq!(exported, trials.len(), "one trajectory directory per trial");
    let _ = std::fs::remove_dir_all(&dir);
}
