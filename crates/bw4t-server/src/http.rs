//! The web port: a small HTTP server for the browser page, the map's layout and replay
//! frames. One request per connection; `/ws` is handed to [`crate::websocket`].
//!
//! Plain requests are short, so they are admitted on accept up to their own limit
//! ([`MAX_REQUESTS`]) and never wait behind the long-lived WebSockets, which have theirs
//! (`max_connections`). Beyond a limit the client gets `503` with `Retry-After`.

use std::borrow::Cow;
use std::sync::Arc;
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::Semaphore;
use tokio_tungstenite::tungstenite::http::{self, StatusCode};

use crate::websocket::{self, Live};

const HTML: &str = "text/html; charset=utf-8";
const CSS: &str = "text/css; charset=utf-8";
const JS: &str = "text/javascript; charset=utf-8";
const JSON: &str = "application/json";

/// The page's files, built into the binary: the path each is served at, its content
/// type, its text. The page is ES modules the browser loads itself (`web/app.js` imports
/// the rest); its belief base is the JavaScript client's own files, served under
/// `/client/`, so that the page and the client keep beliefs with one code.
const PAGE_FILES: &[(&str, &str, &str)] = &[
    ("/index.html", HTML, include_str!("../web/index.html")),
    ("/style.css", CSS, include_str!("../web/style.css")),
    ("/app.js", JS, include_str!("../web/app.js")),
    ("/dom.js", JS, include_str!("../web/dom.js")),
    ("/page.js", JS, include_str!("../web/page.js")),
    ("/geometry.js", JS, include_str!("../web/geometry.js")),
    ("/renderer.js", JS, include_str!("../web/renderer.js")),
    ("/panels.js", JS, include_str!("../web/panels.js")),
    ("/connection.js", JS, include_str!("../web/connection.js")),
    ("/waiting.js", JS, include_str!("../web/waiting.js")),
    ("/lobby.js", JS, include_str!("../web/lobby.js")),
    ("/spectator.js", JS, include_str!("../web/spectator.js")),
    ("/player.js", JS, include_str!("../web/player.js")),
    ("/replay.js", JS, include_str!("../web/replay.js")),
    ("/ownview.js", JS, include_str!("../web/ownview.js")),
    ("/language.js", JS, include_str!("../web/language.js")),
    ("/menu.js", JS, include_str!("../web/menu.js")),
    ("/embed.js", JS, include_str!("../web/embed.js")),
    ("/study.html", HTML, include_str!("../web/study.html")),
    ("/study.js", JS, include_str!("../web/study.js")),
    ("/study.css", CSS, include_str!("../web/study.css")),
    ("/dashboard.html", HTML, include_str!("../web/dashboard.html")),
    ("/dashboard.js", JS, include_str!("../web/dashboard.js")),
    // The message language's table, one source for the menu and the sentences.
    ("/language.json", JSON, include_str!("../../../protocol/schema/language.json")),
    ("/client/beliefs.js", JS, include_str!("../../../protocol/clients/js/src/beliefs.js")),
    ("/client/table.js", JS, include_str!("../../../protocol/clients/js/src/table.js")),
    ("/client/core.js", JS, include_str!("../../../protocol/clients/js/src/core.js")),
];

/// Plain requests read or answered at once, by default; more are answered `503` at once.
/// They are short, so this is far above what a page load needs.
pub const MAX_REQUESTS: usize = 1024;

/// The longest request head read, in bytes.
const MAX_HEAD: usize = 16 * 1024;
/// The most header lines in a request head.
const MAX_HEADERS: usize = 64;
/// The time a client has to send its request head (and its body).
pub(crate) const HEAD_TIMEOUT: Duration = Duration::from_secs(10);
/// The time a client has to take its answer.
const WRITE_TIMEOUT: Duration = Duration::from_secs(10);
/// How long, after answering, the rest of a request is read and dropped so that closing
/// the socket does not reset the connection before the client has read the answer.
const LINGER: Duration = Duration::from_secs(1);
/// What a `503` asks the client to wait, in seconds.
const RETRY_AFTER_S: u32 = 1;

/// What the web server serves besides the page.
pub struct Site {
    /// `GET /map.json`.
    pub map_json: String,
    /// `GET /info.json`.
    pub info_json: String,
    /// Replay mode: `GET /replay.json`, every tick's frame (`GET /replay/frame/T`) and
    /// every robot's own view at every tick (`GET /replay/view/R/T`).
    pub replay: Option<(String, FrameSource)>,
}

/// What the replay viewer asks of a replay.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReplayAsk {
    /// The `frame` of a tick.
    Frame(u64),
    /// What one robot perceived at a tick, and the messages it had received by then.
    View {
        /// The robot's id.
        robot: u32,
        /// The tick.
        tick: u64,
    },
}

