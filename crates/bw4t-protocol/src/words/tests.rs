//! Descriptions and change lines, from scripted deltas and from a played match.

use std::sync::Arc;

use bw4t_sim::{Percept, PerceptDelta};

use super::*;
use crate::knowledge::RoomSeen;

fn name(s: &str) -> Arc<str> {
    Arc::from(s)
}

fn delta(tick: u64, add: Vec<Percept>, not: Vec<Percept>) -> PerceptDelta {
    PerceptDelta { tick, full: false, add, not }
}

/// A message percept carrying a message of the language.
fn says(from: &str, kind: &str, room: Option<&str>, colour: Option<&str>) -> Percept {
    let said = Said { room: room.map(str::to_string), colour: colour.map(str::to_string), ..Said::new(kind) };
    Percept::Message { from: name(from), text: said.to_text().into() }
}

/// What Ann is told first: a small map, a three-colour goal, Bob in the match.
fn introduction() -> PerceptDelta {
    let mut add: Vec<Percept> =
        ["FrontA1", "FrontC1", "RoomA1", "RoomA2", "RoomB1", "RoomC1", "RoomC2", "DropZone"]
            .into_iter()
            .map(|p| Percept::Place(name(p)))
            .collect();
    add.extend([
        Percept::OwnName(name("Ann")),
        Percept::Bot(0),
        Percept::Sequence(Arc::from([Colour::Yellow, Colour::Red, Colour::Blue])),
        Percept::Player(name("Bob")),
        Percept::At(name("FrontC1")),
        Percept::SequenceIndex(0),
        Percept::State(MoveState::Arrived),
    ]);
    PerceptDelta { tick: 0, full: true, add, not: Vec::new() }
}

/// Ann looks into RoomA1 (a Red block), leaves it, hears Bob, walks into RoomC1 and picks up
/// the Yellow block there; Bob is in RoomB1.
fn script() -> Vec<PerceptDelta> {
    let in_a1 = || {
        vec![
            Percept::In(name("RoomA1")),
            Percept::Occupied(name("RoomA1")),
            Percept::Color(4, Colour::Red),
            Percept::Block(4),
        ]
    };
    let mut enter_a1 = in_a1();
    enter_a1.push(Percept::At(name("RoomA1")));
    vec![
        introduction(),
        delta(90, enter_a1, vec![]),
        delta(120, vec![Percept::At(name("FrontA1")), Percept::State(MoveState::Traveling)], in_a1()),
        delta(
            250,
            vec![
                says("Bob", "contains", Some("RoomC2"), Some("Blue")),
                says("Bob", "going_to", Some("RoomA2"), None),
                Percept::Occupied(name("RoomB1")),
            ],
            vec![],
        ),
        delta(
            300,
            vec![
                Percept::At(name("RoomC1")),
                Percept::State(MoveState::Arrived),
                Percept::In(name("RoomC1")),
                Percept::AtBlock(11),
                Percept::Occupied(name("RoomC1")),
                Percept::Color(11, Colour::Yellow),
                Percept::Color(12, Colour::Blue),
                Percept::Block(11),
                Percept::Block(12),
            ],
            vec![],
        ),
        delta(
            310,
            vec![Percept::Holding(11)],
            vec![Percept::AtBlock(11), Percept::Color(11, Colour::Yellow), Percept::Block(11)],
        ),
    ]
}

fn played(deltas: &[PerceptDelta]) -> Knowledge {
    let mut knowledge = Knowledge::new();
    for d in deltas {
        knowledge.apply(d.tick, d);
    }
    knowledge
}

