//! The HTTP API of a live server (JSON): the lobby's listing for anyone; making,
//! stopping, pausing and inspecting matches, results and replays for the operator
//! (`Authorization: Bearer TOKEN`, or `?token=` on a GET). Also the live `/map.json` and
//! `/info.json`, and a study's `/api/study/...` ([`crate::study::api`]) when one is served.

use serde_json::json;
use tokio::io::AsyncReadExt;
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::http::{Method, StatusCode};

use crate::arena::{Arena, ArenaError, CreateRequest};
use crate::http::{HEAD_TIMEOUT, Head, Reply};

/// The longest request body read, in bytes.
const MAX_BODY: usize = 64 * 1024;

/// Whether `path` is answered here rather than by the page's files.
pub(crate) fn serves(path: &str) -> bool {
    path.starts_with("/api/") || path == "/api" || path == "/map.json" || path == "/info.json"
}

/// A JSON error answer: `{"error": "..."}`.
fn error(status: StatusCode, message: impl Into<String>) -> Reply {
    Reply::json(status, json!({ "error": message.into() }).to_string())
}

fn ok(status: StatusCode, body: &serde_json::Value) -> Reply {
    Reply::json(status, body.to_string())
}

/// Answers one request of the API.
pub(crate) async fn respond(head: Head, stream: &mut TcpStream, arena: &Arena) -> Reply {
    let Head { request, rest: rest_body } = head;
    let path = request.uri().path().trim_end_matches('/').to_string();
    let query = request.uri().query().unwrap_or("");
    let operator = is_operator(&request, query, arena);
    let method = request.method().clone();
    let parts: Vec<&str> = path.trim_start_matches('/').split('/').collect();
    match (&method, parts.as_slice()) {
        (&Method::GET, ["map.json"]) => match arena.layout(query_value(query, "match").as_deref()) {
            Some(layout) => Reply::json(StatusCode::OK, layout.to_string()),
            None => error(StatusCode::NOT_FOUND, "no such match"),
        },
        (&Method::GET, ["info.json"]) => ok(StatusCode::OK, &arena.info()),
        (&Method::GET, ["api", "matches"]) => {
            ok(StatusCode::OK, &json!({ "matches": arena.list(operator).await }))
        }
        (&Method::GET, ["api", "matches", name]) => match arena.summary(name, operator).await {
            Some(summary) => ok(StatusCode::OK, &summary),
            None => error(StatusCode::NOT_FOUND, format!("no match named '{name}'")),
        },
        (_, ["api", "study", rest @ ..]) => {
            let Some(study) = crate::study::StudyServer::of(arena) else {
                return error(StatusCode::NOT_FOUND, "this server runs no study (bw4t study STUDY.toml)");
            };
            // Participants' pages post with any content type (`sendBeacon` sends text/plain).
            let body = if method == Method::POST {
                match read_body(&request, rest_body, stream).await {
                    Ok(body) => body,
                    Err(reply) => return reply,
                }
            } else {
                Vec::new()
            };
            match crate::study::api::respond(&study, &method, rest, &body, operator).await {
                crate::study::api::Answer::Json(status, body) => ok(status, &body),
                crate::study::api::Answer::Unauthorized => unauthorized(arena),
            }
        }
        (_, ["api", ..]) if !operator && method != Method::GET => unauthorized(arena),
        (&Method::POST, ["api", "matches"]) => {
            let body = match read_body(&request, rest_body, stream).await {
                Ok(body) => body,
                Err(reply) => return reply,
            };
            let create: CreateRequest = match serde_json::from_slice(&body) {
                Ok(create) => create,
                Err(e) => return error(StatusCode::BAD_REQUEST, format!("not a match request: {e}")),
            };
            match arena.create(create) {
                Ok(name) => match arena.summary(&name, true).await {
                    Some(summary) => ok(StatusCode::CREATED, &summary),
                    None => error(StatusCode::INTERNAL_SERVER_ERROR, "the match ended at once"),
                },
                Err(e) => arena_error(&e),
            }
        }
        (&Method::POST, ["api", "matches", name, "stop"]) => match arena.stop(name).await {
            // The stopped run's summary (a template that goes on has a new run by now).
            Ok(id) => match arena.finished_summary(&id, true) {
                Some(summary) => ok(StatusCode::OK, &summary),
                None => ok(StatusCode::OK, &json!({ "name": name, "id": id, "state": "finished" })),
            },
            Err(e) => arena_error(&e),
        },
        (&Method::POST, ["api", "matches", name, action @ ("pause" | "resume")]) => {
            match arena.pause(name, *action == "pause").await {
                Ok(()) => match arena.summary(name, true).await {
                    Some(summary) => ok(StatusCode::OK, &summary),
                    None => error(StatusCode::NOT_FOUND, format!("no live match named '{name}'")),
                },
                Err(e) => arena_error(&e),
            }
        }
        (&Method::GET, ["api", "results", ..]) if !operator => unauthorized(arena),
        (&Method::GET, ["api", "results"]) => {
            let rows = arena.results().rows();
            ok(StatusCode::OK, &json!({ "results": rows }))
        }
        (&Method::GET, ["api", "results", id]) => match arena.results().result(id) {
            Some(result) => Reply::json(StatusCode::OK, result),
            None => error(StatusCode::NOT_FOUND, format!("no result '{id}'")),
        },
        (&Method::GET, ["api", "results", id, "replay"]) => match arena.results().replay(id) {
            Some(replay) => Reply::new(StatusCode::OK, "application/x-ndjson", replay),
            None => error(StatusCode::NOT_FOUND, format!("no replay of '{id}' was kept")),
        },
        (&Method::GET | &Method::POST, _) => {
            error(StatusCode::NOT_FOUND, format!("no such route: {method} {path}"))
        }
        _ => error(StatusCode::METHOD_NOT_ALLOWED, "only GET and POST").with("Allow", "GET, POST".into()),
    }
}

