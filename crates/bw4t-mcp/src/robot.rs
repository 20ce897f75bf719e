//! One robot played through tool calls, sans-IO: server messages and tool commands in,
//! client messages and finished tool reports out. No socket, no clock.
//!
//! The robot asks for a `percepts` message every tick (`every_tick`), so it knows the
//! time while an action runs. While a tool runs it answers every tick at once; once the
//! tool's report is out it answers nothing until the next tool call, so in lockstep the
//! match waits for whoever drives the robot (up to the match's deadline) and a slow
//! thinker loses no ticks.
//!
//! No call runs unbounded: in lockstep each is limited in simulated time too (its wall
//! timeout as ticks), so nothing a driver asks can fast-forward a match that waits for it.

use std::collections::VecDeque;
use std::time::Duration;

use bw4t_protocol::{
    AckCode, ClientSession, Knowledge, MatchInfo, PlayerUsage, Said, SessionError, SessionEvent,
    SessionOptions, Snapshot,
};
use bw4t_sim::{Action, BlockId, PerceptDelta};

/// What a tool asks the robot to do.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Command {
    /// `goTo(place)`.
    GoTo(String),
    /// `goToBlock(block)`.
    GoToBlock(BlockId),
    /// `pickUp`, of the named block or the one the robot is at.
    PickUp(Option<BlockId>),
    /// `putDown`.
    PutDown,
    /// A message to a player or to `all`: one of the language, or free text.
    Say {
        /// A player's name or `all`.
        to: String,
        /// The message of the language, if it is one.
        said: Option<Said>,
        /// Free text, if it is not.
        text: Option<String>,
    },
    /// Nothing: until something changes for this robot, or `ticks` or `seconds` pass.
    Wait {
        /// Ticks to wait at most.
        ticks: Option<u64>,
        /// Seconds to wait at most: simulated seconds in lockstep, wall time in realtime.
        seconds: Option<f64>,
    },
}

impl Command {
    /// The protocol action, for the commands that are one.
    fn action(&self) -> Option<Action> {
        match self {
            Command::GoTo(place) => Some(Action::GoTo(place.clone())),
            Command::GoToBlock(block) => Some(Action::GoToBlock(*block)),
            Command::PickUp(block) => Some(Action::PickUp(*block)),
            Command::PutDown => Some(Action::PutDown),
            Command::Say { .. } | Command::Wait { .. } => None,
        }
    }

    /// Whether it lasts until a `result` rather than one tick.
    fn durative(&self) -> bool {
        matches!(self, Command::GoTo(_) | Command::GoToBlock(_))
    }
}

/// How a tool call ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// The robot reached its target.
    Arrived,
    /// The robot was stopped on its way and dropped its plan.
    Collided,
    /// A newer order replaced it (another client of the same robot).
    Superseded,
    /// An action of one tick was applied.
    Done,
    /// The match refused the action.
    Rejected,
    /// `wait`: something changed for the robot.
    Changed,
    /// The tool's time ran out first (the robot may still be moving).
    Timeout,
    /// The match is over.
    MatchOver,
    /// The caller cancelled the call (the robot takes orders again at once).
    Cancelled,
}

impl Outcome {
    /// Every outcome.
    pub(crate) const ALL: [Outcome; 9] = [
        Outcome::Arrived,
        Outcome::Collided,
        Outcome::Superseded,
        Outcome::Done,
        Outcome::Rejected,
        Outcome::Changed,
        Outcome::Timeout,
        Outcome::MatchOver,
        Outcome::Cancelled,
    ];

    /// The word in tool results.
    pub(crate) fn word(self) -> &'static str {
        match self {
            Outcome::Arrived => "arrived",
            Outcome::Collided => "collided",
            Outcome::Superseded => "superseded",
            Outcome::Done => "done",
            Outcome::Rejected => "rejected",
            Outcome::Changed => "changed",
            Outcome::Timeout => "timeout",
            Outcome::MatchOver => "match_over",
            Outcome::Cancelled => "cancelled",
        }
    }
}

/// A finished tool call: how it ended and what changed meanwhile.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Report {
    /// How it ended.
    pub outcome: Outcome,
    /// Why, when it was rejected (the match's code and words) or the match ended.
    pub reason: Option<String>,
    /// The tick it started at.
    pub started: u64,
    /// The tick it ended at.
    pub tick: u64,
    /// What changed for the robot meanwhile, in English.
    pub changes: Vec<String>,
}

