//! Who drives the robot over HTTP: the first MCP session to call a tool holds the seat
//! until that session ends, and every other session's tool calls are refused meanwhile.
//! The seat is rmcp's session manager too (it wraps the in-memory one), so it hears of a
//! session's end as it happens: a client's `DELETE`, rmcp closing an idle session, or the
//! session's task ending.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use futures_util::Stream;
use rmcp::model::{ClientJsonRpcMessage, ServerJsonRpcMessage};
use rmcp::transport::streamable_http_server::session::local::LocalSessionManager;
use rmcp::transport::streamable_http_server::session::{
    EventStore, RestoreOutcome, ServerSseMessage, SessionId, SessionManager,
};
use tokio::sync::Mutex;
use tokio_util::sync::CancellationToken;

/// The sessions of the HTTP endpoint and the one among them that drives the robot.
#[derive(Default)]
pub(crate) struct Seat {
    sessions: LocalSessionManager,
    /// Taken under this lock only after the session is seen open, and freed under it once
    /// the session is closed, so a closed session never keeps the seat.
    driver: Mutex<Option<Driver>>,
}

struct Driver {
    session: SessionId,
    since: SystemTime,
    /// The session's calls, each cancelled as the session leaves the seat: one still
    /// running ends then, before the next session can reach the robot.
    calls: Vec<CancellationToken>,
}

/// Why a tool call may not drive the robot.
#[derive(Debug)]
pub(crate) enum Refusal {
    /// The call came outside any open session (a sessionless request, or an unknown id).
    NoSession,
    /// Another session drives the robot, since this time.
    Driven(SystemTime),
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refusal::NoSession => write!(
                f,
                "over HTTP the robot is driven from one MCP session: open one with `initialize` and \
                 send its Mcp-Session-Id with every call (a call outside an open session drives nothing)"
            ),
            Refusal::Driven(since) => {
                let ago = SystemTime::now().duration_since(*since).unwrap_or_default();
                write!(
                    f,
                    "the robot is driven by another MCP session, since {} ({} s ago); it is free again \
                     once that session ends: its client closes it (HTTP DELETE of /mcp with its \
                     Mcp-Session-Id), the server closes it after {} s without requests, or `bw4t mcp` \
                     restarts",
                    utc_clock(*since),
                    ago.as_secs(),
                    IDLE_CLOSE.as_secs()
                )
            }
        }
    }
}

/// How long rmcp keeps a session that exchanges nothing (its default, which the seat keeps).
const IDLE_CLOSE: Duration =
    rmcp::transport::streamable_http_server::session::local::SessionConfig::DEFAULT_KEEP_ALIVE;

/// `HH:MM:SS UTC` of `time`.
fn utc_clock(time: SystemTime) -> String {
    let seconds = time.duration_since(UNIX_EPOCH).unwrap_or_default().as_secs() % 86_400;
    format!("{:02}:{:02}:{:02} UTC", seconds / 3600, seconds / 60 % 60, seconds % 60)
}

impl Seat {
    /// Lets `session` drive `call`: it already drives, or the robot is free and the
    /// session open (then it holds the seat from now on). `call` is cancelled if the session
    /// leaves the seat while it runs; it must be cancelled once it ends, to be forgotten.
    pub(crate) async fn take(&self, session: Option<&str>, call: &CancellationToken) -> Result<(), Refusal> {
        let session = session.ok_or(Refusal::NoSession)?;
        let mut driver = self.driver.lock().await;
        match &mut *driver {
            Some(driver) if &*driver.session == session => {
                driver.calls.retain(|call| !call.is_cancelled());
                driver.calls.push(call.clone());
                Ok(())
            }
            Some(driver) => Err(Refusal::Driven(driver.since)),
            None => {
                let session: SessionId = session.into();
                // A sessionless request names whatever id it likes; only an open session's
                // may be seated, or a made-up one would hold the robot for ever.
                if !self.sessions.has_session(&session).await.unwrap_or(false) {
                    return Err(Refusal::NoSession);
                }
                *driver = Some(Driver { session, since: SystemTime::now(), calls: vec![call.clone()] });
                Ok(())
            }
        }
    }

    /// Frees the seat if `session` (now closed) held it, ending its calls still running.
    async fn leave(&self, session: &SessionId) {
        let mut driver = self.driver.lock().await;
        if let Some(left) = driver.take_if(|driver| driver.session == *session) {
            left.calls.iter().for_each(CancellationToken::cancel);
        }
    }
}

/// rmcp's in-memory sessions, with every close freeing the seat.
impl SessionManager for Seat {
    type Error = <LocalSessionManager as SessionManager>::Error;
    type Transport = <LocalSessionManager as SessionManager>::Transport;

    fn create_session(
        &self,
    ) -> impl Future<Output = Result<(SessionId, Self::Transport), Self::Error>> + Send {
        self.sessions.create_session()
    }

    fn initialize_session(
        &self,
        id: &SessionId,
        message: ClientJsonRpcMessage,
    ) -> impl Future<Output = Result<ServerJsonRpcMessage, Self::Error>> + Send {
        self.sessions.initialize_session(id, message)
    }

    fn has_session(&self, id: &SessionId) -> impl Future<Output = Result<bool, Self::Error>> + Send {
        self.sessions.has_session(id)
    }

    async fn close_session(&self, id: &SessionId) -> Result<(), Self::Error> {
        let closed = self.sessions.close_session(id).await;
        self.leave(id).await;
        closed
    }

    fn create_stream(
        &self,
        id: &SessionId,
        message: ClientJsonRpcMessage,
    ) -> impl Future<
        Output = Result<impl Stream<Item = ServerSseMessage> + Send + Sync + 'static, Self::Error>,
    > + Send {
        self.sessions.create_stream(id, message)
    }

    fn accept_message(
        &self,
        id: &SessionId,
        message: ClientJsonRpcMessage,
    ) -> impl Future<Output = Result<(), Self::Error>> + Send {
        self.sessions.accept_message(id, message)
    }

    fn create_standalone_stream(
        &self,
        id: &SessionId,
    ) -> impl Future<
        Output = Result<impl Stream<Item = ServerSseMessage> + Send + Sync + 'static, Self::Error>,
    > + Send {
        self.sessions.create_standalone_stream(id)
    }

    fn resume(
        &self,
        id: &SessionId,
        last_event_id: String,
    ) -> impl Future<
        Output = Result<impl Stream<Item = ServerSseMessage> + Send + Sync + 'static, Self::Error>,
    > + Send {
        self.sessions.resume(id, last_event_id)
    }

    fn restore_session(
        &self,
        id: SessionId,
    ) -> impl Future<Output = Result<RestoreOutcome<Self::Transport>, Self::Error>> + Send {
        self.sessions.restore_session(id)
    }

    fn event_store(&self) -> Option<std::sync::Arc<dyn EventStore>> {
        self.sessions.event_store()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_is_utc_hours_minutes_seconds() {
        let time = UNIX_EPOCH + Duration::from_secs(3 * 86_400 + 13 * 3600 + 5 * 60 + 9);
        assert_eq!(utc_clock(time), "13:05:09 UTC");
    }
}
