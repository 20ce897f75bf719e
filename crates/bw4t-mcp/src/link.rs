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

use crate::answer::{Answer, INVALID, Shaper};
use crate::robot::{Busy, Command, Robot, tool_name};
use crate::view::View;

/// Token counts an agent reports about itself (cumulative).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Tokens {
    /// Prompt (input) tokens so far.
    pub(crate) prompt: u64,
    /// Completion (output) tokens so far.
    pub(crate) completion: u64,
}

enum Request {
    Run {
        command: Command,
        /// The arguments as the caller gave them, for the transcript.
        given: Value,
        timeout: Duration,
        tokens: Option<Tokens>,
        cancel: CancellationToken,
        reply: oneshot::Sender<Result<Answer, Busy>>,
    },
    /// The `look` tool.
    Look { tokens: Option<Tokens>, reply: oneshot::Sender<Answer> },
    /// A call refused for its arguments: answered, counted and recorded, nothing sent.
    Invalid {
        tool: String,
        given: Value,
        problem: String,
        tokens: Option<Tokens>,
        reply: oneshot::Sender<Answer>,
    },
    /// The state, for a resource or the prompt (no tool call: not counted).
    Peek { reply: oneshot::Sender<View> },
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

/// Where the per-decision log (or the transcript) goes, if anywhere.
pub type DecisionLog = Option<Box<dyn Write + Send>>;

/// What the robot's task records and how it shapes results.
#[derive(Default)]
pub struct LinkOptions {
    /// One JSON line per tool call: tool, arguments, ticks, timing, outcome.
    pub decisions: DecisionLog,
    /// One JSON line per tool call with what it returned (docs/mcp.md, "Transcripts").
    pub transcript: DecisionLog,
    /// Brief results: only what changed since the previous result (`look` stays whole).
    pub brief: bool,
}

impl Link {
    /// Connects, says `hello` and waits for the seat (a `welcome`, or a place in a
    /// template's queue); then the robot's task runs until the match ends and every
    /// handle is dropped.
    pub async fn join(
        addr: SocketAddr,
        options: SessionOptions,
        wait: Duration,
        link_options: LinkOptions,
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
        tokio::spawn(drive(robot, lines, writer, inbox, link_options));
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
        given: Value,
        timeout: Duration,
        tokens: Option<Tokens>,
        cancel: &CancellationToken,
    ) -> Result<Answer, LinkError> {
        let call = cancel.child_token();
        let dropped = call.clone().drop_guard();
        let (reply, answer) = oneshot::channel();
        self.send(Request::Run { command, given, timeout, tokens, cancel: call, reply }).await?;
        let answer = answer.await.map_err(|_| LinkError::Gone)?.map_err(LinkError::Busy);
        dropped.disarm();
        answer
    }

    /// The `look` tool: the whole situation, counted as a call.
    pub(crate) async fn look(&self, tokens: Option<Tokens>) -> Result<Answer, LinkError> {
        let (reply, answer) = oneshot::channel();
        self.send(Request::Look { tokens, reply }).await?;
        answer.await.map_err(|_| LinkError::Gone)
    }

    /// Answers a call refused for its arguments (`problem`): counted as a call and as an
    /// invalid one, recorded, and nothing sent to the match.
    pub(crate) async fn invalid(
        &self,
        tool: &str,
        given: Value,
        problem: String,
        tokens: Option<Tokens>,
    ) -> Result<Answer, LinkError> {
        let (reply, answer) = oneshot::channel();
        self.send(Request::Invalid { tool: tool.into(), given, problem, tokens, reply }).await?;
        answer.await.map_err(|_| LinkError::Gone)
    }

    /// The robot's state now, for a resource or the prompt (not a tool call).
    pub(crate) async fn peek(&self) -> Result<View, LinkError> {
        let (reply, answer) = oneshot::channel();
        self.send(Request::Peek { reply }).await?;
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
    reply: oneshot::Sender<Result<Answer, Busy>>,
    cancel: CancellationToken,
    deadline: tokio::time::Instant,
    tool: &'static str,
    args: Value,
    given: Value,
    called: Instant,
    think_ms: u64,
}

/// What the robot's task keeps besides the robot: the usage it reports, the call
/// waiting, the logs and the shape of results.
struct Books {
    usage: PlayerUsage,
    last_answer: Instant,
    waiting: Option<Waiting>,
    decisions: DecisionLog,
    transcript: DecisionLog,
    shaper: Shaper,
    /// Tool calls answered so far (the transcript's `call`).
    calls: u64,
}

impl Books {
    /// Counts a call that arrived `now` with the driver's `tokens`, and queues the
    /// robot's report, before the call's own messages so that the match cannot end on
    /// this call's `ready` without it. The thinking time, in milliseconds.
    fn count_call(&mut self, robot: &mut Robot, now: Instant, tokens: Option<Tokens>, invalid: bool) -> u64 {
        let ms = now.duration_since(self.last_answer).as_millis() as u64;
        let usage = &mut self.usage;
        usage.tool_calls += 1;
        usage.invalid_calls += u64::from(invalid);
        usage.think_ms += ms;
        usage.think_ms_max = usage.think_ms_max.max(ms);
        if let Some(tokens) = tokens {
            usage.prompt_tokens = tokens.prompt;
            usage.completion_tokens = tokens.completion;
        }
        robot.report(self.usage);
        ms
    }

