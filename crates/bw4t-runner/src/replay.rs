//! Reading replays (every tick checked against the header before any work), checking them
//! by re-simulation, and their frames for the viewer.

use std::collections::BTreeMap;

use bw4t_map::Map;
use bw4t_protocol::{EndReason, Frame, FrameMessage, REPLAY_FORMAT, ReplayEvent, ReplayHeader, ReplayLine};
use bw4t_sim::{Action, Match, MatchConfig, Receiver};

/// The longest digest interval a replay may declare. Every line lies within one interval
/// of the previous digest, so this (times the number of lines) bounds the ticks a file can
/// claim; this program writes a digest every 100 ticks.
pub const MAX_DIGEST_EVERY: u64 = 10_000;

/// Why a replay cannot be read or re-simulated.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// A line is not a replay line, or not where it may be.
    #[error("line {line}: {message}")]
    Line {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The file does not start with a header.
    #[error("the replay has no header line")]
    NoHeader,
    /// A newer format.
    #[error("replay format {0} is not supported (this program reads format {REPLAY_FORMAT})")]
    Format(u32),
    /// The embedded map or configuration is invalid.
    #[error("the replay's map or configuration is invalid: {0}")]
    Setup(String),
}

fn line_error(line: usize, message: String) -> ReplayError {
    ReplayError::Line { line, message }
}

/// A replay's lines, parsed and checked: one header first; ticks that never go back, stay
/// within `max_ticks` (when the header has one) and within `digest_every` of the previous
/// digest; nothing after the `end` line. A last line cut off mid-way (no newline, not
/// JSON), as a killed writer leaves it, is dropped: the replay is then incomplete.
pub fn read_replay(text: &str) -> Result<(ReplayHeader, Vec<(usize, ReplayLine)>), ReplayError> {
    let numbered: Vec<(usize, &str)> =
        text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()).map(|(i, l)| (i + 1, l)).collect();
    let cut_off = !text.ends_with('\n');
    let mut lines = Vec::with_capacity(numbered.len());
    let mut torn = None;
    for (k, &(number, line)) in numbered.iter().enumerate() {
        match serde_json::from_str::<ReplayLine>(line) {
            Ok(parsed) => lines.push((number, parsed)),
            Err(e) if cut_off && k + 1 == numbered.len() => torn = Some(line_error(number, e.to_string())),
            Err(e) => return Err(line_error(number, e.to_string())),
        }
    }
    let Some((_, ReplayLine::Header(header))) = lines.first().cloned() else {
        return Err(torn.unwrap_or(ReplayError::NoHeader));
    };
    if header.format > REPLAY_FORMAT {
        return Err(ReplayError::Format(header.format));
    }
    let lines: Vec<(usize, ReplayLine)> = lines.into_iter().skip(1).collect();
    check_ticks(&header, &lines)?;
    // A torn line after a complete record is damage, not a writer stopped early.
    if let (Some(torn), Some((_, ReplayLine::End { .. }))) = (torn, lines.last()) {
        return Err(torn);
    }
    Ok((header, lines))
}

/// Checks every line's tick against the header and the lines before it, so that no work
/// is done for a tick the file cannot back.
fn check_ticks(header: &ReplayHeader, lines: &[(usize, ReplayLine)]) -> Result<(), ReplayError> {
    let every = header.digest_every;
    if !(1..=MAX_DIGEST_EVERY).contains(&every) {
        return Err(ReplayError::Setup(format!(
            "digest_every is {every}, not between 1 and {MAX_DIGEST_EVERY}"
        )));
    }
    let mut previous: Option<(usize, u64)> = None;
    let mut last_digest = 0;
    let mut ended = None;
    for (number, line) in lines {
        let tick = match line {
            ReplayLine::Header(_) => return Err(line_error(*number, "a second header".into())),
            ReplayLine::Tick { tick, .. }
            | ReplayLine::Digest { tick, .. }
            | ReplayLine::End { tick, .. } => *tick,
        };
        if let Some(end) = ended {
            return Err(line_error(*number, format!("a line after the end record (line {end})")));
        }
        if let Some((before_line, before)) = previous.filter(|&(_, before)| tick < before) {
            return Err(line_error(
                *number,
                format!("tick {tick} goes back (line {before_line} is at tick {before})"),
            ));
        }
        if let Some(max) = header.max_ticks.filter(|&max| tick > max) {
            return Err(line_error(*number, format!("tick {tick} is beyond the header's max_ticks {max}")));
        }
        let due = last_digest + every;
        if tick > due {
            return Err(line_error(
                *number,
                format!(
                    "tick {tick} skips the digest due at tick {due} (the header says one every {every} ticks)"
                ),
            ));
        }
        match line {
            ReplayLine::Digest { .. } => last_digest = tick,
            ReplayLine::End { .. } => ended = Some(*number),
            _ => {}
        }
        previous = Some((*number, tick));
    }
    Ok(())
}

