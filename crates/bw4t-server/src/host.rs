//! The match task: the one owner of the match. It admits players (at most `robots`),
//! spectators and the operator, each with its own token, buffers actions until the next
//! tick boundary, paces ticks (realtime or lockstep) and sends every client what concerns
//! it, never waiting on any client.

use std::collections::{BTreeMap, BTreeSet};
use std::future::Future;
use std::sync::Arc;

use bw4t_agents::Driver;
use bw4t_protocol::{
    Ack, ActId, ActResult, ClientMessage, Frame, FrameMessage, Hello, MatchEnd, MatchInfo, MatchResult, Mode,
    Percepts, Role, ServerMessage, VERSION, Welcome, action_from_act, encode, percept_to_fact,
};
use bw4t_protocol::{Recorder, ReplayEvent, RobotExtra};
use bw4t_sim::{Accepted, Action, Match, OrderId, Receiver, Rejection, RobotId};
use tokio::sync::{Notify, mpsc, watch};
use tokio::time::{Duration, Instant};

use crate::connection::{ConnId, Event, Opened, Outbound, bye_line, error_line};
use crate::{Extras, Seat, ServerConfig};

/// Capacity of the channel from connections to the match task.
pub const EVENT_QUEUE: usize = 4096;

/// Room kept in a client's queue for acks, results and errors: percepts are held back
/// (and later replaced by a snapshot) when less than this is free.
const RESERVE: usize = 64;

/// How many messages a spectator frame carries at most.
const FRAME_MESSAGES: usize = 100;

/// How long the end of a match waits for clients' queues to drain.
const FLUSH_LIMIT: Duration = Duration::from_secs(2);

/// Ticks simulated back to back (lockstep, nobody awaited) before letting other tasks run.
const YIELD_EVERY: u64 = 64;

struct Conn {
    tx: mpsc::Sender<Outbound>,
    kill: Arc<Notify>,
    done: watch::Receiver<bool>,
    role: ConnRole,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum ConnRole {
    New,
    Agent(RobotId),
    /// A spectator or the operator: gets frames, cannot act.
    Watcher(Sight),
}

/// Which messages a watcher's frames carry.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Sight {
    /// Messages to `all` only.
    Public,
    /// Private (addressed) messages too.
    Everything,
}

/// Which percepts to send a player.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Send {
    /// A full snapshot.
    Snapshot,
    /// This tick's delta: sent if anything changed, after a `result`, or with `every_tick`.
    Tick,
}

/// What a player asked for, applied at the next tick boundary.
enum Pending {
    Act(Option<ActId>, Action),
    /// The player's connection dropped: the robot stops where it stands.
    Stop,
}

struct Player {
    name: String,
    session: String,
    conn: Option<ConnId>,
    dropped_at: Option<Instant>,
    every_tick: bool,
    pending: Vec<Pending>,
    actions_this_tick: u32,
    orders: BTreeMap<OrderId, ActId>,
    awaiting: bool,
    needs_snapshot: bool,
    full_since: Option<Instant>,
    /// An in-process agent playing this robot.
    local: Option<Driver>,
    /// A seat kept for a remote player: its name is claimed by the first `hello` with it.
    reserved: bool,
    /// Whether a client ever played this robot.
    connected_ever: bool,
    /// Lockstep deadlines missed in a row.
    late_in_row: u32,
    /// Bad lines from this player's connections.
    errors: u64,
}

impl Player {
    fn new(name: String, session: String) -> Player {
        Player {
            name,
            session,
            conn: None,
            dropped_at: None,
            every_tick: false,
            pending: Vec::new(),
            actions_this_tick: 0,
            orders: BTreeMap::new(),
            awaiting: false,
            needs_snapshot: false,
            full_since: None,
            local: None,
            reserved: false,
            connected_ever: false,
            late_in_row: 0,
            errors: 0,
        }
    }
}

