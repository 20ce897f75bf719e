//! The cooperative agent fed hand-built observations: what it says, and how what others
//! say (people included) changes its plan.

use std::sync::Arc;

use bw4t_map::Colour::{self, Blue, Green, Red, White, Yellow};
use bw4t_protocol::Said;
use bw4t_sim::{Action, MoveState, OrderOutcome, Percept, PerceptDelta, Receiver};

use super::{Cooperative, STALL_TICKS, WORD_CLAIM_LAPSE_TICKS};
use crate::{Agent, Observation, OrderDone};

const PLACES: [&str; 7] = ["RoomA1", "RoomA2", "RoomB1", "RoomB2", "DropZone", "FrontDropZone", "LeftHallA"];

fn name(s: &str) -> Arc<str> {
    s.into()
}

/// A message from `from`, as the simulation delivers it.
fn msg(from: &str, said: Said) -> Percept {
    assert!(said.check().is_ok(), "{said:?}");
    Percept::Message { from: name(from), text: name(&said.to_text()) }
}

fn kind(kind: &str) -> Said {
    Said::new(kind)
}

fn with_room(k: &str, room: &str) -> Said {
    Said { room: Some(room.into()), ..Said::new(k) }
}

fn with_colour(k: &str, colour: Colour) -> Said {
    Said { colour: Some(colour.to_string()), ..Said::new(k) }
}

fn with_player(k: &str, player: &str, room: Option<&str>, colour: Option<Colour>) -> Said {
    Said {
        player: Some(player.into()),
        room: room.map(str::to_string),
        colour: colour.map(|c| c.to_string()),
        ..Said::new(k)
    }
}

fn contains_many(room: &str, count: u32, colour: Colour) -> Said {
    Said {
        room: Some(room.into()),
        count: Some(count),
        colour: Some(colour.to_string()),
        ..Said::new("contains_many")
    }
}

fn contains(room: &str, colour: Colour) -> Said {
    Said { room: Some(room.into()), colour: Some(colour.to_string()), ..Said::new("contains") }
}

/// One agent, the tick it is at, and its last move.
struct Bench {
    agent: Cooperative,
    tick: u64,
    /// Actions returned so far (they are numbered from 0).
    issued: u64,
    /// The number of the last goTo/goToBlock, to tell the agent it arrived.
    last_move: Option<u64>,
}

impl Bench {
    /// `agent` (player `me`) with teammates `others`, the sequence at index 0, standing at
    /// `place` (inside it when it is a room) and seeing `visible` there; `heard` arrives
    /// with these first percepts. Returns the bench and the first decision.
    fn start(
        agent: Cooperative,
        others: &[&str],
        sequence: Vec<Colour>,
        place: &str,
        visible: &[(u32, Colour)],
        heard: Vec<Percept>,
    ) -> (Bench, Vec<Action>) {
        let me = agent.name.clone();
        let mut add: Vec<Percept> = PLACES.iter().map(|p| Percept::Place(name(p))).collect();
        add.extend(others.iter().map(|p| Percept::Player(name(p))));
        add.extend([
            Percept::OwnName(name(&me)),
            Percept::Sequence(sequence.into()),
            Percept::SequenceIndex(0),
            Percept::At(name(place)),
            Percept::State(MoveState::Arrived),
        ]);
        if place.starts_with("Room") || place == "DropZone" {
            add.push(Percept::In(name(place)));
        }
        add.extend(visible.iter().map(|(id, c)| Percept::Color(*id, *c)));
        add.extend(heard);
        let mut bench = Bench { agent, tick: 10, issued: 0, last_move: None };
        let actions = bench.decide(PerceptDelta { tick: 10, full: true, add, not: vec![] });
        (bench, actions)
    }

    fn decide(&mut self, delta: PerceptDelta) -> Vec<Action> {
        self.decide_with(delta, vec![])
    }

    fn decide_with(&mut self, delta: PerceptDelta, done: Vec<OrderDone>) -> Vec<Action> {
        let obs = Observation { tick: self.tick, percepts: vec![delta], done, ..Observation::default() };
        let actions = self.agent.decide(&obs);
        sent(&actions);
        for (i, action) in actions.iter().enumerate() {
            if matches!(action, Action::GoTo(_) | Action::GoToBlock(_)) {
                self.last_move = Some(self.issued + i as u64);
            }
        }
        self.issued += actions.len() as u64;
        actions
    }

