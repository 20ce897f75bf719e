use bw4t_map::{Map, Rect, Spawn, Vec2, Zone, ZoneKind};
use bw4t_sim::{JoinError, Match, MatchConfig};

use crate::util::{check, check_fixed};

#[test]
fn first_percepts_follow_the_spec() {
    check_fixed(
        &["Bot1", "Bot2"],
        "
        Bot1 sees at(FrontDropZone) state(arrived) sequenceIndex(0) ownName(Bot1) bot(0)
        Bot1 sees place(RoomA1) place(FrontA1) place(DropZone) place(FrontDropZone)
        Bot1 sees sequence([Yellow,Red,Blue,Green,White,Orange]) player(Bot2)
        Bot1 lacks player(Bot1) in(FrontDropZone)
        Bot2 sees player(Bot1) ownName(Bot2)
        ",
    );
}

/// BW4T-FACTS section 6, scenario 1: movement and a closed door.
#[test]
fn a_second_robot_collides_at_an_occupied_room() {
    check_fixed(
        &["Bot1", "Bot2"],
        "
        Bot1 goTo RoomC1
        Bot1 ok
        run 1
        Bot1 sees state(traveling)
        run until Bot1 in(RoomC1)
        Bot2 sees occupied(RoomC1)
        Bot2 lacks in(RoomC1)
        Bot2 goTo RoomC1
        run until Bot2 state(collided)
        Bot2 sees at(FrontC1)
        Bot2 lacks in(RoomC1)
        Bot2 ended collided
        run until Bot1 state(arrived)
        Bot1 ended arrived
        Bot1 sees at(RoomC1) in(RoomC1) occupied(RoomC1)
        # Leaving is always possible, and frees the room for the robot that waited.
        Bot1 goTo FrontC2
        run until Bot1 at(FrontC2)
        Bot2 lacks occupied(RoomC1)
        Bot2 goTo RoomC1
        run until Bot2 state(arrived)
        Bot2 sees in(RoomC1)
        Bot2 ended arrived
        ",
    );
}

/// BW4T-FACTS section 6, scenario 2: fetch a yellow block and deliver it.
#[test]
fn a_delivered_block_of_the_needed_colour_advances_the_sequence() {
    let s = check_fixed(
        &["Bot1"],
        "
        Bot1 lacks color(1,Red)
        Bot1 goTo RoomC1
        run until Bot1 state(arrived)
        Bot1 sees in(RoomC1)
        Bot1 goToBlock Yellow
        Bot1 ok
        run until Bot1 state(arrived)
        Bot1 pickUp
        Bot1 ok
        run 1
        Bot1 goTo DropZone
        run until Bot1 in(DropZone)
        Bot1 putDown
        Bot1 ok
        run 1
        Bot1 sees sequenceIndex(1)
        match sequenceIndex 1
        match drops 1 0
        match blocks 16
        ",
    );
    assert_eq!(s.game.stats().sequence_index, 1);
}

#[test]
fn blocks_are_seen_only_from_inside_their_room() {
    let s = check_fixed(
        &["Bot1"],
        "
        Bot1 goTo RoomC1
        run until Bot1 in(RoomC1)
        run 1
        ",
    );
    let colours: Vec<String> = s.facts("Bot1").into_iter().filter(|f| f.starts_with("color(")).collect();
    assert_eq!(colours.len(), 3, "{colours:?}");
    assert!(["Yellow", "Blue", "Red"].iter().all(|c| colours.iter().any(|f| f.ends_with(&format!(",{c})")))));
    let mut s = s;
    s.line("Bot1 goTo FrontC1");
    s.line("run until Bot1 at(FrontC1)");
    assert!(s.facts("Bot1").iter().all(|f| !f.starts_with("color(") && !f.starts_with("block(")));
}

