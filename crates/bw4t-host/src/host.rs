//! [`MatchHost`]: the one owner of a served match, its events in and transmits out.

mod admission;

pub use admission::same_secret;

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant};

use bw4t_agents::{Driver, MatchSetup};
use bw4t_protocol::{
    Ack, ActId, ActResult, ClientMessage, Frame, FrameMessage, Knowledge, Lobby, MatchEnd, MatchResult, Mode,
    Percepts, ServerMessage, action_from_act, encode, percept_to_fact,
};
use bw4t_protocol::{AckCode, ByeReason, EndReason, ErrorCode, Leaving, Recorder, RobotExtra};
use bw4t_sim::{Accepted, Action, Intent, Match, OrderEnd, OrderId, Receiver, Rejection, RobotId, Seats};

use crate::lines::{bye_line, error_line};
use crate::{HostConfig, HostError};

/// Identifies a connection, unique for the host's life.
pub type ConnId = u64;

/// Room kept in a client's queue for acks, results and errors: percepts are held back
/// (and later replaced by a snapshot) when less than this is free.
const RESERVE: usize = 64;

/// How many messages a spectator frame carries at most.
const FRAME_MESSAGES: usize = 100;

/// What the host is told.
pub enum HostEvent {
    /// A new connection.
    Opened {
        /// Its id, unique for the host's life.
        conn: ConnId,
        /// Lines its outgoing queue can take.
        room: usize,
    },
    /// How many lines the connection's outgoing queue can take now, counting every line
    /// [`MatchHost::poll_transmit`] has handed out. The driver says so before it hands the
    /// host anything else, so the host never queues more than a client's queue holds.
    Room {
        /// The connection.
        conn: ConnId,
        /// Lines its outgoing queue can take.
        room: usize,
    },
    /// A well-formed message (other than `ping`, which connections answer themselves).
    Message {
        /// The connection it came on.
        conn: ConnId,
        /// The message.
        message: ClientMessage,
    },
    /// The connection sent a line that is not a valid message.
    BadInput {
        /// The connection.
        conn: ConnId,
    },
    /// The connection is gone.
    Closed {
        /// The connection.
        conn: ConnId,
    },
    /// The player of this reserved seat will not come (its process exited), so the match
    /// need not wait for it to start.
    SeatAbandoned {
        /// The seat's player name.
        name: String,
    },
}

/// What the host asks the driver to do.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Transmit {
    /// Queue these encoded lines for the connection, in order, as one batch: everything a
    /// connection is sent at one moment (a player's acks, results and percepts of a tick)
    /// comes as one, so its writer is woken once and can send it with one write.
    Lines {
        /// The connection.
        conn: ConnId,
        /// The lines, each with its newline; never empty.
        lines: Vec<Arc<str>>,
    },
    /// Close the connection after the lines queued before.
    Close {
        /// The connection.
        conn: ConnId,
    },
    /// Close the connection at once, queued lines or not (it does not read).
    Kill {
        /// The connection.
        conn: ConnId,
    },
}

struct Conn {
    /// Room in its outgoing queue when the driver last said.
    room: usize,
    /// Lines queued for it since then, taken by the driver or not.
    queued: usize,
    /// Lines handed to [`MatchHost::poll_transmit`]'s queue but not yet taken by the driver.
    unsent: usize,
    role: ConnRole,
    /// Its `hello` named a match or template, so it knows `lobby` (older clients, which
    /// name neither, never get a message type they do not know).
    lobby: bool,
}

impl Conn {
    /// Lines this connection's queue can still take.
    fn free(&self) -> usize {
        self.room.saturating_sub(self.queued)
    }
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
enum Delivery {
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

/// What a player is still to be told of the current tick.
struct TickNews {
    robot: RobotId,
    /// Acks and results of the boundary, in the order they arose, for the connection each
    /// was meant for.
    replies: Vec<(ConnId, ServerMessage)>,
}

/// Who asked for an action: a remote player (with the id its `ack` names) or an in-process
/// agent (with its driver's number).
enum Tag {
    Remote(Option<ActId>),
    Local(u64),
}

/// The host's players as the tick boundary sees them. Replies wait in `replies` until the
/// boundary is done, each robot's in the order they arose.
struct HostSeats<'a> {
    /// The tick the boundary applies actions after.
    tick: u64,
    players: &'a mut BTreeMap<RobotId, Player>,
    frame_messages: &'a mut Vec<FrameMessage>,
    replies: BTreeMap<RobotId, Vec<(ConnId, ServerMessage)>>,
    /// Remote players acked or sent a `result` at this boundary.
    told: BTreeSet<RobotId>,
}

impl Seats for HostSeats<'_> {
    type Tag = Tag;

    fn robots(&self, into: &mut Vec<RobotId>) {
        into.extend(self.players.keys().copied());
    }

    fn take(&mut self, robot: RobotId, into: &mut Vec<Intent<Tag>>) {
        let Some(player) = self.players.get_mut(&robot) else { return };
        player.actions_this_tick = 0;
        into.extend(player.pending.drain(..).map(|pending| match pending {
            Pending::Act(id, action) => Intent::Act(Tag::Remote(id), action),
            Pending::Stop => Intent::Stop,
        }));
        if let Some(driver) = player.local.as_mut() {
            driver.take_intents(into, Tag::Local);
        }
    }

