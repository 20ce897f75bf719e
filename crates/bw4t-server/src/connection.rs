//! Connections: an accept loop, and per client a reader (lines to events) and a writer
//! (queued lines to the socket). Malformed input is answered here and never reaches the match.

use std::io::IoSlice;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use std::future::Future;

use bw4t_protocol::{
    ClientMessage, DecodeError, ErrorCode, Leaving, LineBuffer, Lobby, ServerMessage, encode,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};
use tokio::net::{TcpListener, TcpSocket, TcpStream};
use tokio::sync::{Notify, mpsc, watch};

use bw4t_host::{ConnId, bye_line, error_line, pong_line};

use crate::arena::{Arena, QueueNews, Route, Routed, Waiting};
use crate::budget::{SourceBudget, SourcePlace};
use crate::events::{Event, Opened};
use crate::queue::{LineQueue, QueueReader, line_queue};

/// How many connections the kernel may hold for a listener before they are accepted. The
/// usual default (128) overflows under a burst of page loads, and clients then wait a
/// second or more for their retry; the kernel caps it at `net.core.somaxconn`.
pub const LISTEN_BACKLOG: u32 = 1024;

/// Listens on `addr` with a [`LISTEN_BACKLOG`]-deep queue, for the protocol port and the
/// web port alike. Must be called inside a tokio runtime.
pub fn listen(addr: std::net::SocketAddr) -> std::io::Result<TcpListener> {
    let socket = if addr.is_ipv4() { TcpSocket::new_v4()? } else { TcpSocket::new_v6()? };
    // As `TcpListener::bind` does: a restarted server can take its port back at once.
    #[cfg(unix)]
    socket.set_reuseaddr(true)?;
    socket.bind(addr)?;
    socket.listen(LISTEN_BACKLOG)
}

/// Accepts connections until aborted, refusing those beyond the limit.
pub(crate) async fn accept_loop(listener: TcpListener, arena: Arena) {
    let open = Arc::new(AtomicUsize::new(0));
    let max = arena.config().server.max_connections;
    let sources = SourceBudget::new(arena.config().server.max_per_source);
    loop {
        let Ok((stream, peer)) = listener.accept().await else {
            // Out of file descriptors or a reset before accept: try again shortly.
            tokio::time::sleep(std::time::Duration::from_millis(10)).await;
            continue;
        };
        let _ = stream.set_nodelay(true);
        if open.load(Ordering::SeqCst) >= max {
            let why = format!("the server takes at most {max} connections");
            tokio::spawn(refuse(stream, ErrorCode::ServerFull, why));
            continue;
        }
        let Some(place) = sources.take(peer.ip()) else {
            let why = format!("at most {} connections from one address", sources.limit());
            tokio::spawn(refuse(stream, ErrorCode::SourceFull, why));
            continue;
        };
        open.fetch_add(1, Ordering::SeqCst);
        let conn = arena.next_conn();
        let (arena, open) = (arena.clone(), open.clone());
        tokio::spawn(async move {
            handle(stream, conn, &arena, place).await;
            open.fetch_sub(1, Ordering::SeqCst);
        });
    }
}

/// Says why the connection is not taken (a fatal `error`, no `bye`: it never joined) and
/// closes it.
async fn refuse(mut stream: TcpStream, code: ErrorCode, why: String) {
    let error = error_line(code, &why, true);
    let _ = stream.write_all(error.as_bytes()).await;
    let _ = stream.shutdown().await;
}

/// Where a connection's outgoing lines go: a TCP socket or a WebSocket.
pub(crate) trait LineSink: Send + 'static {
    /// Sends encoded lines, in order, at once (a batch); false when the peer is gone.
    fn send_lines(&mut self, lines: &[Arc<str>]) -> impl Future<Output = bool> + Send;
    /// Ends the connection's sending side.
    fn close(&mut self) -> impl Future<Output = ()> + Send;
}

/// Writes every line of a batch with as few system calls as the socket allows: one
/// vectored write when it takes them all.
async fn write_lines(writer: &mut OwnedWriteHalf, lines: &[Arc<str>]) -> std::io::Result<()> {
    let mut slices: Vec<IoSlice<'_>> = lines.iter().map(|line| IoSlice::new(line.as_bytes())).collect();
    let mut rest = &mut slices[..];
    while !rest.is_empty() {
        let written = writer.write_vectored(rest).await?;
        if written == 0 {
            return Err(std::io::ErrorKind::WriteZero.into());
        }
        IoSlice::advance_slices(&mut rest, written);
    }
    Ok(())
}

