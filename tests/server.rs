use std::time::Duration;

use bw4t_protocol::{Mode, ServerMessage};
use bw4t_sim::{Action, Match, MatchConfig, RobotId};
use serde_json::json;

use crate::util::{AutoPlayer, Client, TestServer, delta_of, lockstep, open_seats, shipped_map, two_rooms};

/// BW4T-FACTS section 6, played over TCP: a closed door, a delivery, and messages.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_original_scenarios_over_tcp() {
    let server = TestServer::start_pair(lockstep("fixed", 1, 3)).await;
    let mut ann = AutoPlayer::join(server.addr, "Ann").await;
    let mut bob = AutoPlayer::join(server.addr, "Bob").await;
    let mut cat = AutoPlayer::join(server.addr, "Cat").await;
    ann.wait_fact("at(FrontDropZone)").await;

    // 1. Movement: Bob meets RoomC1's closed door while Ann is inside.
    let go = ann.act("goTo", json!(["RoomC1"])).await;
    ann.wait_fact("in(RoomC1)").await;
    bob.wait_fact("occupied(RoomC1)").await;
    let blocked = bob.act("goTo", json!(["RoomC1"])).await;
    assert_eq!(bob.wait_result(&blocked).await, "collided");
    bob.wait_fact("state(collided)").await;
    bob.wait_fact("at(FrontC1)").await;
    assert_eq!(ann.wait_result(&go).await, "arrived");

    // 2. Blocks: Ann fetches the yellow block and delivers it.
    let yellow = ann.block_of("Yellow").expect("Ann sees a yellow block in RoomC1");
    let to_block = ann.act("goToBlock", json!([yellow])).await;
    assert_eq!(ann.wait_result(&to_block).await, "arrived");
    let pick = ann.act("pickUp", json!([])).await;
    assert_eq!(ann.wait_ack(&pick).await, Ok(()));
    ann.wait_fact(&format!("holding({yellow})")).await;
    let home = ann.act("goTo", json!(["DropZone"])).await;
    assert_eq!(ann.wait_result(&home).await, "arrived");
    let put = ann.act("putDown", json!([])).await;
    assert_eq!(ann.wait_ack(&put).await, Ok(()));
    ann.wait_fact("sequenceIndex(1)").await;
    bob.wait_fact("sequenceIndex(1)").await;

    // 3. Communication with a third player.
    cat.wait_fact("player(Ann)").await;
    ann.wait_fact("player(Cat)").await;
    ann.say("Bob", "hello").await;
    ann.say("all", "hi").await;
    bob.wait("two messages", |s| (s.heard.len() == 2).then_some(())).await;
    cat.wait("one message", |s| (!s.heard.is_empty()).then_some(())).await;
    let result = server.stop().await;
    assert_eq!(bob.seen.lock().expect("lock").heard, ["Ann:hello", "Ann:hi"]);
    assert_eq!(cat.seen.lock().expect("lock").heard, ["Ann:hi"]);
    assert!(ann.seen.lock().expect("lock").heard.is_empty(), "`all` is not echoed to the sender");
    assert_eq!(result.end_reason, "interrupted");
    assert_eq!((result.good_drops, result.messages, result.robots), (1, 2, 3));
}

