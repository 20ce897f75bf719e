//! The robot's rules, driven by hand-written server lines: what it sends, when it answers
//! a tick, and how each kind of tool call ends.

use std::time::Duration;

use bw4t_protocol::SessionOptions;

use super::{Busy, Command, Outcome, Robot};

/// The tool timeout the robot is given unless a test says otherwise.
const T: Duration = Duration::from_secs(120);

fn feed(robot: &mut Robot, line: &str) {
    robot.handle_line(line);
}

fn sent(robot: &mut Robot) -> Vec<String> {
    std::iter::from_fn(|| robot.poll_transmit()).map(|line| line.trim_end().to_string()).collect()
}

/// A robot whose `hello` (asking for every tick) is sent.
fn new_robot() -> Robot {
    let mut robot = Robot::new(SessionOptions::agent("Ann", None));
    assert_eq!(
        sent(&mut robot),
        [
            r#"{"type":"hello","protocol":"bw4t","versions":[1],"role":"agent","name":"Ann","every_tick":true}"#
        ]
    );
    robot
}

const WELCOME: &str = r#"{"type":"welcome","version":1,"name":"Ann","robot":0,"session":"s","match":{"name":"default","map":"fixed","seed":1,"mode":"lockstep","tick_hz":20,"deadline_ms":0,"players_needed":1,"max_ticks":2000,"every_tick":true}}"#;
const SNAPSHOT: &str = r#"{"type":"percepts","tick":0,"add":[["place","RoomA1"],["place","DropZone"],["ownName","Ann"],["bot",0],["sequence",["Red"]],["at","DropZone"],["in","DropZone"],["sequenceIndex",0],["state","arrived"]],"not":[],"full":true}"#;

fn playing() -> Robot {
    let mut robot = new_robot();
    feed(&mut robot, WELCOME);
    feed(&mut robot, SNAPSHOT);
    assert!(sent(&mut robot).is_empty(), "nothing is answered before a tool call");
    robot
}

