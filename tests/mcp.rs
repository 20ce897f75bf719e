use std::collections::HashMap;
use std::net::SocketAddr;
use std::time::Duration;

use bw4t_mcp::{Docs, HttpOptions, Link, LinkOptions, LocalMatch, RobotServer};
use bw4t_protocol::{ServerMessage, SessionOptions};
use serde_json::{Value, json};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

use crate::util::{Client, TestServer, WAIT, lockstep, shipped_map};

const TOKEN: &str = "0123456789abcdef0123456789abcdef";

/// An HTTP answer: status, headers (lower-case names) and the JSON-RPC messages in its
/// body (a JSON body, or the `data` of an event stream).
#[derive(Debug)]
struct Answer {
    status: u16,
    headers: HashMap<String, String>,
    body: String,
    messages: Vec<Value>,
}

impl Answer {
    /// The message answering request `id`.
    fn reply(&self, id: u64) -> &Value {
        self.messages
            .iter()
            .find(|m| m["id"] == json!(id))
            .unwrap_or_else(|| panic!("no answer to request {id} in {self:?}"))
    }
}

/// What a request carries besides its body.
#[derive(Clone, Default)]
struct Head<'a> {
    token: Option<&'a str>,
    origin: Option<&'a str>,
    session: Option<&'a str>,
    /// More headers, by name.
    more: &'a [(&'a str, &'a str)],
}

/// One POST of `body` to `/mcp`, read to its end (the connection closes after it).
async fn post(addr: SocketAddr, head: Head<'_>, body: &Value) -> Answer {
    request(addr, "POST", head, Some(body)).await
}

/// One request to `/mcp`, read to its end (the connection closes after it).
async fn request(addr: SocketAddr, method: &str, head: Head<'_>, body: Option<&Value>) -> Answer {
    let body = body.map(Value::to_string).unwrap_or_default();
    let mut request = format!(
        "{method} /mcp HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Type: application/json\r\n\
         Accept: application/json, text/event-stream\r\nContent-Length: {}\r\n",
        body.len()
    );
    for (name, value) in [
        ("Authorization", head.token.map(|t| format!("Bearer {t}"))),
        ("Origin", head.origin.map(String::from)),
    ]
    .into_iter()
    .chain([("Mcp-Session-Id", head.session.map(String::from))])
    .chain(head.more.iter().map(|&(name, value)| (name, Some(value.to_string()))))
    {
        if let Some(value) = value {
            request += &format!("{name}: {value}\r\n");
        }
    }
    request += "\r\n";
    request += &body;
    let mut stream = TcpStream::connect(addr).await.expect("connect");
    stream.write_all(request.as_bytes()).await.expect("send");
    let mut raw = Vec::new();
    tokio::time::timeout(WAIT, stream.read_to_end(&mut raw)).await.expect("an answer in time").expect("read");
    parse(&String::from_utf8_lossy(&raw))
}

fn parse(raw: &str) -> Answer {
    let (head, body) = raw.split_once("\r\n\r\n").unwrap_or_else(|| panic!("an HTTP answer: {raw:?}"));
    let mut lines = head.lines();
    let status = lines.next().and_then(|l| l.split(' ').nth(1)).and_then(|s| s.parse().ok()).expect("status");
    let headers: HashMap<String, String> = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(n, v)| (n.trim().to_ascii_lowercase(), v.trim().to_string()))
        .collect();
    let body = match headers.get("transfer-encoding") {
        Some(coding) if coding.eq_ignore_ascii_case("chunked") => unchunk(body),
        _ => body.to_string(),
    };
    let json = headers.get("content-type").is_some_and(|t| t.starts_with("application/json"));
    let messages = if json {
        serde_json::from_str(&body).into_iter().collect()
    } else {
        body.lines()
            .filter_map(|l| l.strip_prefix("data:"))
            .filter_map(|d| serde_json::from_str(d.trim()).ok())
            .collect()
    };
    Answer { status, headers, body, messages }
}

