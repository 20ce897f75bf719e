//! The study's pages, built into the binary: the participant's page at `/study` and the
//! operator's dashboard at `/study/admin`. They load the shared modules (`dom.js`,
//! `connection.js`, the player view) from the server's own page.

use bw4t_server::Reply;
use http::{Method, StatusCode};

const HTML: &str = "text/html; charset=utf-8";
const CSS: &str = "text/css; charset=utf-8";
const JS: &str = "text/javascript; charset=utf-8";

/// Each page file: where it is served, its content type, its text.
const FILES: &[(&str, &str, &str)] = &[
    ("/study.html", HTML, include_str!("../web/study.html")),
    ("/study.js", JS, include_str!("../web/study.js")),
    ("/study.css", CSS, include_str!("../web/study.css")),
    ("/dashboard.html", HTML, include_str!("../web/dashboard.html")),
    ("/dashboard.js", JS, include_str!("../web/dashboard.js")),
];

/// The file a path names: `/study` is the participant's page, `/study/admin` the dashboard.
fn file(path: &str) -> Option<&'static (&'static str, &'static str, &'static str)> {
    let path = match path {
        "/study" | "/study/" => "/study.html",
        "/study/admin" | "/study/admin/" => "/dashboard.html",
        path => path,
    };
    FILES.iter().find(|(served_at, ..)| *served_at == path)
}

/// Whether the study answers `path`: its API or one of its pages.
pub(crate) fn serves(path: &str) -> bool {
    path == "/api/study" || path.starts_with("/api/study/") || file(path).is_some()
}

/// A page of the study.
pub(crate) fn page(method: &Method, path: &str) -> Reply {
    if method != Method::GET {
        return Reply::text(StatusCode::METHOD_NOT_ALLOWED, "only GET").with("Allow", "GET".into());
    }
    match file(path) {
        Some(&(_, kind, body)) => Reply::new(StatusCode::OK, kind, body),
        None => Reply::text(StatusCode::NOT_FOUND, "not found"),
    }
}
