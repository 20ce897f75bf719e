//! The named evaluation suite, `bw4t-suite`: tiers from easy to hard, each a fixed set of
//! tasks (teammates, map, seed) in a development and a held-out split, and the tournament
//! that plays an agent on one of them. What a row scores is in `score.rs`.

mod score;

use std::fmt;
use std::str::FromStr;

use bw4t_agents::Strategy;

use crate::config::{Agents, Resolved, Team, derive_seeds};

pub use score::{Outcome, ScoreError, digest_of, score};

/// The suite's name, in every row.
pub const SUITE: &str = "bw4t-suite";
/// The suite's version: tiers, seeds and scoring never change within a version.
pub const SUITE_VERSION: u32 = 1;

/// The maps of the tiers: the two shipped maps whose blocks and sequence follow the match
/// seed, so a seed split is a split of tasks (on the fixed-content maps every seed plays
/// the same match).
pub const MAPS: [&str; 2] = ["default", "side-doors"];

/// The maps of a tier for learners whose observation has one map's size: the default
/// layout only.
const ONE_LAYOUT: [&str; 1] = ["default"];

/// Seeds per map in each split.
pub const DEV_SEEDS: u64 = 5;
/// Seeds per map in the held-out split.
pub const TEST_SEEDS: u64 = 10;

/// Which robots the agent under evaluation plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plays {
    /// Robot 1; the others are built-in teammates.
    One,
    /// Every robot (one copy of the agent per robot).
    All,
}

/// One tier: a team size, who the agent plays, its teammates and whether players may talk.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tier {
    /// Its name on the command line and in rows.
    pub name: &'static str,
    /// What it asks of an agent, in a sentence.
    pub about: &'static str,
    /// Robots in each match.
    pub robots: usize,
    /// Which robots the agent plays.
    pub plays: Plays,
    /// Teammate mixes of the development split: each is the strategies of robots 2, 3, ...
    pub dev_teammates: &'static [&'static [Strategy]],
    /// Teammate mixes of the held-out split (unseen ones, where the tier tests ad hoc
    /// teamwork).
    pub test_teammates: &'static [&'static [Strategy]],
    /// Whether messages are allowed (off: the server refuses every message of the agent,
    /// and its teammates are silent ones).
    pub messages: bool,
    /// Its maps.
    pub maps: &'static [&'static str],
}

use Strategy::{Baseline as BASE, Cooperative as COOP, Ignoring as IGN, Silent as SIL};

/// Every tier, easiest first. One table: the docs' table and the command's help are
/// printed from it.
pub const TIERS: [Tier; 7] = [
    Tier {
        name: "solo",
        about: "one robot alone: find and deliver the whole sequence",
        robots: 1,
        plays: Plays::One,
        dev_teammates: &[&[]],
        test_teammates: &[&[]],
        messages: true,
        maps: &MAPS,
    },
    Tier {
        name: "pair",
        about: "two robots: the agent and one cooperative built-in teammate that talks",
        robots: 2,
        plays: Plays::One,
        dev_teammates: &[&[COOP]],
        test_teammates: &[&[COOP]],
        messages: true,
        maps: &MAPS,
    },
    Tier {
        name: "learn",
        about: "three robots, all played by the agent, on the default layout only: for learners whose observation has one map's size",
        robots: 3,
        plays: Plays::All,
        dev_teammates: &[&[]],
        test_teammates: &[&[]],
        messages: true,
        maps: &ONE_LAYOUT,
    },
    Tier {
        name: "team",
        about: "three robots, all played by the agent: coordinate with copies of itself",
        robots: 3,
        plays: Plays::All,
        dev_teammates: &[&[]],
        test_teammates: &[&[]],
        messages: true,
        maps: &MAPS,
    },
    Tier {
        name: "silent",
        about: "three robots, two silent teammates, and no messages at all",
        robots: 3,
        plays: Plays::One,
        dev_teammates: &[&[SIL, SIL]],
        test_teammates: &[&[SIL, SIL]],
        messages: false,
        maps: &MAPS,
    },
    Tier {
        name: "adhoc",
        about: "three robots with teammates of unknown habits: development teammates cooperate; held-out ones ignore requests or work alone",
        robots: 3,
        plays: Plays::One,
        dev_teammates: &[&[COOP, COOP], &[COOP, SIL]],
        test_teammates: &[&[IGN, IGN], &[BASE, BASE], &[IGN, BASE]],
        messages: true,
        maps: &MAPS,
    },
    Tier {
        name: "crowd",
        about: "six robots: the agent and five cooperative teammates, queueing for rooms and the drop zone",
        robots: 6,
        plays: Plays::One,
        dev_teammates: &[&[COOP, COOP, COOP, COOP, COOP]],
        test_teammates: &[&[COOP, SIL, IGN, COOP, BASE]],
        messages: true,
        maps: &MAPS,
    },
];

/// A tier's development or held-out half.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// For developing and tuning an agent.
    Dev,
    /// Held out: for the numbers a paper reports.
    Test,
}

impl Split {
    /// Its name on the command line and in rows.
    pub fn name(self) -> &'static str {
        match self {
            Split::Dev => "dev",
            Split::Test => "test",
        }
    }
}

impl FromStr for Split {
    type Err = String;

    fn from_str(text: &str) -> Result<Split, String> {
        match text {
            "dev" => Ok(Split::Dev),
            "test" => Ok(Split::Test),
            _ => Err(format!("unknown split '{text}' (dev or test)")),
        }
    }
}

impl fmt::Display for Split {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The tier called `name`, or an error naming the tiers.
pub fn tier(name: &str) -> Result<&'static Tier, String> {
    TIERS.iter().find(|t| t.name == name).ok_or_else(|| {
        let names: Vec<&str> = TIERS.iter().map(|t| t.name).collect();
        format!("unknown tier '{name}' (tiers, easiest first: {})", names.join(", "))
    })
}

