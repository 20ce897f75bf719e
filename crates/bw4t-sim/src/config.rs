//! Match configuration: timing, speed and rule options.

/// How a match runs. The defaults follow BW4T2.
#[derive(Clone, Debug, PartialEq)]
pub struct MatchConfig {
    /// Simulated ticks per simulated second.
    pub ticks_per_second: u32,
    /// Distance a robot travels per tick, in map units.
    pub speed: f32,
    /// Whether robots block each other outside rooms (off in the original).
    pub robot_collisions: bool,
    /// How robots' moves reach the physics; every choice gives the same match, bit for bit.
    pub motion: Motion,
}

/// How robots' moves reach rapier. Both give the same positions, outcomes and digests;
/// they differ only in what a tick costs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Motion {
    /// A robot has a body only when robots collide, and the world is stepped only then:
    /// otherwise a tick costs the robots' shape casts against the static walls and guards.
    #[default]
    Kinematic,
    /// Every robot has a kinematic body and the world is stepped every tick, as before
    /// [`Motion::Kinematic`] existed: the reference the cheaper motion is checked against.
    Stepped,
}

impl Default for MatchConfig {
    fn default() -> Self {
        MatchConfig { ticks_per_second: 20, speed: 0.5, robot_collisions: false, motion: Motion::Kinematic }
    }
}

/// A configuration value out of range.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// Ticks per second outside `1..=MAX_TICKS_PER_SECOND`.
    #[error("ticks per second must be from 1 to {max}, got {0}", max = MatchConfig::MAX_TICKS_PER_SECOND)]
    TickRate(u32),
    /// Speed not positive, not finite, or so fast a robot would skip through a room.
    #[error("speed must be above 0 and at most {max} map units per tick, got {0}", max = MatchConfig::MAX_SPEED)]
    Speed(f32),
}

impl MatchConfig {
    /// Faster than this and a robot could step over a door's approach in one tick.
    pub const MAX_SPEED: f32 = 5.0;

    /// The fastest tick rate: a realtime match ticks every millisecond at most, which
    /// the server's timers can keep, and a tick period is never zero.
    pub const MAX_TICKS_PER_SECOND: u32 = 1000;

    /// Checks every value is in range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(1..=Self::MAX_TICKS_PER_SECOND).contains(&self.ticks_per_second) {
            return Err(ConfigError::TickRate(self.ticks_per_second));
        }
        if !(self.speed > 0.0 && self.speed <= Self::MAX_SPEED) {
            return Err(ConfigError::Speed(self.speed));
        }
        Ok(())
    }

    /// Simulated seconds after `ticks` ticks.
    pub fn seconds(&self, ticks: u64) -> f64 {
        ticks as f64 / f64::from(self.ticks_per_second)
    }
}

#[cfg(test)]
mod tests {
    use super::{ConfigError, MatchConfig};

    #[test]
    fn a_tick_rate_outside_its_range_is_refused_with_the_range() {
        for (rate, ok) in [(0, false), (1, true), (1000, true), (1001, false), (2_000_000_000, false)] {
            let config = MatchConfig { ticks_per_second: rate, ..MatchConfig::default() };
            assert_eq!(config.validate().is_ok(), ok, "{rate}");
        }
        let refused = MatchConfig { ticks_per_second: 0, ..MatchConfig::default() }.validate();
        assert_eq!(refused, Err(ConfigError::TickRate(0)));
        let message = refused.expect_err("refused").to_string();
        assert_eq!(message, "ticks per second must be from 1 to 1000, got 0");
    }
}
