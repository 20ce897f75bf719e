//! A player's side of one protocol session, sans-IO: server lines in, events and client
//! lines out. No socket, no clock; a thin loop reads a line, hands it to
//! [`ClientSession::handle_line`], and writes what [`ClientSession::poll_transmit`] gives.
//!
//! The session says `hello` (and says it again to take the robot back after a dropped
//! connection), numbers `act`s and `say`s, matches each `ack` and `result` to the request
//! it answers, and owes lockstep `ready`s: one for each `percepts` received, sent when the
//! player says it has decided ([`ClientSession::ready`]).

use std::collections::{BTreeMap, VecDeque};

use bw4t_sim::{Action, PerceptDelta};
use serde::Deserialize;
use serde_json::Value;

use crate::codec::{DecodeError, decode_server, encode};
use crate::convert::{FactError, action_to_act, percepts_delta};
use crate::language::Said;
use crate::messages::{
    Ack, Act, ActId, ActResult, ClientBye, ClientMessage, ErrorMessage, Hello, Lobby, MatchEnd, MatchInfo,
    Resync, Say, ServerBye, ServerMessage, Welcome,
};
use crate::result::PlayerUsage;
use crate::vocabulary::Mode;

/// What a player asks for in its `hello`; the session adds the rest (protocol, versions,
/// role, and the session token when it comes back).
#[derive(Clone, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionOptions {
    /// The player name wanted.
    pub name: String,
    /// The player token, if the server has one.
    #[serde(default)]
    pub token: Option<String>,
    /// The live match to join, by name.
    #[serde(default, rename = "match")]
    pub match_name: Option<String>,
    /// The template whose next match with a free seat to join.
    #[serde(default)]
    pub template: Option<String>,
    /// A `percepts` every tick, even an empty one.
    #[serde(default)]
    pub every_tick: bool,
    /// The robot's situation in words with every `percepts`.
    #[serde(default)]
    pub words: bool,
    /// The seat token a study's trial page gives (`hello.seat`).
    #[serde(default)]
    pub seat: Option<String>,
}

impl SessionOptions {
    /// A player named `name`, with the player `token` if the server asks for one.
    pub fn agent(name: impl Into<String>, token: Option<String>) -> SessionOptions {
        SessionOptions { name: name.into(), token, ..SessionOptions::default() }
    }
}

/// An `act` or `say` of this session: what an `ack` or a `result` answers.
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// Its id: the session numbers its requests from 1, in the order they are queued.
    pub id: u64,
    /// The message sent.
    pub message: ClientMessage,
}

impl Request {
    /// Whether an accepted request still has a `result` to come (`goTo`, `goToBlock`).
    fn durative(&self) -> bool {
        match &self.message {
            ClientMessage::Act(act) => crate::action_row(&act.action).is_some_and(|row| row.durative),
            _ => false,
        }
    }
}

/// Something the server told the player.
#[derive(Clone, Debug, PartialEq)]
pub enum SessionEvent {
    /// Seated in a match (again, after a reconnect).
    Welcome(Welcome),
    /// The match's players before it starts, or the place in a template's queue.
    Lobby(Lobby),
    /// The operator paused or resumed the match.
    Pause(crate::Pause),
    /// What the robot perceives; answer it with [`ClientSession::ready`] once decided.
    Percepts {
        /// The facts, as a delta (a full snapshot when `delta.full`).
        delta: PerceptDelta,
        /// The robot's situation in words, if the options asked for them.
        words: Option<String>,
    },
    /// An `act` or `say` accepted or rejected.
    Ack {
        /// The ack.
        ack: Ack,
        /// What it answers (`None` for an id this session did not send).
        request: Option<Request>,
    },
    /// How a durative order ended.
    Result {
        /// The result.
        result: ActResult,
        /// The order it ends (`None` for an id this session did not send).
        request: Option<Request>,
    },
    /// Something the client sent was wrong; a fatal one ends the session.
    Error(ErrorMessage),
    /// The match is over.
    MatchEnd(MatchEnd),
    /// The server closes the connection.
    Bye(ServerBye),
}

/// A server line the session cannot use.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SessionError {
    /// Not a server message.
    #[error("the server sent a line that is not a message ({}: {error}): {line}", error.code)]
    Line {
        /// Why.
        error: DecodeError,
        /// The line, shortened to its first 200 characters.
        line: String,
    },
    /// A `percepts` whose facts are not percepts of this protocol.
    #[error("the server sent percepts this client cannot read: {0}")]
    Percepts(FactError),
}

/// The longest part of a bad line quoted in an error.
const QUOTED: usize = 200;

