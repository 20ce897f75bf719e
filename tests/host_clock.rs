//! The match host on a simulated clock, without sockets: the test owns time and each
//! client's queue, hands the host events and reads what it would send.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use bw4t_agents::{MatchSetup, Seat};
use bw4t_host::{ConnId, HostConfig, HostEvent, MatchHost, Transmit};
use bw4t_protocol::{Mode, ServerMessage, decode_client, decode_server};
use serde_json::{Value, json};

use crate::util::{lockstep, open_seats, shipped_map};

/// What one connection was sent.
#[derive(Default)]
struct Inbox {
    messages: Vec<ServerMessage>,
    /// How many lines each batch the host handed out for the connection held.
    batches: Vec<usize>,
    closed: bool,
    killed: bool,
}

/// A host, the simulated time and what each connection was sent.
struct Sim {
    host: MatchHost,
    start: Instant,
    now: Instant,
    inboxes: BTreeMap<ConnId, Inbox>,
    /// The room each client's queue has, which the test sets (the client reads every line
    /// at once, so the room stays as set).
    rooms: BTreeMap<ConnId, usize>,
}

const ROOMY: usize = 1024;

impl Sim {
    fn new((setup, config): (MatchSetup, HostConfig)) -> Sim {
        let start = Instant::now();
        let host = MatchHost::new(setup, config, None, start).expect("a valid match");
        Sim { host, start, now: start, inboxes: BTreeMap::new(), rooms: BTreeMap::new() }
    }

    /// The simulated time since the start.
    fn elapsed(&self) -> Duration {
        self.now - self.start
    }

    fn collect(&mut self) {
        while let Some(t) = self.host.poll_transmit() {
            match t {
                Transmit::Lines { conn, lines } => {
                    assert!(!lines.is_empty(), "an empty batch for {conn}");
                    let inbox = self.inboxes.entry(conn).or_default();
                    inbox.batches.push(lines.len());
                    for line in lines {
                        let message = decode_server(line.trim_end()).expect("the host sends valid lines");
                        assert!(!inbox.closed && !inbox.killed, "a line after close to {conn}: {line}");
                        inbox.messages.push(message);
                    }
                }
                Transmit::Close { conn } => self.inboxes.entry(conn).or_default().closed = true,
                Transmit::Kill { conn } => self.inboxes.entry(conn).or_default().killed = true,
            }
        }
    }

    /// Tells the host the room of every client's queue, as a driver does before it hands
    /// the host anything.
    fn report_rooms(&mut self) {
        for (&conn, &room) in &self.rooms {
            self.host.handle_event(self.now, HostEvent::Room { conn, room });
        }
    }

    fn event(&mut self, event: HostEvent) {
        self.report_rooms();
        self.host.handle_event(self.now, event);
        self.collect();
    }

    fn set_room(&mut self, conn: ConnId, room: usize) {
        self.rooms.insert(conn, room);
    }

    fn open(&mut self, conn: ConnId) {
        self.rooms.insert(conn, ROOMY);
        self.event(HostEvent::Opened { conn, room: ROOMY });
    }

    fn say(&mut self, conn: ConnId, message: Value) {
        let message = decode_client(&message.to_string()).expect("a valid client message");
        self.event(HostEvent::Message { conn, message });
    }