    /// The next tick: it arrived in `room` (coming from `from`), hearing `heard`.
    fn arrive(&mut self, room: &str, from: &str, heard: Vec<Percept>) -> Vec<Action> {
        self.tick += 1;
        let mut add = vec![Percept::At(name(room)), Percept::In(name(room))];
        add.extend(heard);
        let delta = PerceptDelta { tick: self.tick, full: false, add, not: vec![Percept::At(name(from))] };
        let done = self.last_move.take().map(|action| OrderDone { action, outcome: OrderOutcome::Arrived });
        self.decide_with(delta, done.into_iter().collect())
    }

    /// The next tick: `add` and `not` percepts.
    fn next(&mut self, add: Vec<Percept>, not: Vec<Percept>) -> Vec<Action> {
        self.tick += 1;
        self.decide(PerceptDelta { tick: self.tick, full: false, add, not })
    }
}

/// Every message among `actions`, each of which must be a message of the language.
fn sent(actions: &[Action]) -> Vec<(Receiver, Said)> {
    actions
        .iter()
        .filter_map(|a| match a {
            Action::SendMessage { to, text } => {
                let said =
                    Said::from_text(text).unwrap_or_else(|| panic!("not a message of the language: {text}"));
                assert!(said.sentence().is_ok(), "{said:?}");
                Some((to.clone(), said))
            }
            _ => None,
        })
        .collect()
}

/// The messages' kinds and receivers.
fn kinds(actions: &[Action]) -> Vec<(String, Receiver)> {
    sent(actions).into_iter().map(|(to, s)| (s.kind, to)).collect()
}

fn to(player: &str) -> Receiver {
    Receiver::Player(player.into())
}

/// Where the robot goes, if it moves.
fn goes_to(actions: &[Action]) -> Option<String> {
    actions.iter().find_map(|a| match a {
        Action::GoTo(place) => Some(place.clone()),
        _ => None,
    })
}

/// The positions it claims (`getting_for`, `bringing`).
fn claims(actions: &[Action]) -> Vec<(String, usize)> {
    sent(actions)
        .into_iter()
        .filter(|(_, s)| s.kind == "getting_for" || s.kind == "bringing")
        .map(|(_, s)| (s.colour.unwrap_or_default(), s.position.unwrap_or_default() as usize))
        .collect()
}

#[test]
fn it_reports_a_room_by_counts_and_claims_by_colour_room_and_position() {
    let (_, actions) = Bench::start(
        Cooperative::new("Bot1"),
        &["Bot2"],
        vec![Blue, Red],
        "RoomA1",
        &[(3, Red), (4, Red), (5, White)],
        vec![],
    );
    let said: Vec<Said> = sent(&actions)
        .into_iter()
        .map(|(to, s)| {
            assert_eq!(to, Receiver::All);
            s
        })
        .collect();
    assert_eq!(said[..2], [contains_many("RoomA1", 2, Red), contains_many("RoomA1", 1, White)]);
    // Blue is unknown: position 1 (Red) is fetched from here, then a room is explored.
    assert_eq!(said[2].kind, "getting_for");
    assert_eq!(
        (said[2].colour.as_deref(), said[2].room.as_deref(), said[2].position),
        (Some("Red"), Some("RoomA1"), Some(1))
    );
    assert!(actions.iter().any(|a| matches!(a, Action::GoToBlock(3 | 4))), "{actions:?}");
}

#[test]
fn what_in_is_answered_to_the_asker_from_what_it_knows() {
    let (mut bench, _) = Bench::start(
        Cooperative::new("Bot1"),
        &["Human"],
        vec![Yellow],
        "RoomA1",
        &[(3, Red), (5, White)],
        vec![],
    );
    let actions = bench.next(vec![msg("Human", with_room("what_in", "RoomA1"))], vec![]);
    assert_eq!(
        sent(&actions),
        vec![
            (to("Human"), contains_many("RoomA1", 1, Red)),
            (to("Human"), contains_many("RoomA1", 1, White))
        ]
    );
    let actions = bench.next(vec![msg("Human", with_room("what_in", "RoomB2"))], vec![]);
    assert_eq!(kinds(&actions), vec![("dont_know".to_string(), to("Human"))]);
}

#[test]
fn in_a_larger_team_only_an_agent_that_knows_answers() {
    let (mut bench, _) =
        Bench::start(Cooperative::new("Bot1"), &["Bot2", "Human"], vec![Yellow], "RoomA1", &[], vec![]);
    let actions = bench.next(vec![msg("Human", with_room("what_in", "RoomB2"))], vec![]);
    assert_eq!(kinds(&actions), vec![], "nobody knows: no flood of dont_know");
    let actions = bench.next(vec![msg("Human", with_room("what_in", "RoomA1"))], vec![]);
    assert_eq!(sent(&actions), vec![(to("Human"), with_room("empty", "RoomA1"))]);
}