#[test]
fn the_description_of_a_scripted_walk() {
    let knowledge = played(&script());
    let expected = "\
I am Ann (robot 0), in RoomC1. I hold block 11 (Yellow). I am standing still.
Here I see block 12 (Blue).
Goal: Yellow, Red, Blue (3 of 3 left); next needed: Yellow.
Rooms: RoomA1 had block 4 (Red) at tick 120; RoomC2: Bob said it contains Blue at tick 250. Not yet known: RoomA2, RoomB1.
Other robots are in: RoomB1.
Other players: Bob.
Bob said at tick 250: \"RoomC2 contains Blue.\"
Bob said at tick 250: \"I am going to RoomA2.\"";
    assert_eq!(knowledge.describe(), expected);
    assert_eq!(played(&script()).describe(), expected, "the same deltas give the same text");
}

#[test]
fn before_anything_arrives_it_says_so() {
    assert_eq!(Knowledge::new().describe(), "I know nothing yet: no percepts have arrived.");
    let first = Knowledge::new().snapshot();
    let knowledge = played(&[introduction()]);
    assert_eq!(knowledge.changes_since(&first), knowledge.describe().lines().collect::<Vec<_>>());
}

#[test]
fn the_accessors_read_the_facts_and_the_memory() {
    let knowledge = played(&script());
    assert_eq!((knowledge.name(), knowledge.robot()), (Some("Ann"), Some(0)));
    assert_eq!((knowledge.at(), knowledge.room()), (Some("RoomC1"), Some("RoomC1")));
    assert_eq!(knowledge.holding(), Some((11, Some(Colour::Yellow))));
    assert_eq!(knowledge.at_block(), None);
    assert_eq!(knowledge.state(), Some(MoveState::Arrived));
    assert_eq!(knowledge.visible(), [(12, Colour::Blue)]);
    assert_eq!(knowledge.next_colour(), Some(Colour::Yellow));
    assert_eq!(knowledge.occupied().collect::<Vec<_>>(), ["RoomB1", "RoomC1"]);
    assert_eq!(
        knowledge.rooms().collect::<Vec<_>>(),
        ["DropZone", "RoomA1", "RoomA2", "RoomB1", "RoomC1", "RoomC2"]
    );
    assert_eq!(knowledge.players().collect::<Vec<_>>(), ["Bob"]);
    assert_eq!(knowledge.tick(), Some(310));
    assert_eq!(knowledge.messages().len(), 2);
    assert!(knowledge.latest_messages().is_empty(), "the latest delta brought none");
}

#[test]
fn a_room_is_remembered_after_leaving_it() {
    let script = script();
    let knowledge = played(&script[..3]);
    assert_eq!(knowledge.room(), None);
    assert_eq!(knowledge.seen("RoomA1"), Some(&RoomSeen { tick: 120, blocks: vec![(4, Colour::Red)] }));
    assert!(knowledge.visible().is_empty(), "nothing is visible from the hall");
    let rooms = knowledge.describe().lines().nth(2).unwrap_or_default().to_string();
    assert_eq!(
        rooms,
        "Rooms: RoomA1 had block 4 (Red) at tick 120. Not yet known: RoomA2, RoomB1, RoomC1, RoomC2."
    );
}

#[test]
fn a_teammate_message_reads_as_its_sentence() {
    let mut knowledge = played(&[introduction()]);
    let before = knowledge.snapshot();
    let free = Percept::Message { from: name("Bob"), text: name("hello there") };
    knowledge.apply(5, &delta(5, vec![says("Bob", "will_get", None, Some("Red")), free], vec![]));
    assert_eq!(
        knowledge.changes_since(&before),
        ["Bob said: \"I will get Red.\"", "Bob said: \"hello there\""]
    );
    assert_eq!(knowledge.messages()[0].sentence(), "I will get Red.");
    assert!(
        knowledge
            .describe()
            .ends_with("\nBob said at tick 5: \"I will get Red.\"\nBob said at tick 5: \"hello there\"")
    );
}

