//! The web side: a small HTTP server for the browser page, the map's layout and replay
//! frames, and a WebSocket bridge that lets the page speak the protocol like a TCP client.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use bw4t_protocol::{DecodeError, Frame};
use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc;
use tokio_tungstenite::tungstenite::Message;

use crate::connection::{ConnId, Event, Forwarded, LineSink, finish, forward, start_writer};

/// The page, built into the binary.
const INDEX_HTML: &str = include_str!("../web/index.html");
const APP_JS: &str = include_str!("../web/app.js");
const STYLE_CSS: &str = include_str!("../web/style.css");

/// The longest request head read, in bytes.
const MAX_HEAD: usize = 16 * 1024;

/// What the web server serves besides the page.
pub struct Site {
    /// `GET /map.json`.
    pub map_json: String,
    /// `GET /info.json`.
    pub info_json: String,
    /// Replay mode: every tick's frame (`GET /replay/frame/T`) and `GET /replay.json`.
    pub replay: Option<(String, Vec<Frame>)>,
}

/// Serves the page on `listener` until aborted, at most `max_connections` at once. With
/// `events`, `/ws` joins the live match.
pub async fn serve_site(
    listener: TcpListener,
    site: Arc<Site>,
    events: Option<mpsc::Sender<Event>>,
    ids: Arc<AtomicU64>,
    queue: usize,
    max_connections: usize,
) {
    let open = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    loop {
        let Ok((stream, _)) = listener.accept().await else {
            tokio::time::sleep(Duration::from_millis(10)).await;
            continue;
        };
        // Beyond the limit a connection is simply closed: page loads retry, sockets reconnect.
        if open.load(Ordering::SeqCst) >= max_connections {
            drop(stream);
            continue;
        }
        let _ = stream.set_nodelay(true);
        open.fetch_add(1, Ordering::SeqCst);
        let (site, events, ids, open) = (site.clone(), events.clone(), ids.clone(), open.clone());
        tokio::spawn(async move {
            handle(stream, site, events, ids, queue).await;
            open.fetch_sub(1, Ordering::SeqCst);
        });
    }
}

async fn handle(
    stream: TcpStream,
    site: Arc<Site>,
    events: Option<mpsc::Sender<Event>>,
    ids: Arc<AtomicU64>,
    queue: usize,
) {
    // Look at the request head without taking it, so a WebSocket handshake can read it too.
    let mut head = vec![0u8; MAX_HEAD];
    let peeked = tokio::time::timeout(Duration::from_secs(10), async {
        loop {
            let n = stream.peek(&mut head).await.ok()?;
            if n == 0 {
                return None;
            }
            if head[..n].windows(4).any(|w| w == b"\r\n\r\n") || n == MAX_HEAD {
                return Some(n);
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    })
    .await;
    let Ok(Some(n)) = peeked else { return };
    let text = String::from_utf8_lossy(&head[..n]).to_string();
    let mut words = text.split_whitespace();
    let (method, path) = (words.next().unwrap_or(""), words.next().unwrap_or("/").to_string());
    let upgrade = text.to_ascii_lowercase().contains("upgrade: websocket");
    if upgrade && path.starts_with("/ws") {
        if let Some(events) = events {
            bridge(stream, events, ids.fetch_add(1, Ordering::SeqCst), queue).await;
        }
        return;
    }
    respond(stream, n, method, &path, &site).await;
}

async fn respond(mut stream: TcpStream, head_len: usize, method: &str, path: &str, site: &Site) {
    // Take the head off the socket (it was only peeked).
    let mut sink = vec![0u8; head_len];
    let _ = stream.read_exact(&mut sink).await;
    let path = path.split('?').next().unwrap_or("/");
    let (status, kind, body): (&str, &str, String) = match (method, path) {
        ("GET", "/" | "/index.html") => ("200 OK", "text/html; charset=utf-8", INDEX_HTML.into()),
        ("GET", "/app.js") => ("200 OK", "text/javascript; charset=utf-8", APP_JS.into()),
        ("GET", "/style.css") => ("200 OK", "text/css; charset=utf-8", STYLE_CSS.into()),
        ("GET", "/map.json") => ("200 OK", "application/json", site.map_json.clone()),
        ("GET", "/info.json") => ("200 OK", "application/json", site.info_json.clone()),
        ("GET", "/replay.json") => match &site.replay {
            Some((info, _)) => ("200 OK", "application/json", info.clone()),
            None => ("404 Not Found", "text/plain", "not a replay\n".into()),
        },
        ("GET", p) if p.starts_with("/replay/frame/") => {
            let tick = p.trim_start_matches("/replay/frame/").parse::<usize>().ok();
            match (&site.replay, tick) {
                (Some((_, frames)), Some(t)) if t < frames.len() => {
                    ("200 OK", "application/json", serde_json::to_string(&frames[t]).unwrap_or_default())
                }
                _ => ("404 Not Found", "text/plain", "no such frame\n".into()),
            }
        }
        ("GET", _) => ("404 Not Found", "text/plain", "not found\n".into()),
        _ => ("405 Method Not Allowed", "text/plain", "only GET\n".into()),
    };
    let response = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n{body}",
        body.len()
    );
    let _ = stream.write_all(response.as_bytes()).await;
    let _ = stream.shutdown().await;
}

/// The sending half of a WebSocket, as a line sink: a line is a text frame.
struct WsSink(futures_util::stream::SplitSink<tokio_tungstenite::WebSocketStream<TcpStream>, Message>);

impl LineSink for WsSink {
    async fn send_line(&mut self, line: Arc<str>) -> bool {
        self.0.send(Message::text(line.trim_end().to_string())).await.is_ok()
    }

    async fn close(&mut self) {
        let _ = self.0.close().await;
    }
}

/// One WebSocket client as one protocol connection: a text frame is a line.
async fn bridge(stream: TcpStream, events: mpsc::Sender<Event>, conn: ConnId, queue: usize) {
    let Ok(ws) = tokio_tungstenite::accept_async(stream).await else { return };
    let (write, mut read) = ws.split();
    let outgoing = start_writer(conn, queue, WsSink(write));
    let (tx, mut done) = (outgoing.tx.clone(), outgoing.done.clone());
    if events.send(Event::Opened(outgoing.opened())).await.is_err() {
        return;
    }
    loop {
        let message = tokio::select! {
            message = read.next() => message,
            _ = done.wait_for(|d| *d) => break,
        };
        let line = match message {
            Some(Ok(Message::Text(text))) if text.len() > bw4t_protocol::MAX_LINE => Err(DecodeError {
                code: "line_too_long",
                message: format!("message longer than {} bytes", bw4t_protocol::MAX_LINE),
            }),
            Some(Ok(Message::Text(text))) => Ok(text.to_string()),
            Some(Ok(Message::Binary(_))) => {
                Err(DecodeError { code: "bad_message", message: "send text frames".into() })
            }
            Some(Ok(Message::Close(_)) | Err(_)) | None => break,
            Some(Ok(_)) => continue,
        };
        if let Forwarded::Stop = forward(conn, line, &tx, &events).await {
            break;
        }
    }
    drop(tx);
    finish(conn, outgoing, &events).await;
}