    /// Counts what `answer` gives the model, reports it to the match, and writes the
    /// transcript's line for the call.
    fn answered(&mut self, robot: &mut Robot, tool: &str, given: &Value, answer: &Answer) {
        let tokens = answer.tokens();
        self.usage.result_tokens += tokens;
        robot.report(self.usage);
        self.calls += 1;
        write_log(
            &mut self.transcript,
            json!({
                "call": self.calls, "tool": tool, "args": given, "is_error": answer.is_error,
                "outcome": answer.outcome(), "tick_start": answer.tick_start, "tick_end": answer.tick_end,
                "result_tokens": tokens, "text": answer.text, "structured": answer.structured,
            }),
        );
        self.last_answer = Instant::now();
    }
}

/// The robot's task: lines in, messages out, tool calls answered.
async fn drive(
    mut robot: Robot,
    mut lines: tokio::io::Lines<BufReader<tokio::net::tcp::OwnedReadHalf>>,
    mut writer: OwnedWriteHalf,
    mut inbox: mpsc::Receiver<Request>,
    options: LinkOptions,
) {
    let mut books = Books {
        usage: PlayerUsage::default(),
        last_answer: Instant::now(),
        waiting: None,
        decisions: options.decisions,
        transcript: options.transcript,
        shaper: Shaper::new(options.brief),
        calls: 0,
    };
    let mut connected = true;
    loop {
        let deadline = books.waiting.as_ref().map(|w| w.deadline);
        let cancel = books.waiting.as_ref().map(|w| w.cancel.clone());
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
                if matches!(request, Request::Run { .. }) && books.waiting.as_ref().is_some_and(|w| w.cancel.is_cancelled()) {
                    robot.cancel();
                    deliver(&mut robot, &mut books);
                }
                take(&mut robot, &mut books, request);
            },
            () = sleep_until(deadline) => robot.expire(),
            () = cancelled(cancel) => robot.cancel(),
        }
        flush(&mut robot, &mut writer, &mut connected).await;
        deliver(&mut robot, &mut books);
        // The reports of the calls just answered (their result tokens).
        flush(&mut robot, &mut writer, &mut connected).await;
        if books.waiting.as_ref().is_some_and(|w| w.cancel.is_cancelled()) && robot.busy().is_none() {
            // Nothing left to report to a cancelled call: its caller has gone.
            books.waiting = None;
        }
    }
    if connected {
        robot.bye();
        let bye: String = std::iter::from_fn(|| robot.poll_transmit()).collect();
        let _ = writer.write_all(bye.as_bytes()).await;
    }
}

/// Sends the robot's queued lines.
async fn flush(robot: &mut Robot, writer: &mut OwnedWriteHalf, connected: &mut bool) {
    while let Some(line) = robot.poll_transmit() {
        if *connected && writer.write_all(line.as_bytes()).await.is_err() {
            *connected = false;
            robot.disconnected("the connection failed");
        }
    }
}

/// Takes one request of a caller.
fn take(robot: &mut Robot, books: &mut Books, request: Request) {
    let now = Instant::now();
    let max_ticks = robot.match_info().and_then(|info| info.max_ticks);
    match request {
        Request::Peek { reply } => {
            let _ = reply.send(View::of(robot));
        }
        Request::Look { tokens, reply } => {
            let think_ms = books.count_call(robot, now, tokens, false);
            write_log(
                &mut books.decisions,
                json!({"tool": "look", "tick": robot.tick(), "think_ms": think_ms, "run_ms": 0}),
            );
            let answer = books.shaper.answer(None, &View::of(robot), max_ticks);
            books.answered(robot, "look", &json!({}), &answer);
            let _ = reply.send(answer);
        }
        Request::Invalid { tool, given, problem, tokens, reply } => {
            let think_ms = books.count_call(robot, now, tokens, true);
            write_log(
                &mut books.decisions,
                json!({"tool": tool, "args": given, "tick": robot.tick(), "ticks": 0, "think_ms": think_ms,
                       "run_ms": 0, "outcome": INVALID}),
            );
            let answer = books.shaper.invalid(&problem, &View::of(robot), max_ticks);
            books.answered(robot, &tool, &given, &answer);
            let _ = reply.send(answer);
        }
        Request::Run { command, given, timeout, tokens, cancel, reply } => {
            let think_ms = books.count_call(robot, now, tokens, false);
            let tool = tool_name(&command);
            let args = command_args(&command);
            match robot.start(command, timeout) {
                Err(busy) => {
                    let _ = reply.send(Err(busy));
                }
                Ok(wall) => {
                    let deadline = tokio::time::Instant::now() + wall;
                    books.waiting =
                        Some(Waiting { reply, cancel, deadline, tool, args, given, called: now, think_ms });
                }
            }
        }
    }
}

/// Hands the robot's finished reports to the call waiting for one.
fn deliver(robot: &mut Robot, books: &mut Books) {
    while let Some(report) = robot.poll_report() {
        let Some(w) = books.waiting.take() else { continue };
        write_log(
            &mut books.decisions,
            json!({
                "tool": w.tool, "args": w.args, "tick": report.started, "ticks": report.tick.saturating_sub(report.started),
                "think_ms": w.think_ms, "run_ms": w.called.elapsed().as_millis() as u64, "outcome": report.outcome.word(),
            }),
        );
        let max_ticks = robot.match_info().and_then(|info| info.max_ticks);
        let answer = books.shaper.answer(Some(&report), &View::of(robot), max_ticks);
        books.answered(robot, w.tool, &w.given, &answer);
        let _ = w.reply.send(Ok(answer));
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