/// The match and everyone connected to it.
pub struct Host {
    config: ServerConfig,
    game: Match,
    events: mpsc::Receiver<Event>,
    conns: BTreeMap<ConnId, Conn>,
    players: BTreeMap<RobotId, Player>,
    late: BTreeMap<RobotId, u64>,
    tick_sent_at: Instant,
    last_frame: Option<Instant>,
    frame_messages: Vec<FrameMessage>,
    end: Option<&'static str>,
    sessions: u64,
    /// Writers of closed connections that may still be flushing.
    closing: Vec<watch::Receiver<bool>>,
    recorder: Option<Recorder>,
    /// Names of reserved seats whose player will not come (its process died).
    gone_seats: Option<mpsc::Receiver<String>>,
    abandoned: BTreeSet<String>,
    /// Figures of players that left (errors, whether they ever connected), for the result.
    gone: BTreeMap<RobotId, (u64, bool)>,
}

impl Host {
    /// A host for a new match; nothing runs until [`Host::run`].
    pub fn new(
        config: ServerConfig,
        events: mpsc::Receiver<Event>,
        extras: Extras,
    ) -> Result<Host, crate::ServerError> {
        let tokens = [
            ("player", &config.token),
            ("spectator", &config.spectator_token),
            ("operator", &config.operator_token),
        ];
        for (i, (a, first)) in tokens.iter().enumerate() {
            for (b, second) in &tokens[i + 1..] {
                if first.is_some() && first == second {
                    return Err(crate::ServerError::SameToken(a, b));
                }
            }
        }
        if extras.seats.len() > config.robots {
            let message =
                format!("{} seats, but the match admits {} players", extras.seats.len(), config.robots);
            return Err(crate::ServerError::Seat(message));
        }
        let game = Match::new(&config.map, &config.game, config.seed)?;
        let names = extras.seats.iter().map(|s| s.name().to_string()).collect();
        let recorder = extras.replay.map(|out| {
            Recorder::new(out, &game, &extras.program, names, crate::REPLAY_DIGEST_EVERY, config.max_ticks)
        });
        let mut host = Host {
            config,
            game,
            events,
            conns: BTreeMap::new(),
            players: BTreeMap::new(),
            late: BTreeMap::new(),
            tick_sent_at: Instant::now(),
            last_frame: None,
            frame_messages: Vec::new(),
            end: None,
            sessions: 0,
            closing: Vec::new(),
            recorder,
            gone_seats: extras.gone_seats,
            abandoned: BTreeSet::new(),
            gone: BTreeMap::new(),
        };
        for seat in extras.seats {
            let (name, local) = match seat {
                Seat::Remote(name) => (name, None),
                Seat::Local(name, agent) => (name, Some(agent)),
            };
            let id = host.join(Some(&name)).map_err(|(_, message)| crate::ServerError::Seat(message))?;
            if let Some(player) = host.players.get_mut(&id) {
                player.reserved = local.is_none();
                player.local = local.map(|agent| Driver::new(id, agent));
            }
        }
        Ok(host)
    }

    fn record(&mut self, event: ReplayEvent) {
        let tick = self.game.tick();
        if let Some(r) = self.recorder.as_mut() {
            r.event(tick, event);
        }
    }

    /// Runs the match to its end and returns the result.
    pub async fn run(mut self, shutdown: impl Future<Output = ()>) -> MatchResult {
        let started = Instant::now();
        tokio::pin!(shutdown);
        // Before the first tick: admit players until enough have joined.
        let start_by = self.config.start_timeout.map(|t| started + t);
        while self.end.is_none()
            && self.connected_players() + self.abandoned.len() < self.config.robots
            && start_by.is_none_or(|t| Instant::now() < t)
        {
            tokio::select! {
                () = &mut shutdown => self.end = Some("interrupted"),
                event = self.events.recv() => self.on_event(event),
                Some(name) = recv_opt(&mut self.gone_seats) => {
                    self.abandoned.insert(name);
                }
                () = tokio::time::sleep(Duration::from_millis(100)) => self.expire_dropped(),
            }
        }
        // `wall_ms` counts from the first tick: waiting for players is not playing.
        let mut playing_since = None;
        if self.end.is_none() {
            self.observe_locals();
            self.tick_sent_at = Instant::now();
            playing_since = Some(self.tick_sent_at);
            match self.config.mode {
                Mode::Realtime => self.run_realtime(&mut shutdown).await,
                Mode::Lockstep => self.run_lockstep(&mut shutdown).await,
            }
        }
        self.finish(playing_since).await
    }

