use std::net::SocketAddr;
use std::time::Duration;

use bw4t_map::SeededRng;
use bw4t_protocol::{FrameMessage, Mode, ServerMessage};
use serde_json::{Value, json};

use crate::util::{AutoPlayer, Client, TestServer, bw4t_within, lockstep, welcomed};

/// A `hello` with `fields` added.
fn hello(fields: Value) -> Value {
    let mut h = json!({"type": "hello", "protocol": "bw4t", "versions": [1]});
    h.as_object_mut().expect("object").extend(fields.as_object().expect("object").clone());
    h
}

/// The code of the fatal error a connection saying `message` gets; it must end with `bye`.
async fn refusal(addr: SocketAddr, message: Value) -> String {
    let mut c = Client::connect(addr).await;
    c.send(message.clone()).await;
    let rest = c.drain().await;
    let error =
        rest.iter().find_map(|m| if let ServerMessage::Error(e) = m { Some(e.clone()) } else { None });
    let error = error.unwrap_or_else(|| panic!("no error for {message}: {rest:?}"));
    assert!(error.fatal, "{error:?}");
    assert!(matches!(rest.last(), Some(ServerMessage::Bye(_))), "bye last: {rest:?}");
    error.code.to_string()
}

/// Every message a watcher's frames carry, up to and including the frame with `text`.
async fn frame_messages_until(watcher: &mut Client, text: &str) -> Vec<FrameMessage> {
    let mut seen = Vec::new();
    watcher
        .until(|m| {
            let ServerMessage::Frame(f) = m else { return None };
            seen.extend(f.messages.iter().cloned());
            f.messages.iter().any(|m| m.text == text).then_some(())
        })
        .await;
    seen
}