/// One player's session with a server.
#[derive(Debug)]
pub struct ClientSession {
    options: SessionOptions,
    welcome: Option<Welcome>,
    /// The place in a template's queue, while waiting there.
    queued: Option<usize>,
    /// The tick of the last `percepts`, if it has not been answered yet.
    owed: Option<u64>,
    /// The tick of the last `percepts`.
    tick: Option<u64>,
    next_id: u64,
    in_flight: BTreeMap<u64, Request>,
    /// Why the connection is over: nothing more is sent.
    closed: Option<Closed>,
    transmit: VecDeque<String>,
    events: VecDeque<SessionEvent>,
}

/// Why a session's connection is over.
#[derive(Clone, Debug, PartialEq)]
pub enum Closed {
    /// The server refused or ended it with a fatal `error`.
    Refused(ErrorMessage),
    /// The server said `bye`.
    Bye(ServerBye),
    /// The client said `bye`.
    Left,
}

impl ClientSession {
    /// A session whose first line out is its `hello`.
    pub fn new(options: SessionOptions) -> ClientSession {
        let mut session = ClientSession {
            options,
            welcome: None,
            queued: None,
            owed: None,
            tick: None,
            next_id: 0,
            in_flight: BTreeMap::new(),
            closed: None,
            transmit: VecDeque::new(),
            events: VecDeque::new(),
        };
        session.send(&ClientMessage::Hello(session.hello()));
        session
    }

    /// A session for a connection already welcomed (its `hello` sent by other means), from
    /// its `welcome` on.
    pub fn adopt(welcome: Welcome) -> ClientSession {
        let name = welcome.name.clone().unwrap_or_default();
        let mut session = ClientSession::new(SessionOptions::agent(name, None));
        session.transmit.clear();
        session.welcome = Some(welcome);
        session
    }

    /// The `hello` this session says now: the options', or, once welcomed with a session
    /// token, the one that takes the robot back (its session and match, as PROTOCOL.md's
    /// reconnecting asks).
    pub fn hello(&self) -> Hello {
        let o = &self.options;
        let mut hello = Hello::agent(o.name.clone(), o.token.clone());
        hello.every_tick = o.every_tick;
        hello.words = o.words;
        match self.resumable() {
            Some(welcome) => {
                hello.session = welcome.session.clone();
                hello.match_name = Some(welcome.match_info.name.clone());
            }
            None => {
                hello.match_name = o.match_name.clone();
                hello.template = o.template.clone();
                hello.seat = o.seat.clone();
            }
        }
        hello
    }

    /// The welcome of a session the robot can be taken back with.
    fn resumable(&self) -> Option<&Welcome> {
        self.welcome.as_ref().filter(|w| w.session.is_some())
    }

    /// Starts over on a new connection after the old one dropped: what was queued and
    /// not sent, the tick owed and the requests in flight are forgotten (the server drops
    /// unapplied actions and the results of a dropped robot), and the next line out is
    /// the `hello` of [`ClientSession::hello`].
    pub fn reconnect(&mut self) {
        self.transmit.clear();
        self.in_flight.clear();
        self.owed = None;
        self.queued = None;
        self.closed = None;
        self.send(&ClientMessage::Hello(self.hello()));
    }

    /// Takes in one line from the server.
    pub fn handle_line(&mut self, line: &str) -> Result<(), SessionError> {
        let message = decode_server(line)
            .map_err(|error| SessionError::Line { error, line: line.chars().take(QUOTED).collect() })?;
        self.handle_message(message)
    }

    /// Takes in one message from the server.
    pub fn handle_message(&mut self, message: ServerMessage) -> Result<(), SessionError> {
        let event = match message {
            ServerMessage::Welcome(welcome) => {
                self.queued = None;
                self.welcome = Some(welcome.clone());
                SessionEvent::Welcome(welcome)
            }
            ServerMessage::Lobby(lobby) => {
                if self.welcome.is_none() {
                    self.queued = lobby.queued;
                }
                SessionEvent::Lobby(lobby)
            }
            ServerMessage::Percepts(percepts) => {
                let delta = percepts_delta(&percepts).map_err(SessionError::Percepts)?;
                self.tick = Some(percepts.tick);
                self.owed = Some(percepts.tick);
                SessionEvent::Percepts { delta, words: percepts.words }
            }
            ServerMessage::Ack(ack) => {
                let request = self.answered(ack.id.as_ref(), |request| !ack.ok || !request.durative());
                SessionEvent::Ack { ack, request }
            }
            ServerMessage::Result(result) => {
                let request = self.answered(Some(&result.id), |_| true);
                SessionEvent::Result { result, request }
            }
            ServerMessage::Error(error) => {
                if error.fatal {
                    self.close(Closed::Refused(error.clone()));
                }
                SessionEvent::Error(error)
            }
            ServerMessage::MatchEnd(end) => {
                // No `ready` is expected for the last tick.
                self.owed = None;
                SessionEvent::MatchEnd(end)
            }
            ServerMessage::Bye(bye) => {
                if !matches!(self.closed, Some(Closed::Refused(_))) {
                    self.close(Closed::Bye(bye.clone()));
                }
                SessionEvent::Bye(bye)
            }
            ServerMessage::Pause(pause) => SessionEvent::Pause(pause),
            // Players ping nobody and are sent no frames.
            ServerMessage::Pong(_) | ServerMessage::Frame(_) => return Ok(()),
        };
        self.events.push_back(event);
        Ok(())
    }