#[test]
fn a_report_replaces_what_was_believed_about_its_room() {
    let (mut bench, _) =
        Bench::start(Cooperative::new("Bot1"), &["Human"], vec![Yellow], "LeftHallA", &[], vec![]);
    bench.next(
        vec![msg("Human", contains_many("RoomB1", 2, Red)), msg("Human", contains_many("RoomB1", 1, Blue))],
        vec![],
    );
    let actions = bench.next(vec![msg("Human", with_room("what_in", "RoomB1"))], vec![]);
    assert_eq!(
        sent(&actions).into_iter().map(|(_, s)| s).collect::<Vec<_>>(),
        vec![contains_many("RoomB1", 1, Blue), contains_many("RoomB1", 2, Red)],
        "both messages of one report"
    );
    bench.next(vec![msg("Human", contains_many("RoomB1", 1, Blue))], vec![]);
    let actions = bench.next(vec![msg("Human", with_room("what_in", "RoomB1"))], vec![]);
    assert_eq!(
        sent(&actions).into_iter().map(|(_, s)| s).collect::<Vec<_>>(),
        vec![contains_many("RoomB1", 1, Blue)]
    );
    bench.next(vec![msg("Human", with_room("empty", "RoomB1"))], vec![]);
    let actions = bench.next(vec![msg("Human", with_room("what_in", "RoomB1"))], vec![]);
    assert_eq!(
        sent(&actions).into_iter().map(|(_, s)| s).collect::<Vec<_>>(),
        vec![with_room("empty", "RoomB1")]
    );
}

#[test]
fn where_is_names_a_room_a_block_in_hand_or_nothing() {
    let (mut bench, _) = Bench::start(
        Cooperative::new("Bot1"),
        &["Human"],
        vec![Green],
        "RoomA1",
        &[(3, Red), (4, Blue)],
        vec![],
    );
    let actions = bench.next(vec![msg("Human", with_colour("where_is", Red))], vec![]);
    assert_eq!(sent(&actions), vec![(to("Human"), contains("RoomA1", Red))]);
    let actions = bench.next(vec![msg("Human", with_colour("where_is", Yellow))], vec![]);
    assert_eq!(kinds(&actions), vec![("dont_know".to_string(), to("Human"))]);
    // Holding the blue block (as after picking it up).
    let actions = bench.next(
        vec![Percept::Holding(4), msg("Human", with_colour("where_is", Blue))],
        vec![Percept::Color(4, Blue)],
    );
    assert_eq!(sent(&actions)[0], (to("Human"), with_colour("have", Blue)));
}

#[test]
fn who_has_is_answered_only_by_a_holder() {
    let (mut bench, _) =
        Bench::start(Cooperative::new("Bot1"), &["Human"], vec![Green], "RoomA1", &[(4, Blue)], vec![]);
    let actions = bench.next(vec![msg("Human", with_colour("who_has", Blue))], vec![]);
    assert_eq!(kinds(&actions), vec![]);
    let actions = bench.next(
        vec![Percept::Holding(4), msg("Human", with_colour("who_has", Blue))],
        vec![Percept::Color(4, Blue)],
    );
    assert_eq!(sent(&actions)[0], (to("Human"), with_colour("have", Blue)));
}

#[test]
fn anybody_going_is_answered_by_whoever_goes_there() {
    let (mut bench, first) =
        Bench::start(Cooperative::new("Bot1"), &["Human"], vec![Green], "LeftHallA", &[], vec![]);
    let room = goes_to(&first).expect("explores");
    assert_eq!(sent(&first), vec![(Receiver::All, with_room("going_to", &room))]);
    let actions = bench.next(vec![msg("Human", with_room("anybody_going", &room))], vec![]);
    assert_eq!(sent(&actions), vec![(to("Human"), with_room("going_to", &room))]);
    let other = if room == "RoomB2" { "RoomB1" } else { "RoomB2" };
    let actions = bench.next(vec![msg("Human", with_room("anybody_going", other))], vec![]);
    assert_eq!(kinds(&actions), vec![]);
}