fn texts(messages: &[FrameMessage]) -> Vec<&str> {
    messages.iter().map(|m| m.text.as_str()).collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn players_spectators_and_the_operator_have_their_own_tokens() {
    let (mut setup, mut config) = lockstep("fixed", 9, 2);
    config.mode = Mode::Realtime;
    setup.game.ticks_per_second = 100;
    config.token = Some("player-secret".into());
    config.spectator_token = Some("spectator-secret".into());
    config.operator_token = Some("operator-secret".into());
    let server = TestServer::start(setup, config).await;
    let addr = server.addr;
    // A player's token opens no view of the whole match; nothing opens the wrong role.
    let wrong = [
        ("spectator", None),
        ("spectator", Some("player-secret")),
        ("operator", None),
        ("operator", Some("player-secret")),
        ("operator", Some("spectator-secret")),
        ("agent", None),
        ("agent", Some("spectator-secret")),
        ("agent", Some("operator-secret")),
    ];
    for (role, token) in wrong {
        let message = hello(json!({"role": role, "name": "Eve", "token": token}));
        assert_eq!(refusal(addr, message).await, "bad_token", "{role} with {token:?}");
    }
    let spectator_hello = hello(json!({"role": "spectator", "token": "spectator-secret"}));
    let (mut spectator, welcome) = welcomed(addr, spectator_hello).await;
    assert_eq!(welcome.private_messages, Some(false));
    // The operator's token also lets one watch as a spectator.
    let (_, welcome) = welcomed(addr, hello(json!({"role": "spectator", "token": "operator-secret"}))).await;
    assert_eq!(welcome.private_messages, Some(false));
    let (mut operator, welcome) =
        welcomed(addr, hello(json!({"role": "operator", "token": "operator-secret"}))).await;
    assert_eq!(welcome.private_messages, Some(true));

    let mut ann = AutoPlayer::join_with(addr, json!({"name": "Ann", "token": "player-secret"})).await;
    let mut bob = AutoPlayer::join_with(addr, json!({"name": "Bob", "token": "player-secret"})).await;
    // Applied at the same boundary, so a frame carrying the second also carries the first.
    ann.say("Bob", "psst, the yellow one is in RoomC1").await;
    ann.say("all", "news for everyone").await;
    bob.wait("both messages", |s| (s.heard.len() == 2).then_some(())).await;
    let public = frame_messages_until(&mut spectator, "news for everyone").await;
    assert_eq!(texts(&public), ["news for everyone"], "a spectator sees public messages only");
    let all = frame_messages_until(&mut operator, "news for everyone").await;
    assert_eq!(texts(&all), ["psst, the yellow one is in RoomC1", "news for everyone"]);
    assert_eq!((all[0].from.as_str(), all[0].to.as_str()), ("Ann", "Bob"));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_match_without_tokens_is_open_to_watch_and_private_messages_follow_the_option() {
    for see_private in [false, true] {
        let (mut setup, mut config) = lockstep("fixed", 9, 2);
        config.mode = Mode::Realtime;
        setup.game.ticks_per_second = 100;
        config.spectators_see_private = see_private;
        let server = TestServer::start(setup, config).await;
        let addr = server.addr;
        // No operator token: nobody is the operator.
        assert_eq!(refusal(addr, hello(json!({"role": "operator", "token": "guess"}))).await, "bad_token");
        let (mut spectator, welcome) = welcomed(addr, hello(json!({"role": "spectator"}))).await;
        assert_eq!(welcome.private_messages, Some(see_private));
        let mut ann = AutoPlayer::join(addr, "Ann").await;
        let _bob = AutoPlayer::join(addr, "Bob").await;
        ann.say("Bob", "just for Bob").await;
        ann.say("all", "for all").await;
        let seen = frame_messages_until(&mut spectator, "for all").await;
        let expected: &[&str] = if see_private { &["just for Bob", "for all"] } else { &["for all"] };
        assert_eq!(texts(&seen), expected, "spectators_see_private: {see_private}");
        server.stop().await;
    }
}

#[test]
fn serve_refuses_shared_tokens_and_more_built_in_agents_than_players() {
    let cases: [(&[&str], &str); 2] = [
        (&["--token", "same", "--operator-token", "same"], "the player and operator tokens must differ"),
        (&["--builtin", "3", "--robots", "2"], "--robots counts every player"),
    ];
    for (args, message) in cases {
        let mut all = vec!["serve", "--port", "0", "--map", "fixed"];
        all.extend_from_slice(args);
        let out = bw4t_within(&all, Duration::from_secs(20));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(message), "{args:?}: {stderr}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_match_admits_at_most_its_players() {
    let (mut setup, mut config) = lockstep("fixed", 10, 2);
    config.mode = Mode::Realtime;
    setup.game.ticks_per_second = 100;
    config.grace = Duration::from_secs(600);
    let server = TestServer::start(setup, config).await;
    let addr = server.addr;
    let _ann = AutoPlayer::join(addr, "Ann").await;
    let bob = AutoPlayer::join(addr, "Bob").await;
    let session = bob.welcome.session.clone().expect("session");
    assert_eq!(refusal(addr, hello(json!({"name": "Cat"}))).await, "match_full");
    // A dropped player keeps its seat for the grace period, and takes it back.
    bob.disconnect().await;
    assert_eq!(refusal(addr, hello(json!({"name": "Cat"}))).await, "match_full");
    let (mut bob, welcome) = welcomed(addr, hello(json!({"session": session}))).await;
    assert_eq!((welcome.name.as_deref(), welcome.robot), (Some("Bob"), Some(1)));
    // A player who says bye frees the seat: the next joiner gets it (and the freed id).
    bob.send(json!({"type": "bye"})).await;
    bob.until(|m| matches!(m, ServerMessage::Bye(_)).then_some(())).await;
    let (_cat, welcome) = welcomed(addr, hello(json!({"name": "Cat"}))).await;
    assert_eq!((welcome.name.as_deref(), welcome.robot), (Some("Cat"), Some(1)));
    assert_eq!(refusal(addr, hello(json!({"name": "Dave"}))).await, "match_full");
    let result = server.stop().await;
    let names: Vec<(u32, &str, bool)> =
        result.per_robot.iter().map(|r| (r.id, r.name.as_str(), r.present)).collect();
    assert_eq!(names, [(0, "Ann", true), (1, "Cat", true)]);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn thousands_of_joins_and_leaves_leave_no_robots_behind() {
    const CYCLES: usize = 3000;
    let (mut setup, mut config) = lockstep("fixed", 11, 2);
    config.mode = Mode::Realtime;
    setup.game.ticks_per_second = 100;
    let replay = crate::util::SharedBuffer::default();
    let extras = bw4t_server::Extras {
        replay: Some(Box::new(replay.clone())),
        program: "test".into(),
        ..Default::default()
    };
    let server = TestServer::start_with(setup, config, extras).await;
    let mut ann = AutoPlayer::join(server.addr, "Ann").await;
    ann.act("goTo", json!(["RoomA1"])).await;
    for i in 0..CYCLES {
        let mut guest = Client::connect(server.addr).await;
        guest.send(hello(json!({"name": "Guest"}))).await;
        let robot = guest
            .until(|m| match m {
                ServerMessage::Welcome(w) => Some(w.robot),
                ServerMessage::Error(e) => panic!("guest {i} refused: {e:?}"),
                _ => None,
            })
            .await;
        assert_eq!(robot, Some(1), "guest {i} takes the one free seat");
        guest.send(json!({"type": "bye"})).await;
        guest.until(|m| matches!(m, ServerMessage::Bye(_)).then_some(())).await;
    }
    ann.wait_fact("in(RoomA1)").await;
    let result = server.stop().await;
    assert!(result.ticks > 0);
    let names: Vec<(u32, &str, bool)> =
        result.per_robot.iter().map(|r| (r.id, r.name.as_str(), r.present)).collect();
    assert_eq!(names, [(0, "Ann", true), (1, "Guest", false)], "one record per seat");
    assert_eq!(result.robots, 2);
    let text = replay.text();
    assert_eq!(text.matches("\"kind\":\"leave\"").count(), CYCLES, "every leave is recorded");
    let (verdict, summary) = bw4t_runner::verify_replay(&text).expect("a readable replay");
    assert!(matches!(verdict, bw4t_runner::Verdict::Matches { .. }), "{verdict:?}");
    assert_eq!(summary.game_ticks, result.ticks);
}

/// What a scripted player sends when it receives a `percepts`, before its `ready`.
type Step = Vec<Value>;

/// A player that plays `script` reacting only to `percepts`: on each it sends the next
/// step (an `act` or `say` each), then `ready`. Before every line it waits a random 0-3 ms
/// drawn from `seed`, to vary the network timing (never to wait for the server). Returns
/// every line received (random and wall-clock fields blanked) and the steps it played.
async fn scripted_player(
    addr: SocketAddr,
    name: &str,
    script: Vec<Step>,
    seed: u64,
) -> tokio::task::JoinHandle<(Vec<String>, usize)> {
    let (mut client, welcome) = welcomed(addr, hello(json!({"name": name}))).await;
    tokio::spawn(async move {
        let mut rng = SeededRng::new(seed);
        let mut stream = vec![blanked(&ServerMessage::Welcome(welcome))];
        let mut steps = script.into_iter();
        let mut played = 0;
        while let Some(message) = client.recv().await {
            stream.push(blanked(&message));
            let ServerMessage::Percepts(percepts) = message else { continue };
            let step = steps.next();
            played += usize::from(step.is_some());
            let ready = json!({"type": "ready", "tick": percepts.tick});
            for line in step.unwrap_or_default().into_iter().chain([ready]) {
                tokio::time::sleep(Duration::from_micros(rng.below(3000))).await;
                client.send(line).await;
            }
        }
        (stream, played)
    })
}

fn blanked(message: &ServerMessage) -> String {
    let mut value = serde_json::to_value(message).expect("json");
    for field in ["/session", "/result/wall_ms"] {
        if let Some(v) = value.pointer_mut(field) {
            *v = json!(0);
        }
    }
    value.to_string()
}

fn act(id: u64, action: &str, args: Value) -> Value {
    json!({"type": "act", "id": id, "action": action, "args": args})
}

fn say(to: &str, text: &str) -> Value {
    json!({"type": "say", "to": to, "text": text})
}

/// One lockstep match of two scripted players; their streams and the result's digest.
async fn scripted_match(seed: u64) -> ([(Vec<String>, usize); 2], String) {
    let (mut setup, mut config) = lockstep("fixed", 12, 2);
    config.deadline = None;
    setup.max_ticks = Some(300);
    let server = TestServer::start(setup, config).await;
    // Rejected actions, accepted ones, messages and a request refused at once.
    let ann: Vec<Step> = vec![
        vec![act(1, "goTo", json!(["Nowhere"]))],
        vec![say("Bob", "hi Bob")],
        vec![act(2, "pickUp", json!([]))],
        vec![say("all", "hello all"), act(3, "putDown", json!([]))],
        vec![act(4, "goTo", json!([]))],
        vec![act(5, "goTo", json!(["RoomC1"]))],
        vec![],
        vec![act(6, "goTo", json!(["RoomA1"])), say("Bob", "changed my mind")],
        vec![act(7, "sendMessage", json!(["Nobody", "hello?"]))],
        vec![act(8, "goTo", json!(["DropZone"]))],
    ];
    let bob: Vec<Step> = vec![
        vec![say("Ann", "hi Ann")],
        vec![act(1, "goToBlock", json!([11]))],
        vec![],
        vec![act(2, "goTo", json!(["RoomB2"])), act(3, "putDown", json!([]))],
        vec![say("all", "going to RoomB2")],
        vec![act(4, "pickUp", json!([99]))],
        vec![act(5, "goTo", json!(["RoomC1"]))],
    ];
    let (ann_len, bob_len) = (ann.len(), bob.len());
    let ann = scripted_player(server.addr, "Ann", ann, seed).await;
    let bob = scripted_player(server.addr, "Bob", bob, seed ^ 0x5eed).await;
    let result = server.finish().await;
    let streams = [ann.await.expect("Ann"), bob.await.expect("Bob")];
    assert_eq!((streams[0].1, streams[1].1), (ann_len, bob_len), "every step was answered by a percepts");
    (streams, result.digest)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_scripted_lockstep_match_is_the_same_whatever_the_network_timing() {
    let (first, digest) = scripted_match(1).await;
    for seed in [2, 3, 4] {
        let (again, again_digest) = scripted_match(seed).await;
        for (player, (a, b)) in ["Ann", "Bob"].iter().zip(first.iter().zip(&again)) {
            let differs = a.0.iter().zip(&b.0).position(|(x, y)| x != y);
            if let Some(i) = differs {
                panic!("{player}, delay seed {seed}: message {i} differs:\n {}\n {}", a.0[i], b.0[i]);
            }
            assert_eq!(a.0.len(), b.0.len(), "{player}, delay seed {seed}: stream lengths differ");
        }
        assert_eq!(again_digest, digest);
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn messages_of_the_language_arrive_as_sentence_and_structure_and_the_policy_refuses_the_rest() {
    let (mut setup, mut config) = lockstep("fixed", 9, 2);
    config.mode = Mode::Realtime;
    setup.game.ticks_per_second = 100;
    config.language =
        bw4t_protocol::MessagePolicy { kinds: Some(vec!["contains".into(), "yes".into()]), free_text: false };
    let server = TestServer::start(setup, config).await;
    let addr = server.addr;
    let (mut spectator, _) = welcomed(addr, hello(json!({"role": "spectator"}))).await;
    let (mut ann, welcome) = welcomed(addr, hello(json!({"name": "Ann"}))).await;
    assert_eq!(welcome.match_info.language.kinds, Some(vec!["contains".to_string(), "yes".to_string()]));
    assert!(!welcome.match_info.language.free_text);
    let (mut bob, _) = welcomed(addr, hello(json!({"name": "Bob"}))).await;
    let contains = json!({"kind": "contains", "room": "RoomA1", "colour": "Red"});
    ann.send(json!({"type": "say", "id": 1, "to": "all", "said": contains})).await;
    ann.send(json!({"type": "say", "id": 2, "to": "all", "text": "hello"})).await;
    ann.send(json!({"type": "say", "id": 3, "to": "all", "said": {"kind": "will_get", "colour": "Red"}}))
        .await;
    ann.send(json!({"type": "say", "id": 4, "to": "all", "said": {"kind": "contains", "room": "RoomA1"}}))
        .await;
    ann.send(json!({"type": "act", "id": 5, "action": "sendMessage", "args": ["Bob", {"kind": "yes"}]}))
        .await;
    let mut acks = std::collections::BTreeMap::new();
    while acks.len() < 5 {
        let (id, code) = ann
            .until(|m| match m {
                ServerMessage::Ack(a) => Some((a.id.clone(), a.code.map(|c| c.to_string()))),
                _ => None,
            })
            .await;
        acks.insert(serde_json::to_string(&id).expect("id"), code);
    }
    let code = |id: u64| acks[&id.to_string()].clone();
    assert_eq!(code(1), None);
    assert_eq!(code(2).as_deref(), Some("not_allowed"), "free text");
    assert_eq!(code(3).as_deref(), Some("not_allowed"), "a kind the match does not allow");
    assert_eq!(code(4).as_deref(), Some("bad_args"), "a message missing its colour");
    assert_eq!(code(5), None);
    // Bob sees each message as its sentence plus its structure.
    let mut heard = Vec::new();
    while heard.len() < 2 {
        let facts = bob
            .until(|m| match m {
                ServerMessage::Percepts(p) => Some(p.add.clone()),
                _ => None,
            })
            .await;
        heard.extend(facts.into_iter().filter(|f| f[0] == "message"));
    }
    assert_eq!(heard[0], vec![json!("message"), json!("Ann"), json!("RoomA1 contains Red."), contains]);
    assert_eq!(heard[1], vec![json!("message"), json!("Ann"), json!("Yes."), json!({"kind": "yes"})]);
    // Spectators see the sentence, and the structure beside it.
    let seen = frame_messages_until(&mut spectator, "RoomA1 contains Red.").await;
    let said = seen.iter().find_map(|m| m.said.clone()).expect("a structured message");
    assert_eq!(said.sentence().as_deref(), Ok("RoomA1 contains Red."));
    server.stop().await;
}
