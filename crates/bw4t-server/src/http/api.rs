//! The HTTP API of a live server (JSON): the lobby's listing for anyone (on a closed
//! server, a study's, for the operator only); making,
//! stopping, pausing and inspecting matches, results and replays for the operator
//! (`Authorization: Bearer TOKEN`, or `?token=` on a GET). Also the live `/map.json` and
//! `/info.json`.

use bw4t_protocol::{MatchList, MatchState, ResultList, StoppedMatch};
use hyper::{HeaderMap, Method, StatusCode};
use serde::Serialize;

use super::routes::query_value;
use super::{Reply, WebRequest};
use crate::arena::{Arena, ArenaError, CreateRequest};

/// Whether `path` is answered here rather than by the page's files.
pub(crate) fn serves(path: &str) -> bool {
    path.starts_with("/api/") || path == "/api" || path == "/map.json" || path == "/info.json"
}

fn ok(status: StatusCode, body: &impl Serialize) -> Reply {
    match serde_json::to_string(body) {
        Ok(text) => Reply::json(status, text),
        Err(e) => Reply::error(StatusCode::INTERNAL_SERVER_ERROR, format!("reply not serialisable: {e}")),
    }
}

/// Answers one request of the API.
pub(crate) async fn respond(request: WebRequest, arena: &Arena) -> Reply {
    let path = request.path.trim_end_matches('/').to_string();
    let query = request.query.as_str();
    let operator = request.operator;
    let method = request.method.clone();
    let parts: Vec<&str> = path.trim_start_matches('/').split('/').collect();
    match (&method, parts.as_slice()) {
        (&Method::GET, ["map.json"]) => match arena.layout(query_value(query, "match").as_deref()).await {
            Some(layout) => Reply::json(StatusCode::OK, layout.to_string()),
            None => Reply::error(StatusCode::NOT_FOUND, "no such match"),
        },
        (&Method::GET, ["info.json"]) => ok(StatusCode::OK, &arena.info().await),
        // A closed server's matches are the operator's business only.
        (_, ["api", ..]) if !operator && arena.config().server.closed => unauthorized(arena),
        (&Method::GET, ["api", "matches"]) => {
            ok(StatusCode::OK, &MatchList { matches: arena.list(operator).await })
        }
        (&Method::GET, ["api", "matches", name]) => match arena.summary(name, operator).await {
            Some(summary) => ok(StatusCode::OK, &summary),
            None => Reply::error(StatusCode::NOT_FOUND, format!("no match named '{name}'")),
        },
        (_, ["api", ..]) if !operator && method != Method::GET => unauthorized(arena),
        (&Method::POST, ["api", "matches"]) => {
            let create: CreateRequest = match serde_json::from_slice(&request.body) {
                Ok(create) => create,
                Err(e) => return Reply::error(StatusCode::BAD_REQUEST, format!("not a match request: {e}")),
            };
            match arena.create(create).await {
                Ok(name) => match arena.summary(&name, true).await {
                    Some(summary) => ok(StatusCode::CREATED, &summary),
                    None => Reply::error(StatusCode::INTERNAL_SERVER_ERROR, "the match ended at once"),
                },
                Err(e) => arena_error(&e),
            }
        }
        (&Method::POST, ["api", "matches", name, "stop"]) => match arena.stop(name).await {
            // The stopped run's summary (a template that goes on has a new run by now).
            Ok(id) => match arena.finished_summary(&id, true).await {
                Some(summary) => ok(StatusCode::OK, &summary),
                None => ok(
                    StatusCode::OK,
                    &StoppedMatch { name: name.to_string(), id, state: MatchState::Finished },
                ),
            },
            Err(e) => arena_error(&e),
        },
        (&Method::POST, ["api", "matches", name, action @ ("pause" | "resume")]) => {
            match arena.pause(name, *action == "pause").await {
                Ok(()) => match arena.summary(name, true).await {
                    Some(summary) => ok(StatusCode::OK, &summary),
                    None => Reply::error(StatusCode::NOT_FOUND, format!("no live match named '{name}'")),
                },
                Err(e) => arena_error(&e),
            }
        }
        (&Method::GET, ["api", "results", ..]) if !operator => unauthorized(arena),
        (&Method::GET, ["api", "results"]) => {
            // Through a `Value`, whose keys are in alphabetical order, as this answer's always
            // were (the rows of `matches.jsonl` keep the fields' order).
            let results = ResultList { results: arena.results().rows() };
            match serde_json::to_value(&results) {
                Ok(value) => ok(StatusCode::OK, &value),
                Err(e) => {
                    Reply::error(StatusCode::INTERNAL_SERVER_ERROR, format!("reply not serialisable: {e}"))
                }
            }
        }
        (&Method::GET, ["api", "results", id]) => match arena.results().result(id) {
            Some(result) => Reply::json(StatusCode::OK, result),
            None => Reply::error(StatusCode::NOT_FOUND, format!("no result '{id}'")),
        },
        (&Method::GET, ["api", "results", id, "replay"]) => match arena.results().replay(id) {
            Some(replay) => Reply::new(StatusCode::OK, "application/x-ndjson", replay),
            None => Reply::error(StatusCode::NOT_FOUND, format!("no replay of '{id}' was kept")),
        },
        (&Method::GET | &Method::POST, _) => {
            Reply::error(StatusCode::NOT_FOUND, format!("no such route: {method} {path}"))
        }
        _ => Reply::error(StatusCode::METHOD_NOT_ALLOWED, "only GET and POST")
            .with("Allow", "GET, POST".into()),
    }
}

fn unauthorized(arena: &Arena) -> Reply {
    Reply::unauthorized(arena.config().server.operator_token.is_some())
}

fn arena_error(e: &ArenaError) -> Reply {
    let status = match e {
        ArenaError::NameTaken(_) => StatusCode::CONFLICT,
        ArenaError::UnknownMatch(_) | ArenaError::UnknownTemplate(_) => StatusCode::NOT_FOUND,
        ArenaError::Stopping => StatusCode::SERVICE_UNAVAILABLE,
        ArenaError::Bad(_) | ArenaError::Server(_) => StatusCode::BAD_REQUEST,
    };
    Reply::error(status, e.to_string())
}

/// Whether the request carries the operator token.
pub(super) fn is_operator(method: &Method, headers: &HeaderMap, query: Option<&str>, arena: &Arena) -> bool {
    let Some(secret) = &arena.config().server.operator_token else { return false };
    let query = query.unwrap_or("");
    let bearer = headers
        .get("authorization")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .map(str::trim)
        .map(str::to_string);
    let given = bearer.or_else(|| (method == Method::GET).then(|| query_value(query, "token")).flatten());
    given.is_some_and(|given| bw4t_host::same_secret(&given, secret))
}