    fn answered(&mut self, robot: RobotId, tag: Tag, action: &Action, outcome: &Result<Accepted, Rejection>) {
        let Some(player) = self.players.get_mut(&robot) else { return };
        if let (Ok(_), Action::SendMessage { to, text }) = (outcome, action) {
            if self.frame_messages.len() == FRAME_MESSAGES {
                self.frame_messages.remove(0);
            }
            let to = match to {
                Receiver::All => "all".into(),
                Receiver::Player(name) => name.clone(),
            };
            self.frame_messages.push(FrameMessage::new(player.name.clone(), to, text));
        }
        let act_id = match tag {
            Tag::Local(n) => {
                if let Some(driver) = player.local.as_mut() {
                    driver.answered(n, outcome);
                }
                return;
            }
            Tag::Remote(act_id) => act_id,
        };
        self.told.insert(robot);
        if let (Ok(Accepted { order: Some(order) }), Some(id)) = (outcome, &act_id) {
            player.orders.insert(*order, id.clone());
        }
        let ack = match outcome {
            Ok(_) => Ack { id: act_id, ok: true, tick: self.tick, code: None, reason: None },
            Err(r) => Ack {
                id: act_id,
                ok: false,
                tick: self.tick,
                code: Some(AckCode::from(r)),
                reason: Some(r.to_string()),
            },
        };
        if let (Some(conn), None) = (player.conn, &player.local) {
            self.replies.entry(robot).or_default().push((conn, ServerMessage::Ack(ack)));
        }
    }

    fn ended(&mut self, end: &OrderEnd, tick: u64) {
        let Some(player) = self.players.get_mut(&end.robot) else { return };
        if let Some(driver) = player.local.as_mut() {
            return driver.ended(end);
        }
        let Some(id) = player.orders.remove(&end.order) else { return };
        if let Some(conn) = player.conn {
            self.told.insert(end.robot);
            let result = ActResult { id, outcome: end.outcome.into(), tick };
            self.replies.entry(end.robot).or_default().push((conn, ServerMessage::Result(result)));
        }
    }
}

/// What the result keeps of a player whose robot was taken out.
#[derive(Clone, Copy, Debug, Default)]
struct GoneFigures {
    errors: u64,
    connected: bool,
    absences: Absences,
}

/// A player's absences after the start: drops of its connection and the ticks away.
#[derive(Clone, Copy, Debug, Default)]
struct Absences {
    drops: u32,
    ticks: u64,
    /// The tick of the drop it has not come back from.
    since: Option<u64>,
}

impl Absences {
    /// The connection dropped at `tick`.
    fn dropped(&mut self, tick: u64) {
        self.drops = self.drops.saturating_add(1);
        self.since = Some(tick);
    }

    /// The player is back (or the absence ends otherwise) at `tick`.
    fn ended(&mut self, tick: u64) {
        if let Some(since) = self.since.take() {
            self.ticks = self.ticks.saturating_add(tick.saturating_sub(since));
        }
    }

    /// The figures as of `tick`, an absence still going on counted to it.
    fn as_of(mut self, tick: u64) -> Absences {
        self.ended(tick);
        self
    }
}

struct Player {
    name: String,
    session: String,
    conn: Option<ConnId>,
    dropped_at: Option<Instant>,
    every_tick: bool,
    /// What its robot knows, kept only for a player whose `hello` asked for `words`.
    knowledge: Option<Box<Knowledge>>,
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
    /// Its drops and time away after the start.
    absences: Absences,
    /// The tick its last `resync` was answered at: one a tick at most, since a snapshot is
    /// many times the size of the request (the match's clock paces them, as percepts).
    resynced_at: Option<u64>,
}

impl Player {
    fn new(name: String, session: String) -> Player {
        Player {
            name,
            session,
            conn: None,
            dropped_at: None,
            every_tick: false,
            knowledge: None,
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
            absences: Absences::default(),
            resynced_at: None,
        }
    }
}

/// Where the match is in its life.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Admitting players until enough have joined, or until the start timeout.
    Waiting { start_by: Option<Instant> },
    /// Ticking since the first tick was due; realtime ticks fall due at `next_tick`.
    Playing { since: Instant, next_tick: Instant },
}

/// A served match and everyone connected to it, without I/O.
pub struct MatchHost {
    config: HostConfig,
    /// What of the match's set-up the host needs after the match is made.
    played: Played,
    game: Match,
    conns: BTreeMap<ConnId, Conn>,
    players: BTreeMap<RobotId, Player>,
    late: BTreeMap<RobotId, u64>,
    /// Each robot's player's last `report` (kept after it leaves, for the result).
    usage: BTreeMap<RobotId, bw4t_protocol::PlayerUsage>,
    phase: Phase,
    /// The latest time the host was given.
    now: Instant,
    tick_sent_at: Instant,
    last_frame: Option<Instant>,
    /// A frame was held back by the rate limit: one is sent when the period is over, so
    /// watchers see the present even while a lockstep match waits.
    frame_owed: bool,
    frame_messages: Vec<FrameMessage>,
    end: Option<EndReason>,
    sessions: u64,
    outbox: VecDeque<Transmit>,
    /// Players still to be told the current tick (its replies, then its percepts).
    news_due: VecDeque<TickNews>,
    recorder: Option<Recorder>,
    /// Names of reserved seats whose player will not come.
    abandoned: BTreeSet<String>,
    /// Figures of players that left, for the result.
    gone: BTreeMap<RobotId, GoneFigures>,
    /// How often the operator paused the match.
    pauses: u32,
    /// Who is in the waiting match changed: connections get a `lobby`.
    lobby_changed: bool,
    /// The operator paused the match: no tick is made until it is resumed.
    held: bool,
    /// How late the last realtime tick was made, and the ticks skipped, until taken.
    lateness: Option<(Duration, u64)>,
    /// Since when the started match has had no remote player connected: it ends as
    /// `abandoned` a grace period later (see [`Self::note_presence`]).
    deserted_since: Option<Instant>,
}