#[test]
fn holding_and_atblock_come_and_go_with_negation() {
    check_fixed(
        &["Bot1"],
        "
        Bot1 goTo RoomC1
        run until Bot1 in(RoomC1)
        Bot1 goToBlock Red
        run until Bot1 state(arrived)
        Bot1 pickUp
        Bot1 ok
        run 1
        Bot1 lacks color(13,Red) block(13)
        Bot1 pickUp
        Bot1 rejected already_holding
        # Put back in a room, the block lies near the robot, visible and within reach.
        Bot1 putDown
        Bot1 ok
        run 1
        Bot1 lacks holding(13)
        Bot1 sees color(13,Red) atBlock(13) block(13)
        Bot1 pickUp 13
        Bot1 ok
        run 1
        Bot1 sees holding(13)
        Bot1 lacks atBlock(13)
        ",
    );
}

#[test]
fn a_block_put_down_in_a_hall_leaves_the_world() {
    check_fixed(
        &["Bot1"],
        "
        Bot1 goTo RoomA2
        run until Bot1 in(RoomA2)
        Bot1 goToBlock Green
        run until Bot1 state(arrived)
        Bot1 pickUp
        Bot1 goTo FrontA2
        run until Bot1 state(arrived)
        Bot1 putDown
        Bot1 ok
        match blocks 16
        Bot1 goTo RoomA2
        run until Bot1 state(arrived)
        Bot1 lacks color(3,Green)
        ",
    );
}

#[test]
fn a_wrong_colour_in_the_drop_zone_is_consumed_and_counted() {
    check_fixed(
        &["Bot1"],
        "
        Bot1 goTo RoomA2
        run until Bot1 in(RoomA2)
        Bot1 goToBlock Green
        run until Bot1 state(arrived)
        Bot1 pickUp
        Bot1 goTo DropZone
        run until Bot1 state(arrived)
        Bot1 putDown
        Bot1 ok
        run 1
        match sequenceIndex 0
        match drops 0 1
        match blocks 16
        Bot1 sees sequenceIndex(0)
        ",
    );
}

/// BW4T-FACTS section 6, scenario 3: messages to one player and to all.
#[test]
fn messages_arrive_once_and_all_skips_the_sender() {
    check_fixed(
        &["Bot1", "Bot2", "Bot3"],
        "
        Bot1 say Bot2 hello
        Bot1 ok
        Bot1 say all hi
        Bot3 say Bot1 yes
        run 1
        Bot2 heard message(Bot1,hello) message(Bot1,hi)
        Bot3 heard message(Bot1,hi)
        Bot1 heard message(Bot3,yes)
        run 3
        Bot2 heard message(Bot1,hello) message(Bot1,hi)
        Bot1 say Nobody hi
        Bot1 rejected unknown_receiver
        Bot1 say Bot1 myself
        Bot1 rejected unknown_receiver
        ",
    );
}

#[test]
fn bad_actions_are_rejected_with_a_reason() {
    check_fixed(
        &["Bot1"],
        "
        Bot1 goTo Nowhere
        Bot1 rejected unknown_place
        Bot1 goToBlock 999
        Bot1 rejected unknown_block
        Bot1 goToBlock 0
        Bot1 rejected unknown_block
        Bot1 goToBlock 1
        Bot1 rejected block_not_visible
        Bot1 pickUp
        Bot1 rejected not_at_block
        Bot1 pickUp 1
        Bot1 rejected block_not_visible
        Bot1 putDown
        Bot1 rejected not_holding
        Bot1 sees state(arrived) at(FrontDropZone)
        ",
    );
}

#[test]
fn a_new_order_supersedes_the_old_one() {
    check_fixed(
        &["Bot1"],
        "
        Bot1 goTo RoomA1
        run 5
        Bot1 goTo RoomC3
        run 1
        Bot1 ended superseded
        run until Bot1 state(arrived)
        Bot1 ended arrived
        Bot1 sees in(RoomC3)
        ",
    );
}

#[test]
fn a_stopped_robot_stands_still() {
    let mut s = check_fixed(
        &["Bot1"],
        "
        Bot1 goTo RoomA1
        run 10
        ",
    );
    let id = bw4t_sim::RobotId(0);
    let before = s.game.robots().next().expect("robot").pos;
    s.game.stop(id).expect("stop");
    s.line("run 1");
    s.line("Bot1 ended superseded");
    s.line("Bot1 sees state(arrived)");
    s.line("run 20");
    assert_eq!(s.game.robots().next().expect("robot").pos, before);
}