/// A connection's outgoing side: its queue, the handles the match task keeps, and the
/// writer task behind them.
struct Outgoing {
    conn: ConnId,
    /// The queue of lines to send.
    pub tx: LineQueue,
    kill: Arc<Notify>,
    /// Becomes true when the writer has finished; the reader stops then.
    pub done: watch::Receiver<bool>,
    task: tokio::task::JoinHandle<()>,
}

impl Outgoing {
    /// The handles the match task gets in [`Event::Opened`].
    pub(crate) fn opened(&self) -> Opened {
        Opened { conn: self.conn, tx: self.tx.clone(), kill: self.kill.clone(), done: self.done.clone() }
    }
}

/// Starts the writer: queued lines go to `sink` until the queue is closed, a kill or a
/// dead peer.
fn start_writer(conn: ConnId, queue: usize, sink: impl LineSink) -> Outgoing {
    let (tx, queued) = line_queue(queue);
    let kill = Arc::new(Notify::new());
    let (done_tx, done) = watch::channel(false);
    let writer_kill = kill.clone();
    let task = tokio::spawn(async move {
        write_queued(queued, sink, &writer_kill).await;
        let _ = done_tx.send(true);
    });
    Outgoing { conn, tx, kill, done, task }
}

/// The writer: each wake-up takes every line queued and sends it as one batch, until the
/// queue is closed and empty, `kill` is notified (also while a write is under way: a client
/// that does not read cannot hold its writer) or the peer is gone; then closes the sink.
async fn write_queued(mut queued: QueueReader, mut sink: impl LineSink, kill: &Notify) {
    let mut batch = Vec::new();
    loop {
        let more = tokio::select! {
            more = queued.next_batch(&mut batch) => more,
            () = kill.notified() => false,
        };
        if !more {
            break;
        }
        let sent = tokio::select! {
            sent = sink.send_lines(&batch) => sent,
            () = kill.notified() => false,
        };
        batch.clear();
        queued.written();
        if !sent {
            break;
        }
    }
    sink.close().await;
}

/// What became of incoming lines.
enum Forwarded {
    /// Answered here or passed on.
    Handled,
    /// The match task is gone.
    Stop,
}

/// The most messages one event carries. An event holds what one read brought (at most
/// the read buffer and one line carried over), so the event channel bounds memory about
/// as it did with a message an event; this bounds the messages' own overhead.
const MESSAGES_PER_EVENT: usize = 64;

/// Handles the lines of one read: bad input and `ping` are answered here (best effort: a
/// client that sends garbage and does not read loses only its own replies), the other
/// messages go to the match task together, so it wakes once for them.
async fn forward(
    conn: ConnId,
    lines: Vec<Result<String, DecodeError>>,
    tx: &LineQueue,
    events: &mpsc::Sender<Event>,
) -> Forwarded {
    let mut messages = Vec::new();
    for line in lines {
        match line.and_then(|l| bw4t_protocol::decode_client(&l)) {
            Err(e) => {
                tx.send(error_line(e.code, &e.message, false));
                let _ = events.try_send(Event::BadInput { conn });
            }
            Ok(ClientMessage::Ping(ping)) => {
                tx.send(pong_line(ping.id));
            }
            Ok(message) => {
                messages.push(message);
                if messages.len() == MESSAGES_PER_EVENT {
                    let messages = std::mem::take(&mut messages);
                    if events.send(Event::Messages { conn, messages }).await.is_err() {
                        return Forwarded::Stop;
                    }
                }
            }
        }
    }
    if !messages.is_empty() && events.send(Event::Messages { conn, messages }).await.is_err() {
        return Forwarded::Stop;
    }
    Forwarded::Handled
}

/// Tells the match task the connection is gone and lets the writer flush.
async fn finish(conn: ConnId, outgoing: Outgoing, events: &mpsc::Sender<Event>) {
    let _ = events.send(Event::Closed { conn }).await;
    outgoing.tx.close();
    drop(outgoing.tx);
    let _ = outgoing.task.await;
}

