//! `/ws`: who may open a WebSocket (the page's own origin and host, or those allowed),
//! the handshake, and the bridge that makes each WebSocket one protocol connection.
//!
//! A browser always sends `Origin` with a WebSocket handshake, so a page on another site
//! is told apart by it; `Host` is checked as well because a page on a name that the
//! attacker points at 127.0.0.1 (DNS rebinding) is same-origin with that name. A
//! handshake without `Origin` does not come from a page: such a program could as well
//! use the protocol port, so it is let in.

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr};
use std::sync::Arc;

use bw4t_protocol::{DecodeError, ErrorCode, MAX_LINE};
use bytes::Bytes;
use futures_util::stream::{SplitSink, SplitStream};
use futures_util::{SinkExt, StreamExt};
use http_body_util::Full;
use hyper::upgrade::Upgraded;
use hyper::{Request, Response, StatusCode, header};
use hyper_util::rt::TokioIo;
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio_tungstenite::WebSocketStream;
use tokio_tungstenite::tungstenite::handshake::server::create_response;
use tokio_tungstenite::tungstenite::protocol::{Role, WebSocketConfig};
use tokio_tungstenite::tungstenite::{Error as WsError, Message};

use super::Reply;
use crate::arena::Arena;
use crate::budget::{SourceBudget, SourcePlace, request_source};
use crate::connection::{Incoming, LineSink, LineSource};

/// A WebSocket over the upgraded HTTP connection.
type Socket = WebSocketStream<TokioIo<Upgraded>>;

/// Bytes read from the socket at a time (the library's default, 128 KiB, is allocated
/// eagerly for every connection; messages here are small).
const READ_BUFFER: usize = 4 * 1024;
/// The most outgoing bytes a WebSocket holds beyond its message queue: one message being
/// written. A full `frame` of the 100-room map is 16 KB.
const MAX_WRITE_BUFFER: usize = 1024 * 1024;

/// The live server's side of the web port.
pub(crate) struct Live {
    /// The matches WebSockets join.
    pub arena: Arena,
    /// WebSockets open at once (`max_connections`); more get `503`.
    pub max_sockets: usize,
    /// The places among them.
    pub sockets: Arc<Semaphore>,
    /// Which pages may connect.
    pub origins: OriginPolicy,
    /// The WebSockets each source address may have open.
    pub sources: SourceBudget,
    /// Proxies whose `X-Forwarded-For` names the source.
    pub trusted_proxies: Vec<IpAddr>,
}

impl Live {
    /// The WebSocket side of `arena`.
    pub(crate) fn new(arena: Arena) -> Live {
        let config = &arena.config().server;
        Live {
            max_sockets: config.max_connections,
            sockets: Arc::new(Semaphore::new(config.max_connections)),
            origins: OriginPolicy::new(&config.allowed_origins),
            sources: SourceBudget::new(config.max_per_source),
            trusted_proxies: config.trusted_proxies.clone(),
            arena,
        }
    }
}

/// A handshake that may go ahead: its `101` answer and its places among the WebSockets
/// and among its source address's.
pub(crate) struct Admitted {
    response: Response<()>,
    permit: (OwnedSemaphorePermit, SourcePlace),
}

/// Checks a request on `/ws` from `peer`: a valid handshake, an allowed origin and host,
/// a free place, and one free for its source address.
pub(crate) fn admit<B>(request: &Request<B>, live: &Live, peer: IpAddr) -> Result<Admitted, Reply> {
    let mut head = Request::new(());
    *head.method_mut() = request.method().clone();
    *head.uri_mut() = request.uri().clone();
    *head.version_mut() = request.version();
    *head.headers_mut() = request.headers().clone();
    let response = create_response(&head)
        .map_err(|e| Reply::text(StatusCode::BAD_REQUEST, format!("not a WebSocket handshake: {e}")))?;
    let header = |name| request.headers().get(name).and_then(|v| v.to_str().ok());
    if let Some(why) = live.origins.refusal(header(header::ORIGIN), header(header::HOST)) {
        return Err(Reply::text(StatusCode::FORBIDDEN, why));
    }
    let permit = live
        .sockets
        .clone()
        .try_acquire_owned()
        .map_err(|_| Reply::busy(&format!("the server takes at most {} WebSockets", live.max_sockets)))?;
    let source = request_source(
        peer,
        header(header::HeaderName::from_static("x-forwarded-for")),
        &live.trusted_proxies,
    );
    let place = live.sources.take(source).ok_or_else(|| {
        Reply::too_many(&format!("at most {} WebSockets from one address", live.sources.limit()))
    })?;
    Ok(Admitted { response, permit: (permit, place) })
}