/// The replay's match before anything happened, on `map` (the header's map, read).
fn new_match(header: &ReplayHeader, map: &Map) -> Result<Match, ReplayError> {
    let config = MatchConfig {
        ticks_per_second: header.ticks_per_second,
        speed: header.speed,
        robot_collisions: header.robot_collisions,
        ..MatchConfig::default()
    };
    Match::new(map, &config, header.seed).map_err(|e| ReplayError::Setup(e.to_string()))
}

/// The replay's map, and its match before anything happened.
pub(crate) fn start(header: &ReplayHeader) -> Result<(Map, Match), ReplayError> {
    // Checked as every map a match is played on, so a hand-made header cannot slip one by.
    let (map, _warnings) =
        Map::parse_checked(&header.map_native, "", None).map_err(|e| ReplayError::Setup(e.to_string()))?;
    let game = new_match(header, &map)?;
    Ok((map, game))
}

/// The outcome of re-simulating a replay.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// A complete replay whose every digest matched.
    Matches {
        /// Digests compared.
        digests: usize,
        /// The last tick.
        ticks: u64,
    },
    /// No end record (the writer was stopped, or the file cut), and everything up to the
    /// last recorded tick matched.
    Incomplete {
        /// Digests compared.
        digests: usize,
        /// The last tick recorded, up to which the replay was re-simulated.
        ticks: u64,
        /// The header's tick limit, the most the match could have lasted.
        max_ticks: Option<u64>,
    },
    /// The first tick whose state differs from the recording.
    Differs {
        /// The tick.
        tick: u64,
        /// What was recorded there.
        expected: String,
        /// What re-simulation gave (a digest, or what went wrong).
        found: String,
    },
}

impl Verdict {
    /// The one-line report of an incomplete replay, or `None` for other verdicts.
    pub fn incomplete_report(&self) -> Option<String> {
        let Verdict::Incomplete { digests, ticks, max_ticks } = self else { return None };
        let of = match max_ticks {
            Some(max) => format!("{ticks} of {max} ticks"),
            None => format!("{ticks} ticks (the header sets no tick limit)"),
        };
        Some(format!("incomplete: verified {of}, no end record ({digests} digests match)"))
    }
}

/// What a replay holds, from re-simulating it.
#[derive(Clone, Debug)]
pub struct ReplaySummary {
    /// The header.
    pub header: ReplayHeader,
    /// The match at the end of the replay.
    pub game_ticks: u64,
    /// The sequence and how far it got.
    pub sequence: Vec<String>,
    /// The index reached.
    pub sequence_index: u32,
    /// Why it ended, if the replay says.
    pub reason: Option<EndReason>,
    /// Actions applied.
    pub actions: usize,
    /// Players in joining order.
    pub players: Vec<String>,
}

/// Re-simulates a replay, comparing every recorded digest.
pub fn verify_replay(text: &str) -> Result<(Verdict, ReplaySummary), ReplayError> {
    let (header, lines) = read_replay(text)?;
    let (_, mut game) = start(&header)?;
    let walked = resimulate(&header, &lines, &mut game, &mut ());
    Ok((walked.verdict, walked.summary))
}