/// Where a connection's incoming lines come from: a TCP socket or a WebSocket.
pub(crate) trait LineSource: Send {
    /// What arrived next. Must be cancel-safe: it is raced against the hello deadline.
    fn next(&mut self) -> impl Future<Output = Incoming> + Send;
}

/// A source lent to a connection, so that its owner decides when it is dropped.
impl<S: LineSource> LineSource for &mut S {
    fn next(&mut self) -> impl Future<Output = Incoming> + Send {
        (**self).next()
    }
}

/// What a [`LineSource`] read.
pub(crate) enum Incoming {
    /// Complete lines (possibly none yet), or errors for lines that are not usable.
    Lines(Vec<Result<String, DecodeError>>),
    /// Input the connection cannot recover from: sent as a fatal `error` and `bye`, then
    /// the connection is closed.
    Fatal(DecodeError),
    /// The peer is gone.
    Closed,
}

/// A TCP socket's reading half, split into lines.
struct TcpLines {
    reader: OwnedReadHalf,
    lines: LineBuffer,
    buf: Vec<u8>,
}

impl LineSource for TcpLines {
    async fn next(&mut self) -> Incoming {
        match self.reader.read(&mut self.buf).await {
            Ok(0) | Err(_) => Incoming::Closed,
            Ok(n) => Incoming::Lines(self.lines.push(&self.buf[..n])),
        }
    }
}

async fn handle(stream: TcpStream, conn: ConnId, arena: &Arena, place: SourcePlace) {
    let (reader, writer) = stream.into_split();
    let source = TcpLines { reader, lines: LineBuffer::new(), buf: vec![0u8; 16 * 1024] };
    run(conn, source, PlacedWriter { place: Some(place), writer }, arena).await;
}

/// A TCP connection's sending half and its address's place, given back before the
/// connection is closed, so a client that sees the close can come back at once.
struct PlacedWriter {
    /// Declared first: dropped before the socket's half.
    place: Option<SourcePlace>,
    writer: OwnedWriteHalf,
}

impl LineSink for PlacedWriter {
    async fn send_lines(&mut self, lines: &[Arc<str>]) -> bool {
        write_lines(&mut self.writer, lines).await.is_ok()
    }

    async fn close(&mut self) {
        self.place.take();
        let _ = self.writer.shutdown().await;
    }
}

/// A `hello` routed to a match, and the lines that came after it in the same read.
struct Joined {
    route: Route,
    hello: ClientMessage,
    rest: Vec<Result<String, DecodeError>>,
}

/// Runs one connection, whatever carries it: until `hello`, lines are answered here
/// (`ping`, bad input, `no_hello`); the `hello` is routed to a match ([`Arena::route`]),
/// possibly after waiting in a template's queue; from then on lines go to that match's
/// task (bad input and `ping` are still answered here), and queued lines go to `sink`. A
/// connection that has not said `hello` within the server's `hello_timeout` gets `error`
/// and `bye` `hello_timeout` and is closed.
pub(crate) async fn run(conn: ConnId, mut source: impl LineSource, sink: impl LineSink, arena: &Arena) {
    // The writer ends on `Close`, a kill or a dead socket; the reader then stops too.
    let outgoing = start_writer(conn, arena.config().server.queue, sink);
    let (tx, mut done) = (outgoing.tx.clone(), outgoing.done.clone());
    // `None`: the connection is over (it left, said `bye`, was refused or timed out).
    let Some(Joined { route, hello, rest }) = greet(&mut source, &tx, &mut done, arena).await else {
        drop(tx);
        outgoing.tx.close();
        drop(outgoing.tx);
        let _ = outgoing.task.await;
        return;
    };
    // Held while the connection is open: its seat in a waiting match.
    let _claim = route.claim;
    let events = route.events;
    if events.send(Event::Opened(outgoing.opened())).await.is_err()
        || events.send(Event::Messages { conn, messages: vec![hello] }).await.is_err()
    {
        // The match ended as this connection was routed to it.
        tx.send(bye_line(Leaving::MatchOver));
        drop(tx);
        outgoing.tx.close();
        drop(outgoing.tx);
        let _ = outgoing.task.await;
        return;
    }
    let mut stopped = matches!(forward(conn, rest, &tx, &events).await, Forwarded::Stop);
    while !stopped {
        let incoming = tokio::select! {
            incoming = source.next() => incoming,
            _ = done.wait_for(|d| *d) => break,
        };
        let lines = match incoming {
            Incoming::Lines(lines) => lines,
            Incoming::Fatal(error) => {
                refuse_fatally(&tx, error.code, &error.message);
                break;
            }
            Incoming::Closed => break,
        };
        stopped = matches!(forward(conn, lines, &tx, &events).await, Forwarded::Stop);
    }
    drop(tx);
    finish(conn, outgoing, &events).await;
}

