//! The wire's words, each listed once: error and ack codes, why connections close and
//! matches end, how orders end, robots' move states, agents' statuses and how a match is
//! paced. Each is an enum
//! serialised as the string the protocol documents, so the JSON Schemas list its values.

use std::fmt;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Declares an enum of wire words: each variant with its string, `ALL`, `as_str`,
/// `parse`, `Display`, and comparison with `&str`.
macro_rules! words {
    ($(#[$meta:meta])* $name:ident { $($(#[$vmeta:meta])* $variant:ident = $text:literal,)* }) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize, JsonSchema)]
        pub enum $name {
            $($(#[$vmeta])* #[serde(rename = $text)] $variant,)*
        }

        impl $name {
            /// Every value, in the documented order.
            pub const ALL: &'static [$name] = &[$($name::$variant,)*];

            /// The word on the wire.
            pub fn as_str(self) -> &'static str {
                match self {
                    $($name::$variant => $text,)*
                }
            }

            /// The value whose word is `text`.
            pub fn parse(text: &str) -> Option<$name> {
                $name::ALL.iter().copied().find(|w| w.as_str() == text)
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.as_str())
            }
        }

        impl PartialEq<&str> for $name {
            fn eq(&self, other: &&str) -> bool {
                self.as_str() == *other
            }
        }

        impl PartialEq<$name> for &str {
            fn eq(&self, other: &$name) -> bool {
                *self == other.as_str()
            }
        }
    };
}

words! {
    /// The code of an `error` message.
    ErrorCode {
        /// A line is not valid UTF-8.
        BadUtf8 = "bad_utf8",
        /// A line is longer than 64 KiB.
        LineTooLong = "line_too_long",
        /// A line is not JSON.
        BadJson = "bad_json",
        /// Not a JSON object, no string `type`, or a field missing or of the wrong type.
        BadMessage = "bad_message",
        /// `type` names no client message.
        UnknownType = "unknown_type",
        /// A request before `hello`.
        NoHello = "no_hello",
        /// A second `hello` on the connection.
        AlreadyJoined = "already_joined",
        /// A spectator tried to play.
        NotAPlayer = "not_a_player",
        /// `ready` for a tick that is over.
        LateReady = "late_ready",
        /// `ready` for a tick that has not happened.
        BadTick = "bad_tick",
        /// `hello.protocol` is not `bw4t`.
        BadProtocol = "bad_protocol",
        /// No common protocol version.
        UnsupportedVersion = "unsupported_version",
        /// The token does not open the role asked for.
        BadToken = "bad_token",
        /// The session is unknown or expired.
        BadSession = "bad_session",
        /// The name is not a valid player name.
        InvalidName = "invalid_name",
        /// Another player in the match has the name.
        NameTaken = "name_taken",
        /// The match admits no more players.
        MatchFull = "match_full",
        /// The server has as many connections as it takes.
        ServerFull = "server_full",
        /// The connection's source address has as many connections as one address may.
        SourceFull = "source_full",
        /// The template seats only invited players (a study's participants), and the
        /// `hello` has no seat token for it.
        NotInvited = "not_invited",
        /// A request came sooner than its rate allows (`resync`).
        RateLimited = "rate_limited",
        /// No `hello` in time.
        HelloTimeout = "hello_timeout",
        /// Another connection took up the session.
        Replaced = "replaced",
        /// The client did not read its messages.
        TooSlow = "too_slow",
        /// The player missed too many deadlines in a row.
        Unresponsive = "unresponsive",
        /// `hello.match` names no live match.
        UnknownMatch = "unknown_match",
        /// `hello.template` names no template of the server.
        UnknownTemplate = "unknown_template",
        /// The match failed inside the server and was ended; other matches go on.
        MatchFailed = "match_failed",
        /// The server is stopping: it takes no one into a match any more.
        ServerStopping = "server_stopping",
    }
}

words! {
    /// Why an `act` or `say` was rejected (`ack.code`).
    AckCode {
        /// `action` is not one of the five.
        UnknownAction = "unknown_action",
        /// `args` do not fit the action.
        BadArgs = "bad_args",
        /// More actions and messages since the last boundary than allowed.
        RateLimited = "rate_limited",
        /// The match does not allow this message (its kind, or free text).
        NotAllowed = "not_allowed",
        /// The robot is not in the match.
        UnknownRobot = "unknown_robot",
        /// Not a place of the map.
        UnknownPlace = "unknown_place",
        /// No route from here.
        Unreachable = "unreachable",
        /// No such block, or it has left the world.
        UnknownBlock = "unknown_block",
        /// The block is not in the robot's room.
        BlockNotVisible = "block_not_visible",
        /// No block within reach.
        NotAtBlock = "not_at_block",
        /// The robot already holds a block.
        AlreadyHolding = "already_holding",
        /// The robot holds no block.
        NotHolding = "not_holding",
        /// No room to put the block down.
        NoSpace = "no_space",
        /// No player of that name.
        UnknownReceiver = "unknown_receiver",
    }
}

impl From<&bw4t_sim::Rejection> for AckCode {
    fn from(rejection: &bw4t_sim::Rejection) -> AckCode {
        use bw4t_sim::Rejection as R;
        match rejection {
            R::UnknownRobot(_) => AckCode::UnknownRobot,
            R::UnknownPlace(_) => AckCode::UnknownPlace,
            R::Unreachable(_) => AckCode::Unreachable,
            R::UnknownBlock(_) => AckCode::UnknownBlock,
            R::BlockNotVisible(_) => AckCode::BlockNotVisible,
            R::NotAtBlock => AckCode::NotAtBlock,
            R::AlreadyHolding(_) => AckCode::AlreadyHolding,
            R::NotHolding => AckCode::NotHolding,
            R::NoSpace => AckCode::NoSpace,
            R::UnknownReceiver(_) => AckCode::UnknownReceiver,
        }
    }
}

words! {
    /// Why a connection closes without an error (`bye.reason`; after a fatal `error` the
    /// reason is its code).
    Leaving {
        /// The client said `bye`.
        Goodbye = "goodbye",
        /// The match is over.
        MatchOver = "match_over",
    }
}

/// Why a connection closes (`bye.reason`): a leaving, or the code of the fatal error sent
/// just before.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum ByeReason {
    /// Closed without an error.
    Leaving(Leaving),
    /// Closed after a fatal error with this code.
    Error(ErrorCode),
}

