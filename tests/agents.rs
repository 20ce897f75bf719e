use bw4t_agents::MatchSetup;
use bw4t_agents::Strategy;
use bw4t_map::Map;
use bw4t_runner::play_headless;

use crate::util::{fixture_text, shipped_map};

/// Every match of the built-in team must end within this many ticks.
const TICK_LIMIT: u64 = 20_000;

fn team(map: &Map, seed: u64, strategy: Strategy, n: usize) -> MatchSetup {
    let mut setup = MatchSetup::builtin_team(map.clone(), n, strategy);
    setup.seed = seed;
    setup.max_ticks = Some(TICK_LIMIT);
    setup
}

/// Every map shipped in `maps/`, by file stem.
pub fn shipped_maps() -> Vec<(String, Map)> {
    let dir = std::path::Path::new(repo_root!()).join("maps");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("maps dir")
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect();
    names.sort();
    names.into_iter().map(|n| (n.clone(), shipped_map(&n))).collect()
}

/// Two shipped maps and the playable map fixtures in the original BW4T format (the original
/// files themselves are played in `original_maps`).
pub fn all_maps() -> Vec<(String, Map)> {
    let mut maps: Vec<(String, Map)> =
        ["default", "fixed"].iter().map(|n| (n.to_string(), shipped_map(n))).collect();
    for file in ["bw4t-xml/fixed-content.xml", "bw4t-xml/random-content.xml", "bw4t-xml/small.xml"] {
        let map = Map::parse(&fixture_text(file), file).unwrap_or_else(|e| panic!("{file}: {e}"));
        maps.push((file.to_string(), map));
    }
    maps
}

/// Ticks to complete, per team size, for `seeds` seeds; panics naming any match that did not complete.
pub fn ticks_to_complete(
    map_name: &str,
    map: &Map,
    strategy: Strategy,
    sizes: &[usize],
    seeds: u64,
) -> Vec<u64> {
    let mut all = Vec::new();
    for &n in sizes.iter().filter(|&&n| n <= map.spawns().len()) {
        for seed in 0..seeds {
            let (game, reason) = play_headless(&team(map, seed, strategy, n), None).expect("play");
            assert_eq!(
                reason,
                "completed",
                "{} team of {n} on {map_name}, seed {seed}: sequence {}/{} after {} ticks",
                strategy.name(),
                game.sequence_index(),
                game.sequence().len(),
                game.tick()
            );
            all.push(game.tick());
        }
    }
    all
}

#[test]
fn the_cooperative_team_completes_every_map_with_one_to_ten_robots() {
    for (name, map) in all_maps() {
        let ticks =
            ticks_to_complete(&name, &map, Strategy::Cooperative, &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10], 4);
        assert!(!ticks.is_empty());
    }
}

#[test]
fn the_baseline_completes_too_but_teamwork_is_faster() {
    let (mut coop_total, mut baseline_total) = (0, 0);
    for (name, map) in all_maps() {
        let baseline = ticks_to_complete(&name, &map, Strategy::Baseline, &[1, 3, 10], 2);
        let coop = ticks_to_complete(&name, &map, Strategy::Cooperative, &[1, 3, 10], 2);
        baseline_total += baseline.iter().sum::<u64>();
        coop_total += coop.iter().sum::<u64>();
    }
    assert!(
        coop_total * 10 < baseline_total * 8,
        "coop {coop_total} ticks in all, baseline {baseline_total}"
    );
}

#[test]
fn a_headless_match_is_the_same_every_time() {
    let map = shipped_map("default");
    let run = || {
        let (game, _) = play_headless(&team(&map, 42, Strategy::Cooperative, 4), None).expect("play");
        (game.tick(), game.digest())
    };
    assert_eq!(run(), run());
}

#[test]
fn every_shipped_map_is_completed_by_the_builtin_team() {
    let maps = shipped_maps();
    assert!(maps.len() >= 7, "maps/ holds {} maps", maps.len());
    for (name, map) in maps {
        let problems = bw4t_map::check_parts(map.parts(), None);
        assert!(problems.iter().all(|p| !p.is_error()), "maps/{name}.toml: {problems:?}");
        // Every shipped map is built into the binary, so its name works anywhere.
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_bw4t"))
            .args(["map", "show", &name])
            .output()
            .expect("run");
        assert!(out.status.success(), "bw4t map show {name}: {}", String::from_utf8_lossy(&out.stderr));
        // Big maps get a bigger team so the test stays quick.
        let n = if map.zones().len() > 100 { 10 } else { 3 }.min(map.spawns().len());
        let ticks = ticks_to_complete(&name, &map, Strategy::Cooperative, &[n], 1);
        assert_eq!(ticks.len(), 1);
    }
}
