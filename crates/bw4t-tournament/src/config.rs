//! The tournament configuration file (TOML) and the fixed list of matches it describes.

use std::fmt;
use std::str::FromStr;

use bw4t_agents::{Player, Seat, Strategy, named_seats};
use serde::{Deserialize, Serialize};

/// Seeds as a count (derived from the master seed) or an explicit list.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Seeds {
    /// This many seeds, derived from the master seed.
    Count(u64),
    /// These seeds.
    List(Vec<u64>),
}

/// Who plays a team's robots.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Agents {
    /// One entry for every robot: `builtin`, `builtin:STRATEGY` or a command line run once
    /// per robot.
    Each(String),
    /// One entry per robot, in robot order, each `builtin`, `builtin:STRATEGY` or a command
    /// line: a team that mixes built-in and external agents.
    PerRobot(Vec<String>),
}

/// One team, as configured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TeamConfig {
    /// Its name in the results.
    pub name: String,
    /// `"builtin"`, `"builtin:STRATEGY"`, a command line, or a list of these, one per robot.
    pub agents: Agents,
    /// Robots in the team (default: the list's length, or 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robots: Option<usize>,
}

/// One team, resolved: its robot count fixed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Team {
    /// Its name in the results.
    pub name: String,
    /// Who plays its robots.
    pub agents: Agents,
    /// Robots in the team.
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
    /// The last tick of every match (default: each map's own, as `bw4t_runner::TickLimit`
    /// derives it).
    #[serde(default)]
    pub max_ticks: Option<u64>,
    /// Times every (team, map, seed) is played.
    #[serde(default = "one")]
    pub repetitions: u32,
    /// External agents' lockstep deadline in milliseconds (0: forever).
    #[serde(default = "deadline")]
    pub deadline_ms: u64,
    /// Wall seconds a match with external agents may take before it is ended as
    /// `interrupted` (its row says `out_of_time`); none by default.
    #[serde(default)]
    pub wall_budget_s: Option<u64>,
    /// The teams.
    #[serde(rename = "team", default)]
    pub teams: Vec<TeamConfig>,
    /// Whether external agents may send messages (off: the server refuses every one).
    /// Built-in agents are not held to it: give them a strategy that does not talk.
    #[serde(default = "yes")]
    pub messages: bool,
}

/// Robots of a team that names one agent for all and no count.
const DEFAULT_ROBOTS: usize = 3;

fn one() -> u32 {
    1
}
fn deadline() -> u64 {
    1000
}
fn yes() -> bool {
    true
}
fn is_true(b: &bool) -> bool {
    *b
}

/// The master seed when the configuration names none.
pub(crate) const DEFAULT_MASTER_SEED: u64 = 2026;

