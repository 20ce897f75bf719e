//! Every message of the protocol, as Rust types that serialise to the wire shapes.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::result::MatchResult;
use crate::vocabulary::{AckCode, ByeReason, EndReason, ErrorCode, Mode, MoveState, Outcome};

/// An id chosen by the client for an `act`, echoed in its `ack` and `result`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum ActId {
    /// A number.
    Number(u64),
    /// A string.
    Text(String),
}

/// A fact: a JSON array `[name, arg, ...]`, e.g. `["in","RoomC1"]` or `["color",12,"Red"]`.
pub type Fact = Vec<Value>;

/// A message from a client.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ClientMessage {
    /// The first message: who the client is and what it speaks.
    Hello(Hello),
    /// An action for the client's robot.
    Act(Act),
    /// A message to another player or to all.
    Say(Say),
    /// Lockstep: the client is done with this tick.
    Ready(Ready),
    /// Asks for a full snapshot of the client's percepts.
    Resync(Resync),
    /// Asks for a `pong`.
    Ping(Ping),
    /// The client leaves.
    Bye(ClientBye),
    /// How the player is driven (tool calls, thinking time, model tokens), cumulative;
    /// the last one is in the result.
    Report(crate::PlayerUsage),
}

/// Whether a client plays or watches, and with which credential.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// Drives a robot (the player token, if the server has one).
    #[default]
    Agent,
    /// Watches the whole match; cannot act. Sees private messages only if the server
    /// allows it (the spectator token, when spectating is not open).
    Spectator,
    /// Watches like a spectator and sees every message (the operator token).
    Operator,
}

/// `hello`: the client's introduction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Hello {
    /// Must be `bw4t`.
    pub protocol: String,
    /// Protocol versions the client speaks; the server picks the highest it shares.
    pub versions: Vec<u32>,
    /// `agent` (default), `spectator` or `operator`.
    #[serde(default)]
    pub role: Role,
    /// The player name wanted (agents): letters and digits, starting with a letter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The credential of the role: the player, spectator or operator token.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub token: Option<String>,
    /// A session token from an earlier `welcome`, to take the robot back after a drop.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub session: Option<String>,
    /// Send a `percepts` message every tick, even an empty one (lockstep waits for each).
    #[serde(default, skip_serializing_if = "is_false")]
    pub every_tick: bool,
    /// Agents: add `words` to every `percepts`, the robot's situation in plain English.
    #[serde(default, skip_serializing_if = "is_false")]
    pub words: bool,
    /// The live match to join, by name (any role). Without it and `template`: the server's
    /// default match. A reconnecting player names the match its session belongs to.
    #[serde(default, rename = "match", skip_serializing_if = "Option::is_none")]
    pub match_name: Option<String>,
    /// Agents: the template whose next match with a free seat to join (queued until one has).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub template: Option<String>,
    /// Agents: a seat token the server granted for this `name` in this template's matches
    /// (a study's trial page gives one); a template that seats only invited players
    /// refuses a player without it (`not_invited`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seat: Option<String>,
}

impl Hello {
    /// An agent's `hello` in this crate's protocol and version, asking for `name`.
    pub fn agent(name: impl Into<String>, token: Option<String>) -> Hello {
        Hello {
            protocol: crate::PROTOCOL.to_string(),
            versions: vec![crate::VERSION],
            role: Role::Agent,
            name: Some(name.into()),
            token,
            session: None,
            every_tick: false,
            words: false,
            match_name: None,
            template: None,
            seat: None,
        }
    }
}

impl ClientMessage {
    /// `ready` for `tick`.
    pub fn ready(tick: u64) -> ClientMessage {
        ClientMessage::Ready(Ready { tick })
    }
}

/// `act`: one action.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Act {
    /// Echoed in the `ack` and the `result`.
    pub id: ActId,
    /// `goTo`, `goToBlock`, `pickUp`, `putDown` or `sendMessage`.
    pub action: String,
    /// The action's arguments, in the spec's order.
    #[serde(default)]
    pub args: Vec<Value>,
}

