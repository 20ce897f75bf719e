use bw4t_agents::Strategy;
use bw4t_runner::{Seat, play_headless};
use bw4t_sim::MatchConfig;

use crate::util::shipped_map;

fn team(strategy: Strategy, n: usize) -> Vec<Seat> {
    (0..n)
        .map(|i| Seat { name: format!("Bot{}", i + 1), agent: strategy.agent(&format!("Bot{}", i + 1)) })
        .collect()
}

#[test]
fn explore_figures() {
    for map_name in ["default", "fixed"] {
        let map = shipped_map(map_name);
        for strategy in Strategy::ALL {
            for n in [1, 3, 10] {
                let mut ticks = Vec::new();
                for seed in 0..10 {
                    let (game, reason) =
                        play_headless(&map, &MatchConfig::default(), seed, team(strategy, n), 30_000, None)
                            .expect("play");
                    ticks.push(if reason == "completed" {
                        game.tick() as i64
                    } else {
                        -(game.sequence_index() as i64)
                    });
                }
                eprintln!("{map_name} {} n={n}: {ticks:?}", strategy.name());
            }
        }
    }
}
