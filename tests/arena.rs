//! One server, many matches, over real loopback sockets: a classroom of teams, a ladder
//! that starts again, players queued into a template, the operator's API, a failing
//! match ending alone, hostile clients in one match leaving another untouched, and old
//! clients joining the default match.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use bw4t_agents::{Agent, Observation, Strategy, bot_name};
use bw4t_protocol::{EndReason, MatchState, Mode, ServerMessage, SessionOptions};
use bw4t_server::{Arena, ArenaConfig, HostConfig, MatchSetup, OnEnd, ResultsStore, Seat, Template};
use bw4t_sim::Action;
use serde_json::{Value, json};
use tokio::sync::oneshot;

use crate::util::{AutoPlayer, Client, WAIT, http};

/// An arena served on loopback ports, stopped when dropped.
struct ArenaServer {
    arena: Arena,
    addr: SocketAddr,
    http: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<()>,
}

impl ArenaServer {
    async fn start(config: ArenaConfig) -> ArenaServer {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let http = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let (addr, http_addr) = (listener.local_addr().expect("addr"), http.local_addr().expect("addr"));
        let arena = Arena::start(config).expect("the arena starts");
        let (stop, stopped) = oneshot::channel::<()>();
        let served = arena.clone();
        let task = tokio::spawn(async move {
            let shutdown = async {
                let _ = stopped.await;
            };
            bw4t_server::serve_arena(&served, listener, Some(http.into()), shutdown).await;
        });
        ArenaServer { arena, addr, http: http_addr, stop: Some(stop), task }
    }

    /// Waits until `n` matches have ended.
    async fn ended(&self, n: u64) {
        tokio::time::timeout(WAIT, self.arena.ended(n)).await.expect("matches end in time");
    }

    async fn shutdown(mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        tokio::time::timeout(WAIT, &mut self.task).await.expect("the server stops in time").expect("task");
    }
}

/// A lockstep match of `robots` open seats on a shipped map.
fn lockstep(map: &str, robots: usize, max_ticks: u64) -> (MatchSetup, HostConfig) {
    let (mut setup, mut config) = crate::util::lockstep(map, 5, robots);
    setup.max_ticks = Some(max_ticks);
    config.deadline = Some(Duration::from_secs(10));
    (setup, config)
}

/// A template of one match named `name`, made at the start.
fn single(name: &str, (setup, config): (MatchSetup, HostConfig), on_end: OnEnd) -> Template {
    Template::single(name, setup, config, on_end)
}

/// A template of matches made as players ask.
fn template(name: &str, match_: (MatchSetup, HostConfig)) -> Template {
    let mut t = single(name, match_, OnEnd::Stay);
    t.names.clear();
    t
}

/// The first `n` seats of `t` played by built-in cooperative agents `Bot1`, `Bot2`, ...
fn with_bots(t: &mut Template, n: usize) {
    for (i, seat) in t.setup.seats.iter_mut().take(n).enumerate() {
        *seat = Seat::builtin(bot_name(i), Strategy::Cooperative);
    }
}