    /// The request `id` answers, forgotten if `done` says it has nothing more to come.
    fn answered(&mut self, id: Option<&ActId>, done: impl FnOnce(&Request) -> bool) -> Option<Request> {
        let Some(ActId::Number(id)) = id else { return None };
        let request = self.in_flight.get(id)?;
        if done(request) { self.in_flight.remove(id) } else { Some(request.clone()) }
    }

    /// The next thing the server told the player.
    pub fn poll_event(&mut self) -> Option<SessionEvent> {
        self.events.pop_front()
    }

    /// The next line to send, newline included.
    pub fn poll_transmit(&mut self) -> Option<String> {
        self.transmit.pop_front()
    }

    /// Queues an `act` for `action`; returns its id.
    pub fn act(&mut self, action: &Action) -> u64 {
        let (name, args) = action_to_act(action);
        self.act_named(name, args)
    }

    /// Queues an `act` by the action's wire name and arguments, as given (the server judges
    /// them); returns its id.
    pub fn act_named(&mut self, action: &str, args: Vec<Value>) -> u64 {
        self.request(|id| ClientMessage::Act(Act { id, action: action.to_string(), args }))
    }

    /// Queues a `say` to a player or `all`: a message of the language (`said`) or free
    /// `text`, exactly one of the two; returns its id.
    pub fn say(&mut self, to: &str, text: Option<String>, said: Option<Said>) -> u64 {
        self.request(|id| ClientMessage::Say(Say { id: Some(id), to: to.to_string(), text, said }))
    }

    fn request(&mut self, message: impl FnOnce(ActId) -> ClientMessage) -> u64 {
        self.next_id += 1;
        let request = Request { id: self.next_id, message: message(ActId::Number(self.next_id)) };
        self.send(&request.message);
        if self.closed.is_none() {
            self.in_flight.insert(request.id, request);
        }
        self.next_id
    }

    /// The player has decided on what it was told: in lockstep, answers the last `percepts`
    /// with `ready`, once. Nothing if no `percepts` is unanswered, or in realtime.
    pub fn ready(&mut self) {
        if !self.lockstep() {
            return;
        }
        if let Some(tick) = self.owed.take() {
            self.send(&ClientMessage::ready(tick));
        }
    }

    /// Asks for a full snapshot; it comes as a [`SessionEvent::Percepts`] with `delta.full`, to
    /// be answered like any other.
    pub fn resync(&mut self) {
        self.send(&ClientMessage::Resync(Resync {}));
    }

    /// Queues a `report` of how the player is driven.
    pub fn report(&mut self, usage: PlayerUsage) {
        self.send(&ClientMessage::Report(usage));
    }

    /// Leaves the match: queues `bye`, the last line this session sends.
    pub fn bye(&mut self) {
        self.send(&ClientMessage::Bye(ClientBye {}));
        self.close(Closed::Left);
    }

    fn send(&mut self, message: &ClientMessage) {
        if self.closed.is_none() {
            self.transmit.push_back(encode(message));
        }
    }

    fn close(&mut self, why: Closed) {
        self.owed = None;
        self.closed = Some(why);
    }

    /// The `welcome`, once seated.
    pub fn welcome(&self) -> Option<&Welcome> {
        self.welcome.as_ref()
    }

    /// The match joined, once seated.
    pub fn match_info(&self) -> Option<&MatchInfo> {
        self.welcome.as_ref().map(|w| &w.match_info)
    }

    /// The place in a template's queue (1: next), while waiting there for a seat.
    pub fn queued(&self) -> Option<usize> {
        self.queued
    }

    /// The tick of the last `percepts`.
    pub fn tick(&self) -> Option<u64> {
        self.tick
    }

    /// Why the connection is over, once it is: nothing more is sent on it.
    pub fn closed(&self) -> Option<&Closed> {
        self.closed.as_ref()
    }

    /// Requests sent whose `ack` (or, for an accepted order, `result`) has not come.
    pub fn in_flight(&self) -> impl Iterator<Item = &Request> {
        self.in_flight.values()
    }

    /// Whether the match is paced by `ready`.
    pub fn lockstep(&self) -> bool {
        self.match_info().is_some_and(|info| info.mode == Mode::Lockstep)
    }
}

#[cfg(test)]
mod tests;
