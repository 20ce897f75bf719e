use std::collections::BTreeMap;

use bw4t_map::{Map, MapParts};
use bw4t_protocol::Knowledge;
use bw4t_sim::{Action, Match, MatchConfig, OrderOutcome, Percept, Receiver, RobotId};

/// Bytes written through clones of it (a replay recorder's output), read back as text.
#[derive(Clone, Default)]
pub struct SharedBuffer(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);

impl SharedBuffer {
    /// Everything written so far, as UTF-8.
    pub fn text(&self) -> String {
        String::from_utf8(self.0.lock().expect("lock").clone()).expect("utf-8")
    }
}

impl std::io::Write for SharedBuffer {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.lock().expect("lock").extend_from_slice(bytes);
        Ok(bytes.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Folders of the repository that are made, not kept (build output, installed packages,
/// what runs write): never part of what the documents may name, never linked into a
/// document example's sandbox.
pub const MADE_FOLDERS: [&str; 6] = ["target", ".git", "node_modules", "test-output", "runs", "dist"];

/// A map shipped in `maps/`, by file name without extension.
pub fn shipped_map(name: &str) -> Map {
    let path = format!("{}/maps/{name}.toml", repo_root!());
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    Map::from_native(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// A file under `tests/fixtures/`, by its path there.
pub fn fixture_path(file: &str) -> std::path::PathBuf {
    std::path::Path::new(repo_root!()).join("tests/fixtures").join(file)
}

/// The text of a file under `tests/fixtures/`.
pub fn fixture_text(file: &str) -> String {
    let path = fixture_path(file);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The two-room test map (`tests/fixtures/two-rooms.toml`): a hall over the drop zone and
/// RoomA, which holds the one red block of the sequence; spawn points at (5, 5) and (9, 5).
pub const TWO_ROOMS: &str = include_str!("fixtures/two-rooms.toml");

/// The two-room test map with `edit` applied to what its file says.
pub fn two_rooms(edit: impl FnOnce(&mut MapParts)) -> Map {
    let mut parts = Map::from_native(TWO_ROOMS).expect("the two-room fixture").parts().clone();
    edit(&mut parts);
    Map::new(parts).expect("the edited two-room map")
}

/// The variable that names a folder of original BW4T map files (the original distribution's
/// `setup/maps/`). The tests that read it are `#[ignore]`d, so that a plain `cargo test`
/// lists them as skipped; `./test.sh` runs them when the variable is set.
pub const ORIGINAL_MAPS_VAR: &str = "BW4T_ORIGINAL_MAPS";

/// A file of the original BW4T maps folder named by [`ORIGINAL_MAPS_VAR`], by its path
/// there; fails the test, saying what to set, when the variable or the file is missing.
pub fn original_map_path(file: &str) -> std::path::PathBuf {
    let dir = std::env::var_os(ORIGINAL_MAPS_VAR).unwrap_or_else(|| {
        panic!("{ORIGINAL_MAPS_VAR} is not set: set it to a folder of the original BW4T map files")
    });
    // A relative folder is the repository's, as the command line that set it meant: the
    // tests themselves run in the `bw4t` package's folder.
    let dir = std::path::Path::new(repo_root!()).join(dir);
    assert!(dir.is_dir(), "{ORIGINAL_MAPS_VAR}={} is not a folder", dir.display());
    let path = dir.join(file);
    assert!(path.is_file(), "{ORIGINAL_MAPS_VAR}: no original map '{file}' in {}", dir.display());
    path
}

/// The text of an original BW4T map file (see [`original_map_path`]).
pub fn original_map_text(file: &str) -> String {
    let path = original_map_path(file);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A match with players joined in order, each polled into its own knowledge every tick.
pub struct Scenario {
    pub game: Match,
    robots: BTreeMap<String, RobotId>,
    knowledge: BTreeMap<String, Knowledge>,
    heard: BTreeMap<String, Vec<String>>,
    last: BTreeMap<String, Result<(), String>>,
    ended: BTreeMap<String, OrderOutcome>,
}

/// How long a `run until` may take before the scenario fails.
const UNTIL_LIMIT: u64 = 3000;

impl Scenario {
    pub fn new(map: &Map, config: &MatchConfig, seed: u64, players: &[&str]) -> Scenario {
        let mut game = Match::new(map, config, seed).expect("match");
        let mut robots = BTreeMap::new();
        for name in players {
            robots.insert(name.to_string(), game.join(name).expect("join"));
        }
        let mut s = Scenario {
            game,
            robots,
            knowledge: BTreeMap::new(),
            heard: BTreeMap::new(),
            last: BTreeMap::new(),
            ended: BTreeMap::new(),
        };
        s.poll();
        s
    }

    fn id(&self, name: &str) -> RobotId {
        *self.robots.get(name).unwrap_or_else(|| panic!("no player {name}"))
    }

    fn poll(&mut self) {
        for (name, &id) in &self.robots {
            let delta = self.game.poll_percepts(id).expect("robot in match");
            let knowledge = self.knowledge.entry(name.clone()).or_default();
            knowledge.apply(delta.tick, &delta);
            let heard = self.heard.entry(name.clone()).or_default();
            heard.extend(
                knowledge.latest_messages().iter().map(|h| format!("message({},{})", h.from, h.text)),
            );
        }
    }

    pub fn step(&mut self) {
        let report = self.game.step();
        for end in report.ended {
            let name = self.robots.iter().find(|(_, id)| **id == end.robot).map(|(n, _)| n.clone());
            self.ended.insert(name.expect("known robot"), end.outcome);
        }
        self.poll();
    }

    pub fn sees(&self, name: &str, fact: &str) -> bool {
        self.knowledge[name].facts().iter().any(|p| p.to_string() == fact)
    }

    fn act(&mut self, name: &str, action: Action) {
        let result =
            self.game.handle_action(self.id(name), &action).map(|_| ()).map_err(|r| r.code().to_string());
        self.last.insert(name.to_string(), result);
    }

    /// The lowest-id block of `colour` this player sees.
    fn block_of_colour(&self, name: &str, colour: &str) -> Option<u32> {
        let visible = self.knowledge[name].visible();
        visible.iter().find(|(_, c)| c.name().eq_ignore_ascii_case(colour)).map(|(b, _)| *b)
    }

    /// Runs one script line; panics with the line when it does not hold.
    pub fn line(&mut self, line: &str) {
        let words: Vec<&str> = line.split_whitespace().collect();
        let fail = |why: String| -> ! { panic!("scenario line `{line}`: {why}") };
        match words.as_slice() {
            ["run", n] => (0..n.parse::<u64>().expect("tick count")).for_each(|_| self.step()),
            ["run", "until", who, fact] => {
                // At least one tick, so a fact that held before an order cannot end the wait.
                self.step();
                let mut ticks = 1;
                while !self.sees(who, fact) {
                    if ticks == UNTIL_LIMIT {
                        fail(format!("not true after {UNTIL_LIMIT} ticks; {who} sees {:?}", self.facts(who)));
                    }
                    self.step();
                    ticks += 1;
                }
            }
            ["match", "sequenceIndex", n] => {
                let got = self.game.sequence_index().to_string();
                if got != *n {
                    fail(format!("sequence index is {got}"));
                }
            }
            ["match", "drops", good, wrong] => {
                let s = self.game.stats();
                if s.good_drops.to_string() != *good || s.wrong_drops.to_string() != *wrong {
                    fail(format!("good {} wrong {}", s.good_drops, s.wrong_drops));
                }
            }
            ["match", "blocks", n] => {
                let left = self.game.blocks().filter(|(_, _, p)| *p != bw4t_sim::BlockPlace::Gone).count();
                if left.to_string() != *n {
                    fail(format!("{left} blocks in the world"));
                }
            }
            [who, "goTo", place] => self.act(who, Action::GoTo(place.to_string())),
            [who, "goToBlock", block] => {
                let id = block.parse().ok().or_else(|| self.block_of_colour(who, block));
                let id = id.unwrap_or_else(|| fail(format!("{who} sees no {block} block")));
                self.act(who, Action::GoToBlock(id));
            }
            [who, "pickUp"] => self.act(who, Action::PickUp(None)),
            [who, "pickUp", block] => {
                let id = block.parse().ok().or_else(|| self.block_of_colour(who, block));
                self.act(who, Action::PickUp(Some(id.unwrap_or_else(|| fail(format!("no {block} block"))))));
            }
            [who, "putDown"] => self.act(who, Action::PutDown),
            [who, "say", to, text @ ..] => {
                let to = if *to == "all" { Receiver::All } else { Receiver::Player(to.to_string()) };
                self.act(who, Action::SendMessage { to, text: text.join(" ") });
            }
            [who, "leaves"] => {
                let id = self.id(who);
                self.game.leave(id).expect("leave");
                self.robots.remove(*who);
            }
            [who, "ok"] => {
                if self.last.get(*who) != Some(&Ok(())) {
                    fail(format!("last action: {:?}", self.last.get(*who)));
                }
            }
            [who, "rejected", code] => {
                if self.last.get(*who) != Some(&Err(code.to_string())) {
                    fail(format!("last action: {:?}", self.last.get(*who)));
                }
            }
            [who, "ended", outcome] => {
                let got = self.ended.get(*who).map(|o| o.name());
                if got != Some(*outcome) {
                    fail(format!("last order ended {got:?}"));
                }
            }
            [who, "sees", facts @ ..] => {
                for fact in facts {
                    if !self.sees(who, fact) {
                        fail(format!("{who} does not see {fact}; sees {:?}", self.facts(who)));
                    }
                }
            }
            [who, "lacks", facts @ ..] => {
                for fact in facts {
                    if self.sees(who, fact) {
                        fail(format!("{who} sees {fact}"));
                    }
                }
            }
            [who, "heard", messages @ ..] => {
                let heard = &self.heard[*who];
                let expected: Vec<String> = messages.iter().map(|m| m.to_string()).collect();
                if heard != &expected {
                    fail(format!("{who} heard {heard:?}"));
                }
            }
            _ => fail("unknown line".to_string()),
        }
    }

    pub fn facts(&self, name: &str) -> Vec<String> {
        let facts = self.knowledge[name].facts();
        facts.iter().filter(|p| !matches!(p, Percept::Place(_))).map(|p| p.to_string()).collect()
    }
}

/// Runs a scenario script (one instruction per line, `#` starts a comment).
pub fn check(map: &Map, config: &MatchConfig, seed: u64, players: &[&str], script: &str) -> Scenario {
    let mut scenario = Scenario::new(map, config, seed, players);
    for line in script.lines().map(|l| l.split('#').next().unwrap_or("").trim()).filter(|l| !l.is_empty()) {
        scenario.line(line);
    }
    scenario
}

/// [`check`] on the fixed-content map with the default configuration and seed 1.
pub fn check_fixed(players: &[&str], script: &str) -> Scenario {
    check(&shipped_map("fixed"), &MatchConfig::default(), 1, players, script)
}

// ---------------------------------------------------------------------------------------
// Network helpers: a server on 127.0.0.1:0 and line clients, every wait bounded.

use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use bw4t_protocol::{
    ActId, ClientSession, MatchResult, ServerMessage, SessionEvent, SessionOptions, decode_server,
};
use bw4t_server::{HostConfig, MatchSetup, Seat};
use bw4t_sim::PerceptDelta;
use serde_json::{Value, json};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpStream;
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};
use tokio::sync::{oneshot, watch};
use tokio::task::JoinHandle;

/// How long any single wait in a network test may take before the test fails.
pub const WAIT: Duration = Duration::from_secs(20);

/// A server serving one match in the test's runtime.
pub struct TestServer {
    pub addr: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    task: JoinHandle<MatchResult>,
}

impl TestServer {
    pub async fn start(setup: MatchSetup, config: HostConfig) -> TestServer {
        TestServer::start_with(setup, config, bw4t_server::Extras::default()).await
    }

    /// A server of a match as [`lockstep`] makes one.
    pub async fn start_pair((setup, config): (MatchSetup, HostConfig)) -> TestServer {
        TestServer::start(setup, config).await
    }

    /// A server with these limits on connections.
    pub async fn start_limited(
        setup: MatchSetup,
        config: HostConfig,
        server: bw4t_server::ServerConfig,
    ) -> TestServer {
        TestServer::start_with(setup, config, bw4t_server::Extras { server, ..Default::default() }).await
    }

    /// A server with a replay, the web port, or seats whose players will not come.
    pub async fn start_with(
        setup: MatchSetup,
        config: HostConfig,
        extras: bw4t_server::Extras,
    ) -> TestServer {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let addr = listener.local_addr().expect("addr");
        let (stop, stopped) = oneshot::channel::<()>();
        let task = tokio::spawn(async move {
            let shutdown = async {
                let _ = stopped.await;
            };
            bw4t_server::serve_with(listener, setup, config, extras, shutdown).await.expect("serve")
        });
        TestServer { addr, stop: Some(stop), task }
    }

    /// Stops the match (as Ctrl-C would) and returns its result.
    pub async fn stop(mut self) -> MatchResult {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        self.finish().await
    }

    /// Waits for the match to end by itself.
    pub async fn finish(self) -> MatchResult {
        let _keep_running = self.stop;
        tokio::time::timeout(WAIT, self.task).await.expect("match ends in time").expect("server task")
    }
}

/// `robots` open seats: for whoever joins.
pub fn open_seats(robots: usize) -> Vec<Seat> {
    std::iter::repeat_with(Seat::open).take(robots).collect()
}

/// A match on a shipped map of `robots` open seats, served lockstep.
pub fn lockstep(map: &str, seed: u64, robots: usize) -> (MatchSetup, HostConfig) {
    let setup = MatchSetup { seed, seats: open_seats(robots), ..MatchSetup::new(shipped_map(map)) };
    let mut config = HostConfig::new();
    config.mode = bw4t_protocol::Mode::Lockstep;
    config.deadline = Some(Duration::from_secs(10));
    (setup, config)
}

/// A TCP connection to `addr` from the loopback address `from`.
pub async fn stream_from(addr: SocketAddr, from: &str) -> TcpStream {
    let socket = tokio::net::TcpSocket::new_v4().expect("socket");
    socket.bind(SocketAddr::new(from.parse().expect("an address"), 0)).expect("bind a loopback address");
    socket.connect(addr).await.expect("connect")
}

/// A raw line client.
pub struct Client {
    lines: tokio::io::Lines<BufReader<OwnedReadHalf>>,
    writer: OwnedWriteHalf,
}

impl Client {
    pub async fn connect(addr: SocketAddr) -> Client {
        Client::from_stream(TcpStream::connect(addr).await.expect("connect"))
    }

    /// A client connecting from the loopback address `from` (`127.0.0.2`, ...): another
    /// source address on this machine.
    pub async fn connect_from(addr: SocketAddr, from: &str) -> Client {
        Client::from_stream(stream_from(addr, from).await)
    }

    /// A client whose socket takes in little before the server's writes block, so a client
    /// that does not read fills the server's queue quickly.
    pub async fn connect_small(addr: SocketAddr) -> Client {
        let socket = tokio::net::TcpSocket::new_v4().expect("socket");
        socket.set_recv_buffer_size(4096).expect("buffer size");
        Client::from_stream(socket.connect(addr).await.expect("connect"))
    }

    fn from_stream(stream: TcpStream) -> Client {
        let (reader, writer) = stream.into_split();
        Client { lines: BufReader::new(reader).lines(), writer }
    }

    pub async fn send_raw(&mut self, line: &str) {
        // One write: a line in two small segments waits for the first one's delayed ack.
        self.writer.write_all(format!("{line}\n").as_bytes()).await.expect("write");
    }

    pub async fn send(&mut self, message: Value) {
        self.send_raw(&message.to_string()).await;
    }

    /// The next message, or `None` when the server closed the connection.
    pub async fn recv(&mut self) -> Option<ServerMessage> {
        let line = tokio::time::timeout(WAIT, self.lines.next_line()).await.expect("a message in time");
        line.ok()
            .flatten()
            .map(|l| decode_server(&l).unwrap_or_else(|e| panic!("bad line from server {l}: {e}")))
    }

    /// Reads until `pick` returns something; panics if the connection ends first or it
    /// takes longer than [`WAIT`] in all.
    pub async fn until<T>(&mut self, mut pick: impl FnMut(&ServerMessage) -> Option<T>) -> T {
        let deadline = tokio::time::Instant::now() + WAIT;
        let mut last = String::new();
        loop {
            let Ok(line) = tokio::time::timeout_at(deadline, self.lines.next_line()).await else {
                panic!("the awaited message did not come in time; the last line was {last}");
            };
            let line = line.ok().flatten().expect("connection open");
            last.clone_from(&line);
            let message = decode_server(&line).unwrap_or_else(|e| panic!("bad line from server {line}: {e}"));
            if let Some(found) = pick(&message) {
                return found;
            }
        }
    }

    /// Reads to the end of the connection, returning everything received.
    /// Closes the sending half as a client that goes away does, and reads until the
    /// server has closed the connection: the server has then seen it go.
    pub async fn leave(mut self) {
        self.writer.shutdown().await.expect("shut the sending half");
        self.drain().await;
    }

    pub async fn drain(&mut self) -> Vec<ServerMessage> {
        let mut all = Vec::new();
        while let Some(m) = self.recv().await {
            all.push(m);
        }
        all
    }

    pub async fn hello(&mut self, name: &str) -> bw4t_protocol::Welcome {
        self.send(json!({"type": "hello", "protocol": "bw4t", "versions": [1], "name": name})).await;
        self.until(|m| match m {
            ServerMessage::Welcome(w) => Some(w.clone()),
            ServerMessage::Error(e) => panic!("hello refused: {e:?}"),
            _ => None,
        })
        .await
    }

    /// The `error` code the next error message carries.
    pub async fn error_code(&mut self) -> String {
        self.until(|m| match m {
            ServerMessage::Error(e) => Some(e.code.to_string()),
            _ => None,
        })
        .await
    }

    pub fn into_parts(self) -> (tokio::io::Lines<BufReader<OwnedReadHalf>>, OwnedWriteHalf) {
        (self.lines, self.writer)
    }
}

/// Plays a well-behaved lockstep player on `good` (welcomed or about to be) to the end of
/// its connection: it goes round four places, one order at a time, and answers every
/// `percepts` with `ready`. Returns every message it got, as JSON, with the volatile
/// fields (`session`, `wall_ms`) zeroed, so two runs can be compared line by line.
pub async fn well_behaved_stream(good: &mut Client) -> Vec<String> {
    let places = ["RoomA1", "RoomC2", "DropZone", "RoomB3"];
    let (mut stream, mut next, mut busy) = (Vec::new(), 0, false);
    let mut session = None;
    while let Some(message) = good.recv().await {
        let mut value = serde_json::to_value(&message).expect("json");
        for field in ["/session", "/result/wall_ms"] {
            if let Some(v) = value.pointer_mut(field) {
                *v = json!(0);
            }
        }
        stream.push(value.to_string());
        let session = match (&message, &mut session) {
            (ServerMessage::Welcome(welcome), None) => session.insert(ClientSession::adopt(welcome.clone())),
            (_, Some(session)) => {
                session.handle_message(message).expect("a message of the protocol");
                session
            }
            (_, None) => continue,
        };
        while let Some(event) = session.poll_event() {
            match event {
                // The tick's `percepts` follows; decide and answer then.
                SessionEvent::Result { .. } => busy = false,
                SessionEvent::Percepts { .. } => {
                    if !busy {
                        busy = true;
                        next += 1;
                        session.act_named("goTo", vec![json!(places[next % places.len()])]);
                    }
                    session.ready();
                }
                _ => {}
            }
        }
        let out: String = std::iter::from_fn(|| session.poll_transmit()).collect();
        if !out.is_empty() {
            good.send_raw(out.trim_end()).await;
        }
    }
    stream
}

/// A percepts message as a simulation delta.
pub fn delta_of(p: &bw4t_protocol::Percepts) -> PerceptDelta {
    bw4t_protocol::percepts_delta(p).expect("percepts of this protocol")
}

/// What an auto-playing client has seen so far.
#[derive(Default)]
pub struct Seen {
    pub knowledge: Knowledge,
    pub heard: Vec<String>,
    pub acks: Vec<bw4t_protocol::Ack>,
    pub results: Vec<bw4t_protocol::ActResult>,
    pub errors: Vec<String>,
    pub tick: u64,
    pub ended: bool,
    /// `lobby` messages, in order.
    pub lobbies: Vec<bw4t_protocol::Lobby>,
    /// Each `pause` heard: paused or resumed.
    pub pauses: Vec<bool>,
}

/// A player that answers every `percepts` with `ready` (in lockstep), so matches move
/// on, while the test sends actions and waits on what the player has seen.
pub struct AutoPlayer {
    pub welcome: bw4t_protocol::Welcome,
    pub seen: Arc<Mutex<Seen>>,
    updates: watch::Receiver<u64>,
    link: Arc<Link>,
    reader: JoinHandle<()>,
}

/// An auto-player's session and the socket it writes to.
struct Link {
    session: Mutex<ClientSession>,
    writer: tokio::sync::Mutex<OwnedWriteHalf>,
}

impl Link {
    /// Writes what the session has to send. The writer is held first, so lines leave in the
    /// order the session queued them whoever flushes.
    async fn flush(&self) -> std::io::Result<()> {
        let mut writer = self.writer.lock().await;
        let out: String = {
            let mut session = self.session.lock().expect("lock");
            std::iter::from_fn(|| session.poll_transmit()).collect()
        };
        writer.write_all(out.as_bytes()).await
    }
}

impl AutoPlayer {
    pub async fn join(addr: SocketAddr, name: &str) -> AutoPlayer {
        AutoPlayer::join_with(addr, json!({"name": name})).await
    }

    /// Joins with the `hello` fields a player chooses (e.g. `{"name": "Bob", "every_tick": true}`).
    pub async fn join_with(addr: SocketAddr, fields: Value) -> AutoPlayer {
        let options: SessionOptions =
            serde_json::from_value(fields.clone()).unwrap_or_else(|e| panic!("hello fields {fields}: {e}"));
        let mut session = ClientSession::new(options);
        let mut client = Client::connect(addr).await;
        let hello: String = std::iter::from_fn(|| session.poll_transmit()).collect();
        client.send_raw(hello.trim_end()).await;
        let welcome = client
            .until(|m| match m {
                ServerMessage::Welcome(w) => Some(w.clone()),
                ServerMessage::Error(e) => panic!("{fields} refused: {e:?}"),
                _ => None,
            })
            .await;
        session.handle_message(ServerMessage::Welcome(welcome.clone())).expect("a welcome");
        // The welcome, which the player keeps as a field.
        session.poll_event();
        AutoPlayer::play(client, session, welcome)
    }

    /// Plays on for a client that has been welcomed.
    pub fn adopt(client: Client, welcome: bw4t_protocol::Welcome) -> AutoPlayer {
        AutoPlayer::play(client, ClientSession::adopt(welcome.clone()), welcome)
    }

    fn play(client: Client, session: ClientSession, welcome: bw4t_protocol::Welcome) -> AutoPlayer {
        let (mut lines, writer) = client.into_parts();
        let link = Arc::new(Link { session: Mutex::new(session), writer: tokio::sync::Mutex::new(writer) });
        let seen = Arc::new(Mutex::new(Seen::default()));
        let (notify, updates) = watch::channel(0u64);
        let (task_seen, task_link) = (seen.clone(), link.clone());
        let reader = tokio::spawn(async move {
            while let Ok(Some(line)) = lines.next_line().await {
                {
                    let mut session = task_link.session.lock().expect("lock");
                    session.handle_line(&line).unwrap_or_else(|e| panic!("{e}"));
                    let mut s = task_seen.lock().expect("lock");
                    while let Some(event) = session.poll_event() {
                        match event {
                            SessionEvent::Percepts { delta, .. } => {
                                s.knowledge.apply(delta.tick, &delta);
                                let heard: Vec<String> = s
                                    .knowledge
                                    .latest_messages()
                                    .iter()
                                    .map(|h| format!("{}:{}", h.from, h.text))
                                    .collect();
                                s.heard.extend(heard);
                                s.tick = delta.tick;
                                session.ready();
                            }
                            // A tick's messages end with its `percepts`: answer that one.
                            SessionEvent::Result { result, .. } => s.results.push(result),
                            SessionEvent::Ack { ack, .. } => s.acks.push(ack),
                            SessionEvent::Error(e) => s.errors.push(e.code.to_string()),
                            SessionEvent::MatchEnd(_) | SessionEvent::Bye(_) => s.ended = true,
                            SessionEvent::Lobby(l) => s.lobbies.push(l),
                            SessionEvent::Pause(p) => s.pauses.push(p.paused),
                            SessionEvent::Welcome(_) => {}
                        }
                    }
                }
                let _ = task_link.flush().await;
                notify.send_modify(|n| *n += 1);
            }
            task_seen.lock().expect("lock").ended = true;
            notify.send_modify(|n| *n += 1);
        });
        AutoPlayer { welcome, seen, updates, link, reader }
    }

    /// Drops the connection without a `bye`, as a crash or a network fault would.
    pub async fn disconnect(self) {
        self.reader.abort();
        let _ = self.reader.await;
        let _ = self.link.writer.lock().await.shutdown().await;
    }

    /// Sends an action by its wire name and arguments; returns its id.
    pub async fn act(&mut self, action: &str, args: Value) -> ActId {
        let args = args.as_array().cloned().unwrap_or_else(|| panic!("arguments as an array: {args}"));
        let id = self.link.session.lock().expect("lock").act_named(action, args);
        self.link.flush().await.expect("write");
        ActId::Number(id)
    }

    pub async fn say(&mut self, to: &str, text: &str) {
        self.link.session.lock().expect("lock").say(to, Some(text.to_string()), None);
        self.link.flush().await.expect("write");
    }

    /// Waits until `check` holds for what the player has seen.
    pub async fn wait<T>(&mut self, what: &str, mut check: impl FnMut(&Seen) -> Option<T>) -> T {
        let seen = self.seen.clone();
        let found = tokio::time::timeout(WAIT, async {
            loop {
                if let Some(found) = check(&seen.lock().expect("lock")) {
                    return found;
                }
                if self.updates.changed().await.is_err() {
                    panic!("connection ended while waiting for {what}");
                }
            }
        })
        .await;
        found.unwrap_or_else(|_| {
            let facts: Vec<String> =
                seen.lock().expect("lock").knowledge.facts().iter().map(|p| p.to_string()).collect();
            panic!("timed out waiting for {what}; facts: {facts:?}")
        })
    }

    /// Waits until the player perceives `fact` (in the spec's notation, e.g. `in(RoomC1)`).
    pub async fn wait_fact(&mut self, fact: &str) {
        self.wait(fact, |s| s.knowledge.facts().iter().any(|p| p.to_string() == fact).then_some(())).await
    }

    /// Waits for the `result` of an action.
    pub async fn wait_result(&mut self, id: &ActId) -> String {
        self.wait("a result", |s| s.results.iter().find(|r| &r.id == id).map(|r| r.outcome.to_string())).await
    }

    /// Waits for the `ack` of an action: `Ok(())` or the rejection code.
    pub async fn wait_ack(&mut self, id: &ActId) -> Result<(), String> {
        self.wait("an ack", |s| {
            s.acks
                .iter()
                .find(|a| a.id.as_ref() == Some(id))
                .map(|a| if a.ok { Ok(()) } else { Err(a.code.map(|c| c.to_string()).unwrap_or_default()) })
        })
        .await
    }

    /// The lowest-id block of `colour` the player sees.
    pub fn block_of(&self, colour: &str) -> Option<u32> {
        let seen = self.seen.lock().expect("lock");
        seen.knowledge.visible().iter().find(|(_, c)| c.name() == colour).map(|(b, _)| *b)
    }
}

/// Runs `bw4t ARGS` from the repository root and returns its output, failing the test if it
/// has not ended within `limit` (the process is then killed).
pub fn bw4t_within(args: &[&str], limit: Duration) -> std::process::Output {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_bw4t"));
    command.args(args).current_dir(repo_root!());
    output_within(command, limit, &format!("bw4t {args:?}"))
}

/// Runs `command` to its end with its output captured, failing the test (and killing the
/// process) if it takes longer than `limit`; `what` names it in the failure.
pub fn output_within(
    mut command: std::process::Command,
    limit: Duration,
    what: &str,
) -> std::process::Output {
    use std::process::Stdio;
    let child = command.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("start");
    let pid = child.id();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(limit) {
        Ok(output) => output.expect("output"),
        Err(_) => {
            let _ = std::process::Command::new("kill").args(["-KILL", &pid.to_string()]).status();
            panic!("{what} did not finish within {limit:?}");
        }
    }
}

/// One HTTP/1.1 request (`Authorization: Bearer` with `token`); returns the status and the
/// body.
pub async fn http(
    addr: SocketAddr,
    method: &str,
    path: &str,
    token: Option<&str>,
    body: Option<&str>,
) -> (u16, String) {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut stream = tokio::net::TcpStream::connect(addr).await.expect("connect");
    let mut request = format!("{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n");
    if let Some(token) = token {
        request += &format!("Authorization: Bearer {token}\r\n");
    }
    let body = body.unwrap_or("");
    request += &format!("Content-Type: text/plain\r\nContent-Length: {}\r\n\r\n{body}", body.len());
    // A server that refuses a body early may close before reading all of it.
    let _ = stream.write_all(request.as_bytes()).await;
    let mut answer = Vec::new();
    let _ = tokio::time::timeout(WAIT, stream.read_to_end(&mut answer)).await.expect("an answer in time");
    let answer = String::from_utf8_lossy(&answer).into_owned();
    let status =
        answer.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap_or_else(|| panic!("a status: {answer}"));
    let body = answer.split_once("\r\n\r\n").map(|(_, b)| b.to_string()).unwrap_or_default();
    (status, body)
}

/// A connection that said `message` and got its `welcome` (a fatal error instead panics).
pub async fn welcomed(addr: SocketAddr, message: Value) -> (Client, bw4t_protocol::Welcome) {
    let mut c = Client::connect(addr).await;
    c.send(message.clone()).await;
    let welcome = c
        .until(|m| match m {
            ServerMessage::Welcome(w) => Some(w.clone()),
            ServerMessage::Error(e) => panic!("{message} refused: {e:?}"),
            _ => None,
        })
        .await;
    (c, welcome)
}
