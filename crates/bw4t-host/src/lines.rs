//! The encoded lines the host and the connections around it send on their own account:
//! `error`, `bye` and `pong`.

use std::sync::Arc;

use bw4t_protocol::{ActId, ByeReason, ErrorCode, ErrorMessage, Pong, ServerBye, ServerMessage, encode};

/// An encoded `error` message.
pub fn error_line(code: ErrorCode, message: &str, fatal: bool) -> Arc<str> {
    let msg = ServerMessage::Error(ErrorMessage { code, message: message.into(), fatal });
    encode(&msg).into()
}

/// An encoded `pong` answering a `ping` with this id.
pub fn pong_line(id: Option<ActId>) -> Arc<str> {
    encode(&ServerMessage::Pong(Pong { id })).into()
}

/// An encoded `bye` message.
pub fn bye_line(reason: impl Into<ByeReason>) -> Arc<str> {
    encode(&ServerMessage::Bye(ServerBye { reason: reason.into() })).into()
}