/// Hears a re-simulation as it goes: every tick the match reaches, every recorded event
/// around its re-application. Whoever turns a replay into something else (trajectories)
/// sees the match exactly as verification re-simulates it.
pub(crate) trait Watch {
    /// The match is at a new tick (tick 0 before anything is applied, then after each step).
    fn ticked(&mut self, game: &mut Match);
    /// `event` is about to be applied again.
    fn before(&mut self, game: &mut Match, event: &ReplayEvent);
    /// `event` was applied again, as recorded.
    fn after(&mut self, game: &mut Match, event: &ReplayEvent);
    /// Every event recorded after the match's tick was applied again.
    fn settled(&mut self, game: &mut Match);
}

impl Watch for () {
    fn ticked(&mut self, _: &mut Match) {}
    fn before(&mut self, _: &mut Match, _: &ReplayEvent) {}
    fn after(&mut self, _: &mut Match, _: &ReplayEvent) {}
    fn settled(&mut self, _: &mut Match) {}
}

/// What re-simulating a replay gave.
pub(crate) struct Walked {
    pub(crate) verdict: Verdict,
    pub(crate) summary: ReplaySummary,
}

/// Re-simulates `lines` on `game` (the header's match, before anything happened),
/// comparing every recorded digest and outcome, and telling `watch` as it goes.
pub(crate) fn resimulate(
    header: &ReplayHeader,
    lines: &[(usize, ReplayLine)],
    game: &mut Match,
    watch: &mut impl Watch,
) -> Walked {
    let (mut digests, mut actions, mut reason, mut players) = (0, 0, None, Vec::new());
    let differs = |tick, expected: &str, found: String| Verdict::Differs {
        tick,
        expected: expected.to_string(),
        found,
    };
    let mut verdict = None;
    watch.ticked(game);
    'lines: for (_, line) in lines {
        let (tick, recorded) = match line {
            ReplayLine::Header(_) => continue,
            ReplayLine::Tick { tick, .. } => (*tick, None),
            ReplayLine::Digest { tick, digest } | ReplayLine::End { tick, digest, .. } => {
                (*tick, Some(digest))
            }
        };
        // `read_replay` checked that ticks never go back and stay within the file's digests.
        while game.tick() < tick {
            game.step();
            watch.ticked(game);
        }
        if let Some(digest) = recorded {
            let found = format!("{:016x}", game.digest());
            if &found != digest {
                verdict = Some(differs(tick, digest, found));
                break;
            }
            digests += 1;
        }
        if let ReplayLine::End { reason: r, .. } = line {
            reason = Some(*r);
        }
        let ReplayLine::Tick { events, .. } = line else { continue };
        for event in events {
            watch.before(game, event);
            let problem = event.reapply(game).err();
            match event {
                ReplayEvent::Join { name, .. } if problem.is_none() => players.push(name.clone()),
                ReplayEvent::Act { .. } => actions += 1,
                _ => {}
            }
            if let Some(problem) = problem {
                verdict = Some(differs(tick, "the recorded outcome", problem));
                break 'lines;
            }
            watch.after(game, event);
        }
        watch.settled(game);
    }
    let verdict = verdict.unwrap_or_else(|| match reason {
        Some(_) => Verdict::Matches { digests, ticks: game.tick() },
        None => Verdict::Incomplete { digests, ticks: game.tick(), max_ticks: header.max_ticks },
    });
    let summary = ReplaySummary {
        game_ticks: game.tick(),
        sequence: game.sequence().iter().map(|c| c.name().to_string()).collect(),
        sequence_index: game.sequence_index(),
        reason,
        actions,
        players,
        header: header.clone(),
    };
    Walked { verdict, summary }
}

/// A message of a replay and the tick whose frame first shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayMessage {
    /// The tick at which it was sent (applied).
    pub tick: u64,
    /// Sender, receiver and text.
    pub message: FrameMessage,
}

/// The most bytes of frames (as JSON) a [`ReplayFrames`] keeps unless told otherwise.
pub const FRAME_CACHE_BYTES: usize = 32 << 20;
/// How many frames before the one asked for are kept when stepping to it, for requests
/// that come out of order (the page fetches a few ahead at once).
const FRAMES_BEHIND: u64 = 32;