fn unauthorized(arena: &Arena) -> Reply {
    let why = if arena.config().operator_token.is_none() {
        "this server has no operator token (bw4t serve --operator-token)"
    } else {
        "wrong or missing operator token (Authorization: Bearer TOKEN)"
    };
    error(StatusCode::UNAUTHORIZED, why).with("WWW-Authenticate", "Bearer".into())
}

fn arena_error(e: &ArenaError) -> Reply {
    let status = match e {
        ArenaError::NameTaken(_) => StatusCode::CONFLICT,
        ArenaError::UnknownMatch(_) | ArenaError::UnknownTemplate(_) => StatusCode::NOT_FOUND,
        ArenaError::Stopping => StatusCode::SERVICE_UNAVAILABLE,
        ArenaError::Bad(_) | ArenaError::Server(_) => StatusCode::BAD_REQUEST,
    };
    error(status, e.to_string())
}

/// Whether the request carries the operator token.
fn is_operator(
    request: &tokio_tungstenite::tungstenite::http::Request<()>,
    query: &str,
    arena: &Arena,
) -> bool {
    let Some(secret) = &arena.config().operator_token else { return false };
    let bearer = request
        .headers()
        .get("authorization")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .map(str::trim)
        .map(str::to_string);
    let given =
        bearer.or_else(|| (request.method() == Method::GET).then(|| query_value(query, "token")).flatten());
    given.is_some_and(|given| crate::host::same_secret(&given, secret))
}

/// The value of `key` in a query string (`a=1&b=2`), percent-decoded.
fn query_value(query: &str, key: &str) -> Option<String> {
    query.split('&').find_map(|pair| {
        let (k, v) = pair.split_once('=')?;
        (k == key).then(|| percent_decode(v))
    })
}

fn percent_decode(text: &str) -> String {
    let bytes = text.as_bytes();
    let hex = |i: usize| bytes.get(i).and_then(|b| (*b as char).to_digit(16));
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        match (bytes[i], hex(i + 1), hex(i + 2)) {
            (b'%', Some(high), Some(low)) => {
                out.push((high * 16 + low) as u8);
                i += 3;
                continue;
            }
            (b'+', ..) => out.push(b' '),
            (b, ..) => out.push(b),
        }
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Reads the body `Content-Length` announces (at most [`MAX_BODY`] bytes).
async fn read_body(
    request: &tokio_tungstenite::tungstenite::http::Request<()>,
    mut body: Vec<u8>,
    stream: &mut TcpStream,
) -> Result<Vec<u8>, Reply> {
    let length = request
        .headers()
        .get("content-length")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<usize>().ok())
        .ok_or_else(|| error(StatusCode::LENGTH_REQUIRED, "a body needs Content-Length"))?;
    if length > MAX_BODY {
        return Err(error(StatusCode::PAYLOAD_TOO_LARGE, format!("a body of at most {MAX_BODY} bytes")));
    }
    let read = async {
        let mut chunk = [0u8; 4096];
        while body.len() < length {
            match stream.read(&mut chunk).await {
                Ok(0) | Err(_) => return false,
                Ok(n) => body.extend_from_slice(&chunk[..n]),
            }
        }
        true
    };
    match tokio::time::timeout(HEAD_TIMEOUT, read).await {
        Ok(true) => {
            body.truncate(length);
            Ok(body)
        }
        _ => Err(error(StatusCode::BAD_REQUEST, "the body ended before its Content-Length")),
    }
}
