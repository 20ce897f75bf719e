//! How one served match is run: who may join and how, and its pacing. What is played
//! (map, seed, settings, seats, tick limit) is its `bw4t_agents::MatchSetup`.

use std::collections::BTreeMap;
use std::time::Duration;

use bw4t_protocol::{MessagePolicy, Mode};

/// The name of the match that clients naming none join.
pub const DEFAULT_MATCH: &str = "default";

/// How often a served match's replay records a digest, in ticks.
pub const REPLAY_DIGEST_EVERY: u64 = 100;

/// How a served match runs.
#[derive(Clone, Debug)]
pub struct HostConfig {
    /// The match's name on the server (`hello.match`, `welcome.match.name`).
    pub name: String,
    /// This run's id (`NAME.RUN`, `welcome.match.id`), under which its result is filed;
    /// set by the arena.
    pub id: String,
    /// The template the match was made from, if any.
    pub template: Option<String>,
    /// At the start timeout, seat built-in agents of this strategy in the open seats.
    pub fill: Option<bw4t_agents::Strategy>,
    /// Realtime or lockstep pacing.
    pub mode: Mode,
    /// Lockstep: how long to wait for `ready` (`None`: forever).
    pub deadline: Option<Duration>,
    /// The player token: a secret players must present.
    pub token: Option<String>,
    /// The spectator token: with it (or the player token) set, spectators must present it.
    pub spectator_token: Option<String>,
    /// The operator token: the secret of the `operator` role, which sees every message.
    pub operator_token: Option<String>,
    /// Spectators see private (addressed) messages too.
    pub spectators_see_private: bool,
    /// Send every player `percepts` every tick, even empty ones.
    pub every_tick: bool,
    /// How long a dropped player's robot waits for its session to come back.
    pub grace: Duration,
    /// Actions and messages a player may send per tick; more are rejected.
    pub max_actions_per_tick: u32,
    /// A client whose queue stays full this long is disconnected.
    pub slow_limit: Duration,
    /// Spectator frames per wall-clock second, at most.
    pub spectator_hz: u32,
    /// Start even if fewer than `robots` players are connected after this long.
    pub start_timeout: Option<Duration>,
    /// Lockstep: disconnect a player that misses this many deadlines in a row.
    pub max_late_in_row: Option<u32>,
    /// Lockstep: with no player connected, wait for one instead of running on; and, in
    /// any mode, end a started match as `abandoned` once it has had no remote player for
    /// the grace period. Off for matches whose players are programs that will not come
    /// back once gone: those run on without them, to their end.
    pub pause_when_empty: bool,
    /// Which messages players may send.
    pub language: MessagePolicy,
    /// Free-form labels (e.g. a study's condition), written into the replay and the result.
    pub labels: BTreeMap<String, String>,
}

/// The longest any of a match's waits may be (grace, start timeout): a day. Longer ones
/// would overflow the clock's arithmetic, and no player waits that long.
pub const MAX_WAIT: Duration = Duration::from_secs(24 * 60 * 60);

/// The longest a lockstep deadline or the slow-reader limit may be: an hour.
pub const MAX_DEADLINE: Duration = Duration::from_secs(60 * 60);

/// The most actions and messages a player may be allowed per tick.
pub const MAX_ACTIONS_PER_TICK: u32 = 1000;

/// The most spectator frames a second.
pub const MAX_SPECTATOR_HZ: u32 = 60;

impl Default for HostConfig {
    fn default() -> Self {
        HostConfig::new()
    }
}

impl HostConfig {
    /// Checks every figure is in its range (they come from flags, files and the API);
    /// the error names the setting, its range and the value.
    pub fn check(&self) -> Result<(), String> {
        let within = |what: &str, value: Duration, least: Duration, most: Duration| {
            if (least..=most).contains(&value) {
                Ok(())
            } else {
                Err(format!("{what} must be from {least:?} to {most:?}, got {value:?}"))
            }
        };
        let tiny = Duration::from_millis(1);
        if let Some(deadline) = self.deadline {
            within("the lockstep deadline", deadline, tiny, MAX_DEADLINE)?;
        }
        within("the slow-reader limit", self.slow_limit, tiny, MAX_DEADLINE)?;
        within("the reconnect grace", self.grace, Duration::ZERO, MAX_WAIT)?;
        if let Some(start) = self.start_timeout {
            within("the start timeout", start, Duration::ZERO, MAX_WAIT)?;
        }
        let count = |what: &str, value: u32, most: u32| {
            if (1..=most).contains(&value) {
                Ok(())
            } else {
                Err(format!("{what} must be from 1 to {most}, got {value}"))
            }
        };
        count("actions per tick", self.max_actions_per_tick, MAX_ACTIONS_PER_TICK)?;
        count("spectator frames per second", self.spectator_hz, MAX_SPECTATOR_HZ)?;
        if let Some(late) = self.max_late_in_row {
            count("deadlines missed in a row", late, u32::MAX)?;
        }
        Ok(())
    }

    /// The defaults: a realtime match named `default`, open to anyone.
    pub fn new() -> Self {
        HostConfig {
            name: DEFAULT_MATCH.to_string(),
            id: String::new(),
            template: None,
            fill: None,
            mode: Mode::Realtime,
            deadline: Some(Duration::from_millis(1000)),
            token: None,
            spectator_token: None,
            operator_token: None,
            spectators_see_private: false,
            every_tick: false,
            grace: Duration::from_secs(30),
            max_actions_per_tick: 16,
            slow_limit: Duration::from_secs(5),
            spectator_hz: 20,
            start_timeout: None,
            max_late_in_row: None,
            pause_when_empty: true,
            language: MessagePolicy::default(),
            labels: BTreeMap::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::{HostConfig, MAX_WAIT};

    #[test]
    fn figures_out_of_range_are_refused_by_name() {
        assert_eq!(HostConfig::new().check(), Ok(()));
        type Spoil = fn(&mut HostConfig);
        let cases: [(Spoil, &str); 5] = [
            (
                |c| c.grace = MAX_WAIT + Duration::from_secs(1),
                "the reconnect grace must be from 0ns to 86400s",
            ),
            (|c| c.deadline = Some(Duration::ZERO), "the lockstep deadline must be from 1ms to 3600s"),
            (|c| c.start_timeout = Some(Duration::from_secs(u64::MAX)), "the start timeout must be"),
            (|c| c.max_actions_per_tick = 0, "actions per tick must be from 1 to 1000, got 0"),
            (|c| c.spectator_hz = 1000, "spectator frames per second must be from 1 to 60, got 1000"),
        ];
        for (spoil, expected) in cases {
            let mut config = HostConfig::new();
            spoil(&mut config);
            let refused = config.check().expect_err(expected);
            assert!(refused.starts_with(expected), "{refused}");
        }
    }
}
