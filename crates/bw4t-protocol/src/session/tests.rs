//! The session driven by scripted server lines: what it sends, and what it tells the player.

use bw4t_sim::Action;

use super::*;

const WELCOME: &str = r#"{"type":"welcome","version":1,"name":"Ann","robot":0,"session":"s3cr3t","match":{"name":"team-a","map":"fixed","seed":1,"mode":"lockstep","tick_hz":20,"deadline_ms":0,"players_needed":1,"every_tick":false}}"#;
const SNAPSHOT: &str = r#"{"type":"percepts","tick":0,"add":[["ownName","Ann"],["at","DropZone"],["state","arrived"]],"not":[],"full":true}"#;

/// The lines the session has to send, without their newlines.
fn sent(session: &mut ClientSession) -> Vec<String> {
    std::iter::from_fn(|| session.poll_transmit()).map(|line| line.trim_end().to_string()).collect()
}

fn events(session: &mut ClientSession) -> Vec<SessionEvent> {
    std::iter::from_fn(|| session.poll_event()).collect()
}

fn feed(session: &mut ClientSession, line: &str) {
    session.handle_line(line).expect("a line the session reads");
}

/// Ann, welcomed into `team-a` and told her first snapshot, with nothing left to send.
fn playing() -> ClientSession {
    let mut session = ClientSession::new(SessionOptions::agent("Ann", None));
    feed(&mut session, WELCOME);
    feed(&mut session, SNAPSHOT);
    sent(&mut session);
    events(&mut session);
    session
}

