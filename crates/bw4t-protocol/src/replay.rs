//! The replay format: JSON lines holding everything needed to re-simulate a match.
//!
//! A header (format version, program version, the map itself in the native format, seed,
//! config, robots, the tick limit if any), then for every tick at which something was
//! applied a `tick` line with the events applied after that tick, a `digest` line every
//! `digest_every` ticks, and an `end` line with the final digest. Ticks never go back, no
//! line is further than `digest_every` ticks from the previous digest (so a file's lines
//! bound how many ticks it can claim), none is past `max_ticks`, and nothing follows `end`;
//! a file without `end` is incomplete (its writer was stopped). The recorder flushes after
//! the header and every digest, so a killed writer leaves a usable prefix.
//!
//! A served match's replay also says when things happened: the header's `started_ms` and
//! each tick line's `wall_ms` (milliseconds since the Unix epoch), and the match's `labels`
//! (a study's condition, say). Re-simulating ignores them.

use std::collections::BTreeMap;
use std::io::Write;
use std::time::{SystemTime, UNIX_EPOCH};

use bw4t_sim::{Action, Applied, Journal, Match, MatchConfig, RobotId};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::convert::{action_from_act, action_to_act};
use crate::vocabulary::EndReason;

/// The replay format version this build writes and reads.
pub const REPLAY_FORMAT: u32 = 1;

/// One line of a replay.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ReplayLine {
    /// The first line.
    Header(ReplayHeader),
    /// Events applied after tick `tick` (before the next step).
    Tick {
        /// The tick they were applied after.
        tick: u64,
        /// In the order applied.
        events: Vec<ReplayEvent>,
        /// When they were written, in milliseconds since the Unix epoch (served matches).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        wall_ms: Option<u64>,
    },
    /// The state digest after tick `tick`.
    Digest {
        /// The tick.
        tick: u64,
        /// 16 hex digits.
        digest: String,
    },
    /// The last line.
    End {
        /// The last tick.
        tick: u64,
        /// The final digest.
        digest: String,
        /// Why the match ended.
        reason: EndReason,
    },
}

/// The header of a replay.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ReplayHeader {
    /// [`REPLAY_FORMAT`].
    pub format: u32,
    /// The program that wrote it, e.g. `bw4t 0.1.0`.
    pub program: String,
    /// The map's name.
    pub map: String,
    /// The whole map, in the native format.
    pub map_native: String,
    /// The match seed.
    pub seed: u64,
    /// Simulated ticks per second.
    pub ticks_per_second: u32,
    /// Map units per tick.
    pub speed: f32,
    /// Whether robots collide.
    pub robot_collisions: bool,
    /// The robots' names in joining order (as far as known when the header was written).
    pub robots: Vec<String>,
    /// How often a `digest` line is written.
    pub digest_every: u64,
    /// The tick at which the match was to end at the latest (none: no limit was set).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_ticks: Option<u64>,
    /// Free-form labels of the match (a study's condition, its participants...).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub labels: BTreeMap<String, String>,
    /// When the replay was started, in milliseconds since the Unix epoch (served matches).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub started_ms: Option<u64>,
}

/// Something applied to the match at a tick boundary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ReplayEvent {
    /// A robot joined.
    Join {
        /// The player's name.
        name: String,
        /// The id it got.
        robot: u32,
    },
    /// A robot left.
    Leave {
        /// Its id.
        robot: u32,
    },
    /// A robot was stopped (its player's connection dropped).
    Stop {
        /// Its id.
        robot: u32,
    },
    /// An action, and whether it was accepted.
    Act {
        /// The robot.
        robot: u32,
        /// The action name.
        action: String,
        /// Its arguments.
        args: Vec<Value>,
        /// Whether the match accepted it.
        ok: bool,
    },
}

impl ReplayEvent {
    /// The record of `what`.
    pub fn of(what: Applied<'_>) -> Self {
        match what {
            Applied::Join { name, robot } => ReplayEvent::Join { name: name.to_string(), robot: robot.0 },
            Applied::Leave { robot } => ReplayEvent::Leave { robot: robot.0 },
            Applied::Stop { robot } => ReplayEvent::Stop { robot: robot.0 },
            Applied::Act { robot, action, ok } => {
                let (name, args) = action_to_act(action);
                ReplayEvent::Act { robot: robot.0, action: name.to_string(), args, ok }
            }
        }
    }