/// The figures of a match's set-up the host goes on using.
struct Played {
    seed: u64,
    tick_hz: u32,
    /// Seats, named and open: the players the match waits for and admits at most.
    robots: usize,
    max_ticks: Option<u64>,
    /// Some seat is for a remote player (not all are built-in or in-process agents): a
    /// match all its players left can end as `abandoned`.
    remote_seats: bool,
}

/// Where a match is, for listings: a copy made on request, so it costs nothing per tick.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct HostStatus {
    /// Whether the first tick has been made.
    pub started: bool,
    /// Whether the operator paused it.
    pub paused: bool,
    /// Whether the match has ended.
    pub over: bool,
    /// The current tick.
    pub tick: u64,
    /// The players in the match, in robot order.
    pub players: Vec<String>,
    /// How many more players the match waits for before its first tick (0 once started).
    pub awaited: usize,
    /// Sequence positions delivered, and the sequence's length.
    pub sequence: (usize, usize),
    /// Connections open (players, spectators and those yet to say hello).
    pub connections: usize,
}

impl MatchHost {
    /// A host for a new match of `setup` created at `now`, run as `config` says, with the
    /// replay, if any, written to `replay`. Its named seats are taken at once, in robot-id
    /// order: built-in and in-process agents play them here, remote players claim them
    /// by name; its open seats wait for whoever joins. A program or a learner cannot
    /// play a served match (the runner starts programs and gives them remote seats).
    pub fn new(
        setup: MatchSetup,
        config: HostConfig,
        replay: Option<(Box<dyn std::io::Write + Send>, String)>,
        now: Instant,
    ) -> Result<MatchHost, HostError> {
        admission::check_tokens_differ(&config)?;
        config.check().map_err(HostError::Config)?;
        setup.check().map_err(|e| HostError::Seat(e.to_string()))?;
        setup
            .only_players("in a served match", |p| {
                !matches!(p, bw4t_agents::Player::Program(_) | bw4t_agents::Player::Learner)
            })
            .map_err(|e| HostError::Seat(e.to_string()))?;
        let MatchSetup { map, seed, game, seats, max_ticks } = setup;
        let remote_seats =
            seats.iter().any(|s| matches!(s.player, bw4t_agents::Player::Remote | bw4t_agents::Player::Open));
        let played =
            Played { seed, tick_hz: game.ticks_per_second, robots: seats.len(), max_ticks, remote_seats };
        let game = Match::new(&map, &game, seed)?;
        let names = seats.iter().filter(|s| !matches!(s.player, bw4t_agents::Player::Open));
        let names = names.map(|s| s.name.clone()).collect();
        let recorder = replay.map(|(out, program)| {
            let meta = bw4t_protocol::ReplayMeta {
                program,
                robots: names,
                digest_every: crate::REPLAY_DIGEST_EVERY,
                max_ticks,
                labels: config.labels.clone(),
                wall_clock: true,
            };
            Recorder::new(out, &game, meta)
        });
        let start_by = config.start_timeout.map(|t| now + t);
        let mut host = MatchHost {
            config,
            played,
            game,
            conns: BTreeMap::new(),
            players: BTreeMap::new(),
            late: BTreeMap::new(),
            usage: BTreeMap::new(),
            phase: Phase::Waiting { start_by },
            now,
            tick_sent_at: now,
            last_frame: None,
            frame_owed: false,
            frame_messages: Vec::new(),
            end: None,
            sessions: 0,
            outbox: VecDeque::new(),
            news_due: VecDeque::new(),
            recorder,
            abandoned: BTreeSet::new(),
            gone: BTreeMap::new(),
            pauses: 0,
            lobby_changed: false,
            held: false,
            lateness: None,
            deserted_since: None,
        };
        for seat in seats.into_iter().filter(|s| !matches!(s.player, bw4t_agents::Player::Open)) {
            let local = seat.player.agent(&seat.name);
            let id = host.join(Some(&seat.name)).map_err(|(_, message)| HostError::Seat(message))?;
            if let Some(player) = host.players.get_mut(&id) {
                player.reserved = local.is_none();
                player.local = local.map(|agent| Driver::new(id, agent));
            }
        }
        host.start_if_ready(now);
        Ok(host)
    }