#[test]
fn the_handshake_says_hello_from_the_options_and_reports_the_welcome_and_snapshot() {
    let options = SessionOptions {
        template: Some("ladder".into()),
        every_tick: true,
        seat: Some("s1".into()),
        ..SessionOptions::agent("Ann", Some("pw".into()))
    };
    let mut session = ClientSession::new(options);
    assert_eq!(
        sent(&mut session),
        [
            r#"{"type":"hello","protocol":"bw4t","versions":[1],"role":"agent","name":"Ann","token":"pw","every_tick":true,"template":"ladder","seat":"s1"}"#
        ]
    );
    feed(&mut session, r#"{"type":"lobby","template":"ladder","queued":2}"#);
    assert_eq!(session.queued(), Some(2));
    feed(&mut session, WELCOME);
    feed(&mut session, SNAPSHOT);
    let told = events(&mut session);
    assert!(matches!(&told[0], SessionEvent::Lobby(l) if l.queued == Some(2)), "{told:?}");
    assert!(matches!(&told[1], SessionEvent::Welcome(w) if w.robot == Some(0)), "{told:?}");
    let SessionEvent::Percepts { delta, words } = &told[2] else { panic!("percepts: {told:?}") };
    assert!(delta.full && delta.tick == 0 && delta.add.len() == 3 && words.is_none(), "{delta:?}");
    assert_eq!((session.queued(), session.tick(), session.lockstep()), (None, Some(0), true));
    assert_eq!(session.match_info().map(|m| m.name.as_str()), Some("team-a"));
    assert!(sent(&mut session).is_empty(), "nothing is sent until the player decides");
}

#[test]
fn ready_answers_each_percepts_once_after_the_decision_and_never_otherwise() {
    let mut session = ClientSession::new(SessionOptions::agent("Ann", None));
    sent(&mut session);
    session.ready();
    assert!(sent(&mut session).is_empty(), "told nothing yet");
    feed(&mut session, WELCOME);
    feed(&mut session, SNAPSHOT);
    let id = session.act(&Action::GoTo("RoomC1".into()));
    session.ready();
    session.ready();
    assert_eq!(
        sent(&mut session),
        [r#"{"type":"act","id":1,"action":"goTo","args":["RoomC1"]}"#, r#"{"type":"ready","tick":0}"#]
    );
    assert_eq!(id, 1);
    // An ack and a result tell the player something, but only a `percepts` is answered.
    feed(&mut session, r#"{"type":"ack","id":1,"ok":true,"tick":0}"#);
    session.ready();
    assert!(sent(&mut session).is_empty(), "an ack is not a tick to answer");
    feed(&mut session, r#"{"type":"percepts","tick":1,"add":[["state","traveling"]],"not":[]}"#);
    session.ready();
    assert_eq!(sent(&mut session), [r#"{"type":"ready","tick":1}"#]);
    // A resync's snapshot is answered again, even for a tick already answered.
    session.resync();
    assert_eq!(sent(&mut session), [r#"{"type":"resync"}"#]);
    feed(&mut session, &SNAPSHOT.replace(r#""tick":0"#, r#""tick":1"#));
    session.ready();
    assert_eq!(sent(&mut session), [r#"{"type":"ready","tick":1}"#]);
    // The last tick is not answered.
    feed(&mut session, r#"{"type":"percepts","tick":2,"add":[],"not":[]}"#);
    feed(
        &mut session,
        r#"{"type":"match_end","reason":"max_ticks","result":{"map":"fixed","seed":1,"robots":1,"completed":false,"end_reason":"max_ticks","ticks":2,"sim_seconds":0.1,"wall_ms":5,"sequence":["Red"],"sequence_index":0,"good_drops":0,"wrong_drops":0,"messages":0,"digest":"0","per_robot":[]}}"#,
    );
    session.ready();
    assert!(sent(&mut session).is_empty(), "no ready after match_end");
}

#[test]
fn realtime_percepts_are_never_answered() {
    let mut session = ClientSession::new(SessionOptions::agent("Ann", None));
    feed(&mut session, &WELCOME.replace("lockstep", "realtime"));
    feed(&mut session, SNAPSHOT);
    sent(&mut session);
    session.ready();
    assert!(sent(&mut session).is_empty());
}

#[test]
fn acks_and_results_come_with_the_request_they_answer_in_any_order() {
    let mut session = playing();
    let first = session.act(&Action::GoTo("RoomA1".into()));
    let said = session.say("all", Some("hi".into()), None);
    let second = session.act_named("goToBlock", vec![serde_json::json!(7)]);
    let refused = session.act(&Action::PutDown);
    assert_eq!((first, said, second, refused), (1, 2, 3, 4));
    assert_eq!(sent(&mut session)[1], r#"{"type":"say","id":2,"to":"all","text":"hi"}"#);
    for line in [
        r#"{"type":"ack","id":1,"ok":true,"tick":0}"#,
        r#"{"type":"ack","id":2,"ok":true,"tick":0}"#,
        r#"{"type":"ack","id":3,"ok":true,"tick":0}"#,
        r#"{"type":"ack","id":4,"ok":false,"tick":0,"code":"not_holding"}"#,
        // The newer order's result first, then the superseded one's.
        r#"{"type":"result","id":3,"outcome":"arrived","tick":9}"#,
        r#"{"type":"result","id":1,"outcome":"superseded","tick":1}"#,
        r#"{"type":"result","id":99,"outcome":"arrived","tick":9}"#,
    ] {
        feed(&mut session, line);
    }
    let answered: Vec<(&str, Option<u64>)> = events(&mut session)
        .iter()
        .map(|event| match event {
            SessionEvent::Ack { ack, request } => {
                (if ack.ok { "ack" } else { "refused" }, request.as_ref().map(|r| r.id))
            }
            SessionEvent::Result { result, request } => {
                (result.outcome.as_str(), request.as_ref().map(|r| r.id))
            }
            other => panic!("unexpected {other:?}"),
        })
        .collect();
    assert_eq!(
        answered,
        [
            ("ack", Some(1)),
            ("ack", Some(2)),
            ("ack", Some(3)),
            ("refused", Some(4)),
            ("arrived", Some(3)),
            ("superseded", Some(1)),
            ("arrived", None)
        ]
    );
    assert_eq!(session.in_flight().count(), 0, "every request has had its last answer");
}

#[test]
fn an_accepted_order_stays_in_flight_until_its_result() {
    let mut session = playing();
    let go = session.act(&Action::GoTo("RoomA1".into()));
    let pick = session.act(&Action::PickUp(None));
    feed(&mut session, r#"{"type":"ack","id":1,"ok":true,"tick":0}"#);
    feed(&mut session, r#"{"type":"ack","id":2,"ok":true,"tick":0}"#);
    let waiting: Vec<u64> = session.in_flight().map(|r| r.id).collect();
    assert_eq!(waiting, [go]);
    let told = events(&mut session);
    let SessionEvent::Ack { request: Some(request), .. } = &told[1] else { panic!("{told:?}") };
    assert_eq!(request.id, pick);
    assert!(matches!(&request.message, ClientMessage::Act(act) if act.action == "pickUp"));
}

#[test]
fn a_reconnect_presents_the_same_session_and_match_and_forgets_what_was_in_flight() {
    let options = SessionOptions { template: Some("ladder".into()), ..SessionOptions::agent("Ann", None) };
    let mut session = ClientSession::new(options);
    sent(&mut session);
    session.reconnect();
    assert_eq!(
        sent(&mut session),
        [
            r#"{"type":"hello","protocol":"bw4t","versions":[1],"role":"agent","name":"Ann","template":"ladder"}"#
        ],
        "not yet welcomed: the same hello again"
    );
    feed(&mut session, WELCOME);
    feed(&mut session, SNAPSHOT);
    session.act(&Action::GoTo("RoomA1".into()));
    session.reconnect();
    let resume = r#"{"type":"hello","protocol":"bw4t","versions":[1],"role":"agent","name":"Ann","session":"s3cr3t","match":"team-a"}"#;
    assert_eq!(sent(&mut session), [resume], "the act queued on the old connection is dropped");
    assert_eq!(session.in_flight().count(), 0);
    session.ready();
    assert!(sent(&mut session).is_empty(), "the old connection's tick is not owed");
    feed(&mut session, WELCOME);
    feed(&mut session, &SNAPSHOT.replace(r#""tick":0"#, r#""tick":5"#));
    // Ids go on, so a late answer on the old connection cannot be mistaken for a new one.
    assert_eq!(session.act(&Action::PutDown), 2);
    session.ready();
    assert_eq!(sent(&mut session)[1], r#"{"type":"ready","tick":5}"#);
    // A session refused (its grace period over) comes back with the same session again.
    feed(
        &mut session,
        r#"{"type":"error","code":"replaced","message":"another connection took the robot","fatal":true}"#,
    );
    session.reconnect();
    assert_eq!(sent(&mut session), [resume]);
}

#[test]
fn a_fatal_error_or_bye_ends_what_is_sent() {
    let mut session = ClientSession::new(SessionOptions::agent("Ann", None));
    sent(&mut session);
    feed(
        &mut session,
        r#"{"type":"error","code":"name_taken","message":"the name Ann is taken","fatal":true}"#,
    );
    feed(&mut session, r#"{"type":"bye","reason":"name_taken"}"#);
    assert!(matches!(session.closed(), Some(Closed::Refused(e)) if e.code.as_str() == "name_taken"));
    session.act(&Action::PutDown);
    assert!(sent(&mut session).is_empty());
    assert_eq!(session.in_flight().count(), 0);

    let mut session = playing();
    session.bye();
    session.report(PlayerUsage::default());
    assert_eq!(sent(&mut session), [r#"{"type":"bye"}"#]);
    assert_eq!(session.closed(), Some(&Closed::Left));
}

#[test]
fn malformed_lines_are_errors_that_name_the_problem_and_the_line() {
    let mut session = playing();
    session.ready();
    assert_eq!(sent(&mut session), [r#"{"type":"ready","tick":0}"#]);
    let error =
        |session: &mut ClientSession, line: &str| session.handle_line(line).expect_err(line).to_string();
    let not_json = error(&mut session, "{oops");
    assert!(
        not_json.starts_with("the server sent a line that is not a message (bad_json: not JSON"),
        "{not_json}"
    );
    assert!(not_json.ends_with(": {oops"), "{not_json}");
    let unknown = error(&mut session, r#"{"type":"dance"}"#);
    assert!(unknown.contains("(unknown_type: unknown message type 'dance')"), "{unknown}");
    let wrong = error(&mut session, r#"{"type":"ack","ok":"yes","tick":0}"#);
    assert!(wrong.contains("bad_message: bad 'ack' message"), "{wrong}");
    let long = error(&mut session, &format!("{{{}", "x".repeat(1000)));
    assert!(long.len() < 400, "a long line is quoted shortened: {long}");
    let facts = error(&mut session, r#"{"type":"percepts","tick":3,"add":[["fly","high"]],"not":[]}"#);
    assert_eq!(facts, r#"the server sent percepts this client cannot read: not a percept: ["fly","high"]"#);
    assert!(events(&mut session).is_empty(), "nothing of a bad line reaches the player");
    session.ready();
    assert!(sent(&mut session).is_empty(), "a bad percepts is not owed a ready");
}

#[test]
fn an_adopted_connection_says_no_hello_and_plays_on() {
    let Ok(ServerMessage::Welcome(welcome)) = decode_server(WELCOME) else { panic!("a welcome") };
    let mut session = ClientSession::adopt(welcome);
    assert!(sent(&mut session).is_empty());
    feed(&mut session, SNAPSHOT);
    session.ready();
    assert_eq!(sent(&mut session), [r#"{"type":"ready","tick":0}"#]);
    session.reconnect();
    assert!(sent(&mut session)[0].contains(r#""session":"s3cr3t","match":"team-a""#));
}

#[test]
fn options_read_the_hello_fields_a_player_chooses() {
    let options: SessionOptions =
        serde_json::from_value(serde_json::json!({"name": "Bob", "match": "demo", "every_tick": true}))
            .expect("options");
    assert_eq!(options.match_name.as_deref(), Some("demo"));
    let refused =
        serde_json::from_value::<SessionOptions>(serde_json::json!({"name": "Bob", "role": "spectator"}));
    assert!(refused.is_err(), "a field the session owns is not an option");
}
