use std::collections::BTreeMap;

use bw4t_map::Map;
use bw4t_sim::{Action, Beliefs, Match, MatchConfig, OrderOutcome, Percept, Receiver, RobotId};

/// A map shipped in `maps/`, by file name without extension.
pub fn shipped_map(name: &str) -> Map {
    let path = format!("{}/maps/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    Map::from_native(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// A match with players joined in order, each polled into its own belief base every tick.
pub struct Scenario {
    pub game: Match,
    robots: BTreeMap<String, RobotId>,
    beliefs: BTreeMap<String, Beliefs>,
    heard: BTreeMap<String, Vec<String>>,
    last: BTreeMap<String, Result<(), String>>,
    ended: BTreeMap<String, OrderOutcome>,
}

/// How long a `run until` may take before the scenario fails.
const UNTIL_LIMIT: u64 = 3000;

impl Scenario {
    pub fn new(map: &Map, config: &MatchConfig, seed: u64, players: &[&str]) -> Scenario {
        let mut game = Match::new(map, config, seed).expect("match");
        let mut robots = BTreeMap::new();
        for name in players {
            robots.insert(name.to_string(), game.join(name).expect("join"));
        }
        let mut s = Scenario {
            game,
            robots,
            beliefs: BTreeMap::new(),
            heard: BTreeMap::new(),
            last: BTreeMap::new(),
            ended: BTreeMap::new(),
        };
        s.poll();
        s
    }

    fn id(&self, name: &str) -> RobotId {
        *self.robots.get(name).unwrap_or_else(|| panic!("no player {name}"))
    }

    fn poll(&mut self) {
        for (name, &id) in &self.robots {
            let delta = self.game.poll_percepts(id).expect("robot in match");
            let beliefs = self.beliefs.entry(name.clone()).or_default();
            beliefs.apply(&delta);
            let heard = self.heard.entry(name.clone()).or_default();
            heard.extend(beliefs.take_messages().into_iter().map(|(f, t)| format!("message({f},{t})")));
        }
    }

    pub fn step(&mut self) {
        let report = self.game.step();
        for end in report.ended {
            let name = self.robots.iter().find(|(_, id)| **id == end.robot).map(|(n, _)| n.clone());
            self.ended.insert(name.expect("known robot"), end.outcome);
        }
        self.poll();
    }

    pub fn sees(&self, name: &str, fact: &str) -> bool {
        self.beliefs[name].facts().iter().any(|p| p.to_string() == fact)
    }

    fn act(&mut self, name: &str, action: Action) {
        let result =
            self.game.handle_action(self.id(name), action).map(|_| ()).map_err(|r| r.code().to_string());
        self.last.insert(name.to_string(), result);
    }

    /// The lowest-id block of `colour` this player sees.
    fn block_of_colour(&self, name: &str, colour: &str) -> Option<u32> {
        self.beliefs[name].facts().iter().find_map(|p| match p {
            Percept::Color(b, c) if c.name().eq_ignore_ascii_case(colour) => Some(*b),
            _ => None,
        })
    }

    /// Runs one script line; panics with the line when it does not hold.
    pub fn line(&mut self, line: &str) {
        let words: Vec<&str> = line.split_whitespace().collect();
        let fail = |why: String| -> ! { panic!("scenario line `{line}`: {why}") };
        match words.as_slice() {
            ["run", n] => (0..n.parse::<u64>().expect("tick count")).for_each(|_| self.step()),
            ["run", "until", who, fact] => {
                // At least one tick, so a fact that held before an order cannot end the wait.
                self.step();
                let mut ticks = 1;
                while !self.sees(who, fact) {
                    if ticks == UNTIL_LIMIT {
                        fail(format!("not true after {UNTIL_LIMIT} ticks; {who} sees {:?}", self.facts(who)));
                    }
                    self.step();
                    ticks += 1;
                }
            }
            ["match", "sequenceIndex", n] => {
                let got = self.game.sequence_index().to_string();
                if got != *n {
                    fail(format!("sequence index is {got}"));
                }
            }
            ["match", "drops", good, wrong] => {
                let s = self.game.stats();
                if s.good_drops.to_string() != *good || s.wrong_drops.to_string() != *wrong {
                    fail(format!("good {} wrong {}", s.good_drops, s.wrong_drops));
                }
            }
            ["match", "blocks", n] => {
                let left = self.game.blocks().filter(|(_, _, p)| *p != bw4t_sim::BlockPlace::Gone).count();
                if left.to_string() != *n {
                    fail(format!("{left} blocks in the world"));
                }
            }
            [who, "goTo", place] => self.act(who, Action::GoTo(place.to_string())),
            [who, "goToBlock", block] => {
                let id = block.parse().ok().or_else(|| self.block_of_colour(who, block));
                let id = id.unwrap_or_else(|| fail(format!("{who} sees no {block} block")));
                self.act(who, Action::GoToBlock(id));
            }
            [who, "pickUp"] => self.act(who, Action::PickUp(None)),
            [who, "pickUp", block] => {
                let id = block.parse().ok().or_else(|| self.block_of_colour(who, block));
                self.act(who, Action::PickUp(Some(id.unwrap_or_else(|| fail(format!("no {block} block"))))));
            }
            [who, "putDown"] => self.act(who, Action::PutDown),
            [who, "say", to, text @ ..] => {
                let to = if *to == "all" { Receiver::All } else { Receiver::Player(to.to_string()) };
                self.act(who, Action::SendMessage { to, text: text.join(" ") });
            }
            [who, "leaves"] => {
                let id = self.id(who);
                self.game.leave(id).expect("leave");
                self.robots.remove(*who);
            }
            [who, "ok"] => {
                if self.last.get(*who) != Some(&Ok(())) {
                    fail(format!("last action: {:?}", self.last.get(*who)));
                }
            }
            [who, "rejected", code] => {
                if self.last.get(*who) != Some(&Err(code.to_string())) {
                    fail(format!("last action: {:?}", self.last.get(*who)));
                }
            }
            [who, "ended", outcome] => {
                let got = self.ended.get(*who).map(|o| o.name());
                if got != Some(*outcome) {
                    fail(format!("last order ended {got:?}"));
                }
            }
            [who, "sees", facts @ ..] => {
                for fact in facts {
                    if !self.sees(who, fact) {
                        fail(format!("{who} does not see {fact}; sees {:?}", self.facts(who)));
                    }
                }
            }
            [who, "lacks", facts @ ..] => {
                for fact in facts {
                    if self.sees(who, fact) {
                        fail(format!("{who} sees {fact}"));
                    }
                }
            }
            [who, "heard", messages @ ..] => {
                let heard = &self.heard[*who];
                let expected: Vec<String> = messages.iter().map(|m| m.to_string()).collect();
                if heard != &expected {
                    fail(format!("{who} heard {heard:?}"));
                }
            }
            _ => fail("unknown line".to_string()),
        }
    }

    pub fn facts(&self, name: &str) -> Vec<String> {
        let facts = self.beliefs[name].facts().iter();
        facts.filter(|p| !matches!(p, Percept::Place(_))).map(|p| p.to_string()).collect()
    }
}

/// Runs a scenario script (one instruction per line, `#` starts a comment).
pub fn check(map: &Map, config: &MatchConfig, seed: u64, players: &[&str], script: &str) -> Scenario {
    let mut scenario = Scenario::new(map, config, seed, players);
    for line in script.lines().map(|l| l.split('#').next().unwrap_or("").trim()).filter(|l| !l.is_empty()) {
        scenario.line(line);
    }
    scenario
}

/// [`check`] on the fixed-content map with the default configuration and seed 1.
pub fn check_fixed(players: &[&str], script: &str) -> Scenario {
    check(&shipped_map("fixed"), &MatchConfig::default(), 1, players, script)
}
