//! The web port, on hyper: the browser page, the map's layout and replay frames, the
//! JSON API of a live server, `/ws` (handed to [`websocket`]), and the [`Routes`] of
//! whatever is mounted beside them (a study). One request per connection.
//!
//! Plain requests are short, so they are admitted on accept up to their own limit
//! ([`MAX_REQUESTS`]) and never wait behind the long-lived WebSockets, which have theirs
//! (`max_connections`). Beyond a limit the client gets `503` with `Retry-After`. Each
//! source address has its share of both (a quarter of the requests' places,
//! `max_per_source` WebSockets; beyond it `429`), so one client cannot hold every place. hyper
//! frames the requests: heads are bounded in size and time, bodies in size and time here.
//! Every answer but a WebSocket's `101` says `Connection: close`, so hyper closes the
//! connection after it.

mod api;
mod files;
mod reply;
mod routes;
pub(crate) mod websocket;

pub use files::{FrameSource, ReplayAsk, Site};
pub use reply::Reply;
pub use routes::{Answering, Routes, WebRequest, query_value};

use std::convert::Infallible;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;

use bytes::Bytes;
use http_body_util::{BodyExt, Full, Limited};
use hyper::body::Incoming;
use hyper::server::conn::http1;
use hyper::service::service_fn;
use hyper::{Request, Response, StatusCode};
use hyper_util::rt::{TokioIo, TokioTimer};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use crate::arena::Arena;
use crate::budget::{SourceBudget, SourcePlace, request_source};
use websocket::{Live, OriginPolicy};

/// Plain requests read or answered at once, by default; more are answered `503` at once.
/// They are short, so this is far above what a page load needs.
pub const MAX_REQUESTS: usize = 1024;

/// One source address may hold at most 1/`REQUEST_SHARE` of the plain-request places.
const REQUEST_SHARE: usize = 4;

/// The longest request head read, in bytes (hyper's buffer; longer heads get `431`).
const MAX_HEAD: usize = 16 * 1024;
/// The most header lines in a request head.
const MAX_HEADERS: usize = 64;
/// The longest request body read, in bytes.
const MAX_BODY: usize = 64 * 1024;
/// The time a client has to send its request head, and again its body.
const HEAD_TIMEOUT: Duration = Duration::from_secs(10);
/// The time a client beyond the request limit has to send its head before it is told to
/// come back: short, so that refusals hold no place for long.
const BUSY_HEAD_TIMEOUT: Duration = Duration::from_secs(1);

/// What the web port serves besides the page's files.
#[derive(Clone)]
pub(crate) struct Served {
    pub site: Arc<Site>,
    /// A live server: its API and `/ws`.
    pub live: Option<Arc<Live>>,
    /// Routes mounted beside the server's own, asked first.
    pub mounted: Vec<Arc<dyn Routes>>,
}

/// Serves the page (no match: `/ws` is not found) on `listener` until aborted, with at
/// most `max_requests` requests being read or answered at once.
pub async fn serve_site(listener: TcpListener, site: Arc<Site>, max_requests: usize) {
    serve(listener, Served { site, live: None, mounted: Vec::new() }, max_requests).await;
}

/// Why a connection's request is answered at once, without being read.
#[derive(Clone, Copy)]
enum TurnedAway {
    /// Every place for plain requests is taken.
    Busy,
    /// Its source address holds its share of them.
    SourceFull(usize),
}