/// A replay opened for the viewer. Frames are re-simulated on demand from the recorded
/// events and at most [`FRAME_CACHE_BYTES`] of them are kept (as JSON), so memory follows
/// the size of the file, not the number of ticks it claims. Open only a replay that verifies.
pub struct ReplayFrames {
    header: ReplayHeader,
    map: Map,
    /// The events of every tick that has some, in tick order.
    events: Vec<(u64, Vec<ReplayEvent>)>,
    /// Every message sent, in the order sent.
    messages: Vec<ReplayMessage>,
    last_tick: u64,
    complete: bool,
    /// A match part-way through the replay, to step forwards from.
    cursor: Option<Cursor>,
    cache: BTreeMap<u64, String>,
    cached_bytes: usize,
    cache_budget: usize,
}

struct Cursor {
    game: Match,
    /// The first entry of `events` not applied yet.
    next: usize,
}

impl ReplayFrames {
    /// Reads and checks a replay (see [`read_replay`]); re-simulates nothing yet.
    pub fn open(text: &str) -> Result<ReplayFrames, ReplayError> {
        let (header, lines) = read_replay(text)?;
        let (map, game) = start(&header)?;
        let mut events: Vec<(u64, Vec<ReplayEvent>)> = Vec::new();
        let mut messages = Vec::new();
        let mut names: BTreeMap<u32, String> = BTreeMap::new();
        for (_, line) in &lines {
            let ReplayLine::Tick { tick, events: applied, .. } = line else { continue };
            for event in applied {
                match event {
                    ReplayEvent::Join { name, robot } => {
                        names.insert(*robot, name.clone());
                    }
                    ReplayEvent::Act { robot, ok: true, .. } => {
                        if let Some(Action::SendMessage { to, text }) = event.action() {
                            let to = match to {
                                Receiver::All => "all".to_string(),
                                Receiver::Player(p) => p,
                            };
                            let from = names.get(robot).cloned().unwrap_or_default();
                            messages.push(ReplayMessage {
                                tick: *tick,
                                message: FrameMessage::new(from, to, &text),
                            });
                        }
                    }
                    _ => {}
                }
            }
            match events.last_mut() {
                Some((last, same)) if last == tick => same.extend(applied.iter().cloned()),
                _ => events.push((*tick, applied.clone())),
            }
        }
        let (last_tick, complete) = match lines.last() {
            Some((_, ReplayLine::End { tick, .. })) => (*tick, true),
            Some((_, ReplayLine::Tick { tick, .. } | ReplayLine::Digest { tick, .. })) => (*tick, false),
            _ => (0, false),
        };
        let mut frames = ReplayFrames {
            header,
            map,
            events,
            messages,
            last_tick,
            complete,
            cursor: None,
            cache: BTreeMap::new(),
            cached_bytes: 0,
            cache_budget: FRAME_CACHE_BYTES,
        };
        frames.cursor = Some(frames.cursor_at_start(game));
        Ok(frames)
    }

    /// Keeps at most `bytes` of frames instead of [`FRAME_CACHE_BYTES`] (at least the
    /// frame last asked for).
    pub fn with_cache_budget(mut self, bytes: usize) -> ReplayFrames {
        self.cache_budget = bytes;
        self
    }

    /// The header.
    pub fn header(&self) -> &ReplayHeader {
        &self.header
    }

    /// The map.
    pub fn map(&self) -> &Map {
        &self.map
    }

    /// The last tick recorded: frames exist for `0..=last_tick()`.
    pub fn last_tick(&self) -> u64 {
        self.last_tick
    }

    /// Whether the replay has its end record.
    pub fn complete(&self) -> bool {
        self.complete
    }

    /// Every message sent, in the order sent (so by tick).
    pub fn messages(&self) -> &[ReplayMessage] {
        &self.messages
    }

    /// The frame of `tick` as JSON (its `messages` those sent at that tick), or `None`
    /// past the last tick.
    pub fn frame_json(&mut self, tick: u64) -> Option<String> {
        if tick > self.last_tick {
            return None;
        }
        if let Some(json) = self.cache.get(&tick) {
            return Some(json.clone());
        }
        self.seek(tick, true)?;
        let json = self.cache.get(&tick).cloned();
        self.trim_cache(tick);
        json
    }

