//! Connections: an accept loop, and per client a reader (lines to events) and a writer
//! (queued lines to the socket). Malformed input is answered here and never reaches the match.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use bw4t_protocol::{ClientMessage, ErrorMessage, LineBuffer, Pong, ServerBye, ServerMessage, encode};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{Notify, mpsc, watch};

use crate::ServerConfig;

/// Identifies a connection for the match task.
pub type ConnId = u64;

/// What a connection's writer sends.
#[derive(Debug)]
pub enum Outbound {
    /// One encoded line.
    Line(Arc<str>),
    /// Flush and close the connection.
    Close,
}

/// A new connection's handles.
#[derive(Debug)]
pub struct Opened {
    /// Its id.
    pub conn: ConnId,
    /// Its queue of outgoing lines.
    pub tx: mpsc::Sender<Outbound>,
    /// Closes it at once, queued lines or not (for clients that do not read).
    pub kill: Arc<Notify>,
    /// Becomes true when its writer has finished (flushed and closed).
    pub done: watch::Receiver<bool>,
}

/// What connections tell the match task.
#[derive(Debug)]
pub enum Event {
    /// A new connection.
    Opened(Opened),
    /// A well-formed message (other than `ping`, answered by the connection itself).
    Message { conn: ConnId, message: ClientMessage },
    /// The connection sent a line that is not a valid message.
    BadInput { conn: ConnId },
    /// The connection is gone.
    Closed { conn: ConnId },
}

/// Accepts connections until aborted, refusing those beyond the limit.
pub async fn accept_loop(
    listener: TcpListener,
    config: ServerConfig,
    events: mpsc::Sender<Event>,
    ids: Arc<AtomicU64>,
) {
    let open = Arc::new(AtomicUsize::new(0));
    loop {
        let Ok((stream, _)) = listener.accept().await else {
            // Out of file descriptors or a reset before accept: try again shortly.
            tokio::time::sleep(std::time::Duration::from_millis(10)).await;
            continue;
        };
        let _ = stream.set_nodelay(true);
        if open.load(Ordering::SeqCst) >= config.max_connections {
            tokio::spawn(refuse(stream, config.max_connections));
            continue;
        }
        open.fetch_add(1, Ordering::SeqCst);
        let conn = ids.fetch_add(1, Ordering::SeqCst);
        let (events, open, config) = (events.clone(), open.clone(), config.clone());
        tokio::spawn(async move {
            handle(stream, conn, &config, events).await;
            open.fetch_sub(1, Ordering::SeqCst);
        });
    }
}

async fn refuse(mut stream: TcpStream, limit: usize) {
    let error = error_line("server_full", &format!("the server takes at most {limit} connections"), true);
    let _ = stream.write_all(error.as_bytes()).await;
    let _ = stream.shutdown().await;
}

/// An encoded `error` message.
pub fn error_line(code: &str, message: &str, fatal: bool) -> Arc<str> {
    let msg = ServerMessage::Error(ErrorMessage { code: code.into(), message: message.into(), fatal });
    encode(&msg).into()
}

/// An encoded `bye` message.
pub fn bye_line(reason: &str) -> Arc<str> {
    encode(&ServerMessage::Bye(ServerBye { reason: reason.into() })).into()
}

async fn handle(stream: TcpStream, conn: ConnId, config: &ServerConfig, events: mpsc::Sender<Event>) {
    let (mut reader, mut writer) = stream.into_split();
    let (tx, mut rx) = mpsc::channel::<Outbound>(config.queue);
    // The writer ends on `Close`, a kill or a dead socket; the reader then stops too.
    let kill = Arc::new(Notify::new());
    let (done_tx, mut done) = watch::channel(false);
    let writer_kill = kill.clone();
    let writer_task = tokio::spawn(async move {
        loop {
            let out = tokio::select! {
                out = rx.recv() => out,
                () = writer_kill.notified() => None,
            };
            match out {
                Some(Outbound::Line(line)) => {
                    if writer.write_all(line.as_bytes()).await.is_err() {
                        break;
                    }
                }
                Some(Outbound::Close) | None => break,
            }
        }
        let _ = writer.shutdown().await;
        let _ = done_tx.send(true);
    });
    let opened = Opened { conn, tx: tx.clone(), kill, done: done.clone() };
    if events.send(Event::Opened(opened)).await.is_err() {
        return;
    }
    let mut lines = LineBuffer::new();
    let mut buf = vec![0u8; 16 * 1024];
    let mut greeted = false;
    let hello_deadline = tokio::time::Instant::now() + config.hello_timeout;
    'read: loop {
        let read = tokio::select! {
            read = reader.read(&mut buf) => read,
            _ = done.wait_for(|d| *d) => break 'read,
            () = tokio::time::sleep_until(hello_deadline), if !greeted => {
                let _ = tx.try_send(Outbound::Line(error_line("hello_timeout", "no hello in time", true)));
                let _ = tx.try_send(Outbound::Line(bye_line("hello_timeout")));
                break 'read;
            }
        };
        let n = match read {
            Ok(0) | Err(_) => break,
            Ok(n) => n,
        };
        for line in lines.push(&buf[..n]) {
            let message = line.and_then(|l| bw4t_protocol::decode_client(&l));
            match message {
                Err(e) => {
                    // Replies to bad input are best effort: a client that sends garbage
                    // and does not read loses only its own error messages.
                    let _ = tx.try_send(Outbound::Line(error_line(e.code, &e.message, false)));
                    let _ = events.try_send(Event::BadInput { conn });
                }
                Ok(ClientMessage::Ping(ping)) => {
                    let _ = tx
                        .try_send(Outbound::Line(encode(&ServerMessage::Pong(Pong { id: ping.id })).into()));
                }
                Ok(message) => {
                    greeted |= matches!(message, ClientMessage::Hello(_));
                    if events.send(Event::Message { conn, message }).await.is_err() {
                        break 'read;
                    }
                }
            }
        }
    }
    let _ = events.send(Event::Closed { conn }).await;
    let _ = tx.try_send(Outbound::Close);
    drop(tx);
    let _ = writer_task.await;
}