    async fn run_realtime(&mut self, shutdown: &mut std::pin::Pin<&mut impl Future<Output = ()>>) {
        let period = Duration::from_secs_f64(1.0 / f64::from(self.config.game.ticks_per_second));
        let mut ticks = tokio::time::interval_at(Instant::now() + period, period);
        ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        while self.end.is_none() {
            tokio::select! {
                biased;
                () = &mut *shutdown => self.end = Some("interrupted"),
                _ = ticks.tick() => self.advance(),
                event = self.events.recv() => self.on_event(event),
            }
        }
    }

    async fn run_lockstep(&mut self, shutdown: &mut std::pin::Pin<&mut impl Future<Output = ()>>) {
        let mut back_to_back = 0u64;
        while self.end.is_none() {
            let deadline = self.config.deadline.map(|d| self.tick_sent_at + d);
            while self.end.is_none() && self.players.values().any(|p| p.awaiting) {
                back_to_back = 0;
                tokio::select! {
                    biased;
                    () = &mut *shutdown => self.end = Some("interrupted"),
                    event = self.events.recv() => self.on_event(event),
                    () = sleep_until_opt(deadline) => self.mark_late(),
                }
            }
            // Take in what has arrived, without waiting for anyone.
            while let Ok(event) = self.events.try_recv() {
                self.on_event(Some(event));
            }
            if self.end.is_some() {
                break;
            }
            // A player that joined or resynced just now was sent this tick: wait for it too.
            if self.players.values().any(|p| p.awaiting) {
                continue;
            }
            // With no player connected there is no one to play for: wait instead of spinning.
            if self.config.pause_when_empty && self.connected_players() == 0 {
                tokio::select! {
                    () = &mut *shutdown => self.end = Some("interrupted"),
                    event = self.events.recv() => self.on_event(event),
                    () = tokio::time::sleep(Duration::from_millis(250)) => self.expire_dropped(),
                }
                continue;
            }
            // A stop request must be seen even while nobody is awaited and no event comes.
            tokio::select! {
                biased;
                () = &mut *shutdown => self.end = Some("interrupted"),
                () = std::future::ready(()) => {}
            }
            if self.end.is_some() {
                break;
            }
            self.advance();
            back_to_back += 1;
            if back_to_back.is_multiple_of(YIELD_EVERY) {
                tokio::task::yield_now().await;
            }
        }
    }

    fn connected_players(&self) -> usize {
        self.players.values().filter(|p| p.conn.is_some() || p.local.is_some()).count()
    }

    /// In-process agents see what they were told and decide; their actions wait for the
    /// next boundary like everyone else's.
    fn observe_locals(&mut self) {
        for player in self.players.values_mut() {
            if let Some(driver) = player.local.as_mut() {
                driver.observe(&mut self.game);
            }
        }
    }

    /// Players that did not answer by the deadline are counted late and no longer awaited.
    fn mark_late(&mut self) {
        let mut unresponsive = Vec::new();
        for (id, player) in self.players.iter_mut().filter(|(_, p)| p.awaiting) {
            player.awaiting = false;
            player.late_in_row += 1;
            *self.late.entry(*id).or_default() += 1;
            if self.config.max_late_in_row.is_some_and(|max| player.late_in_row >= max) {
                unresponsive.extend(player.conn);
            }
        }
        for conn in unresponsive {
            self.disconnect(conn, "unresponsive", "no ready for too many ticks in a row");
        }
    }

