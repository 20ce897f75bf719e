//! Deltas in, facts and memory out.

use super::*;
use crate::language::Said;

fn name(s: &str) -> Arc<str> {
    Arc::from(s)
}

fn delta(tick: u64, add: Vec<Percept>, not: Vec<Percept>) -> PerceptDelta {
    PerceptDelta { tick, full: false, add, not }
}

fn snapshot(tick: u64, add: Vec<Percept>) -> PerceptDelta {
    PerceptDelta { tick, full: true, add, not: Vec::new() }
}

fn message(from: &str, said: Said) -> Percept {
    Percept::Message { from: name(from), text: said.to_text().into() }
}

fn report(kind: &str, room: &str, colour: Option<&str>, count: Option<u32>) -> Said {
    Said { room: Some(room.into()), colour: colour.map(str::to_string), count, ..Said::new(kind) }
}

/// What Ann is told first: three places, a two-colour goal, Bob in the match.
fn introduction() -> Vec<Percept> {
    let mut add: Vec<Percept> =
        ["RoomA1", "FrontA1", "DropZone"].into_iter().map(|p| Percept::Place(name(p))).collect();
    add.extend([
        Percept::OwnName(name("Ann")),
        Percept::Bot(3),
        Percept::Sequence(Arc::from([Colour::Red, Colour::Blue])),
        Percept::Player(name("Bob")),
        Percept::At(name("FrontA1")),
        Percept::SequenceIndex(0),
        Percept::State(MoveState::Arrived),
    ]);
    add
}

fn into_a1() -> Vec<Percept> {
    vec![
        Percept::At(name("RoomA1")),
        Percept::In(name("RoomA1")),
        Percept::Occupied(name("RoomA1")),
        Percept::AtBlock(4),
        Percept::Color(4, Colour::Red),
        Percept::Color(7, Colour::Blue),
        Percept::Block(4),
        Percept::Block(7),
    ]
}

#[test]
fn the_accessors_read_what_the_deltas_say_holds() {
    let mut knowledge = Knowledge::new();
    assert_eq!((knowledge.name(), knowledge.tick(), knowledge.sequence()), (None, None, &[][..]));
    knowledge.apply(0, &snapshot(0, introduction()));
    knowledge.apply(5, &delta(5, into_a1(), vec![]));
    assert_eq!((knowledge.name(), knowledge.robot(), knowledge.tick()), (Some("Ann"), Some(3), Some(5)));
    assert_eq!((knowledge.at(), knowledge.room()), (Some("RoomA1"), Some("RoomA1")));
    assert_eq!(knowledge.at_block(), Some((4, Some(Colour::Red))));
    assert_eq!(knowledge.holding(), None);
    assert_eq!(knowledge.visible(), [(4, Colour::Red), (7, Colour::Blue)]);
    assert_eq!((knowledge.sequence(), knowledge.sequence_index()), (&[Colour::Red, Colour::Blue][..], 0));
    assert_eq!(knowledge.next_colour(), Some(Colour::Red));
    assert_eq!(knowledge.places().collect::<Vec<_>>(), ["DropZone", "FrontA1", "RoomA1"], "by name");
    assert_eq!(knowledge.rooms().collect::<Vec<_>>(), ["DropZone", "RoomA1"]);
    assert_eq!(knowledge.occupied().collect::<Vec<_>>(), ["RoomA1"]);
    assert_eq!(knowledge.players().collect::<Vec<_>>(), ["Bob"]);
    // Picking the block up: it is held, no longer seen, and its colour is remembered.
    knowledge.apply(
        6,
        &delta(
            6,
            vec![Percept::Holding(4), Percept::SequenceIndex(1), Percept::State(MoveState::Traveling)],
            vec![Percept::AtBlock(4), Percept::Color(4, Colour::Red), Percept::Block(4)],
        ),
    );
    assert_eq!(knowledge.holding(), Some((4, Some(Colour::Red))));
    assert_eq!((knowledge.at_block(), knowledge.visible()), (None, &[(7, Colour::Blue)][..]));
    assert_eq!((knowledge.sequence_index(), knowledge.state()), (1, Some(MoveState::Traveling)));
    assert_eq!(knowledge.next_colour(), Some(Colour::Blue));
}

#[test]
fn the_facts_are_the_percepts_that_hold() {
    let mut knowledge = Knowledge::new();
    knowledge.apply(0, &snapshot(0, introduction()));
    knowledge.apply(5, &delta(5, into_a1(), vec![]));
    let mut expected: BTreeSet<Percept> = introduction().into_iter().collect();
    expected.remove(&Percept::At(name("FrontA1")));
    expected.extend(into_a1());
    assert_eq!(knowledge.facts(), expected);
    assert!(expected.iter().all(|fact| knowledge.holds(fact)));
    assert!(!knowledge.holds(&Percept::At(name("FrontA1"))), "`at` was replaced");
    assert!(!knowledge.holds(&Percept::Occupied(name("FrontA1"))));
    assert!(!knowledge.holds(&Percept::Message { from: name("Bob"), text: name("hi") }));
}

