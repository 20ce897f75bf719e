//! The tournament configuration file (TOML) and the fixed list of matches it describes.

use bw4t_agents::Strategy;
use serde::{Deserialize, Serialize};

use crate::external::SeatSpec;

/// Seeds as a count (derived from the master seed) or an explicit list.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Seeds {
    /// This many seeds, derived from the master seed.
    Count(u64),
    /// These seeds.
    List(Vec<u64>),
}

/// One team, as configured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TeamConfig {
    /// Its name in the results.
    pub name: String,
    /// `builtin`, `builtin:STRATEGY`, or a command line run once per robot.
    pub agents: String,
    /// Robots in the team.
    #[serde(default = "three")]
    pub robots: usize,
}

/// A tournament configuration file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TournamentConfig {
    /// Maps: shipped names or paths (native or original BW4T files).
    pub maps: Vec<String>,
    /// A count or a list.
    #[serde(default)]
    pub seeds: Option<Seeds>,
    /// The seed every match seed is derived from.
    #[serde(default)]
    pub master_seed: Option<u64>,
    /// Matches per team and map when seeds are derived (same as `seeds = N`).
    #[serde(default)]
    pub games: Option<u64>,
    /// The last tick of every match.
    #[serde(default = "max_ticks")]
    pub max_ticks: u64,
    /// Times every (team, map, seed) is played.
    #[serde(default = "one")]
    pub repetitions: u32,
    /// External agents' lockstep deadline in milliseconds (0: forever).
    #[serde(default = "deadline")]
    pub deadline_ms: u64,
    /// The teams.
    #[serde(rename = "team", default)]
    pub teams: Vec<TeamConfig>,
}

fn three() -> usize {
    3
}
fn one() -> u32 {
    1
}
fn max_ticks() -> u64 {
    20_000
}
fn deadline() -> u64 {
    1000
}

/// The master seed when the configuration names none.
pub const DEFAULT_MASTER_SEED: u64 = 2026;

/// A configuration with everything resolved: the seed list, team seats.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Resolved {
    /// The maps as given.
    pub maps: Vec<String>,
    /// Every match seed, in order.
    pub seeds: Vec<u64>,
    /// The master seed (also recorded when seeds were listed).
    pub master_seed: u64,
    /// The last tick.
    pub max_ticks: u64,
    /// Repetitions.
    pub repetitions: u32,
    /// Deadline for external agents.
    pub deadline_ms: u64,
    /// The teams.
    pub teams: Vec<TeamConfig>,
}

/// One match of the tournament.
#[derive(Clone, Debug, PartialEq)]
pub struct Planned {
    /// Its place in the fixed order.
    pub index: u64,
    /// `team/map/seed/repetition`.
    pub key: String,
    /// Team index.
    pub team: usize,
    /// Map index.
    pub map: usize,
    /// The seed.
    pub seed: u64,
    /// The repetition.
    pub repetition: u32,
}

/// A configuration that does not make sense.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// Not TOML, or a misspelt or mistyped key (with line and column).
    #[error("{0}")]
    Syntax(#[from] toml::de::Error),
    /// A value out of range or missing.
    #[error("{0}")]
    Invalid(String),
}

impl TournamentConfig {
    /// Parses a configuration file's text.
    pub fn parse(text: &str) -> Result<TournamentConfig, ConfigError> {
        Ok(toml::from_str(text)?)
    }

    /// Checks the configuration and fixes the seed list.
    pub fn resolve(&self) -> Result<Resolved, ConfigError> {
        let bad = |m: String| Err(ConfigError::Invalid(m));
        if self.maps.is_empty() {
            return bad("no maps: give `maps = [\"default\", ...]`".into());
        }
        if self.teams.is_empty() {
            return bad("no teams: add at least one [[team]] with name, agents and robots".into());
        }
        for (i, team) in self.teams.iter().enumerate() {
            if team.name.trim().is_empty() || team.name.contains('/') {
                return bad(format!("team {}: a name is required and may not contain '/'", i + 1));
            }
            if self.teams[..i].iter().any(|t| t.name == team.name) {
                return bad(format!("two teams are called '{}'", team.name));
            }
            if team.robots == 0 {
                return bad(format!("team '{}': robots must be at least 1", team.name));
            }
            seats(team).map_err(ConfigError::Invalid)?;
        }
        if self.repetitions == 0 {
            return bad("repetitions must be at least 1".into());
        }
        let master_seed = self.master_seed.unwrap_or(DEFAULT_MASTER_SEED);
        let seeds = match (&self.seeds, self.games) {
            (Some(Seeds::List(list)), _) if list.is_empty() => return bad("the seed list is empty".into()),
            (Some(Seeds::List(list)), _) => list.clone(),
            (Some(Seeds::Count(n)), _) => derive_seeds(master_seed, *n),
            (None, Some(n)) => derive_seeds(master_seed, n),
            (None, None) => {
                return bad("no seeds: give `seeds = 30`, a list, or `master_seed` with `games`".into());
            }
        };
        if seeds.is_empty() {
            return bad("zero seeds".into());
        }
        Ok(Resolved {
            maps: self.maps.clone(),
            seeds,
            master_seed,
            max_ticks: self.max_ticks,
            repetitions: self.repetitions,
            deadline_ms: self.deadline_ms,
            teams: self.teams.clone(),
        })
    }
}

