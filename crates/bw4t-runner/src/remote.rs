//! Any [`Agent`] as a TCP client: it plays a served match through the protocol exactly as
//! it plays in-process, deciding when its player is told something.

use std::net::SocketAddr;

use bw4t_agents::{ActionAck, Agent, Observation, OrderDone};
use bw4t_protocol::{ClientSession, MatchResult, SessionEvent, SessionOptions, Welcome};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpStream;

/// Why a remote game ended without a result.
#[derive(Debug, thiserror::Error)]
pub enum RemoteError {
    /// The connection failed.
    #[error("connection: {0}")]
    Io(std::io::Error),
    /// The server sent something this client cannot use.
    #[error("protocol: {0}")]
    Protocol(String),
}

// By hand rather than `#[from]`, which would also make the error its source and print it
// twice in a chain of causes.
impl From<std::io::Error> for RemoteError {
    fn from(e: std::io::Error) -> Self {
        RemoteError::Io(e)
    }
}

/// Connects, says `hello` (an agent's: its name, token, and the match or template it
/// joins) and lets `agent` play until the match ends; returns the result the server sent.
pub async fn play_remote(
    addr: SocketAddr,
    options: SessionOptions,
    agent: Box<dyn Agent>,
) -> Result<MatchResult, RemoteError> {
    play_remote_told(addr, options, agent, |_| {}).await
}

/// [`play_remote`], telling `welcomed` the `welcome` (which match, which robot) as it comes.
pub async fn play_remote_told(
    addr: SocketAddr,
    options: SessionOptions,
    mut agent: Box<dyn Agent>,
    mut welcomed: impl FnMut(&Welcome) + Send,
) -> Result<MatchResult, RemoteError> {
    let stream = TcpStream::connect(addr).await?;
    stream.set_nodelay(true)?;
    let (reader, mut writer) = stream.into_split();
    let mut lines = BufReader::new(reader).lines();
    let mut session = ClientSession::new(options);
    let mut told = Observation::default();
    loop {
        let out: String = std::iter::from_fn(|| session.poll_transmit()).collect();
        writer.write_all(out.as_bytes()).await?;
        let Some(line) = lines.next_line().await? else { break };
        session.handle_line(&line).map_err(|e| RemoteError::Protocol(e.to_string()))?;
        while let Some(event) = session.poll_event() {
            // The agent numbers its actions from 0, the session its requests from 1, both in
            // the order sent; the session sends nothing but the agent's actions.
            match event {
                SessionEvent::Ack { ack, request: Some(request) } => {
                    let result = if ack.ok {
                        Ok(())
                    } else {
                        Err(ack.code.map(|c| c.to_string()).unwrap_or_default())
                    };
                    told.acks.push(ActionAck { action: request.id - 1, result });
                }
                SessionEvent::Result { result, request: Some(request) } => {
                    told.done.push(OrderDone { action: request.id - 1, outcome: result.outcome.into() });
                }
                SessionEvent::Percepts { delta, .. } => {
                    // The same rule as in-process: decide when told something, or when the
                    // agent asked to be woken by now (on time if the hello asked for every tick).
                    let due = agent.wake_at().is_some_and(|tick| delta.tick >= tick);
                    if !delta.is_empty() || !told.done.is_empty() || due {
                        told.tick = delta.tick;
                        if !delta.is_empty() {
                            told.percepts.push(delta);
                        }
                        for action in agent.decide(&told) {
                            session.act(&action);
                        }
                        told = Observation::default();
                    }
                    session.ready();
                }
                SessionEvent::Welcome(welcome) => welcomed(&welcome),
                SessionEvent::MatchEnd(end) => return Ok(end.result),
                SessionEvent::Error(e) if e.fatal => {
                    return Err(RemoteError::Protocol(format!("{}: {}", e.code, e.message)));
                }
                _ => {}
            }
        }
    }
    Err(RemoteError::Protocol("the server closed the connection before the end".into()))
}