    /// Takes in one event at `now`.
    pub fn handle_event(&mut self, now: Instant, event: HostEvent) {
        let event = match event {
            // Only a gauge: it makes nothing due, so nothing is settled for it.
            HostEvent::Room { conn, room } => return self.note_room(conn, room),
            event => event,
        };
        self.settle();
        self.now = self.now.max(now);
        match event {
            HostEvent::Opened { conn, room } => {
                let c = Conn { room, queued: 0, unsent: 0, role: ConnRole::New, lobby: false };
                self.conns.insert(conn, c);
            }
            HostEvent::Room { conn, room } => self.note_room(conn, room),
            HostEvent::Closed { conn } => self.on_closed(conn),
            HostEvent::BadInput { conn } => self.count_error(conn),
            HostEvent::Message { conn, message } => self.on_message(conn, message),
            HostEvent::SeatAbandoned { name } => {
                self.abandoned.insert(name);
            }
        }
        self.start_if_ready(self.now);
        self.send_lobby();
    }

    /// How many lines `conn`'s queue can take now. Lines still in the outbox are not in the
    /// driver's queue yet: they count against the room just reported.
    fn note_room(&mut self, conn: ConnId, room: usize) {
        if let Some(c) = self.conns.get_mut(&conn) {
            c.room = room;
            c.queued = c.unsent;
        }
    }

    /// Does what has fallen due by `now`: the start timeout, expired grace periods, a
    /// lockstep deadline, or one tick. The driver calls it when [`Self::poll_timeout`] is
    /// reached; calling it early does nothing that was not due.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.settle();
        self.now = self.now.max(now);
        let now = self.now;
        if self.end.is_some() {
            return;
        }
        if self.trailing_frame_at().is_some_and(|at| now >= at) {
            self.send_frames(false);
        }
        self.expire_dropped();
        if self.deserted_since.is_some_and(|since| now >= since + self.config.grace) {
            tracing::info!(target: "bw4t::match", r#match = %self.config.name, "every player left: the match ends");
            self.end = Some(EndReason::Abandoned);
            return;
        }
        match self.phase {
            Phase::Waiting { start_by } => {
                if start_by.is_some_and(|t| now >= t) {
                    self.fill_seats();
                    self.start(now);
                }
                self.send_lobby();
            }
            Phase::Playing { .. } if self.held => {}
            Phase::Playing { since, next_tick } => match self.config.mode {
                Mode::Realtime if now >= next_tick => {
                    // Ticks missed while the host was late are skipped, not made up: the
                    // next falls on the old grid, counted, not stepped to (a long stall at
                    // a high rate would be a long loop).
                    let period = self.tick_period().max(Duration::from_nanos(1));
                    let late = now.saturating_duration_since(next_tick);
                    let skipped = u64::try_from(late.as_nanos() / period.as_nanos()).unwrap_or(u64::MAX);
                    // The first grid point after `now`: `next_tick + (skipped + 1) * period`.
                    let into_period = u64::try_from(late.as_nanos() % period.as_nanos()).unwrap_or(0);
                    let next = now - Duration::from_nanos(into_period) + period;
                    self.lateness = Some((late, skipped));
                    self.phase = Phase::Playing { since, next_tick: next };
                    self.advance();
                }
                Mode::Realtime => {}
                Mode::Lockstep if self.awaiting_anyone() => {
                    if self.deadline().is_some_and(|d| now >= d) {
                        self.mark_late();
                    }
                }
                Mode::Lockstep if self.paused() => {}
                Mode::Lockstep => self.advance(),
            },
        }
    }

    /// The next thing to send, if any.
    pub fn poll_transmit(&mut self) -> Option<Transmit> {
        loop {
            if let Some(transmit) = self.outbox.pop_front() {
                if let Transmit::Lines { conn, lines } = &transmit {
                    if let Some(c) = self.conns.get_mut(conn) {
                        c.unsent = c.unsent.saturating_sub(lines.len());
                    }
                }
                return Some(transmit);
            }
            let news = self.news_due.pop_front()?;
            self.tell(news);
        }
    }

    /// Makes what the tick has for the players not yet taken by [`Self::poll_transmit`],
    /// so that what comes next sees every player as told.
    fn settle(&mut self) {
        while let Some(news) = self.news_due.pop_front() {
            self.tell(news);
        }
    }

    /// Tells a player its tick: the replies of the boundary, then its percepts, so what it
    /// is sent at a tick leaves in one batch.
    fn tell(&mut self, news: TickNews) {
        for (conn, reply) in news.replies {
            self.send(conn, &reply);
        }
        self.send_percepts(news.robot, Delivery::Tick);
    }

    /// Whether a dropped player's grace period is over.
    fn any_expired(&self) -> bool {
        self.players.values().any(|p| self.grace_over(p))
    }

    /// Whether `player` dropped and its grace period is over.
    fn grace_over(&self, player: &Player) -> bool {
        let since = |t: Instant| self.now.saturating_duration_since(t);
        player.conn.is_none() && player.dropped_at.is_some_and(|t| since(t) >= self.config.grace)
    }

