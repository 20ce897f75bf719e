//! The page's files, built into the binary, and what a site serves besides them: the
//! map's layout, the server's info and, in replay mode, the replay's frames and views.

use std::sync::Arc;

use hyper::{Method, StatusCode};

use super::Reply;

pub(crate) const HTML: &str = "text/html; charset=utf-8";
pub(crate) const CSS: &str = "text/css; charset=utf-8";
pub(crate) const JS: &str = "text/javascript; charset=utf-8";
pub(crate) const JSON: &str = "application/json";

/// The page's files, built into the binary: the path each is served at, its content
/// type, its text. The page is ES modules the browser loads itself (`web/app.js` imports
/// the rest); its belief base is the JavaScript client's own files, served under
/// `/client/`, so that the page and the client keep beliefs with one code.
const PAGE_FILES: &[(&str, &str, &str)] = &[
    ("/index.html", HTML, include_str!("../../web/index.html")),
    ("/style.css", CSS, include_str!("../../web/style.css")),
    ("/app.js", JS, include_str!("../../web/app.js")),
    ("/dom.js", JS, include_str!("../../web/dom.js")),
    ("/page.js", JS, include_str!("../../web/page.js")),
    ("/geometry.js", JS, include_str!("../../web/geometry.js")),
    ("/renderer.js", JS, include_str!("../../web/renderer.js")),
    ("/panels.js", JS, include_str!("../../web/panels.js")),
    ("/connection.js", JS, include_str!("../../web/connection.js")),
    ("/waiting.js", JS, include_str!("../../web/waiting.js")),
    ("/lobby.js", JS, include_str!("../../web/lobby.js")),
    ("/spectator.js", JS, include_str!("../../web/spectator.js")),
    ("/player.js", JS, include_str!("../../web/player.js")),
    ("/replay.js", JS, include_str!("../../web/replay.js")),
    ("/ownview.js", JS, include_str!("../../web/ownview.js")),
    ("/language.js", JS, include_str!("../../web/language.js")),
    ("/menu.js", JS, include_str!("../../web/menu.js")),
    ("/embed.js", JS, include_str!("../../web/embed.js")),
    ("/participant.js", JS, include_str!("../../web/participant.js")),
    ("/glide.js", JS, include_str!("../../web/glide.js")),
    // The message language's table, one source for the menu and the sentences.
    ("/language.json", JSON, include_str!("../../../../protocol/schema/language.json")),
    ("/client/beliefs.js", JS, include_str!("../../../../protocol/clients/js/src/beliefs.js")),
    ("/client/table.js", JS, include_str!("../../../../protocol/clients/js/src/table.js")),
    ("/client/core.js", JS, include_str!("../../../../protocol/clients/js/src/core.js")),
];

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

/// The answer to a plain request.
pub(super) async fn respond(method: &Method, path: &str, site: &Site) -> Reply {
    if method != Method::GET {
        return Reply::text(StatusCode::METHOD_NOT_ALLOWED, "only GET").with("Allow", "GET".into());
    }
    let json = |body: &str| Reply::new(StatusCode::OK, "application/json", body.to_string());
    let path = match path {
        "/" => "/index.html",
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