    /// One tick boundary: apply buffered actions in robot-id order, step, tell everyone.
    fn advance(&mut self) {
        let ids: Vec<RobotId> = self.players.keys().copied().collect();
        // Players acked at this boundary: each gets this tick's `percepts`, so it has a tick
        // to answer and its next actions land at a boundary its script decides.
        let mut acked = BTreeSet::new();
        for &id in &ids {
            let pending =
                self.players.get_mut(&id).map(|p| std::mem::take(&mut p.pending)).unwrap_or_default();
            for item in pending {
                match item {
                    Pending::Act(act_id, action) => {
                        let _ = self.apply(id, act_id, action);
                        acked.insert(id);
                    }
                    Pending::Stop => {
                        let _ = self.game.stop(id);
                        self.record(ReplayEvent::Stop { robot: id.0 });
                    }
                }
            }
            let queued = self.players.get_mut(&id).and_then(|p| p.local.as_mut()).map(Driver::take_queued);
            for (n, action) in queued.unwrap_or_default() {
                let outcome = self.apply(id, None, action);
                if let Some(driver) = self.players.get_mut(&id).and_then(|p| p.local.as_mut()) {
                    driver.answered(n, &outcome);
                }
            }
            if let Some(p) = self.players.get_mut(&id) {
                p.actions_this_tick = 0;
            }
        }
        let report = self.game.step();
        let tick = report.tick;
        if let Some(r) = self.recorder.as_mut() {
            r.stepped(&self.game);
        }
        // A new tick: players are awaited again only if they are sent something now.
        for (id, player) in &mut self.players {
            player.awaiting = acked.contains(id) && player.conn.is_some();
        }
        for end in report.ended {
            let Some(player) = self.players.get_mut(&end.robot) else { continue };
            if let Some(driver) = player.local.as_mut() {
                driver.ended(&end);
                continue;
            }
            let Some(id) = player.orders.remove(&end.order) else { continue };
            let result = ServerMessage::Result(ActResult { id, outcome: end.outcome.name().into(), tick });
            if let Some(conn) = player.conn {
                player.awaiting = true;
                self.send(conn, &result);
            }
        }
        self.tick_sent_at = Instant::now();
        for id in ids {
            self.send_percepts(id, Send::Tick);
        }
        self.observe_locals();
        self.send_frames(false);
        self.expire_dropped();
        if self.game.is_complete() {
            self.end = Some("completed");
        } else if self.config.max_ticks.is_some_and(|max| tick >= max) {
            self.end = Some("max_ticks");
        }
    }

    fn apply(
        &mut self,
        robot: RobotId,
        act_id: Option<ActId>,
        action: Action,
    ) -> Result<Accepted, Rejection> {
        let message = match &action {
            Action::SendMessage { to, text } => Some(FrameMessage {
                from: self.players.get(&robot).map(|p| p.name.clone()).unwrap_or_default(),
                to: match to {
                    Receiver::All => "all".into(),
                    Receiver::Player(name) => name.clone(),
                },
                text: text.clone(),
            }),
            _ => None,
        };
        let (name, args) = bw4t_protocol::action_to_act(&action);
        let outcome = self.game.handle_action(robot, action);
        let event = ReplayEvent::Act { robot: robot.0, action: name.to_string(), args, ok: outcome.is_ok() };
        self.record(event);
        let tick = self.game.tick();
        let ack = match &outcome {
            Ok(_) => Ack { id: act_id.clone(), ok: true, tick, code: None, reason: None },
            Err(r) => Ack {
                id: act_id.clone(),
                ok: false,
                tick,
                code: Some(r.code().into()),
                reason: Some(r.to_string()),
            },
        };
        if let (Ok(_), Some(message)) = (&outcome, message) {
            if self.frame_messages.len() == FRAME_MESSAGES {
                self.frame_messages.remove(0);
            }
            self.frame_messages.push(message);
        }
        let Some(player) = self.players.get_mut(&robot) else { return outcome };
        if let (Ok(accepted), Some(id)) = (&outcome, act_id) {
            if let Some(order) = accepted.order {
                player.orders.insert(order, id);
            }
        }
        if let (Some(conn), None) = (player.conn, &player.local) {
            self.send(conn, &ServerMessage::Ack(ack));
        }
        outcome
    }

    /// Sends a player what it has not been told. Returns whether anything was sent.
    fn send_percepts(&mut self, id: RobotId, what: Send) -> bool {
        let Some(player) = self.players.get_mut(&id) else { return false };
        let Some(conn_id) = player.conn else { return false };
        let Some(conn) = self.conns.get(&conn_id) else { return false };
        if conn.tx.capacity() < RESERVE {
            // Not reading: hold percepts back; the next ones sent will be a full snapshot.
            // Nothing sent, nothing to answer: lockstep does not wait for it.
            player.needs_snapshot = true;
            player.awaiting = false;
            let since = *player.full_since.get_or_insert_with(Instant::now);
            if since.elapsed() > self.config.slow_limit {
                self.disconnect(conn_id, "too_slow", "the client did not read its messages");
            }
            return false;
        }
        player.full_since = None;
        let full = what == Send::Snapshot || std::mem::take(&mut player.needs_snapshot);
        let delta = if full { self.game.snapshot(id) } else { self.game.poll_percepts(id) };
        let Some(delta) = delta else { return false };
        // A tick's messages to a player always end with its `percepts`, even an empty one
        // after a `result`, so a player knows when it has heard everything for the tick.
        if delta.is_empty() && !player.every_tick && !player.awaiting {
            return false;
        }
        player.awaiting = true;
        let message = ServerMessage::Percepts(Percepts {
            tick: delta.tick,
            add: delta.add.iter().map(percept_to_fact).collect(),
            not: delta.not.iter().map(percept_to_fact).collect(),
            full: delta.full,
        });
        self.send(conn_id, &message);
        true
    }

