//! Streamable HTTP: the MCP endpoint at `/mcp` on a plain HTTP/1.1 server (hyper). The
//! robot belongs to whoever holds the bearer token: every request must carry it, and a
//! browser page must come from an allowed origin. Of the token's sessions, one drives
//! the robot at a time (`seat.rs`). Only loopback host names are accepted
//! unless the operator names more (rmcp's check against DNS rebinding). Connections are
//! capped and must send their heads in time, and a failing `accept` (out of file
//! descriptors) is retried, so no visitor can make the process exit.

use std::convert::Infallible;
use std::sync::Arc;
use std::time::Duration;

use bytes::Bytes;
use http::{HeaderMap, StatusCode, header};
use http_body_util::{BodyExt, Full};
use hyper::body::Incoming;
use hyper_util::rt::{TokioIo, TokioTimer};
use rmcp::transport::streamable_http_server::{StreamableHttpServerConfig, StreamableHttpService};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::Semaphore;
use tower_service::Service;

use crate::seat::Seat;
use crate::server::RobotServer;

/// The path of the MCP endpoint.
pub const MCP_PATH: &str = "/mcp";

/// Host names always accepted, in `Host` and in `Origin`: this machine's.
const LOOPBACK: [&str; 3] = ["localhost", "127.0.0.1", "::1"];
/// The longest request head read, in bytes (longer heads get `431`).
const MAX_HEAD: usize = 16 * 1024;
/// The most header lines in a request head.
const MAX_HEADERS: usize = 64;
/// The longest JSON-RPC body read, in bytes: far above any tool call (a `say` is at most
/// one protocol line).
const MAX_BODY: usize = 256 * 1024;
/// The time a connection beyond the cap has to send its request before it is refused.
const REFUSAL_WAIT: Duration = Duration::from_secs(1);
/// The longest pause between attempts when `accept` fails.
const MAX_ACCEPT_BACKOFF: Duration = Duration::from_secs(1);

/// Who may use the endpoint, and how many connections it holds.
#[derive(Clone, Debug)]
pub struct HttpOptions {
    /// The bearer token every request must carry (`Authorization: Bearer TOKEN`).
    pub token: String,
    /// `Host` names accepted besides loopback's; an `Origin` on one of them is accepted too.
    pub hosts: Vec<String>,
    /// Browser origins accepted besides those on an accepted host (`null` for `Origin: null`).
    pub origins: Vec<String>,
    /// Connections open at once; more are answered `503`.
    pub max_connections: usize,
    /// The time a connection has to send a request head, on opening and between requests.
    pub header_timeout: Duration,
}

impl HttpOptions {
    /// The default limits for `token`, loopback only.
    pub fn new(token: String) -> HttpOptions {
        HttpOptions {
            token,
            hosts: Vec::new(),
            origins: Vec::new(),
            max_connections: 64,
            header_timeout: Duration::from_secs(10),
        }
    }
}