/// `say`: a message in the shared language (`said`), delivered to the receiver as
/// `["message", sender, sentence, said]`, or free text (`text`), delivered as
/// `["message", sender, text]`. Exactly one of the two.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Say {
    /// Optional id, echoed in the `ack`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<ActId>,
    /// A player's name, or `all` for every other player.
    pub to: String,
    /// Free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub text: Option<String>,
    /// A message of the language.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub said: Option<crate::Said>,
}

/// `ready`: the client has sent everything it wants applied after `tick`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Ready {
    /// The tick of the `percepts` being answered.
    pub tick: u64,
}

/// `resync`: no fields.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Resync {}

/// `ping`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Ping {
    /// Optional id, echoed in the `pong`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<ActId>,
}

/// `bye` from a client.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct ClientBye {}

/// A message from the server.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ServerMessage {
    /// The answer to a successful `hello`.
    Welcome(Welcome),
    /// What the robot perceives: a delta, or a full snapshot.
    Percepts(Percepts),
    /// An action accepted or rejected.
    Ack(Ack),
    /// How a durative action (`goTo`, `goToBlock`) ended.
    Result(ActResult),
    /// Something was wrong with what the client sent.
    Error(ErrorMessage),
    /// The answer to `ping`.
    Pong(Pong),
    /// The match is over.
    MatchEnd(MatchEnd),
    /// The server closes the connection.
    Bye(ServerBye),
    /// Spectators: the whole state of the match.
    Frame(Frame),
    /// Before the first tick: who is in the match and how many it still waits for; or,
    /// before `welcome`, the player's place in a template's queue.
    Lobby(Lobby),
    /// The operator paused the match (no tick until resumed) or resumed it.
    Pause(Pause),
}

/// `pause`: sent to every player and watcher when the operator pauses or resumes the
/// match, and to one who joins while it is paused.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Pause {
    /// Paused (`true`) or resumed (`false`).
    pub paused: bool,
    /// The match's tick at that moment.
    pub tick: u64,
}

/// `welcome`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Welcome {
    /// The protocol version chosen.
    pub version: u32,
    /// The player's name (agents).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The robot's id (agents).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robot: Option<u32>,
    /// Present this in a later `hello` to take the robot back after a dropped connection.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub session: Option<String>,
    /// Spectators and operators: whether their frames carry private (addressed) messages.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub private_messages: Option<bool>,
    /// About the match.
    #[serde(rename = "match")]
    pub match_info: MatchInfo,
}

/// The match a client joined.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MatchInfo {
    /// The match's name on the server (the `match` of a later `hello`).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub name: String,
    /// This run of the match (`NAME.RUN`): the id its result and replay are filed under.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub id: String,
    /// The template the match was made from, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub template: Option<String>,
    /// The map's name.
    pub map: String,
    /// The match seed.
    pub seed: u64,
    /// `realtime` or `lockstep`.
    pub mode: Mode,
    /// Simulated ticks per simulated second.
    pub tick_hz: u32,
    /// Lockstep only: how long the server waits for `ready` (0: forever).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deadline_ms: Option<u64>,
    /// How many connected players the match waits for before its first tick.
    pub players_needed: usize,
    /// The last tick, if the match has a limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_ticks: Option<u64>,
    /// The messages players may send: the kinds of the language allowed, and whether
    /// free text is.
    #[serde(default)]
    pub language: crate::MessagePolicy,
    /// Whether this client gets `percepts` every tick.
    pub every_tick: bool,
}

/// `lobby`: a match waiting for its players, as its connections see it.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Lobby {
    /// The match's name; absent while the player is queued for a template.
    #[serde(default, rename = "match", skip_serializing_if = "Option::is_none")]
    pub match_name: Option<String>,
    /// The template the match comes from, or the one queued for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub template: Option<String>,
    /// The players in the match now, built-in agents included, in robot order.
    #[serde(default)]
    pub players: Vec<String>,
    /// Seats kept for players by name who have not come yet (counted in `awaited`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub expected: Vec<String>,
    /// How many more players the match waits for before its first tick.
    #[serde(default)]
    pub awaited: usize,
    /// The match starts anyway in this many milliseconds (empty seats filled by built-in
    /// teammates when its template says so).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_in_ms: Option<u64>,
    /// Before `welcome`: the player's place in the template's queue (1: next).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub queued: Option<usize>,
    /// The match has started: the last `lobby` a connection gets.
    #[serde(default, skip_serializing_if = "is_false")]
    pub started: bool,
}