    /// When [`Self::handle_timeout`] is next due: `None` while only an event can move the
    /// match on. In lockstep with nobody awaited, the next tick is due at once.
    pub fn poll_timeout(&mut self) -> Option<Instant> {
        self.settle();
        if self.end.is_some() {
            return None;
        }
        let expiry = self.players.values().filter_map(|p| p.dropped_at).min().map(|t| t + self.config.grace);
        let deserted = self.deserted_since.map(|since| since + self.config.grace);
        let expiry = [expiry, self.trailing_frame_at(), deserted].into_iter().flatten().min();
        let pacing = match self.phase {
            Phase::Waiting { start_by } => start_by,
            Phase::Playing { .. } if self.held => None,
            Phase::Playing { next_tick, .. } => match self.config.mode {
                Mode::Realtime => Some(next_tick),
                Mode::Lockstep if self.awaiting_anyone() => self.deadline(),
                Mode::Lockstep if self.paused() => None,
                Mode::Lockstep => Some(self.now),
            },
        };
        match (expiry, pacing) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Whether the first tick has been made (the match no longer waits for players).
    pub fn has_started(&self) -> bool {
        matches!(self.phase, Phase::Playing { .. })
    }

    /// Whether the match has ended; [`Self::finish`] then gives its result.
    pub fn is_over(&self) -> bool {
        self.end.is_some()
    }

    /// Ends the match now (the server is stopping).
    pub fn interrupt(&mut self) {
        self.end.get_or_insert(EndReason::Interrupted);
    }

    /// Pauses the match (no ticks until resumed) or resumes it. On resuming, the next tick
    /// (or lockstep deadline) is a full period away, so nobody loses time to the pause.
    pub fn set_paused(&mut self, now: Instant, paused: bool) {
        self.now = self.now.max(now);
        if self.held && !paused {
            if let Phase::Playing { since, .. } = self.phase {
                self.phase = Phase::Playing { since, next_tick: self.now + self.tick_period() };
            }
            self.tick_sent_at = self.now;
        }
        if self.held != paused {
            self.held = paused;
            self.pauses += u32::from(paused);
            self.tell_pause(None);
        }
    }

    /// Tells `only` (else every player and watcher) whether the match is paused.
    pub(crate) fn tell_pause(&mut self, only: Option<ConnId>) {
        let line: Arc<str> =
            encode(&ServerMessage::Pause(bw4t_protocol::Pause { paused: self.held, tick: self.tick() }))
                .into();
        let told: Vec<ConnId> = match only {
            Some(conn) => vec![conn],
            None => self
                .conns
                .iter()
                .filter(|(_, c)| matches!(c.role, ConnRole::Agent(_) | ConnRole::Watcher(_)))
                .map(|(conn, _)| *conn)
                .collect(),
        };
        for conn in told {
            self.send_line(conn, line.clone());
        }
    }

    /// How late the last realtime tick was made after it fell due, and how many ticks
    /// were skipped because the host was later than a whole period; once per tick.
    pub fn take_lateness(&mut self) -> Option<(Duration, u64)> {
        self.lateness.take()
    }

    /// The current tick.
    pub fn tick(&self) -> u64 {
        self.game.tick()
    }

    /// Where the match is, for listings.
    pub fn status(&self) -> HostStatus {
        let started = matches!(self.phase, Phase::Playing { .. });
        HostStatus {
            started,
            paused: self.held,
            over: self.end.is_some(),
            tick: self.game.tick(),
            players: self.players.values().map(|p| p.name.clone()).collect(),
            awaited: if started { 0 } else { self.awaited() },
            sequence: (self.game.sequence_index() as usize, self.game.sequence().len()),
            connections: self.conns.len(),
        }
    }

    /// How many more players the waiting match needs before it starts.
    fn awaited(&self) -> usize {
        self.played.robots.saturating_sub(self.connected_players() + self.abandoned.len())
    }

    /// Tells every connection who is in the waiting match, if that changed.
    fn send_lobby(&mut self) {
        if !std::mem::take(&mut self.lobby_changed) {
            return;
        }
        let start_in_ms = match self.phase {
            Phase::Waiting { start_by } => {
                start_by.map(|t| t.saturating_duration_since(self.now).as_millis() as u64)
            }
            Phase::Playing { .. } => None,
        };
        let started = matches!(self.phase, Phase::Playing { .. });
        let present = |p: &&Player| p.conn.is_some() || p.local.is_some();
        let lobby = Lobby {
            match_name: Some(self.config.name.clone()),
            template: self.config.template.clone(),
            players: self.players.values().filter(present).map(|p| p.name.clone()).collect(),
            expected: self
                .players
                .values()
                .filter(|p| p.reserved && !p.connected_ever && !self.abandoned.contains(&p.name))
                .map(|p| p.name.clone())
                .collect(),
            awaited: if started { 0 } else { self.awaited() },
            start_in_ms,
            queued: None,
            started,
        };
        let line: Arc<str> = encode(&ServerMessage::Lobby(lobby)).into();
        let greeted: Vec<ConnId> = self
            .conns
            .iter()
            .filter(|(_, c)| c.lobby && c.role != ConnRole::New)
            .map(|(id, _)| *id)
            .collect();
        for conn in greeted {
            self.send_line(conn, line.clone());
        }
    }

    /// At the start timeout: built-in agents take the seats no player came for, if the
    /// match says so.
    fn fill_seats(&mut self) {
        let Some(strategy) = self.config.fill else { return };
        while self.players.len() < self.played.robots {
            let Some(name) =
                (1..).map(|i| format!("Bot{i}")).take(1000).find(|n| self.game.check_name(n).is_ok())
            else {
                return;
            };
            let Ok(id) = self.join(Some(&name)) else { return };
            if let Some(player) = self.players.get_mut(&id) {
                player.local = Some(Driver::new(id, strategy.agent(&name)));
            }
        }
    }

    /// Ends the match at `now` (if it has not ended), records the end, queues `match_end`
    /// and `bye` for every client and closes every connection; returns the result.
    pub fn finish(&mut self, now: Instant) -> MatchResult {
        self.settle();
        self.now = self.now.max(now);
        let reason = *self.end.get_or_insert(EndReason::Interrupted);
        // `wall_ms` counts from the first tick: waiting for players is not playing.
        let wall_ms = match self.phase {
            Phase::Playing { since, .. } => self.now.saturating_duration_since(since).as_millis() as u64,
            Phase::Waiting { .. } => 0,
        };
        let tick = self.game.tick();
        let extra = |id: RobotId| {
            let figures = match self.players.get(&id) {
                Some(p) => GoneFigures {
                    errors: p.errors,
                    connected: p.connected_ever || p.local.is_some(),
                    absences: p.absences,
                },
                None => self.gone.get(&id).copied().unwrap_or_default(),
            };
            let absences = figures.absences.as_of(tick);
            RobotExtra {
                late_ticks: self.late.get(&id).copied().unwrap_or(0),
                errors: figures.errors,
                connected: figures.connected,
                usage: self.usage.get(&id).copied(),
                disconnections: absences.drops,
                absent_ticks: absences.ticks,
            }
        };
        let mut result = MatchResult::of(&self.game, Some(self.config.mode), reason, wall_ms, extra);
        result.pauses = self.pauses;
        if let Some(recorder) = self.recorder.take() {
            // A replay that cannot be written must not cost the match its result.
            let _ = recorder.finish(&self.game, reason);
        }
        let end = encode(&ServerMessage::MatchEnd(MatchEnd { reason, result: result.clone() }));
        let end: Arc<str> = end.into();
        let conns: Vec<ConnId> = self.conns.keys().copied().collect();
        for conn in conns {
            if matches!(
                self.conns.get(&conn).map(|c| c.role),
                Some(ConnRole::Agent(_) | ConnRole::Watcher(_))
            ) {
                self.send_line(conn, end.clone());
            }
            self.disconnect(conn, Leaving::MatchOver.into());
        }
        result
    }

    fn tick_period(&self) -> Duration {
        Duration::from_secs_f64(1.0 / f64::from(self.played.tick_hz))
    }

    /// The lockstep deadline of the current tick.
    fn deadline(&self) -> Option<Instant> {
        self.config.deadline.map(|d| self.tick_sent_at + d)
    }

    fn awaiting_anyone(&self) -> bool {
        self.players.values().any(|p| p.awaiting)
    }

    /// Lockstep with no player connected: there is no one to play for, so wait.
    fn paused(&self) -> bool {
        self.config.pause_when_empty && self.connected_players() == 0
    }

    fn connected_players(&self) -> usize {
        self.players.values().filter(|p| p.conn.is_some() || p.local.is_some()).count()
    }

    fn start_if_ready(&mut self, now: Instant) {
        if self.end.is_none() && matches!(self.phase, Phase::Waiting { .. }) && self.awaited() == 0 {
            self.start(now);
        }
    }

    /// The first tick is due: in-process agents decide on what they were told at joining.
    fn start(&mut self, now: Instant) {
        // Connections that saw the lobby learn that it is over.
        self.lobby_changed = true;
        self.observe_locals();
        self.tick_sent_at = now;
        self.phase = Phase::Playing { since: now, next_tick: now + self.tick_period() };
        self.note_presence();
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
            self.error(conn, ErrorCode::Unresponsive, "no ready for too many ticks in a row", true);
        }
    }