    fn send_frames(&mut self, force: bool) {
        let watchers: Vec<(ConnId, Sight)> = self
            .conns
            .iter()
            .filter_map(
                |(id, c)| if let ConnRole::Watcher(sight) = c.role { Some((*id, sight)) } else { None },
            )
            .collect();
        if watchers.is_empty() {
            self.frame_messages.clear();
            return;
        }
        let interval = Duration::from_secs_f64(1.0 / f64::from(self.config.spectator_hz.max(1)));
        // Ticks come with some jitter: allow a frame a little early rather than skip one.
        if !force && self.last_frame.is_some_and(|t| t.elapsed() < interval.mul_f64(0.8)) {
            return;
        }
        self.last_frame = Some(Instant::now());
        let mut frame = Frame::of(&self.game, std::mem::take(&mut self.frame_messages));
        let wanted = |sight| watchers.iter().any(|w| w.1 == sight);
        let line = |frame: &Frame| -> Arc<str> { encode(&ServerMessage::Frame(frame.clone())).into() };
        let everything = wanted(Sight::Everything).then(|| line(&frame));
        // `all` is no player's name (it is refused at `hello`), so it marks public messages.
        frame.messages.retain(|m| m.to == "all");
        let public = wanted(Sight::Public).then(|| line(&frame));
        for (conn, sight) in watchers {
            let line = if sight == Sight::Everything { &everything } else { &public };
            // Frames are whole states: one a spectator misses is replaced by the next.
            if let (Some(c), Some(line)) = (self.conns.get(&conn), line) {
                if c.tx.capacity() > RESERVE {
                    let _ = c.tx.try_send(Outbound::Line(line.clone()));
                }
            }
        }
    }

    fn on_event(&mut self, event: Option<Event>) {
        match event {
            // Every sender is gone only when the acceptor has stopped; end the match.
            None => self.end = Some("interrupted"),
            Some(Event::Opened(Opened { conn, tx, kill, done })) => {
                self.conns.insert(conn, Conn { tx, kill, done, role: ConnRole::New });
            }
            Some(Event::Closed { conn }) => self.on_closed(conn),
            Some(Event::BadInput { conn }) => self.count_error(conn),
            Some(Event::Message { conn, message }) => self.on_message(conn, message),
        }
    }

    fn count_error(&mut self, conn: ConnId) {
        if let Some(ConnRole::Agent(id)) = self.conns.get(&conn).map(|c| c.role) {
            if let Some(player) = self.players.get_mut(&id) {
                player.errors += 1;
            }
        }
    }

    fn on_closed(&mut self, conn: ConnId) {
        let Some(closed) = self.conns.remove(&conn) else { return };
        // The end of the match waits for this writer too, so nothing queued is cut off.
        self.closing.retain(|done| !*done.borrow());
        self.closing.push(closed.done);
        if let ConnRole::Agent(id) = closed.role {
            if let Some(player) = self.players.get_mut(&id) {
                if player.conn == Some(conn) {
                    // The robot stands still (holding what it holds) until its player returns.
                    player.conn = None;
                    player.dropped_at = Some(Instant::now());
                    player.awaiting = false;
                    player.orders.clear();
                    player.pending = vec![Pending::Stop];
                }
            }
        }
    }

