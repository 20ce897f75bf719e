//! The BW4T wire protocol, version 1: one JSON object per line, named by its `type` field.
//!
//! The only crate that knows the JSON shapes. `protocol/PROTOCOL.md` is the specification;
//! `protocol/schema/` holds a JSON Schema per message, generated from these types.

mod codec;
mod convert;
mod http;
mod knowledge;
mod language;
mod leaderboard;
mod messages;
mod replay;
mod result;
mod row;
mod schema;
mod session;
mod study;
mod table;
mod trajectory;
mod view;
mod vocabulary;
mod words;

pub use codec::{DecodeError, LineBuffer, MAX_LINE, decode_client, decode_server, encode};
pub use convert::{
    ActError, FactError, act_message, action_from_act, action_to_act, fact_to_percept, message_text,
    percept_to_fact, percepts_delta, receiver,
};
pub use http::{
    DoorLayout, ErrorReply, MapLayout, MatchList, MatchState, MatchSummary, ResultList, ServerInfo,
    StoppedMatch, TemplateInfo, Watch, ZoneKindWord, ZoneLayout,
};
pub use knowledge::{Heard, Knowledge, RoomSeen, RoomTold, is_room};
pub use language::{
    Group, KINDS, KindRow, MessagePolicy, SPOKEN_FIRST_POSITION, Said, SaidError, Slot, kind_row,
    language_json,
};
pub use leaderboard::{AgentInfo, LeaderboardRow, UsageTotals};
pub use messages::*;
pub use replay::{REPLAY_FORMAT, Recorder, ReplayEvent, ReplayHeader, ReplayLine, ReplayMeta};
pub use result::{MatchResult, PlayerUsage, RobotExtra, RobotResult};
pub use row::{CSV_COLUMNS, ResultRow, spreadsheet_safe};
pub use schema::schemas;
pub use session::{ClientSession, Closed, Request, SessionError, SessionEvent, SessionOptions};
pub use study::{
    EventsRecorded, ExportCounts, MatrixRow, ParticipantList, ParticipantRow, ParticipantState, QuestionItem,
    QuestionKind, ScreenRequirement, ShowIf, StepConflict, StudyExported, StudyInfo, StudyPage, TrialHello,
    TrialLanguage,
};
pub use table::{
    ACTIONS, ActionRow, PERCEPTS, PerceptRow, Scope, SendType, action_row, percept_row, table_json,
};
pub use trajectory::{
    EnvEncoding, EnvStep, EnvStepTaken, LayoutSegment, RobotTick, TRAJECTORY_FORMAT, TrajectoryAction,
    TrajectoryMessage, TrajectoryMeta, TrajectoryRobot,
};
pub use vocabulary::{
    AckCode, AgentStatus, ByeReason, EndReason, ErrorCode, Leaving, Mode, MoveState, Outcome,
};
pub use words::Snapshot;

/// The protocol's name, as sent in `hello`.
pub const PROTOCOL: &str = "bw4t";
/// The protocol version this build speaks.
pub const VERSION: u32 = 1;
