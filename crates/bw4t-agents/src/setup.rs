//! One match's set-up: the map, seed, settings, who plays each robot and the tick limit.
//! Every front end (headless runs, served matches, arena templates, studies, tournaments,
//! the learning environments) builds a [`MatchSetup`] and refuses the players it cannot
//! seat, by name.

use std::fmt;
use std::sync::Arc;

use bw4t_map::Map;
use bw4t_sim::MatchConfig;

use crate::{Agent, Strategy};

/// Makes an in-process agent for a player name.
pub type AgentFactory = Arc<dyn Fn(&str) -> Box<dyn Agent> + Send + Sync>;

/// Who plays a robot.
#[derive(Clone)]
pub enum Player {
    /// A built-in agent of this strategy.
    Builtin(Strategy),
    /// An in-process agent the caller makes (a test's scripted player, say).
    Agent(AgentFactory),
    /// A program started with `sh -c COMMAND` that connects as the seat's player.
    Program(String),
    /// A remote client that claims the seat with `hello` and the seat's name.
    Remote,
    /// Any remote client, under the name its `hello` gives; open seats come last.
    Open,
    /// A learning robot: its actions come from an environment's `step`.
    Learner,
}

impl Player {
    /// What kind of player this is, in words for errors and logs.
    pub fn kind(&self) -> String {
        match self {
            Player::Builtin(strategy) => format!("builtin:{}", strategy.name()),
            Player::Agent(_) => "an in-process agent".into(),
            Player::Program(command) => format!("the program `{command}`"),
            Player::Remote => "a remote player".into(),
            Player::Open => "an open seat".into(),
            Player::Learner => "a learner".into(),
        }
    }

    /// An in-process agent for the player `name`, if this player is one.
    pub fn agent(&self, name: &str) -> Option<Box<dyn Agent>> {
        match self {
            Player::Builtin(strategy) => Some(strategy.agent(name)),
            Player::Agent(make) => Some(make(name)),
            _ => None,
        }
    }
}

impl fmt::Debug for Player {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.kind())
    }
}

/// Who plays robot `i` of a match: a name and a player.
#[derive(Clone, Debug)]
pub struct Seat {
    /// The player's name (empty for an open seat, whose player names itself).
    pub name: String,
    /// Who plays it.
    pub player: Player,
}

impl Seat {
    /// A seat of a built-in agent.
    pub fn builtin(name: impl Into<String>, strategy: Strategy) -> Seat {
        Seat { name: name.into(), player: Player::Builtin(strategy) }
    }

    /// A seat of an in-process agent made by `make`.
    pub fn agent(name: impl Into<String>, make: AgentFactory) -> Seat {
        Seat { name: name.into(), player: Player::Agent(make) }
    }

    /// A seat of a program, started with `sh -c command`.
    pub fn program(name: impl Into<String>, command: impl Into<String>) -> Seat {
        Seat { name: name.into(), player: Player::Program(command.into()) }
    }

    /// A seat kept for the remote player of this name.
    pub fn remote(name: impl Into<String>) -> Seat {
        Seat { name: name.into(), player: Player::Remote }
    }

    /// A seat for whoever joins first.
    pub fn open() -> Seat {
        Seat { name: String::new(), player: Player::Open }
    }

    /// A seat of a learning robot.
    pub fn learner(name: impl Into<String>) -> Seat {
        Seat { name: name.into(), player: Player::Learner }
    }

    /// The seat's strategy, if a built-in agent plays it.
    pub fn strategy(&self) -> Option<Strategy> {
        match self.player {
            Player::Builtin(strategy) => Some(strategy),
            _ => None,
        }
    }
}

/// `Bot1`, `Bot2`, ...: the names of built-in teammates, as `bw4t run` gives them.
pub fn bot_name(i: usize) -> String {
    format!("Bot{}", i + 1)
}

/// Seats for `players` in robot-id order, named as `bw4t run` names them: built-in agents
/// `Bot1`, `Bot2`, ..., every other player `Agent1`, `Agent2`, ..., each kind counted on
/// its own.
pub fn named_seats(players: impl IntoIterator<Item = Player>) -> Vec<Seat> {
    let (mut bots, mut agents) = (0, 0);
    let name = |player: &Player| match player {
        Player::Builtin(_) => {
            bots += 1;
            format!("Bot{bots}")
        }
        _ => {
            agents += 1;
            format!("Agent{agents}")
        }
    };
    let mut name = name;
    players.into_iter().map(|player| Seat { name: name(&player), player }).collect()
}

/// A match to play: this map, this seed, these settings, these seats, this tick limit.
#[derive(Clone, Debug)]
pub struct MatchSetup {
    /// The map.
    pub map: Map,
    /// The seed of the match's content (blocks, sequence).
    pub seed: u64,
    /// Simulation settings; `ticks_per_second` is also a realtime match's tick rate.
    pub game: MatchConfig,
    /// Who plays each robot, in robot-id order.
    pub seats: Vec<Seat>,
    /// The match ends after this many ticks (`None`: only when the sequence is complete).
    pub max_ticks: Option<u64>,
}

