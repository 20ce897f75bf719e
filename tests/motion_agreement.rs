//! The kinematic motion against the stepped reference: on every shipped map, the built-in
//! teams and random orders give the same arrivals, collisions, completions and digests.
//! The tolerance is zero: both motions run the same character controller against the same
//! static colliders, and a robot's body only ever mirrors the position the controller gave.

use bw4t_agents::{MatchSetup, Strategy};
use bw4t_protocol::{Recorder, ReplayMeta};
use bw4t_sim::{Match, MatchConfig, Motion, OrderEnd, RandomPlay};

use crate::util::{SharedBuffer, shipped_map};

/// Every map in `maps/`, by name.
fn shipped_maps() -> Vec<String> {
    let dir = format!("{}/maps", repo_root!());
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{dir}: {e}"))
        .filter_map(|entry| {
            let path = entry.expect("directory entry").path();
            (path.extension()? == "toml").then(|| path.file_stem()?.to_str().map(str::to_string))?
        })
        .collect();
    names.sort();
    assert!(names.len() >= 7, "shipped maps: {names:?}");
    names
}

fn config(motion: Motion) -> MatchConfig {
    MatchConfig { motion, ..MatchConfig::default() }
}

/// A built-in team's whole match as its replay, with the digest after every tick.
fn team_replay(map: &str, strategy: Strategy, robots: usize, seed: u64, motion: Motion) -> String {
    let mut setup = MatchSetup::builtin_team(shipped_map(map), robots, strategy);
    setup.seed = seed;
    setup.game = config(motion);
    setup.max_ticks = Some(4000);
    let blank = Match::new(&setup.map, &setup.game, seed).expect("match");
    let buffer = SharedBuffer::default();
    let meta = ReplayMeta { digest_every: 1, max_ticks: setup.max_ticks, ..ReplayMeta::default() };
    let mut recorder = Recorder::new(Box::new(buffer.clone()), &blank, meta);
    let (game, reason) = bw4t_runner::play_headless(&setup, Some(&mut recorder)).expect("match plays");
    recorder.finish(&game, reason).expect("replay written");
    buffer.text()
}

/// Random orders for `ticks` ticks: every order's end (arrival, collision, ...) and the
/// digest after every tick.
fn random_play(
    map: &str,
    robots: usize,
    seed: u64,
    ticks: u64,
    motion: Motion,
) -> (Vec<(u64, Vec<OrderEnd>, u64)>, String) {
    let mut game = Match::new(&shipped_map(map), &config(motion), seed).expect("match");
    for i in 0..robots {
        game.join(&format!("R{i}")).expect("join");
    }
    let mut play = RandomPlay::new(seed);
    let mut trace = Vec::new();
    for _ in 0..ticks {
        play.act(&mut game);
        let report = game.step();
        trace.push((report.tick, report.ended, game.digest()));
    }
    (trace, format!("{:?} {:?}", game.stats(), play.accepted()))
}

#[test]
fn built_in_teams_play_the_same_match_under_both_motions() {
    for (i, map) in shipped_maps().iter().enumerate() {
        for (strategy, robots) in [(Strategy::Cooperative, 3), (Strategy::Baseline, 2), (Strategy::Random, 4)]
        {
            let seed = 11 + i as u64;
            let stepped = team_replay(map, strategy, robots, seed, Motion::Stepped);
            let kinematic = team_replay(map, strategy, robots, seed, Motion::Kinematic);
            assert!(stepped.lines().count() > 100, "{map} {strategy:?}: a real match");
            assert!(stepped == kinematic, "{map} {strategy:?}: the motions' replays differ");
        }
    }
}

#[test]
fn random_orders_end_the_same_under_both_motions() {
    let mut ends = 0;
    for (i, map) in shipped_maps().iter().enumerate() {
        let seed = 101 + i as u64;
        let (stepped, stepped_totals) = random_play(map, 6, seed, 1500, Motion::Stepped);
        let (kinematic, kinematic_totals) = random_play(map, 6, seed, 1500, Motion::Kinematic);
        for (a, b) in stepped.iter().zip(&kinematic) {
            assert_eq!(a, b, "{map}: tick {}", a.0);
        }
        assert_eq!(stepped_totals, kinematic_totals, "{map}");
        ends += stepped.iter().map(|(_, ended, _)| ended.len()).sum::<usize>();
    }
    assert!(ends > 500, "random play ended only {ends} orders");
}