/// Answers the handshake with `101` and, once hyper hands the connection over, runs the
/// WebSocket as a protocol connection.
pub(crate) fn upgrade(
    request: Request<hyper::body::Incoming>,
    admitted: Admitted,
    live: Arc<Live>,
) -> Response<Full<Bytes>> {
    let Admitted { response, permit } = admitted;
    tokio::spawn(async move {
        if let Ok(upgraded) = hyper::upgrade::on(request).await {
            let ws =
                WebSocketStream::from_raw_socket(TokioIo::new(upgraded), Role::Server, Some(config())).await;
            bridge(ws, permit, &live).await;
        }
    });
    response.map(|()| Full::new(Bytes::new()))
}

/// Runs the WebSocket as a protocol connection: a text frame is a line.
async fn bridge(ws: Socket, place: (OwnedSemaphorePermit, SourcePlace), live: &Live) {
    let (write, read) = ws.split();
    let mut lines = WsLines(read);
    let conn = live.arena.next_conn();
    crate::connection::run(conn, &mut lines, WsSink(write), &live.arena).await;
    // The writer is done, so `lines` holds the socket's last half: the place is free
    // before the socket closes, and a client that sees the close can take it at once.
    drop(place);
    drop(lines);
}

/// Frames and messages no longer than a protocol line, so an over-long message is refused
/// at its first frame header or fragment instead of being buffered whole.
fn config() -> WebSocketConfig {
    WebSocketConfig::default()
        .read_buffer_size(READ_BUFFER)
        .max_frame_size(Some(MAX_LINE))
        .max_message_size(Some(MAX_LINE))
        .write_buffer_size(0)
        .max_write_buffer_size(MAX_WRITE_BUFFER)
}

/// The receiving half of a WebSocket, as a line source: a text message is a line.
struct WsLines(SplitStream<Socket>);

impl LineSource for WsLines {
    async fn next(&mut self) -> Incoming {
        let error = |code, message: String| DecodeError { code, message };
        loop {
            return match self.0.next().await {
                Some(Ok(Message::Text(text))) => Incoming::Lines(vec![Ok(text.as_str().to_owned())]),
                Some(Ok(Message::Binary(_))) => {
                    Incoming::Lines(vec![Err(error(ErrorCode::BadMessage, "send text frames".into()))])
                }
                // Pings are answered by the library; pongs and raw frames mean nothing here.
                Some(Ok(Message::Ping(_) | Message::Pong(_) | Message::Frame(_))) => continue,
                Some(Ok(Message::Close(_))) | None => Incoming::Closed,
                // The rest of the message is not read, so the connection cannot go on.
                Some(Err(WsError::Capacity(_))) => Incoming::Fatal(error(
                    ErrorCode::LineTooLong,
                    format!("message longer than {MAX_LINE} bytes; the WebSocket is closed"),
                )),
                Some(Err(WsError::Utf8(_))) => {
                    Incoming::Fatal(error(ErrorCode::BadUtf8, "text frame is not valid UTF-8".into()))
                }
                Some(Err(_)) => Incoming::Closed,
            };
        }
    }
}

/// The sending half of a WebSocket, as a line sink: a line is a text frame, and a batch
/// is flushed once.
struct WsSink(SplitSink<Socket, Message>);

impl LineSink for WsSink {
    async fn send_lines(&mut self, lines: &[Arc<str>]) -> bool {
        for line in lines {
            if self.0.feed(Message::text(line.trim_end().to_string())).await.is_err() {
                return false;
            }
        }
        self.0.flush().await.is_ok()
    }

    async fn close(&mut self) {
        let _ = self.0.close().await;
    }
}