    /// Opens `conn` and says hello as player `name`.
    fn join(&mut self, conn: ConnId, name: &str) {
        self.open(conn);
        self.say(conn, json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": name}));
    }

    fn close(&mut self, conn: ConnId) {
        self.event(HostEvent::Closed { conn });
    }

    /// Moves the clock to `start + at`, handling every timeout that falls due on the way
    /// at its own time. Ticks run back to back count as at most `limit` timeouts.
    fn run_until(&mut self, at: Duration) {
        let target = self.start + at;
        for _ in 0..100_000 {
            match self.host.poll_timeout() {
                Some(t) if t <= target && !self.host.is_over() => {
                    self.now = self.now.max(t);
                    self.report_rooms();
                    self.host.handle_timeout(self.now);
                    self.collect();
                }
                _ => {
                    self.now = self.now.max(target);
                    return;
                }
            }
        }
        panic!("the host kept asking for timeouts before {at:?}");
    }

    fn messages(&self, conn: ConnId) -> &[ServerMessage] {
        self.inboxes.get(&conn).map_or(&[], |i| &i.messages)
    }

    fn percepts(&self, conn: ConnId) -> Vec<&bw4t_protocol::Percepts> {
        self.messages(conn)
            .iter()
            .filter_map(|m| if let ServerMessage::Percepts(p) = m { Some(p) } else { None })
            .collect()
    }

    fn last_percepts_tick(&self, conn: ConnId) -> Option<u64> {
        self.percepts(conn).last().map(|p| p.tick)
    }

    /// Answers the last `percepts` `conn` got with `ready`.
    fn ready(&mut self, conn: ConnId) {
        let tick = self.last_percepts_tick(conn).expect("percepts to answer");
        self.say(conn, json!({"type": "ready", "tick": tick}));
    }

    fn bye_reason(&self, conn: ConnId) -> Option<&str> {
        self.messages(conn)
            .iter()
            .rev()
            .find_map(|m| if let ServerMessage::Bye(b) = m { Some(b.reason.as_str()) } else { None })
    }

    fn finish(&mut self) -> bw4t_protocol::MatchResult {
        self.report_rooms();
        let result = self.host.finish(self.now);
        self.collect();
        result
    }
}

/// Lockstep with a 1 s deadline and percepts every tick, so a player that does not answer
/// paces the match at one tick per second of the simulated clock.
fn lockstep_config(robots: usize) -> (MatchSetup, HostConfig) {
    let (mut setup, mut config) = lockstep("fixed", 3, robots);
    config.deadline = Some(Duration::from_secs(1));
    config.every_tick = true;
    setup.max_ticks = Some(1000);
    (setup, config)
}

fn late_ticks(result: &bw4t_protocol::MatchResult, name: &str) -> u64 {
    result.per_robot.iter().find(|r| r.name == name).map(|r| r.late_ticks).expect("the robot's line")
}

#[test]
fn lockstep_waits_for_ready_until_the_deadline_and_counts_late_players() {
    let mut sim = Sim::new(lockstep_config(2));
    sim.join(1, "Ann");
    assert_eq!(sim.host.poll_timeout(), None, "nothing is due while a player is missing");
    sim.join(2, "Bob");
    // Both got their tick-0 snapshot and are awaited until the deadline.
    assert_eq!(sim.host.poll_timeout(), Some(sim.start + Duration::from_secs(1)));
    sim.ready(1);
    sim.run_until(Duration::from_millis(999));
    assert_eq!(sim.host.tick(), 0, "Bob is awaited until the deadline");
    sim.run_until(Duration::from_millis(1000));
    // Bob was late: tick 1 followed at once, and robots that were told nothing new are not
    // awaited, so the match runs on back to back.
    assert!(sim.host.tick() >= 1);
    let result = sim.finish();
    assert_eq!((late_ticks(&result, "Ann"), late_ticks(&result, "Bob")), (0, 1));
}

#[test]
fn what_a_tick_tells_each_player_leaves_as_one_batch() {
    let mut sim = Sim::new(lockstep_config(2));
    sim.join(1, "Ann");
    sim.join(2, "Bob");
    let mut before = BTreeMap::new();
    for conn in [1, 2] {
        sim.say(conn, json!({"type": "say", "id": 1, "to": "all", "text": "hello"}));
        sim.say(conn, json!({"type": "act", "id": 2, "action": "goTo", "args": ["RoomA1"]}));
        sim.ready(conn);
        before.insert(conn, (sim.inboxes[&conn].batches.len(), sim.messages(conn).len()));
    }
    sim.run_until(Duration::ZERO);
    assert_eq!(sim.host.tick(), 1);
    for conn in [1, 2] {
        let (batches, messages) = before[&conn];
        let told: Vec<&str> = sim.messages(conn)[messages..]
            .iter()
            .map(|m| match m {
                ServerMessage::Ack(_) => "ack",
                ServerMessage::Percepts(_) => "percepts",
                _ => "other",
            })
            .collect();
        assert_eq!(told, ["ack", "ack", "percepts"], "what {conn} was told at the tick");
        // Both acks and the percepts in one batch: one wake-up of the connection's writer.
        assert_eq!(sim.inboxes[&conn].batches[batches..], [3], "the batches {conn} got at the tick");
    }
}

#[test]
fn a_player_late_too_often_in_a_row_is_disconnected() {
    let (setup, mut config) = lockstep_config(1);
    config.max_late_in_row = Some(3);
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    // Ann never answers: each deadline counts her late once more.
    for late in 1..=3 {
        sim.run_until(Duration::from_secs(late));
        assert_eq!(sim.bye_reason(1).is_some(), late == 3, "after {late} deadlines");
    }
    assert_eq!(sim.bye_reason(1), Some("unresponsive"));
    assert!(sim.inboxes[&1].closed);
}

#[test]
fn a_dropped_player_keeps_its_seat_for_the_grace_period_and_can_take_it_back() {
    let (setup, mut config) = lockstep_config(2);
    config.grace = Duration::from_secs(30);
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    sim.join(2, "Bob");
    let session = sim
        .messages(2)
        .iter()
        .find_map(|m| if let ServerMessage::Welcome(w) = m { w.session.clone() } else { None })
        .expect("a session");
    sim.ready(1);
    sim.ready(2);
    sim.run_until(Duration::from_secs(5));
    sim.close(2);
    let dropped_at = sim.now;
    let dropped_tick = sim.host.tick();
    // The seat is kept: the grace period's end is the next thing due while nobody waits.
    assert!(sim.host.poll_timeout().is_some());
    sim.join(3, "Cy");
    assert!(
        sim.messages(3).iter().any(|m| matches!(m, ServerMessage::Error(e) if e.code == "match_full")),
        "Bob's seat is still his"
    );
    // Back within the grace period, with the session: the same robot.
    sim.run_until(Duration::from_secs(5) + Duration::from_secs(29));
    sim.open(4);
    sim.say(4, json!({"type": "hello", "protocol": "bw4t", "versions": [1], "session": session}));
    let welcome = sim
        .messages(4)
        .iter()
        .find_map(|m| if let ServerMessage::Welcome(w) = m { Some(w.clone()) } else { None });
    assert_eq!(welcome.and_then(|w| w.robot), Some(1), "Bob is back on robot 1");
    assert!(sim.now - dropped_at < Duration::from_secs(30));
    // The result says he was away once, for the ticks between his drop and his return.
    let away = sim.host.tick() - dropped_tick;
    assert!(away > 0, "the match went on without him");
    let result = sim.finish();
    let figures = |name: &str| {
        let robot = result.per_robot.iter().find(|r| r.name == name).expect("a robot");
        (robot.disconnections, robot.absent_ticks)
    };
    assert_eq!((figures("Bob"), figures("Ann")), ((1, away), (0, 0)));
}

#[test]
fn a_seat_is_freed_when_the_grace_period_ends() {
    let (setup, mut config) = lockstep_config(2);
    config.grace = Duration::from_secs(30);
    config.pause_when_empty = true;
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    sim.join(2, "Bob");
    sim.close(2);
    let dropped = sim.elapsed();
    sim.ready(1);
    sim.run_until(dropped + Duration::from_millis(29_999));
    sim.join(3, "Cy");
    assert!(sim.messages(3).iter().any(|m| matches!(m, ServerMessage::Error(e) if e.code == "match_full")));
    sim.run_until(dropped + Duration::from_secs(30));
    sim.join(4, "Dee");
    let robot =
        sim.messages(4).iter().find_map(|m| if let ServerMessage::Welcome(w) = m { w.robot } else { None });
    assert_eq!(robot, Some(1), "Dee takes the freed seat and its id");
    let result = sim.finish();
    assert!(
        result.per_robot.iter().any(|r| r.name == "Dee") && result.per_robot.iter().all(|r| r.name != "Bob")
    );
}

#[test]
fn a_client_that_does_not_read_gets_a_snapshot_later_or_is_disconnected() {
    let (setup, mut config) = lockstep_config(2);
    config.slow_limit = Duration::from_secs(5);
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    sim.join(2, "Bob");
    // Bob reads but never answers, so ticks come once a second. Ann's queue has less than
    // the reserve free: her percepts are held back and she is not awaited.
    sim.ready(1);
    sim.set_room(1, 10);
    sim.run_until(Duration::from_secs(3));
    assert_eq!(sim.host.tick(), 3);
    assert_eq!(sim.percepts(1).len(), 1, "only the joining snapshot");
    // Reading again within the slow limit: her next percepts are a full snapshot.
    sim.set_room(1, ROOMY);
    sim.run_until(Duration::from_secs(4));
    let latest = sim.percepts(1).last().copied().cloned().expect("percepts again");
    assert!(latest.full && latest.tick == 4, "{latest:?}");
    assert!(!latest.add.is_empty());
    // Not reading for longer than the slow limit (from the first tick held back, 5 s):
    // disconnected with too_slow.
    sim.set_room(1, 10);
    sim.run_until(Duration::from_secs(10));
    assert_eq!(sim.bye_reason(1), None, "5 s held back is within the limit");
    sim.run_until(Duration::from_secs(11));
    assert_eq!(sim.bye_reason(1), Some("too_slow"));
    assert!(sim.inboxes[&1].closed);
    // Ann was awaited only for the tick she was sent (tick 4), never while held back.
    let result = sim.finish();
    assert_eq!((late_ticks(&result, "Ann"), late_ticks(&result, "Bob")), (1, 11));
}

#[test]
fn a_client_whose_queue_is_full_is_killed_without_waiting() {
    let mut sim = Sim::new(lockstep_config(2));
    sim.join(1, "Ann");
    sim.set_room(1, 0);
    sim.join(2, "Bob");
    // Bob's hello makes the match start; Ann's queue has no room left even for replies.
    sim.say(1, json!({"type": "act", "id": 1, "action": "goTo", "args": ["RoomA1"]}));
    sim.ready(2);
    sim.run_until(Duration::from_secs(2));
    assert!(sim.inboxes[&1].killed, "killed, not left waiting");
    assert!(!sim.inboxes[&2].killed && !sim.inboxes[&2].closed);
}

#[test]
fn spectator_frames_are_throttled_to_their_rate_on_the_match_clock() {
    let (mut setup, mut config) = (MatchSetup::new(shipped_map("fixed")), HostConfig::new());
    config.mode = Mode::Realtime;
    setup.seats = open_seats(1);
    setup.game.ticks_per_second = 20;
    config.spectator_hz = 5;
    setup.seats[0] = Seat::builtin("Bot1", bw4t_agents::Strategy::Cooperative);
    let mut sim = Sim::new((setup, config));
    sim.open(9);
    sim.say(9, json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator"}));
    let frames = |sim: &Sim| sim.messages(9).iter().filter(|m| matches!(m, ServerMessage::Frame(_))).count();
    assert_eq!(frames(&sim), 1, "a frame at once on hello");
    sim.run_until(Duration::from_secs(2));
    // 20 ticks a second for 2 s, frames at most 5 a second: one every 4 ticks.
    assert_eq!(sim.host.tick(), 40);
    assert_eq!(frames(&sim), 1 + 10, "one frame per 200 ms");
}

#[test]
fn realtime_ticks_fall_on_the_period_and_missed_ones_are_skipped() {
    let (mut setup, mut config) = (MatchSetup::new(shipped_map("fixed")), HostConfig::new());
    config.mode = Mode::Realtime;
    setup.seats = open_seats(1);
    setup.game.ticks_per_second = 10;
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    assert_eq!(sim.host.poll_timeout(), Some(sim.start + Duration::from_millis(100)));
    sim.run_until(Duration::from_millis(350));
    assert_eq!(sim.host.tick(), 3);
    // The driver was away for a second: one tick then, and the next on the old grid.
    sim.now = sim.start + Duration::from_millis(1350);
    sim.host.handle_timeout(sim.now);
    assert_eq!(sim.host.tick(), 4);
    assert_eq!(sim.host.poll_timeout(), Some(sim.start + Duration::from_millis(1400)));
}

#[test]
fn the_start_timeout_starts_a_match_with_the_players_it_has() {
    let (setup, mut config) = lockstep_config(3);
    config.start_timeout = Some(Duration::from_secs(5));
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    assert_eq!(sim.host.poll_timeout(), Some(sim.start + Duration::from_secs(5)));
    sim.ready(1);
    sim.run_until(Duration::from_millis(4_999));
    assert_eq!(sim.host.tick(), 0);
    assert_eq!(sim.percepts(1).len(), 1, "only the joining snapshot while waiting");
    sim.run_until(Duration::from_secs(5));
    assert!(sim.host.tick() >= 1, "started at the timeout");
    let result = sim.finish();
    assert_eq!(result.wall_ms, 0, "wall_ms counts from the first tick, not from the wait");
}

#[test]
fn a_match_whose_reserved_players_will_not_come_starts_without_them() {
    let (mut setup, config) = lockstep_config(2);
    setup.seats[0] = Seat::remote("Agent1");
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    assert_eq!(sim.host.tick(), 0);
    sim.ready(1);
    sim.run_until(Duration::from_secs(1));
    assert_eq!(sim.host.tick(), 0, "waiting for Agent1");
    sim.event(HostEvent::SeatAbandoned { name: "Agent1".into() });
    sim.run_until(Duration::from_secs(1));
    assert!(sim.host.tick() >= 1);
}

#[test]
fn a_paused_match_makes_no_ticks_and_resumes_a_full_period_later() {
    let (mut setup, mut config) = (MatchSetup::new(shipped_map("fixed")), HostConfig::new());
    config.mode = Mode::Realtime;
    setup.seats = open_seats(1);
    setup.game.ticks_per_second = 10;
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    sim.run_until(Duration::from_millis(250));
    assert_eq!(sim.host.tick(), 2);
    sim.host.set_paused(sim.now, true);
    assert!(sim.host.status().paused);
    assert_eq!(sim.host.poll_timeout(), None, "nothing falls due while paused");
    sim.run_until(Duration::from_secs(60));
    assert_eq!(sim.host.tick(), 2, "a minute of pause, no ticks");
    sim.host.set_paused(sim.now, false);
    assert_eq!(sim.host.poll_timeout(), Some(sim.start + Duration::from_millis(60_100)));
    sim.run_until(Duration::from_millis(60_350));
    assert_eq!(sim.host.tick(), 5, "ticks on the period again, with none made up");
}

#[test]
fn a_player_that_asks_for_words_gets_its_situation_in_english_with_each_percepts() {
    let (mut setup, mut config) = (MatchSetup::new(shipped_map("fixed")), HostConfig::new());
    config.mode = Mode::Realtime;
    setup.seats = open_seats(2);
    let mut sim = Sim::new((setup, config));
    sim.open(1);
    sim.say(1, json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Ann", "words": true}));
    sim.join(2, "Bob");
    sim.say(1, json!({"type": "act", "id": 1, "action": "goTo", "args": ["RoomC1"]}));
    sim.run_until(Duration::from_secs(60));
    let ann = sim.percepts(1);
    // The first snapshot names where Ann stands, as its `at` fact does.
    let at = ann[0].add.iter().find(|f| f[0] == "at").map(|f| f[1].as_str().unwrap_or_default().to_string());
    let first = ann[0].words.as_deref().expect("words with the first percepts");
    assert!(
        first.starts_with(&format!("I am Ann (robot 0), at {}, not in a room.", at.expect("an at fact"))),
        "{first}"
    );
    assert!(ann.iter().all(|p| p.words.is_some()), "words with every percepts");
    let last = ann.last().and_then(|p| p.words.as_deref()).unwrap_or_default();
    assert!(
        last.starts_with("I am Ann (robot 0), in RoomC1. I hold nothing. I am standing still.\n"),
        "{last}"
    );
    assert!(last.contains("\nOther players: Bob.\n"), "{last}");
    let bob = sim.percepts(2);
    assert!(
        !bob.is_empty() && bob.iter().all(|p| p.words.is_none()),
        "no words for a player that did not ask"
    );
}

#[test]
fn the_last_report_of_each_player_is_in_the_result_even_after_it_left() {
    let (mut setup, mut config) = (MatchSetup::new(shipped_map("fixed")), HostConfig::new());
    config.mode = Mode::Realtime;
    setup.seats = open_seats(2);
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    sim.join(2, "Bob");
    sim.say(1, json!({"type": "report", "tool_calls": 1, "think_ms": 40}));
    sim.say(1, json!({"type": "report", "tool_calls": 2, "think_ms": 90, "think_ms_max": 50, "prompt_tokens": 700, "completion_tokens": 30}));
    sim.run_until(Duration::from_secs(1));
    sim.say(1, json!({"type": "bye"}));
    sim.run_until(Duration::from_secs(2));
    let result = sim.finish();
    let usage = |name: &str| result.per_robot.iter().find(|r| r.name == name).and_then(|r| r.usage);
    let ann = usage("Ann").expect("Ann's report");
    assert_eq!(
        (ann.tool_calls, ann.think_ms, ann.think_ms_max, ann.prompt_tokens, ann.completion_tokens),
        (2, 90, 50, 700, 30)
    );
    assert_eq!(usage("Bob"), None, "no report, no usage");
}

#[test]
fn a_spectator_sees_the_present_tick_within_one_frame_period_while_lockstep_waits() {
    let (setup, mut config) = lockstep_config(1);
    config.deadline = None;
    let mut sim = Sim::new((setup, config));
    sim.open(9);
    sim.say(9, json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator"}));
    sim.join(1, "Ann");
    // Ann answers five ticks at once, faster than frames may go out; then she thinks.
    for _ in 0..5 {
        sim.ready(1);
        sim.run_until(Duration::ZERO);
    }
    let tick = sim.host.tick();
    assert!(tick >= 5, "five ticks made, at {tick}");
    let last_frame = |sim: &Sim| {
        sim.messages(9)
            .iter()
            .rev()
            .find_map(|m| if let ServerMessage::Frame(f) = m { Some(f.tick) } else { None })
    };
    assert!(last_frame(&sim) < Some(tick), "the rate limit held frames back");
    // One frame period (20 a second: 50 ms) later the watcher has the present.
    sim.run_until(Duration::from_millis(50));
    assert_eq!(last_frame(&sim), Some(tick));
    // And nothing more is owed: the match waits without waking the host.
    assert_eq!(sim.host.poll_timeout(), None);
}

#[test]
fn a_player_on_a_recycled_robot_id_does_not_inherit_the_last_players_report() {
    let (mut setup, mut config) = (MatchSetup::new(shipped_map("fixed")), HostConfig::new());
    config.mode = Mode::Realtime;
    setup.seats = open_seats(1);
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    sim.say(1, json!({"type": "report", "tool_calls": 7, "prompt_tokens": 900}));
    sim.run_until(Duration::from_secs(1));
    sim.say(1, json!({"type": "bye"}));
    sim.run_until(Duration::from_secs(2));
    sim.join(2, "Cat");
    sim.run_until(Duration::from_secs(3));
    let result = sim.finish();
    let cat = result.per_robot.iter().find(|r| r.name == "Cat").expect("Cat's line");
    assert_eq!(cat.id, 0, "Cat plays the robot Ann left");
    assert_eq!(cat.usage, None, "Ann's report is not Cat's");
}

#[test]
fn a_player_who_leaves_before_the_start_frees_the_seat_at_once() {
    let (setup, config) = lockstep_config(2);
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    sim.close(1);
    // No time passes: the seat is free for the next two players, and they start the match.
    sim.join(2, "Bob");
    sim.join(3, "Cy");
    assert!(
        sim.messages(3).iter().any(|m| matches!(m, ServerMessage::Welcome(_))),
        "Cy is seated: {:?}",
        sim.messages(3)
    );
    assert!(sim.host.has_started(), "two players present start a match of two");
    let result = sim.finish();
    let names: Vec<&str> = result.per_robot.iter().map(|r| r.name.as_str()).collect();
    assert!(names.contains(&"Bob") && names.contains(&"Cy") && !names.contains(&"Ann"), "{names:?}");
}

#[test]
fn a_started_match_every_player_left_ends_as_abandoned_after_the_grace_period() {
    let (setup, mut config) = lockstep_config(2);
    config.grace = Duration::from_secs(30);
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    sim.join(2, "Bob");
    sim.ready(1);
    sim.ready(2);
    sim.run_until(Duration::from_secs(3));
    sim.close(1);
    sim.close(2);
    let left = sim.elapsed();
    sim.run_until(left + Duration::from_millis(29_999));
    assert!(!sim.host.is_over(), "the players may still come back");
    sim.run_until(left + Duration::from_secs(30));
    assert!(sim.host.is_over(), "nobody came back within the grace period");
    assert_eq!(sim.finish().end_reason, bw4t_protocol::EndReason::Abandoned);
}

#[test]
fn a_player_back_within_the_grace_period_keeps_a_match_going() {
    let (setup, mut config) = lockstep_config(1);
    config.grace = Duration::from_secs(30);
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    let session = sim
        .messages(1)
        .iter()
        .find_map(|m| if let ServerMessage::Welcome(w) = m { w.session.clone() } else { None })
        .expect("a session");
    sim.close(1);
    sim.run_until(Duration::from_secs(29));
    sim.open(2);
    sim.say(2, json!({"type": "hello", "protocol": "bw4t", "versions": [1], "session": session}));
    sim.run_until(Duration::from_secs(120));
    assert!(!sim.host.is_over(), "Ann came back: the match goes on");
}

#[test]
fn a_match_of_built_in_agents_only_is_never_abandoned() {
    let (mut setup, mut config) = lockstep_config(1);
    let player = bw4t_agents::Player::Builtin(bw4t_agents::Strategy::Cooperative);
    setup.seats = vec![Seat { name: "Bot1".into(), player }];
    config.mode = Mode::Realtime;
    config.grace = Duration::from_secs(1);
    let mut sim = Sim::new((setup, config));
    assert!(sim.host.has_started());
    sim.run_until(Duration::from_secs(5));
    assert!(!sim.host.is_over(), "nobody is missing from a match of built-in agents");
    assert!(sim.host.tick() > 0);
}

#[test]
fn resync_is_answered_at_most_once_a_tick_and_refused_with_rate_limited() {
    let (setup, config) = lockstep_config(1);
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    let full = |sim: &Sim| sim.percepts(1).iter().filter(|p| p.full).count();
    let before = full(&sim);
    sim.say(1, json!({"type": "resync"}));
    assert_eq!(full(&sim), before + 1, "the first resync gets a snapshot");
    // A flood at once: each is refused, and no snapshot is sent for it.
    for _ in 0..50 {
        sim.say(1, json!({"type": "resync"}));
    }
    assert_eq!(full(&sim), before + 1);
    let refusals = sim
        .messages(1)
        .iter()
        .filter(|m| matches!(m, ServerMessage::Error(e) if e.code == "rate_limited" && !e.fatal))
        .count();
    assert_eq!(refusals, 50);
    // Ann does not answer: the deadline moves the match to tick 1.
    sim.run_until(Duration::from_secs(1));
    assert!(sim.host.tick() >= 1);
    sim.say(1, json!({"type": "resync"}));
    assert_eq!(full(&sim), before + 2, "a resync at a later tick is answered again");
}

#[test]
fn a_match_of_programs_that_will_not_come_back_runs_on_when_they_leave() {
    let (setup, mut config) = lockstep_config(1);
    config.grace = Duration::from_secs(1);
    config.pause_when_empty = false;
    let mut sim = Sim::new((setup, config));
    sim.join(1, "Ann");
    sim.close(1);
    sim.run_until(Duration::from_secs(5));
    assert!(sim.host.tick() > 0);
    if sim.host.is_over() {
        assert_ne!(sim.finish().end_reason, bw4t_protocol::EndReason::Abandoned);
    }
}