    /// The action of an `act` event.
    pub fn action(&self) -> Option<Action> {
        match self {
            ReplayEvent::Act { action, args, .. } => action_from_act(action, args).ok(),
            _ => None,
        }
    }

    /// Applies this event to `game` again ([`Match::reapply`]); the error says how it went
    /// otherwise than recorded.
    pub fn reapply(&self, game: &mut Match) -> Result<(), String> {
        match self {
            ReplayEvent::Join { name, robot } => game.reapply(Applied::Join { name, robot: RobotId(*robot) }),
            ReplayEvent::Leave { robot } => game.reapply(Applied::Leave { robot: RobotId(*robot) }),
            ReplayEvent::Stop { robot } => game.reapply(Applied::Stop { robot: RobotId(*robot) }),
            ReplayEvent::Act { robot, ok, .. } => match self.action() {
                None => Err("an action this program cannot read".to_string()),
                Some(action) => {
                    game.reapply(Applied::Act { robot: RobotId(*robot), action: &action, ok: *ok })
                }
            },
        }
    }
}

/// Writes a replay while a match is played: it is the match's [`Journal`] (everything
/// applied, every step); [`Recorder::finish`] writes the end.
pub struct Recorder {
    out: Box<dyn Write + Send>,
    digest_every: u64,
    pending: Vec<ReplayEvent>,
    pending_tick: u64,
    error: Option<std::io::Error>,
    /// Stamp tick lines with the wall clock (a served match's replay).
    wall_clock: bool,
}

/// Milliseconds since the Unix epoch now.
fn wall_ms() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_millis() as u64)
}

/// What a replay's header says besides the match itself.
#[derive(Clone, Debug, Default)]
pub struct ReplayMeta {
    /// The program that writes it.
    pub program: String,
    /// The robots' names, as far as known.
    pub robots: Vec<String>,
    /// How often a digest line is written.
    pub digest_every: u64,
    /// The match's tick limit, if any.
    pub max_ticks: Option<u64>,
    /// Labels of the match.
    pub labels: BTreeMap<String, String>,
    /// Stamp the header and tick lines with the wall clock: replays of served matches,
    /// whose timing is part of what happened (a headless replay stays the same bytes).
    pub wall_clock: bool,
}

impl Recorder {
    /// Starts a replay of `game` (before any robot joins) on `out`.
    pub fn new(mut out: Box<dyn Write + Send>, game: &Match, meta: ReplayMeta) -> Self {
        let config: &MatchConfig = game.config();
        let header = ReplayLine::Header(ReplayHeader {
            format: REPLAY_FORMAT,
            program: meta.program,
            map: game.map().name().to_string(),
            map_native: game.map().to_native(),
            seed: game.seed(),
            ticks_per_second: config.ticks_per_second,
            speed: config.speed,
            robot_collisions: config.robot_collisions,
            robots: meta.robots,
            digest_every: meta.digest_every.max(1),
            max_ticks: meta.max_ticks,
            labels: meta.labels,
            started_ms: meta.wall_clock.then(wall_ms),
        });
        let error = write_line(&mut out, &header).and_then(|()| out.flush()).err();
        Recorder {
            out,
            digest_every: meta.digest_every.max(1),
            pending: Vec::new(),
            pending_tick: game.tick(),
            error,
            wall_clock: meta.wall_clock,
        }
    }

    /// Records something applied to the match after `tick`.
    fn event(&mut self, tick: u64, event: ReplayEvent) {
        if tick != self.pending_tick {
            self.flush_events();
            self.pending_tick = tick;
        }
        self.pending.push(event);
    }

    /// Writes the last line and flushes. Returns the first write error, if any happened.
    pub fn finish(mut self, game: &Match, reason: EndReason) -> std::io::Result<()> {
        self.flush_events();
        let line = ReplayLine::End { tick: game.tick(), digest: format!("{:016x}", game.digest()), reason };
        self.write(&line);
        self.flush();
        self.error.map_or(Ok(()), Err)
    }