impl Tier {
    /// The teammate mixes of `split`.
    pub fn teammates(&self, split: Split) -> &'static [&'static [Strategy]] {
        match split {
            Split::Dev => self.dev_teammates,
            Split::Test => self.test_teammates,
        }
    }

    /// The seeds of `split`: drawn from a master seed made of the suite version, the tier
    /// and the split, so every tier's seeds are its own and the splits never share one.
    pub fn seeds(&self, split: Split) -> Vec<u64> {
        let master = |s: Split| {
            let text = format!("{SUITE}/{SUITE_VERSION}/{}/{}", self.name, s.name());
            bw4t_map::fnv1a(text.bytes())
        };
        let dev = derive_seeds(master(Split::Dev), DEV_SEEDS);
        match split {
            Split::Dev => dev,
            Split::Test => {
                // Drawn long and filtered, so a held-out seed is never a development one.
                let mut test: Vec<u64> = derive_seeds(master(Split::Test), TEST_SEEDS * 2)
                    .into_iter()
                    .filter(|s| !dev.contains(s))
                    .collect();
                test.truncate(TEST_SEEDS as usize);
                test
            }
        }
    }

    /// The agents entry of the agent's seats in the reference (built-in) team: the
    /// cooperative strategy, or the silent one where messages are off.
    pub fn reference_entry(&self) -> String {
        let strategy = if self.messages { Strategy::Cooperative } else { Strategy::Silent };
        format!("builtin:{}", strategy.name())
    }

    /// Whether `entry` may play this tier: where messages are off, a built-in strategy that
    /// talks would talk anyway (built-in players are not held to the server's policy).
    pub fn admits(&self, entry: &str) -> Result<(), String> {
        let talks =
            matches!(crate::builtin_strategy(entry), Ok(Some(Strategy::Cooperative | Strategy::Ignoring)));
        if !self.messages && talks {
            return Err(format!(
                "tier '{}' allows no messages and {entry} talks: evaluate builtin:silent, builtin:baseline or builtin:random there",
                self.name
            ));
        }
        Ok(())
    }

    /// The tournament that plays `entry` (a built-in strategy or a command line) on this
    /// tier's `split`, each task `repetitions` times: one team per teammate mix.
    pub fn tournament(
        &self,
        split: Split,
        entry: &str,
        repetitions: u32,
        deadline_ms: u64,
        wall_budget_s: Option<u64>,
    ) -> Resolved {
        let teams = self
            .teammates(split)
            .iter()
            .enumerate()
            .map(|(i, mix)| {
                let mut agents: Vec<String> = Vec::with_capacity(self.robots);
                match self.plays {
                    Plays::All => agents.resize(self.robots, entry.to_string()),
                    Plays::One => {
                        agents.push(entry.to_string());
                        agents.extend(mix.iter().map(|s| format!("builtin:{}", s.name())));
                    }
                }
                Team {
                    name: format!("{}{}", self.name, i + 1),
                    agents: Agents::PerRobot(agents),
                    robots: self.robots,
                }
            })
            .collect();
        Resolved {
            maps: self.maps.iter().map(|m| m.to_string()).collect(),
            seeds: self.seeds(split),
            master_seed: 0,
            max_ticks: None,
            repetitions,
            deadline_ms,
            wall_budget_s,
            teams,
            messages: self.messages,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_tier_is_well_formed() {
        for tier in &TIERS {
            for split in [Split::Dev, Split::Test] {
                for mix in tier.teammates(split) {
                    let seats = match tier.plays {
                        Plays::One => 1 + mix.len(),
                        Plays::All => tier.robots,
                    };
                    assert_eq!(seats, tier.robots, "{} {split}", tier.name);
                }
                if !tier.messages {
                    assert!(
                        tier.teammates(split).iter().flat_map(|m| m.iter()).all(|s| {
                            matches!(s, Strategy::Silent | Strategy::Baseline | Strategy::Random)
                        })
                    );
                }
                let resolved = tier.tournament(split, "./agent", 2, 1000, None);
                assert!(resolved.teams.iter().all(|t| crate::seats(t).is_ok()));
                let maps = tier.maps.len() as u64;
                assert_eq!(
                    resolved.plan().len() as u64,
                    2 * maps * resolved.seeds.len() as u64 * resolved.teams.len() as u64
                );
            }
        }
    }

    #[test]
    fn splits_are_disjoint_and_fixed() {
        for tier in &TIERS {
            let (dev, test) = (tier.seeds(Split::Dev), tier.seeds(Split::Test));
            assert_eq!(dev.len() as u64, DEV_SEEDS);
            assert_eq!(test.len() as u64, TEST_SEEDS);
            assert!(dev.iter().all(|s| !test.contains(s)), "{}", tier.name);
            assert_eq!(dev, tier.seeds(Split::Dev));
        }
        // Tiers draw their own seeds.
        assert_ne!(TIERS[0].seeds(Split::Dev), TIERS[1].seeds(Split::Dev));
    }

    #[test]
    fn talking_strategies_are_refused_where_messages_are_off() {
        let silent = tier("silent").expect("as made");
        assert!(silent.admits("builtin:coop").expect_err("refused").contains("allows no messages"));
        assert!(silent.admits("builtin:baseline").is_ok());
        assert!(silent.admits("python agent.py").is_ok());
        assert_eq!(silent.reference_entry(), "builtin:silent");
        assert!(tier("nope").expect_err("refused").contains("solo, pair, learn, team, silent, adhoc, crowd"));
    }
}