/// A replay's frames and views as JSON, or `None` when there is none. It may re-simulate,
/// so it runs off the async threads.
pub type FrameSource = Arc<dyn Fn(ReplayAsk) -> Option<String> + Send + Sync>;

/// Serves the page (no match: `/ws` is not found) on `listener` until aborted, with at
/// most `max_requests` requests being read or answered at once.
pub async fn serve_site(listener: TcpListener, site: Arc<Site>, max_requests: usize) {
    serve(listener, site, max_requests, None).await;
}

/// Serves the page, and with `live` the match's WebSockets on `/ws`, until aborted.
pub(crate) async fn serve(
    listener: TcpListener,
    site: Arc<Site>,
    max_requests: usize,
    live: Option<Arc<Live>>,
) {
    let requests = Arc::new(Semaphore::new(max_requests));
    loop {
        let Ok((stream, _)) = listener.accept().await else {
            // Out of file descriptors or a reset before accept: try again shortly.
            tokio::time::sleep(Duration::from_millis(10)).await;
            continue;
        };
        let _ = stream.set_nodelay(true);
        let Ok(permit) = requests.clone().try_acquire_owned() else {
            tokio::spawn(reply_and_close(stream, Reply::busy("too many requests at once")));
            continue;
        };
        let (site, live) = (site.clone(), live.clone());
        tokio::spawn(async move {
            let mut stream = stream;
            let head = match tokio::time::timeout(HEAD_TIMEOUT, read_head(&mut stream)).await {
                Err(_) => Err(Some(Reply::text(StatusCode::REQUEST_TIMEOUT, "no request in time"))),
                Ok(head) => head,
            };
            let head = match head {
                Ok(head) => head,
                Err(Some(reply)) => return reply_and_close(stream, reply).await,
                Err(None) => {
                    // The client left. Its place is free before its socket closes (on
                    // return), so a client that sees the close can be served at once.
                    drop(permit);
                    return;
                }
            };
            if let Some(live) = live.as_ref().filter(|_| head.request.uri().path() == "/ws") {
                match websocket::admit(&head.request, live) {
                    Ok(admitted) => {
                        // From here on it counts as a WebSocket, not as a request.
                        drop(permit);
                        websocket::bridge(stream, head, admitted, live).await;
                    }
                    Err(reply) => reply_and_close(stream, reply).await,
                }
                return;
            }
            let reply = match live.as_ref().filter(|_| crate::api::serves(head.request.uri().path())) {
                Some(live) => crate::api::respond(head, &mut stream, &live.arena).await,
                None => respond(&head.request, &site).await,
            };
            reply_and_close(stream, reply).await;
            drop(permit);
        });
    }
}

/// A request head as read, and the bytes that came after it.
pub(crate) struct Head {
    pub request: http::Request<()>,
    pub rest: Vec<u8>,
}

/// Reads one request head. `Err(None)`: the client left before sending one.
async fn read_head(stream: &mut TcpStream) -> Result<Head, Option<Reply>> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 4096];
    loop {
        let n = match stream.read(&mut chunk).await {
            Ok(0) | Err(_) => return Err(None),
            Ok(n) => n,
        };
        buf.extend_from_slice(&chunk[..n]);
        if let Some((request, len)) = parse_head(&buf)? {
            return Ok(Head { request, rest: buf.split_off(len) });
        }
        if buf.len() >= MAX_HEAD {
            return Err(Some(Reply::text(
                StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
                format!("request head longer than {MAX_HEAD} bytes"),
            )));
        }
    }
}

/// The request and its head's length, or `None` while the head is incomplete.
fn parse_head(buf: &[u8]) -> Result<Option<(http::Request<()>, usize)>, Option<Reply>> {
    let bad = |what: String| Some(Reply::text(StatusCode::BAD_REQUEST, what));
    let mut headers = [httparse::EMPTY_HEADER; MAX_HEADERS];
    let mut parsed = httparse::Request::new(&mut headers);
    let len = match parsed.parse(buf) {
        Ok(httparse::Status::Complete(len)) => len,
        Ok(httparse::Status::Partial) => return Ok(None),
        Err(httparse::Error::TooManyHeaders) => {
            return Err(Some(Reply::text(
                StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
                format!("more than {MAX_HEADERS} header lines"),
            )));
        }
        Err(e) => return Err(bad(format!("not an HTTP request: {e}"))),
    };
    let version = if parsed.version == Some(0) { http::Version::HTTP_10 } else { http::Version::HTTP_11 };
    let mut request = http::Request::builder()
        .method(parsed.method.unwrap_or_default())
        .uri(parsed.path.unwrap_or_default())
        .version(version);
    for header in parsed.headers.iter() {
        request = request.header(header.name, header.value);
    }
    let request = request.body(()).map_err(|e| bad(format!("bad request: {e}")))?;
    Ok(Some((request, len)))
}

