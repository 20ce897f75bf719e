//! The connection to the match: one task owns the socket and the [`Robot`], and tool
//! calls reach it over a channel, one at a time; a call cancelled (or dropped) by its
//! caller ends at once, so the robot never stays busy for a caller that has gone.

use std::io::Write;
use std::net::SocketAddr;
use std::time::{Duration, Instant};

use bw4t_protocol::{Closed, MatchInfo, PlayerUsage, SessionOptions};
use serde_json::{Value, json};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpStream;
use tokio::net::tcp::OwnedWriteHalf;
use tokio::sync::{mpsc, oneshot};
use tokio_util::sync::CancellationToken;

use crate::robot::{Busy, Command, Report, Robot, tool_name};
use crate::view::View;

/// Token counts an agent reports about itself (cumulative).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Tokens {
    /// Prompt (input) tokens so far.
    pub(crate) prompt: u64,
    /// Completion (output) tokens so far.
    pub(crate) completion: u64,
}

/// A tool call's answer: the report of an action (none for `look`) and the state after.
#[derive(Debug)]
pub(crate) struct Reply {
    pub report: Option<Report>,
    pub view: View,
}

enum Request {
    Run {
        command: Command,
        timeout: Duration,
        tokens: Option<Tokens>,
        cancel: CancellationToken,
        reply: oneshot::Sender<Result<Reply, Busy>>,
    },
    Look {
        tokens: Option<Tokens>,
        counted: bool,
        reply: oneshot::Sender<Reply>,
    },
}

/// A handle on the robot's task; cheap to clone.
#[derive(Clone)]
pub struct Link {
    requests: mpsc::Sender<Request>,
    info: Option<MatchInfo>,
}

/// Why the robot could not join its match.
#[derive(Debug, thiserror::Error)]
pub enum JoinError {
    /// No connection.
    #[error("cannot connect to {addr}")]
    Connect {
        /// Where.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
    /// The server refused the `hello`.
    #[error("the server refused to seat this player: {0}")]
    Refused(String),
    /// The server did not answer the `hello` in time.
    #[error("no answer to hello from {0} within {1:?}")]
    Silent(SocketAddr, Duration),
}

/// Where the per-decision log goes, if anywhere.
pub type DecisionLog = Option<Box<dyn Write + Send>>;

impl Link {
    /// Connects, says `hello` and waits for the seat (a `welcome`, or a place in a
    /// template's queue); then the robot's task runs until the match ends and every
    /// handle is dropped.
    pub async fn join(
        addr: SocketAddr,
        options: SessionOptions,
        wait: Duration,
        log: DecisionLog,
    ) -> Result<Link, JoinError> {
        let stream = TcpStream::connect(addr).await.map_err(|source| JoinError::Connect { addr, source })?;
        let _ = stream.set_nodelay(true);
        let (reader, mut writer) = stream.into_split();
        let mut lines = BufReader::new(reader).lines();
        let mut robot = Robot::new(options);
        let hello: String = std::iter::from_fn(|| robot.poll_transmit()).collect();
        writer.write_all(hello.as_bytes()).await.map_err(|source| JoinError::Connect { addr, source })?;
        let seated = async {
            loop {
                let line = match lines.next_line().await {
                    Ok(Some(line)) => line,
                    Ok(None) => return Err(JoinError::Refused("the server closed the connection".into())),
                    Err(e) => return Err(JoinError::Refused(format!("the connection failed: {e}"))),
                };
                robot.handle_line(&line);
                let session = robot.session();
                if let Some(Closed::Refused(error)) = session.closed() {
                    return Err(JoinError::Refused(format!("{} ({})", error.message, error.code)));
                }
                if session.welcome().is_some() || session.queued().is_some() {
                    return Ok(());
                }
            }
        };
        tokio::time::timeout(wait, seated).await.map_err(|_| JoinError::Silent(addr, wait))??;
        let info = robot.match_info().cloned();
        let (requests, inbox) = mpsc::channel(16);
        tokio::spawn(drive(robot, lines, writer, inbox, log));
        Ok(Link { requests, info })
    }