/// Serves `served` on `listener` until aborted.
pub(crate) async fn serve(listener: TcpListener, served: Served, max_requests: usize) {
    let requests = Arc::new(Semaphore::new(max_requests));
    let trusted =
        served.live.as_ref().map(|l| l.arena.config().server.trusted_proxies.clone()).unwrap_or_default();
    // A page load is a burst of short requests, and a classroom behind one address loads
    // many pages at once: an address may hold a quarter of the places, so that a client
    // with half-sent heads can never hold them all.
    let sources = SourceBudget::new((max_requests / REQUEST_SHARE).max(1));
    loop {
        let Ok((stream, peer)) = listener.accept().await else {
            // Out of file descriptors or a reset before accept: try again shortly.
            tokio::time::sleep(Duration::from_millis(10)).await;
            continue;
        };
        let _ = stream.set_nodelay(true);
        // A trusted proxy's connections come from many clients: their WebSockets are
        // counted by the forwarded address; its plain requests only against the total.
        let source = if trusted.contains(&peer.ip()) {
            Ok(None)
        } else {
            sources.take(peer.ip()).map(Some).ok_or(TurnedAway::SourceFull(sources.limit()))
        };
        let request = requests.clone().try_acquire_owned().map_err(|_| TurnedAway::Busy);
        let (places, turned_away) = match (request, source) {
            (Ok(request), Ok(source)) => (Places { request: Some(request), source }, None),
            (Err(why), _) | (_, Err(why)) => (Places { request: None, source: None }, Some(why)),
        };
        let place = Arc::new(Mutex::new(places));
        let served = served.clone();
        tokio::spawn(async move {
            let io = TokioIo::new(Placed { place: place.clone(), stream });
            let service = service_fn(move |request| {
                let (served, place) = (served.clone(), place.clone());
                async move {
                    let response = match turned_away {
                        Some(TurnedAway::Busy) => Reply::busy("too many requests at once").into_response(),
                        Some(TurnedAway::SourceFull(limit)) => {
                            Reply::too_many(&format!("at most {limit} requests at once from one address"))
                                .into_response()
                        }
                        None => answer(request, &served, &place, peer).await,
                    };
                    Ok::<_, Infallible>(response)
                }
            });
            let connection = http1::Builder::new()
                .timer(TokioTimer::new())
                .header_read_timeout(if turned_away.is_some() { BUSY_HEAD_TIMEOUT } else { HEAD_TIMEOUT })
                .max_buf_size(MAX_HEAD)
                .max_headers(MAX_HEADERS)
                .title_case_headers(true)
                .serve_connection(io, service)
                .with_upgrades();
            let _ = connection.await;
        });
    }
}

/// A connection's socket and its places among the plain requests: the places are given
/// back before the socket closes (so a client that sees the close can come back at
/// once), or as soon as the connection becomes a WebSocket.
struct Placed {
    place: Arc<Mutex<Places>>,
    stream: TcpStream,
}

/// A plain request's places: among all requests, and among its source address's.
struct Places {
    request: Option<OwnedSemaphorePermit>,
    source: Option<SourcePlace>,
}

impl Drop for Placed {
    fn drop(&mut self) {
        free_place(&self.place);
    }
}

fn free_place(place: &Mutex<Places>) {
    let mut places = place.lock().unwrap_or_else(|p| p.into_inner());
    places.request.take();
    places.source.take();
}

impl AsyncRead for Placed {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_read(cx, buf)
    }
}

impl AsyncWrite for Placed {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        Pin::new(&mut self.stream).poll_write(cx, buf)
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_shutdown(cx)
    }
}

/// Answers one request: `/ws` becomes a WebSocket; the rest is read whole and answered
/// by the mounted routes, the API or the page's files.
async fn answer(
    request: Request<Incoming>,
    served: &Served,
    place: &Mutex<Places>,
    peer: SocketAddr,
) -> Response<Full<Bytes>> {
    let host = request.headers().get(hyper::header::HOST).and_then(|v| v.to_str().ok()).map(str::to_owned);
    let mut response = respond(request, served, place, peer).await;
    // A `Host` of a name's characters only names where the page's WebSocket may go.
    let host = host.filter(|h| h.chars().all(|c| c.is_ascii_alphanumeric() || ".-:[]".contains(c)));
    if let Some(csp) = host
        .and_then(|h| hyper::header::HeaderValue::from_str(&reply::content_security_policy(Some(&h))).ok())
    {
        response.headers_mut().insert(hyper::header::CONTENT_SECURITY_POLICY, csp);
    }
    response
}