#[test]
fn go_to_drops_the_claim_goes_there_reports_and_resumes() {
    let heard = vec![msg("Bot2", contains_many("RoomB2", 1, Red))];
    let (mut bench, first) =
        Bench::start(Cooperative::new("Bot1"), &["Bot2", "Human"], vec![Red, Blue], "LeftHallA", &[], heard);
    assert_eq!(claims(&first), vec![("Red".to_string(), 0)]);
    assert_eq!(goes_to(&first).as_deref(), Some("RoomB2"));

    // A request to somebody else changes nothing.
    let actions = bench.next(vec![msg("Human", with_player("go_to", "Bot2", Some("RoomA2"), None))], vec![]);
    assert_eq!((kinds(&actions), goes_to(&actions)), (vec![], None));

    let actions = bench.next(vec![msg("Human", with_player("go_to", "Bot1", Some("RoomA2"), None))], vec![]);
    assert_eq!(
        sent(&actions),
        vec![(to("Human"), kind("ok")), (Receiver::All, Said { position: Some(0), ..kind("giving_up") })]
    );
    assert_eq!(goes_to(&actions).as_deref(), Some("RoomA2"), "{actions:?}");

    // There (before the move has even ended): what it sees, then back to work.
    let actions = bench.next(
        vec![Percept::At(name("RoomA2")), Percept::In(name("RoomA2")), Percept::Color(9, Yellow)],
        vec![Percept::At(name("LeftHallA"))],
    );
    let said: Vec<Said> = sent(&actions).into_iter().map(|(_, s)| s).collect();
    assert_eq!(said[0], contains_many("RoomA2", 1, Yellow));
    assert_eq!(claims(&actions), vec![("Red".to_string(), 0)], "resumes: {said:?}");
    assert_eq!(goes_to(&actions).as_deref(), Some("RoomB2"));

    // An unknown place cannot be gone to.
    let actions = bench.next(vec![msg("Human", with_player("go_to", "Bot1", Some("Narnia"), None))], vec![]);
    assert_eq!(kinds(&actions), vec![("could_not".to_string(), to("Human"))]);
}

#[test]
fn go_to_a_room_already_explored_still_reports_it() {
    let (mut bench, _) =
        Bench::start(Cooperative::new("Bot1"), &["Human"], vec![Green], "RoomA1", &[(3, Red)], vec![]);
    let actions = bench.next(vec![msg("Human", with_player("go_to", "Bot1", Some("RoomA1"), None))], vec![]);
    assert_eq!(
        sent(&actions)[..2],
        [(to("Human"), kind("ok")), (Receiver::All, contains_many("RoomA1", 1, Red))],
        "{actions:?}"
    );
}

#[test]
fn get_takes_on_the_colour_asked_for() {
    let heard =
        vec![msg("Bot2", contains_many("RoomB2", 1, Red)), msg("Bot2", contains_many("RoomB1", 1, Blue))];
    let (mut bench, first) = Bench::start(
        Cooperative::new("Bot1"),
        &["Bot2", "Human"],
        vec![Red, Blue, Green],
        "LeftHallA",
        &[],
        heard,
    );
    assert_eq!(claims(&first), vec![("Red".to_string(), 0)]);

    let actions = bench.next(vec![msg("Human", with_player("get", "Bot1", None, Some(Blue)))], vec![]);
    assert_eq!(kinds(&actions)[0], ("ok".to_string(), to("Human")));
    assert!(kinds(&actions).contains(&("giving_up".to_string(), Receiver::All)), "{actions:?}");
    assert_eq!(claims(&actions), vec![("Blue".to_string(), 1)]);
    assert_eq!(goes_to(&actions).as_deref(), Some("RoomB1"));

    let actions = bench.next(vec![msg("Human", with_player("get", "Bot1", None, Some(Green)))], vec![]);
    assert_eq!(kinds(&actions), vec![("dont_know".to_string(), to("Human"))], "no green block known");
    let actions = bench.next(vec![msg("Human", with_player("get", "Bot1", None, Some(White)))], vec![]);
    assert_eq!(kinds(&actions), vec![("could_not".to_string(), to("Human"))], "white is not needed");
    let actions = bench.next(vec![msg("Human", with_player("get", "Bot2", None, Some(Red)))], vec![]);
    assert_eq!(kinds(&actions), vec![]);
}