    /// The match joined, as its `welcome` described it (`None` while queued for a seat).
    pub fn match_info(&self) -> Option<&MatchInfo> {
        self.info.as_ref()
    }

    /// Runs a command until it ends, `timeout` passes or `cancel` is cancelled (then it
    /// ends [`Cancelled`](crate::robot::Outcome::Cancelled)); dropping the future cancels
    /// it too, so the robot is free for the next call at once.
    pub(crate) async fn run(
        &self,
        command: Command,
        timeout: Duration,
        tokens: Option<Tokens>,
        cancel: &CancellationToken,
    ) -> Result<Reply, LinkError> {
        let call = cancel.child_token();
        let dropped = call.clone().drop_guard();
        let (reply, answer) = oneshot::channel();
        self.send(Request::Run { command, timeout, tokens, cancel: call, reply }).await?;
        let answer = answer.await.map_err(|_| LinkError::Gone)?.map_err(LinkError::Busy);
        dropped.disarm();
        answer
    }

    /// The robot's state now; `counted` for the `look` tool (not for a resource read).
    pub(crate) async fn look(&self, tokens: Option<Tokens>, counted: bool) -> Result<Reply, LinkError> {
        let (reply, answer) = oneshot::channel();
        self.send(Request::Look { tokens, counted, reply }).await?;
        answer.await.map_err(|_| LinkError::Gone)
    }

