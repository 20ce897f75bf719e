//! The benchmarks' client: a TCP player that keeps its robot moving to random rooms (and,
//! as a study's participant, talks), counting what it does and how fast actions are acked.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use bw4t_map::SeededRng;
use bw4t_protocol::{ClientSession, ErrorCode, Outcome, SessionEvent};
use bw4t_sim::Action;
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader, Lines};
use tokio::net::TcpStream;
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};

/// What the players did, counted across all of them.
#[derive(Default)]
pub(super) struct PlayCounts {
    pub(super) orders: AtomicU64,
    pub(super) percepts: AtomicU64,
    pub(super) messages: AtomicU64,
    /// How often each player sends a message, if it talks.
    pub(super) talk_every: Option<Duration>,
    /// Times from sending an action to its ack.
    pub(super) latencies: Mutex<Vec<Duration>>,
}

/// A bench client's connection: it orders its robot to a random room whenever it is
/// welcomed and whenever its last order ends (arrived or collided) or is refused.
pub(super) struct Player {
    session: ClientSession,
    lines: Lines<BufReader<OwnedReadHalf>>,
    writer: OwnedWriteHalf,
    rooms: Arc<[String]>,
    rng: SeededRng,
    counts: Arc<PlayCounts>,
    /// When each action still awaiting its ack was sent.
    sent: std::collections::HashMap<u64, Instant>,
    /// When the player sends its next message, if it talks.
    next_talk: Option<tokio::time::Instant>,
}

/// What a player heard, as far as the benchmark cares.
pub(super) enum Heard {
    /// Welcomed into a match.
    Welcome,
    /// Waiting in a template's queue.
    Queued,
    /// The match started (the last `lobby`).
    Started,
    /// Anything else while the match goes on.
    Playing,
    /// The match ended, or the server said `bye` or closed the connection.
    Ended,
    /// A fatal `error`.
    Refused(ErrorCode, String),
}

impl Player {
    /// Connects and says the session's `hello`.
    pub(super) async fn connect(
        addr: SocketAddr,
        session: ClientSession,
        rooms: Arc<[String]>,
        seed: u64,
        counts: Arc<PlayCounts>,
    ) -> Result<Player> {
        let stream = TcpStream::connect(addr).await.with_context(|| format!("cannot connect to {addr}"))?;
        stream.set_nodelay(true)?;
        let (reader, writer) = stream.into_split();
        let mut player = Player {
            session,
            lines: BufReader::new(reader).lines(),
            writer,
            rooms,
            rng: SeededRng::new(seed),
            counts,
            sent: std::collections::HashMap::new(),
            next_talk: None,
        };
        player.flush().await?;
        player.plan_talk();
        Ok(player)
    }

    /// Reads one line and plays on it.
    pub(super) async fn next(&mut self) -> Result<Heard> {
        let line = match self.next_talk {
            // A person's input comes at any moment, not in step with the ticks.
            Some(at) => tokio::select! {
                line = self.lines.next_line() => line?,
                () = tokio::time::sleep_until(at) => {
                    self.talk();
                    self.flush().await?;
                    return Ok(Heard::Playing);
                }
            },
            None => self.lines.next_line().await?,
        };
        let Some(line) = line else { return Ok(Heard::Ended) };
        self.session.handle_line(&line)?;
        let mut heard = Heard::Playing;
        while let Some(event) = self.session.poll_event() {
            heard = match event {
                SessionEvent::Percepts { .. } => {
                    self.counts.percepts.fetch_add(1, Ordering::Relaxed);
                    Heard::Playing
                }
                SessionEvent::Welcome(_) => {
                    self.go();
                    Heard::Welcome
                }
                SessionEvent::Lobby(lobby) if lobby.queued.is_some() => Heard::Queued,
                SessionEvent::Lobby(lobby) if lobby.started => Heard::Started,
                SessionEvent::Ack { ack, request } => {
                    if let Some(sent) = request.and_then(|r| self.sent.remove(&r.id)) {
                        if let Ok(mut latencies) = self.counts.latencies.lock() {
                            latencies.push(sent.elapsed());
                        }
                    }
                    if !ack.ok {
                        self.go();
                    }
                    Heard::Playing
                }
                SessionEvent::Result { result, .. } if result.outcome != Outcome::Superseded => {
                    self.go();
                    Heard::Playing
                }
                SessionEvent::Error(error) if error.fatal => Heard::Refused(error.code, error.message),
                SessionEvent::MatchEnd(_) | SessionEvent::Bye(_) => Heard::Ended,
                _ => Heard::Playing,
            };
        }
        self.flush().await?;
        Ok(heard)
    }

    /// Orders the robot to a random room.
    fn go(&mut self) {
        let room = self.rooms[self.rng.index(self.rooms.len())].clone();
        self.send(&Action::GoTo(room));
        self.counts.orders.fetch_add(1, Ordering::Relaxed);
    }

    /// Tells the team where it is going, as a person would from the page's menu.
    fn talk(&mut self) {
        self.plan_talk();
        let mut said = bw4t_protocol::Said::new("going_to");
        said.room = Some(self.rooms[self.rng.index(self.rooms.len())].clone());
        self.send(&Action::SendMessage { to: bw4t_sim::Receiver::All, text: said.to_text() });
        self.counts.messages.fetch_add(1, Ordering::Relaxed);
    }

    /// Picks when to talk next: `talk_every` on average, at a random moment.
    fn plan_talk(&mut self) {
        self.next_talk = self.counts.talk_every.map(|every| {
            let jitter = every.mul_f64(self.rng.index(1000) as f64 / 1000.0);
            tokio::time::Instant::now() + every / 2 + jitter
        });
    }

    /// Queues an action, noting when, for its ack's latency.
    fn send(&mut self, action: &Action) {
        let id = self.session.act(action);
        self.sent.insert(id, Instant::now());
    }

    /// Writes what the session has to send.
    async fn flush(&mut self) -> Result<()> {
        let out: String = std::iter::from_fn(|| self.session.poll_transmit()).collect();
        if !out.is_empty() {
            self.writer.write_all(out.as_bytes()).await?;
        }
        Ok(())
    }

    /// Closes the connection; the session stays, to come back with.
    pub(super) fn into_session(self) -> ClientSession {
        self.session
    }

    /// Says `bye` (best effort: the connection is dropped next anyway).
    pub(super) async fn bye(&mut self) {
        self.session.bye();
        let _ = self.flush().await;
    }
}