#[test]
fn will_get_is_respected_until_it_lapses() {
    let red_in_b2 = || msg("Bot2", contains_many("RoomB2", 1, Red));
    // Without it, Bot1 fetches red for position 0.
    let (_, first) = Bench::start(
        Cooperative::new("Bot1"),
        &["Bot2", "Human"],
        vec![Red, Blue],
        "LeftHallA",
        &[],
        vec![red_in_b2()],
    );
    assert_eq!(claims(&first), vec![("Red".to_string(), 0)]);

    let heard = vec![red_in_b2(), msg("Human", with_colour("will_get", Red))];
    let (mut bench, first) =
        Bench::start(Cooperative::new("Bot1"), &["Bot2", "Human"], vec![Red, Blue], "LeftHallA", &[], heard);
    assert_eq!(claims(&first), vec![], "position 0 is the human's");
    assert_ne!(goes_to(&first).as_deref(), Some("RoomB2"), "{first:?}");

    // Halfway, it arrives in the room it explores, and explores the next.
    let room = goes_to(&first).expect("explores");
    bench.tick += WORD_CLAIM_LAPSE_TICKS / 2;
    let actions = bench.arrive(&room, "LeftHallA", vec![]);
    assert_eq!(claims(&actions), vec![], "not yet lapsed: {actions:?}");
    let next = goes_to(&actions).expect("explores on");
    bench.tick += WORD_CLAIM_LAPSE_TICKS / 2 + 1;
    let actions = bench.arrive(&next, &room, vec![]);
    assert_eq!(claims(&actions), vec![("Red".to_string(), 0)], "lapsed: {actions:?}");
}

#[test]
fn could_not_ends_a_claim_at_once() {
    let heard = vec![msg("Bot2", contains_many("RoomB2", 1, Red)), msg("Human", with_colour("have", Red))];
    let (mut bench, first) =
        Bench::start(Cooperative::new("Bot1"), &["Human"], vec![Red, Blue], "LeftHallA", &[], heard);
    assert_eq!(claims(&first), vec![]);
    // Exploring a room meanwhile; arrives there and hears the human give up.
    let room = goes_to(&first).expect("explores");
    let actions = bench.arrive(&room, "LeftHallA", vec![msg("Human", kind("could_not"))]);
    assert_eq!(claims(&actions), vec![("Red".to_string(), 0)], "{actions:?}");
}

#[test]
fn contains_from_anyone_is_a_place_to_fetch_from() {
    let (_, first) = Bench::start(Cooperative::new("Bot1"), &["Human"], vec![Red], "LeftHallA", &[], vec![]);
    assert_eq!(goes_to(&first).as_deref(), Some("RoomA1"), "explores its first room");
    let heard = vec![msg("Human", contains("RoomB2", Red))];
    let (_, first) = Bench::start(Cooperative::new("Bot1"), &["Human"], vec![Red], "LeftHallA", &[], heard);
    assert_eq!(claims(&first), vec![("Red".to_string(), 0)]);
    assert_eq!(goes_to(&first).as_deref(), Some("RoomB2"));
}

#[test]
fn ignoring_hears_the_team_but_no_requests_claims_or_hints() {
    let heard =
        vec![msg("Bot2", contains_many("RoomB2", 1, Red)), msg("Human", with_colour("will_get", Red))];
    let (mut bench, first) = Bench::start(
        Cooperative::ignoring("Bot1"),
        &["Bot2", "Human"],
        vec![Red, Blue],
        "LeftHallA",
        &[],
        heard,
    );
    assert_eq!(
        claims(&first),
        vec![("Red".to_string(), 0)],
        "the human's will_get is not taken into account"
    );
    assert_eq!(goes_to(&first).as_deref(), Some("RoomB2"), "Bot2's report is");
    for request in [
        with_player("go_to", "Bot1", Some("RoomA2"), None),
        with_player("get", "Bot1", None, Some(Blue)),
        with_room("what_in", "RoomB2"),
        with_colour("where_is", Red),
    ] {
        let actions = bench.next(vec![msg("Human", request.clone())], vec![]);
        assert_eq!((kinds(&actions), goes_to(&actions)), (vec![], None), "{request:?}");
    }
    let (_, first) = Bench::start(
        Cooperative::ignoring("Bot1"),
        &["Human"],
        vec![Red],
        "LeftHallA",
        &[],
        vec![msg("Human", contains("RoomB2", Red))],
    );
    assert_eq!(goes_to(&first).as_deref(), Some("RoomA1"), "a hint is not taken");
}

