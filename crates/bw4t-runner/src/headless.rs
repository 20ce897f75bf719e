//! A whole match in-process, as fast as the machine allows.

use bw4t_agents::{Agent, Driver};
use bw4t_map::Map;
use bw4t_protocol::{Recorder, ReplayEvent};
use bw4t_sim::{JoinError, Match, MatchConfig, MatchError};

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
    Join(#[from] JoinError),
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
) -> Result<(Match, &'static str), RunError> {
    let mut game = Match::new(map, config, seed)?;
    let mut drivers = Vec::with_capacity(seats.len());
    for seat in seats {
        let robot = game.join(&seat.name)?;
        if let Some(r) = recorder.as_deref_mut() {
            r.event(game.tick(), ReplayEvent::Join { name: seat.name.clone(), robot: robot.0 });
        }
        drivers.push(Driver::new(robot, seat.agent));
    }
    let reason = loop {
        for driver in &mut drivers {
            driver.observe(&mut game);
        }
        if game.is_complete() {
            break "completed";
        }
        if game.tick() >= max_ticks {
            break "max_ticks";
        }
        for driver in &mut drivers {
            for (n, action) in driver.take_queued() {
                let outcome = game.handle_action(driver.robot, action.clone());
                if let Some(r) = recorder.as_deref_mut() {
                    r.event(game.tick(), ReplayEvent::act(driver.robot, &action, outcome.is_ok()));
                }
                driver.answered(n, &outcome);
            }
        }
        let report = game.step();
        if let Some(r) = recorder.as_deref_mut() {
            r.stepped(&game);
        }
        for end in &report.ended {
            if let Some(driver) = drivers.iter_mut().find(|d| d.robot == end.robot) {
                driver.ended(end);
            }
        }
    };
    Ok((game, reason))
}
