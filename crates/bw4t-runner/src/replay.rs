//! Checking and summarising replays by re-simulating them.

use bw4t_map::Map;
use bw4t_protocol::{REPLAY_FORMAT, ReplayEvent, ReplayHeader, ReplayLine};
use bw4t_sim::{Match, MatchConfig, RobotId};

/// Why a replay cannot be read or re-simulated.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// A line is not a replay line.
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

/// A replay's lines, parsed.
pub fn read_replay(text: &str) -> Result<(ReplayHeader, Vec<(usize, ReplayLine)>), ReplayError> {
    let mut lines = Vec::new();
    for (i, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let parsed: ReplayLine = serde_json::from_str(line)
            .map_err(|e| ReplayError::Line { line: i + 1, message: e.to_string() })?;
        lines.push((i + 1, parsed));
    }
    let Some((_, ReplayLine::Header(header))) = lines.first().cloned() else {
        return Err(ReplayError::NoHeader);
    };
    if header.format > REPLAY_FORMAT {
        return Err(ReplayError::Format(header.format));
    }
    Ok((header, lines.into_iter().skip(1).collect()))
}

/// The replay's map, and its match before anything happened.
fn start(header: &ReplayHeader) -> Result<(Map, Match), ReplayError> {
    let map = Map::from_native(&header.map_native).map_err(|e| ReplayError::Setup(e.to_string()))?;
    let config = MatchConfig {
        ticks_per_second: header.ticks_per_second,
        speed: header.speed,
        robot_collisions: header.robot_collisions,
    };
    let game = Match::new(&map, &config, header.seed).map_err(|e| ReplayError::Setup(e.to_string()))?;
    Ok((map, game))
}

/// The outcome of re-simulating a replay.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Every digest matched.
    Matches {
        /// Digests compared.
        digests: usize,
        /// The last tick.
        ticks: u64,
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
    pub reason: Option<String>,
    /// Actions applied.
    pub actions: usize,
    /// Players by robot id.
    pub players: Vec<String>,
}

/// Re-simulates a replay, comparing every recorded digest.
pub fn verify_replay(text: &str) -> Result<(Verdict, ReplaySummary), ReplayError> {
    let (header, lines) = read_replay(text)?;
    let (_, mut game) = start(&header)?;
    let (mut digests, mut actions, mut reason, mut players) = (0, 0, None, Vec::new());
    let differs = |tick, expected: &str, found: String| Verdict::Differs {
        tick,
        expected: expected.to_string(),
        found,
    };
    let mut verdict = None;
    'lines: for (_, line) in &lines {
        let (tick, recorded) = match line {
            ReplayLine::Header(_) => continue,
            ReplayLine::Tick { tick, .. } => (*tick, None),
            ReplayLine::Digest { tick, digest } | ReplayLine::End { tick, digest, .. } => {
                (*tick, Some(digest))
            }
        };
        if game.tick() > tick {
            verdict = Some(differs(tick, "a later tick", format!("lines out of order at tick {tick}")));
            break;
        }
        while game.tick() < tick {
            game.step();
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
            reason = Some(r.clone());
        }
        let ReplayLine::Tick { events, .. } = line else { continue };
        for event in events {
            let problem = match event {
                ReplayEvent::Join { name, robot } => match game.join(name) {
                    Ok(id) if id.0 == *robot => {
                        players.push(name.clone());
                        None
                    }
                    Ok(id) => Some(format!("{name} joined as robot {}, recorded {robot}", id.0)),
                    Err(e) => Some(format!("{name} cannot join: {e}")),
                },
                ReplayEvent::Leave { robot } => game.leave(RobotId(*robot)).err().map(|e| e.to_string()),
                ReplayEvent::Stop { robot } => game.stop(RobotId(*robot)).err().map(|e| e.to_string()),
                ReplayEvent::Act { robot, ok, .. } => {
                    actions += 1;
                    match event.action() {
                        None => Some("an action this program cannot read".to_string()),
                        Some(action) => {
                            let got = game.handle_action(RobotId(*robot), action).is_ok();
                            (got != *ok)
                                .then(|| format!("robot {robot}'s action accepted: {got}, recorded {ok}"))
                        }
                    }
                }
            };
            if let Some(problem) = problem {
                verdict = Some(differs(tick, "the recorded outcome", problem));
                break 'lines;
            }
        }
    }
    let summary = ReplaySummary {
        game_ticks: game.tick(),
        sequence: game.sequence().iter().map(|c| c.name().to_string()).collect(),
        sequence_index: game.sequence_index(),
        reason,
        actions,
        players,
        header,
    };
    let verdict = verdict.unwrap_or(Verdict::Matches { digests, ticks: game.tick() });
    Ok((verdict, summary))
}

/// Every tick's frame of a replay (index = tick), by re-simulating it, for the replay viewer.
pub fn replay_frames(text: &str) -> Result<(ReplayHeader, Map, Vec<bw4t_protocol::Frame>), ReplayError> {
    use bw4t_protocol::{Frame, FrameMessage};
    let (header, lines) = read_replay(text)?;
    let (map, mut game) = start(&header)?;
    let mut frames = Vec::new();
    let mut said: Vec<FrameMessage> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for (_, line) in &lines {
        let tick = match line {
            ReplayLine::Header(_) => continue,
            ReplayLine::Tick { tick, .. }
            | ReplayLine::Digest { tick, .. }
            | ReplayLine::End { tick, .. } => *tick,
        };
        while game.tick() < tick {
            frames.push(Frame::of(&game, std::mem::take(&mut said)));
            game.step();
        }
        let ReplayLine::Tick { events, .. } = line else { continue };
        for event in events {
            match event {
                ReplayEvent::Join { name, .. } => {
                    if game.join(name).is_ok() {
                        names.push(name.clone());
                    }
                }
                ReplayEvent::Leave { robot } => {
                    let _ = game.leave(RobotId(*robot));
                }
                ReplayEvent::Stop { robot } => {
                    let _ = game.stop(RobotId(*robot));
                }
                ReplayEvent::Act { robot, .. } => {
                    if let Some(action) = event.action() {
                        if let bw4t_sim::Action::SendMessage { to, text } = &action {
                            let to = match to {
                                bw4t_sim::Receiver::All => "all".to_string(),
                                bw4t_sim::Receiver::Player(p) => p.clone(),
                            };
                            let from = names.get(*robot as usize).cloned().unwrap_or_default();
                            said.push(FrameMessage { from, to, text: text.clone() });
                        }
                        let _ = game.handle_action(RobotId(*robot), action);
                    }
                }
            }
        }
    }
    frames.push(Frame::of(&game, said));
    Ok((header, map, frames))
}
