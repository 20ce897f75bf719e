//! The built-in team in the shared message language: everything it says is a message of
//! the language, the silent variant says nothing and still completes, and a player who
//! talks to the team (a person, here a script) is answered and followed.

use std::sync::{Arc, Mutex};

use bw4t_agents::{Agent, MatchSetup, Observation, Seat, Strategy, WORD_CLAIM_LAPSE_TICKS};
use bw4t_map::{Colour, Map};
use bw4t_protocol::{EndReason, Knowledge, Said};
use bw4t_runner::play_headless;
use bw4t_sim::{Action, Receiver};

use crate::util::shipped_map;

/// Every match of these tests must end within this many ticks.
const TICK_LIMIT: u64 = 20_000;

/// A message one player sent: tick, sender, receiver, what.
#[derive(Clone, Debug)]
struct Sent {
    tick: u64,
    from: String,
    to: Receiver,
    said: Said,
}

/// What the spies saw: every message sent, and free text (which the team must not send).
#[derive(Default)]
pub(crate) struct Record {
    sent: Vec<Sent>,
    pub(crate) not_language: Vec<String>,
    /// Claims outside `[index, index + team)`, described.
    pub(crate) outside_window: Vec<String>,
    /// (tick, loser, position): a robot lost a position it claimed in the same tick as a
    /// player with a smaller name, while holding a block.
    pub(crate) lost_while_holding: Vec<(u64, String, usize)>,
}

/// The position a message claims (`getting_for`, `bringing`).
pub(crate) fn claimed(said: &Said) -> Option<usize> {
    ["getting_for", "bringing"].contains(&said.kind.as_str()).then_some(said.position? as usize)
}

type Shared = Arc<Mutex<Record>>;

/// A built-in agent watched from outside: it sees the same observations and actions.
struct Spy {
    name: String,
    inner: Box<dyn Agent>,
    knowledge: Knowledge,
    /// The tick of the last decision and the positions it claimed.
    last_claims: (u64, Vec<usize>),
    record: Shared,
}

impl Agent for Spy {
    fn decide(&mut self, obs: &Observation) -> Vec<Action> {
        let mut heard = Vec::new();
        for delta in &obs.percepts {
            self.knowledge.apply(delta.tick, delta);
            heard.extend_from_slice(self.knowledge.latest_messages());
        }
        let holding = self.knowledge.holding().is_some();
        let index = self.knowledge.sequence_index() as usize;
        let team = 1 + self.knowledge.players().count();
        let mut record = self.record.lock().expect("record");
        for message in heard {
            let Some(pos) = message.said().and_then(claimed) else { continue };
            let same_tick = self.last_claims.0 + 1 == obs.tick && self.last_claims.1.contains(&pos);
            if same_tick && holding && *message.from < *self.name {
                record.lost_while_holding.push((obs.tick, self.name.clone(), pos));
            }
        }
        let actions = self.inner.decide(obs);
        let mut claims = Vec::new();
        for action in &actions {
            let Action::SendMessage { to, text } = action else { continue };
            match Said::from_text(text) {
                Some(said) if said.sentence().is_ok() => {
                    if let Some(pos) = claimed(&said) {
                        claims.push(pos);
                        if !(index..index + team).contains(&pos) {
                            record.outside_window.push(format!(
                                "{} at tick {} claimed {pos} with index {index} and {team} players",
                                self.name, obs.tick
                            ));
                        }
                    }
                    record.sent.push(Sent { tick: obs.tick, from: self.name.clone(), to: to.clone(), said });
                }
                _ => record.not_language.push(format!("{}: {text}", self.name)),
            }
        }
        self.last_claims = (obs.tick, claims);
        actions
    }

    fn wake_at(&self) -> Option<u64> {
        self.inner.wake_at()
    }
}

fn spy(name: &str, strategy: Strategy, record: &Shared) -> Seat {
    let record = record.clone();
    let make = move |name: &str| -> Box<dyn Agent> {
        Box::new(Spy {
            name: name.into(),
            inner: strategy.agent(name),
            knowledge: Knowledge::new(),
            last_claims: (u64::MAX - 1, Vec::new()),
            record: record.clone(),
        })
    };
    Seat::agent(name, Arc::new(make))
}

fn play(map: &Map, seed: u64, seats: Vec<Seat>) -> (EndReason, u64) {
    let setup = MatchSetup { seed, seats, max_ticks: Some(TICK_LIMIT), ..MatchSetup::new(map.clone()) };
    let (game, reason) = play_headless(&setup, None).expect("play");
    (reason, game.tick())
}

/// A team of `robots` of `strategy`, watched.
pub(crate) fn play_team(map: &Map, seed: u64, robots: usize, strategy: Strategy) -> (EndReason, u64, Record) {
    let record = Shared::default();
    let seats = (1..=robots).map(|i| spy(&format!("Bot{i}"), strategy, &record)).collect();
    let (reason, ticks) = play(map, seed, seats);
    let record = Arc::try_unwrap(record).map_err(|_| "spies still held").expect("record");
    (reason, ticks, record.into_inner().expect("record"))
}