#[test]
fn players_leave_and_others_are_told() {
    let s = check_fixed(
        &["Bot1", "Bot2"],
        "
        Bot2 goTo RoomB2
        run until Bot2 in(RoomB2)
        Bot1 sees occupied(RoomB2) player(Bot2)
        Bot2 leaves
        run 1
        Bot1 lacks occupied(RoomB2) player(Bot2)
        ",
    );
    // Statistics of a robot that left stay in the match's record.
    let all: Vec<_> = s
        .game
        .all_robot_stats()
        .map(|(_, name, stats, present)| (name.to_string(), stats.rooms_entered, present))
        .collect();
    assert_eq!(all, [("Bot1".to_string(), 0, true), ("Bot2".to_string(), 1, false)]);
}

/// The two-room map without blocks or sequence, with two spawn points `offset` to either
/// side of RoomA's door (x = 15), so two robots walking there reach the door in the same tick.
fn twin(offset: f32) -> Map {
    crate::util::two_rooms(|parts| {
        let door = parts.zones.iter().find(|z| z.name == "RoomA").expect("RoomA").doors[0].centre;
        parts.spawns = [("Left", -offset), ("Right", offset)]
            .map(|(name, dx)| Spawn { name: name.into(), pos: Vec2::new(door.x + dx, 5.0) })
            .into();
        parts.sequence.clear();
        parts.zones.iter_mut().for_each(|z| z.blocks.clear());
    })
}

#[test]
fn when_two_robots_reach_a_free_room_in_one_tick_the_lower_id_wins() {
    let map = twin(4.0);
    let s = check(
        &map,
        &MatchConfig::default(),
        1,
        &["Ann", "Bob"],
        "
        Ann goTo RoomA
        Bob goTo RoomA
        run until Bob state(collided)
        run until Ann state(arrived)
        Ann sees in(RoomA)
        Bob lacks in(RoomA)
        Bob sees occupied(RoomA) at(Hall)
        ",
    );
    // Both walked the same path; only the door decided between them.
    assert_eq!(s.game.robot_stats(bw4t_sim::RobotId(1)).map(|r| r.rooms_entered), Some(0));
}

#[test]
fn robots_pass_through_each_other_unless_collisions_are_on() {
    let map = twin(12.0);
    let script = "
        Ann goTo Hall
        Bob goTo Hall
        run 2
        Ann sees state(traveling)
        Bob sees state(traveling)
    ";
    // Both head for the hall's centre from opposite ends.
    let apart = check(&map, &MatchConfig::default(), 1, &["Ann", "Bob"], script);
    let mut apart = apart;
    apart.line("run until Bob state(arrived)");
    apart.line("Ann sees state(arrived)");
    let config = MatchConfig { robot_collisions: true, ..MatchConfig::default() };
    let mut blocked = check(&map, &config, 1, &["Ann", "Bob"], script);
    blocked.line("run until Bob state(collided)");
    blocked.line("Bob ended collided");
    let xs: Vec<f32> = blocked.game.robots().map(|r| r.pos.x).collect();
    assert!(xs[1] - xs[0] >= 2.0 - 1e-3, "robots overlap: {xs:?}");
}

#[test]
fn joining_checks_names_and_spawn_points() {
    let map = twin(4.0);
    let mut game = Match::new(&map, &MatchConfig::default(), 1).expect("match");
    for bad in ["", "1abc", "a b", "ünï", "x-y", "all"] {
        assert_eq!(game.join(bad), Err(JoinError::InvalidName(bad.to_string())));
    }
    let ann = game.join("Ann").expect("first");
    assert_eq!(game.join("Ann"), Err(JoinError::NameTaken("Ann".into())));
    game.join("Bob2").expect("second");
    assert_eq!(game.join("Cat"), Err(JoinError::Full(2)));
    // A robot that leaves frees its spawn point and its name.
    game.leave(ann).expect("leave");
    let again = game.join("Ann").expect("rejoin");
    assert_eq!(again, ann, "the lowest free id is given again");
    assert_eq!(game.robots().find(|r| r.id == again).map(|r| r.pos.x), Some(11.0));
}