/// `n` match seeds drawn from `master`: the same master always gives the same seeds.
pub fn derive_seeds(master: u64, n: u64) -> Vec<u64> {
    let mut rng = bw4t_map::SeededRng::new(master);
    // Seeds small enough to type back in.
    (0..n).map(|_| rng.next_u64() % 1_000_000_000).collect()
}

impl Resolved {
    /// Every match, in the fixed order: map, then seed, then repetition, then team, so
    /// all teams play each (map, seed) next to each other.
    pub fn plan(&self) -> Vec<Planned> {
        let mut out = Vec::new();
        for (map, map_spec) in self.maps.iter().enumerate() {
            for &seed in &self.seeds {
                for repetition in 0..self.repetitions {
                    for (team, t) in self.teams.iter().enumerate() {
                        let key = format!("{}/{map_spec}/{seed}/{repetition}", t.name);
                        out.push(Planned { index: out.len() as u64, key, team, map, seed, repetition });
                    }
                }
            }
        }
        out
    }
}

/// The seats of a team.
pub fn seats(team: &TeamConfig) -> Result<Vec<SeatSpec>, String> {
    let agents = team.agents.trim();
    if agents == "builtin" || agents.starts_with("builtin:") {
        let name = agents.strip_prefix("builtin:").unwrap_or("coop");
        let strategy = Strategy::named(name).ok_or_else(|| {
            let known: Vec<&str> = Strategy::ALL.iter().map(|s| s.name()).collect();
            format!("team '{}': unknown strategy '{name}' (known: {})", team.name, known.join(", "))
        })?;
        Ok((1..=team.robots).map(|i| SeatSpec::Builtin { name: format!("Bot{i}"), strategy }).collect())
    } else if agents.is_empty() {
        Err(format!("team '{}': agents is empty", team.name))
    } else {
        let command = agents.to_string();
        Ok((1..=team.robots)
            .map(|i| SeatSpec::External { name: format!("Agent{i}"), command: command.clone() })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"
        maps = ["default", "path/to/a/map"]
        seeds = 30
        max_ticks = 20000

        [[team]]
        name = "coop"
        agents = "builtin"
        robots = 3

        [[team]]
        name = "solo"
        agents = "builtin:baseline"
        robots = 3
    "#;

    #[test]
    fn the_documented_example_resolves_and_plans_paired_matches() {
        let resolved = TournamentConfig::parse(EXAMPLE).expect("parses").resolve().expect("valid");
        assert_eq!(resolved.seeds.len(), 30);
        assert_eq!(resolved.seeds, derive_seeds(DEFAULT_MASTER_SEED, 30));
        let plan = resolved.plan();
        assert_eq!(plan.len(), 2 * 30 * 2);
        // Both teams play the same (map, seed) next to each other.
        assert_eq!((plan[0].team, plan[1].team, plan[0].seed), (0, 1, plan[1].seed));
        assert!(plan.iter().enumerate().all(|(i, p)| p.index == i as u64));
    }

    #[test]
    fn seeds_can_be_listed_or_derived_from_a_master_seed() {
        let with = |extra: &str| {
            TournamentConfig::parse(&EXAMPLE.replace("seeds = 30", extra)).expect("parses").resolve()
        };
        assert_eq!(with("seeds = [1, 2, 3]").expect("valid").seeds, [1, 2, 3]);
        assert_eq!(with("master_seed = 7\ngames = 4").expect("valid").seeds, derive_seeds(7, 4));
        assert!(with("").is_err());
    }

    #[test]
    fn mistakes_are_named() {
        let cases = [
            (
                EXAMPLE.replace("robots = 3\n\n        [[team]]", "robots = 0\n\n        [[team]]"),
                "robots must be at least 1",
            ),
            (EXAMPLE.replace("builtin:baseline", "builtin:psychic"), "unknown strategy 'psychic'"),
            (EXAMPLE.replace("name = \"solo\"", "name = \"coop\""), "two teams are called 'coop'"),
            (EXAMPLE.replace("max_ticks", "max_tick"), "unknown field `max_tick`"),
            (EXAMPLE.replace("maps = [\"default\", \"path/to/a/map\"]", "maps = []"), "no maps"),
        ];
        for (text, expected) in cases {
            let err =
                TournamentConfig::parse(&text).and_then(|c| c.resolve()).expect_err("invalid").to_string();
            assert!(err.contains(expected), "expected '{expected}' in {err}");
        }
    }
}