    /// One tick boundary ([`Match::boundary`]): every player's buffered actions applied in
    /// robot-id order, a step, then everyone told what concerns them.
    fn advance(&mut self) {
        let mut seats = HostSeats {
            tick: self.game.tick(),
            players: &mut self.players,
            frame_messages: &mut self.frame_messages,
            replies: BTreeMap::new(),
            told: BTreeSet::new(),
        };
        let tick = self.game.boundary(&mut seats, &mut self.recorder);
        let HostSeats { mut replies, told, .. } = seats;
        // A new tick: players are awaited again only if they are sent something now. One
        // acked at this boundary, or whose order ended, always gets this tick's `percepts`,
        // so its next actions land at a boundary its own script decides.
        for (id, player) in &mut self.players {
            player.awaiting = told.contains(id) && player.conn.is_some();
        }
        self.tick_sent_at = self.now;
        // Each player's replies and percepts are made as the driver takes them
        // (`poll_transmit`), so the first player's are on their way while the others' are
        // still being made. Replies come from players, so every one has a place here.
        self.news_due = self
            .players
            .keys()
            .map(|&robot| TickNews { robot, replies: replies.remove(&robot).unwrap_or_default() })
            .collect();
        self.observe_locals();
        self.send_frames(false);
        if self.any_expired() {
            // A leave changes what the others perceive: this tick's percepts come first.
            self.settle();
            self.expire_dropped();
        }
        if self.game.is_complete() {
            self.end = Some(EndReason::Completed);
        } else if self.played.max_ticks.is_some_and(|max| tick >= max) {
            self.end = Some(EndReason::MaxTicks);
        }
    }