/// A chunked body's content.
fn unchunk(mut body: &str) -> String {
    let mut out = String::new();
    while let Some((size, rest)) = body.split_once("\r\n") {
        let Ok(size) = usize::from_str_radix(size.trim(), 16) else { break };
        if size == 0 || rest.len() < size {
            break;
        }
        out += &rest[..size];
        body = rest[size..].trim_start_matches("\r\n");
    }
    out
}

fn initialize() -> Value {
    json!({"jsonrpc": "2.0", "id": 1, "method": "initialize", "params": {
        "protocolVersion": "2025-06-18", "capabilities": {}, "clientInfo": {"name": "test", "version": "0"}}})
}

fn call(id: u64, tool: &str, arguments: Value) -> Value {
    json!({"jsonrpc": "2.0", "id": id, "method": "tools/call", "params": {"name": tool, "arguments": arguments}})
}

/// An initialized MCP session of the robot served at `addr`.
struct Session {
    addr: SocketAddr,
    id: String,
}

impl Session {
    async fn open(addr: SocketAddr) -> Session {
        let answer = post(addr, Head { token: Some(TOKEN), ..Head::default() }, &initialize()).await;
        assert_eq!(answer.status, 200, "{answer:?}");
        let id = answer.headers.get("mcp-session-id").expect("a session id").clone();
        let session = Session { addr, id };
        let initialized = json!({"jsonrpc": "2.0", "method": "notifications/initialized"});
        assert_eq!(session.post(&initialized).await.status, 202);
        session
    }

    async fn post(&self, body: &Value) -> Answer {
        post(self.addr, Head { token: Some(TOKEN), session: Some(&self.id), ..Head::default() }, body).await
    }

    /// Calls `tool`: its result (`structuredContent`), or the JSON-RPC error, or for a tool
    /// error (`isError`) its text as `message` beside its `structuredContent`.
    async fn call(&self, id: u64, tool: &str, arguments: Value) -> Result<Value, Value> {
        let answer = self.post(&call(id, tool, arguments)).await;
        assert_eq!(answer.status, 200, "{answer:?}");
        let reply = answer.reply(id);
        if let Some(error) = reply.get("error") {
            return Err(error.clone());
        }
        let result = &reply["result"];
        if result["isError"] == true {
            let text = result["content"][0]["text"].clone();
            return Err(json!({"message": text, "structuredContent": result["structuredContent"]}));
        }
        Ok(result["structuredContent"].clone())
    }

    async fn tick(&self, id: u64) -> u64 {
        self.call(id, "look", json!({})).await.expect("look")["tick"].as_u64().expect("tick")
    }

    /// Ends the session as a client does (`DELETE`): the HTTP status.
    async fn close(&self) -> u16 {
        let head = Head { token: Some(TOKEN), session: Some(&self.id), ..Head::default() };
        request(self.addr, "DELETE", head, None).await.status
    }
}

/// A match of its own on the fixed map (seed 1, alone, lockstep, `max_ticks`), its robot
/// served over HTTP with `options`; tool calls time out after `timeout`.
async fn own_match(max_ticks: u64, timeout: Duration, options: HttpOptions) -> SocketAddr {
    let map = shipped_map("fixed");
    let mut setup = LocalMatch::setup(map.clone(), "Model", &[]);
    setup.seed = 1;
    setup.max_ticks = Some(max_ticks);
    let started = LocalMatch { setup, deadline: None, replay: None }.start().await.expect("a match");
    let link = Link::join(started.addr, started.hello, WAIT, LinkOptions::default()).await.expect("joined");
    serve(link, Docs::new(Some(map)), timeout, options).await
}

async fn serve(link: Link, docs: Docs, timeout: Duration, options: HttpOptions) -> SocketAddr {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
    let addr = listener.local_addr().expect("addr");
    tokio::spawn(bw4t_mcp::serve_http(RobotServer::new(link, docs, timeout), listener, options));
    addr
}