/// A player whose actions depend only on what it received: it sends each next `goTo`
/// before its `ready`, so the match is the same on every run.
async fn scripted_player(
    addr: std::net::SocketAddr,
    name: &str,
    places: Vec<&'static str>,
) -> tokio::task::JoinHandle<Vec<(u64, Action)>> {
    let mut client = Client::connect(addr).await;
    client.hello(name).await;
    tokio::spawn(async move {
        let (mut next, mut busy, mut sent) = (0usize, false, Vec::new());
        let mut applied = Vec::new();
        loop {
            let Some(message) = client.recv().await else { return applied };
            let tick = match &message {
                ServerMessage::Percepts(p) => p.tick,
                ServerMessage::Result(_) => {
                    // The tick's `percepts` follows; decide and answer then.
                    busy = false;
                    continue;
                }
                ServerMessage::Ack(ack) => {
                    let action: Action = sent.remove(0);
                    if ack.ok {
                        applied.push((ack.tick, action));
                    } else {
                        busy = false;
                    }
                    continue;
                }
                ServerMessage::MatchEnd(_) => return applied,
                _ => continue,
            };
            if !busy && next < places.len() * 4 {
                let place = places[next % places.len()];
                next += 1;
                busy = true;
                sent.push(Action::GoTo(place.to_string()));
                client.send(json!({"type": "act", "id": next, "action": "goTo", "args": [place]})).await;
            }
            client.send(json!({"type": "ready", "tick": tick})).await;
        }
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lockstep_match_has_the_digest_of_the_same_actions_played_headless() {
    let (mut setup, config) = lockstep("default", 5, 2);
    setup.max_ticks = Some(700);
    let server = TestServer::start(setup, config).await;
    let ann = scripted_player(server.addr, "Ann", vec!["RoomB2", "RoomA1", "DropZone"]).await;
    let bob = scripted_player(server.addr, "Bob", vec!["RoomB2", "RoomC3", "RightHallA"]).await;
    let result = server.finish().await;
    let logs = [ann.await.expect("Ann"), bob.await.expect("Bob")];
    assert!(logs.iter().all(|l| l.len() > 3), "players acted: {logs:?}");

    let mut game = Match::new(&shipped_map("default"), &MatchConfig::default(), 5).expect("match");
    let ids = [game.join("Ann").expect("Ann"), game.join("Bob").expect("Bob")];
    for tick in 0..result.ticks {
        for (robot, log) in ids.iter().zip(&logs) {
            for (_, action) in log.iter().filter(|(t, _)| *t == tick) {
                game.handle_action(*robot, action).expect("accepted as when served");
            }
        }
        game.step();
    }
    assert_eq!(format!("{:016x}", game.digest()), result.digest);
    assert_eq!(result.end_reason, "max_ticks");
    // Bob was sent to RoomB2 while Ann was in it at least once: the door decided.
    let again = Match::new(&shipped_map("default"), &MatchConfig::default(), 5).expect("match");
    assert_ne!(again.digest(), game.digest());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_dropped_player_takes_its_robot_back_with_its_session() {
    let server = TestServer::start_pair(lockstep("fixed", 2, 1)).await;
    let mut ann = AutoPlayer::join(server.addr, "Ann").await;
    let session = ann.welcome.session.clone().expect("a session token");
    let go = ann.act("goTo", json!(["RoomC1"])).await;
    ann.wait_result(&go).await;
    let yellow = ann.block_of("Yellow").expect("yellow block");
    let to_block = ann.act("goToBlock", json!([yellow])).await;
    ann.wait_result(&to_block).await;
    let pick = ann.act("pickUp", json!([])).await;
    assert_eq!(ann.wait_ack(&pick).await, Ok(()));
    ann.wait_fact(&format!("holding({yellow})")).await;
    ann.disconnect().await;

    let mut thief = Client::connect(server.addr).await;
    thief.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Ann"})).await;
    assert_eq!(thief.error_code().await, "name_taken");

    let mut back = Client::connect(server.addr).await;
    back.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "session": session})).await;
    let welcome =
        back.until(|m| if let ServerMessage::Welcome(w) = m { Some(w.clone()) } else { None }).await;
    assert_eq!((welcome.name.as_deref(), welcome.robot), (Some("Ann"), Some(0)));
    let snapshot =
        back.until(|m| if let ServerMessage::Percepts(p) = m { Some(p.clone()) } else { None }).await;
    assert!(snapshot.full);
    let facts: Vec<String> = delta_of(&snapshot).add.iter().map(|p| p.to_string()).collect();
    assert!(
        facts.contains(&format!("holding({yellow})")) && facts.contains(&"in(RoomC1)".to_string()),
        "{facts:?}"
    );

    let mut stranger = Client::connect(server.addr).await;
    stranger.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "session": "nope"})).await;
    assert_eq!(stranger.error_code().await, "bad_session");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn spectators_watch_the_whole_match_but_cannot_act() {
    let (mut setup, mut config) = lockstep("fixed", 3, 1);
    config.mode = Mode::Realtime;
    setup.game.ticks_per_second = 100;
    let server = TestServer::start(setup, config).await;
    let mut watcher = Client::connect(server.addr).await;
    watcher.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator"})).await;
    let welcome =
        watcher.until(|m| if let ServerMessage::Welcome(w) = m { Some(w.clone()) } else { None }).await;
    assert_eq!(welcome.robot, None);
    let mut ann = AutoPlayer::join(server.addr, "Ann").await;
    ann.act("goTo", json!(["RoomA1"])).await;
    let start = watcher
        .until(|m| match m {
            ServerMessage::Frame(f) if !f.robots.is_empty() => Some(f.clone()),
            _ => None,
        })
        .await;
    assert_eq!(start.blocks.len(), 17, "a frame shows every block");
    let moved = watcher
        .until(|m| match m {
            ServerMessage::Frame(f) if f.robots[0].y < start.robots[0].y - 5.0 => Some(f.clone()),
            _ => None,
        })
        .await;
    assert!(moved.tick > start.tick);
    watcher.send(json!({"type": "act", "id": 1, "action": "goTo", "args": ["RoomA1"]})).await;
    assert_eq!(watcher.error_code().await, "not_a_player");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_input_is_answered_and_the_connection_stays_open() {
    let server = TestServer::start_pair(lockstep("fixed", 4, 1)).await;
    let mut c = Client::connect(server.addr).await;
    let cases = [
        ("this is not json", "bad_json"),
        ("{\"type\":\"dance\"}", "unknown_type"),
        ("{\"type\":\"ready\"}", "bad_message"),
        ("{\"type\":\"ready\",\"tick\":-1}", "bad_message"),
        ("[1,2,3]", "bad_message"),
        ("{\"type\":\"act\",\"id\":1,\"action\":\"goTo\",\"args\":[\"RoomA1\"]}", "no_hello"),
    ];
    for (line, code) in cases {
        c.send_raw(line).await;
        assert_eq!(c.error_code().await, code, "for {line}");
    }
    c.send_raw(&"x".repeat(70 * 1024)).await;
    assert_eq!(c.error_code().await, "line_too_long");
    c.hello("Ann").await;
    c.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Ann"})).await;
    assert_eq!(c.error_code().await, "already_joined");
    c.send(json!({"type": "ready", "tick": 999})).await;
    assert_eq!(c.error_code().await, "bad_tick");
    let acts = [
        (json!({"type": "act", "id": 1, "action": "fly", "args": []}), "unknown_action"),
        (json!({"type": "act", "id": 2, "action": "goTo", "args": []}), "bad_args"),
        (json!({"type": "act", "id": 3, "action": "goToBlock", "args": ["seven"]}), "bad_args"),
        (json!({"type": "act", "id": 4, "action": "goTo", "args": ["Narnia"]}), "unknown_place"),
    ];
    for (act, code) in acts {
        c.send(act.clone()).await;
        c.send(json!({"type": "ready", "tick": 0})).await;
        let got = c
            .until(|m| match m {
                ServerMessage::Ack(a) => Some(a.code),
                _ => None,
            })
            .await;
        assert_eq!(got.map(|c| c.as_str()), Some(code), "for {act}");
    }
    c.send(json!({"type": "ping", "id": "still-there"})).await;
    let pong = c.until(|m| if let ServerMessage::Pong(p) = m { Some(p.clone()) } else { None }).await;
    assert_eq!(pong.id, Some(bw4t_protocol::ActId::Text("still-there".into())));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn refusals_are_fatal_and_name_the_reason() {
    let one_spawn = two_rooms(|parts| parts.spawns.truncate(1));
    let mut setup = bw4t_server::MatchSetup::new(one_spawn);
    let mut config = bw4t_server::HostConfig::new();
    config.token = Some("sesame".into());
    // Two seats but one spawn point: the last refusal is the map's.
    setup.seats = open_seats(2);
    let limits = bw4t_server::ServerConfig { max_connections: 8, ..Default::default() };
    let server = TestServer::start_limited(setup, config, limits).await;
    let hello = |extra: serde_json::Value| {
        let mut h = json!({"type": "hello", "protocol": "bw4t", "versions": [1], "token": "sesame"});
        h.as_object_mut().expect("object").extend(extra.as_object().expect("object").clone());
        h
    };
    let mut first = Client::connect(server.addr).await;
    first.send(hello(json!({"name": "Ann"}))).await;
    first.until(|m| matches!(m, ServerMessage::Welcome(_)).then_some(())).await;
    let cases = [
        (hello(json!({"name": "Bob", "token": "wrong"})), "bad_token"),
        (hello(json!({"name": "Bob", "versions": [7, 9]})), "unsupported_version"),
        (hello(json!({"name": "Bob", "protocol": "http"})), "bad_protocol"),
        (hello(json!({"name": "Ann"})), "name_taken"),
        (hello(json!({"name": "9lives"})), "invalid_name"),
        (hello(json!({"name": "Bob"})), "match_full"),
    ];
    for (message, code) in cases {
        let mut c = Client::connect(server.addr).await;
        c.send(message.clone()).await;
        let rest = c.drain().await;
        let error =
            rest.iter().find_map(|m| if let ServerMessage::Error(e) = m { Some(e.clone()) } else { None });
        let error = error.unwrap_or_else(|| panic!("no error for {message}: {rest:?}"));
        assert_eq!((error.code.as_str(), error.fatal), (code, true), "for {message}");
        assert!(matches!(rest.last(), Some(ServerMessage::Bye(_))), "bye last: {rest:?}");
    }
    first.send(json!({"type": "ping"})).await;
    first.until(|m| matches!(m, ServerMessage::Pong(_)).then_some(())).await;
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn silent_connections_time_out_and_extra_connections_are_refused() {
    let (setup, config) = lockstep("fixed", 4, 1);
    let limits = bw4t_server::ServerConfig {
        hello_timeout: Duration::from_millis(300),
        max_connections: 2,
        ..Default::default()
    };
    let server = TestServer::start_limited(setup, config, limits).await;
    let mut silent = Client::connect(server.addr).await;
    let mut second = Client::connect(server.addr).await;
    second.send(json!({"type": "ping"})).await;
    second.until(|m| matches!(m, ServerMessage::Pong(_)).then_some(())).await;
    let mut third = Client::connect(server.addr).await;
    assert_eq!(third.error_code().await, "server_full");
    assert!(third.recv().await.is_none(), "refused connection is closed");
    assert_eq!(silent.error_code().await, "hello_timeout");
    assert!(matches!(silent.recv().await, Some(ServerMessage::Bye(_))));
    assert!(silent.recv().await.is_none());
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn actions_beyond_the_per_tick_limit_are_rejected() {
    let (setup, mut config) = lockstep("fixed", 4, 1);
    config.max_actions_per_tick = 2;
    let server = TestServer::start(setup, config).await;
    let mut c = Client::connect(server.addr).await;
    c.hello("Ann").await;
    for id in 1..=3 {
        c.send(json!({"type": "say", "id": id, "to": "all", "text": "spam"})).await;
    }
    let code = c
        .until(|m| match m {
            ServerMessage::Ack(a) if !a.ok => Some(a.code),
            _ => None,
        })
        .await;
    assert_eq!(code.map(|c| c.as_str()), Some("rate_limited"));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stopping_the_server_ends_the_match_for_everyone() {
    let server = TestServer::start_pair(lockstep("fixed", 4, 1)).await;
    let mut ann = Client::connect(server.addr).await;
    ann.hello("Ann").await;
    let result = server.stop().await;
    let rest = ann.drain().await;
    let end =
        rest.iter().find_map(|m| if let ServerMessage::MatchEnd(e) = m { Some(e.clone()) } else { None });
    let end = end.expect("match_end");
    assert_eq!(end.reason, "interrupted");
    assert_eq!(end.result, result);
    assert!(matches!(rest.last(), Some(ServerMessage::Bye(_))));
    let _ = RobotId(0);
}

/// Bob sends Ann `rounds` x 16 messages of 50 KB, waiting for each round's acks.
async fn flood(bob: &mut AutoPlayer, rounds: usize, tag: &str) {
    let text = "m".repeat(50_000);
    for round in 0..rounds {
        let mut ids = Vec::new();
        for i in 0..16 {
            ids.push(bob.act("sendMessage", json!(["Ann", format!("{tag}{round}-{i} {text}")])).await);
        }
        for id in &ids {
            assert_eq!(bob.wait_ack(id).await, Ok(()));
        }
    }
}

/// Waits until Bob (an `every_tick` player) has seen `n` more ticks.
async fn let_ticks_pass(bob: &mut AutoPlayer, n: u64) {
    let now = bob.seen.lock().expect("lock").tick;
    bob.wait("ticks to pass", |s| (s.tick >= now + n).then_some(())).await;
}

/// A fast realtime match whose clients' queues hold 100 lines.
async fn realtime_flood_server(slow_limit: Duration) -> TestServer {
    let (mut setup, mut config) = lockstep("fixed", 6, 2);
    config.mode = Mode::Realtime;
    setup.game.ticks_per_second = 200;
    config.slow_limit = slow_limit;
    TestServer::start_limited(setup, config, bw4t_server::ServerConfig { queue: 100, ..Default::default() })
        .await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_that_stops_reading_gets_a_snapshot_and_every_message_once() {
    let server = realtime_flood_server(Duration::from_secs(60)).await;
    let mut ann = Client::connect_small(server.addr).await;
    ann.send(
        json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Ann", "every_tick": true}),
    )
    .await;
    let mut bob = AutoPlayer::join_with(server.addr, json!({"name": "Bob", "every_tick": true})).await;
    // Ann reads nothing while 16 MB of messages and a percepts line per tick pile up.
    flood(&mut bob, 20, "a").await;
    let_ticks_pass(&mut bob, 200).await;
    for i in 0..5 {
        bob.say("Ann", &format!("late{i}")).await;
    }
    let_ticks_pass(&mut bob, 20).await;
    let (mut heard, mut snapshots) = (Vec::new(), 0);
    while heard.len() < 325 {
        let Some(message) = ann.recv().await else {
            panic!("Ann was disconnected after {} messages", heard.len())
        };
        if let ServerMessage::Percepts(p) = message {
            snapshots += usize::from(p.full);
            for fact in &p.add {
                if fact[0] == "message" {
                    heard.push(fact[2].as_str().expect("text").split(' ').next().expect("tag").to_string());
                }
            }
        }
    }
    let unique: std::collections::BTreeSet<&String> = heard.iter().collect();
    assert_eq!(unique.len(), heard.len(), "a message arrived twice");
    assert!(heard.iter().any(|m| m == "late4") && heard.iter().any(|m| m == "a19-15"));
    assert!(snapshots >= 2, "held-back percepts are replaced by a full snapshot (got {snapshots} snapshots)");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_that_never_reads_is_disconnected_and_others_play_on() {
    let server = realtime_flood_server(Duration::from_millis(300)).await;
    let mut ann = Client::connect_small(server.addr).await;
    ann.send(
        json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Ann", "every_tick": true}),
    )
    .await;
    let mut bob = AutoPlayer::join_with(server.addr, json!({"name": "Bob", "every_tick": true})).await;
    flood(&mut bob, 20, "a").await;
    let_ticks_pass(&mut bob, 400).await;
    let rest = ann.drain().await;
    let error =
        rest.iter().rev().find_map(|m| if let ServerMessage::Error(e) = m { Some(e.code) } else { None });
    assert_eq!(error.map(|c| c.as_str()), Some("too_slow"));
    assert!(matches!(rest.last(), Some(ServerMessage::Bye(_))));
    let_ticks_pass(&mut bob, 10).await;
    server.stop().await;
}

/// Everything the well-behaved player receives in a fixed lockstep match, with the
/// wall-clock and random fields blanked.
async fn good_player_stream(adversaries: bool) -> Vec<String> {
    let (mut setup, mut config) = lockstep("fixed", 8, 1);
    setup.max_ticks = Some(400);
    config.token = Some("sesame".into());
    let limits =
        bw4t_server::ServerConfig { hello_timeout: Duration::from_millis(200), ..Default::default() };
    let server = TestServer::start_limited(setup, config, limits).await;
    let addr = server.addr;
    let mut hostile = Vec::new();
    if adversaries {
        hostile.push(tokio::spawn(async move {
            let mut c = Client::connect(addr).await;
            for i in 0..300 {
                c.send_raw(&format!("garbage {i} {{")).await;
            }
            c.send_raw(&"y".repeat(1 << 20)).await;
            c.drain().await;
        }));
        hostile.push(tokio::spawn(async move {
            let mut c = Client::connect(addr).await;
            c.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Eve", "token": "guess"})).await;
            c.drain().await;
        }));
        hostile.push(tokio::spawn(async move {
            let mut c = Client::connect_small(addr).await;
            c.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator", "token": "sesame"})).await;
            // A spectator that never reads.
            std::future::pending::<()>().await;
            c.drain().await;
        }));
        hostile.push(tokio::spawn(async move {
            let mut silent = Client::connect(addr).await;
            silent.drain().await;
        }));
    }
    let mut good = Client::connect(addr).await;
    good.send(
        json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Ann", "token": "sesame"}),
    )
    .await;
    let stream = crate::util::well_behaved_stream(&mut good).await;
    server.finish().await;
    hostile.iter().for_each(|h| h.abort());
    stream
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hostile_clients_do_not_change_what_a_good_player_receives() {
    let alone = good_player_stream(false).await;
    let among = good_player_stream(true).await;
    assert!(alone.len() > 20, "{alone:?}");
    let first_difference = alone.iter().zip(&among).position(|(a, b)| a != b);
    if let Some(i) = first_difference {
        panic!("message {i} differs:\n alone: {}\n among: {}", alone[i], among[i]);
    }
    assert_eq!(alone.len(), among.len(), "the streams have different lengths");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn completing_the_sequence_ends_the_match_for_everyone() {
    let setup =
        bw4t_server::MatchSetup { seats: open_seats(1), ..bw4t_server::MatchSetup::new(two_rooms(|_| ())) };
    let mut config = bw4t_server::HostConfig::new();
    config.mode = Mode::Lockstep;
    let server = TestServer::start(setup, config).await;
    let mut ann = AutoPlayer::join_with(server.addr, json!({"name": "Ann", "every_tick": true})).await;
    let go = ann.act("goTo", json!(["RoomA"])).await;
    ann.wait_result(&go).await;
    let go = ann.act("goToBlock", json!([1])).await;
    ann.wait_result(&go).await;
    ann.act("pickUp", json!([])).await;
    let go = ann.act("goTo", json!(["DropZone"])).await;
    ann.wait_result(&go).await;
    ann.act("putDown", json!([])).await;
    let result = server.finish().await;
    assert_eq!((result.end_reason.as_str(), result.completed, result.sequence_index), ("completed", true, 1));
    assert_eq!(
        result.completed_tick,
        Some(result.ticks),
        "the completing delivery shows in the last tick's percepts"
    );
    ann.wait("the end", |s| s.ended.then_some(())).await;
    // With every_tick, Ann was sent (and answered) every tick; the last showed the sequence done.
    let (ticks, complete) = {
        let seen = ann.seen.lock().expect("lock");
        (seen.tick, seen.knowledge.holds(&bw4t_sim::Percept::SequenceIndex(1)))
    };
    assert_eq!(ticks, result.ticks);
    assert!(complete, "the last percepts show the sequence complete");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_whose_player_stays_away_leaves_after_the_grace_period() {
    let mut setup = bw4t_server::MatchSetup::new(two_rooms(|_| ()));
    let mut config = bw4t_server::HostConfig::new();
    config.mode = Mode::Realtime;
    setup.game.ticks_per_second = 100;
    setup.seats = open_seats(2);
    config.grace = Duration::from_millis(300);
    let server = TestServer::start(setup, config).await;
    let mut ann = AutoPlayer::join(server.addr, "Ann").await;
    let bob = AutoPlayer::join(server.addr, "Bob").await;
    let old_session = bob.welcome.session.clone();
    ann.wait_fact("player(Bob)").await;
    bob.disconnect().await;
    ann.wait("Bob's robot to leave", |s| {
        (!s.knowledge.facts().iter().any(|p| p.to_string() == "player(Bob)")).then_some(())
    })
    .await;
    // The name is free again.
    let back = AutoPlayer::join(server.addr, "Bob").await;
    assert_eq!(back.welcome.robot, Some(1), "the freed id is given again");
    assert_ne!(back.welcome.session, old_session, "to a new robot, not the old one");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_dropped_players_robot_stands_still() {
    let (mut setup, mut config) = lockstep("fixed", 3, 1);
    config.mode = Mode::Realtime;
    setup.game.ticks_per_second = 100;
    let server = TestServer::start(setup, config).await;
    let mut watcher = Client::connect(server.addr).await;
    watcher.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator"})).await;
    let mut ann = AutoPlayer::join(server.addr, "Ann").await;
    ann.act("goTo", json!(["RoomA3"])).await;
    ann.wait_fact("at(RightHallD)").await;
    ann.disconnect().await;
    // Once stopped (on its way, past RightHallD), the robot keeps its place across many ticks.
    let stopped = watcher
        .until(|m| match m {
            ServerMessage::Frame(f)
                if f.robots.first().is_some_and(|r| r.state == "arrived" && r.x >= 39.0) =>
            {
                Some(f.clone())
            }
            _ => None,
        })
        .await;
    let later = watcher
        .until(|m| match m {
            ServerMessage::Frame(f) if f.tick > stopped.tick + 50 => Some(f.clone()),
            _ => None,
        })
        .await;
    assert_eq!((later.robots[0].x, later.robots[0].y), (stopped.robots[0].x, stopped.robots[0].y));
    assert!(stopped.robots[0].y > 30.0, "stopped before reaching RoomA3: {:?}", stopped.robots[0]);
    server.stop().await;
}

/// The built-in team playing over TCP, one connection per robot, gives the very match it
/// plays headless: the same agent trait, the same lockstep rule.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_builtin_team_over_tcp_plays_the_same_match_as_headless() {
    let (mut setup, config) = lockstep("default", 21, 3);
    setup.max_ticks = Some(20_000);
    // Seats taken in advance fix the robot ids, whoever connects first.
    setup.seats = ["Bot1", "Bot2", "Bot3"].map(bw4t_server::Seat::remote).into();
    let server = TestServer::start(setup, config).await;
    let mut clients = Vec::new();
    for name in ["Bot3", "Bot1", "Bot2"] {
        let agent = bw4t_agents::Strategy::Cooperative.agent(name);
        clients.push(tokio::spawn(bw4t_runner::play_remote(
            server.addr,
            bw4t_protocol::SessionOptions::agent(name, None),
            agent,
        )));
    }
    let served = server.finish().await;
    for client in clients {
        let result = client.await.expect("client task").expect("played to the end");
        assert_eq!(result.digest, served.digest);
    }
    let mut headless =
        bw4t_server::MatchSetup::builtin_team(shipped_map("default"), 3, bw4t_agents::Strategy::Cooperative);
    headless.seed = 21;
    headless.max_ticks = Some(20_000);
    let (game, reason) = bw4t_runner::play_headless(&headless, None).expect("play");
    assert_eq!((reason.as_str(), served.end_reason.as_str()), ("completed", "completed"));
    assert_eq!(format!("{:016x}", game.digest()), served.digest);
}