#[test]
fn a_report_of_one_tick_adds_up_and_what_i_saw_later_wins() {
    let mut knowledge = played(&[introduction()]);
    let many = |colour: &str, count| {
        let said = Said {
            room: Some("RoomA1".into()),
            colour: Some(colour.into()),
            count: Some(count),
            ..Said::new("contains_many")
        };
        Percept::Message { from: name("Bob"), text: said.to_text().into() }
    };
    knowledge.apply(7, &delta(7, vec![many("Blue", 2), many("Red", 1)], vec![]));
    let rooms = |k: &Knowledge| k.describe().lines().nth(2).unwrap_or_default().to_string();
    assert!(rooms(&knowledge).starts_with("Rooms: RoomA1: Bob said it contains 2 Blue, 1 Red at tick 7."));
    knowledge.apply(9, &delta(9, vec![says("Bob", "empty", Some("RoomA1"), None)], vec![]));
    assert!(rooms(&knowledge).starts_with("Rooms: RoomA1: Bob said it is empty at tick 9."));
    knowledge.apply(20, &delta(20, vec![Percept::In(name("RoomA1")), Percept::At(name("RoomA1"))], vec![]));
    knowledge.apply(21, &delta(21, vec![Percept::At(name("FrontA1"))], vec![Percept::In(name("RoomA1"))]));
    assert!(rooms(&knowledge).starts_with("Rooms: RoomA1 was empty at tick 21."), "{}", rooms(&knowledge));
}

#[test]
fn changes_say_arrivals_pick_ups_and_deliveries() {
    let script = script();
    let mut knowledge = played(&script[..4]);
    let before = knowledge.snapshot();
    // One action's worth of deltas: walk into RoomC1, then pick the Yellow block up.
    knowledge.apply(300, &script[4]);
    knowledge.apply(310, &script[5]);
    assert_eq!(
        knowledge.changes_since(&before),
        ["I arrived at RoomC1.", "I now see block 12 (Blue).", "I picked up block 11 (Yellow)."]
    );
    let before = knowledge.snapshot();
    let put_down = delta(
        320,
        vec![Percept::AtBlock(11), Percept::Color(11, Colour::Yellow), Percept::Block(11)],
        vec![Percept::Holding(11)],
    );
    knowledge.apply(320, &put_down);
    let check =
        |k: &Knowledge, before: &Snapshot, expected: &[&str]| assert_eq!(k.changes_since(before), expected);
    check(&knowledge, &before, &["I put down block 11 (Yellow).", "I can pick up block 11 (Yellow)."]);
    // Out to the drop zone with the block, and delivered.
    let mut knowledge = played(&script);
    let before = knowledge.snapshot();
    knowledge.apply(
        400,
        &delta(
            400,
            vec![
                Percept::At(name("DropZone")),
                Percept::In(name("DropZone")),
                Percept::Occupied(name("DropZone")),
            ],
            vec![
                Percept::In(name("RoomC1")),
                Percept::Occupied(name("RoomC1")),
                Percept::Color(12, Colour::Blue),
                Percept::Block(12),
                Percept::Occupied(name("RoomB1")),
            ],
        ),
    );
    knowledge.apply(401, &delta(401, vec![Percept::SequenceIndex(1)], vec![Percept::Holding(11)]));
    check(
        &knowledge,
        &before,
        &[
            "I left RoomC1.",
            "I arrived at DropZone.",
            "DropZone is empty.",
            "I put down block 11 (Yellow).",
            "Delivered: the team is now at 1 of 3; next needed: Red.",
            "RoomB1 is free now.",
        ],
    );
    assert!(knowledge.describe().contains("Goal: Yellow, Red, Blue (2 of 3 left); next needed: Red."));
}

#[test]
fn changes_say_who_comes_and_goes_and_where() {
    let mut knowledge = played(&script()[..3]);
    let before = knowledge.snapshot();
    knowledge.apply(
        130,
        &delta(
            130,
            vec![
                Percept::Player(name("Cat")),
                Percept::Occupied(name("RoomA2")),
                Percept::At(name("FrontC1")),
            ],
            vec![Percept::Player(name("Bob"))],
        ),
    );
    knowledge.apply(131, &delta(131, vec![Percept::State(MoveState::Collided)], vec![]));
    assert_eq!(
        knowledge.changes_since(&before),
        [
            "I was stopped at FrontC1: a closed door or a robot is in the way.",
            "RoomA2 is now occupied.",
            "Cat joined.",
            "Bob left.",
        ]
    );
}