#[test]
fn statistics_count_what_robots_do() {
    let s = check_fixed(
        &["Bot1", "Bot2"],
        "
        Bot1 goTo RoomC1
        Bot2 say Bot1 hi
        run until Bot1 state(arrived)
        Bot1 goToBlock Yellow
        run until Bot1 state(arrived)
        Bot1 pickUp
        Bot1 goTo DropZone
        run until Bot1 state(arrived)
        Bot1 putDown
        run 1
        ",
    );
    let ticks = s.game.tick();
    let one = s.game.robot_stats(bw4t_sim::RobotId(0)).expect("Bot1").clone();
    let two = s.game.robot_stats(bw4t_sim::RobotId(1)).expect("Bot2").clone();
    assert_eq!((one.good_drops, one.rooms_entered, one.messages_sent), (1, 2, 0));
    assert_eq!((two.messages_sent, two.idle_ticks), (1, ticks));
    assert!(one.idle_ticks < 10, "{one:?}");
    // FrontDropZone to RoomC1 goes round by LeftHallD and LeftHallC: about 60 units each way.
    assert!(one.distance > 110.0 && one.distance < 150.0, "{one:?}");
    assert_eq!(s.game.stats().messages, 1);
}

#[test]
fn a_block_put_down_in_a_room_lands_near_the_robot_and_on_no_other_block() {
    let s = check_fixed(
        &["Bot1"],
        "
        Bot1 goTo RoomC1
        run until Bot1 in(RoomC1)
        Bot1 goToBlock 11
        run until Bot1 state(arrived)
        Bot1 pickUp
        Bot1 ok
        Bot1 goToBlock 12
        run until Bot1 state(arrived)
        Bot1 putDown
        Bot1 ok
        ",
    );
    let pos = |id: u32| match s.game.blocks().find(|b| b.0 == id).map(|b| b.2) {
        Some(bw4t_sim::BlockPlace::Room { pos, .. }) => pos,
        other => panic!("block {id} is {other:?}"),
    };
    let robot = s.game.robots().next().expect("robot").pos;
    let (put, other) = (pos(11), pos(12));
    assert!((put - other).abs().max_element() >= 1.0, "{put} overlaps {other}");
    assert!(put.distance(robot) <= 1.5, "{put} is not near the robot at {robot}");
    let room = &s.game.map().zones()[s.game.map().zone_named("RoomC1").expect("room")].rect;
    assert!(room.shrunk(0.5).contains(put));
}

#[test]
fn speed_and_tick_rate_are_configurable() {
    let ticks_to_room = |speed: f32| {
        let config = MatchConfig { speed, ticks_per_second: 10, ..MatchConfig::default() };
        let s = check(
            &crate::util::shipped_map("fixed"),
            &config,
            1,
            &["Bot1"],
            "
            Bot1 goTo RoomC1
            run until Bot1 state(arrived)
        ",
        );
        s.game.tick()
    };
    let (slow, fast) = (ticks_to_room(0.5), ticks_to_room(1.0));
    assert!(fast * 2 >= slow - 2 && fast * 2 <= slow + 2, "0.5/tick took {slow} ticks, 1.0/tick {fast}");
    let config = MatchConfig { ticks_per_second: 10, ..MatchConfig::default() };
    assert_eq!(config.seconds(25), 2.5);
    for bad in
        [MatchConfig { speed: 0.0, ..config.clone() }, MatchConfig { ticks_per_second: 0, ..config.clone() }]
    {
        let map = crate::util::shipped_map("fixed");
        assert!(Match::new(&map, &bad, 1).is_err());
    }
}

#[test]
fn places_no_robot_can_reach_are_rejected() {
    let map = crate::util::two_rooms(|parts| {
        parts.zones[0].neighbours.push("Wall".into());
        parts.zones.push(Zone {
            name: "Wall".into(),
            kind: ZoneKind::Blockade,
            rect: Rect::new(Vec2::new(5.0, 15.0), Vec2::new(10.0, 10.0)),
            doors: Vec::new(),
            neighbours: Vec::new(),
            blocks: Vec::new(),
        });
    });
    check(
        &map,
        &MatchConfig::default(),
        1,
        &["Ann"],
        "
        Ann goTo Wall
        Ann rejected unreachable
        Ann goTo RoomA
        Ann ok
    ",
    );
}