    /// What robot `robot` perceived at `tick` (its facts, as the protocol writes them) and
    /// the messages it had received by then, as JSON: the player's own view beside the
    /// overview. `None` past the last tick or for a robot not in the match then.
    pub fn view_json(&mut self, robot: u32, tick: u64) -> Option<String> {
        if tick > self.last_tick {
            return None;
        }
        let game = &self.seek(tick, false)?.game;
        let id = bw4t_sim::RobotId(robot);
        let facts: Vec<_> = game.perceived(id)?.iter().map(bw4t_protocol::percept_to_fact).collect();
        let name = game.robots().find(|r| r.id == id).map(|r| r.name.to_string())?;
        let upto = self.messages.partition_point(|m| m.tick < tick);
        let heard: Vec<serde_json::Value> = self.messages[..upto]
            .iter()
            .filter(|m| m.message.from != name && (m.message.to == "all" || m.message.to == name))
            .map(|m| serde_json::json!({ "tick": m.tick, "message": m.message }))
            .collect();
        let view = serde_json::json!({ "tick": tick, "robot": robot, "name": name, "facts": facts, "messages": heard });
        serde_json::to_string(&view).ok()
    }

    /// Moves the cursor to `tick` (from the start when it is past it), keeping the frames
    /// near `tick` on the way when `keep_frames`.
    fn seek(&mut self, tick: u64, keep_frames: bool) -> Option<&Cursor> {
        let mut cursor = match self.cursor.take() {
            Some(cursor) if cursor.game.tick() <= tick => cursor,
            // Matches cannot be copied: going back means starting again.
            _ => self.cursor_at_start(new_match(&self.header, &self.map).ok()?),
        };
        let keep_from = tick.saturating_sub(FRAMES_BEHIND);
        loop {
            let now = cursor.game.tick();
            if keep_frames && now >= keep_from && !self.cache.contains_key(&now) {
                let json = serde_json::to_string(&Frame::of(&cursor.game, self.messages_at(now))).ok()?;
                self.cached_bytes += json.len();
                self.cache.insert(now, json);
            }
            if now == tick {
                break;
            }
            cursor.game.step();
            self.apply_due(&mut cursor);
        }
        self.cursor = Some(cursor);
        self.cursor.as_ref()
    }

    /// A cursor on `game` (a fresh match) with the events of tick 0 applied.
    fn cursor_at_start(&self, game: Match) -> Cursor {
        let mut cursor = Cursor { game, next: 0 };
        self.apply_due(&mut cursor);
        cursor
    }

    /// Applies the events recorded at the cursor's tick, if not yet applied. The replay
    /// verified, so every outcome is the recorded one.
    fn apply_due(&self, cursor: &mut Cursor) {
        let Some((tick, events)) = self.events.get(cursor.next) else { return };
        if *tick != cursor.game.tick() {
            return;
        }
        cursor.next += 1;
        for event in events {
            // The replay verified, so every outcome is the recorded one.
            let _ = event.reapply(&mut cursor.game);
        }
    }

    fn messages_at(&self, tick: u64) -> Vec<FrameMessage> {
        let from = self.messages.partition_point(|m| m.tick < tick);
        let to = self.messages.partition_point(|m| m.tick <= tick);
        self.messages[from..to].iter().map(|m| m.message.clone()).collect()
    }

    /// Drops the frames farthest from `tick` until the cache fits its budget.
    fn trim_cache(&mut self, tick: u64) {
        while self.cached_bytes > self.cache_budget && self.cache.len() > 1 {
            let (Some((&first, _)), Some((&last, _))) =
                (self.cache.first_key_value(), self.cache.last_key_value())
            else {
                return;
            };
            let far = if tick.abs_diff(first) >= tick.abs_diff(last) { first } else { last };
            if let Some(json) = self.cache.remove(&far) {
                self.cached_bytes -= json.len();
            }
        }
    }
}