#[test]
fn changes_say_blocks_taken_by_others_and_a_room_entered_from_its_doorway() {
    let mut knowledge = played(&script());
    let before = knowledge.snapshot();
    knowledge.apply(330, &delta(330, vec![], vec![Percept::Color(12, Colour::Blue), Percept::Block(12)]));
    assert_eq!(knowledge.changes_since(&before), ["No longer here: block 12 (Blue)."]);
    let mut knowledge = played(&script()[..3]);
    let before = knowledge.snapshot();
    knowledge.apply(140, &delta(140, vec![Percept::In(name("RoomA2"))], vec![]));
    assert_eq!(knowledge.changes_since(&before), ["I entered RoomA2.", "RoomA2 is empty."]);
}

/// Ann walks into RoomC1 of the shipped `fixed` map in a real match and picks a block up.
#[test]
fn a_played_match_reads_the_same_every_time() {
    use bw4t_sim::{Action, Match, MatchConfig};
    let run = || {
        let map =
            bw4t_map::Map::parse(include_str!("../../../../maps/fixed.toml"), "fixed").expect("the map");
        let mut game = Match::new(&map, &MatchConfig::default(), 1).expect("a match");
        let ann = game.join("Ann").expect("Ann joins");
        game.join("Bob").expect("Bob joins");
        let mut knowledge = Knowledge::new();
        let first = game.poll_percepts(ann).expect("Ann's first percepts");
        knowledge.apply(first.tick, &first);
        let mut lines = Vec::new();
        // Each action: its deltas until `done`, then what changed.
        let mut act = |game: &mut Match,
                       knowledge: &mut Knowledge,
                       action: Action,
                       done: &dyn Fn(&Knowledge) -> bool| {
            let before = knowledge.snapshot();
            game.handle_action(ann, &action).expect("accepted");
            for _ in 0..2000 {
                game.step();
                if let Some(d) = game.poll_percepts(ann) {
                    knowledge.apply(d.tick, &d);
                }
                if done(knowledge) {
                    break;
                }
            }
            lines.push(knowledge.changes_since(&before));
        };
        let arrived = |k: &Knowledge| k.state() == Some(MoveState::Arrived);
        act(&mut game, &mut knowledge, Action::GoTo("RoomC1".into()), &|k| {
            arrived(k) && k.at() == Some("RoomC1")
        });
        act(&mut game, &mut knowledge, Action::GoToBlock(12), &|k| {
            arrived(k) && k.at_block() == Some((12, Some(Colour::Blue)))
        });
        act(&mut game, &mut knowledge, Action::PickUp(None), &|k| k.holding().is_some());
        (knowledge.describe(), lines)
    };
    let (text, lines) = run();
    assert_eq!(run(), (text.clone(), lines.clone()), "same match, same words");
    assert_eq!(
        text,
        "\
I am Ann (robot 0), in RoomC1. I hold block 12 (Blue). I am standing still.
Here I see block 11 (Yellow), block 13 (Red).
Goal: Yellow, Red, Blue, Green, White, Orange (6 of 6 left); next needed: Yellow.
Rooms: none seen yet. Not yet known: RoomA1, RoomA2, RoomA3, RoomB1, RoomB2, RoomB3, RoomC2, RoomC3.
Other robots are in: none.
Other players: Bob.
Teammates said nothing yet."
    );
    assert_eq!(
        lines,
        [
            vec!["I arrived at RoomC1.", "I now see block 11 (Yellow), block 12 (Blue), block 13 (Red)."],
            vec!["I can pick up block 12 (Blue)."],
            vec!["I picked up block 12 (Blue)."],
        ]
    );
}