    fn on_message(&mut self, conn: ConnId, message: ClientMessage) {
        let Some(role) = self.conns.get(&conn).map(|c| c.role) else { return };
        let robot = match (role, &message) {
            (_, ClientMessage::Hello(hello)) => return self.on_hello(conn, role, hello),
            (ConnRole::Agent(id), _) => id,
            (ConnRole::Watcher(_) | ConnRole::New, ClientMessage::Bye(_)) => {
                return self.disconnect(conn, "goodbye", "");
            }
            (ConnRole::Watcher(_), _) => {
                return self.error(conn, "not_a_player", "spectators cannot act", false);
            }
            (ConnRole::New, _) => return self.error(conn, "no_hello", "say hello first", false),
        };
        match message {
            ClientMessage::Act(act) => match action_from_act(&act.action, &act.args) {
                Ok(action) => self.queue_action(conn, robot, Some(act.id), action),
                Err(e) => self.reject(conn, Some(act.id), e.code, &e.message),
            },
            ClientMessage::Say(say) => {
                let action = Action::SendMessage { to: bw4t_protocol::receiver(&say.to), text: say.text };
                self.queue_action(conn, robot, say.id, action);
            }
            ClientMessage::Ready(ready) => {
                let now = self.game.tick();
                if ready.tick == now {
                    if let Some(player) = self.players.get_mut(&robot) {
                        player.awaiting = false;
                        player.late_in_row = 0;
                    }
                } else if ready.tick < now {
                    let message = format!("tick {} is over; the match is at tick {now}", ready.tick);
                    self.error(conn, "late_ready", &message, false);
                } else {
                    let message = format!("tick {} has not happened; the match is at tick {now}", ready.tick);
                    self.error(conn, "bad_tick", &message, false);
                }
            }
            ClientMessage::Resync(_) => {
                self.send_percepts(robot, Send::Snapshot);
            }
            ClientMessage::Bye(_) => {
                self.remove_player(robot);
                self.disconnect(conn, "goodbye", "");
            }
            ClientMessage::Hello(_) | ClientMessage::Ping(_) => {}
        }
    }

    fn queue_action(&mut self, conn: ConnId, robot: RobotId, id: Option<ActId>, action: Action) {
        let limit = self.config.max_actions_per_tick;
        let Some(player) = self.players.get_mut(&robot) else { return };
        if player.actions_this_tick >= limit {
            let reason = format!("at most {limit} actions and messages per tick");
            return self.reject(conn, id, "rate_limited", &reason);
        }
        player.actions_this_tick += 1;
        player.pending.push(Pending::Act(id, action));
    }

    fn reject(&mut self, conn: ConnId, id: Option<ActId>, code: &str, reason: &str) {
        let tick = self.game.tick();
        let ack = Ack { id, ok: false, tick, code: Some(code.into()), reason: Some(reason.into()) };
        self.send(conn, &ServerMessage::Ack(ack));
    }

    fn on_hello(&mut self, conn: ConnId, role: ConnRole, hello: &Hello) {
        if role != ConnRole::New {
            return self.error(conn, "already_joined", "this connection has already said hello", false);
        }
        if hello.protocol != bw4t_protocol::PROTOCOL {
            let message = format!("unknown protocol '{}' (this server speaks 'bw4t')", hello.protocol);
            return self.error(conn, "bad_protocol", &message, true);
        }
        if !hello.versions.contains(&VERSION) {
            let message = format!("no common protocol version (this server speaks {VERSION})");
            return self.error(conn, "unsupported_version", &message, true);
        }
        if let Err(message) = self.check_token(hello) {
            return self.error(conn, "bad_token", message, true);
        }
        let sight = match hello.role {
            Role::Agent => None,
            Role::Spectator if !self.config.spectators_see_private => Some(Sight::Public),
            Role::Spectator | Role::Operator => Some(Sight::Everything),
        };
        if let Some(sight) = sight {
            if let Some(c) = self.conns.get_mut(&conn) {
                c.role = ConnRole::Watcher(sight);
            }
            self.welcome(conn, None, false, Some(sight == Sight::Everything));
            return self.send_frames(true);
        }
        let every_tick = self.config.every_tick || hello.every_tick;
        let robot = match &hello.session {
            Some(session) => {
                let found = self.players.iter().find(|(_, p)| &p.session == session).map(|(id, _)| *id);
                let Some(id) = found else {
                    return self.error(conn, "bad_session", "unknown or expired session", true);
                };
                if let Some(old) = self.players.get(&id).and_then(|p| p.conn) {
                    self.disconnect(old, "replaced", "the session was taken up by a new connection");
                }
                id
            }
            None => {
                let seat = self
                    .players
                    .iter()
                    .find(|(_, p)| {
                        p.reserved && p.conn.is_none() && Some(p.name.as_str()) == hello.name.as_deref()
                    })
                    .map(|(id, _)| *id);
                match seat {
                    Some(id) => id,
                    None => match self.join(hello.name.as_deref()) {
                        Ok(id) => id,
                        Err((code, message)) => return self.error(conn, code, &message, true),
                    },
                }
            }
        };
        if let Some(player) = self.players.get_mut(&robot) {
            player.conn = Some(conn);
            player.connected_ever = true;
            player.late_in_row = 0;
            player.dropped_at = None;
            player.every_tick = every_tick;
            player.full_since = None;
        }
        if let Some(c) = self.conns.get_mut(&conn) {
            c.role = ConnRole::Agent(robot);
        }
        self.welcome(conn, Some(robot), every_tick, None);
        self.send_percepts(robot, Send::Snapshot);
    }