fn temp_dir(what: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("bw4t-arena-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// `hello` fields joining a match or a template.
fn hello_in(name: &str, field: &str, value: &str) -> Value {
    json!({"name": name, field: value})
}

fn json_of(body: &str) -> Value {
    serde_json::from_str(body).unwrap_or_else(|e| panic!("not JSON ({e}): {body}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_classroom_of_teams_each_completes_its_match_at_once() {
    let dir = temp_dir("classroom");
    let teams: Vec<String> = (0..6).map(|i| format!("team-{}", (b'a' + i) as char)).collect();
    let mut classroom = template("classroom", lockstep("default", 2, 20_000));
    classroom.names = teams.clone();
    classroom.max_running = teams.len();
    with_bots(&mut classroom, 1);
    let mut config = ArenaConfig::new(vec![classroom]);
    config.results = ResultsStore::in_dir(&dir).expect("results dir");
    let server = ArenaServer::start(config).await;
    // Each team's student is a program over TCP naming its team's match.
    let players: Vec<_> = teams
        .iter()
        .map(|team| {
            let options =
                SessionOptions { match_name: Some(team.clone()), ..SessionOptions::agent("Student", None) };
            tokio::spawn(bw4t_runner::play_remote(
                server.addr,
                options,
                Strategy::Cooperative.agent("Student"),
            ))
        })
        .collect();
    for player in players {
        let result =
            tokio::time::timeout(WAIT * 3, player).await.expect("in time").expect("task").expect("played");
        assert!(result.completed, "{result:?}");
        let names: Vec<&str> = result.per_robot.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, ["Bot1", "Student"]);
    }
    server.ended(teams.len() as u64).await;
    let index = std::fs::read_to_string(dir.join("matches.jsonl")).expect("the index");
    let mut keys: Vec<String> =
        index.lines().map(|l| json_of(l)["key"].as_str().expect("key").to_string()).collect();
    keys.sort();
    let expected: Vec<String> = teams.iter().map(|t| format!("{t}.1")).collect();
    assert_eq!(keys, expected);
    assert!(index.lines().all(|l| json_of(l)["completed"] == true), "{index}");
    // Each team played its own match: its own seed.
    let seeds: std::collections::BTreeSet<u64> =
        index.lines().map(|l| json_of(l)["seed"].as_u64().expect("seed")).collect();
    assert_eq!(seeds.len(), teams.len());
    server.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ladder_template_starts_again_when_its_match_ends() {
    let mut ladder = single("ladder", lockstep("default", 3, 60), OnEnd::Restart);
    // Realtime at 200 ticks/s: each run lasts a third of a second, long enough to join.
    ladder.config.mode = Mode::Realtime;
    ladder.setup.game.ticks_per_second = 200;
    with_bots(&mut ladder, 3);
    let server = ArenaServer::start(ArenaConfig::new(vec![ladder])).await;
    server.ended(4).await;
    let outcomes = server.arena.outcomes();
    let ids: Vec<&str> = outcomes.iter().take(4).map(|(id, _)| id.as_str()).collect();
    assert_eq!(ids, ["ladder.1", "ladder.2", "ladder.3", "ladder.4"]);
    let seeds: Vec<u64> = outcomes.iter().take(4).map(|(_, r)| r.as_ref().expect("a result").seed).collect();
    assert_eq!(seeds, [5, 6, 7, 8], "each run plays the next seed");
    // The name stays live: a spectator naming it watches the current run. (One that
    // arrives as a run ends is told `bye` `match_over`, and comes again.)
    let mut name = None;
    for _ in 0..5 {
        let mut watcher = Client::connect(server.addr).await;
        watcher
            .send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator", "match": "ladder"}))
            .await;
        name = watcher
            .until(|m| match m {
                ServerMessage::Welcome(w) => Some(Some(w.match_info.name.clone())),
                ServerMessage::Bye(b) if b.reason == "match_over" => Some(None),
                _ => None,
            })
            .await;
        if name.is_some() {
            break;
        }
    }
    let name = name.expect("a spectator got into a run");
    assert_eq!(name, "ladder");
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn players_asking_for_a_template_share_a_match_and_the_next_one_waits_in_line() {
    let mut open = template("open", lockstep("default", 2, 40));
    open.max_running = 1;
    // Ann reads her messages by hand at first: a tick she skipped is over within a second.
    open.config.deadline = Some(Duration::from_secs(1));
    let server = ArenaServer::start(ArenaConfig::new(vec![open])).await;
    let mut ann = Client::connect(server.addr).await;
    ann.send(
        json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Ann", "template": "open"}),
    )
    .await;
    let welcome = ann.until(|m| if let ServerMessage::Welcome(w) = m { Some(w.clone()) } else { None }).await;
    assert_eq!(
        (welcome.match_info.name.as_str(), welcome.match_info.template.as_deref()),
        ("open-1", Some("open"))
    );
    let lobby = ann.until(|m| if let ServerMessage::Lobby(l) = m { Some(l.clone()) } else { None }).await;
    assert_eq!((lobby.players.clone(), lobby.awaited, lobby.started), (vec!["Ann".to_string()], 1, false));
    // Bob takes the other seat of the same match, and it starts.
    let bob = AutoPlayer::join_with(server.addr, hello_in("Bob", "template", "open")).await;
    assert_eq!(bob.welcome.match_info.name, "open-1");
    // With both seats taken it starts at once: the last lobby says so.
    let lobby = ann.until(|m| if let ServerMessage::Lobby(l) = m { Some(l.clone()) } else { None }).await;
    assert_eq!(
        (lobby.players, lobby.awaited, lobby.started),
        (vec!["Ann".to_string(), "Bob".to_string()], 0, true)
    );
    // The template runs one match at most: Cy waits in line until it ends.
    let mut cy = Client::connect(server.addr).await;
    cy.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Cy", "template": "open"}))
        .await;
    let queued = cy.until(|m| if let ServerMessage::Lobby(l) = m { Some(l.clone()) } else { None }).await;
    assert_eq!((queued.queued, queued.match_name), (Some(1), None));
    // Ann plays on (answers ready) so the match reaches its tick limit.
    let ann = AutoPlayer::adopt(ann, welcome);
    let welcome = cy.until(|m| if let ServerMessage::Welcome(w) = m { Some(w.clone()) } else { None }).await;
    assert_eq!(welcome.match_info.name, "open-2");
    server.ended(1).await;
    // Dee takes the other seat of Cy's match; Eve waits in line, and when the server stops
    // she is told so.
    let dee = AutoPlayer::join_with(server.addr, hello_in("Dee", "template", "open")).await;
    assert_eq!(dee.welcome.match_info.name, "open-2");
    let mut eve = Client::connect(server.addr).await;
    eve.send(
        json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Eve", "template": "open"}),
    )
    .await;
    let queued = eve.until(|m| if let ServerMessage::Lobby(l) = m { Some(l.clone()) } else { None }).await;
    assert_eq!(queued.queued, Some(1));
    drop((ann, bob, dee));
    server.shutdown().await;
    let error = eve.until(|m| if let ServerMessage::Error(e) = m { Some(e.clone()) } else { None }).await;
    assert_eq!((error.code.as_str(), error.fatal), ("server_stopping", true));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_operator_makes_lists_inspects_and_stops_matches_through_the_api() {
    let dir = temp_dir("api");
    let mut base = template("base", lockstep("default", 1, 0));
    base.setup.max_ticks = None;
    base.replays = true;
    let mut config = ArenaConfig::new(vec![base]);
    config.server.operator_token = Some("op".into());
    config.results = ResultsStore::in_dir(&dir).expect("results dir");
    let server = ArenaServer::start(config).await;
    let create = r#"{"name": "demo", "robots": 2, "builtin": 1}"#;
    let (status, body) = http(server.http, "POST", "/api/matches", None, Some(create)).await;
    assert_eq!(status, 401, "{body}");
    let refused: bw4t_protocol::ErrorReply = serde_json::from_str(&body).expect("an error answer");
    assert!(refused.error.contains("operator token"), "{body}");
    // A body sent in chunks, without Content-Length, is refused before it is read.
    let chunked = format!(
        "POST /api/matches HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer op\r\nTransfer-Encoding: chunked\r\n\r\n{:x}\r\n{create}\r\n0\r\n\r\n",
        create.len()
    );
    let mut stream = tokio::net::TcpStream::connect(server.http).await.expect("connect");
    tokio::io::AsyncWriteExt::write_all(&mut stream, chunked.as_bytes()).await.expect("write");
    let mut answer = String::new();
    let read = tokio::io::AsyncReadExt::read_to_string(&mut stream, &mut answer);
    let _ = tokio::time::timeout(crate::util::WAIT, read).await.expect("an answer in time");
    assert!(answer.starts_with("HTTP/1.1 411 ") && answer.contains("Content-Length"), "{answer}");
    let (status, body) = http(server.http, "POST", "/api/matches", Some("op"), Some(create)).await;
    assert_eq!(status, 201, "{body}");
    let made = json_of(&body);
    assert_eq!(
        (made["name"].as_str(), made["robots"].as_u64(), made["state"].as_str()),
        (Some("demo"), Some(2), Some("waiting"))
    );
    let (status, body) = http(server.http, "POST", "/api/matches", Some("op"), Some(create)).await;
    assert_eq!(status, 409, "{body}");
    let (status, body) =
        http(server.http, "POST", "/api/matches", Some("op"), Some(r#"{"robots": 99}"#)).await;
    assert_eq!(status, 400, "{body}");
    assert!(body.contains("spawn points"), "{body}");
    let (status, body) =
        http(server.http, "POST", "/api/matches", Some("op"), Some(r#"{"colour": 1}"#)).await;
    assert_eq!(status, 400, "{body}");
    assert!(body.contains("colour"), "{body}");
    // A tick rate whose period would be zero is refused, and the server goes on answering.
    let (status, body) =
        http(server.http, "POST", "/api/matches", Some("op"), Some(r#"{"tick_hz": 2000000000}"#)).await;
    assert_eq!(status, 400, "{body}");
    assert!(body.contains("tick_hz: ticks per second must be from 1 to 1000"), "{body}");
    // A player joins the match the API made; the lobby listing shows it, without the seed.
    let _ann = AutoPlayer::join_with(server.addr, hello_in("Ann", "match", "demo")).await;
    let (status, body) = http(server.http, "GET", "/api/matches", None, None).await;
    assert_eq!(status, 200);
    let listed = json_of(&body);
    assert!(serde_json::from_value::<bw4t_protocol::MatchList>(listed.clone()).is_ok(), "{listed}");
    let demo = listed["matches"]
        .as_array()
        .expect("list")
        .iter()
        .find(|m| m["name"] == "demo")
        .expect("demo listed")
        .clone();
    assert_eq!(demo["players"], json!(["Bot1", "Ann"]));
    assert!(demo.get("seed").is_none(), "{demo}");
    let (_, body) = http(server.http, "GET", "/api/matches/demo?token=op", None, None).await;
    assert!(json_of(&body)["seed"].is_u64(), "{body}");
    // Stopping it ends it for the player and files its result.
    let (status, body) = http(server.http, "POST", "/api/matches/demo/stop", Some("op"), Some("")).await;
    assert_eq!(status, 200, "{body}");
    let stopped: bw4t_protocol::MatchSummary = serde_json::from_str(&body).expect("a summary");
    assert_eq!((stopped.state, stopped.end_reason), (MatchState::Finished, Some(EndReason::Interrupted)));
    let (status, body) = http(server.http, "GET", "/api/results", None, None).await;
    assert_eq!(status, 401, "{body}");
    let (_, body) = http(server.http, "GET", "/api/results", Some("op"), None).await;
    assert_eq!(body, json_of(&body).to_string(), "the index's keys in alphabetical order, as always");
    let rows = serde_json::from_str::<bw4t_protocol::ResultList>(&body).expect("the results index").results;
    assert_eq!(rows.len(), 1, "{body}");
    assert_eq!((rows[0].key.as_str(), rows[0].end_reason), ("demo.1", EndReason::Interrupted));
    let (status, body) = http(server.http, "GET", "/api/results/demo.1", Some("op"), None).await;
    assert_eq!(status, 200);
    assert_eq!(json_of(&body)["per_robot"].as_array().map(Vec::len), Some(2));
    let (status, body) = http(server.http, "GET", "/api/results/demo.1/replay", Some("op"), None).await;
    assert_eq!(status, 200, "{body}");
    assert!(body.lines().next().is_some_and(|l| l.contains("header")), "{}", &body[..body.len().min(200)]);
    let (status, _) = http(server.http, "GET", "/api/results/..%2Fmatches.jsonl", Some("op"), None).await;
    assert_eq!(status, 404);
    let (status, body) = http(server.http, "POST", "/api/matches/nothing/stop", Some("op"), Some("")).await;
    assert_eq!(status, 404, "{body}");
    server.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// A built-in agent with a bug: it panics a few ticks into the match.
struct Faulty;

impl Agent for Faulty {
    fn decide(&mut self, observation: &Observation) -> Vec<Action> {
        assert!(observation.tick < 5, "a bug in an agent");
        vec![Action::GoTo("RoomA1".into())]
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_match_that_fails_ends_alone_and_the_server_goes_on() {
    let mut faulty = single("faulty", lockstep("default", 2, 20_000), OnEnd::Stay);
    faulty.setup.seats[0] = Seat::agent("Bug", Arc::new(|_: &str| Box::new(Faulty) as Box<dyn Agent>));
    let mut sound = single("sound", lockstep("default", 2, 300), OnEnd::Stay);
    with_bots(&mut sound, 1);
    let server = ArenaServer::start(ArenaConfig::new(vec![faulty, sound])).await;
    let good = AutoPlayer::join_with(server.addr, hello_in("Ann", "match", "sound")).await;
    let mut victim = AutoPlayer::join_with(server.addr, hello_in("Eve", "match", "faulty")).await;
    victim
        .wait("the failed match's error", |s| s.errors.iter().any(|e| e == "match_failed").then_some(()))
        .await;
    victim.wait("the connection's end", |s| s.ended.then_some(())).await;
    let outcome_of = |id: &str| server.arena.outcomes().into_iter().find(|(i, _)| i == id).map(|(_, o)| o);
    let ends = tokio::time::timeout(WAIT, async {
        loop {
            // Counted before looking, so an end between the two is never waited for again.
            let ended = server.arena.outcomes().len() as u64;
            if outcome_of("faulty.1").is_some() {
                break;
            }
            server.arena.ended(ended + 1).await;
        }
    });
    ends.await.expect("the faulty match ends in time");
    let outcome = outcome_of("faulty.1").expect("recorded");
    assert!(outcome.as_ref().is_err_and(|why| why.contains("a bug in an agent")), "{outcome:?}");
    // The other match plays to its end, and the server still takes new players.
    let mut good = good;
    good.wait("the end of the sound match", |s| s.ended.then_some(())).await;
    server.ended(2).await;
    let result = outcome_of("sound.1").expect("recorded").expect("the sound match's result");
    assert_eq!((result.ticks, result.end_reason.as_str()), (300, "max_ticks"));
    let rows = server.arena.results().rows();
    let failed = rows.iter().find(|r| r.key == "faulty.1").expect("the failed match's row");
    assert_eq!(failed.end_reason.as_str(), "error");
    assert!(failed.error.as_deref().is_some_and(|e| e.contains("a bug in an agent")), "{rows:?}");
    let (status, _) = http(server.http, "GET", "/api/matches", None, None).await;
    assert_eq!(status, 200);
    server.shutdown().await;
}

/// What a well-behaved player of match `b` receives, with or without hostile clients
/// in match `a` of the same server.
async fn bystander_stream(hostile_in_a: bool) -> Vec<String> {
    let mut a = single("a", lockstep("fixed", 1, 400), OnEnd::Stay);
    a.config.token = Some("sesame".into());
    let mut b = single("b", lockstep("fixed", 1, 400), OnEnd::Stay);
    b.setup.seed = 8;
    let mut config = ArenaConfig::new(vec![a, b]);
    config.server.hello_timeout = Duration::from_millis(200);
    let server = ArenaServer::start(config).await;
    let addr = server.addr;
    let mut hostile = Vec::new();
    if hostile_in_a {
        hostile.push(tokio::spawn(async move {
            let mut c = Client::connect(addr).await;
            c.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Mal", "match": "a", "token": "sesame"})).await;
            for i in 0..300 {
                c.send_raw(&format!("garbage {i} {{")).await;
                c.send(json!({"type": "act", "id": i, "action": "goTo", "args": ["RoomA1"]})).await;
                c.send(json!({"type": "resync"})).await;
            }
            c.send_raw(&"y".repeat(1 << 20)).await;
            c.drain().await;
        }));
        hostile.push(tokio::spawn(async move {
            let mut c = Client::connect(addr).await;
            c.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Eve", "match": "a", "token": "guess"})).await;
            c.drain().await;
        }));
        hostile.push(tokio::spawn(async move {
            let mut c = Client::connect_small(addr).await;
            c.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator", "match": "a", "token": "sesame"})).await;
            // A spectator that never reads.
            std::future::pending::<()>().await;
            c.drain().await;
        }));
        hostile.push(tokio::spawn(async move {
            let mut c = Client::connect(addr).await;
            c.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Nob", "match": "nowhere"})).await;
            c.drain().await;
        }));
        // One other address takes as many connections as it can and holds them, watching.
        hostile.push(tokio::spawn(async move {
            let mut held = Vec::new();
            loop {
                let mut c = Client::connect_from(addr, "127.0.0.2").await;
                c.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator", "match": "a", "token": "sesame"})).await;
                match c.recv().await {
                    Some(ServerMessage::Welcome(_)) => held.push(c),
                    _ => break,
                }
            }
            std::future::pending::<()>().await;
            drop(held);
        }));
    }
    let mut good = Client::connect(addr).await;
    good.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Ann", "match": "b"}))
        .await;
    let stream = crate::util::well_behaved_stream(&mut good).await;
    hostile.iter().for_each(|h| h.abort());
    server.shutdown().await;
    stream
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hostile_clients_in_one_match_leave_another_match_s_streams_identical() {
    let alone = bystander_stream(false).await;
    let among = bystander_stream(true).await;
    assert!(alone.len() > 20, "{alone:?}");
    assert!(alone.iter().any(|l| l.contains("\"match_end\"")), "the match played to its end");
    if let Some(i) = alone.iter().zip(&among).position(|(x, y)| x != y) {
        panic!("message {i} differs:\n alone: {}\n among: {}", alone[i], among[i]);
    }
    assert_eq!(alone.len(), among.len(), "the streams have different lengths");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn clients_that_name_no_match_join_the_default_one_and_never_see_a_lobby() {
    let mut config = ArenaConfig::new(vec![single("default", lockstep("fixed", 2, 20), OnEnd::Stay)]);
    config.default = Some("default".into());
    let server = ArenaServer::start(config).await;
    let mut old = AutoPlayer::join(server.addr, "Ann").await;
    assert_eq!(old.welcome.match_info.name, "default");
    let mut new = AutoPlayer::join_with(server.addr, hello_in("Bob", "match", "default")).await;
    new.wait("the end", |s| s.ended.then_some(())).await;
    old.wait("the end", |s| s.ended.then_some(())).await;
    let lobby = new.seen.lock().expect("lock").lobbies.last().cloned().expect("a lobby");
    assert!(lobby.started && lobby.players == ["Ann", "Bob"], "{lobby:?}");
    let old_lobbies = old.seen.lock().expect("lock").lobbies.len();
    assert_eq!(old_lobbies, 0, "a client that named no match got a lobby");
    // Naming a match that does not exist is refused, naming the live ones.
    let mut lost = Client::connect(server.addr).await;
    lost.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "match": "nowhere"})).await;
    let error = lost.until(|m| if let ServerMessage::Error(e) = m { Some(e.clone()) } else { None }).await;
    assert_eq!(error.code.as_str(), "unknown_match");
    assert!(error.message.contains("'nowhere'"), "{}", error.message);
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_lobby_names_who_is_there_and_whose_seat_waits() {
    let (mut setup, config) = lockstep("fixed", 3, 20);
    setup.seats[..2].clone_from_slice(&[Seat::builtin("Bot1", Strategy::Cooperative), Seat::remote("Bob")]);
    let server = crate::util::TestServer::start(setup, config).await;
    let mut ann = Client::connect(server.addr).await;
    ann.send(
        json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Ann", "match": "default"}),
    )
    .await;
    let lobby = ann.until(|m| if let ServerMessage::Lobby(l) = m { Some(l.clone()) } else { None }).await;
    assert_eq!(lobby.players, ["Bot1", "Ann"]);
    assert_eq!((lobby.expected, lobby.awaited, lobby.started), (vec!["Bob".to_string()], 1, false));
    let mut bob = Client::connect(server.addr).await;
    bob.send(
        json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Bob", "match": "default"}),
    )
    .await;
    let lobby = ann.until(|m| if let ServerMessage::Lobby(l) = m { Some(l.clone()) } else { None }).await;
    assert_eq!((lobby.players.len(), lobby.expected.len(), lobby.awaited, lobby.started), (3, 0, 0, true));
    // A session is reconnected through its match, never through a template.
    let mut lost = Client::connect(server.addr).await;
    lost.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "session": "x", "template": "t"}))
        .await;
    let error = lost.until(|m| if let ServerMessage::Error(e) = m { Some(e.clone()) } else { None }).await;
    assert!(error.fatal && error.message.contains("reconnect with hello.match"), "{error:?}");
    drop((ann, bob));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_restarted_server_numbers_runs_on_from_its_results() {
    let dir = temp_dir("restart");
    let ladder = || {
        let mut t = single("ladder", lockstep("default", 3, 30), OnEnd::Restart);
        with_bots(&mut t, 3);
        let mut config = ArenaConfig::new(vec![t]);
        config.results = ResultsStore::in_dir(&dir).expect("results dir");
        config.server.operator_token = Some("op".into());
        config
    };
    let first = ArenaServer::start(ladder()).await;
    first.ended(2).await;
    first.shutdown().await;
    let before = ResultsStore::in_dir(&dir).expect("results dir").rows().len();
    let second = ArenaServer::start(ladder()).await;
    // Stopping a match its template starts again answers for the run that was stopped.
    let (status, body) = http(second.http, "POST", "/api/matches/ladder/stop", Some("op"), Some("")).await;
    assert_eq!(status, 200, "{body}");
    let stopped = json_of(&body);
    assert_eq!(stopped["state"], "finished", "{body}");
    second.shutdown().await;
    let rows = ResultsStore::in_dir(&dir).expect("results dir").rows();
    let keys: std::collections::BTreeSet<&str> = rows.iter().map(|r| r.key.as_str()).collect();
    assert_eq!(keys.len(), rows.len(), "every key is unique: {keys:?}");
    let indices: Vec<u64> = rows.iter().map(|r| r.index).collect();
    assert_eq!(indices, (1..=rows.len() as u64).collect::<Vec<_>>());
    assert!(rows.len() > before, "the second server added rows");
    // The first run after the restart follows the first server's last one.
    let run = stopped["run"].as_u64().expect("run");
    assert!(run > before as u64, "run {run} after {before} rows: {body}");
    assert_eq!(stopped["id"].as_str(), Some(format!("ladder.{run}").as_str()), "{body}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Stopping a match while its template makes the next one, many times over: each stop is
/// answered once its run has ended, even as the next run of the name starts at once (an
/// arena that guarded its state with locks deadlocked here now and then, every thread
/// stuck). Watched from another thread, so that a hang fails the test instead of hanging it.
#[test]
fn stops_racing_restarts_never_deadlock() {
    let (done, finished) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .expect("runtime");
        let stopped = runtime.block_on(async {
            let mut t = single("ladder", lockstep("default", 3, 5), OnEnd::Restart);
            with_bots(&mut t, 3);
            let server = ArenaServer::start(ArenaConfig::new(vec![t])).await;
            let mut stopped = 0;
            for _ in 0..300 {
                if server.arena.stop("ladder").await.is_ok() {
                    stopped += 1;
                }
            }
            server.shutdown().await;
            stopped
        });
        let _ = done.send(stopped);
    });
    let stopped = finished.recv_timeout(Duration::from_secs(120)).expect("every stop answered: no deadlock");
    assert!(stopped > 0, "some stops found the ladder live");
}

/// `hello` joining template `template` as `name`.
fn hello_template(name: &str, template: &str) -> Value {
    json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": name, "template": template})
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_player_who_leaves_a_waiting_match_frees_its_seat_for_the_next() {
    let mut open = template("open", lockstep("default", 2, 40));
    open.max_running = 1;
    open.config.grace = Duration::from_secs(600);
    let server = ArenaServer::start(ArenaConfig::new(vec![open])).await;
    let (mal, welcome) = crate::util::welcomed(server.addr, hello_template("Mal", "open")).await;
    assert_eq!(welcome.match_info.name, "open-1");
    mal.leave().await;
    // Mal's seat is free at once, not after the grace period: Ann and Bob both sit in open-1.
    let (_ann, ann) = crate::util::welcomed(server.addr, hello_template("Ann", "open")).await;
    let (_bob, bob) = crate::util::welcomed(server.addr, hello_template("Bob", "open")).await;
    assert_eq!((ann.match_info.name.as_str(), bob.match_info.name.as_str()), ("open-1", "open-1"));
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sixteen_players_who_join_a_template_and_leave_do_not_block_it() {
    // As examples/arena.toml's `open`: four seats, four matches at most, a long tick limit.
    let mut open = template("open", lockstep("default", 4, 1_000_000));
    open.config.mode = Mode::Realtime;
    open.max_running = 4;
    open.config.grace = Duration::from_millis(300);
    let server = ArenaServer::start(ArenaConfig::new(vec![open])).await;
    let mut gone = Vec::new();
    for i in 0..16 {
        let (client, welcome) =
            crate::util::welcomed(server.addr, hello_template(&format!("Mal{i}"), "open")).await;
        assert_eq!(welcome.match_info.name, format!("open-{}", i / 4 + 1));
        gone.push(client);
    }
    drop(gone);
    // The four matches lost every player: each ends a grace period later, and Ann is seated.
    let (_ann, welcome) = crate::util::welcomed(server.addr, hello_template("Ann", "open")).await;
    assert_eq!(welcome.match_info.template.as_deref(), Some("open"));
    server.ended(4).await;
    let (_, body) = http(server.http, "GET", "/api/matches", None, None).await;
    let list = json_of(&body);
    let reasons: Vec<&str> =
        list["matches"].as_array().expect("a list").iter().filter_map(|m| m["end_reason"].as_str()).collect();
    assert_eq!(reasons, ["abandoned"; 4], "{body}");
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_address_gets_its_share_of_connections_and_no_more() {
    let mut config = ArenaConfig::new(vec![single("a", lockstep("fixed", 1, 400), OnEnd::Stay)]);
    config.server.max_per_source = 3;
    let server = ArenaServer::start(config).await;
    let spectate =
        json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator", "match": "a"});
    let mut held = Vec::new();
    for _ in 0..3 {
        let mut c = Client::connect_from(server.addr, "127.0.0.2").await;
        c.send(spectate.clone()).await;
        c.until(|m| matches!(m, ServerMessage::Welcome(_)).then_some(())).await;
        held.push(c);
    }
    let mut fourth = Client::connect_from(server.addr, "127.0.0.2").await;
    let error = fourth.until(|m| if let ServerMessage::Error(e) = m { Some(e.clone()) } else { None }).await;
    assert_eq!((error.code.as_str(), error.fatal), ("source_full", true), "{}", error.message);
    assert!(error.message.contains("at most 3"), "{}", error.message);
    // Another address is let in, and a place given back is free again.
    let (_ann, welcome) = crate::util::welcomed(server.addr, hello_template_free("Ann", "a")).await;
    assert_eq!(welcome.match_info.name, "a");
    // A spectator that leaves: its place is free once the server has closed it.
    let mut leaving = held.pop().expect("a held connection");
    leaving.send(json!({"type": "bye"})).await;
    leaving.drain().await;
    let mut again = Client::connect_from(server.addr, "127.0.0.2").await;
    again.send(spectate).await;
    again
        .until(|m| match m {
            ServerMessage::Welcome(_) => Some(()),
            ServerMessage::Error(e) => panic!("refused after a place was given back: {e:?}"),
            _ => None,
        })
        .await;
    server.shutdown().await;
}

/// `hello` joining match `name` as player `player`.
fn hello_template_free(player: &str, name: &str) -> Value {
    json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": player, "match": name})
}