/// A generated grid of `rows` x `cols` rooms with random content drawn from the seed.
pub(crate) fn random_grid(rows: usize, cols: usize) -> Map {
    let generated = bw4t_map::generate(cols, rows, 10, 7).expect("generate");
    let mut parts = generated.parts().clone();
    for zone in &mut parts.zones {
        zone.blocks.clear();
    }
    parts.sequence.clear();
    parts.random_sequence = 6;
    parts.random_blocks = 30;
    parts.seed = None;
    Map::new(parts).expect("a valid map")
}

fn maps() -> Vec<(&'static str, Map)> {
    vec![
        ("default", shipped_map("default")),
        ("side-doors", shipped_map("side-doors")),
        ("rooms12", shipped_map("rooms12")),
        ("2x3 grid", random_grid(2, 3)),
    ]
}

/// Every message the cooperative and ignoring teams send is a message of the language with
/// a sentence; they claim only within the window; every match completes.
#[test]
fn the_team_speaks_only_the_language_and_completes() {
    let mut failures = Vec::new();
    let mut kinds = std::collections::BTreeSet::new();
    for strategy in [Strategy::Cooperative, Strategy::Ignoring] {
        for (map_name, map) in &maps() {
            for robots in (1..=5).filter(|&n| n <= map.spawns().len()) {
                for seed in 0..3 {
                    let (reason, ticks, record) = play_team(map, seed, robots, strategy);
                    let what = format!("{} team of {robots} on {map_name}, seed {seed}", strategy.name());
                    if reason != "completed" {
                        failures.push(format!("{what}: {reason} after {ticks} ticks"));
                    }
                    if !record.not_language.is_empty() || !record.outside_window.is_empty() {
                        failures
                            .push(format!("{what}: {:?} {:?}", record.not_language, record.outside_window));
                    }
                    if record.sent.is_empty() {
                        failures.push(format!("{what}: said nothing"));
                    }
                    kinds.extend(record.sent.iter().map(|s| s.said.kind.clone()));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let expected = ["going_to", "contains_many", "empty", "getting_for", "dropped"];
    for kind in expected {
        assert!(kinds.contains(kind), "nobody said {kind}: {kinds:?}");
    }
}

/// The silent team sends no message at all and still completes every match.
#[test]
fn the_silent_team_says_nothing_and_completes() {
    let mut failures = Vec::new();
    for (map_name, map) in &maps() {
        for robots in (1..=5).filter(|&n| n <= map.spawns().len()) {
            for seed in 0..3 {
                let (reason, ticks, record) = play_team(map, seed, robots, Strategy::Silent);
                let sent = record.sent.len() + record.not_language.len();
                if reason != "completed" || sent > 0 {
                    failures.push(format!(
                        "silent team of {robots} on {map_name}, seed {seed}: {reason} after {ticks} ticks, {sent} messages"
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// What a talker heard: tick, sender, what.
type Heard = Vec<(u64, String, Said)>;

/// Lines to say, given the rooms (sorted) and the sequence: (tick, to whom, what).
type Lines = fn(&[String], &[Colour]) -> Vec<(u64, Receiver, Said)>;

/// A player that does not move: it says its lines at their ticks and records what it hears.
struct Talker {
    name: String,
    knowledge: Knowledge,
    lines: Lines,
    /// The lines not said yet, once the first percepts came.
    pending: Option<Vec<(u64, Receiver, Said)>>,
    heard: Arc<Mutex<Heard>>,
}

impl Agent for Talker {
    fn decide(&mut self, obs: &Observation) -> Vec<Action> {
        let mut heard = self.heard.lock().expect("heard");
        for delta in &obs.percepts {
            self.knowledge.apply(delta.tick, delta);
            for message in self.knowledge.latest_messages() {
                let said = message.said().cloned();
                let said = said.unwrap_or_else(|| panic!("{} heard free text {}", self.name, message.text));
                heard.push((obs.tick, message.from.to_string(), said));
            }
        }
        let pending = self.pending.get_or_insert_with(|| {
            let rooms: Vec<String> =
                self.knowledge.places().filter(|p| p.starts_with("Room")).map(str::to_string).collect();
            (self.lines)(&rooms, self.knowledge.sequence())
        });
        let (due, later): (Vec<_>, Vec<_>) =
            std::mem::take(pending).into_iter().partition(|(at, _, _)| *at <= obs.tick);
        *pending = later;
        due.into_iter().map(|(_, to, said)| Action::SendMessage { to, text: said.to_text() }).collect()
    }

    fn wake_at(&self) -> Option<u64> {
        self.pending.iter().flatten().map(|(at, _, _)| *at).min()
    }
}

/// Plays a talker named `Asker` beside `Bot1` and `Bot2` (cooperative, watched).
fn play_with_talker(seed: u64, lines: Lines) -> (EndReason, u64, Vec<Sent>, Heard) {
    let record = Shared::default();
    let heard = Arc::new(Mutex::new(Vec::new()));
    let talker = Talker {
        name: "Asker".into(),
        knowledge: Knowledge::new(),
        lines,
        pending: None,
        heard: heard.clone(),
    };
    // The one talker, handed to the match when it seats `Asker`.
    let talker = Mutex::new(Some(talker));
    let take = move |_: &str| -> Box<dyn Agent> {
        Box::new(talker.lock().expect("lock").take().expect("seated once"))
    };
    let seats = vec![
        Seat::agent("Asker", Arc::new(take)),
        spy("Bot1", Strategy::Cooperative, &record),
        spy("Bot2", Strategy::Cooperative, &record),
    ];
    let (reason, ticks) = play(&shipped_map("default"), seed, seats);
    let record = Arc::try_unwrap(record).map_err(|_| "spies still held").expect("record");
    let record = record.into_inner().expect("record");
    assert!(
        record.not_language.is_empty() && record.outside_window.is_empty(),
        "{:?}",
        record.outside_window
    );
    let heard = Arc::try_unwrap(heard).map_err(|_| "talker still held").expect("heard");
    (reason, ticks, record.sent, heard.into_inner().expect("heard"))
}

/// Asked to go to a room it would look into last, Bot2 says `ok`, and the next room it
/// reports is that one; asked later where the last colour is, the robots that know answer
/// the asker alone.
#[test]
fn a_robot_sent_to_a_room_goes_there_and_reports_it() {
    let lines = |rooms: &[String], sequence: &[Colour]| {
        let room = rooms[0].clone();
        let go_to = Said { player: Some("Bot2".into()), room: Some(room), ..Said::new("go_to") };
        let mut lines = vec![(0, Receiver::Player("Bot2".into()), go_to)];
        // Every colour of the sequence: some are known by then, some not (those are not
        // answered, in a team of three), some may be in hand.
        for colour in sequence {
            let where_is = Said { colour: Some(colour.to_string()), ..Said::new("where_is") };
            lines.push((600, Receiver::All, where_is));
        }
        lines
    };
    for seed in 0..3 {
        let (reason, ticks, sent, heard) = play_with_talker(seed, lines);
        assert_eq!(reason, "completed", "seed {seed}: after {ticks} ticks");
        let asker = Receiver::Player("Asker".into());
        let ok = sent.iter().position(|s| s.from == "Bot2" && s.to == asker && s.said.kind == "ok");
        let ok = ok.unwrap_or_else(|| panic!("seed {seed}: Bot2 did not say ok: {sent:?}"));
        let report = sent[ok..]
            .iter()
            .find(|s| s.from == "Bot2" && (s.said.kind == "empty" || s.said.kind == "contains_many"))
            .unwrap_or_else(|| panic!("seed {seed}: Bot2 reported nothing after ok"));
        assert_eq!(report.said.room.as_deref(), Some("RoomA1"), "seed {seed}: {report:?}");
        assert!(
            heard.iter().any(|(_, from, s)| from == "Bot2" && s.kind == "ok"),
            "the asker hears the answer"
        );
        let answers: Vec<&Sent> = sent
            .iter()
            .filter(|s| s.to == asker && ["contains", "have", "dont_know"].contains(&s.said.kind.as_str()))
            .collect();
        assert!(!answers.is_empty(), "seed {seed}: where_is never answered");
        assert!(answers.iter().all(|s| s.tick >= 600 && s.said.kind != "dont_know"), "{answers:?}");
        let heard_answers = heard.iter().filter(|(_, _, s)| ["contains", "have"].contains(&s.kind.as_str()));
        assert_eq!(heard_answers.count(), answers.len(), "the asker hears each answer");
    }
}

/// A player says it will get the first colour and never does (a participant who claims a
/// colour and then does nothing): the team leaves position 0 to it until the claim lapses,
/// then delivers it and completes within a study trial's time.
#[test]
fn a_forgotten_will_get_lapses_and_the_team_completes() {
    let lines = |_: &[String], sequence: &[Colour]| {
        vec![(0, Receiver::All, Said { colour: Some(sequence[0].to_string()), ..Said::new("will_get") })]
    };
    for seed in 0..2 {
        let (reason, ticks, sent, _) = play_with_talker(seed, lines);
        assert_eq!(reason, "completed", "seed {seed}: after {ticks} ticks");
        // Within a study's trial of 300 s at 10 ticks a second (examples/study).
        assert!(ticks <= 3_000, "seed {seed}: completed only after {ticks} ticks");
        let first_claim = sent
            .iter()
            .find(|s| {
                s.said.position == Some(0) && ["getting_for", "bringing"].contains(&s.said.kind.as_str())
            })
            .expect("somebody claims position 0 at last");
        assert!(
            first_claim.tick > WORD_CLAIM_LAPSE_TICKS,
            "seed {seed}: {first_claim:?} before the asker's claim lapsed"
        );
        assert!(first_claim.tick < WORD_CLAIM_LAPSE_TICKS + 1_000, "seed {seed}: {first_claim:?} long after");
    }
}