/// Reads until a `hello` is routed to a match.
async fn greet(
    source: &mut impl LineSource,
    tx: &LineQueue,
    done: &mut watch::Receiver<bool>,
    arena: &Arena,
) -> Option<Joined> {
    let hello_deadline = tokio::time::Instant::now() + arena.config().server.hello_timeout;
    loop {
        let incoming = tokio::select! {
            incoming = source.next() => incoming,
            _ = done.wait_for(|d| *d) => return None,
            () = tokio::time::sleep_until(hello_deadline) => {
                refuse_fatally(tx, ErrorCode::HelloTimeout, "no hello in time");
                return None;
            }
        };
        let mut lines = match incoming {
            Incoming::Lines(lines) => lines.into_iter(),
            Incoming::Fatal(error) => {
                refuse_fatally(tx, error.code, &error.message);
                return None;
            }
            Incoming::Closed => return None,
        };
        while let Some(line) = lines.next() {
            let message = match line.and_then(|l| bw4t_protocol::decode_client(&l)) {
                Err(e) => {
                    tx.send(error_line(e.code, &e.message, false));
                    continue;
                }
                Ok(message) => message,
            };
            let hello = match message {
                ClientMessage::Hello(hello) => hello,
                ClientMessage::Ping(ping) => {
                    tx.send(pong_line(ping.id));
                    continue;
                }
                ClientMessage::Bye(_) => {
                    tx.send(bye_line(Leaving::Goodbye));
                    return None;
                }
                _ => {
                    tx.send(error_line(ErrorCode::NoHello, "say hello first", false));
                    continue;
                }
            };
            let route = match arena.route(&hello).await {
                Err((code, message)) => {
                    refuse_fatally(tx, code, &message);
                    return None;
                }
                Ok(Routed::Match(route)) => route,
                Ok(Routed::Queued(news, place)) => {
                    let template = hello.template.clone().unwrap_or_default();
                    match wait_in_queue(source, tx, done, news, place, &template).await {
                        Some(route) => route,
                        None => return None,
                    }
                }
            };
            return Some(Joined { route, hello: ClientMessage::Hello(hello), rest: lines.collect() });
        }
    }
}

/// Waits in a template's queue for a seat, telling the player its place; `None` if the
/// player leaves (or the server stops) first. Only `ping` and `bye` are taken meanwhile.
async fn wait_in_queue(
    source: &mut impl LineSource,
    tx: &LineQueue,
    done: &mut watch::Receiver<bool>,
    mut news: Waiting,
    mut place: usize,
    template: &str,
) -> Option<Route> {
    loop {
        let lobby = Lobby { template: Some(template.to_string()), queued: Some(place), ..Lobby::default() };
        tx.send(encode(&ServerMessage::Lobby(lobby)).into());
        loop {
            tokio::select! {
                heard = news.recv() => match heard {
                    Some(QueueNews::Seat(route)) => return Some(route),
                    Some(QueueNews::Place(now)) if now != place => {
                        place = now;
                        break;
                    }
                    Some(QueueNews::Place(_)) => {}
                    None => {
                        refuse_fatally(tx, ErrorCode::ServerStopping, "the server is stopping");
                        return None;
                    }
                },
                incoming = source.next() => match incoming {
                    Incoming::Lines(lines) => {
                        for line in lines {
                            match line.and_then(|l| bw4t_protocol::decode_client(&l)) {
                                Ok(ClientMessage::Ping(ping)) => {
                                    tx.send(pong_line(ping.id));
                                }
                                Ok(ClientMessage::Bye(_)) => {
                                    tx.send(bye_line(Leaving::Goodbye));
                                    return None;
                                }
                                Ok(_) => {
                                    let why = "waiting for a seat in a match: only ping and bye until welcome";
                                    tx.send(error_line(ErrorCode::NotAPlayer, why, false));
                                }
                                Err(e) => {
                                    tx.send(error_line(e.code, &e.message, false));
                                }
                            }
                        }
                    }
                    Incoming::Fatal(error) => {
                        refuse_fatally(tx, error.code, &error.message);
                        return None;
                    }
                    Incoming::Closed => return None,
                },
                _ = done.wait_for(|d| *d) => return None,
            }
        }
    }
}