/// A set-up that cannot be played where it was given.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SetupError {
    /// A seat's player cannot play in this front end.
    #[error("seat {robot} ({name}): {kind} cannot play {front_end}")]
    Player {
        /// The robot index, from 1.
        robot: usize,
        /// The seat's name.
        name: String,
        /// What kind of player it is.
        kind: String,
        /// Where it was asked to play (`in a headless match`, ...).
        front_end: &'static str,
    },
    /// Something else is wrong with the set-up.
    #[error("{0}")]
    Invalid(String),
}

impl MatchSetup {
    /// The default settings on `map`: seed 0, no seats, no tick limit.
    pub fn new(map: Map) -> MatchSetup {
        MatchSetup { map, seed: 0, game: MatchConfig::default(), seats: Vec::new(), max_ticks: None }
    }

    /// `robots` built-in agents of `strategy`, named `Bot1`, `Bot2`, ...
    pub fn builtin_team(map: Map, robots: usize, strategy: Strategy) -> MatchSetup {
        let seats = (0..robots).map(|i| Seat::builtin(bot_name(i), strategy)).collect();
        MatchSetup { seats, ..MatchSetup::new(map) }
    }

    /// How many robots the match has.
    pub fn robots(&self) -> usize {
        self.seats.len()
    }

    /// The named seats' player names, in robot-id order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.seats.iter().filter(|s| !matches!(s.player, Player::Open)).map(|s| s.name.as_str())
    }

    /// Checks what holds wherever the match is played: the settings, named seats with
    /// distinct names, open seats last. (A robot beyond the map's spawn points is refused
    /// when it joins, by the match, as a player joining late would be.)
    pub fn check(&self) -> Result<(), SetupError> {
        self.game.validate().map_err(|e| SetupError::Invalid(e.to_string()))?;
        let mut open_seen = false;
        let mut names = std::collections::BTreeSet::new();
        for (i, seat) in self.seats.iter().enumerate() {
            match seat.player {
                Player::Open => open_seen = true,
                _ if open_seen => {
                    return Err(SetupError::Invalid(format!(
                        "seat {} ({}) comes after an open seat; open seats come last",
                        i + 1,
                        seat.name
                    )));
                }
                _ if seat.name.is_empty() => {
                    return Err(SetupError::Invalid(format!("seat {} has no name", i + 1)));
                }
                _ if !names.insert(seat.name.as_str()) => {
                    return Err(SetupError::Invalid(format!("two seats are named '{}'", seat.name)));
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Refuses the first seat whose player `can_play` says no to, naming the front end.
    pub fn only_players(
        &self,
        front_end: &'static str,
        can_play: impl Fn(&Player) -> bool,
    ) -> Result<(), SetupError> {
        match self.seats.iter().enumerate().find(|(_, s)| !can_play(&s.player)) {
            Some((i, seat)) => Err(SetupError::Player {
                robot: i + 1,
                name: seat.name.clone(),
                kind: seat.player.kind(),
                front_end,
            }),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> Map {
        let text = include_str!("../../../maps/default.toml");
        Map::from_native(text).expect("the default map")
    }

    #[test]
    fn a_builtin_team_is_named_like_bw4t_run() {
        let setup = MatchSetup::builtin_team(map(), 3, Strategy::Baseline);
        assert_eq!(setup.names().collect::<Vec<_>>(), ["Bot1", "Bot2", "Bot3"]);
        assert_eq!(setup.seats[2].strategy(), Some(Strategy::Baseline));
        assert!(setup.check().is_ok());
    }

    #[test]
    fn seats_are_named_per_kind_in_robot_order() {
        let players = [Player::Learner, Player::Builtin(Strategy::Silent), Player::Learner, Player::Remote];
        let seats = named_seats(players);
        let names: Vec<&str> = seats.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["Agent1", "Bot1", "Agent2", "Agent3"]);
        assert_eq!(seats[1].strategy(), Some(Strategy::Silent));
    }

    #[test]
    fn check_refuses_what_no_front_end_can_play() {
        let mut setup = MatchSetup::builtin_team(map(), 2, Strategy::Cooperative);
        setup.seats[1].name = "Bot1".into();
        assert_eq!(setup.check(), Err(SetupError::Invalid("two seats are named 'Bot1'".into())));
        setup.seats = vec![Seat::open(), Seat::remote("Ann")];
        let refused = setup.check().expect_err("a named seat after an open one");
        assert!(refused.to_string().contains("open seats come last"), "{refused}");
        setup.seats = vec![Seat::remote("Ann"), Seat { name: String::new(), player: Player::Remote }];
        assert_eq!(setup.check(), Err(SetupError::Invalid("seat 2 has no name".into())));
    }

    #[test]
    fn only_players_names_the_seat_a_front_end_cannot_play() {
        let mut setup = MatchSetup::builtin_team(map(), 2, Strategy::Cooperative);
        setup.seats.push(Seat::program("Ann", "python3 agent.py"));
        let refused = setup
            .only_players("in a headless match", |p| matches!(p, Player::Builtin(_)))
            .expect_err("a program in a headless match");
        assert_eq!(
            refused.to_string(),
            "seat 3 (Ann): the program `python3 agent.py` cannot play in a headless match"
        );
        assert!(setup.only_players("served", |p| !matches!(p, Player::Learner)).is_ok());
    }
}