/// The tool call in progress.
#[derive(Debug)]
struct Pending {
    command: Command,
    /// The `act` id, for commands sent as actions.
    act: Option<u64>,
    /// Whether the match has acknowledged it (read it).
    acked: bool,
    started: u64,
    /// The tick it gives up at (`wait`'s ticks or seconds; in lockstep, every call's
    /// timeout in simulated time).
    until: Option<u64>,
    /// What the robot knew when it started, to say what changed.
    before: Snapshot,
    /// How it ended, once known; reported with the next `percepts`, so that the report
    /// includes that tick's changes.
    concluded: Option<(Outcome, Option<String>)>,
}

/// Why a command cannot start.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub(crate) enum Busy {
    /// Another tool call of this robot has not finished.
    #[error("another action is still in progress ({0}); wait for its result")]
    InProgress(&'static str),
}

/// One robot, driven by tool calls.
#[derive(Debug)]
pub(crate) struct Robot {
    /// The protocol's bookkeeping: hello, act ids, acks and results, `ready`.
    session: ClientSession,
    knowledge: Knowledge,
    tick: u64,
    started: bool,
    pending: Option<Pending>,
    /// A command given before the match started, with its timeout.
    queued: Option<(Command, Duration)>,
    ended: Option<String>,
    finished: VecDeque<Report>,
}

impl Robot {
    /// A robot not yet in a match, whose first line out is its `hello`.
    pub(crate) fn new(mut options: SessionOptions) -> Robot {
        options.every_tick = true;
        Robot {
            session: ClientSession::new(options),
            knowledge: Knowledge::default(),
            tick: 0,
            started: false,
            pending: None,
            queued: None,
            ended: None,
            finished: VecDeque::new(),
        }
    }

    /// The protocol session.
    pub(crate) fn session(&self) -> &ClientSession {
        &self.session
    }

    /// What the robot knows.
    pub(crate) fn knowledge(&self) -> &Knowledge {
        &self.knowledge
    }

    /// The match, once welcomed.
    pub(crate) fn match_info(&self) -> Option<&MatchInfo> {
        self.session.match_info()
    }

    /// The robot's id, once welcomed.
    pub(crate) fn robot_id(&self) -> Option<u32> {
        self.session.welcome().and_then(|w| w.robot)
    }

    /// The last tick told.
    pub(crate) fn tick(&self) -> u64 {
        self.tick
    }

    /// Whether the first percepts have come.
    pub(crate) fn started(&self) -> bool {
        self.started
    }

    /// Why the match ended for this robot, once it has.
    pub(crate) fn ended(&self) -> Option<&str> {
        self.ended.as_deref()
    }