/// Queues a fatal `error` and its `bye` (best effort: the connection closes next anyway).
fn refuse_fatally(tx: &LineQueue, code: ErrorCode, message: &str) {
    tx.send_all(vec![error_line(code, message, true), bye_line(code)]);
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use super::*;

    /// A sink that records each batch it is handed, or never finishes a write.
    #[derive(Clone, Default)]
    struct RecordingSink {
        batches: Arc<Mutex<Vec<Vec<String>>>>,
        stalls: bool,
    }

    impl LineSink for RecordingSink {
        async fn send_lines(&mut self, lines: &[Arc<str>]) -> bool {
            if self.stalls {
                std::future::pending::<()>().await;
            }
            let batch = lines.iter().map(|l| l.to_string()).collect();
            self.batches.lock().expect("lock").push(batch);
            true
        }

        async fn close(&mut self) {}
    }

    #[tokio::test]
    async fn lines_queued_together_wake_the_writer_once_and_leave_in_one_write() {
        let sink = RecordingSink::default();
        let outgoing = start_writer(1, 16, sink.clone());
        // The writer has not run yet (one thread, no await since it was spawned): the
        // tick's lines and then the close are all queued when it first looks.
        outgoing.tx.send_all(vec!["ack\n".into(), "ack\n".into(), "percepts\n".into()]);
        assert!(outgoing.tx.close());
        outgoing.task.await.expect("the writer ends");
        let batches = sink.batches.lock().expect("lock").clone();
        assert_eq!(batches, [["ack\n", "ack\n", "percepts\n"]]);
        assert!(*outgoing.done.borrow());
    }

    #[tokio::test]
    async fn what_one_read_brought_reaches_the_match_as_one_event_in_bounded_pieces() {
        let (events, mut received) = mpsc::channel(16);
        let (queue, _reader) = line_queue(16);
        let ready = r#"{"type": "ready", "tick": 0}"#;
        let mut lines = vec![Ok(r#"{"type": "ping", "id": 1}"#.to_string()), Ok("nonsense".to_string())];
        lines.extend(std::iter::repeat_n(Ok(ready.to_string()), MESSAGES_PER_EVENT + 1));
        assert!(matches!(forward(7, lines, &queue, &events).await, Forwarded::Handled));
        // Ping and bad input are answered here: a pong and an error for the client.
        assert_eq!(queue.room(), 14);
        let mut sizes = Vec::new();
        while let Ok(event) = received.try_recv() {
            match event {
                Event::Messages { conn: 7, messages } => sizes.push(messages.len()),
                Event::BadInput { conn: 7 } => sizes.push(0),
                other => panic!("an unexpected event: {other:?}"),
            }
        }
        assert_eq!(sizes, [0, MESSAGES_PER_EVENT, 1]);
    }

    #[tokio::test]
    async fn a_kill_ends_the_writer_even_in_the_middle_of_a_write() {
        let sink = RecordingSink { stalls: true, ..RecordingSink::default() };
        let outgoing = start_writer(1, 16, sink);
        outgoing.tx.send("percepts\n".into());
        let mut done = outgoing.done.clone();
        // Let the writer take the line and start its write, which never finishes.
        tokio::task::yield_now().await;
        assert_eq!(outgoing.tx.room(), 15, "the line being written still counts");
        outgoing.kill.notify_one();
        // A bound for the failure only: a writer that waits for its write never ends.
        let ended = tokio::time::timeout(std::time::Duration::from_secs(10), done.wait_for(|d| *d)).await;
        assert!(ended.is_ok(), "the killed writer is still writing");
    }
}