fn tick(robot: &mut Robot, tick: u64, add: &str, not: &str) {
    feed(robot, &format!(r#"{{"type":"percepts","tick":{tick},"add":[{add}],"not":[{not}]}}"#));
}

#[test]
fn a_journey_answers_every_tick_until_it_ends_and_then_holds_the_tick() {
    let mut robot = playing();
    robot.start(Command::GoTo("RoomA1".into()), T).expect("idle");
    assert_eq!(
        sent(&mut robot),
        [r#"{"type":"act","id":1,"action":"goTo","args":["RoomA1"]}"#, r#"{"type":"ready","tick":0}"#]
    );
    feed(&mut robot, r#"{"type":"ack","id":1,"ok":true,"tick":0}"#);
    tick(&mut robot, 1, r#"["state","traveling"]"#, "");
    assert_eq!(sent(&mut robot), [r#"{"type":"ready","tick":1}"#]);
    assert_eq!(robot.busy(), Some("go_to"));
    feed(&mut robot, r#"{"type":"result","id":1,"outcome":"arrived","tick":40}"#);
    assert!(robot.poll_report().is_none(), "the report waits for the tick's percepts");
    tick(
        &mut robot,
        40,
        r#"["at","RoomA1"],["in","RoomA1"],["state","arrived"],["color",7,"Red"],["block",7]"#,
        "",
    );
    let report = robot.poll_report().expect("a report");
    assert_eq!((report.outcome, report.started, report.tick), (Outcome::Arrived, 0, 40));
    assert!(report.changes.iter().any(|line| line.contains("RoomA1")), "{:?}", report.changes);
    assert!(report.changes.iter().any(|line| line.contains("block 7 (Red)")), "{:?}", report.changes);
    assert!(sent(&mut robot).is_empty(), "tick 40 is held while the driver thinks");
    robot.start(Command::PickUp(Some(7)), T).expect("idle again");
    assert_eq!(
        sent(&mut robot),
        [r#"{"type":"act","id":2,"action":"pickUp","args":[7]}"#, r#"{"type":"ready","tick":40}"#]
    );
}

#[test]
fn a_refused_action_is_rejected_with_the_code_and_the_reason() {
    let mut robot = playing();
    robot.start(Command::PickUp(None), T).expect("idle");
    sent(&mut robot);
    feed(
        &mut robot,
        r#"{"type":"ack","id":1,"ok":false,"tick":0,"code":"not_at_block","reason":"not at a block"}"#,
    );
    tick(&mut robot, 1, "", "");
    let report = robot.poll_report().expect("a report");
    assert_eq!(
        (report.outcome, report.reason.as_deref()),
        (Outcome::Rejected, Some("not_at_block: not at a block"))
    );
}

#[test]
fn a_second_call_while_one_runs_is_refused() {
    let mut robot = playing();
    robot.start(Command::Wait { ticks: None, seconds: None }, T).expect("idle");
    assert_eq!(robot.start(Command::PutDown, T), Err(Busy::InProgress("wait")));
}

#[test]
fn wait_ends_on_a_change_or_when_its_ticks_run_out() {
    let mut robot = playing();
    robot.start(Command::Wait { ticks: None, seconds: None }, T).expect("idle");
    tick(&mut robot, 1, "", "");
    tick(&mut robot, 2, "", "");
    assert!(robot.poll_report().is_none(), "empty ticks are no change");
    tick(&mut robot, 3, r#"["message","Bob","{\"kind\":\"have\",\"colour\":\"Red\"}"]"#, "");
    let report = robot.poll_report().expect("a report");
    assert_eq!((report.outcome, report.tick), (Outcome::Changed, 3));
    assert!(report.changes.iter().any(|l| l.contains("I have Red.")), "{:?}", report.changes);

    robot.start(Command::Wait { ticks: Some(2), seconds: None }, T).expect("idle");
    tick(&mut robot, 4, "", "");
    assert!(robot.poll_report().is_none());
    tick(&mut robot, 5, "", "");
    assert_eq!(robot.poll_report().map(|r| r.outcome), Some(Outcome::Timeout));
}

#[test]
fn a_call_before_the_start_waits_for_it_and_one_out_of_time_says_so() {
    let mut robot = new_robot();
    feed(&mut robot, WELCOME);
    robot.start(Command::GoTo("RoomA1".into()), T).expect("held");
    assert!(sent(&mut robot).is_empty(), "nothing to send before the first percepts");
    feed(&mut robot, SNAPSHOT);
    assert_eq!(sent(&mut robot).len(), 2, "act and ready once the match starts");
    robot.expire();
    let report = robot.poll_report().expect("a report");
    assert_eq!(report.outcome, Outcome::Timeout);
    assert!(report.reason.as_deref().is_some_and(|r| r.contains("still on its way")), "{report:?}");
}

#[test]
fn the_match_end_ends_the_call_in_progress_and_every_later_one() {
    let mut robot = playing();
    robot.start(Command::Wait { ticks: None, seconds: None }, T).expect("idle");
    assert_eq!(sent(&mut robot), [r#"{"type":"ready","tick":0}"#]);
    feed(&mut robot, r#"{"type":"bye","reason":"match_over"}"#);
    assert_eq!(robot.poll_report().map(|r| r.outcome), Some(Outcome::MatchOver));
    robot.start(Command::PutDown, T).expect("answered at once");
    let report = robot.poll_report().expect("a report");
    assert_eq!(report.outcome, Outcome::MatchOver);
    assert!(sent(&mut robot).is_empty(), "nothing is sent into an ended match");
    assert!(robot.ended().is_some());
}

#[test]
fn realtime_matches_are_never_answered_with_ready() {
    let mut robot = new_robot();
    feed(&mut robot, &WELCOME.replace("lockstep", "realtime"));
    feed(&mut robot, SNAPSHOT);
    robot.start(Command::GoTo("RoomA1".into()), T).expect("idle");
    assert_eq!(sent(&mut robot), [r#"{"type":"act","id":1,"action":"goTo","args":["RoomA1"]}"#]);
}

/// Ticks `from..=to` with nothing new, answered as the robot answers them.
fn empty_ticks(robot: &mut Robot, from: u64, to: u64) {
    for t in from..=to {
        tick(robot, t, "", "");
    }
}

#[test]
fn in_lockstep_wait_seconds_are_simulated_seconds_and_no_call_outlasts_its_timeout_in_ticks() {
    let mut robot = playing();
    let wall = robot.start(Command::Wait { ticks: None, seconds: Some(5.0) }, T).expect("idle");
    assert_eq!(wall, T, "the wall clock only guards against a stalled match");
    empty_ticks(&mut robot, 1, 99);
    assert!(robot.poll_report().is_none(), "5 s at 20 ticks a second are 100 ticks");
    assert_eq!(sent(&mut robot).last().map(String::as_str), Some(r#"{"type":"ready","tick":99}"#));
    tick(&mut robot, 100, "", "");
    let report = robot.poll_report().expect("a report");
    assert_eq!((report.outcome, report.started, report.tick), (Outcome::Timeout, 0, 100));
    assert!(sent(&mut robot).is_empty(), "tick 100 is held for the next call");

    // Ticks given are capped by the seconds, and a call of any kind by its timeout.
    robot.start(Command::Wait { ticks: Some(1000), seconds: Some(0.5) }, T).expect("idle");
    empty_ticks(&mut robot, 101, 110);
    assert_eq!(robot.poll_report().map(|r| (r.outcome, r.tick)), Some((Outcome::Timeout, 110)));
    robot.start(Command::GoTo("RoomA1".into()), Duration::from_secs(1)).expect("idle");
    feed(&mut robot, r#"{"type":"ack","id":1,"ok":true,"tick":110}"#);
    empty_ticks(&mut robot, 111, 129);
    assert!(robot.poll_report().is_none());
    tick(&mut robot, 130, "", "");
    let report = robot.poll_report().expect("a report");
    assert_eq!((report.outcome, report.tick), (Outcome::Timeout, 130));
    assert!(report.reason.as_deref().is_some_and(|r| r.contains("still on its way")), "{report:?}");
}

#[test]
fn in_realtime_wait_seconds_are_wall_time() {
    let mut robot = new_robot();
    feed(&mut robot, &WELCOME.replace("lockstep", "realtime"));
    feed(&mut robot, SNAPSHOT);
    let wall = robot.start(Command::Wait { ticks: None, seconds: Some(5.0) }, T).expect("idle");
    assert_eq!(wall, Duration::from_secs(5));
    empty_ticks(&mut robot, 1, 500);
    assert!(robot.poll_report().is_none(), "only the clock ends it");
    robot.expire();
    assert_eq!(robot.poll_report().map(|r| r.outcome), Some(Outcome::Timeout));
}

#[test]
fn an_error_without_an_id_ends_the_unanswered_call_whose_line_it_dropped() {
    let mut robot = playing();
    robot.start(Command::Say { to: "all".into(), said: None, text: Some("hello".into()) }, T).expect("idle");
    sent(&mut robot);
    feed(
        &mut robot,
        r#"{"type":"error","code":"line_too_long","message":"line longer than 65536 bytes; skipped up to its newline","fatal":false}"#,
    );
    tick(&mut robot, 1, "", "");
    let report = robot.poll_report().expect("the call ends");
    assert_eq!(report.outcome, Outcome::Rejected);
    assert!(report.reason.as_deref().is_some_and(|r| r.starts_with("line_too_long: ")), "{report:?}");

    // An acknowledged journey is not the line an error is about.
    robot.start(Command::GoTo("RoomA1".into()), T).expect("idle");
    feed(&mut robot, r#"{"type":"ack","id":2,"ok":true,"tick":1}"#);
    feed(&mut robot, r#"{"type":"error","code":"bad_json","message":"not JSON","fatal":false}"#);
    tick(&mut robot, 2, "", "");
    assert!(robot.poll_report().is_none());
    assert_eq!(robot.busy(), Some("go_to"));
}

#[test]
fn a_cancelled_call_frees_the_robot_at_once() {
    let mut robot = playing();
    robot.start(Command::GoTo("RoomA1".into()), T).expect("idle");
    sent(&mut robot);
    robot.cancel();
    let report = robot.poll_report().expect("a report");
    assert_eq!(report.outcome, Outcome::Cancelled);
    assert_eq!(robot.busy(), None);
    robot.start(Command::PutDown, T).expect("the robot takes the next order");
    assert_eq!(sent(&mut robot), [r#"{"type":"act","id":2,"action":"putDown","args":[]}"#]);
}