    /// Sends a player what it has not been told. Returns whether anything was sent.
    fn send_percepts(&mut self, id: RobotId, what: Delivery) -> bool {
        let now = self.now;
        let Some(player) = self.players.get_mut(&id) else { return false };
        let Some(conn_id) = player.conn else { return false };
        let Some(conn) = self.conns.get(&conn_id) else { return false };
        if conn.free() < RESERVE {
            // Not reading: hold percepts back; the next ones sent will be a full snapshot.
            // Nothing sent, nothing to answer: lockstep does not wait for it.
            player.needs_snapshot = true;
            player.awaiting = false;
            let since = *player.full_since.get_or_insert(now);
            if now.saturating_duration_since(since) > self.config.slow_limit {
                self.error(conn_id, ErrorCode::TooSlow, "the client did not read its messages", true);
            }
            return false;
        }
        player.full_since = None;
        let full = what == Delivery::Snapshot || std::mem::take(&mut player.needs_snapshot);
        let delta = if full { self.game.snapshot(id) } else { self.game.poll_percepts(id) };
        let Some(delta) = delta else { return false };
        // A tick's messages to a player always end with its `percepts`, even an empty one
        // after a `result`, so a player knows when it has heard everything for the tick.
        if delta.is_empty() && !player.every_tick && !player.awaiting {
            return false;
        }
        player.awaiting = true;
        // Fed exactly what the player is sent, so the words say what the player was told.
        let words = player.knowledge.as_mut().map(|knowledge| {
            knowledge.apply(delta.tick, &delta);
            knowledge.describe()
        });
        let message = ServerMessage::Percepts(Percepts {
            tick: delta.tick,
            add: delta.add.iter().map(percept_to_fact).collect(),
            not: delta.not.iter().map(percept_to_fact).collect(),
            full: delta.full,
            words,
        });
        self.send(conn_id, &message);
        true
    }

    /// The shortest time between two frames.
    fn frame_interval(&self) -> Duration {
        Duration::from_secs_f64(1.0 / f64::from(self.config.spectator_hz.max(1)))
    }

    /// When the frame held back by the rate limit is due, if one is.
    fn trailing_frame_at(&self) -> Option<Instant> {
        let last = self.last_frame.filter(|_| self.frame_owed)?;
        Some(last + self.frame_interval())
    }