/// Serves `server` on `listener` until the process ends.
pub async fn serve_http(server: RobotServer, listener: TcpListener, options: HttpOptions) {
    let mut config = StreamableHttpServerConfig::default().with_max_request_body_bytes(MAX_BODY);
    config.allowed_hosts.extend(options.hosts.iter().cloned());
    let seat = Arc::new(Seat::default());
    let server = server.seated(seat.clone());
    let mcp: StreamableHttpService<RobotServer, Seat> =
        StreamableHttpService::new(move || Ok(server.clone()), seat, config);
    let gate = Arc::new(Gate::new(&options));
    let places = Arc::new(Semaphore::new(options.max_connections));
    let mut failures: u32 = 0;
    loop {
        let stream = match listener.accept().await {
            Ok((stream, _)) => stream,
            Err(e) => {
                // Out of file descriptors, or a connection reset before it was taken: the
                // connection waits in the backlog while others close.
                failures = failures.saturating_add(1);
                if failures == 1 {
                    eprintln!("bw4t mcp: cannot accept a connection ({e}); trying again");
                }
                let backoff = Duration::from_millis(10).saturating_mul(1 << failures.min(7));
                tokio::time::sleep(backoff.min(MAX_ACCEPT_BACKOFF)).await;
                continue;
            }
        };
        if failures > 0 {
            eprintln!("bw4t mcp: accepting connections again after {failures} failed attempts");
            failures = 0;
        }
        let Ok(place) = places.clone().try_acquire_owned() else {
            tokio::spawn(refuse(stream, options.max_connections));
            continue;
        };
        let (mcp, gate, header_timeout) = (mcp.clone(), gate.clone(), options.header_timeout);
        tokio::spawn(async move {
            let route = hyper::service::service_fn(move |request: http::Request<Incoming>| {
                let (mut mcp, gate) = (mcp.clone(), gate.clone());
                async move {
                    if request.uri().path() != MCP_PATH {
                        return Ok(plain(StatusCode::NOT_FOUND, "not found: the MCP endpoint is /mcp\n"));
                    }
                    if let Some(refusal) = gate.refusal(request.headers()) {
                        return Ok::<_, Infallible>(refusal);
                    }
                    mcp.call(request).await
                }
            });
            // A client that goes away mid-request is its own business.
            let _ = hyper::server::conn::http1::Builder::new()
                .timer(TokioTimer::new())
                .header_read_timeout(header_timeout)
                .max_buf_size(MAX_HEAD)
                .max_headers(MAX_HEADERS)
                .serve_connection(TokioIo::new(stream), route)
                .await;
            drop(place);
        });
    }
}

type Body = http_body_util::combinators::BoxBody<Bytes, Infallible>;

/// The checks before rmcp sees a request: the origin, then the token.
struct Gate {
    token: String,
    /// Host names an `Origin` may have, lower case, without brackets or port.
    hosts: Vec<String>,
    /// Whole origins accepted, lower case.
    origins: Vec<String>,
}

impl Gate {
    fn new(options: &HttpOptions) -> Gate {
        let hosts = LOOPBACK
            .iter()
            .map(|h| h.to_string())
            .chain(options.hosts.iter().map(|h| host_of_authority(h)))
            .collect();
        let origins = options.origins.iter().map(|o| o.trim_end_matches('/').to_ascii_lowercase()).collect();
        Gate { token: options.token.clone(), hosts, origins }
    }

    /// The answer refusing a request with these headers, if it is refused.
    fn refusal(&self, headers: &HeaderMap) -> Option<http::Response<Body>> {
        if let Some(origin) = headers.get(header::ORIGIN) {
            let origin = origin.to_str().unwrap_or("(not text)");
            if !self.origin_allowed(origin) {
                let message = format!(
                    "forbidden: requests from the web origin '{origin}' are not accepted (only this \
                     machine's and the --allow-host names' origins, and --allow-origin ones)\n"
                );
                return Some(plain(StatusCode::FORBIDDEN, &message));
            }
        }
        let given = headers.get(header::AUTHORIZATION).and_then(|v| v.to_str().ok()).and_then(bearer);
        match given {
            Some(token) if same_secret(token, &self.token) => None,
            Some(_) => Some(unauthorized("the bearer token is wrong")),
            None => Some(unauthorized(
                "this robot is driven by whoever holds its bearer token: send `Authorization: Bearer TOKEN` \
                 with the token `bw4t mcp` printed at start (or was given with --http-token)",
            )),
        }
    }

    fn origin_allowed(&self, origin: &str) -> bool {
        let lower = origin.trim_end_matches('/').to_ascii_lowercase();
        if self.origins.contains(&lower) {
            return true;
        }
        let Some((scheme, authority)) = lower.split_once("://") else { return false };
        matches!(scheme, "http" | "https") && self.hosts.contains(&host_of_authority(authority))
    }
}

/// The host of `host[:port]` (or `[v6]:port`), lower case, without brackets.
fn host_of_authority(authority: &str) -> String {
    let authority = authority.trim().to_ascii_lowercase();
    let host = match authority.strip_prefix('[') {
        Some(rest) => rest.split(']').next().unwrap_or_default(),
        // A bare IPv6 address has several colons and no port.
        None if authority.matches(':').count() > 1 => &authority,
        None => authority.split(':').next().unwrap_or_default(),
    };
    host.to_string()
}

