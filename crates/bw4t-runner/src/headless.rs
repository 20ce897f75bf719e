//! A whole match in-process, as fast as the machine allows.

use std::io::Write;
use std::time::Instant;

use bw4t_agents::{Driver, MatchSetup, Player, SetupError, Team};
use bw4t_protocol::{EndReason, MatchResult, Recorder, ReplayMeta, RobotExtra};
use bw4t_sim::{JoinError, Match, MatchError};

use crate::external::AgentReport;

/// Why a headless match could not run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The match could not be created.
    #[error(transparent)]
    Match(#[from] MatchError),
    /// A seat could not join.
    #[error("player cannot join: {0}")]
    Join(JoinError),
    /// The set-up cannot be played in-process (a program's seat, no tick limit, ...).
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The replay could not be written.
    #[error("cannot write the replay: {0}")]
    Replay(std::io::Error),
}

/// Plays a match of in-process seats (built-in agents, or agents the caller makes) to
/// its end, recording a replay to `replay` if given; returns the result and a report per
/// built-in seat.
pub fn play(
    setup: &MatchSetup,
    replay: Option<Box<dyn Write + Send>>,
) -> Result<(MatchResult, Vec<AgentReport>), RunError> {
    let max_ticks = tick_limit(setup)?;
    let mut recorder = match replay {
        Some(out) => {
            // The recorder describes the match before anyone joins; a fresh one is that.
            let blank = Match::new(&setup.map, &setup.game, setup.seed)?;
            let meta = ReplayMeta {
                program: crate::program(),
                robots: setup.names().map(str::to_string).collect(),
                digest_every: 100,
                max_ticks: Some(max_ticks),
                ..ReplayMeta::default()
            };
            Some(Recorder::new(out, &blank, meta))
        }
        None => None,
    };
    let (mut game, mut team) = set_up(setup, recorder.as_mut())?;
    // `wall_ms` counts from the first tick, as in a served match.
    let started = Instant::now();
    let reason = play_to_end(&mut game, &mut team, max_ticks, recorder.as_mut());
    let wall_ms = started.elapsed().as_millis() as u64;
    if let Some(recorder) = recorder {
        recorder.finish(&game, reason).map_err(RunError::Replay)?;
    }
    let result = MatchResult::of(&game, None, reason, wall_ms, |_| RobotExtra::LOCAL);
    let reports = setup
        .seats
        .iter()
        .filter_map(|s| s.strategy().map(|strategy| AgentReport::builtin(&s.name, strategy)))
        .collect();
    Ok((result, reports))
}

/// Plays a match to completion or its tick limit: each tick every agent that was told
/// something decides, and its actions apply at the next boundary in robot-id order,
/// exactly as in a lockstep server.
pub fn play_headless(
    setup: &MatchSetup,
    mut recorder: Option<&mut Recorder>,
) -> Result<(Match, EndReason), RunError> {
    let max_ticks = tick_limit(setup)?;
    let (mut game, mut team) = set_up(setup, recorder.as_deref_mut())?;
    let reason = play_to_end(&mut game, &mut team, max_ticks, recorder);
    Ok((game, reason))
}

/// The tick limit a headless match needs: it has no other end but the sequence.
fn tick_limit(setup: &MatchSetup) -> Result<u64, RunError> {
    setup.max_ticks.ok_or_else(|| SetupError::Invalid("a headless match needs a tick limit".into()).into())
}

/// A new match with every seat joined, in order.
fn set_up(setup: &MatchSetup, mut recorder: Option<&mut Recorder>) -> Result<(Match, Team), RunError> {
    setup.check()?;
    setup.only_players("in a headless match", |p| matches!(p, Player::Builtin(_) | Player::Agent(_)))?;
    let mut game = Match::new(&setup.map, &setup.game, setup.seed)?;
    let mut drivers = Vec::with_capacity(setup.seats.len());
    for seat in &setup.seats {
        let robot = game.join_logged(&seat.name, &mut recorder).map_err(RunError::Join)?;
        let agent = seat.player.agent(&seat.name).expect("checked: every seat is in-process");
        drivers.push(Driver::new(robot, agent));
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