fn options() -> HttpOptions {
    HttpOptions::new(TOKEN.into())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_visitor_without_the_token_is_refused_and_the_robot_stays_put() {
    let addr = own_match(20_000, WAIT, options()).await;
    let driver = Session::open(addr).await;
    assert_eq!(driver.tick(2).await, 0);

    let unknown = post(addr, Head::default(), &initialize()).await;
    assert_eq!(unknown.status, 401, "{unknown:?}");
    assert!(unknown.headers.get("www-authenticate").is_some_and(|v| v.starts_with("Bearer")));
    let message = unknown.messages.first().expect("a JSON-RPC error");
    assert!(
        message["error"]["message"].as_str().is_some_and(|m| m.contains("Authorization: Bearer")),
        "{message}"
    );
    let wrong = post(addr, Head { token: Some("not-the-token"), ..Head::default() }, &initialize()).await;
    assert_eq!(wrong.status, 401);
    assert!(wrong.body.contains("the bearer token is wrong"), "{wrong:?}");
    // Even inside the driver's session, a call without the token moves nothing.
    let intruder = Head { session: Some(&driver.id), ..Head::default() };
    let moved = post(addr, intruder, &call(3, "go_to", json!({"place": "RoomA1"}))).await;
    assert_eq!(moved.status, 401);

    let state = driver.call(4, "look", json!({})).await.expect("look");
    assert_eq!((state["tick"].as_u64(), state["state"]["at"].as_str()), (Some(0), Some("FrontDropZone")));
}

/// Asserts that `error` is the refusal of a session that does not drive the robot.
fn assert_driven_by_another(error: &Value, tool: &str) {
    let message = error["message"].as_str().unwrap_or_default();
    assert_eq!(error["code"], -32600, "{error}");
    assert!(
        message.starts_with(&format!("{tool}: the robot is driven by another MCP session, since ")),
        "{error}"
    );
    assert!(message.contains(" UTC (") && message.contains("HTTP DELETE"), "{error}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_first_session_to_call_a_tool_drives_and_the_others_are_refused() {
    let addr = own_match(20_000, WAIT, options()).await;
    let first = Session::open(addr).await;
    let second = Session::open(addr).await;
    let went = first.call(2, "go_to", json!({"place": "RoomA1"})).await.expect("the first drives");
    assert_eq!(went["outcome"], "arrived", "{went}");
    let (tick, at) = (went["tick"].clone(), went["state"]["at"].clone());
    assert_eq!(at, "RoomA1");

    assert_driven_by_another(
        &second.call(3, "go_to", json!({"place": "DropZone"})).await.expect_err("refused"),
        "go_to",
    );
    assert_driven_by_another(&second.call(4, "look", json!({})).await.expect_err("refused"), "look");
    // What any reader of the docs knows stays open to every session.
    let listed = second.post(&json!({"jsonrpc": "2.0", "id": 5, "method": "tools/list"})).await;
    assert!(listed.reply(5)["result"]["tools"].as_array().is_some_and(|t| !t.is_empty()), "{listed:?}");
    let read =
        json!({"jsonrpc": "2.0", "id": 6, "method": "resources/read", "params": {"uri": "bw4t://map"}});
    let map = second.post(&read).await;
    assert!(
        map.reply(6)["result"]["contents"][0]["text"].as_str().is_some_and(|t| t.contains("RoomA1")),
        "{map:?}"
    );

    let looked = first.call(7, "look", json!({})).await.expect("the first still drives");
    assert_eq!((&looked["tick"], &looked["state"]["at"]), (&tick, &at), "nobody else moved the robot");
    let back = first.call(8, "go_to", json!({"place": "DropZone"})).await.expect("the first still drives");
    assert_eq!(back["outcome"], "arrived", "{back}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn when_the_driving_session_ends_the_next_one_takes_the_robot() {
    let addr = own_match(20_000, WAIT, options()).await;
    let (first, second, third) =
        (Session::open(addr).await, Session::open(addr).await, Session::open(addr).await);
    assert_eq!(first.tick(2).await, 0);
    assert_driven_by_another(
        &second.call(3, "go_to", json!({"place": "RoomA1"})).await.expect_err("refused"),
        "go_to",
    );

    assert_eq!(first.close().await, 202);
    let gone = first.post(&call(4, "look", json!({}))).await;
    assert_eq!(gone.status, 404, "the first session is over: {gone:?}");
    let went = second.call(5, "go_to", json!({"place": "RoomA1"})).await.expect("the robot is free again");
    assert_eq!(
        (went["outcome"].as_str(), went["state"]["at"].as_str()),
        (Some("arrived"), Some("RoomA1")),
        "{went}"
    );
    // The seat is the second session's now.
    assert_driven_by_another(&third.call(6, "look", json!({})).await.expect_err("refused"), "look");
    assert_eq!(second.tick(7).await, went["tick"].as_u64().expect("tick"));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_driving_session_that_ends_mid_call_frees_the_robot_at_once() {
    // A lockstep match with a second player, this test, so that the first session's call
    // lasts as long as the test holds its `ready`.
    let (setup, mut config) = lockstep("fixed", 1, 2);
    config.deadline = None;
    let server = TestServer::start(setup, config).await;
    let link = Link::join(server.addr, SessionOptions::agent("Model", None), WAIT, LinkOptions::default())
        .await
        .expect("joined");
    let mut tester = Client::connect(server.addr).await;
    tester.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Tester", "every_tick": true})).await;
    tester.until(|m| matches!(m, ServerMessage::Percepts(_)).then_some(())).await;
    tester.send(json!({"type": "ready", "tick": 0})).await;

    let addr = serve(link, Docs::new(Some(shipped_map("fixed"))), WAIT, options()).await;
    let (first, second) = (Session::open(addr).await, Session::open(addr).await);
    let journey = {
        let (addr, id) = (addr, first.id.clone());
        tokio::spawn(async move {
            let head = Head { token: Some(TOKEN), session: Some(&id), ..Head::default() };
            post(addr, head, &call(2, "go_to", json!({"place": "RoomA1"}))).await
        })
    };
    // Tick 1 comes only once the robot answered tick 0: the journey is under way.
    tester.until(|m| matches!(m, ServerMessage::Percepts(p) if p.tick == 1).then_some(())).await;
    assert_driven_by_another(&second.call(3, "put_down", json!({})).await.expect_err("refused"), "put_down");

    assert_eq!(first.close().await, 202);
    let put_down = {
        let (addr, id) = (addr, second.id.clone());
        tokio::spawn(async move { Session { addr, id }.call(4, "put_down", json!({})).await })
    };
    let answering = tokio::spawn(async move {
        tester.send(json!({"type": "ready", "tick": 1})).await;
        while let Some(message) = tester.recv().await {
            if let ServerMessage::Percepts(p) = message {
                tester.send(json!({"type": "ready", "tick": p.tick})).await;
            }
        }
    });
    let put_down = tokio::time::timeout(WAIT, put_down).await.expect("in time").expect("task");
    // Not `busy` with the first session's journey: that ended with its session.
    let put_down = put_down.expect("the robot took the order");
    assert_eq!(put_down["outcome"], "rejected", "{put_down}");
    assert!(put_down["reason"].as_str().is_some_and(|r| r.starts_with("not_holding")), "{put_down}");
    journey.abort();
    answering.abort();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_call_outside_any_session_drives_nothing() {
    let addr = own_match(20_000, WAIT, options()).await;
    // The sessionless revision of MCP: the version in every request, no `initialize`.
    let version = "2026-07-28";
    let mut go = call(2, "go_to", json!({"place": "RoomA1"}));
    go["params"]["_meta"] = json!({
        "io.modelcontextprotocol/protocolVersion": version,
        "io.modelcontextprotocol/clientCapabilities": {},
        "io.modelcontextprotocol/clientInfo": {"name": "test", "version": "0"},
    });
    let more = [("MCP-Protocol-Version", version), ("Mcp-Method", "tools/call"), ("Mcp-Name", "go_to")];
    let sessionless = Head { token: Some(TOKEN), more: &more, ..Head::default() };
    let made_up = Head { session: Some("made-up"), ..sessionless.clone() };
    for head in [sessionless, made_up] {
        let answer = post(addr, head, &go).await;
        let error = &answer.reply(2)["error"];
        let message = error["message"].as_str().unwrap_or_default();
        assert!(
            message.starts_with("go_to: over HTTP the robot is driven from one MCP session"),
            "{answer:?}"
        );
    }
    // Nothing moved, and no made-up session holds the robot.
    let driver = Session::open(addr).await;
    assert_eq!(driver.tick(3).await, 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn browser_pages_from_other_origins_are_refused() {
    let addr = own_match(20_000, WAIT, options()).await;
    let with_origin = |origin| Head { token: Some(TOKEN), origin, ..Head::default() };
    let evil = post(addr, with_origin(Some("http://evil.example")), &initialize()).await;
    assert_eq!(evil.status, 403, "{evil:?}");
    assert!(evil.body.contains("http://evil.example"), "{evil:?}");
    let local = format!("http://127.0.0.1:{}", addr.port());
    assert_eq!(post(addr, with_origin(Some(&local)), &initialize()).await.status, 200);
    assert_eq!(post(addr, with_origin(None), &initialize()).await.status, 200, "not a browser page");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_over_long_say_is_a_tool_error_before_anything_is_sent() {
    // Were a line too long for the protocol sent, the match would drop it and the call
    // would run until its timeout with the robot answering every tick: the whole match in
    // a moment. Free text is bounded well below that: every teammate reads it.
    let addr = own_match(20_000, Duration::from_secs(5), options()).await;
    let driver = Session::open(addr).await;
    let long = "x".repeat(70_000);
    let error = driver.call(2, "say", json!({"text": long})).await.expect_err("refused");
    let message = error["message"].as_str().unwrap_or_default();
    assert!(message.contains("say: the text is 70000 characters long; the most is 280"), "{error}");
    assert_eq!(error["structuredContent"]["outcome"], "invalid", "{error}");
    let error = driver.call(3, "say", json!({"kind": "contains", "room": long, "colour": "Red"})).await;
    assert!(error.expect_err("refused")["message"].as_str().is_some_and(|m| m.contains("room is")));
    let error = driver.call(4, "go_to", json!({"place": long})).await;
    assert!(error.expect_err("refused")["message"].as_str().is_some_and(|m| m.contains("place is")));
    let error = driver.call(5, "wait", json!({"ticks": 1_000_000})).await;
    assert!(error.expect_err("refused")["message"].as_str().is_some_and(|m| m.contains("from 1 to 72000")));
    assert_eq!(driver.tick(6).await, 0, "the match has not moved");
    // A say that fits is sent and answered in its tick.
    let said = driver.call(7, "say", json!({"text": "x".repeat(280)})).await.expect("said");
    assert_eq!((said["outcome"].as_str(), said["tick"].as_u64()), (Some("done"), Some(1)), "{said}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn wait_seconds_in_lockstep_are_simulated_seconds() {
    let addr = own_match(20_000, WAIT, options()).await;
    let driver = Session::open(addr).await;
    let waited = driver.call(2, "wait", json!({"seconds": 5})).await.expect("waited");
    assert_eq!(waited["outcome"], "timeout", "{waited}");
    assert_eq!((waited["ticks"].as_u64(), waited["tick"].as_u64()), (Some(100), Some(100)), "5 s at 20 Hz");
    assert_eq!(waited["ended"], false);
    // So is a call with no limit of its own: at most its timeout in simulated time.
    let waited = driver.call(3, "wait", json!({})).await.expect("waited");
    let ticks = WAIT.as_secs() * 20;
    assert_eq!(
        (waited["outcome"].as_str(), waited["ticks"].as_u64()),
        (Some("timeout"), Some(ticks)),
        "{waited}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cancelled_call_frees_the_robot_at_once() {
    // A lockstep match with a second player, this test, so that the robot's calls last
    // as long as the test holds its `ready`.
    let (setup, mut config) = lockstep("fixed", 1, 2);
    config.deadline = None;
    let server = TestServer::start(setup, config).await;
    let link = Link::join(server.addr, SessionOptions::agent("Model", None), WAIT, LinkOptions::default())
        .await
        .expect("joined");
    let mut tester = Client::connect(server.addr).await;
    // Told of every tick, the test holds each one until it says `ready`.
    tester.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": "Tester", "every_tick": true})).await;
    tester.until(|m| matches!(m, ServerMessage::Percepts(_)).then_some(())).await;
    tester.send(json!({"type": "ready", "tick": 0})).await;

    let addr = serve(link, Docs::new(Some(shipped_map("fixed"))), WAIT, options()).await;
    let driver = Session::open(addr).await;
    let journey = {
        let (addr, id) = (addr, driver.id.clone());
        tokio::spawn(async move {
            let head = Head { token: Some(TOKEN), session: Some(&id), ..Head::default() };
            post(addr, head, &call(2, "go_to", json!({"place": "RoomA1"}))).await
        })
    };
    // Tick 1 comes only once the robot answered tick 0: the journey is under way.
    tester.until(|m| matches!(m, ServerMessage::Percepts(p) if p.tick == 1).then_some(())).await;
    let cancel = json!({"jsonrpc": "2.0", "method": "notifications/cancelled",
        "params": {"requestId": 2, "reason": "the model changed its mind"}});
    assert_eq!(driver.post(&cancel).await.status, 202);
    let put_down = {
        let (addr, id) = (addr, driver.id.clone());
        tokio::spawn(async move { Session { addr, id }.call(3, "put_down", json!({})).await })
    };
    // From here the test answers every tick, so the order can be carried out.
    let answering = tokio::spawn(async move {
        tester.send(json!({"type": "ready", "tick": 1})).await;
        while let Some(message) = tester.recv().await {
            if let ServerMessage::Percepts(p) = message {
                tester.send(json!({"type": "ready", "tick": p.tick})).await;
            }
        }
    });
    let put_down = tokio::time::timeout(WAIT, put_down).await.expect("in time").expect("task");
    let put_down = put_down.expect("the robot took the order");
    assert_eq!(put_down["outcome"], "rejected", "{put_down}");
    assert!(put_down["reason"].as_str().is_some_and(|r| r.starts_with("not_holding")), "{put_down}");
    journey.abort();
    answering.abort();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn idle_connections_are_capped_and_closed_when_their_head_is_late() {
    let mut options = options();
    options.max_connections = 2;
    options.header_timeout = Duration::from_millis(300);
    let addr = own_match(20_000, WAIT, options).await;
    let mut idle = Vec::new();
    for _ in 0..2 {
        idle.push(TcpStream::connect(addr).await.expect("connect"));
    }
    // Connections are taken in the order they came, so both places are held by the time
    // a third is: it is refused at once rather than waiting for them.
    let refused = post(addr, Head { token: Some(TOKEN), ..Head::default() }, &initialize()).await;
    assert_eq!(refused.status, 503, "{refused:?}");
    assert!(refused.body.contains("at most 2 connections"), "{refused:?}");
    for mut stream in idle {
        let mut byte = [0u8; 1];
        let read = tokio::time::timeout(WAIT, stream.read(&mut byte)).await.expect("closed in time");
        assert!(matches!(read, Ok(0) | Err(_)), "the server closed the silent connection");
    }
    let answer = post(addr, Head { token: Some(TOKEN), ..Head::default() }, &initialize()).await;
    assert_eq!(answer.status, 200, "{answer:?}");
}

#[test]
fn running_out_of_file_descriptors_does_not_end_the_server() {
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};
    // `ulimit -n 48`: the server's table fills with a few dozen connections.
    let bw4t = env!("CARGO_BIN_EXE_bw4t");
    let script = format!(
        "ulimit -n 48 && exec {bw4t} mcp --map fixed --seed 1 --http 127.0.0.1:0 --http-token {TOKEN}"
    );
    let mut child = Command::new("sh")
        .args(["-c", &script])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start bw4t mcp");
    let (lines_tx, lines) = std::sync::mpsc::channel();
    let stderr = child.stderr.take().expect("stderr");
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = lines_tx.send(line);
        }
    });
    let mut said = Vec::new();
    let addr: SocketAddr = loop {
        let line = lines.recv_timeout(WAIT).unwrap_or_else(|_| panic!("no address; it said {said:?}"));
        if let Some(url) = line.split("http://").nth(1) {
            break url.trim_end_matches("/mcp").parse().expect("an address");
        }
        said.push(line);
    };
    let runtime =
        tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().expect("rt");
    let answer = runtime.block_on(async {
        let mut open = Vec::new();
        for _ in 0..100 {
            open.push(TcpStream::connect(addr).await.expect("the kernel queues what is not accepted"));
        }
        // Accepting fails now; the failure is said, and the server waits for room.
        loop {
            let line = lines.recv_timeout(WAIT).expect("the server says accepting fails");
            if line.contains("cannot accept a connection") {
                break;
            }
        }
        drop(open);
        post(addr, Head { token: Some(TOKEN), ..Head::default() }, &initialize()).await
    });
    let alive = child.try_wait().expect("status").is_none();
    let _ = child.kill();
    let _ = child.wait();
    assert!(alive, "bw4t mcp is still running");
    assert_eq!(answer.status, 200, "{answer:?}");
}

#[test]
fn the_map_text_lists_every_connection_both_ways_on_every_shipped_map() {
    let maps = crate::agents::shipped_maps();
    assert!(maps.len() >= 7, "{} maps", maps.len());
    for (name, map) in maps {
        let text = Docs::new(Some(map.clone())).map_text();
        // What the text says: each place's line, `- NAME (what): connects to A, B`.
        let mut said = std::collections::BTreeSet::new();
        let mut listed = std::collections::BTreeSet::new();
        for line in text.lines().filter_map(|l| l.strip_prefix("- ")) {
            let (place, rest) = line.split_once(" (").expect("a place's line");
            let (_, list) = rest.split_once("): connects to ").expect("its connections");
            listed.insert(place.to_string());
            for other in list.split(", ").filter(|o| !o.is_empty()) {
                said.insert((place.to_string(), other.to_string()));
            }
        }
        // What the graph says: every walkable place, every edge from either side.
        let zones = map.zones();
        let walkable: std::collections::BTreeSet<String> =
            zones.iter().filter(|z| z.kind.is_walkable()).map(|z| z.name.clone()).collect();
        assert_eq!(listed, walkable, "map {name}: the places listed");
        let mut graph = std::collections::BTreeSet::new();
        for (i, zone) in zones.iter().enumerate().filter(|(_, z)| z.kind.is_walkable()) {
            for &j in map.neighbours(i) {
                graph.insert((zone.name.clone(), zones[j].name.clone()));
            }
        }
        assert_eq!(said, graph, "map {name}: the connections");
        for (a, b) in &said {
            assert!(said.contains(&(b.clone(), a.clone())), "map {name}: {a} -> {b} one way only");
        }
        let isolated: Vec<&String> = listed.iter().filter(|p| !said.iter().any(|(a, _)| a == *p)).collect();
        assert!(isolated.is_empty(), "map {name}: connected to nothing: {isolated:?}");
    }
}