#[test]
fn single_valued_facts_are_replaced_and_a_negation_removes_only_what_holds() {
    let mut knowledge = Knowledge::new();
    knowledge.apply(1, &delta(1, vec![Percept::At(name("FrontA1")), Percept::In(name("RoomA1"))], vec![]));
    knowledge.apply(
        2,
        &delta(
            2,
            vec![Percept::At(name("RoomA1")), Percept::Message { from: name("Bob"), text: name("hi") }],
            vec![Percept::In(name("RoomA2")), Percept::Player(name("Cat"))],
        ),
    );
    assert_eq!(knowledge.room(), Some("RoomA1"), "a negation of another room changes nothing");
    knowledge.apply(3, &delta(3, vec![], vec![Percept::In(name("RoomA1"))]));
    assert_eq!(
        knowledge.facts().into_iter().collect::<Vec<_>>(),
        [Percept::At(name("RoomA1"))],
        "messages are no facts"
    );
    assert_eq!(knowledge.messages().len(), 1);
}

#[test]
fn a_full_snapshot_replaces_the_facts_and_keeps_the_memory() {
    let mut knowledge = Knowledge::new();
    knowledge.apply(0, &snapshot(0, introduction()));
    knowledge.apply(5, &delta(5, into_a1(), vec![]));
    knowledge.apply(6, &delta(6, vec![message("Bob", Said::new("ok"))], vec![]));
    let hall = vec![Percept::OwnName(name("Ann")), Percept::At(name("FrontA1")), Percept::Holding(4)];
    knowledge.apply(9, &snapshot(9, hall.clone()));
    assert_eq!(knowledge.facts(), hall.into_iter().collect());
    assert_eq!((knowledge.room(), knowledge.visible(), knowledge.sequence()), (None, &[][..], &[][..]));
    assert_eq!(knowledge.occupied().count() + knowledge.places().count() + knowledge.players().count(), 0);
    assert_eq!(knowledge.holding(), Some((4, Some(Colour::Red))), "colours seen are remembered");
    assert_eq!(knowledge.seen("RoomA1").map(|s| s.tick), Some(9), "left at the snapshot");
    assert_eq!(knowledge.messages().len(), 1);
}

#[test]
fn a_room_is_remembered_as_last_seen_with_the_tick_it_was_left() {
    let mut knowledge = Knowledge::new();
    knowledge.apply(0, &snapshot(0, introduction()));
    assert_eq!(knowledge.seen("RoomA1"), None);
    knowledge.apply(5, &delta(5, into_a1(), vec![]));
    let seen = |k: &Knowledge| k.seen("RoomA1").cloned();
    let red_and_blue = vec![(4, Colour::Red), (7, Colour::Blue)];
    assert_eq!(seen(&knowledge), Some(RoomSeen { tick: 5, blocks: red_and_blue.clone() }));
    knowledge.apply(8, &delta(8, vec![], vec![]));
    assert_eq!(seen(&knowledge), Some(RoomSeen { tick: 8, blocks: red_and_blue }), "inside, still seeing");
    knowledge.apply(9, &delta(9, vec![], vec![Percept::Color(7, Colour::Blue), Percept::Block(7)]));
    knowledge.apply(
        12,
        &delta(
            12,
            vec![Percept::At(name("FrontA1"))],
            vec![Percept::In(name("RoomA1")), Percept::AtBlock(4)],
        ),
    );
    assert_eq!(knowledge.room(), None);
    knowledge.apply(30, &delta(30, vec![], vec![]));
    assert_eq!(
        seen(&knowledge),
        Some(RoomSeen { tick: 12, blocks: vec![(4, Colour::Red)] }),
        "as it was when the robot left"
    );
}

