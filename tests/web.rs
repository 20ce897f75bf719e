use bw4t_protocol::{Mode, ServerMessage, decode_server};
use futures_util::{SinkExt, StreamExt};
use serde_json::{Value, json};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::Message;

use crate::util::{TestServer, WAIT, lockstep};

/// A plain HTTP GET: (status line, body), or `None` when the server closed the connection
/// without answering.
async fn try_get(addr: std::net::SocketAddr, path: &str) -> Option<(String, String)> {
    let mut stream = tokio::net::TcpStream::connect(addr).await.expect("connect");
    let _ = stream.write_all(format!("GET {path} HTTP/1.1\r\nHost: test\r\n\r\n").as_bytes()).await;
    let mut response = String::new();
    let _ = tokio::time::timeout(WAIT, stream.read_to_string(&mut response)).await.expect("in time");
    let (head, body) = response.split_once("\r\n\r\n")?;
    Some((head.lines().next().unwrap_or("").to_string(), body.to_string()))
}

/// A plain HTTP GET that must be answered.
async fn get(addr: std::net::SocketAddr, path: &str) -> (String, String) {
    try_get(addr, path).await.expect("an answer")
}

type Ws = tokio_tungstenite::WebSocketStream<tokio::net::TcpStream>;

/// The next server message on a WebSocket, within [`WAIT`].
async fn next(ws: &mut Ws) -> ServerMessage {
    match tokio::time::timeout(WAIT, ws.next()).await.expect("a message in time") {
        Some(Ok(Message::Text(t))) => decode_server(&t).expect("a server message"),
        other => panic!("unexpected {other:?}"),
    }
}

async fn web_server(builtin: usize, robots: usize) -> (TestServer, std::net::SocketAddr) {
    let mut config = lockstep("fixed", 4, robots);
    config.mode = Mode::Realtime;
    config.game.ticks_per_second = 100;
    let http = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
    let http_addr = http.local_addr().expect("addr");
    let seats = (1..=builtin)
        .map(|i| {
            bw4t_server::Seat::Local(
                format!("Bot{i}"),
                bw4t_agents::Strategy::Cooperative.agent(&format!("Bot{i}")),
            )
        })
        .collect();
    let extras = bw4t_server::Extras { seats, http: Some(http), ..Default::default() };
    (TestServer::start_with(config, extras).await, http_addr)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_and_the_map_layout_are_served() {
    let (server, http) = web_server(1, 1).await;
    let (status, page) = get(http, "/").await;
    assert!(status.contains("200") && page.contains("<html"), "{status}");
    for path in ["/app.js", "/style.css"] {
        assert!(get(http, path).await.0.contains("200"), "{path}");
    }
    let (_, info) = get(http, "/info.json").await;
    let info: Value = serde_json::from_str(&info).expect("json");
    assert_eq!(info["mode"], "live");
    let (_, layout) = get(http, "/map.json").await;
    let layout: Value = serde_json::from_str(&layout).expect("json");
    let zones = layout["zones"].as_array().expect("zones");
    let room = zones.iter().find(|z| z["name"] == "RoomA1").expect("RoomA1");
    assert_eq!(
        (room["x"].as_f64(), room["y"].as_f64(), room["w"].as_f64()),
        (Some(10.0), Some(10.0), Some(10.0))
    );
    assert_eq!(room["doors"].as_array().map(Vec::len), Some(1));
    assert!(get(http, "/nothing-here").await.0.contains("404"));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_speaks_the_protocol_over_websocket() {
    let (server, http) = web_server(1, 2).await;
    let connect = || async {
        let stream = tokio::net::TcpStream::connect(http).await.expect("connect");
        let (ws, _) =
            tokio_tungstenite::client_async(format!("ws://{http}/ws"), stream).await.expect("handshake");
        ws
    };
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
    let buffer = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    struct Shared(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);
    impl std::io::Write for Shared {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            self.0.lock().expect("lock").extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let map = crate::util::shipped_map("fixed");
    let config = bw4t_sim::MatchConfig::default();
    let blank = bw4t_sim::Match::new(&map, &config, 3).expect("match");
    let mut recorder = bw4t_protocol::Recorder::new(
        Box::new(Shared(buffer.clone())),
        &blank,
        "test",
        vec!["Bot1".into()],
        100,
    );
    let seats = vec![bw4t_runner::Seat {
        name: "Bot1".into(),
        agent: bw4t_agents::Strategy::Cooperative.agent("Bot1"),
    }];
    let (game, reason) =
        bw4t_runner::play_headless(&map, &config, 3, seats, 400, Some(&mut recorder)).expect("play");
    recorder.finish(&game, reason).expect("written");
    let text = String::from_utf8(buffer.lock().expect("lock").clone()).expect("utf-8");
    let (_, _, frames) = bw4t_runner::replay_frames(&text).expect("frames");
    assert_eq!(frames.len() as u64, game.tick() + 1, "a frame per tick, 0 included");
    assert!(frames.iter().enumerate().all(|(i, f)| f.tick == i as u64));
    let robot = |t: usize| (frames[t].robots[0].x, frames[t].robots[0].y);
    assert_ne!(robot(0), robot(100), "the robot moved");
    // Served over HTTP.
    let site = bw4t_server::Site {
        map_json: bw4t_protocol::map_layout(&map).to_string(),
        info_json: json!({"mode": "replay"}).to_string(),
        replay: Some((json!({"ticks": frames.len() - 1}).to_string(), frames)),
    };
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
    let addr = listener.local_addr().expect("addr");
    let ids = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(1));
    let task = tokio::spawn(bw4t_server::serve_site(listener, std::sync::Arc::new(site), None, ids, 8, 16));
    let (_, frame) = get(addr, "/replay/frame/100").await;
    let frame: Value = serde_json::from_str(&frame).expect("json");
    assert_eq!(frame["tick"], 100);
    assert!(get(addr, "/replay/frame/99999").await.0.contains("404"));
    assert!(get(addr, "/replay.json").await.1.contains("\"ticks\""));
    task.abort();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_web_port_has_a_connection_limit() {
    let mut config = lockstep("fixed", 4, 1);
    config.max_connections = 2;
    let http = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
    let addr = http.local_addr().expect("addr");
    let server =
        TestServer::start_with(config, bw4t_server::Extras { http: Some(http), ..Default::default() }).await;
    // Two connections that never finish their request hold both places.
    let _a = tokio::net::TcpStream::connect(addr).await.expect("connect");
    let _b = tokio::net::TcpStream::connect(addr).await.expect("connect");
    // Once the server has taken both, a third request is closed unanswered.
    let refused = async { while try_get(addr, "/info.json").await.is_some() {} };
    tokio::time::timeout(WAIT, refused).await.expect("a refusal in time");
    drop((_a, _b));
    // With the places free again, requests are served.
    let served = async {
        while !try_get(addr, "/info.json").await.is_some_and(|(status, _)| status.contains("200")) {}
    };
    tokio::time::timeout(WAIT, served).await.expect("served again");
    server.stop().await;
}
