use std::net::SocketAddr;

use bw4t_protocol::{MAX_LINE, Mode, ServerMessage, decode_server, encode};
use bw4t_server::{HostConfig, MatchSetup, ServerConfig};
use futures_util::{SinkExt, StreamExt};
use serde_json::{Value, json};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::tungstenite::protocol::Role;
use tokio_tungstenite::tungstenite::{self, Message};

use crate::util::{Client, TestServer, WAIT, lockstep, open_seats};

/// An HTTP answer.
struct Answer {
    status: u16,
    head: String,
    body: String,
}

/// A plain HTTP GET, or `None` when the server closed the connection without answering.
async fn try_get(addr: SocketAddr, path: &str) -> Option<Answer> {
    let mut stream = tokio::net::TcpStream::connect(addr).await.expect("connect");
    let _ = stream.write_all(format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n").as_bytes()).await;
    let mut response = String::new();
    let _ = tokio::time::timeout(WAIT, stream.read_to_string(&mut response)).await.expect("in time");
    let (head, body) = response.split_once("\r\n\r\n")?;
    let status = head.split(' ').nth(1).and_then(|s| s.parse().ok()).expect("a status code");
    Some(Answer { status, head: head.to_string(), body: body.to_string() })
}

/// A plain HTTP GET that must be answered.
async fn get(addr: SocketAddr, path: &str) -> Answer {
    try_get(addr, path).await.expect("an answer")
}

/// Leaves as a client does: shuts the sending half of `stream`, then waits, within
/// [`WAIT`], for the server to close the connection (whatever it sends before). The server
/// frees a connection's place before it closes the socket, so the place is free then.
async fn leave(mut stream: tokio::net::TcpStream) {
    stream.shutdown().await.expect("shut the sending half");
    let mut rest = Vec::new();
    // A reset closes it as well as an end of stream does.
    let _ = tokio::time::timeout(WAIT, stream.read_to_end(&mut rest)).await.expect("closed in time");
}

type Ws = tokio_tungstenite::WebSocketStream<tokio::net::TcpStream>;

/// Opens `ws://ADDR/ws` with these extra (or replaced) headers; on a refusal, the
/// handshake's error (`Http` with the answer's status).
async fn try_ws(addr: SocketAddr, headers: &[(&'static str, &str)]) -> Result<Ws, tungstenite::Error> {
    let mut request = format!("ws://{addr}/ws").into_client_request().expect("request");
    for (name, value) in headers {
        request.headers_mut().insert(*name, value.parse().expect("header value"));
    }
    let stream = tokio::net::TcpStream::connect(addr).await.expect("connect");
    let handshake = tokio_tungstenite::client_async(request, stream);
    Ok(tokio::time::timeout(WAIT, handshake).await.expect("a handshake in time")?.0)
}

/// [`try_ws`] from the loopback address `from` (another source address).
async fn try_ws_from(
    addr: SocketAddr,
    from: &str,
    headers: &[(&'static str, &str)],
) -> Result<Ws, tungstenite::Error> {
    let mut request = format!("ws://{addr}/ws").into_client_request().expect("request");
    for (name, value) in headers {
        request.headers_mut().insert(*name, value.parse().expect("header value"));
    }
    let stream = crate::util::stream_from(addr, from).await;
    let handshake = tokio_tungstenite::client_async(request, stream);
    Ok(tokio::time::timeout(WAIT, handshake).await.expect("a handshake in time")?.0)
}

/// Opens `ws://ADDR/ws`, which must succeed.
async fn ws(addr: SocketAddr) -> Ws {
    try_ws(addr, &[]).await.expect("handshake")
}

/// The HTTP status of a refused handshake (0 if it was not refused).
fn refusal(handshake: &Result<Ws, tungstenite::Error>) -> u16 {
    match handshake {
        Err(tungstenite::Error::Http(answer)) => answer.status().as_u16(),
        _ => 0,
    }
}

/// The next server message on a WebSocket, within [`WAIT`].
async fn next(ws: &mut Ws) -> ServerMessage {
    match tokio::time::timeout(WAIT, ws.next()).await.expect("a message in time") {
        Some(Ok(Message::Text(t))) => decode_server(&t).expect("a server message"),
        other => panic!("unexpected {other:?}"),
    }
}

/// Every server message until the server closes the WebSocket, which it must within [`WAIT`].
async fn drain(ws: &mut Ws) -> Vec<ServerMessage> {
    let mut all = Vec::new();
    let closed = async {
        loop {
            match ws.next().await {
                Some(Ok(Message::Text(t))) => all.push(decode_server(&t).expect("a server message")),
                Some(Ok(Message::Close(_)) | Err(_)) | None => break,
                Some(Ok(_)) => {}
            }
        }
    };
    tokio::time::timeout(WAIT, closed).await.expect("closed in time");
    all
}

/// A client frame's bytes as a raw socket sends them: `FIN`, the opcode, the length it
/// announces, a mask (of zeros, so the payload goes as it is) and the payload sent with it.
fn client_frame(opcode: u8, fin: bool, announced: u64, payload: &[u8]) -> Vec<u8> {
    let mut frame = vec![if fin { 0x80 | opcode } else { opcode }];
    match announced {
        0..=125 => frame.push(0x80 | announced as u8),
        126..=0xffff => {
            frame.push(0x80 | 126);
            frame.extend_from_slice(&(announced as u16).to_be_bytes());
        }
        _ => {
            frame.push(0x80 | 127);
            frame.extend_from_slice(&announced.to_be_bytes());
        }
    }
    frame.extend_from_slice(&[0, 0, 0, 0]);
    frame.extend_from_slice(payload);
    frame
}

/// Sends raw bytes on an open WebSocket's socket and returns everything the server says
/// until it closes the connection.
async fn send_raw_and_drain(ws: Ws, bytes: &[u8]) -> Vec<ServerMessage> {
    let mut stream = ws.into_inner();
    stream.write_all(bytes).await.expect("write");
    let mut ws = tokio_tungstenite::WebSocketStream::from_raw_socket(stream, Role::Client, None).await;
    drain(&mut ws).await
}

/// The codes of the `error` and `bye` messages, in order, and whether each error was fatal.
fn refusal_codes(messages: &[ServerMessage]) -> Vec<String> {
    messages
        .iter()
        .filter_map(|m| match m {
            ServerMessage::Error(e) => Some(format!("error {} fatal={}", e.code, e.fatal)),
            ServerMessage::Bye(b) => Some(format!("bye {}", b.reason)),
            _ => None,
        })
        .collect()
}

fn hello_json(name: &str) -> String {
    json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": name}).to_string()
}

/// A realtime server on the fixed map with the web port, listening as `bw4t serve` does.
async fn web_server_with(match_: (MatchSetup, HostConfig), builtin: usize) -> (TestServer, SocketAddr) {
    web_server_limited(match_, builtin, ServerConfig::default()).await
}

/// [`web_server_with`] with these limits on connections.
/// The first `builtin` seats are built-in cooperative agents.
async fn web_server_limited(
    (mut setup, config): (MatchSetup, HostConfig),
    builtin: usize,
    server: ServerConfig,
) -> (TestServer, SocketAddr) {
    let http = bw4t_server::listen("127.0.0.1:0".parse().expect("addr")).expect("listen");
    let http_addr = http.local_addr().expect("addr");
    for (i, seat) in setup.seats.iter_mut().take(builtin).enumerate() {
        *seat = bw4t_server::Seat::builtin(bw4t_agents::bot_name(i), bw4t_agents::Strategy::Cooperative);
    }
    let extras = bw4t_server::Extras { server, http: Some(http), ..Default::default() };
    (TestServer::start_with(setup, config, extras).await, http_addr)
}

fn web_config(robots: usize) -> (MatchSetup, HostConfig) {
    let (mut setup, mut config) = lockstep("fixed", 4, robots);
    config.mode = Mode::Realtime;
    setup.game.ticks_per_second = 100;
    (setup, config)
}

async fn web_server(builtin: usize, robots: usize) -> (TestServer, SocketAddr) {
    web_server_with(web_config(robots), builtin).await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_and_the_map_layout_are_served() {
    let (server, http) = web_server(1, 1).await;
    let page = get(http, "/").await;
    assert!(page.status == 200 && page.body.contains("<html"), "{}", page.head);
    for path in ["/app.js", "/style.css"] {
        assert_eq!(get(http, path).await.status, 200, "{path}");
    }
    let info: Value = serde_json::from_str(&get(http, "/info.json").await.body).expect("json");
    assert_eq!(info["mode"], "live");
    assert!(matches!(serde_json::from_value(info), Ok(bw4t_protocol::ServerInfo::Live { .. })));
    let layout: Value = serde_json::from_str(&get(http, "/map.json").await.body).expect("json");
    let typed: bw4t_protocol::MapLayout = serde_json::from_value(layout.clone()).expect("a map layout");
    assert_eq!(typed.robot, bw4t_map::ROBOT_SIZE, "the page draws robots of the map crate's size");
    let zones = layout["zones"].as_array().expect("zones");
    let room = zones.iter().find(|z| z["name"] == "RoomA1").expect("RoomA1");
    assert_eq!(
        (room["x"].as_f64(), room["y"].as_f64(), room["w"].as_f64()),
        (Some(10.0), Some(10.0), Some(10.0))
    );
    assert_eq!(room["doors"].as_array().map(Vec::len), Some(1));
    // The walls and openings are the map crate's, so the page draws what the physics has.
    let map = crate::util::shipped_map("fixed");
    let number = |v: &Value| v.as_f64().expect("a number") as f32;
    let walls: Vec<[f32; 4]> = layout["walls"]
        .as_array()
        .expect("walls")
        .iter()
        .map(|w| [number(&w[0]), number(&w[1]), number(&w[2]), number(&w[3])])
        .collect();
    let expected: Vec<[f32; 4]> =
        map.walls().iter().map(|w| w.ends()).map(|(a, b)| [a.x, a.y, b.x, b.y]).collect();
    assert!(!walls.is_empty() && walls == expected, "{walls:?}");
    let door = &room["doors"][0];
    let (a, b) = map.zones()[map.zone_named("RoomA1").expect("RoomA1")].doors[0].opening();
    assert_eq!(door["opening"], serde_json::json!([a.x, a.y, b.x, b.y]));
    assert_eq!(get(http, "/nothing-here").await.status, 404);
    server.stop().await;
}

/// The module paths a page module imports, resolved against its own path (`/a/b.js`
/// importing `../c.js` is `/c.js`): every `import` statement and `export ... from`, each
/// read up to its `;`. The page imports only relative paths, in single quotes.
fn imports_of(module: &str, source: &str) -> Vec<String> {
    let line_starts = std::iter::once(0).chain(source.match_indices('\n').map(|(at, _)| at + 1));
    let statements = line_starts.map(|start| &source[start..]).filter(|rest| {
        ["import ", "import{", "export {", "export *"].iter().any(|start| rest.starts_with(start))
    });
    let specifiers = statements.filter_map(|rest| {
        let statement = rest.split_once(';').map_or(rest, |(statement, _)| statement);
        let quoted = statement.split_once("from '").or_else(|| statement.split_once("import '"))?.1;
        quoted.split_once('\'').map(|(specifier, _)| specifier)
    });
    specifiers
        .map(|specifier| {
            assert!(
                specifier.starts_with("./") || specifier.starts_with("../"),
                "{module} imports {specifier}"
            );
            let mut path: Vec<&str> = module.split('/').collect();
            path.pop();
            for part in specifier.split('/') {
                match part {
                    "." => {}
                    ".." => assert!(path.pop().is_some(), "{module} imports {specifier}, above the root"),
                    part => path.push(part),
                }
            }
            path.join("/")
        })
        .collect()
}

/// Every module the pages at `pages` load, directly or through imports, by path with its
/// text; each must be served as JavaScript. Pages name their module from the root, as
/// the study's are served at `/study` and `/study/admin`.
pub(crate) async fn modules_of(
    http: SocketAddr,
    pages: &[&str],
) -> std::collections::BTreeMap<String, String> {
    let mut queue: Vec<String> = Vec::new();
    for at in pages {
        let page = get(http, at).await.body;
        let before = queue.len();
        queue.extend(
            page.split("<script type=\"module\" src=\"")
                .skip(1)
                .map(|rest| format!("/{}", rest.split('"').next().expect("a src").trim_start_matches('/'))),
        );
        assert!(queue.len() > before, "{at} loads a module: {page}");
    }
    let mut served = std::collections::BTreeMap::new();
    while let Some(path) = queue.pop() {
        if served.contains_key(&path) {
            continue;
        }
        let answer = get(http, &path).await;
        assert_eq!(answer.status, 200, "{path}: {}", answer.head);
        assert!(answer.head.contains("\r\nContent-Type: text/javascript"), "{path}: {}", answer.head);
        queue.extend(imports_of(&path, &answer.body));
        served.insert(path, answer.body);
    }
    served
}

/// Checks that every module in `folder` (from the repository's root) is among `served`.
pub(crate) fn assert_every_module_in_use(folder: &str, served: &std::collections::BTreeMap<String, String>) {
    let web = std::path::Path::new(repo_root!()).join(folder);
    for entry in std::fs::read_dir(&web).expect("the page's folder") {
        let name = entry.expect("an entry").file_name().into_string().expect("a UTF-8 name");
        if name.ends_with(".js") {
            assert!(served.contains_key(&format!("/{name}")), "{folder}/{name} is not imported by a page");
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_module_the_page_imports_is_served_as_javascript() {
    let (server, http) = web_server(0, 1).await;
    let served = modules_of(http, &["/"]).await;
    // The page keeps beliefs with the JavaScript client's own file, not a copy.
    assert_eq!(
        served.get("/client/beliefs.js").map(String::as_str),
        Some(include_str!("../protocol/clients/js/src/beliefs.js")),
        "modules: {:?}",
        served.keys()
    );
    assert_every_module_in_use("crates/bw4t-server/web", &served);
    // A server that runs no study serves no study pages.
    assert_eq!(get(http, "/study").await.status, 404);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_speaks_the_protocol_over_websocket() {
    let (server, http) = web_server(1, 2).await;
    let connect = || ws(http);
    // A human player joins; with the built-in agent that makes two and the match starts.
    let mut human = connect().await;
    human
        .send(Message::text(
            json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Human"}).to_string(),
        ))
        .await
        .expect("send");
    assert!(
        matches!(next(&mut human).await, ServerMessage::Welcome(w) if w.name.as_deref() == Some("Human"))
    );
    assert!(matches!(next(&mut human).await, ServerMessage::Percepts(p) if p.full));
    human
        .send(Message::text(
            json!({"type": "act", "id": 1, "action": "goTo", "args": ["RoomA1"]}).to_string(),
        ))
        .await
        .expect("send");
    let ack = loop {
        if let ServerMessage::Ack(a) = next(&mut human).await {
            break a;
        }
    };
    assert!(ack.ok);
    // A spectator sees the whole match, the built-in agent included.
    let mut watcher = connect().await;
    watcher
        .send(Message::text(
            json!({"type": "hello", "protocol": "bw4t", "versions": [1], "role": "spectator"}).to_string(),
        ))
        .await
        .expect("send");
    let frame = loop {
        if let ServerMessage::Frame(f) = next(&mut watcher).await {
            if f.robots.len() == 2 {
                break f;
            }
        }
    };
    let names: Vec<&str> = frame.robots.iter().map(|r| r.name.as_str()).collect();
    assert!(names.contains(&"Human") && names.contains(&"Bot1"), "{names:?}");
    // Bad input over WebSocket is answered like over TCP.
    watcher.send(Message::text("not json")).await.expect("send");
    let error = loop {
        if let ServerMessage::Error(e) = next(&mut watcher).await {
            break e;
        }
    };
    assert_eq!(error.code, "bad_json");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_replay_viewer_serves_every_ticks_frame() {
    // Record a short headless match.
    let buffer = crate::util::SharedBuffer::default();
    let map = crate::util::shipped_map("fixed");
    let config = bw4t_sim::MatchConfig::default();
    let blank = bw4t_sim::Match::new(&map, &config, 3).expect("match");
    let mut recorder = bw4t_protocol::Recorder::new(
        Box::new(buffer.clone()),
        &blank,
        bw4t_protocol::ReplayMeta {
            program: "test".into(),
            robots: vec!["Bot1".into()],
            digest_every: 100,
            max_ticks: Some(400),
            ..Default::default()
        },
    );
    let mut setup = MatchSetup::builtin_team(map.clone(), 1, bw4t_agents::Strategy::Cooperative);
    setup.seed = 3;
    setup.max_ticks = Some(400);
    let (game, reason) = bw4t_runner::play_headless(&setup, Some(&mut recorder)).expect("play");
    recorder.finish(&game, reason).expect("written");
    let text = buffer.text();
    fn frame_at(frames: &mut bw4t_runner::ReplayFrames, tick: u64) -> Value {
        serde_json::from_str(&frames.frame_json(tick).expect("a frame")).expect("json")
    }
    let mut frames = bw4t_runner::ReplayFrames::open(&text).expect("frames");
    assert_eq!(frames.last_tick(), game.tick(), "a frame per tick, 0 included");
    let forwards: Vec<Value> = (0..=game.tick()).map(|t| frame_at(&mut frames, t)).collect();
    assert!(forwards.iter().enumerate().all(|(i, f)| f["tick"] == i as u64));
    assert_ne!(forwards[0]["robots"][0]["x"], forwards[100]["robots"][0]["x"], "the robot moved");
    assert!(frames.frame_json(game.tick() + 1).is_none());
    // Keeping a single frame, every step back re-simulates from the start: same frames.
    let mut lean = bw4t_runner::ReplayFrames::open(&text).expect("frames").with_cache_budget(0);
    for t in (0..=game.tick()).rev().step_by(7) {
        assert_eq!(frame_at(&mut lean, t), forwards[t as usize], "tick {t}");
    }
    // Served over HTTP.
    let frames = std::sync::Mutex::new(frames);
    let source: bw4t_server::FrameSource = std::sync::Arc::new(move |ask| match ask {
        bw4t_server::ReplayAsk::Frame(t) => frames.lock().expect("lock").frame_json(t),
        bw4t_server::ReplayAsk::View { robot, tick } => frames.lock().expect("lock").view_json(robot, tick),
    });
    let site = bw4t_server::Site {
        map_json: serde_json::to_string(&bw4t_protocol::MapLayout::of(&map)).expect("json"),
        info_json: json!({"mode": "replay"}).to_string(),
        replay: Some((json!({"ticks": game.tick()}).to_string(), source)),
    };
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
    let addr = listener.local_addr().expect("addr");
    let task = tokio::spawn(bw4t_server::serve_site(listener, std::sync::Arc::new(site), 16));
    let frame: Value = serde_json::from_str(&get(addr, "/replay/frame/100").await.body).expect("json");
    assert_eq!(frame["tick"], 100);
    assert_eq!(get(addr, "/replay/frame/99999").await.status, 404);
    // One player's own view beside the overview: what its robot perceived then.
    let view: Value = serde_json::from_str(&get(addr, "/replay/view/0/100").await.body).expect("json");
    assert_eq!((&view["name"], &view["tick"]), (&json!("Bot1"), &json!(100)));
    let facts = view["facts"].as_array().expect("facts");
    assert!(facts.contains(&json!(["ownName", "Bot1"])), "{view}");
    assert!(facts.iter().any(|f| f[0] == "at") && facts.iter().any(|f| f[0] == "sequence"), "{view}");
    assert_eq!(get(addr, "/replay/view/7/100").await.status, 404, "no robot 7");
    assert_eq!(get(addr, "/replay/view/0/99999").await.status, 404, "past the end");
    assert!(get(addr, "/replay.json").await.body.contains("\"ticks\""));
    task.abort();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_websocket_without_hello_is_closed_at_the_hello_deadline_like_tcp() {
    let limits = ServerConfig { hello_timeout: std::time::Duration::from_millis(300), ..Default::default() };
    let (server, http) = web_server_limited(web_config(1), 0, limits).await;
    let mut silent_ws = ws(http).await;
    let mut silent_tcp = Client::connect(server.addr).await;
    let over_ws = drain(&mut silent_ws).await;
    let over_tcp = silent_tcp.drain().await;
    assert_eq!(refusal_codes(&over_ws), ["error hello_timeout fatal=true", "bye hello_timeout"]);
    let encoded = |messages: &[ServerMessage]| messages.iter().map(encode).collect::<Vec<_>>();
    assert_eq!(encoded(&over_ws), encoded(&over_tcp), "the same messages as over TCP");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_answers_while_the_websocket_limit_is_full() {
    // The silent sockets keep their places for the whole test.
    let limits = ServerConfig {
        max_connections: 2,
        hello_timeout: std::time::Duration::from_secs(600),
        ..Default::default()
    };
    let (server, http) = web_server_limited(web_config(1), 0, limits).await;
    let first = ws(http).await;
    let _second = ws(http).await;
    let page = get(http, "/").await;
    assert!(page.status == 200 && page.body.contains("<html"), "{}", page.head);
    assert_eq!(get(http, "/map.json").await.status, 200);
    // A third WebSocket is told to come back later, not dropped.
    match try_ws(http, &[]).await {
        Err(tungstenite::Error::Http(answer)) => {
            assert_eq!(answer.status().as_u16(), 503);
            assert_eq!(answer.headers().get("retry-after").and_then(|v| v.to_str().ok()), Some("1"));
        }
        other => panic!("expected 503, got {:?}", other.map(|_| "a WebSocket")),
    }
    // Once a WebSocket has left, its place is taken again.
    leave(first.into_inner()).await;
    let again = try_ws(http, &[]).await;
    assert!(again.is_ok(), "refused with {} after a WebSocket left", refusal(&again));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn over_long_websocket_messages_are_refused_before_they_are_buffered() {
    let (server, http) = web_server(0, 1).await;
    let refused = ["error line_too_long fatal=true", "bye line_too_long"];
    // A frame that announces 45 MiB is refused at its header, before any of it arrives.
    let over = send_raw_and_drain(ws(http).await, &client_frame(0x1, true, 45 << 20, b"")).await;
    assert_eq!(refusal_codes(&over), refused);
    // So is a message whose fragments are each short but add up to more than a line.
    let mut fragments = client_frame(0x1, false, 60_000, &[b' '; 60_000]);
    fragments.extend(client_frame(0x0, false, 10_000, &[b' '; 10_000]));
    let over = send_raw_and_drain(ws(http).await, &fragments).await;
    assert_eq!(refusal_codes(&over), refused);
    // A message of exactly the line limit is read, and the match went on meanwhile.
    let mut fine = ws(http).await;
    let mut padded = json!({"type": "ping", "id": "padded"}).to_string();
    padded += &" ".repeat(MAX_LINE - padded.len());
    assert_eq!(padded.len(), MAX_LINE);
    fine.send(Message::text(padded)).await.expect("send");
    assert!(
        matches!(next(&mut fine).await, ServerMessage::Pong(p) if p.id == Some(bw4t_protocol::ActId::Text("padded".into())))
    );
    fine.send(Message::text(hello_json("Ann"))).await.expect("send");
    assert!(matches!(next(&mut fine).await, ServerMessage::Welcome(_)));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn websockets_from_other_pages_are_refused_unless_allowed() {
    let check = |allowed: &[&str]| {
        let allowed: Vec<String> = allowed.iter().map(|o| o.to_string()).collect();
        async move {
            let limits = ServerConfig { allowed_origins: allowed, ..Default::default() };
            let (server, http) = web_server_limited(web_config(4), 0, limits).await;
            let port = http.port();
            let cases = [
                ("no Origin: not a page", vec![]),
                ("the page's own origin", vec![("Origin", format!("http://127.0.0.1:{port}"))]),
                (
                    "the page under localhost",
                    vec![
                        ("Host", format!("localhost:{port}")),
                        ("Origin", format!("http://localhost:{port}")),
                    ],
                ),
                (
                    "the page under [::1]",
                    vec![("Host", format!("[::1]:{port}")), ("Origin", format!("http://[::1]:{port}"))],
                ),
                ("another site", vec![("Origin", "http://evil.example".to_string())]),
                ("a sandboxed page", vec![("Origin", "null".to_string())]),
                ("another local page", vec![("Origin", "http://127.0.0.1:1".to_string())]),
                (
                    "a rebound name",
                    vec![
                        ("Host", format!("evil.example:{port}")),
                        ("Origin", format!("http://evil.example:{port}")),
                    ],
                ),
            ];
            let mut outcome = Vec::new();
            for (what, headers) in cases {
                let headers: Vec<(&'static str, &str)> =
                    headers.iter().map(|(n, v)| (*n, v.as_str())).collect();
                let handshake = try_ws(http, &headers).await;
                if let Err(tungstenite::Error::Http(answer)) = &handshake {
                    let body =
                        String::from_utf8_lossy(answer.body().as_deref().unwrap_or_default()).to_string();
                    assert!(
                        body.contains("--allow-origin"),
                        "{what}: the refusal says how to allow it: {body}"
                    );
                }
                assert!(handshake.is_ok() || refusal(&handshake) == 403, "{what}: {handshake:?}");
                outcome.push(format!("{what}: {}", if handshake.is_ok() { "open" } else { "403" }));
            }
            server.stop().await;
            outcome
        }
    };
    let open = |what: &str| format!("{what}: open");
    let refused = |what: &str| format!("{what}: 403");
    let own = [
        "no Origin: not a page",
        "the page's own origin",
        "the page under localhost",
        "the page under [::1]",
    ];
    let mut expected: Vec<String> = own.iter().map(|w| open(w)).collect();
    expected
        .extend(["another site", "a sandboxed page", "another local page", "a rebound name"].map(refused));
    assert_eq!(check(&[]).await, expected, "by default");
    let mut expected: Vec<String> = own.iter().map(|w| open(w)).collect();
    expected.extend([open("another site"), refused("a sandboxed page"), refused("another local page")]);
    expected.push(open("a rebound name"));
    assert_eq!(check(&["http://evil.example"]).await, expected, "with evil.example allowed");
    let everything: Vec<String> = expected.iter().map(|o| o.replace(": 403", ": open")).collect();
    assert_eq!(check(&["*"]).await, everything, "with every origin allowed");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn serve_takes_the_origins_to_allow_from_the_command_line() {
    let out = crate::util::bw4t_within(&["serve", "--http", "0", "--allow-origin", "ftp://x"], WAIT);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("'ftp://x' is not an origin"), "{stderr}");
    let served = ServeChild::start(&["--allow-origin", "HTTP://Evil.Example/"]);
    let http = served.http;
    assert!(try_ws(http, &[("Origin", "http://evil.example")]).await.is_ok(), "listed");
    assert_eq!(refusal(&try_ws(http, &[("Origin", "http://other.example")]).await), 403, "not listed");
}

/// `bw4t serve --port 0 --http 0 ARGS` as a child process, killed when dropped.
struct ServeChild {
    child: std::process::Child,
    http: SocketAddr,
}

impl ServeChild {
    fn start(args: &[&str]) -> ServeChild {
        use std::io::BufRead;
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_bw4t"))
            .args(["serve", "--port", "0", "--http", "0", "--map", "fixed"])
            .args(args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("start bw4t serve");
        let stdout = child.stdout.take().expect("stdout");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(stdout).lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        let mut served = ServeChild { child, http: "0.0.0.0:0".parse().expect("addr") };
        loop {
            let line = rx.recv_timeout(WAIT).expect("bw4t serve prints `http on ADDR` in time");
            if let Some(addr) = line.strip_prefix("http on ") {
                served.http = addr.parse().expect("an address");
                return served;
            }
        }
    }
}

impl Drop for ServeChild {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_burst_of_page_requests_is_answered_whatever_the_websocket_limit() {
    let limits = ServerConfig { max_connections: 2, ..Default::default() };
    let (server, http) = web_server_limited(web_config(1), 0, limits).await;
    let paths = [
        "/",
        "/app.js",
        "/player.js",
        "/renderer.js",
        "/client/beliefs.js",
        "/style.css",
        "/map.json",
        "/info.json",
    ];
    let requests: Vec<_> = (0..2000).map(|i| tokio::spawn(try_get(http, paths[i % paths.len()]))).collect();
    let (mut ok, mut busy, mut silent) = (0, 0, 0);
    for request in requests {
        match request.await.expect("request task") {
            Some(answer) if answer.status == 200 => ok += 1,
            // Beyond the total (503) or this address's share (429): told to come back.
            Some(answer)
                if [503, 429].contains(&answer.status) && answer.head.contains("\r\nRetry-After: 1") =>
            {
                busy += 1
            }
            Some(answer) => panic!("unexpected answer {}", answer.head),
            None => silent += 1,
        }
    }
    assert_eq!(silent, 0, "closed unanswered ({ok} served, {busy} told to retry)");
    assert!(ok > 0, "{busy} told to retry, none served");
    server.stop().await;
}

/// A site without a match, serving at most `max_requests` requests at once.
async fn plain_site(max_requests: usize) -> (tokio::task::JoinHandle<()>, SocketAddr) {
    let site = bw4t_server::Site { map_json: "{}".into(), info_json: "{}".into(), replay: None };
    let listener = bw4t_server::listen("127.0.0.1:0".parse().expect("addr")).expect("listen");
    let addr = listener.local_addr().expect("addr");
    (tokio::spawn(bw4t_server::serve_site(listener, std::sync::Arc::new(site), max_requests)), addr)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn over_the_request_limit_a_client_is_told_to_retry() {
    let (task, addr) = plain_site(2).await;
    // Two connections that never finish their request hold both places: the server takes
    // connections in the order they were made and gives each its place as it takes it, so
    // the next one is refused at once. (From two addresses: one may hold only a quarter.)
    let idle = [
        crate::util::stream_from(addr, "127.0.0.2").await,
        crate::util::stream_from(addr, "127.0.0.3").await,
    ];
    let busy = get(addr, "/info.json").await;
    assert_eq!(busy.status, 503, "{}", busy.head);
    assert!(busy.head.contains("\r\nRetry-After: 1"), "{}", busy.head);
    for stream in idle {
        leave(stream).await;
    }
    let served = get(addr, "/info.json").await;
    assert_eq!(served.status, 200, "served once the idle connections have left: {}", served.head);
    task.abort();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_requests_get_a_status_that_names_the_problem() {
    let (task, addr) = plain_site(8).await;
    let ask = |request: Vec<u8>| async move {
        let mut stream = tokio::net::TcpStream::connect(addr).await.expect("connect");
        stream.write_all(&request).await.expect("write");
        let mut response = String::new();
        let _ = tokio::time::timeout(WAIT, stream.read_to_string(&mut response)).await.expect("in time");
        response
    };
    let garbage = ask(b"HELLO THERE\x01\r\n\r\n".to_vec()).await;
    assert!(garbage.starts_with("HTTP/1.1 400 "), "{garbage}");
    let post = ask(b"POST / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".to_vec()).await;
    assert!(post.starts_with("HTTP/1.1 405 ") && post.contains("\r\nAllow: GET"), "{post}");
    let huge = format!("GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: {}\r\n\r\n", "y".repeat(20_000));
    let huge = ask(huge.into_bytes()).await;
    assert!(huge.starts_with("HTTP/1.1 431 "), "{huge}");
    let plain_ws = ask(b"GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".to_vec()).await;
    assert!(plain_ws.starts_with("HTTP/1.1 404 "), "no match, no /ws: {plain_ws}");
    task.abort();
}

/// The page decides which zone a point is in (a click, a hover, a robot's row) by the map's
/// own rule: `zoneAt` of the served geometry.js, given the served /map.json, names the zone
/// `Map::zone_at` names, at every point of a half-unit grid (shared edges and corners among
/// them) on every shipped map and on the two-room map with a small zone laid over its hall
/// after it in file order, where the first zone wins even though it is not the smallest.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_locates_points_as_the_map_does() {
    use bw4t_map::{Map, Rect, Vec2, Zone, ZoneKind};
    let over_the_hall = crate::util::two_rooms(|parts| {
        parts.zones.push(Zone {
            name: "Nook".into(),
            kind: ZoneKind::Corridor,
            rect: Rect::new(Vec2::new(4.0, 6.0), Vec2::new(4.0, 4.0)),
            doors: Vec::new(),
            neighbours: vec!["Hall".into()],
            blocks: Vec::new(),
        });
    });
    let mut maps: Vec<Map> = std::fs::read_dir(concat!(repo_root!(), "/maps"))
        .expect("maps/")
        .map(|entry| entry.expect("entry").path())
        .filter(|path| path.extension().is_some_and(|e| e == "toml"))
        .map(|path| {
            let name = path.file_stem().and_then(|s| s.to_str()).expect("a map name").to_string();
            crate::util::shipped_map(&name)
        })
        .collect();
    maps.push(over_the_hall);

    let mut geometry = None;
    let (mut cases, mut grids, mut expected) = (Vec::new(), Vec::new(), Vec::<Vec<Option<String>>>::new());
    for map in &maps {
        let setup = MatchSetup { seats: open_seats(1), ..MatchSetup::new(map.clone()) };
        let (server, http) = web_server_with((setup, HostConfig::new()), 0).await;
        let layout: Value = serde_json::from_str(&get(http, "/map.json").await.body).expect("map.json");
        geometry.get_or_insert(get(http, "/geometry.js").await.body);
        server.stop().await;
        // Half units hit every edge exactly, and are exact in f32 and f64 alike.
        let on_half_units = |v: f32| (v * 2.0).fract() == 0.0;
        assert!(
            map.zones().iter().all(|z| {
                let (min, max) = (z.rect.min(), z.rect.max());
                [min.x, min.y, max.x, max.y].into_iter().all(on_half_units)
            }),
            "map '{}' has an edge off the half-unit grid",
            map.name()
        );
        let (lo, hi) = map
            .zones()
            .iter()
            .fold((Vec2::ZERO, map.area()), |(lo, hi), z| (lo.min(z.rect.min()), hi.max(z.rect.max())));
        let steps =
            |from: f32, to: f32| ((from - 1.0) * 2.0).floor() as i32..=((to + 1.0) * 2.0).ceil() as i32;
        let points: Vec<Vec2> = steps(lo.y, hi.y)
            .flat_map(|y| steps(lo.x, hi.x).map(move |x| Vec2::new(x as f32 / 2.0, y as f32 / 2.0)))
            .collect();
        expected.push(points.iter().map(|&p| map.zone_at(p).map(|i| map.zones()[i].name.clone())).collect());
        let xy: Vec<[f32; 2]> = points.iter().map(|p| [p.x, p.y]).collect();
        cases.push(json!({"map": layout, "points": xy}));
        grids.push(points);
    }
    assert!(
        expected.last().expect("the nook map").iter().any(|z| z.as_deref() == Some("Hall"))
            && !expected.last().expect("the nook map").iter().any(|z| z.as_deref() == Some("Nook")),
        "the hall, first in file order, covers the nook"
    );

    let dir = std::env::temp_dir().join(format!("bw4t-zone-at-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("geometry.mjs"), geometry.expect("geometry.js")).expect("write");
    std::fs::write(dir.join("cases.json"), serde_json::to_string(&cases).expect("json")).expect("write");
    let script = "import { readFileSync } from 'node:fs';\n\
        import { buildMap, zoneAt } from './geometry.mjs';\n\
        const cases = JSON.parse(readFileSync(new URL('./cases.json', import.meta.url), 'utf8'));\n\
        const names = cases.map(({ map, points }) => {\n\
          const built = buildMap(map);\n\
          return points.map(([x, y]) => zoneAt(built, x, y)?.name ?? null);\n\
        });\n\
        process.stdout.write(JSON.stringify(names));\n";
    std::fs::write(dir.join("locate.mjs"), script).expect("write");
    let mut node = std::process::Command::new("node");
    node.arg(dir.join("locate.mjs"));
    let out = crate::util::output_within(node, WAIT, "node (Node.js 20 or newer, as ./test.sh requires)");
    assert!(out.status.success(), "node failed: {}", String::from_utf8_lossy(&out.stderr));
    let page: Vec<Vec<Option<String>>> = serde_json::from_slice(&out.stdout).expect("node's answer");
    let _ = std::fs::remove_dir_all(&dir);

    assert_eq!(page.len(), maps.len());
    for (((map, points), page), expected) in maps.iter().zip(&grids).zip(&page).zip(&expected) {
        assert_eq!(page.len(), points.len(), "map '{}'", map.name());
        let disagree: Vec<String> = (points.iter().zip(page).zip(expected))
            .filter(|((_, page), map)| page != map)
            .map(|((p, page), map)| format!("{p}: page {page:?}, map {map:?}"))
            .take(10)
            .collect();
        assert!(disagree.is_empty(), "map '{}': the page and the map disagree at {disagree:?}", map.name());
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_address_holding_its_share_of_request_places_leaves_the_page_to_others() {
    // An address may hold a quarter of the places.
    let (task, addr) = plain_site(64).await;
    let share = 16;
    // Half-sent request heads from one address: each holds a place until its head timeout.
    let mut idle = Vec::new();
    for _ in 0..share {
        let mut stream = crate::util::stream_from(addr, "127.0.0.2").await;
        stream.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n").await.expect("write");
        idle.push(stream);
    }
    let mut one_more = crate::util::stream_from(addr, "127.0.0.2").await;
    one_more.write_all(b"GET /info.json HTTP/1.1\r\nHost: x\r\n\r\n").await.expect("write");
    let mut answer = String::new();
    let _ = tokio::time::timeout(WAIT, one_more.read_to_string(&mut answer)).await.expect("in time");
    assert!(answer.starts_with("HTTP/1.1 429 ") && answer.contains("\r\nRetry-After: 1"), "{answer}");
    assert!(answer.contains(&format!("at most {share} requests at once from one address")), "{answer}");
    assert_eq!(get(addr, "/info.json").await.status, 200, "another address is served");
    for stream in idle {
        leave(stream).await;
    }
    task.abort();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_address_gets_its_share_of_websockets_counted_by_a_trusted_proxy_s_forwarded_address() {
    let limits = ServerConfig {
        max_per_source: 2,
        trusted_proxies: vec!["127.0.0.3".parse().expect("an address")],
        hello_timeout: std::time::Duration::from_secs(600),
        ..Default::default()
    };
    let (server, http) = web_server_limited(web_config(1), 0, limits).await;
    let _held = [
        try_ws_from(http, "127.0.0.2", &[]).await.expect("a first WebSocket"),
        try_ws_from(http, "127.0.0.2", &[]).await.expect("a second WebSocket"),
    ];
    // The third from the address is refused, even when it claims to come from elsewhere:
    // only a trusted proxy's X-Forwarded-For is believed.
    let third = try_ws_from(http, "127.0.0.2", &[("x-forwarded-for", "10.9.9.9")]).await;
    assert_eq!(refusal(&third), 429);
    assert!(ws(http).await.get_ref().peer_addr().is_ok(), "another address is let in");
    // Behind the proxy each client has its own share, by the address the proxy names.
    let via = |client: &'static str| async move {
        try_ws_from(http, "127.0.0.3", &[("x-forwarded-for", client)]).await
    };
    let _proxied = [via("10.0.0.1").await.expect("first"), via("10.0.0.1").await.expect("second")];
    assert_eq!(refusal(&via("10.0.0.1").await), 429);
    assert!(via("192.0.2.1, 10.0.0.2").await.is_ok(), "the last address the proxy names counts");
    server.stop().await;
}

/// Sends `request` to `addr` as is and reads the whole answer.
async fn raw(addr: SocketAddr, request: &str) -> String {
    let mut stream = tokio::net::TcpStream::connect(addr).await.expect("connect");
    let _ = stream.write_all(request.as_bytes()).await;
    let mut response = String::new();
    let _ = tokio::time::timeout(WAIT, stream.read_to_string(&mut response)).await.expect("in time");
    response
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn plain_requests_are_answered_only_on_the_server_s_own_names() {
    let limits =
        ServerConfig { allowed_origins: vec!["http://example.org:8080".into()], ..Default::default() };
    let (server, http) = web_server_limited(web_config(1), 0, limits).await;
    let port = http.port();
    let status = |answer: String| answer.split(' ').nth(1).unwrap_or_default().to_string();
    let on = |host: String| format!("GET /api/matches HTTP/1.1\r\nHost: {host}\r\n\r\n");
    // A name pointed at this server by someone else (DNS rebinding) does not read the API.
    let rebound = raw(http, &on(format!("evil.example:{port}"))).await;
    assert_eq!(status(rebound.clone()), "403", "{rebound}");
    assert!(rebound.contains("is not a name of this server"), "{rebound}");
    assert_eq!(status(raw(http, "GET / HTTP/1.1\r\n\r\n").await), "403", "no Host at all");
    for host in
        [format!("localhost:{port}"), format!("127.0.0.1:{port}"), "[::1]".into(), "example.org:8080".into()]
    {
        let answer = raw(http, &on(host.clone())).await;
        assert_eq!(status(answer.clone()), "200", "{host}: {answer}");
    }
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_answer_says_how_a_browser_may_use_it() {
    let (server, http) = web_server(0, 1).await;
    let page = get(http, "/").await;
    let missing = get(http, "/nowhere").await;
    assert_eq!((page.status, missing.status), (200, 404));
    for answer in [page, missing] {
        let head = answer.head.to_ascii_lowercase();
        let csp = head
            .lines()
            .find_map(|l| l.strip_prefix("content-security-policy: "))
            .unwrap_or_else(|| panic!("no Content-Security-Policy: {}", answer.head))
            .to_string();
        for directive in [
            "default-src 'self'",
            "script-src 'self'",
            &format!("connect-src 'self' ws://{http} wss://{http}"),
            "frame-ancestors 'self'",
            "object-src 'none'",
        ] {
            assert!(csp.contains(directive), "{directive} missing from {csp}");
        }
        for header in
            ["x-frame-options: sameorigin", "x-content-type-options: nosniff", "referrer-policy: no-referrer"]
        {
            assert!(head.contains(header), "{header} missing: {}", answer.head);
        }
    }
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_request_body_has_one_valid_length_or_is_refused() {
    let (server, http) = web_server(0, 1).await;
    let post = |lengths: &str| format!("POST /api/matches HTTP/1.1\r\nHost: {http}\r\n{lengths}\r\n{{}}");
    // Two lengths that differ, or one with a sign, could be read one way here and another
    // by a proxy in front: hyper refuses them before the request reaches the server.
    for lengths in
        ["Content-Length: 2\r\nContent-Length: 3\r\n", "Content-Length: +2\r\n", "Content-Length: 2, 3\r\n"]
    {
        let answer = raw(http, &post(lengths)).await;
        assert!(answer.starts_with("HTTP/1.1 400 "), "{lengths:?}: {answer}");
    }
    // One length, even said twice, is read: the API answers (it needs the operator).
    let answer = raw(http, &post("Content-Length: 2\r\nContent-Length: 2\r\n")).await;
    assert!(answer.starts_with("HTTP/1.1 401 "), "{answer}");
    server.stop().await;
}