#[test]
fn a_teammates_report_adds_up_within_its_tick_and_the_next_one_replaces_it() {
    let mut knowledge = Knowledge::new();
    knowledge.apply(0, &snapshot(0, introduction()));
    let blue = report("contains_many", "RoomB2", Some("Blue"), Some(2));
    let red = report("contains", "RoomB2", Some("Red"), None);
    let going = Said { room: Some("RoomB2".into()), ..Said::new("going_to") };
    knowledge.apply(
        4,
        &delta(
            4,
            vec![message("Bob", blue.clone()), message("Bob", going), message("Bob", red.clone())],
            vec![],
        ),
    );
    let told = knowledge.told("RoomB2").cloned();
    assert_eq!(told, Some(RoomTold { tick: 4, from: name("Bob"), said: vec![blue, red] }), "not going_to");
    let empty = report("empty", "RoomB2", None, None);
    knowledge.apply(6, &delta(6, vec![message("Cat", empty.clone())], vec![]));
    assert_eq!(
        knowledge.told("RoomB2").cloned(),
        Some(RoomTold { tick: 6, from: name("Cat"), said: vec![empty] })
    );
    assert_eq!(knowledge.told("RoomA1"), None);
    assert_eq!(knowledge.places().count(), 3, "a room named in a message is not a place of the map");
}

#[test]
fn messages_are_bounded_but_the_latest_delta_is_whole() {
    let mut knowledge = Knowledge::new();
    let many: Vec<Percept> =
        (0..25).map(|i| Percept::Message { from: name("Bob"), text: format!("hi {i}").into() }).collect();
    knowledge.apply(1, &delta(1, many, vec![]));
    assert_eq!((knowledge.latest_messages().len(), knowledge.messages().len()), (25, memory::KEPT_MESSAGES));
    assert_eq!(&*knowledge.messages()[0].text, "hi 5", "the oldest are forgotten");
    knowledge.apply(2, &delta(2, vec![message("Cat", Said::new("ok"))], vec![]));
    let latest = knowledge.latest_messages();
    assert_eq!((latest.len(), &*latest[0].from, latest[0].said()), (1, "Cat", Some(&Said::new("ok"))));
    assert_eq!(knowledge.messages().len(), memory::KEPT_MESSAGES);
    assert_eq!(knowledge.messages()[0].said(), None, "free text is no message of the language");
    assert_eq!(knowledge.heard_count(), 26);
    knowledge.apply(3, &delta(3, vec![], vec![]));
    assert!(knowledge.latest_messages().is_empty());
}

#[test]
fn a_model_for_a_map_answers_by_zone_index() {
    let map = Map::parse(include_str!("../../../../maps/fixed.toml"), "fixed").expect("the map");
    let zone = |name: &str| map.zone_named(name);
    let mut knowledge = Knowledge::for_map(&map);
    assert_eq!((knowledge.at_zone(), knowledge.places().count()), (None, 0), "no facts yet");
    knowledge.apply(
        1,
        &delta(
            1,
            vec![
                Percept::At(name("RoomB2")),
                Percept::In(name("RoomB2")),
                Percept::Occupied(name("RoomB2")),
                Percept::Occupied(name("DropZone")),
            ],
            vec![],
        ),
    );
    assert_eq!((knowledge.at_zone(), knowledge.room_zone()), (zone("RoomB2"), zone("RoomB2")));
    let occupied: Vec<ZoneIdx> = (0..map.zones().len()).filter(|&z| knowledge.zone_occupied(z)).collect();
    let mut expected = vec![zone("RoomB2").expect("a zone"), zone("DropZone").expect("a zone")];
    expected.sort_unstable();
    assert_eq!(occupied, expected);
    knowledge.apply(2, &delta(2, vec![Percept::At(name("Nowhere"))], vec![Percept::In(name("RoomB2"))]));
    assert_eq!((knowledge.at(), knowledge.at_zone(), knowledge.room_zone()), (Some("Nowhere"), None, None));
    assert!(!knowledge.zone_occupied(map.zones().len()), "past the map's zones");
}

#[test]
fn latest_only_keeps_just_the_latest_deltas_messages() {
    let mut knowledge = Knowledge::new().latest_only();
    knowledge.apply(0, &snapshot(0, introduction()));
    let two = vec![message("Bob", Said::new("ok")), message("Cal", Said::new("ok"))];
    knowledge.apply(1, &delta(1, two, vec![]));
    assert_eq!((knowledge.latest_messages().len(), knowledge.messages().len()), (2, 2));
    knowledge.apply(2, &delta(2, vec![message("Bob", Said::new("ok"))], vec![]));
    assert_eq!((knowledge.latest_messages().len(), knowledge.messages().len()), (1, 1));
    knowledge.apply(3, &delta(3, vec![], vec![]));
    assert!(knowledge.messages().is_empty(), "{:?}", knowledge.messages());
    assert_eq!(knowledge.heard_count(), 3, "every message is still counted");
    // The default keeps the older ones too.
    let mut keeping = Knowledge::new();
    keeping.apply(0, &snapshot(0, introduction()));
    keeping.apply(1, &delta(1, vec![message("Bob", Said::new("ok"))], vec![]));
    keeping.apply(2, &delta(2, vec![], vec![]));
    assert_eq!(keeping.messages().len(), 1);
}
