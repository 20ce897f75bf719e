//! A whole match in-process, as fast as the machine allows.

use std::io::Write;
use std::time::Instant;

use bw4t_agents::{Agent, Driver, Team};
use bw4t_map::Map;
use bw4t_protocol::{EndReason, MatchResult, Recorder, ReplayMeta, RobotExtra};
use bw4t_sim::{JoinError, Match, MatchConfig, MatchError};

use crate::external::{AgentReport, SeatSpec};

/// A player of a headless match.
pub struct Seat {
    /// The player's name.
    pub name: String,
    /// Its brain.
    pub agent: Box<dyn Agent>,
}

/// Why a headless match could not run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The match could not be created.
    #[error(transparent)]
    Match(#[from] MatchError),
    /// A seat could not join.
    #[error("player cannot join: {0}")]
    Join(JoinError),
    /// An external seat was given to an in-process match.
    #[error("external agent '{0}' needs a served match")]
    External(String),
    /// The replay could not be written.
    #[error("cannot write the replay: {0}")]
    Replay(std::io::Error),
}

/// Plays a match of built-in seats in-process, recording a replay to `replay` if given;
/// returns the result and a report per seat.
pub fn play_builtin(
    map: &Map,
    seed: u64,
    seats: &[SeatSpec],
    max_ticks: u64,
    replay: Option<Box<dyn Write + Send>>,
) -> Result<(MatchResult, Vec<AgentReport>), RunError> {
    let config = MatchConfig::default();
    let mut recorder = match replay {
        Some(out) => {
            // The recorder describes the match before anyone joins; a fresh one is that.
            let blank = Match::new(map, &config, seed)?;
            let names = seats.iter().map(|s| s.name().to_string()).collect();
            let meta = ReplayMeta {
                program: crate::program(),
                robots: names,
                digest_every: 100,
                max_ticks: Some(max_ticks),
                ..ReplayMeta::default()
            };
            Some(Recorder::new(out, &blank, meta))
        }
        None => None,
    };
    let players = seats
        .iter()
        .map(|s| match s {
            SeatSpec::Builtin { name, strategy } => {
                Ok(Seat { name: name.clone(), agent: strategy.agent(name) })
            }
            SeatSpec::External { name, .. } => Err(RunError::External(name.clone())),
        })
        .collect::<Result<Vec<_>, _>>()?;
    let (mut game, mut team) = set_up(map, &config, seed, players, recorder.as_mut())?;
    // `wall_ms` counts from the first tick, as in a served match.
    let started = Instant::now();
    let reason = play_to_end(&mut game, &mut team, max_ticks, recorder.as_mut());
    let wall_ms = started.elapsed().as_millis() as u64;
    if let Some(recorder) = recorder {
        recorder.finish(&game, reason).map_err(RunError::Replay)?;
    }
    let result = MatchResult::of(&game, None, reason, wall_ms, |_| RobotExtra::LOCAL);
    let reports = seats
        .iter()
        .filter_map(|s| match s {
            SeatSpec::Builtin { name, strategy } => Some(AgentReport::builtin(name, *strategy)),
            SeatSpec::External { .. } => None,
        })
        .collect();
    Ok((result, reports))
}

/// Plays a match to completion or `max_ticks`: each tick every agent that was told
/// something decides, and its actions apply at the next boundary in robot-id order,
/// exactly as in a lockstep server.
pub fn play_headless(
    map: &Map,
    config: &MatchConfig,
    seed: u64,
    seats: Vec<Seat>,
    max_ticks: u64,
    mut recorder: Option<&mut Recorder>,
) -> Result<(Match, EndReason), RunError> {
    let (mut game, mut team) = set_up(map, config, seed, seats, recorder.as_deref_mut())?;
    let reason = play_to_end(&mut game, &mut team, max_ticks, recorder);
    Ok((game, reason))
}

/// A new match with every seat joined, in order.
fn set_up(
    map: &Map,
    config: &MatchConfig,
    seed: u64,
    seats: Vec<Seat>,
    mut recorder: Option<&mut Recorder>,
) -> Result<(Match, Team), RunError> {
    let mut game = Match::new(map, config, seed)?;
    let mut drivers = Vec::with_capacity(seats.len());
    for seat in seats {
        let robot = game.join_logged(&seat.name, &mut recorder).map_err(RunError::Join)?;
        drivers.push(Driver::new(robot, seat.agent));
    }
    Ok((game, Team::new(drivers)))
}

/// Plays ticks until the sequence is complete or `max_ticks` is reached; returns why it ended.
fn play_to_end(
    game: &mut Match,
    team: &mut Team,
    max_ticks: u64,
    mut recorder: Option<&mut Recorder>,
) -> EndReason {
    loop {
        team.observe(game);
        if game.is_complete() {
            break EndReason::Completed;
        }
        if game.tick() >= max_ticks {
            break EndReason::MaxTicks;
        }
        game.boundary(team, &mut recorder);
    }
}