    async fn send(&self, request: Request) -> Result<(), LinkError> {
        self.requests.send(request).await.map_err(|_| LinkError::Gone)
    }
}

/// Why a tool call got no answer from the robot.
#[derive(Debug, thiserror::Error)]
pub(crate) enum LinkError {
    /// Another call is in progress.
    #[error(transparent)]
    Busy(Busy),
    /// The robot's task has ended.
    #[error("the robot's connection is gone")]
    Gone,
}

/// The call waiting for the robot's report.
struct Waiting {
    reply: oneshot::Sender<Result<Reply, Busy>>,
    cancel: CancellationToken,
    deadline: tokio::time::Instant,
    tool: &'static str,
    args: Value,
    called: Instant,
    think_ms: u64,
}

/// The robot's task: lines in, messages out, tool calls answered.
async fn drive(
    mut robot: Robot,
    mut lines: tokio::io::Lines<BufReader<tokio::net::tcp::OwnedReadHalf>>,
    mut writer: OwnedWriteHalf,
    mut inbox: mpsc::Receiver<Request>,
    mut log: DecisionLog,
) {
    let mut usage = PlayerUsage::default();
    let mut last_answer = Instant::now();
    let mut waiting: Option<Waiting> = None;
    let mut connected = true;
    loop {
        let deadline = waiting.as_ref().map(|w| w.deadline);
        let cancel = waiting.as_ref().map(|w| w.cancel.clone());
        tokio::select! {
            line = lines.next_line(), if connected => match line {
                Ok(Some(line)) => robot.handle_line(&line),
                Ok(None) => { connected = false; robot.disconnected("closed by the server"); }
                Err(e) => { connected = false; robot.disconnected(&e.to_string()); }
            },
            request = inbox.recv() => {
                let Some(request) = request else { break };
                // A call cancelled just before this request (rmcp cancels in order) may not
                // have ended yet: it ends first, so that its report goes to its own caller.
                if matches!(request, Request::Run { .. }) && waiting.as_ref().is_some_and(|w| w.cancel.is_cancelled()) {
                    robot.cancel();
                    deliver(&mut robot, &mut waiting, &mut log, &mut last_answer);
                }
                let now = Instant::now();
                // Counted and reported before the call's own messages, so that the match
                // cannot end on this call's `ready` without its report.
                let mut think = |robot: &mut Robot, tokens: Option<Tokens>| {
                    let ms = now.duration_since(last_answer).as_millis() as u64;
                    usage.tool_calls += 1;
                    usage.think_ms += ms;
                    usage.think_ms_max = usage.think_ms_max.max(ms);
                    if let Some(tokens) = tokens {
                        usage.prompt_tokens = tokens.prompt;
                        usage.completion_tokens = tokens.completion;
                    }
                    robot.report(usage);
                    ms
                };
                match request {
                    Request::Look { tokens, counted, reply } => {
                        if counted {
                            let think_ms = think(&mut robot, tokens);
                            write_log(&mut log, json!({"tool": "look", "tick": robot.tick(), "think_ms": think_ms, "run_ms": 0}));
                            last_answer = Instant::now();
                        }
                        let _ = reply.send(Reply { report: None, view: View::of(&robot) });
                    }
                    Request::Run { command, timeout, tokens, cancel, reply } => {
                        let think_ms = think(&mut robot, tokens);
                        let tool = tool_name(&command);
                        let args = command_args(&command);
                        match robot.start(command, timeout) {
                            Err(busy) => { let _ = reply.send(Err(busy)); }
                            Ok(wall) => {
                                let deadline = tokio::time::Instant::now() + wall;
                                waiting = Some(Waiting { reply, cancel, deadline, tool, args, called: now, think_ms });
                            }
                        }
                    }
                }
            },
            () = sleep_until(deadline) => robot.expire(),
            () = cancelled(cancel) => robot.cancel(),
        }
        while let Some(line) = robot.poll_transmit() {
            if connected && writer.write_all(line.as_bytes()).await.is_err() {
                connected = false;
                robot.disconnected("the connection failed");
            }
        }
        deliver(&mut robot, &mut waiting, &mut log, &mut last_answer);
        if waiting.as_ref().is_some_and(|w| w.cancel.is_cancelled()) && robot.busy().is_none() {
            // Nothing left to report to a cancelled call: its caller has gone.
            waiting = None;
        }
    }
    if connected {
        robot.bye();
        let bye: String = std::iter::from_fn(|| robot.poll_transmit()).collect();
        let _ = writer.write_all(bye.as_bytes()).await;
    }
}

/// Hands the robot's finished reports to the call waiting for one.
fn deliver(
    robot: &mut Robot,
    waiting: &mut Option<Waiting>,
    log: &mut DecisionLog,
    last_answer: &mut Instant,
) {
    while let Some(report) = robot.poll_report() {
        let Some(w) = waiting.take() else { continue };
        write_log(
            log,
            json!({
                "tool": w.tool, "args": w.args, "tick": report.started, "ticks": report.tick.saturating_sub(report.started),
                "think_ms": w.think_ms, "run_ms": w.called.elapsed().as_millis() as u64, "outcome": report.outcome.word(),
            }),
        );
        *last_answer = Instant::now();
        let _ = w.reply.send(Ok(Reply { report: Some(report), view: View::of(robot) }));
    }
}

async fn cancelled(cancel: Option<CancellationToken>) {
    match cancel {
        Some(cancel) => cancel.cancelled_owned().await,
        None => std::future::pending().await,
    }
}

async fn sleep_until(deadline: Option<tokio::time::Instant>) {
    match deadline {
        Some(deadline) => tokio::time::sleep_until(deadline).await,
        None => std::future::pending().await,
    }
}

fn write_log(log: &mut DecisionLog, line: Value) {
    if let Some(log) = log {
        let _ = writeln!(log, "{line}");
        let _ = log.flush();
    }
}

/// A command's arguments, for the decision log.
fn command_args(command: &Command) -> Value {
    match command {
        Command::GoTo(place) => json!({"place": place}),
        Command::GoToBlock(block) => json!({"block": block}),
        Command::PickUp(block) => json!({"block": block}),
        Command::PutDown => json!({}),
        Command::Say { to, said, text } => json!({"to": to, "said": said, "text": text}),
        Command::Wait { ticks, seconds } => json!({"ticks": ticks, "seconds": seconds}),
    }
}