/// A configuration with everything resolved: the seed list, team seats.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Resolved {
    /// The maps as given.
    pub maps: Vec<String>,
    /// Every match seed, in order.
    pub seeds: Vec<u64>,
    /// The master seed (also recorded when seeds were listed).
    pub master_seed: u64,
    /// The last tick, when the configuration gives one; each map's own otherwise.
    pub max_ticks: Option<u64>,
    /// Repetitions.
    pub repetitions: u32,
    /// Deadline for external agents.
    pub deadline_ms: u64,
    /// Wall-time budget of a match with external agents, in seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_budget_s: Option<u64>,
    /// The teams.
    pub teams: Vec<Team>,
    /// Whether external agents may send messages; left out of the file (and so of the
    /// configuration's hash) when they may.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub messages: bool,
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
    #[error(transparent)]
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
        let mut teams = Vec::with_capacity(self.teams.len());
        for (i, team) in self.teams.iter().enumerate() {
            if team.name.trim().is_empty() || team.name.contains('/') {
                return bad(format!("team {}: a name is required and may not contain '/'", i + 1));
            }
            if self.teams[..i].iter().any(|t| t.name == team.name) {
                return bad(format!("two teams are called '{}'", team.name));
            }
            let robots = match (&team.agents, team.robots) {
                (Agents::PerRobot(list), Some(n)) if n != list.len() => {
                    return bad(format!(
                        "team '{}': robots = {n} but agents lists {}",
                        team.name,
                        crate::plural(list.len(), "entry")
                    ));
                }
                (Agents::PerRobot(list), _) => list.len(),
                (Agents::Each(_), n) => n.unwrap_or(DEFAULT_ROBOTS),
            };
            if robots == 0 {
                return bad(format!("team '{}': robots must be at least 1", team.name));
            }
            let team = Team { name: team.name.clone(), agents: team.agents.clone(), robots };
            seats(&team).map_err(ConfigError::Invalid)?;
            teams.push(team);
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
        if self.wall_budget_s == Some(0) {
            return bad("wall_budget_s must be at least 1 (leave it out for no budget)".into());
        }
        Ok(Resolved {
            maps: self.maps.clone(),
            seeds,
            master_seed,
            max_ticks: self.max_ticks,
            repetitions: self.repetitions,
            deadline_ms: self.deadline_ms,
            wall_budget_s: self.wall_budget_s,
            teams,
            messages: self.messages,
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

    /// The shard (from 0) of `n` that plays match `p`. Matches are dealt round the shards
    /// with each team starting one shard further on, so every shard gets an even share of
    /// every team (and, in plan order, of maps and seeds); a slow team does not land on one
    /// machine. Depends only on the match's index, so resume and merge still line up.
    pub fn shard_of(&self, p: &Planned, n: u64) -> u64 {
        let teams = self.teams.len().max(1) as u64;
        // The plan puts teams innermost: index = group * teams + team.
        let (group, team) = (p.index / teams, p.index % teams);
        (group + team) % n.max(1)
    }
}

/// One share of a tournament's matches: `i/n`, the `i`-th (from 1) of `n`, as `--shard`
/// gives it and the manifest records it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Shard {
    /// Which share, from 1.
    pub index: u64,
    /// How many shares.
    pub count: u64,
}

/// Text that is not a shard `i/n` with `1 <= i <= n`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("'{0}' is not i/n with 1 <= i <= n (e.g. 1/4)")]
pub struct ShardError(String);

impl Shard {
    /// Whether this shard plays match `p` of `resolved` (see [`Resolved::shard_of`]).
    pub fn plays(self, resolved: &Resolved, p: &Planned) -> bool {
        resolved.shard_of(p, self.count) == self.index - 1
    }
}

impl FromStr for Shard {
    type Err = ShardError;

    fn from_str(text: &str) -> Result<Shard, ShardError> {
        let parsed =
            text.split_once('/').and_then(|(i, n)| Some((i.trim().parse().ok()?, n.trim().parse().ok()?)));
        match parsed {
            Some((index, count)) if count >= 1 && (1..=count).contains(&index) => Ok(Shard { index, count }),
            _ => Err(ShardError(text.to_string())),
        }
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl TryFrom<String> for Shard {
    type Error = ShardError;

    fn try_from(text: String) -> Result<Shard, ShardError> {
        text.parse()
    }
}

impl From<Shard> for String {
    fn from(shard: Shard) -> String {
        shard.to_string()
    }
}

/// The seats of a team, in robot order: built-in ones named `Bot1`, `Bot2`, ..., external
/// ones `Agent1`, `Agent2`, ..., each kind counted on its own (as `bw4t run` names them).
pub fn seats(team: &Team) -> Result<Vec<Seat>, String> {
    let entries: Vec<&str> = match &team.agents {
        Agents::Each(entry) => vec![entry.as_str(); team.robots],
        Agents::PerRobot(list) => list.iter().map(String::as_str).collect(),
    };
    let players = entries.into_iter().map(|entry| {
        let entry = entry.trim();
        let strategy = builtin_strategy(entry).map_err(|e| format!("team '{}': {e}", team.name))?;
        Ok(strategy.map_or_else(|| Player::Program(entry.to_string()), Player::Builtin))
    });
    Ok(named_seats(players.collect::<Result<Vec<_>, String>>()?))
}

/// The strategy an agents entry names (`builtin`, `builtin:STRATEGY`), `None` for a command
/// line, or an error for an empty entry or one that looks like a misspelt `builtin`, which
/// would otherwise be run as a command that cannot start.
pub fn builtin_strategy(entry: &str) -> Result<Option<Strategy>, String> {
    let known = || Strategy::ALL.iter().map(|s| s.name()).collect::<Vec<_>>().join(", ");
    if entry.is_empty() {
        return Err("an agents entry is empty".into());
    }
    if entry == "builtin" || entry.starts_with("builtin:") {
        let name = entry.strip_prefix("builtin:").unwrap_or("coop");
        let strategy =
            Strategy::named(name).ok_or_else(|| format!("unknown strategy '{name}' (known: {})", known()))?;
        return Ok(Some(strategy));
    }
    let first = entry.split([' ', '\t', ':']).next().unwrap_or(entry);
    let lower = first.to_ascii_lowercase();
    if lower.starts_with("builtin") || edit_distance(&lower, "builtin") <= 2 {
        return Err(format!(
            "agents \"{entry}\" looks like a misspelt built-in team: write builtin or builtin:STRATEGY \
             (strategies: {}), or a command line",
            known()
        ));
    }
    Ok(None)
}

/// The optimal-string-alignment distance: insertions, deletions, substitutions and swaps of
/// two neighbouring characters each count 1.
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut best = (d[i - 1][j] + 1).min(d[i][j - 1] + 1).min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                best = best.min(d[i - 2][j - 2] + 1);
            }
            d[i][j] = best;
        }
    }
    d[a.len()][b.len()]
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

    #[test]
    fn a_team_can_mix_builtin_and_external_agents() {
        let text = EXAMPLE.replace(
            "agents = \"builtin:baseline\"\n        robots = 3",
            "agents = [\"builtin\", \"python3 a.py\", \"builtin:baseline\"]",
        );
        let resolved = TournamentConfig::parse(&text).expect("parses").resolve().expect("valid");
        let team = &resolved.teams[1];
        assert_eq!(team.robots, 3);
        let seats = seats(team).expect("seats");
        let seats: Vec<(&str, String)> = seats.iter().map(|s| (s.name.as_str(), s.player.kind())).collect();
        assert_eq!(
            seats,
            [
                ("Bot1", "builtin:coop".to_string()),
                ("Agent1", "the program `python3 a.py`".to_string()),
                ("Bot2", "builtin:baseline".to_string()),
            ]
        );
        let wrong = text.replace("\"builtin:baseline\"]", "\"builtin:baseline\"]\n        robots = 2");
        let err = TournamentConfig::parse(&wrong).expect("parses").resolve().expect_err("count differs");
        assert!(err.to_string().contains("robots = 2 but agents lists 3 entries"), "{err}");
    }

    #[test]
    fn a_misspelt_builtin_is_refused_with_the_strategies() {
        let strategies: Vec<&str> = bw4t_agents::Strategy::ALL.iter().map(|s| s.name()).collect();
        let strategies = strategies.join(", ");
        for typo in ["biultin", "bultin", "Builtin", "builtin-coop", "builtins:coop"] {
            let text = EXAMPLE.replace("\"builtin:baseline\"", &format!("\"{typo}\""));
            let err = TournamentConfig::parse(&text).expect("parses").resolve().expect_err(typo).to_string();
            assert!(
                err.contains("team 'solo'") && err.contains("misspelt") && err.contains(&strategies),
                "{err}"
            );
        }
        for command in ["python3 agent.py", "./builder", "bash run.sh"] {
            assert_eq!(builtin_strategy(command), Ok(None), "{command}");
        }
    }

    #[test]
    fn shards_get_an_even_share_of_every_team() {
        let text = EXAMPLE.replace("seeds = 30", "seeds = 6");
        let resolved = TournamentConfig::parse(&text).expect("parses").resolve().expect("valid");
        let plan = resolved.plan();
        for n in [2u64, 3, 4] {
            for shard in 0..n {
                let mine: Vec<&Planned> = plan.iter().filter(|p| resolved.shard_of(p, n) == shard).collect();
                for team in 0..2 {
                    let count = mine.iter().filter(|p| p.team == team).count() as f64;
                    let even = plan.len() as f64 / 2.0 / n as f64;
                    assert!((count - even).abs() <= 1.0, "shard {shard}/{n}, team {team}: {count} vs {even}");
                }
                let maps: std::collections::BTreeSet<usize> = mine.iter().map(|p| p.map).collect();
                assert_eq!(maps.len(), 2, "shard {shard}/{n} plays every map");
            }
        }
    }

    #[test]
    fn a_shard_is_read_as_i_of_n_and_its_shares_cover_the_plan_once() {
        assert_eq!("2/3".parse(), Ok(Shard { index: 2, count: 3 }));
        assert_eq!(Shard { index: 2, count: 3 }.to_string(), "2/3");
        for bad in ["0/2", "3/2", "1/0", "2", "a/b", ""] {
            let err = bad.parse::<Shard>().expect_err(bad).to_string();
            assert!(err.contains(&format!("'{bad}' is not i/n")), "{err}");
        }
        let resolved = TournamentConfig::parse(EXAMPLE).expect("parses").resolve().expect("valid");
        let plan = resolved.plan();
        for count in 1..=4 {
            let shards: Vec<Shard> = (1..=count).map(|index| Shard { index, count }).collect();
            for p in &plan {
                let playing = shards.iter().filter(|s| s.plays(&resolved, p)).count();
                assert_eq!(playing, 1, "match {} in {count} shards", p.index);
            }
        }
    }
}