/// `percepts`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Percepts {
    /// The tick the facts hold at.
    pub tick: u64,
    /// Facts that started to hold or changed value, and messages.
    #[serde(default)]
    pub add: Vec<Fact>,
    /// Facts that stopped holding.
    #[serde(default)]
    pub not: Vec<Fact>,
    /// A full snapshot: forget everything held before.
    #[serde(default, skip_serializing_if = "is_false")]
    pub full: bool,
    /// For a player whose `hello` asked for `words`: what its robot knows after these
    /// percepts, in a few short lines of English.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub words: Option<String>,
}

/// `ack`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Ack {
    /// The `act` (or `say`) id.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<ActId>,
    /// Whether the action was accepted.
    pub ok: bool,
    /// The tick the action was applied after.
    pub tick: u64,
    /// Why not (a stable code), when rejected.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub code: Option<AckCode>,
    /// Why not, in words, when rejected.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

/// `result`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ActResult {
    /// The `act` id.
    pub id: ActId,
    /// How the order ended.
    pub outcome: Outcome,
    /// The tick it ended at.
    pub tick: u64,
}

/// `error`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ErrorMessage {
    /// A stable code (see PROTOCOL.md).
    pub code: ErrorCode,
    /// What was wrong, in words.
    pub message: String,
    /// Whether the server closes the connection after it.
    pub fatal: bool,
}

/// `pong`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Pong {
    /// The `ping` id.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<ActId>,
}

/// `match_end`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MatchEnd {
    /// Why the match ended.
    pub reason: EndReason,
    /// The results.
    pub result: MatchResult,
}

/// `bye` from the server.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ServerBye {
    /// Why the connection closes.
    pub reason: ByeReason,
}

/// `frame`: the god view, for spectators.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Frame {
    /// The tick.
    pub tick: u64,
    /// Simulated seconds.
    pub sim_seconds: f64,
    /// The goal colours.
    pub sequence: Vec<String>,
    /// The next colour needed.
    pub sequence_index: u32,
    /// Every robot.
    pub robots: Vec<FrameRobot>,
    /// Every block still in the world.
    pub blocks: Vec<FrameBlock>,
    /// Rooms that are occupied.
    pub occupied: Vec<String>,
    /// Messages sent since the previous frame.
    pub messages: Vec<FrameMessage>,
}

/// A robot in a frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FrameRobot {
    /// Robot id.
    pub id: u32,
    /// Player name.
    pub name: String,
    /// Centre x.
    pub x: f32,
    /// Centre y.
    pub y: f32,
    /// Its move state.
    pub state: MoveState,
    /// The block held.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub holding: Option<u32>,
}

/// A block in a frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FrameBlock {
    /// Block id.
    pub id: u32,
    /// Colour name.
    pub color: String,
    /// Centre x (the holder's, when held).
    pub x: f32,
    /// Centre y.
    pub y: f32,
    /// The robot holding it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_by: Option<u32>,
}

/// A message in a frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FrameMessage {
    /// Sender's name.
    pub from: String,
    /// Receiver's name, or `all`.
    pub to: String,
    /// The text: the sentence of a message of the language.
    pub text: String,
    /// The message of the language, if it is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub said: Option<crate::Said>,
}

impl FrameMessage {
    /// The frame's form of a message a match carried as `text`: a message of the language
    /// shows its sentence and carries its structured form.
    pub fn new(from: String, to: String, text: &str) -> FrameMessage {
        let said = crate::Said::from_text(text);
        let text = said.as_ref().and_then(|s| s.sentence().ok()).unwrap_or_else(|| text.to_string());
        FrameMessage { from, to, text, said }
    }
}

fn is_false(b: &bool) -> bool {
    !*b
}