/// The token of an `Authorization: Bearer TOKEN` value.
fn bearer(value: &str) -> Option<&str> {
    let (scheme, token) = value.trim().split_once(' ')?;
    scheme.eq_ignore_ascii_case("bearer").then(|| token.trim())
}

/// Whether `given` is `secret`, in a time that does not tell how much of it matched.
fn same_secret(given: &str, secret: &str) -> bool {
    let (given, secret) = (given.as_bytes(), secret.as_bytes());
    given.len() == secret.len() && given.iter().zip(secret).fold(0, |diff, (a, b)| diff | (a ^ b)) == 0
}

/// `401` with a JSON-RPC error naming the problem; the connection closes after it.
fn unauthorized(problem: &str) -> http::Response<Body> {
    let body = serde_json::json!({
        "jsonrpc": "2.0",
        "id": null,
        "error": {"code": -32001, "message": format!("unauthorized: {problem}")},
    });
    let mut response = http::Response::new(Full::new(Bytes::from(body.to_string())).boxed());
    *response.status_mut() = StatusCode::UNAUTHORIZED;
    let headers = response.headers_mut();
    headers.insert(header::WWW_AUTHENTICATE, http::HeaderValue::from_static("Bearer realm=\"bw4t mcp\""));
    headers.insert(header::CONTENT_TYPE, http::HeaderValue::from_static("application/json"));
    headers.insert(header::CONNECTION, http::HeaderValue::from_static("close"));
    response
}

/// A plain-text answer; the connection closes after it.
fn plain(status: StatusCode, text: &str) -> http::Response<Body> {
    let mut response = http::Response::new(Full::new(Bytes::from(text.to_string())).boxed());
    *response.status_mut() = status;
    response.headers_mut().insert(header::CONTENT_TYPE, http::HeaderValue::from_static("text/plain"));
    response.headers_mut().insert(header::CONNECTION, http::HeaderValue::from_static("close"));
    response
}

/// Answers a connection beyond the cap `503`, once its request is in (so that closing
/// does not reset it before the client reads the answer) or [`REFUSAL_WAIT`] has passed.
async fn refuse(mut stream: TcpStream, limit: usize) {
    let mut head = [0u8; 4096];
    let _ = tokio::time::timeout(REFUSAL_WAIT, stream.read(&mut head)).await;
    let body = format!("busy: this server holds at most {limit} connections at once; try again shortly\n");
    let answer = format!(
        "HTTP/1.1 503 Service Unavailable\r\nRetry-After: 1\r\nContent-Type: text/plain\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    );
    let _ = tokio::time::timeout(REFUSAL_WAIT, async {
        stream.write_all(answer.as_bytes()).await?;
        stream.shutdown().await
    })
    .await;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gate() -> Gate {
        let mut options = HttpOptions::new("s3cret".into());
        options.hosts = vec!["robot.example:8765".into()];
        options.origins = vec!["https://app.example".into()];
        Gate::new(&options)
    }

    #[test]
    fn origins_of_this_machine_and_of_named_hosts_pass_and_others_do_not() {
        let gate = gate();
        for origin in [
            "http://localhost:3000",
            "http://127.0.0.1:8765",
            "http://[::1]:1",
            "https://robot.example",
            "https://app.example/",
        ] {
            assert!(gate.origin_allowed(origin), "{origin}");
        }
        for origin in ["http://evil.example", "null", "http://127.0.0.1.evil.example", "file://localhost"] {
            assert!(!gate.origin_allowed(origin), "{origin}");
        }
    }

    #[test]
    fn only_the_exact_bearer_token_is_taken() {
        assert_eq!(bearer("Bearer abc"), Some("abc"));
        assert_eq!(bearer("bearer  abc "), Some("abc"));
        assert_eq!(bearer("Basic abc"), None);
        assert!(same_secret("s3cret", "s3cret"));
        assert!(!same_secret("s3cre", "s3cret") && !same_secret("s3creT", "s3cret"));
    }
}
