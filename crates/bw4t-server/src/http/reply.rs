//! An HTTP answer: status, content type, body and extra headers; every answer is made
//! into a response here, with the headers every answer carries.

use std::borrow::Cow;

use bw4t_protocol::ErrorReply;
use bytes::Bytes;
use http_body_util::Full;
use hyper::{Response, StatusCode, header};

/// What a `503` asks the client to wait, in seconds.
const RETRY_AFTER_S: u32 = 1;

/// An HTTP answer.
#[derive(Debug)]
pub struct Reply {
    status: StatusCode,
    kind: &'static str,
    body: Cow<'static, str>,
    headers: Vec<(&'static str, String)>,
}

impl Reply {
    /// An answer with this status, content type and body.
    pub fn new(status: StatusCode, kind: &'static str, body: impl Into<Cow<'static, str>>) -> Reply {
        Reply { status, kind, body: body.into(), headers: Vec::new() }
    }

    /// A plain-text answer; the text gets a newline.
    pub fn text(status: StatusCode, text: impl Into<String>) -> Reply {
        Reply::new(status, "text/plain; charset=utf-8", text.into() + "\n")
    }

    /// A JSON answer.
    pub fn json(status: StatusCode, body: impl Into<Cow<'static, str>>) -> Reply {
        Reply::new(status, "application/json", body)
    }

    /// A JSON error answer: `{"error": "..."}` ([`ErrorReply`]).
    pub fn error(status: StatusCode, message: impl Into<String>) -> Reply {
        // A struct of one string always serialises.
        Reply::json(status, serde_json::to_string(&ErrorReply { error: message.into() }).unwrap_or_default())
    }

    /// `503 Service Unavailable` with `Retry-After`.
    pub fn busy(why: &str) -> Reply {
        Reply::text(StatusCode::SERVICE_UNAVAILABLE, format!("{why}; try again shortly"))
            .with("Retry-After", RETRY_AFTER_S.to_string())
    }

    /// `429 Too Many Requests` with `Retry-After`: the client's address holds its share.
    pub fn too_many(why: &str) -> Reply {
        Reply::text(StatusCode::TOO_MANY_REQUESTS, format!("{why}; try again shortly"))
            .with("Retry-After", RETRY_AFTER_S.to_string())
    }

    /// `401 Unauthorized` for a request without the operator's token; `has_token` tells
    /// whether the server has one at all.
    pub fn unauthorized(has_token: bool) -> Reply {
        let why = if has_token {
            "wrong or missing operator token (Authorization: Bearer TOKEN)"
        } else {
            "this server has no operator token (bw4t serve --operator-token)"
        };
        Reply::error(StatusCode::UNAUTHORIZED, why).with("WWW-Authenticate", "Bearer".into())
    }

    /// The answer with one more header.
    pub fn with(mut self, name: &'static str, value: String) -> Reply {
        self.headers.push((name, value));
        self
    }

    /// The response: never cached, and the connection closed after it.
    pub(crate) fn into_response(self) -> Response<Full<Bytes>> {
        let body = match self.body {
            Cow::Borrowed(text) => Bytes::from_static(text.as_bytes()),
            Cow::Owned(text) => Bytes::from(text),
        };
        let mut response = Response::new(Full::new(body));
        *response.status_mut() = self.status;
        let headers = response.headers_mut();
        headers.insert(header::CONTENT_TYPE, header::HeaderValue::from_static(self.kind));
        headers.insert(header::CACHE_CONTROL, header::HeaderValue::from_static("no-store"));
        headers.insert(header::CONNECTION, header::HeaderValue::from_static("close"));
        // The page loads its scripts, styles and data from this server only, is framed by
        // no other page, and tells no other site where the visitor came from.
        if let Ok(csp) = header::HeaderValue::from_str(&content_security_policy(None)) {
            headers.insert(header::CONTENT_SECURITY_POLICY, csp);
        }
        headers.insert(header::X_FRAME_OPTIONS, header::HeaderValue::from_static("DENY"));
        headers.insert(header::X_CONTENT_TYPE_OPTIONS, header::HeaderValue::from_static("nosniff"));
        headers.insert(header::REFERRER_POLICY, header::HeaderValue::from_static("no-referrer"));
        for (name, value) in self.headers {
            if let Ok(value) = header::HeaderValue::from_str(&value) {
                headers.append(name, value);
            }
        }
        response
    }
}

/// The `Content-Security-Policy` of every answer: scripts, styles (the page sets some
/// inline), images (`data:` for the empty icon) and connections from this server only, the
/// WebSocket to `host` when the request names it (`'self'` covers `ws:` in newer
/// browsers only); no plugins, no `<base>`, no framing.
pub(crate) fn content_security_policy(host: Option<&str>) -> String {
    let sockets = host.map(|h| format!(" ws://{h} wss://{h}")).unwrap_or_default();
    format!(
        "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; \
         connect-src 'self'{sockets}; object-src 'none'; base-uri 'none'; form-action 'self'; \
         frame-ancestors 'none'"
    )
}
