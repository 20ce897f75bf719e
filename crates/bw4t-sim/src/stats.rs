//! Statistics the original BW4T logged, per robot and per match.

/// What one robot did during a match.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RobotStats {
    /// Blocks delivered in the needed order.
    pub good_drops: u32,
    /// Blocks dropped in the drop zone that were not the needed colour.
    pub wrong_drops: u32,
    /// Messages sent (one per `sendMessage`, whatever the number of receivers).
    pub messages_sent: u32,
    /// Ticks spent not travelling.
    pub idle_ticks: u64,
    /// Times the robot's centre entered a room.
    pub rooms_entered: u32,
    /// Map units travelled.
    pub distance: f64,
}

/// The match as a whole.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MatchStats {
    /// Ticks simulated so far.
    pub ticks: u64,
    /// The first tick whose state (and percepts) show the whole sequence delivered: the
    /// tick after the boundary at which the last colour was put down.
    pub completed_at: Option<u64>,
    /// How far the sequence got.
    pub sequence_index: u32,
    /// Sum over robots.
    pub good_drops: u32,
    /// Sum over robots.
    pub wrong_drops: u32,
    /// Sum over robots.
    pub messages: u32,
}
