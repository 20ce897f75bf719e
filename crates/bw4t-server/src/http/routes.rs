//! How another product mounts its pages and API on the web port: a [`Routes`] value
//! answers the paths it claims, before the server's own.

use std::future::Future;
use std::pin::Pin;

use hyper::{HeaderMap, Method};

use super::Reply;

/// A request as a route sees it: its head, and its body, read whole within the server's
/// limits (size and time) before the route is asked.
#[derive(Debug)]
pub struct WebRequest {
    /// The method.
    pub method: Method,
    /// The path, without the query.
    pub path: String,
    /// The query string (`a=1&b=2`), empty when there is none.
    pub query: String,
    /// The headers.
    pub headers: HeaderMap,
    /// The body (empty for most `GET`s).
    pub body: Vec<u8>,
    /// Whether the request carries the server's operator token.
    pub operator: bool,
    /// The client's address: the peer's, or the one a trusted reverse proxy forwarded.
    pub source: std::net::IpAddr,
}

/// An answer still being made.
pub type Answering<'a> = Pin<Box<dyn Future<Output = Reply> + Send + 'a>>;

/// Pages and an API served on the web port beside the server's own (a study's).
pub trait Routes: Send + Sync + 'static {
    /// Whether `path` is answered here.
    fn serves(&self, path: &str) -> bool;
    /// Answers a request for a path it serves.
    fn respond(&self, request: WebRequest) -> Answering<'_>;
}

/// The value of `key` in a query string (`a=1&b=2`), percent-decoded.
pub fn query_value(query: &str, key: &str) -> Option<String> {
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