    /// Sends watchers a frame, at most `spectator_hz` a second unless `force`d.
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
        let interval = self.frame_interval();
        // Ticks come with some jitter: allow a frame a little early rather than skip one.
        let recent =
            self.last_frame.is_some_and(|t| self.now.saturating_duration_since(t) < interval.mul_f64(0.8));
        if !force && recent {
            self.frame_owed = true;
            return;
        }
        self.frame_owed = false;
        self.last_frame = Some(self.now);
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
                if c.free() > RESERVE {
                    self.send_line(conn, line.clone());
                }
            }
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
        if let ConnRole::Agent(id) = closed.role {
            if let Some(player) = self.players.get_mut(&id) {
                if player.conn == Some(conn) {
                    tracing::info!(target: "bw4t::match", r#match = %self.config.name, player = %player.name, robot = id.0, conn, "player dropped");
                    self.lobby_changed |= matches!(self.phase, Phase::Waiting { .. });
                    // The robot stands still (holding what it holds) until its player returns.
                    player.conn = None;
                    player.dropped_at = Some(self.now);
                    if matches!(self.phase, Phase::Playing { .. }) {
                        player.absences.dropped(self.game.tick());
                    }
                    player.awaiting = false;
                    player.orders.clear();
                    player.pending = vec![Pending::Stop];
                    // Before the start a seat held for a player who left would keep
                    // everyone else out for its grace period: it is free again at once
                    // (a reserved seat stays its named player's).
                    if matches!(self.phase, Phase::Waiting { .. }) && !player.reserved {
                        self.remove_player(id);
                    }
                    self.note_presence();
                }
            }
        }
    }

    /// Notes whether a started match with seats for remote players has any of them
    /// connected; one with none since `deserted_since` ends a grace period later. Called
    /// when a player comes or goes and at the start, never per tick.
    fn note_presence(&mut self) {
        let started = matches!(self.phase, Phase::Playing { .. });
        let present = self.players.values().any(|p| p.local.is_none() && p.conn.is_some());
        if !started || !self.played.remote_seats || !self.config.pause_when_empty || present {
            self.deserted_since = None;
        } else {
            self.deserted_since.get_or_insert(self.now);
        }
    }

    fn on_message(&mut self, conn: ConnId, message: ClientMessage) {
        let Some(role) = self.conns.get(&conn).map(|c| c.role) else { return };
        let robot = match (role, &message) {
            (_, ClientMessage::Hello(hello)) => return self.on_hello(conn, role, hello),
            (ConnRole::Agent(id), _) => id,
            (ConnRole::Watcher(_) | ConnRole::New, ClientMessage::Bye(_)) => {
                return self.disconnect(conn, Leaving::Goodbye.into());
            }
            (ConnRole::Watcher(_), _) => {
                return self.error(conn, ErrorCode::NotAPlayer, "spectators cannot act", false);
            }
            (ConnRole::New, _) => return self.error(conn, ErrorCode::NoHello, "say hello first", false),
        };
        match message {
            ClientMessage::Act(act) => match action_from_act(&act.action, &act.args) {
                Ok(action) => self.queue_allowed(conn, robot, Some(act.id), action),
                Err(e) => self.reject(conn, Some(act.id), e.code, &e.message),
            },
            ClientMessage::Say(say) => {
                match bw4t_protocol::message_text(say.text.as_deref(), say.said.as_ref()) {
                    Ok(text) => {
                        let action = Action::SendMessage { to: bw4t_protocol::receiver(&say.to), text };
                        self.queue_allowed(conn, robot, say.id, action);
                    }
                    Err(e) => self.reject(conn, say.id, e.code, &e.message),
                }
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
                    self.error(conn, ErrorCode::LateReady, &message, false);
                } else {
                    let message = format!("tick {} has not happened; the match is at tick {now}", ready.tick);
                    self.error(conn, ErrorCode::BadTick, &message, false);
                }
            }
            ClientMessage::Resync(_) => {
                let tick = self.game.tick();
                let Some(player) = self.players.get_mut(&robot) else { return };
                if player.resynced_at == Some(tick) {
                    let message = format!("at most one resync a tick; tick {tick} has had its snapshot");
                    return self.error(conn, ErrorCode::RateLimited, &message, false);
                }
                player.resynced_at = Some(tick);
                self.send_percepts(robot, Delivery::Snapshot);
            }
            ClientMessage::Bye(_) => {
                self.remove_player(robot);
                self.disconnect(conn, Leaving::Goodbye.into());
            }
            ClientMessage::Report(usage) => {
                self.usage.insert(robot, usage);
            }
            ClientMessage::Hello(_) | ClientMessage::Ping(_) => {}
        }
    }

    /// Queues an action of a remote player, unless it is a message the match's policy
    /// refuses.
    fn queue_allowed(&mut self, conn: ConnId, robot: RobotId, id: Option<ActId>, action: Action) {
        let policy = &self.config.language;
        if let (Action::SendMessage { text, .. }, true) = (&action, policy.restricts()) {
            if let Some(why) = policy.refuses(bw4t_protocol::Said::from_text(text).as_ref()) {
                return self.reject(conn, id, AckCode::NotAllowed, &why);
            }
        }
        self.queue_action(conn, robot, id, action);
    }

    fn queue_action(&mut self, conn: ConnId, robot: RobotId, id: Option<ActId>, action: Action) {
        let limit = self.config.max_actions_per_tick;
        let Some(player) = self.players.get_mut(&robot) else { return };
        if player.actions_this_tick >= limit {
            let reason = format!("at most {limit} actions and messages per tick");
            return self.reject(conn, id, AckCode::RateLimited, &reason);
        }
        player.actions_this_tick += 1;
        player.pending.push(Pending::Act(id, action));
    }

    fn reject(&mut self, conn: ConnId, id: Option<ActId>, code: AckCode, reason: &str) {
        let tick = self.game.tick();
        let ack = Ack { id, ok: false, tick, code: Some(code), reason: Some(reason.into()) };
        self.send(conn, &ServerMessage::Ack(ack));
    }

    /// Takes a player's robot out of the match, keeping its figures for the result.
    fn remove_player(&mut self, id: RobotId) {
        self.lobby_changed |= matches!(self.phase, Phase::Waiting { .. });
        if let Some(player) = self.players.remove(&id) {
            tracing::info!(target: "bw4t::match", r#match = %self.config.name, player = %player.name, robot = id.0, "player left");
            let absences = player.absences.as_of(self.game.tick());
            let figures = GoneFigures { errors: player.errors, connected: player.connected_ever, absences };
            self.gone.insert(id, figures);
        }
        let _ = self.game.leave_logged(id, &mut self.recorder);
        self.note_presence();
    }

    /// Robots whose players stayed away longer than the grace period leave the match.
    fn expire_dropped(&mut self) {
        let expired: Vec<RobotId> =
            self.players.iter().filter(|(_, p)| self.grace_over(p)).map(|(id, _)| *id).collect();
        for id in expired {
            self.remove_player(id);
        }
    }

    fn send(&mut self, conn: ConnId, message: &ServerMessage) {
        self.send_line(conn, encode(message).into());
    }

    fn send_line(&mut self, conn: ConnId, line: Arc<str>) {
        let Some(c) = self.conns.get_mut(&conn) else { return };
        if c.free() == 0 {
            // Even the room kept for replies is used up: the client cannot keep up.
            self.outbox.push_back(Transmit::Kill { conn });
            self.on_closed(conn);
            return;
        }
        c.unsent += 1;
        c.queued += 1;
        // Lines for the connection the last batch is for join it.
        match self.outbox.back_mut() {
            Some(Transmit::Lines { conn: last, lines }) if *last == conn => lines.push(line),
            _ => self.outbox.push_back(Transmit::Lines { conn, lines: vec![line] }),
        }
    }

    /// Sends an `error`; a fatal one is followed by `bye` with its code and the close.
    fn error(&mut self, conn: ConnId, code: ErrorCode, message: &str, fatal: bool) {
        self.send_line(conn, error_line(code, message, fatal));
        if fatal {
            tracing::warn!(target: "bw4t::match", r#match = %self.config.name, conn, %code, message, "connection refused");
            self.disconnect(conn, code.into());
        }
    }

    /// Says `bye` and closes the connection.
    fn disconnect(&mut self, conn: ConnId, reason: ByeReason) {
        self.send_line(conn, bye_line(reason));
        if self.conns.contains_key(&conn) {
            self.outbox.push_back(Transmit::Close { conn });
        }
        self.on_closed(conn);
    }
}