#[test]
fn silent_says_nothing_but_listens_and_follows() {
    let heard = vec![msg("Bot2", contains_many("RoomB2", 1, Red))];
    let (mut bench, first) = Bench::start(
        Cooperative::silent("Bot1"),
        &["Bot2", "Human"],
        vec![Red, Blue],
        "RoomA1",
        &[(3, Blue)],
        heard,
    );
    assert_eq!(kinds(&first), vec![]);
    assert_eq!(goes_to(&first).as_deref(), Some("RoomB2"), "fetches what Bot2 reported");
    let actions = bench.next(vec![msg("Human", with_player("go_to", "Bot1", Some("RoomA2"), None))], vec![]);
    assert_eq!((kinds(&actions), goes_to(&actions).as_deref()), (vec![], Some("RoomA2")));
    let actions = bench.next(vec![msg("Human", with_room("what_in", "RoomA1"))], vec![]);
    assert_eq!(kinds(&actions), vec![]);
}

#[test]
fn two_explorers_of_one_room_leave_it_to_the_smaller_name() {
    let (mut bench, first) =
        Bench::start(Cooperative::new("Bot2"), &["Bot1"], vec![Red], "LeftHallA", &[], vec![]);
    let room = goes_to(&first).expect("explores");
    let actions = bench.next(vec![msg("Bot1", with_room("going_to", &room))], vec![]);
    let next = goes_to(&actions).expect("another room");
    assert_ne!(next, room);
    assert_eq!(sent(&actions), vec![(Receiver::All, with_room("going_to", &next))]);
}

/// The deadlock's situation: Bot2 of a team of four picks up the red block 7 for position
/// 0, and Bot1 claimed position 0 in the same tick. The next red position, 5, lies beyond
/// the window `[0, 4)`: Bot2 must not claim it, and puts the block back where it stands.
#[test]
fn a_loser_holding_a_block_needed_only_beyond_the_window_puts_it_back() {
    let (mut bot2, first) = Bench::start(
        Cooperative::new("Bot2"),
        &["Bot1", "Bot3", "Bot4"],
        vec![Red, Blue, Green, Yellow, White, Red],
        "RoomA1",
        &[(7, Red)],
        vec![Percept::AtBlock(7)],
    );
    assert_eq!(claims(&first), vec![("Red".to_string(), 0)]);
    assert!(first.contains(&Action::PickUp(Some(7))), "{first:?}");
    let bot1 = Said {
        colour: Some("Red".into()),
        room: Some("RoomB1".into()),
        position: Some(0),
        ..kind("getting_for")
    };
    let actions = bot2.next(
        vec![Percept::Holding(7), msg("Bot1", bot1)],
        vec![Percept::AtBlock(7), Percept::Color(7, Red)],
    );
    assert_eq!(claims(&actions), vec![], "claims beyond the window: {actions:?}");
    assert!(actions.contains(&Action::PutDown), "puts the block back in the room: {actions:?}");
    assert!(
        !kinds(&actions).iter().any(|(k, _)| k == "giving_up"),
        "position 0 is Bot1's now, not Bot2's to give up: {actions:?}"
    );
}

/// A person counted as free never fetches the next position: the robot, waiting with a
/// block for a later one, asks to be woken when the stall falls due, then gives its claim
/// up and puts the block back to fetch the next position itself.
#[test]
fn a_stalled_team_gives_later_claims_up() {
    let (mut bench, first) = Bench::start(
        Cooperative::new("Bot1"),
        &["Human"],
        vec![Red, Blue],
        "RoomA1",
        &[(4, Blue)],
        vec![Percept::AtBlock(4)],
    );
    assert_eq!(claims(&first), vec![("Blue".to_string(), 1)]);
    assert!(first.contains(&Action::PickUp(Some(4))), "{first:?}");
    let actions = bench.next(vec![Percept::Holding(4)], vec![Percept::AtBlock(4), Percept::Color(4, Blue)]);
    assert_eq!(goes_to(&actions).as_deref(), Some("FrontDropZone"), "waits for its turn: {actions:?}");
    let wake = bench.agent.wake_at().expect("a stall to wake for");
    assert_eq!(wake, bench.tick + STALL_TICKS - 1, "the next position has been open since the tick before");
    bench.tick = wake - 2;
    let actions = bench.next(vec![], vec![]);
    assert!(actions.is_empty(), "not yet: {actions:?}");
    // Woken with nothing new to perceive (still in the room, on its way out).
    let actions = bench.next(vec![], vec![]);
    assert!(kinds(&actions).contains(&("giving_up".to_string(), Receiver::All)), "{actions:?}");
    assert!(actions.contains(&Action::PutDown), "puts the blue block back: {actions:?}");
}
