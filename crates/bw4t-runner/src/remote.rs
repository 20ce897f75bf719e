//! Any [`Agent`] as a TCP client: it plays a served match through the protocol exactly as
//! it plays in-process, deciding when its player is told something.

use std::net::SocketAddr;

use bw4t_agents::{ActionAck, Agent, Observation, OrderDone};
use bw4t_protocol::{
    ActId, ClientMessage, Hello, MatchResult, ServerMessage, act_message, decode_server, encode,
    percepts_delta,
};
use bw4t_sim::OrderOutcome;
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
    hello: Hello,
    mut agent: Box<dyn Agent>,
) -> Result<MatchResult, RemoteError> {
    let stream = TcpStream::connect(addr).await?;
    stream.set_nodelay(true)?;
    let (reader, mut writer) = stream.into_split();
    let mut lines = BufReader::new(reader).lines();
    writer.write_all(encode(&ClientMessage::Hello(hello)).as_bytes()).await?;
    let mut told = Observation::default();
    let mut next_action = 0u64;
    // `act` ids are the agent's action numbers, so acks and results map straight back.
    while let Some(line) = lines.next_line().await? {
        let message = decode_server(&line).map_err(|e| RemoteError::Protocol(e.to_string()))?;
        match message {
            ServerMessage::Ack(ack) => {
                if let Some(ActId::Number(n)) = ack.id {
                    let result = if ack.ok {
                        Ok(())
                    } else {
                        Err(ack.code.map(|c| c.to_string()).unwrap_or_default())
                    };
                    told.acks.push(ActionAck { action: n, result });
                }
            }
            ServerMessage::Result(result) => {
                let ActId::Number(n) = result.id else { continue };
                let outcome = match result.outcome.as_str() {
                    "arrived" => OrderOutcome::Arrived,
                    "collided" => OrderOutcome::Collided,
                    _ => OrderOutcome::Superseded,
                };
                told.done.push(OrderDone { action: n, outcome });
            }
            ServerMessage::Percepts(p) => {
                let delta = percepts_delta(&p).map_err(|e| RemoteError::Protocol(e.to_string()))?;
                // The same rule as in-process: decide when told something, or when the agent
                // asked to be woken by now (on time if the hello asked for every tick).
                let due = agent.wake_at().is_some_and(|tick| p.tick >= tick);
                let decide = !delta.is_empty() || !told.done.is_empty() || due;
                if !delta.is_empty() {
                    told.percepts.push(delta);
                }
                let mut out = String::new();
                if decide {
                    told.tick = p.tick;
                    for action in agent.decide(&told) {
                        out += &encode(&act_message(next_action, &action));
                        next_action += 1;
                    }
                    told = Observation::default();
                }
                out += &encode(&ClientMessage::ready(p.tick));
                writer.write_all(out.as_bytes()).await?;
            }
            ServerMessage::MatchEnd(end) => return Ok(end.result),
            ServerMessage::Error(e) if e.fatal => {
                return Err(RemoteError::Protocol(format!("{}: {}", e.code, e.message)));
            }
            _ => {}
        }
    }
    Err(RemoteError::Protocol("the server closed the connection before the end".into()))
}