/// [`answer`] but for the headers that depend on the request: plain requests on a `Host`
/// that is not this server's are refused (`403`), as WebSockets are.
async fn respond(
    request: Request<Incoming>,
    served: &Served,
    place: &Mutex<Places>,
    peer: SocketAddr,
) -> Response<Full<Bytes>> {
    let path = request.uri().path().to_string();
    if let Some(live) = served.live.as_ref().filter(|_| path == "/ws") {
        return match websocket::admit(&request, live, peer.ip()) {
            Ok(admitted) => {
                // From here on it counts as a WebSocket, not as a request.
                free_place(place);
                websocket::upgrade(request, admitted, live.clone())
            }
            Err(reply) => reply.into_response(),
        };
    }
    let site_only = OriginPolicy::default();
    let origins = served.live.as_ref().map_or(&site_only, |live| &live.origins);
    let host = request.headers().get(hyper::header::HOST).and_then(|v| v.to_str().ok());
    if let Some(why) = origins.host_refusal(host) {
        return Reply::text(StatusCode::FORBIDDEN, why).into_response();
    }
    let arena = served.live.as_ref().map(|live| &live.arena);
    let mounted = served.mounted.iter().find(|r| r.serves(&path));
    let api = arena.filter(|_| api::serves(&path));
    if mounted.is_none() && api.is_none() {
        // The page's files: no body is read.
        return files::respond(request.method(), &path, &served.site).await.into_response();
    }
    let (head, body) = request.into_parts();
    let body = match read_body(&head, body).await {
        Ok(body) => body,
        Err(reply) => return reply.into_response(),
    };
    let forwarded_for = head.headers.get("x-forwarded-for").and_then(|v| v.to_str().ok());
    let source = request_source(
        peer.ip(),
        forwarded_for,
        served.live.as_ref().map_or(&[], |l| &l.trusted_proxies[..]),
    );
    let request = WebRequest {
        source,
        operator: arena
            .is_some_and(|arena| api::is_operator(&head.method, &head.headers, head.uri.query(), arena)),
        method: head.method,
        query: head.uri.query().unwrap_or("").to_string(),
        headers: head.headers,
        path,
        body,
    };
    let reply = match (mounted, api) {
        (Some(routes), _) => routes.respond(request).await,
        (None, Some(arena)) => api::respond(request, arena).await,
        (None, None) => files::respond(&request.method, &request.path, &served.site).await,
    };
    reply.into_response()
}

/// A request's body, read whole within [`MAX_BODY`] bytes and [`HEAD_TIMEOUT`]; a `POST`
/// must say its length.
async fn read_body(head: &hyper::http::request::Parts, body: Incoming) -> Result<Vec<u8>, Reply> {
    if head.method == hyper::Method::POST && !head.headers.contains_key(hyper::header::CONTENT_LENGTH) {
        return Err(Reply::error(StatusCode::LENGTH_REQUIRED, "a body needs Content-Length"));
    }
    match tokio::time::timeout(HEAD_TIMEOUT, Limited::new(body, MAX_BODY).collect()).await {
        Err(_) => Err(Reply::text(StatusCode::REQUEST_TIMEOUT, "the body did not come in time")),
        Ok(Err(e)) if e.is::<http_body_util::LengthLimitError>() => {
            Err(Reply::error(StatusCode::PAYLOAD_TOO_LARGE, format!("a body of at most {MAX_BODY} bytes")))
        }
        Ok(Err(e)) => Err(Reply::text(StatusCode::BAD_REQUEST, format!("bad body: {e}"))),
        Ok(Ok(body)) => Ok(body.to_bytes().to_vec()),
    }
}

/// The WebSocket side of a live server's web port, for `arena`.
pub(crate) fn live(arena: &Arena) -> Arc<Live> {
    Arc::new(Live::new(arena.clone()))
}
