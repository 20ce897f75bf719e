//! The cooperative team's progress rule: a robot claims only positions in the look-ahead
//! window `[index, index + team)`, a block in hand included, so the team never ends up with
//! every robot holding a block for a later position and nobody fetching the next one.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use bw4t_agents::{Agent, Observation, Strategy};
use bw4t_map::{Colour, Map};
use bw4t_protocol::Said;
use bw4t_runner::{Seat, play_headless};
use bw4t_sim::{Action, Beliefs, MatchConfig, MoveState, Percept, PerceptDelta, Receiver};

use crate::util::{bw4t_within, shipped_map};

/// Every match of these tests must end within this many ticks.
const TICK_LIMIT: u64 = 20_000;

/// A generated grid of `rows` x `cols` rooms with random content drawn from the match seed
/// (a six-colour sequence and 30 more blocks), so that every seed plays a different match.
fn random_grid(rows: usize, cols: usize) -> Map {
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

/// The position a claim (`getting_for`, `bringing`) names.
fn claimed_position(text: &str) -> Option<usize> {
    let said = Said::from_text(text)?;
    ["getting_for", "bringing"].contains(&said.kind.as_str()).then_some(said.position? as usize)
}

/// The positions this list of actions claims.
fn claims_in(actions: &[Action]) -> Vec<usize> {
    actions
        .iter()
        .filter_map(|a| match a {
            Action::SendMessage { text, .. } => claimed_position(text),
            _ => None,
        })
        .collect()
}

/// What the spies saw during a match.
#[derive(Default)]
struct Record {
    /// (tick, loser, position): a robot lost a position it claimed in the same tick as a
    /// player with a smaller name, while holding a block.
    lost_while_holding: Vec<(u64, String, usize)>,
    /// Claims outside `[index, index + team)`, described.
    outside_window: Vec<String>,
}

/// A built-in agent, watched from outside: it sees the same observations and actions.
struct Spy {
    name: String,
    inner: Box<dyn Agent>,
    beliefs: Beliefs,
    /// The tick of the last decision and the positions it claimed.
    last_claims: (u64, Vec<usize>),
    record: Arc<Mutex<Record>>,
}

impl Agent for Spy {
    fn decide(&mut self, obs: &Observation) -> Vec<Action> {
        for delta in &obs.percepts {
            self.beliefs.apply(delta);
        }
        let facts = self.beliefs.facts();
        let holding = facts.iter().any(|p| matches!(p, Percept::Holding(_)));
        let index = facts
            .iter()
            .find_map(|p| match p {
                Percept::SequenceIndex(i) => Some(*i as usize),
                _ => None,
            })
            .unwrap_or(0);
        let team = 1 + facts.iter().filter(|p| matches!(p, Percept::Player(_))).count();
        let mut record = self.record.lock().expect("record");
        for (from, text) in self.beliefs.take_messages() {
            let Some(pos) = claimed_position(&text) else { continue };
            let same_tick = self.last_claims.0 + 1 == obs.tick && self.last_claims.1.contains(&pos);
            if same_tick && holding && *from < *self.name {
                record.lost_while_holding.push((obs.tick, self.name.clone(), pos));
            }
        }
        let actions = self.inner.decide(obs);
        let claims = claims_in(&actions);
        for &pos in &claims {
            if !(index..index + team).contains(&pos) {
                record.outside_window.push(format!(
                    "{} at tick {} claimed {pos} with index {index} and {team} robots",
                    self.name, obs.tick
                ));
            }
        }
        self.last_claims = (obs.tick, claims);
        actions
    }
}

/// Plays the cooperative team of `robots`, every agent watched by a spy.
fn play_watched(map: &Map, seed: u64, robots: usize) -> (bw4t_protocol::EndReason, u64, Record) {
    let record = Arc::new(Mutex::new(Record::default()));
    let seats = (1..=robots)
        .map(|i| {
            let name = format!("Bot{i}");
            let spy = Spy {
                name: name.clone(),
                inner: Strategy::Cooperative.agent(&name),
                beliefs: Beliefs::default(),
                last_claims: (u64::MAX - 1, Vec::new()),
                record: Arc::clone(&record),
            };
            Seat { name, agent: Box::new(spy) }
        })
        .collect();
    let (game, reason) =
        play_headless(map, &MatchConfig::default(), seed, seats, TICK_LIMIT, None).expect("play");
    let record = Arc::try_unwrap(record).map_err(|_| "spies still held").expect("record").into_inner();
    (reason, game.tick(), record.expect("record"))
}

/// The match where the deadlock was found: Bot1 and Bot2 claim position 1 in the same tick,
/// Bot2 picking its block up as it claims; it loses, and used to claim position 4 with the
/// block (beyond the window), so that Bot1 took position 4 too and nobody fetched position 2.
const SEED: u64 = 122;

#[test]
fn a_robot_that_loses_a_claim_while_holding_its_block_does_not_stall_the_team() {
    let map = random_grid(2, 3);
    let (reason, ticks, record) = play_watched(&map, SEED, 3);
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
                let (reason, ticks, record) = play_watched(map, seed, robots);
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
