//! The cooperative team's progress rule: a robot claims only positions in the look-ahead
//! window `[index, index + team)`, a block in hand included, so the team never ends up with
//! every robot holding a block for a later position and nobody fetching the next one.

use std::sync::Arc;
use std::time::Duration;

use bw4t_agents::{Observation, Strategy};
use bw4t_map::Colour;
use bw4t_protocol::Said;
use bw4t_sim::{Action, MoveState, Percept, PerceptDelta, Receiver};

use crate::coop_language::{claimed, play_team, random_grid};
use crate::util::{bw4t_within, shipped_map};

/// The positions this list of actions claims.
fn claims_in(actions: &[Action]) -> Vec<usize> {
    actions
        .iter()
        .filter_map(|a| match a {
            Action::SendMessage { text, .. } => Said::from_text(text).as_ref().and_then(claimed),
            _ => None,
        })
        .collect()
}

/// The match where the deadlock was found: Bot1 and Bot2 claim position 1 in the same tick,
/// Bot2 picking its block up as it claims; it loses, and used to claim position 4 with the
/// block (beyond the window), so that Bot1 took position 4 too and nobody fetched position 2.
const SEED: u64 = 122;

#[test]
fn a_robot_that_loses_a_claim_while_holding_its_block_does_not_stall_the_team() {
    let map = random_grid(2, 3);
    let (reason, ticks, record) = play_team(&map, SEED, 3, Strategy::Cooperative);
    assert!(
        !record.lost_while_holding.is_empty(),
        "the scenario no longer builds the collision (two claims of one position in one tick, \
         the loser holding its block); pick another seed"
    );
    assert_eq!(record.outside_window, Vec::<String>::new());
    assert_eq!(reason, "completed", "after {ticks} ticks; collisions {:?}", record.lost_while_holding);

    // The same match through the binary.
    let dir = std::env::temp_dir().join(format!("bw4t-coop-deadlock-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let file = dir.join("grid.toml");
    std::fs::write(&file, map.to_native()).expect("write map");
    let path = file.to_string_lossy().into_owned();
    let out = bw4t_within(
        &["run", "--map", &path, "--seed", &SEED.to_string(), "--robots", "3", "--json"],
        Duration::from_secs(120),
    );
    let result: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON result");
    assert_eq!(result["completed"], true, "bw4t run: {result}");
    assert_eq!(result["ticks"], ticks, "the binary plays the same match");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The situation of the finding, fed to one agent directly: Bot2 of a team of four picks up
/// the red block 7 for position 0, and Bot1 claimed position 0 in the same tick. The next red
/// position, 5, lies beyond the window `[0, 4)`: Bot2 must not claim it, and puts the block
/// back where it stands.
#[test]
fn a_loser_holding_a_block_needed_only_beyond_the_window_puts_it_back() {
    use Colour::{Blue, Green, Red, White, Yellow};
    let name = |s: &str| -> Arc<str> { s.into() };
    let mut bot2 = Strategy::Cooperative.agent("Bot2");
    let mut add: Vec<Percept> = ["RoomA1", "RoomA2", "RoomB1", "DropZone", "FrontDropZone", "LeftHallA"]
        .into_iter()
        .map(|p| Percept::Place(name(p)))
        .collect();
    add.extend(["Bot1", "Bot3", "Bot4"].map(|p| Percept::Player(name(p))));
    add.extend([
        Percept::OwnName(name("Bot2")),
        Percept::Sequence(vec![Red, Blue, Green, Yellow, White, Red].into()),
        Percept::SequenceIndex(0),
        Percept::At(name("RoomA1")),
        Percept::In(name("RoomA1")),
        Percept::State(MoveState::Arrived),
        Percept::Color(7, Red),
        Percept::AtBlock(7),
    ]);
    let first = Observation {
        tick: 10,
        percepts: vec![PerceptDelta { tick: 10, full: true, add, not: vec![] }],
        ..Observation::default()
    };
    let actions = bot2.decide(&first);
    assert_eq!(claims_in(&actions), vec![0], "{actions:?}");
    assert!(actions.contains(&Action::PickUp(Some(7))), "{actions:?}");

    let said = |from: &str, said: Said| Percept::Message { from: name(from), text: name(&said.to_text()) };
    let bot1_claims = Said {
        colour: Some("Red".into()),
        room: Some("RoomB1".into()),
        position: Some(0),
        ..Said::new("getting_for")
    };
    let second = Observation {
        tick: 11,
        percepts: vec![PerceptDelta {
            tick: 11,
            full: false,
            add: vec![Percept::Holding(7), said("Bot1", bot1_claims)],
            not: vec![Percept::AtBlock(7), Percept::Color(7, Red)],
        }],
        ..Observation::default()
    };
    let actions = bot2.decide(&second);
    assert_eq!(claims_in(&actions), Vec::<usize>::new(), "claims beyond the window: {actions:?}");
    assert!(actions.contains(&Action::PutDown), "puts the block back in the room: {actions:?}");
    assert!(
        !actions.iter().any(|a| matches!(a, Action::SendMessage { to: Receiver::All, text }
                if Said::from_text(text).is_some_and(|s| s.kind == "giving_up" && s.position == Some(0)))),
        "position 0 is Bot1's now, not Bot2's to release: {actions:?}"
    );
}

/// Every match completes and no robot ever claims outside its window: robots 1 to 5, on
/// shipped maps with random content and generated grids. `BW4T_COOP_SEEDS=N` plays N seeds
/// per map and team size instead of the quick default.
#[test]
fn the_cooperative_team_completes_every_seed_and_team_size() {
    let seeds: u64 = std::env::var("BW4T_COOP_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(8);
    let maps = [
        ("default", shipped_map("default")),
        ("side-doors", shipped_map("side-doors")),
        ("2x3 grid", random_grid(2, 3)),
        ("3x4 grid", random_grid(3, 4)),
    ];
    let mut failures = Vec::new();
    let mut played = 0;
    for (map_name, map) in &maps {
        for robots in (1..=5).filter(|&n| n <= map.spawns().len()) {
            for seed in 0..seeds {
                let (reason, ticks, record) = play_team(map, seed, robots, Strategy::Cooperative);
                played += 1;
                if reason != "completed" || !record.outside_window.is_empty() {
                    failures.push(format!(
                        "{map_name}, {robots} robots, seed {}: {reason} after {ticks} ticks; {:?}",
                        seed, record.outside_window
                    ));
                }
            }
        }
    }
    assert!(played >= 4 * 4 * seeds as usize, "played {played}");
    assert!(failures.is_empty(), "{} of {played} matches failed:\n{}", failures.len(), failures.join("\n"));
}