    /// The tool in progress, by name.
    pub(crate) fn busy(&self) -> Option<&'static str> {
        self.pending
            .as_ref()
            .map(|p| tool_name(&p.command))
            .or(self.queued.as_ref().map(|(c, _)| tool_name(c)))
    }

    /// Starts a command that may take `timeout`, and says how much wall time the caller
    /// should give it before [`Robot::expire`]: `timeout`, or a realtime `wait`'s seconds.
    /// Before the match starts it is held until it does; after the match is over it ends
    /// at once with [`Outcome::MatchOver`].
    pub(crate) fn start(&mut self, command: Command, timeout: Duration) -> Result<Duration, Busy> {
        if let Some(busy) = self.busy() {
            return Err(Busy::InProgress(busy));
        }
        let wall = match &command {
            Command::Wait { seconds: Some(seconds), .. } if !self.session.lockstep() => {
                Duration::from_secs_f64(*seconds).min(timeout)
            }
            _ => timeout,
        };
        if let Some(reason) = self.ended.clone() {
            self.report_now(Outcome::MatchOver, reason);
            return Ok(wall);
        }
        if !self.started {
            self.queued = Some((command, timeout));
            return Ok(wall);
        }
        // Actions and messages get an id, which their `ack` (and `result`) echo.
        let act = match (&command, command.action()) {
            (_, Some(action)) => Some(self.session.act(&action)),
            (Command::Say { to, said, text }, None) => Some(self.session.say(to, text.clone(), said.clone())),
            _ => None,
        };
        let until = self.limit(&command, timeout).map(|ticks| self.tick.saturating_add(ticks));
        self.pending = Some(Pending {
            command,
            act,
            acked: false,
            started: self.tick,
            until,
            before: self.knowledge.snapshot(),
            concluded: None,
        });
        self.answer();
        Ok(wall)
    }

    /// The most ticks `command` may take: a `wait`'s ticks and, in lockstep, its seconds
    /// and every call's `timeout`, as simulated time.
    fn limit(&self, command: &Command, timeout: Duration) -> Option<u64> {
        let ticks = match command {
            Command::Wait { ticks, .. } => *ticks,
            _ => None,
        };
        let info = self.match_info().filter(|_| self.session.lockstep());
        let Some(hz) = info.map(|info| f64::from(info.tick_hz)) else { return ticks };
        let simulated = |seconds: f64| (seconds * hz).ceil().max(1.0) as u64;
        let mut limit = simulated(timeout.as_secs_f64());
        if let Command::Wait { seconds: Some(seconds), .. } = command {
            limit = limit.min(simulated(*seconds));
        }
        Some(ticks.map_or(limit, |ticks| ticks.min(limit)))
    }

    /// Ends the tool in progress because its time ran out. A journey goes on (the
    /// report says so); the robot stops answering ticks until the next tool call.
    pub(crate) fn expire(&mut self) {
        self.stop(Outcome::Timeout);
    }

    /// Ends the tool in progress because its caller gave up on it: the robot takes a new
    /// order at once (a journey goes on, as after a timeout).
    pub(crate) fn cancel(&mut self) {
        self.stop(Outcome::Cancelled);
    }

    fn stop(&mut self, outcome: Outcome) {
        if let Some(pending) = self.pending.take() {
            let reason = pending
                .command
                .durative()
                .then(|| "the robot is still on its way; call wait, or give a new order".to_string());
            self.finish(pending, outcome, reason);
        } else if let Some((command, _)) = self.queued.take() {
            let reason = format!("the match has not started yet ({} not sent)", tool_name(&command));
            self.report_now(outcome, reason);
        }
    }

    /// Takes in one line from the server (a line that is no message is skipped).
    pub(crate) fn handle_line(&mut self, line: &str) {
        match self.session.handle_line(line) {
            Ok(()) | Err(SessionError::Line { .. }) => {}
            Err(e @ SessionError::Percepts(_)) => self.end(e.to_string()),
        }
        while let Some(event) = self.session.poll_event() {
            self.on_event(event);
        }
    }

    fn on_event(&mut self, event: SessionEvent) {
        let id = |request: Option<bw4t_protocol::Request>| request.map(|r| r.id);
        match event {
            SessionEvent::Percepts { delta, .. } => self.on_percepts(&delta),
            SessionEvent::Ack { ack, request } => {
                let acked = request.as_ref().map(|r| r.id);
                if let Some(pending) = self.pending.as_mut().filter(|p| acked.is_some() && p.act == acked) {
                    pending.acked = true;
                }
                if !ack.ok {
                    let reason = match (ack.code, ack.reason) {
                        (Some(code), Some(words)) => format!("{code}: {words}"),
                        (Some(code), None) => format!("{code}: {}", explain(code)),
                        (None, words) => words.unwrap_or_else(|| "refused".into()),
                    };
                    self.conclude(id(request), Outcome::Rejected, Some(reason));
                } else if self.pending.as_ref().is_some_and(|p| !p.command.durative()) {
                    self.conclude(id(request), Outcome::Done, None);
                }
            }
            SessionEvent::Result { result, request } => {
                let outcome = match result.outcome {
                    bw4t_protocol::Outcome::Arrived => Outcome::Arrived,
                    bw4t_protocol::Outcome::Collided => Outcome::Collided,
                    bw4t_protocol::Outcome::Superseded => Outcome::Superseded,
                };
                self.conclude(id(request), outcome, None);
            }
            SessionEvent::MatchEnd(end) => self.end(format!("the match ended: {}", end.reason.as_str())),
            SessionEvent::Bye(bye) => {
                self.end(format!("the server closed the connection: {}", bye.reason.as_str()))
            }
            SessionEvent::Error(error) if error.fatal => {
                self.end(format!("the server refused this player: {} ({})", error.message, error.code))
            }
            // A line the server could not read (too long, say) is dropped with an error that
            // carries no id; the call waiting for it would never get its ack.
            SessionEvent::Error(error) => {
                let act = self.pending.as_ref().filter(|p| !p.acked).and_then(|p| p.act);
                self.conclude(act, Outcome::Rejected, Some(format!("{}: {}", error.code, error.message)));
            }
            SessionEvent::Welcome(_) | SessionEvent::Lobby(_) | SessionEvent::Pause(_) => {}
        }
    }

    /// The connection is gone.
    pub(crate) fn disconnected(&mut self, why: &str) {
        self.end(format!("the connection to the match closed ({why})"));
    }

    /// Queues a `report` of how the robot is driven, unless the match is over.
    pub(crate) fn report(&mut self, usage: PlayerUsage) {
        if self.ended.is_none() {
            self.session.report(usage);
        }
    }

    /// Leaves the match with `bye`.
    pub(crate) fn bye(&mut self) {
        self.session.bye();
    }

    /// The next line to send, newline included.
    pub(crate) fn poll_transmit(&mut self) -> Option<String> {
        self.session.poll_transmit()
    }

    /// The next finished tool call.
    pub(crate) fn poll_report(&mut self) -> Option<Report> {
        self.finished.pop_front()
    }

    fn on_percepts(&mut self, delta: &PerceptDelta) {
        self.tick = delta.tick;
        self.knowledge.apply(delta.tick, delta);
        if !self.started {
            self.started = true;
            if let Some((command, timeout)) = self.queued.take() {
                // Cannot be busy: nothing else ran before the start.
                let _ = self.start(command, timeout);
                return;
            }
        }
        if let Some(pending) = &mut self.pending {
            if pending.concluded.is_none() {
                let changed = matches!(pending.command, Command::Wait { .. }) && !delta.is_empty();
                if changed {
                    pending.concluded = Some((Outcome::Changed, None));
                } else if pending.until.is_some_and(|until| delta.tick >= until) {
                    let reason = match pending.command {
                        Command::Wait { .. } => "the time given ran out",
                        _ if pending.command.durative() => {
                            "the robot is still on its way; call wait, or give a new order"
                        }
                        _ => "the match did not answer in time",
                    };
                    pending.concluded = Some((Outcome::Timeout, Some(reason.into())));
                }
            }
            if let Some((outcome, reason)) = pending.concluded.take() {
                let pending = self.pending.take().expect("pending checked above");
                self.finish(pending, outcome, reason);
                return;
            }
        }
        if self.pending.is_some() {
            self.answer();
        }
    }

    /// Notes how the command with act `id` ended (reported with the next percepts).
    fn conclude(&mut self, id: Option<u64>, outcome: Outcome, reason: Option<String>) {
        let Some(pending) = &mut self.pending else { return };
        let ours = id.is_some() && id == pending.act;
        if ours && pending.concluded.is_none() {
            pending.concluded = Some((outcome, reason));
        }
    }

    /// Reports a call that ended before it began: nothing changed.
    fn report_now(&mut self, outcome: Outcome, reason: String) {
        let report = Report {
            outcome,
            reason: Some(reason),
            started: self.tick,
            tick: self.tick,
            changes: Vec::new(),
        };
        self.finished.push_back(report);
    }

    fn finish(&mut self, pending: Pending, outcome: Outcome, reason: Option<String>) {
        let changes = self.knowledge.changes_since(&pending.before);
        let report = Report { outcome, reason, started: pending.started, tick: self.tick, changes };
        self.finished.push_back(report);
    }

    fn end(&mut self, reason: String) {
        if self.ended.is_some() {
            return;
        }
        self.ended = Some(reason.clone());
        if let Some(pending) = self.pending.take() {
            self.finish(pending, Outcome::MatchOver, Some(reason));
        } else if self.queued.take().is_some() {
            self.report_now(Outcome::MatchOver, reason);
        }
    }

    /// Answers the last tick told, in lockstep.
    fn answer(&mut self) {
        self.session.ready();
    }
}