/// Which pages may open WebSockets: the page's own origin on an allowed host always, and
/// the origins listed in `ServerConfig::allowed_origins` (`*`: any page, any host).
#[derive(Clone, Debug, Default)]
pub(crate) struct OriginPolicy {
    any: bool,
    origins: Vec<String>,
    /// The host names of the listed origins, also accepted in `Host`.
    hosts: Vec<String>,
}

impl OriginPolicy {
    /// The policy for a list of origins as [`parse_origin`] gives them.
    pub(crate) fn new(allowed: &[String]) -> OriginPolicy {
        let origins: Vec<String> = allowed.iter().filter_map(|o| parse_origin(o).ok()).collect();
        let hosts = origins
            .iter()
            .filter_map(|o| o.split_once("://").map(|(_, authority)| host_name(authority).to_string()))
            .collect();
        OriginPolicy { any: origins.iter().any(|o| o == "*"), origins, hosts }
    }

    /// Why a handshake with these `Origin` and `Host` headers is refused, if it is.
    pub(crate) fn refusal(&self, origin: Option<&str>, host: Option<&str>) -> Option<String> {
        let origin = origin?.trim().to_ascii_lowercase();
        if self.any {
            return None;
        }
        let Some(host) = host.map(|h| h.trim().to_ascii_lowercase()) else {
            return Some("a WebSocket from a page needs a Host header".into());
        };
        let own =
            ["http://", "https://"].iter().any(|scheme| origin.strip_prefix(scheme) == Some(host.as_str()));
        if !own && !self.origins.contains(&origin) {
            return Some(format!(
                "pages from {origin} may not open WebSockets here (the server can allow them: \
                 bw4t serve --allow-origin {origin})"
            ));
        }
        self.host_refusal(Some(&host))
    }

    /// Why a request with this `Host` header is refused, if it is: a name that is not
    /// this server's (`localhost`, an IP address, or the host of an allowed origin) may
    /// be one an attacker points at this server (DNS rebinding), making the attacker's
    /// page same-origin with it.
    pub(crate) fn host_refusal(&self, host: Option<&str>) -> Option<String> {
        if self.any {
            return None;
        }
        let Some(host) = host.map(|h| h.trim().to_ascii_lowercase()) else {
            return Some("a request needs a Host header".into());
        };
        let name = host_name(&host);
        let literal = name.parse::<Ipv4Addr>().is_ok()
            || name
                .strip_prefix('[')
                .and_then(|n| n.strip_suffix(']'))
                .is_some_and(|n| n.parse::<Ipv6Addr>().is_ok());
        if !(literal || name == "localhost" || self.hosts.iter().any(|h| h == name)) {
            return Some(format!(
                "'{host}' is not a name of this server (the server can allow it: \
                 bw4t serve --allow-origin http://{host})"
            ));
        }
        None
    }
}

/// The host name of `host[:port]` (an IPv6 address keeps its brackets).
fn host_name(authority: &str) -> &str {
    match authority.find(']') {
        Some(end) if authority.starts_with('[') => &authority[..=end],
        _ => authority.split(':').next().unwrap_or(authority),
    }
}

/// Checks and normalises an allowed origin: `*`, or `http://` or `https://` with a host
/// and an optional port, as browsers send it in `Origin` (lower case, no default port, no
/// path).
pub fn parse_origin(text: &str) -> Result<String, String> {
    let text = text.trim();
    if text == "*" {
        return Ok(text.into());
    }
    let lower = text.trim_end_matches('/').to_ascii_lowercase();
    let bad = || {
        format!(
            "'{text}' is not an origin: expected `*` or a scheme, host and optional port, like http://example.org:8080"
        )
    };
    let (scheme, authority) = lower.split_once("://").ok_or_else(bad)?;
    let default_port = match scheme {
        "http" => ":80",
        "https" => ":443",
        _ => return Err(bad()),
    };
    let authority = authority.strip_suffix(default_port).unwrap_or(authority);
    let clean = authority.chars().all(|c| c.is_ascii_alphanumeric() || "-.:[]_".contains(c));
    if authority.is_empty() || !clean || host_name(authority).is_empty() {
        return Err(bad());
    }
    Ok(format!("{scheme}://{authority}"))
}