    /// Checks the credential of the role `hello` asks for; the error says what is missing.
    fn check_token(&self, hello: &Hello) -> Result<(), &'static str> {
        let presents = |secret: &Option<String>| matches!((secret, &hello.token), (Some(s), Some(t)) if same_secret(t, s));
        let config = &self.config;
        match hello.role {
            Role::Agent if config.token.is_none() || presents(&config.token) => Ok(()),
            Role::Agent => Err("wrong or missing player token"),
            // A local match (no player or spectator token) is open to watch.
            Role::Spectator if config.token.is_none() && config.spectator_token.is_none() => Ok(()),
            Role::Spectator if presents(&config.spectator_token) || presents(&config.operator_token) => {
                Ok(())
            }
            Role::Spectator => Err("watching this match needs the spectator token"),
            Role::Operator if presents(&config.operator_token) => Ok(()),
            Role::Operator if config.operator_token.is_none() => Err("this server has no operator token"),
            Role::Operator => Err("wrong or missing operator token"),
        }
    }

    fn join(&mut self, name: Option<&str>) -> Result<RobotId, (&'static str, String)> {
        let name = match name {
            Some(n) => n.to_string(),
            None => (1..)
                .map(|i| format!("Player{i}"))
                .find(|n| self.players.values().all(|p| &p.name != n))
                .unwrap_or_default(),
        };
        let refusal = |e: bw4t_sim::JoinError| {
            let code = match e {
                bw4t_sim::JoinError::InvalidName(_) => "invalid_name",
                bw4t_sim::JoinError::NameTaken(_) => "name_taken",
                bw4t_sim::JoinError::Full(_) => "match_full",
            };
            (code, e.to_string())
        };
        self.game.check_name(&name).map_err(refusal)?;
        // Every player in the match holds a seat: connected, reserved, or dropped and
        // within its grace period.
        let seats = self.config.robots;
        if self.players.len() >= seats {
            return Err(("match_full", format!("the match is full: it admits {seats} players")));
        }
        let id = self.game.join(&name).map_err(refusal)?;
        self.record(ReplayEvent::Join { name: name.clone(), robot: id.0 });
        // The id may have been another robot's: its figures belong to that one.
        self.late.remove(&id);
        self.gone.remove(&id);
        self.sessions += 1;
        let session = format!("{:016x}{:08x}", session_entropy(), self.sessions);
        self.players.insert(id, Player::new(name, session));
        Ok(id)
    }

    fn welcome(&mut self, conn: ConnId, robot: Option<RobotId>, every_tick: bool, private: Option<bool>) {
        let player = robot.and_then(|r| self.players.get(&r));
        let welcome = Welcome {
            version: VERSION,
            name: player.map(|p| p.name.clone()),
            robot: robot.map(|r| r.0),
            session: player.map(|p| p.session.clone()),
            private_messages: private,
            match_info: MatchInfo {
                map: self.game.map().name().to_string(),
                seed: self.config.seed,
                mode: self.config.mode,
                tick_hz: self.config.game.ticks_per_second,
                deadline_ms: (self.config.mode == Mode::Lockstep)
                    .then(|| self.config.deadline.map_or(0, |d| d.as_millis() as u64)),
                players_needed: self.config.robots,
                max_ticks: self.config.max_ticks,
                every_tick,
            },
        };
        self.send(conn, &ServerMessage::Welcome(welcome));
    }

    /// Takes a player's robot out of the match, keeping its figures for the result.
    fn remove_player(&mut self, id: RobotId) {
        if let Some(player) = self.players.remove(&id) {
            self.gone.insert(id, (player.errors, player.connected_ever));
        }
        if self.game.leave(id).is_ok() {
            self.record(ReplayEvent::Leave { robot: id.0 });
        }
    }

    /// Robots whose players stayed away longer than the grace period leave the match.
    fn expire_dropped(&mut self) {
        let grace = self.config.grace;
        let expired: Vec<RobotId> = self
            .players
            .iter()
            .filter(|(_, p)| p.conn.is_none() && p.dropped_at.is_some_and(|t| t.elapsed() >= grace))
            .map(|(id, _)| *id)
            .collect();
        for id in expired {
            self.remove_player(id);
        }
    }

    fn send(&mut self, conn: ConnId, message: &ServerMessage) {
        self.send_line(conn, encode(message).into());
    }

    fn send_line(&mut self, conn: ConnId, line: Arc<str>) {
        let Some(c) = self.conns.get(&conn) else { return };
        if c.tx.try_send(Outbound::Line(line)).is_err() {
            // Even the room kept for replies is used up: the client cannot keep up.
            c.kill.notify_one();
            self.on_closed(conn);
        }
    }

    fn error(&mut self, conn: ConnId, code: &str, message: &str, fatal: bool) {
        self.send_line(conn, error_line(code, message, fatal));
        if fatal {
            self.disconnect(conn, code, "");
        }
    }

    /// Says `bye` (after an error, when `message` is given) and closes the connection.
    fn disconnect(&mut self, conn: ConnId, reason: &str, message: &str) {
        if !message.is_empty() {
            self.send_line(conn, error_line(reason, message, true));
        }
        self.send_line(conn, bye_line(reason));
        if let Some(c) = self.conns.get(&conn) {
            if c.tx.try_send(Outbound::Close).is_err() {
                c.kill.notify_one();
            }
        }
        self.on_closed(conn);
    }

    async fn finish(mut self, playing_since: Option<Instant>) -> MatchResult {
        let reason = self.end.unwrap_or("interrupted");
        let wall_ms = playing_since.map_or(0, |t| t.elapsed().as_millis() as u64);
        let extra = |id: RobotId| {
            let (errors, connected) = match self.players.get(&id) {
                Some(p) => (p.errors, p.connected_ever || p.local.is_some()),
                None => self.gone.get(&id).copied().unwrap_or((0, false)),
            };
            RobotExtra { late_ticks: self.late.get(&id).copied().unwrap_or(0), errors, connected }
        };
        let result = MatchResult::of(&self.game, Some(self.config.mode), reason, wall_ms, extra);
        if let Some(recorder) = self.recorder.take() {
            // A replay that cannot be written must not cost the match its result.
            let _ = recorder.finish(&self.game, reason);
        }
        let end =
            encode(&ServerMessage::MatchEnd(MatchEnd { reason: reason.into(), result: result.clone() }));
        let end: Arc<str> = end.into();
        let conns: Vec<ConnId> = self.conns.keys().copied().collect();
        for conn in conns {
            if matches!(
                self.conns.get(&conn).map(|c| c.role),
                Some(ConnRole::Agent(_) | ConnRole::Watcher(_))
            ) {
                self.send_line(conn, end.clone());
            }
            self.disconnect(conn, "match_over", "");
        }
        let mut done = std::mem::take(&mut self.closing);
        let flushed = async {
            for d in &mut done {
                let _ = d.wait_for(|d| *d).await;
            }
        };
        let _ = tokio::time::timeout(FLUSH_LIMIT, flushed).await;
        result
    }
}

async fn recv_opt<T>(rx: &mut Option<mpsc::Receiver<T>>) -> Option<T> {
    match rx {
        Some(rx) => rx.recv().await,
        None => std::future::pending().await,
    }
}

async fn sleep_until_opt(deadline: Option<Instant>) {
    match deadline {
        Some(t) => tokio::time::sleep_until(t).await,
        None => std::future::pending().await,
    }
}

/// Whether `given` is `secret`, in a time that does not depend on where they differ.
fn same_secret(given: &str, secret: &str) -> bool {
    let differences = given.bytes().zip(secret.bytes()).fold(0u8, |acc, (a, b)| acc | (a ^ b));
    given.len() == secret.len() && differences == 0
}

/// Unpredictable bits for session tokens, from the standard library's per-process keys.
fn session_entropy() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(0);
    h.finish()
}