impl ByeReason {
    /// The word on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            ByeReason::Leaving(l) => l.as_str(),
            ByeReason::Error(e) => e.as_str(),
        }
    }
}

impl From<Leaving> for ByeReason {
    fn from(l: Leaving) -> ByeReason {
        ByeReason::Leaving(l)
    }
}

impl From<ErrorCode> for ByeReason {
    fn from(e: ErrorCode) -> ByeReason {
        ByeReason::Error(e)
    }
}

impl PartialEq<&str> for ByeReason {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

impl fmt::Display for ByeReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

words! {
    /// Why a match ended.
    EndReason {
        /// The whole sequence was delivered.
        Completed = "completed",
        /// The tick limit was reached.
        MaxTicks = "max_ticks",
        /// The server was stopped, or the run interrupted.
        Interrupted = "interrupted",
        /// Every player left a started match and none came back within the grace period
        /// (built-in agents do not count): it ends so its seats serve someone else.
        Abandoned = "abandoned",
        /// The match could not be played, or failed inside the server (a row's or the
        /// index's `error` says why).
        Error = "error",
    }
}

words! {
    /// How a durative order ended (`result.outcome`).
    Outcome {
        /// The robot reached its target.
        Arrived = "arrived",
        /// The robot was stopped and dropped its plan.
        Collided = "collided",
        /// A newer order replaced it.
        Superseded = "superseded",
    }
}

impl From<bw4t_sim::OrderOutcome> for Outcome {
    fn from(outcome: bw4t_sim::OrderOutcome) -> Outcome {
        match outcome {
            bw4t_sim::OrderOutcome::Arrived => Outcome::Arrived,
            bw4t_sim::OrderOutcome::Collided => Outcome::Collided,
            bw4t_sim::OrderOutcome::Superseded => Outcome::Superseded,
        }
    }
}

impl From<Outcome> for bw4t_sim::OrderOutcome {
    fn from(outcome: Outcome) -> bw4t_sim::OrderOutcome {
        match outcome {
            Outcome::Arrived => bw4t_sim::OrderOutcome::Arrived,
            Outcome::Collided => bw4t_sim::OrderOutcome::Collided,
            Outcome::Superseded => bw4t_sim::OrderOutcome::Superseded,
        }
    }
}

words! {
    /// A robot's move state, as a frame shows it.
    MoveState {
        /// Standing where its last order took it.
        Arrived = "arrived",
        /// On its way.
        Traveling = "traveling",
        /// Stopped short of its target.
        Collided = "collided",
    }
}

impl From<bw4t_sim::MoveState> for MoveState {
    fn from(state: bw4t_sim::MoveState) -> MoveState {
        match state {
            bw4t_sim::MoveState::Arrived => MoveState::Arrived,
            bw4t_sim::MoveState::Traveling => MoveState::Traveling,
            bw4t_sim::MoveState::Collided => MoveState::Collided,
        }
    }
}

words! {
    /// How an agent program fared in a match.
    AgentStatus {
        /// It played to the end.
        Ok = "ok",
        /// It exited or was killed before the end.
        Crashed = "crashed",
        /// It never connected and said hello.
        NeverConnected = "never_connected",
        /// It stopped answering.
        Unresponsive = "unresponsive",
        /// It broke the protocol.
        BadProtocol = "bad_protocol",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_round_trip_through_json_and_text() {
        for code in ErrorCode::ALL {
            let json = serde_json::to_string(code).expect("serialises");
            assert_eq!(json, format!("\"{code}\""));
            assert_eq!(serde_json::from_str::<ErrorCode>(&json).ok(), Some(*code));
            assert_eq!(ErrorCode::parse(code.as_str()), Some(*code));
        }
        let bye: ByeReason = serde_json::from_str("\"too_slow\"").expect("an error code");
        assert_eq!(bye, ByeReason::Error(ErrorCode::TooSlow));
        let bye: ByeReason = serde_json::from_str("\"goodbye\"").expect("a leaving");
        assert_eq!(bye, ByeReason::Leaving(Leaving::Goodbye));
        assert!(serde_json::from_str::<EndReason>("\"error: boom\"").is_err());
    }

    #[test]
    fn the_simulation_s_names_are_the_wire_s_words() {
        use bw4t_sim::{Rejection as R, RobotId};
        let rejections = [
            R::UnknownRobot(RobotId(0)),
            R::UnknownPlace("x".into()),
            R::Unreachable("x".into()),
            R::UnknownBlock(0),
            R::BlockNotVisible(0),
            R::NotAtBlock,
            R::AlreadyHolding(0),
            R::NotHolding,
            R::NoSpace,
            R::UnknownReceiver("x".into()),
        ];
        for r in &rejections {
            assert_eq!(AckCode::from(r).as_str(), r.code());
        }
        use bw4t_sim::OrderOutcome as O;
        for o in [O::Arrived, O::Collided, O::Superseded] {
            assert_eq!(Outcome::from(o).as_str(), o.name());
            assert_eq!(bw4t_sim::OrderOutcome::from(Outcome::from(o)), o);
        }
        use bw4t_sim::MoveState as M;
        for m in [M::Arrived, M::Traveling, M::Collided] {
            assert_eq!(MoveState::from(m).as_str(), m.name());
        }
    }
}

/// How a match is paced.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Ticks follow the wall clock.
    Realtime,
    /// Each tick waits for the players (or a deadline).
    Lockstep,
}

impl Mode {
    /// The wire name.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Realtime => "realtime",
            Mode::Lockstep => "lockstep",
        }
    }
}