/// The tool a command comes from.
pub(crate) fn tool_name(command: &Command) -> &'static str {
    match command {
        Command::GoTo(_) => "go_to",
        Command::GoToBlock(_) => "go_to_block",
        Command::PickUp(_) => "pick_up",
        Command::PutDown => "put_down",
        Command::Say { .. } => "say",
        Command::Wait { .. } => "wait",
    }
}

/// A rejection's code in words, for acks that carry no reason.
fn explain(code: AckCode) -> &'static str {
    match code {
        AckCode::UnknownAction => "no such action",
        AckCode::BadArgs => "the arguments do not fit the action",
        AckCode::RateLimited => "too many actions in one tick",
        AckCode::NotAllowed => "the match does not allow this",
        AckCode::UnknownRobot => "no such robot",
        AckCode::UnknownPlace => "no such place",
        AckCode::Unreachable => "the place cannot be reached from here",
        AckCode::UnknownBlock => "no such block",
        AckCode::BlockNotVisible => "the block is not in sight",
        AckCode::NotAtBlock => "the robot is not at a block",
        AckCode::AlreadyHolding => "the robot already holds a block",
        AckCode::NotHolding => "the robot holds no block",
        AckCode::NoSpace => "there is no room to put the block down here",
        AckCode::UnknownReceiver => "no such player",
    }
}

#[cfg(test)]
mod tests;
