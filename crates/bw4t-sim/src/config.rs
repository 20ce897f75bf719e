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
}

impl Default for MatchConfig {
    fn default() -> Self {
        MatchConfig { ticks_per_second: 20, speed: 0.5, robot_collisions: false }
    }
}

/// A configuration value out of range.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// Zero ticks per second.
    #[error("ticks per second must be at least 1")]
    TickRate,
    /// Speed not positive, not finite, or so fast a robot would skip through a room.
    #[error("speed must be above 0 and at most {max} map units per tick, got {0}", max = MatchConfig::MAX_SPEED)]
    Speed(f32),
}

impl MatchConfig {
    /// Faster than this and a robot could step over a door's approach in one tick.
    pub const MAX_SPEED: f32 = 5.0;

    /// Checks every value is in range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.ticks_per_second == 0 {
            return Err(ConfigError::TickRate);
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