    fn flush(&mut self) {
        if self.error.is_none() {
            self.error = self.out.flush().err();
        }
    }

    fn flush_events(&mut self) {
        if !self.pending.is_empty() {
            let line = ReplayLine::Tick {
                tick: self.pending_tick,
                events: std::mem::take(&mut self.pending),
                wall_ms: self.wall_clock.then(wall_ms),
            };
            self.write(&line);
        }
    }

    fn write(&mut self, line: &ReplayLine) {
        if self.error.is_none() {
            self.error = write_line(&mut self.out, line).err();
        }
    }
}

impl Journal for Recorder {
    fn applied(&mut self, tick: u64, what: Applied<'_>) {
        self.event(tick, ReplayEvent::of(what));
    }

    /// Records a step: the events before it, and a digest when one is due.
    fn stepped(&mut self, game: &Match) {
        self.flush_events();
        self.pending_tick = game.tick();
        if game.tick().is_multiple_of(self.digest_every) {
            let line = ReplayLine::Digest { tick: game.tick(), digest: format!("{:016x}", game.digest()) };
            self.write(&line);
            // What is written up to a digest survives the writer being killed.
            self.flush();
        }
    }
}

fn write_line(out: &mut Box<dyn Write + Send>, line: &ReplayLine) -> std::io::Result<()> {
    let text = serde_json::to_string(line).map_err(std::io::Error::other)?;
    out.write_all(text.as_bytes())?;
    out.write_all(b"\n")
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use bw4t_sim::{Action, MatchConfig};

    use super::*;

    /// A writer whose bytes the test reads afterwards.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);

    impl Write for Shared {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            self.0.lock().expect("lock").extend_from_slice(bytes);
            Ok(bytes.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    fn lines(meta: ReplayMeta) -> Vec<ReplayLine> {
        let map = bw4t_map::generate(2, 1, 1, 5).expect("a map");
        let mut game = Match::new(&map, &MatchConfig::default(), 5).expect("a match");
        let out = Shared::default();
        let mut recorder = Recorder::new(Box::new(out.clone()), &game, meta);
        let robot = game.join("Ann").expect("joins");
        recorder.applied(0, Applied::Join { name: "Ann", robot });
        let hello = Action::SendMessage { to: bw4t_sim::Receiver::All, text: "hi".into() };
        recorder.applied(0, Applied::Act { robot, action: &hello, ok: true });
        game.step();
        recorder.stepped(&game);
        recorder.finish(&game, EndReason::Completed).expect("written");
        let text = String::from_utf8(out.0.lock().expect("lock").clone()).expect("utf-8");
        text.lines().map(|l| serde_json::from_str(l).expect("a replay line")).collect()
    }

    #[test]
    fn served_replays_carry_labels_and_wall_clock_times_and_headless_ones_do_not() {
        let labels = BTreeMap::from([("condition".to_string(), "talking".to_string())]);
        let served = lines(ReplayMeta { labels: labels.clone(), wall_clock: true, ..ReplayMeta::default() });
        let ReplayLine::Header(header) = &served[0] else { panic!("{:?}", served[0]) };
        assert_eq!(header.labels, labels);
        assert!(header.started_ms.is_some_and(|ms| ms > 1_600_000_000_000), "{:?}", header.started_ms);
        let ReplayLine::Tick { wall_ms, .. } = &served[1] else { panic!("{:?}", served[1]) };
        assert!(wall_ms.is_some_and(|ms| ms >= header.started_ms.unwrap_or(0)));
        let headless = lines(ReplayMeta::default());
        let ReplayLine::Header(header) = &headless[0] else { panic!("{:?}", headless[0]) };
        assert!(header.labels.is_empty() && header.started_ms.is_none());
        let ReplayLine::Tick { wall_ms, .. } = &headless[1] else { panic!("{:?}", headless[1]) };
        assert_eq!(*wall_ms, None);
    }
}
