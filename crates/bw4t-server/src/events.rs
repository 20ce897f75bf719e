//! What connections and the server tell a match's task, and the handles it reaches a
//! connection's writer with: the channel vocabulary between the layers above the driver.

use std::sync::Arc;

use bw4t_host::{ConnId, HostStatus};
use bw4t_protocol::ClientMessage;
use tokio::sync::{Notify, watch};

use crate::queue::LineQueue;

/// A new connection's handles.
#[derive(Debug)]
pub(crate) struct Opened {
    /// Its id.
    pub conn: ConnId,
    /// Its queue of outgoing lines.
    pub tx: LineQueue,
    /// Closes it at once, queued lines or not (for clients that do not read).
    pub kill: Arc<Notify>,
    /// Becomes true when its writer has finished (flushed and closed).
    pub done: watch::Receiver<bool>,
}

/// What connections tell the match task.
#[derive(Debug)]
pub(crate) enum Event {
    /// A new connection.
    Opened(Opened),
    /// Well-formed messages that arrived together, in order (other than `ping`, answered
    /// by the connection itself); never empty.
    Messages { conn: ConnId, messages: Vec<ClientMessage> },
    /// The connection sent a line that is not a valid message.
    BadInput { conn: ConnId },
    /// The connection is gone.
    Closed { conn: ConnId },
    /// From the server, not a connection.
    Control(Control),
}

/// What the server asks of a match.
#[derive(Debug)]
pub(crate) enum Control {
    /// Where the match is.
    Status(tokio::sync::oneshot::Sender<HostStatus>),
    /// End it now (`interrupted`).
    Stop,
    /// Stop ticking until resumed (`true`), or go on (`false`).
    Pause(bool),
}