/// The answer to a plain request.
async fn respond(request: &http::Request<()>, site: &Site) -> Reply {
    if request.method() != http::Method::GET {
        return Reply::text(StatusCode::METHOD_NOT_ALLOWED, "only GET").with("Allow", "GET".into());
    }
    let json = |body: &str| Reply::new(StatusCode::OK, "application/json", body.to_string());
    let path = match request.uri().path() {
        "/" => "/index.html",
        "/study" | "/study/" => "/study.html",
        "/study/admin" | "/study/admin/" => "/dashboard.html",
        path => path,
    };
    if let Some(&(_, kind, body)) = PAGE_FILES.iter().find(|(served_at, ..)| *served_at == path) {
        return Reply::new(StatusCode::OK, kind, body);
    }
    match path {
        "/map.json" => json(&site.map_json),
        "/info.json" => json(&site.info_json),
        "/replay.json" => match &site.replay {
            Some((info, _)) => json(info),
            None => Reply::text(StatusCode::NOT_FOUND, "not a replay"),
        },
        path if path.starts_with("/replay/frame/") || path.starts_with("/replay/view/") => {
            let numbers: Vec<Option<u64>> = path.split('/').skip(3).map(|n| n.parse().ok()).collect();
            let ask = match numbers.as_slice() {
                [Some(tick)] if path.starts_with("/replay/frame/") => Some(ReplayAsk::Frame(*tick)),
                [Some(robot), Some(tick)] => {
                    u32::try_from(*robot).ok().map(|robot| ReplayAsk::View { robot, tick: *tick })
                }
                _ => None,
            };
            let frame = match (&site.replay, ask) {
                (Some((_, frames)), Some(ask)) => {
                    let frames = frames.clone();
                    tokio::task::spawn_blocking(move || frames(ask)).await.ok().flatten()
                }
                _ => None,
            };
            match frame {
                Some(frame) => json(&frame),
                None => Reply::text(StatusCode::NOT_FOUND, "no such frame"),
            }
        }
        _ => Reply::text(StatusCode::NOT_FOUND, "not found"),
    }
}

/// An HTTP answer; the connection is closed after it.
pub(crate) struct Reply {
    status: StatusCode,
    kind: &'static str,
    body: Cow<'static, str>,
    headers: Vec<(&'static str, String)>,
}

impl Reply {
    pub(crate) fn new(status: StatusCode, kind: &'static str, body: impl Into<Cow<'static, str>>) -> Reply {
        Reply { status, kind, body: body.into(), headers: Vec::new() }
    }

    /// A plain-text answer; the text gets a newline.
    pub(crate) fn text(status: StatusCode, text: impl Into<String>) -> Reply {
        Reply::new(status, "text/plain; charset=utf-8", text.into() + "\n")
    }

    /// `503 Service Unavailable` with `Retry-After`.
    pub(crate) fn busy(why: &str) -> Reply {
        Reply::text(StatusCode::SERVICE_UNAVAILABLE, format!("{why}; try again shortly"))
            .with("Retry-After", RETRY_AFTER_S.to_string())
    }

    /// The answer with one more header.
    pub(crate) fn with(mut self, name: &'static str, value: String) -> Reply {
        self.headers.push((name, value));
        self
    }

    /// A JSON answer.
    pub(crate) fn json(status: StatusCode, body: String) -> Reply {
        Reply::new(status, "application/json", body)
    }

    fn to_bytes(&self) -> Vec<u8> {
        let mut head = format!(
            "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n",
            self.status.as_str(),
            self.status.canonical_reason().unwrap_or(""),
            self.kind,
            self.body.len()
        );
        for (name, value) in &self.headers {
            head += &format!("{name}: {value}\r\n");
        }
        head += "\r\n";
        let mut bytes = head.into_bytes();
        bytes.extend_from_slice(self.body.as_bytes());
        bytes
    }
}

/// Sends `reply` and closes the connection, reading and dropping whatever the client
/// still sends for a moment first (closing a socket with unread input resets the
/// connection, which can throw away the answer before the client reads it).
pub(crate) async fn reply_and_close(mut stream: TcpStream, reply: Reply) {
    let sent = tokio::time::timeout(WRITE_TIMEOUT, async {
        stream.write_all(&reply.to_bytes()).await?;
        stream.shutdown().await
    })
    .await;
    if !matches!(sent, Ok(Ok(()))) {
        return;
    }
    let mut sink = [0u8; 1024];
    let drain = async { while matches!(stream.read(&mut sink).await, Ok(n) if n > 0) {} };
    let _ = tokio::time::timeout(LINGER, drain).await;
}
